// Exact queries on the CAD solid with a CGAL AABB tree (dissertation 5.3.3:
// the representation map, evaluated lazily per voxel instead of as an array).

#include "hullgauge/model/solid.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "inside_volume.h"

namespace hg::model {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
using Side = CGAL::Side_of_triangle_mesh<SurfaceMesh, K, CGAL::Default, Tree>;
using EK = CGAL::Exact_predicates_exact_constructions_kernel;

Point toPoint(const Eigen::Vector3d& v)
{
    return {v.x(), v.y(), v.z()};
}
Eigen::Vector3d toEigen(const Point& p)
{
    return {p.x(), p.y(), p.z()};
}
K::Iso_cuboid_3 toCuboid(const Eigen::AlignedBox3d& b)
{
    return {toPoint(b.min()), toPoint(b.max())};
}

} // namespace

struct Solid::Impl {
    TriangleMesh mesh;
    SurfaceMesh surface;
    Tree tree;
    std::unique_ptr<Side> side;
    double scale = 1.0; // largest bounding-box edge, for relative tolerances

    std::size_t faceIndex(SurfaceMesh::Face_index f) const { return static_cast<std::size_t>(f); }

    K::Triangle_3 triangle(std::size_t i) const
    {
        const auto& t = mesh.triangles[i];
        return {toPoint(mesh.vertices[t[0]]), toPoint(mesh.vertices[t[1]]), toPoint(mesh.vertices[t[2]])};
    }

    template <class Query> std::vector<std::size_t> trianglesMeeting(const Query& query) const
    {
        std::vector<SurfaceMesh::Face_index> faces;
        tree.all_intersected_primitives(query, std::back_inserter(faces));
        std::vector<std::size_t> ids;
        ids.reserve(faces.size());
        for (auto f : faces) ids.push_back(faceIndex(f));
        return ids;
    }

    // Exact: does the closed triangle meet the open box? The intersection
    // with the closed box is a convex set K ⊂ B; K meets the interior of B
    // iff its centroid does (a convex set whose relative-interior point lies
    // on a supporting plane of B lies in that plane).
    bool meetsInterior(std::size_t i, const Eigen::AlignedBox3d& box) const
    {
        const auto& t = mesh.triangles[i];
        auto ep = [&](int k) {
            const auto& v = mesh.vertices[t[k]];
            return EK::Point_3(v.x(), v.y(), v.z());
        };
        const EK::Triangle_3 tri(ep(0), ep(1), ep(2));
        const EK::Iso_cuboid_3 cube(EK::Point_3(box.min().x(), box.min().y(), box.min().z()),
                                    EK::Point_3(box.max().x(), box.max().y(), box.max().z()));
        if (tri.is_degenerate()) return false; // zero-area triangles bound nothing
        const auto result = CGAL::intersection(tri, cube);
        if (!result) return false;
        EK::Point_3 centre;
        if (const auto* p = boost::get<EK::Point_3>(&*result))
            centre = *p;
        else if (const auto* s = boost::get<EK::Segment_3>(&*result))
            centre = CGAL::midpoint(s->source(), s->target());
        else if (const auto* tr = boost::get<EK::Triangle_3>(&*result))
            centre = CGAL::centroid(tr->vertex(0), tr->vertex(1), tr->vertex(2));
        else if (const auto* poly = boost::get<std::vector<EK::Point_3>>(&*result)) {
            EK::Vector_3 sum = CGAL::NULL_VECTOR;
            for (const auto& q : *poly) sum = sum + (q - CGAL::ORIGIN);
            centre = CGAL::ORIGIN + sum / static_cast<int>(poly->size());
        } else
            return true; // unknown shape: be conservative (Boundary)
        return cube.bounded_side(centre) == CGAL::ON_BOUNDED_SIDE;
    }
};

Solid::Solid(TriangleMesh mesh) : impl_(std::make_unique<Impl>())
{
    if (mesh.empty()) throw ArgumentError("Solid: mesh: has no triangles");
    impl_->mesh = std::move(mesh);
    auto& sm = impl_->surface;
    for (const auto& v : impl_->mesh.vertices) sm.add_vertex(toPoint(v));
    for (std::size_t i = 0; i < impl_->mesh.triangles.size(); ++i) {
        const auto& t = impl_->mesh.triangles[i];
        auto f = sm.add_face(SurfaceMesh::Vertex_index(t[0]), SurfaceMesh::Vertex_index(t[1]),
                             SurfaceMesh::Vertex_index(t[2]));
        // Face i must be triangle i; add_face refuses non-manifold input.
        if (f == SurfaceMesh::null_face() || static_cast<std::size_t>(f) != i)
            throw ArgumentError("Solid: mesh: not a closed, oriented 2-manifold at triangle " + std::to_string(i) +
                                " (see checkMesh)");
    }
    impl_->tree.insert(faces(sm).first, faces(sm).second, sm);
    // Build the tree and the distance-query search structure now: both are
    // otherwise built lazily on first use, which is not meant for concurrent
    // const callers.
    impl_->tree.build();
    impl_->tree.accelerate_distance_queries();
    impl_->side = std::make_unique<Side>(impl_->tree);
    const auto b = impl_->mesh.bounds();
    impl_->scale = std::max((b.max() - b.min()).maxCoeff(), 1e-9);
}

Solid::~Solid() = default;
Solid::Solid(Solid&&) noexcept = default;
Solid& Solid::operator=(Solid&&) noexcept = default;

const TriangleMesh& Solid::mesh() const
{
    return impl_->mesh;
}

bool Solid::contains(const Eigen::Vector3d& point) const
{
    return (*impl_->side)(toPoint(point)) != CGAL::ON_UNBOUNDED_SIDE;
}

Occupancy Solid::classify(const Eigen::AlignedBox3d& box) const
{
    // Classification of the open box (its interior): a voxel that only
    // touches the surface with a face, edge or corner is Inside or Outside.
    for (std::size_t i : impl_->trianglesMeeting(toCuboid(box)))
        if (impl_->meetsInterior(i, box)) return Occupancy::Boundary;
    // The surface misses the interior, so the centre decides for all of it
    // (and lies off the surface).
    return (*impl_->side)(toPoint(box.center())) == CGAL::ON_BOUNDED_SIDE ? Occupancy::Inside : Occupancy::Outside;
}

InsideFraction Solid::insideFraction(const Eigen::AlignedBox3d& box, double /*tolerance*/, bool /*decideHalf*/) const
{
    // The fraction is computed in closed form (inside_volume.cpp), so the
    // bracket is only as wide as the floating-point error bound, far below
    // any tolerance a caller can ask for.
    InsideFraction f;
    const double boxVolume = box.volume();
    if (!(boxVolume > 0.0))
        throw ArgumentError("Solid::insideFraction: box: empty (volume " + formatNumber(boxVolume) + ")");
    const Eigen::Vector3d lo = box.min(), hi = box.max();
    // Triangles meeting the box, or the corner line {x = hi.x, y = hi.y, z <= hi.z}.
    const double below = std::min(lo.z(), impl_->mesh.bounds().min().z()) - 1.0;
    // The closed form is exact for any superset of the triangles that meet
    // the box and the corner line. The queries are padded far beyond
    // rounding (1e-9 of the coordinates) so that a triangle whose rounded
    // cross-section point lands on the corner line is never left out: its
    // crossing must meet the opposite crossing of its neighbour to cancel.
    const double pad = 1e-9 * (impl_->scale + std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff()));
    const Eigen::Vector3d padding = Eigen::Vector3d::Constant(pad);
    auto candidates = impl_->trianglesMeeting(toCuboid(Eigen::AlignedBox3d(lo - padding, hi + padding)));
    if (candidates.empty()) {
        const bool inside = (*impl_->side)(toPoint(box.center())) == CGAL::ON_BOUNDED_SIDE;
        f.lower = f.upper = f.estimate = inside ? 1.0 : 0.0;
        return f;
    }
    auto line = impl_->trianglesMeeting(
        K::Iso_cuboid_3(Point(hi.x() - pad, hi.y() - pad, below), Point(hi.x() + pad, hi.y() + pad, hi.z() + pad)));
    candidates.insert(candidates.end(), line.begin(), line.end());
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
    const auto v = detail::insideVolume(impl_->mesh.vertices, impl_->mesh.triangles, candidates, box);
    const double value = v.volume / boxVolume, err = v.errorBound / boxVolume;
    f.estimate = std::clamp(value, 0.0, 1.0);
    f.lower = std::clamp(value - err, 0.0, 1.0);
    f.upper = std::clamp(value + err, 0.0, 1.0);
    return f;
}

bool Solid::isObjectVoxel(const Eigen::AlignedBox3d& box) const
{
    // 5.3.3/5.3.4: object when at least half of the voxel is inside. A
    // fraction within rounding of exactly one half counts as object.
    return insideFraction(box).upper >= 0.5;
}

SurfacePoint Solid::closestPoint(const Eigen::Vector3d& point) const
{
    const auto [p, face] = impl_->tree.closest_point_and_primitive(toPoint(point));
    SurfacePoint s;
    s.point = toEigen(p);
    s.triangle = impl_->faceIndex(face);
    s.normal = impl_->mesh.faceNormal(s.triangle);
    s.distance = (s.point - point).norm();
    return s;
}

Eigen::Vector3d Solid::surfaceNormal(const Eigen::Vector3d& surfacePoint, double radius) const
{
    // Angle-weighted pseudo-normal (Bærentzen and Aanæs 2005) of the
    // triangles within `radius`: the face normal inside a face, the bisector
    // of the two faces on an edge, the angle-weighted mean at a vertex.
    const Eigen::Vector3d r = Eigen::Vector3d::Constant(radius);
    auto ids = impl_->trianglesMeeting(toCuboid(Eigen::AlignedBox3d(surfacePoint - r, surfacePoint + r)));
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t i : ids) {
        const K::Triangle_3 tri = impl_->triangle(i);
        if (tri.is_degenerate()) continue;
        if (std::sqrt(CGAL::to_double(CGAL::squared_distance(tri, toPoint(surfacePoint)))) > radius) continue;
        const auto& t = impl_->mesh.triangles[i];
        double angle = 2.0 * std::numbers::pi; // interior of the face
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d& a = impl_->mesh.vertices[t[k]];
            const Eigen::Vector3d& b = impl_->mesh.vertices[t[(k + 1) % 3]];
            const Eigen::Vector3d& c = impl_->mesh.vertices[t[(k + 2) % 3]];
            if ((a - surfacePoint).norm() <= radius) { // at a corner: its interior angle
                angle = std::acos(std::clamp((b - a).normalized().dot((c - a).normalized()), -1.0, 1.0));
                break;
            }
            const Eigen::Vector3d e = b - a;
            const double s = std::clamp((surfacePoint - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
            if ((a + s * e - surfacePoint).norm() <= radius) angle = std::numbers::pi; // on an edge
        }
        sum += angle * impl_->mesh.faceNormal(i);
    }
    if (sum.norm() == 0.0) return closestPoint(surfacePoint).normal;
    return sum.normalized();
}

std::optional<RayHit> Solid::firstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const
{
    const double len = direction.norm();
    if (!(len > 0.0)) throw ArgumentError("Solid::firstHit: direction: zero vector (length " + formatNumber(len) + ")");
    const Eigen::Vector3d d = direction / len;
    const K::Ray_3 ray(toPoint(origin), K::Vector_3(d.x(), d.y(), d.z()));
    using Hit = Tree::Intersection_and_primitive_id<K::Ray_3>::Type;
    std::optional<RayHit> best;
    // Fast path: CGAL's nearest-first traversal. A ray that starts on the
    // surface gets its own start point back (s = 0, not a hit): then every
    // intersection is listed and the nearest one beyond the start is kept.
    if (const auto first = impl_->tree.first_intersection(ray)) {
        const auto& [object, face] = *first;
        if (const auto* p = boost::get<Point>(&object)) {
            const Eigen::Vector3d q = toEigen(*p);
            const double s = (q - origin).dot(d);
            if (s > 0.0) return RayHit{s, q, impl_->faceIndex(face)};
        }
    } else {
        return std::nullopt;
    }
    std::vector<Hit> hits;
    impl_->tree.all_intersections(ray, std::back_inserter(hits));
    auto consider = [&](const Point& p, std::size_t tri) {
        const Eigen::Vector3d q = toEigen(p);
        const double s = (q - origin).dot(d);
        if (!(s > 0.0)) return; // the ray starts on the surface: s = 0 is not a hit
        if (!best || s < best->distance) best = RayHit{s, q, tri};
    };
    for (const auto& [object, face] : hits) {
        const std::size_t tri = impl_->faceIndex(face);
        if (const auto* p = boost::get<Point>(&object))
            consider(*p, tri);
        else if (const auto* s = boost::get<K::Segment_3>(&object)) { // ray in the triangle's plane
            consider(s->source(), tri);
            consider(s->target(), tri);
        }
    }
    return best;
}

bool Solid::segmentHits(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const
{
    const Point pa = toPoint(a), pb = toPoint(b);
    if (pa == pb) return false;
    const K::Segment_3 segment(pa, pb);
    std::vector<SurfaceMesh::Face_index> faces;
    impl_->tree.all_intersected_primitives(segment, std::back_inserter(faces));
    // Exact predicates: a triangle met only at an endpoint (a landmark on the
    // surface, a camera centre on it) does not count. A segment lying in a
    // triangle's plane and touching it grazes the surface and counts.
    for (auto f : faces) {
        const K::Triangle_3 tri = impl_->triangle(impl_->faceIndex(f));
        const auto oa = CGAL::orientation(tri[0], tri[1], tri[2], pa);
        const auto ob = CGAL::orientation(tri[0], tri[1], tri[2], pb);
        if (oa == CGAL::COPLANAR && ob == CGAL::COPLANAR) return true;
        if (oa == CGAL::COPLANAR && tri.has_on(pa)) continue; // met at a only
        if (ob == CGAL::COPLANAR && tri.has_on(pb)) continue; // met at b only
        return true;
    }
    return false;
}

} // namespace hg::model
