// Landmark suggestion (dissertation 6.2 future work 6, 3.3.1; the method is in
// the header, the contract in docs/part-program.md "Suggesting landmarks").
#include "hullgauge/plan/landmark_suggest.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/inspect/deviation.h"
#include "hullgauge/model/step_io.h"
#include "hullgauge/plan/program_plan.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <unordered_map>

namespace hg::plan {

namespace {

using model::TriangleMesh;

constexpr double kPi = std::numbers::pi;
/// A cylinder's normals lie within this angle of the plane square to its axis (radians, 5°).
const double kCylinderNormalSin = std::sin(5.0 * kPi / 180.0);
/// A bore runs at least 300° round its axis: no gap between its vertices' angles above 60°.
constexpr double kCylinderMaxGapRad = 60.0 * kPi / 180.0;
/// Axes tried for openings (openingAxes): a bound on the work for a freeform part.
constexpr std::size_t kOpeningAxes = 64;
/// Triangle centroids tried per face for its deepest point (the largest first).
constexpr std::size_t kFacePointTrials = 256;
/// Radius within which a STEP part's faces are averaged for the normal at a
/// snapped point (mm): one face inside a face, both on an edge.
constexpr double kBRepNormalRadiusMm = 1e-3;

std::size_t kindIndex(FeatureKind kind)
{
    return static_cast<std::size_t>(kind);
}

/// A number with at most `decimals` decimals, trailing zeros dropped ("12.5", "30", "-0.25").
std::string decimal(double v, int decimals)
{
    std::ostringstream s;
    s.precision(decimals);
    s << std::fixed << v;
    std::string out = s.str();
    if (out.find('.') != std::string::npos) {
        while (out.back() == '0') out.pop_back();
        if (out.back() == '.') out.pop_back();
    }
    return out == "-0" ? "0" : out;
}

std::string vecText(const Vec3& v, int decimals = 3)
{
    return "(" + decimal(v.x(), decimals) + ", " + decimal(v.y(), decimals) + ", " + decimal(v.z(), decimals) + ")";
}

std::string yamlVector(const Vec3& v)
{
    return "[" + decimal(v.x(), 6) + ", " + decimal(v.y(), 6) + ", " + decimal(v.z(), 6) + "]";
}

// ---------------------------------------------------------------------------
// Mesh topology: per triangle its normal, area, centroid and the triangle
// across each of its edges (edge k runs from vertex k to vertex k + 1). The
// Solid's mesh is a closed 2-manifold, so every edge has exactly two.

struct Topology {
    std::vector<Vec3> normals;
    std::vector<double> areas;
    std::vector<Vec3> centroids;
    std::vector<std::array<int, 3>> across;
};

std::uint64_t edgeKey(int a, int b)
{
    const auto lo = static_cast<std::uint64_t>(std::min(a, b));
    const auto hi = static_cast<std::uint64_t>(std::max(a, b));
    return (lo << 32) | hi;
}

Topology topologyOf(const TriangleMesh& mesh)
{
    Topology topo;
    const std::size_t n = mesh.triangles.size();
    topo.across.assign(n, {-1, -1, -1});
    std::unordered_map<std::uint64_t, std::pair<int, int>> firstUse; // edge -> (triangle, k)
    for (std::size_t t = 0; t < n; ++t) {
        const auto& tri = mesh.triangles[t];
        const Vec3& a = mesh.vertices[tri[0]];
        const Vec3& b = mesh.vertices[tri[1]];
        const Vec3& c = mesh.vertices[tri[2]];
        topo.normals.push_back(mesh.faceNormal(t));
        topo.areas.push_back(0.5 * (b - a).cross(c - a).norm());
        topo.centroids.push_back((a + b + c) / 3.0);
        for (int k = 0; k < 3; ++k) {
            const auto key = edgeKey(tri[k], tri[(k + 1) % 3]);
            auto [it, fresh] = firstUse.emplace(key, std::make_pair(static_cast<int>(t), k));
            if (fresh) continue;
            topo.across[t][k] = it->second.first;
            topo.across[static_cast<std::size_t>(it->second.first)][static_cast<std::size_t>(it->second.second)] =
                static_cast<int>(t);
        }
    }
    return topo;
}

/// Sharp: both triangles have a normal and the normals differ by more than the sharp angle.
bool sharpEdge(const Topology& topo, std::size_t t, std::size_t u, double cosSharp)
{
    const Vec3& a = topo.normals[t];
    const Vec3& b = topo.normals[u];
    if (a.isZero() || b.isZero()) return false;
    return a.dot(b) < cosSharp;
}

/// Convex: the far vertex of the triangle across edge k of t lies below t's plane.
bool convexEdge(const TriangleMesh& mesh, const Topology& topo, std::size_t t, int k)
{
    const auto u = static_cast<std::size_t>(topo.across[t][static_cast<std::size_t>(k)]);
    const auto& tri = mesh.triangles[t];
    const auto& other = mesh.triangles[u];
    const int a = tri[static_cast<std::size_t>(k)];
    const int b = tri[static_cast<std::size_t>((k + 1) % 3)];
    for (int v : other)
        if (v != a && v != b) return topo.normals[t].dot(mesh.vertices[v] - mesh.vertices[a]) < 0.0;
    return false;
}

/// Connected components of triangles, joined across the edges `join` accepts.
template <class Join> std::vector<int> components(const Topology& topo, Join join)
{
    const std::size_t n = topo.normals.size();
    std::vector<int> label(n, -1);
    int next = 0;
    std::vector<std::size_t> stack;
    for (std::size_t seed = 0; seed < n; ++seed) {
        if (label[seed] >= 0) continue;
        label[seed] = next;
        stack.assign(1, seed);
        while (!stack.empty()) {
            const std::size_t t = stack.back();
            stack.pop_back();
            for (int u : topo.across[t]) {
                if (u < 0 || label[static_cast<std::size_t>(u)] >= 0) continue;
                if (!join(seed, t, static_cast<std::size_t>(u))) continue;
                label[static_cast<std::size_t>(u)] = next;
                stack.push_back(static_cast<std::size_t>(u));
            }
        }
        ++next;
    }
    return label;
}

std::vector<std::vector<std::size_t>> members(const std::vector<int>& label)
{
    std::vector<std::vector<std::size_t>> out;
    for (std::size_t t = 0; t < label.size(); ++t) {
        const auto l = static_cast<std::size_t>(label[t]);
        if (out.size() <= l) out.resize(l + 1);
        out[l].push_back(t);
    }
    return out;
}

// ---------------------------------------------------------------------------
// Cylinders: a smooth patch whose normals are square to one axis and whose
// facets' normal lines meet that axis, at least 300° round it.

struct Cylinder {
    Vec3 axis = Vec3::UnitZ();  ///< unit, its largest component positive
    Vec3 centre = Vec3::Zero(); ///< on the axis, at mid-length
    double radius = 0.0;
    double lengthMm = 0.0;
    bool bore = false; ///< normals point to the axis (a hole), else away (a boss)
};

/// The axis: the direction least along the area-weighted normals (smallest eigenvector of Σ a n nᵀ).
std::optional<Vec3> cylinderAxis(const Topology& topo, const std::vector<std::size_t>& tris)
{
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for (std::size_t t : tris) m += topo.areas[t] * topo.normals[t] * topo.normals[t].transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m);
    Vec3 axis = eig.eigenvectors().col(0).normalized();
    for (std::size_t t : tris)
        if (std::abs(topo.normals[t].dot(axis)) > kCylinderNormalSin) return std::nullopt;
    Eigen::Index largest = 0;
    axis.cwiseAbs().maxCoeff(&largest);
    if (axis[largest] < 0.0) axis = -axis;
    return axis;
}

/// A facet's normal line in the plane square to the axis (2-D): through the
/// middle of the facet's projection — for a facet of a cylinder (a planar
/// strip whose corners lie on the surface) the middle of a chord, whatever
/// vertices a mesher added inside it — along its normal.
struct NormalLine {
    Eigen::Vector2d through;
    Eigen::Vector2d along;
    double weight = 0.0; ///< the facet's area
};

NormalLine normalLine(const TriangleMesh& mesh, const Topology& topo, const std::vector<std::size_t>& facet,
                      const Vec3& u, const Vec3& v)
{
    Vec3 n = Vec3::Zero(), c = Vec3::Zero();
    double area = 0.0;
    for (std::size_t t : facet) {
        n += topo.areas[t] * topo.normals[t];
        c += topo.areas[t] * topo.centroids[t];
        area += topo.areas[t];
    }
    const Eigen::Vector2d m = Eigen::Vector2d(n.dot(u), n.dot(v)).normalized();
    const Eigen::Vector2d chord(-m.y(), m.x());
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t t : facet)
        for (int i : mesh.triangles[t]) {
            const Vec3& p = mesh.vertices[static_cast<std::size_t>(i)];
            const double s = Eigen::Vector2d(p.dot(u), p.dot(v)).dot(chord);
            lo = std::min(lo, s);
            hi = std::max(hi, s);
        }
    const Eigen::Vector2d centroid(c.dot(u) / area, c.dot(v) / area);
    return {centroid.dot(m) * m + 0.5 * (lo + hi) * chord, m, area};
}

/// The axis' point (2-D): the least-squares meeting point of the facets'
/// normal lines, none when they are all parallel (a plane) or do not meet
/// within 1e-3 of the radius (no cylinder: its normals do not point to one
/// axis).
std::optional<Eigen::Vector2d> axisPoint(const std::vector<NormalLine>& lines)
{
    Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const Eigen::Matrix2d across = Eigen::Matrix2d::Identity() - lines[i].along * lines[i].along.transpose();
        a += lines[i].weight * across;
        b += lines[i].weight * across * lines[i].through;
    }
    if (!(std::abs(a.determinant()) > 1e-12 * a.squaredNorm())) return std::nullopt;
    const Eigen::Vector2d c = a.ldlt().solve(b);
    double radius = 0.0;
    for (const auto& l : lines) radius = std::max(radius, (l.through - c).norm());
    for (const auto& l : lines) {
        const Eigen::Vector2d d = c - l.through;
        if ((d - d.dot(l.along) * l.along).norm() > 1e-3 * radius + 1e-6) return std::nullopt;
    }
    return c;
}

/// True when the points' angles about `centre` leave no gap wider than kCylinderMaxGapRad.
bool runsRound(const std::vector<Eigen::Vector2d>& pts, const Eigen::Vector2d& centre)
{
    std::vector<double> angles;
    for (const auto& p : pts) angles.push_back(std::atan2(p.y() - centre.y(), p.x() - centre.x()));
    std::sort(angles.begin(), angles.end());
    double gap = angles.front() + 2.0 * kPi - angles.back();
    for (std::size_t i = 1; i < angles.size(); ++i) gap = std::max(gap, angles[i] - angles[i - 1]);
    return gap <= kCylinderMaxGapRad;
}

/// `tris` is a smooth patch, `planar` the planar region (facet) of every triangle.
std::optional<Cylinder> fitCylinder(const TriangleMesh& mesh, const Topology& topo,
                                    const std::vector<std::size_t>& tris, const std::vector<int>& planar)
{
    const auto axis = cylinderAxis(topo, tris);
    if (!axis) return std::nullopt;
    const Vec3 u = axis->unitOrthogonal();
    const Vec3 v = axis->cross(u);
    std::vector<int> verts;
    for (std::size_t t : tris) verts.insert(verts.end(), mesh.triangles[t].begin(), mesh.triangles[t].end());
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    std::map<int, std::vector<std::size_t>> facets;
    for (std::size_t t : tris) facets[planar[t]].push_back(t);
    std::vector<NormalLine> lines;
    for (const auto& [id, facet] : facets) lines.push_back(normalLine(mesh, topo, facet, u, v));
    const auto centre = axisPoint(lines);
    if (!centre) return std::nullopt;
    const Eigen::Vector2d c = *centre;
    std::vector<Eigen::Vector2d> pts;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, r = 0.0;
    for (int i : verts) {
        const Vec3& p = mesh.vertices[static_cast<std::size_t>(i)];
        pts.emplace_back(p.dot(u), p.dot(v));
        r = std::max(r, (pts.back() - c).norm());
        lo = std::min(lo, p.dot(*axis));
        hi = std::max(hi, p.dot(*axis));
    }
    if (!(r > 0.0) || !runsRound(pts, c)) return std::nullopt;
    Cylinder cyl;
    cyl.axis = *axis;
    cyl.radius = r;
    cyl.lengthMm = hi - lo;
    cyl.centre = c.x() * u + c.y() * v + 0.5 * (lo + hi) * *axis;
    double outward = 0.0;
    for (std::size_t t : tris) {
        const Vec3 d = topo.centroids[t] - cyl.centre;
        outward += topo.areas[t] * topo.normals[t].dot(d - d.dot(*axis) * *axis);
    }
    cyl.bore = outward < 0.0;
    return cyl;
}

std::string cylinderText(const Cylinder& c)
{
    return std::string(c.bore ? "bore" : "cylinder") + " r = " + decimal(c.radius, 3) + " mm about the axis " +
           vecText(c.axis) + " through " + vecText(c.centre);
}

// ---------------------------------------------------------------------------
// Openings: a hole that is not round — a slot, a D-shaped, double-D or
// rectangular hole. Its wall is a ring of triangles square to one axis,
// joined across smooth and re-entrant edges (a slot's ends meet its flats
// smoothly; a D's flat meets its arc in an edge that is re-entrant for the
// material), whose normals all point into the ring, running round the axis.

struct Opening {
    Vec3 axis = Vec3::UnitZ();  ///< unit, its largest component positive
    Vec3 centre = Vec3::Zero(); ///< the wall's area centroid, at mid-length
    Vec3 along = Vec3::UnitX(); ///< the ring's long direction, square to the axis
    double lengthMm = 0.0;      ///< along the axis
    std::string shape;          ///< "slot 20 × 6 mm", "D-shaped hole 10 × 8 mm", ...
    std::vector<std::size_t> wall;
};

/// True when the union of the triangles' angular spans about `centre` leaves
/// no gap wider than kCylinderMaxGapRad (as a bore must run 300° round).
bool ringCloses(const TriangleMesh& mesh, const std::vector<std::size_t>& tris, const Eigen::Vector2d& centre,
                const Vec3& u, const Vec3& v)
{
    std::vector<std::pair<double, double>> spans;
    for (std::size_t t : tris) {
        double first = 0.0, lo = 0.0, hi = 0.0;
        for (std::size_t k = 0; k < 3; ++k) {
            const Vec3& p = mesh.vertices[static_cast<std::size_t>(mesh.triangles[t][k])];
            double a = std::atan2(p.dot(v) - centre.y(), p.dot(u) - centre.x());
            if (k == 0) first = lo = hi = a;
            a = first + std::remainder(a - first, 2.0 * kPi); // unwrapped next to the first vertex
            lo = std::min(lo, a);
            hi = std::max(hi, a);
        }
        if (lo < -kPi) lo += 2.0 * kPi, hi += 2.0 * kPi;
        spans.emplace_back(lo, hi);
        if (hi > kPi) spans.emplace_back(lo - 2.0 * kPi, hi - 2.0 * kPi);
    }
    std::sort(spans.begin(), spans.end());
    double reach = -kPi, gap = 0.0;
    for (const auto& [lo, hi] : spans) {
        if (hi < -kPi) continue;
        gap = std::max(gap, lo - reach);
        reach = std::max(reach, hi);
    }
    return std::max(gap, kPi - reach) <= kCylinderMaxGapRad;
}

/// The opening's shape in words, from its flat walls (planar regions of at
/// least 5 % of the wall's area) and its curved rest: a D has one flat, a
/// slot two parallel flats joined by arcs off the centre, a double-D two flats
/// and arcs about the centre, a rectangular hole four flats.
std::string openingShape(const TriangleMesh& mesh, const Topology& topo, const std::vector<std::size_t>& wall,
                         const std::vector<int>& planar, const Eigen::Vector2d& c, const Vec3& u, const Vec3& v,
                         const Vec3& along)
{
    std::map<int, double> regionArea;
    double area = 0.0;
    for (std::size_t t : wall) {
        regionArea[planar[t]] += topo.areas[t];
        area += topo.areas[t];
    }
    std::size_t flats = 0;
    double curvedMin = std::numeric_limits<double>::infinity(), curvedMax = 0.0;
    double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    double hi[2] = {-lo[0], -lo[1]};
    const Vec3 across = along.cross(u.cross(v)).normalized();
    for (const auto& [region, a] : regionArea) flats += a >= 0.05 * area ? 1 : 0;
    for (std::size_t t : wall)
        for (int i : mesh.triangles[t]) {
            const Vec3& p = mesh.vertices[static_cast<std::size_t>(i)];
            lo[0] = std::min(lo[0], p.dot(along)), hi[0] = std::max(hi[0], p.dot(along));
            lo[1] = std::min(lo[1], p.dot(across)), hi[1] = std::max(hi[1], p.dot(across));
            if (regionArea[planar[t]] >= 0.05 * area) continue;
            const double r = (Eigen::Vector2d(p.dot(u), p.dot(v)) - c).norm();
            curvedMin = std::min(curvedMin, r), curvedMax = std::max(curvedMax, r);
        }
    const bool curved = curvedMax > 0.0;
    const std::string size = " " + decimal(hi[0] - lo[0], 3) + " × " + decimal(hi[1] - lo[1], 3) + " mm";
    if (flats == 1 && curved) return "D-shaped hole" + size;
    if (flats == 2 && curved) return (curvedMax - curvedMin <= 0.02 * curvedMax ? "double-D hole" : "slot") + size;
    if (flats == 4 && !curved) return "rectangular hole" + size;
    return "opening with " + std::to_string(flats) + " flat walls" + size;
}

/// The opening whose wall is `wall` (triangles square to `axis`), if its
/// normals all point into it and it runs round the axis.
std::optional<Opening> fitOpening(const TriangleMesh& mesh, const Topology& topo, const std::vector<std::size_t>& wall,
                                  const std::vector<int>& planar, Vec3 axis)
{
    Eigen::Index largest = 0;
    axis.cwiseAbs().maxCoeff(&largest);
    if (axis[largest] < 0.0) axis = -axis;
    const Vec3 u = axis.unitOrthogonal();
    const Vec3 v = axis.cross(u);
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    double area = 0.0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t t : wall) {
        c += topo.areas[t] * Eigen::Vector2d(topo.centroids[t].dot(u), topo.centroids[t].dot(v));
        area += topo.areas[t];
        for (int i : mesh.triangles[t]) {
            lo = std::min(lo, mesh.vertices[static_cast<std::size_t>(i)].dot(axis));
            hi = std::max(hi, mesh.vertices[static_cast<std::size_t>(i)].dot(axis));
        }
    }
    if (!(area > 0.0)) return std::nullopt;
    c /= area;
    Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
    for (std::size_t t : wall) {
        const Eigen::Vector2d p(topo.centroids[t].dot(u), topo.centroids[t].dot(v));
        const Eigen::Vector2d n(topo.normals[t].dot(u), topo.normals[t].dot(v));
        if (n.dot(c - p) <= 1e-9 * std::sqrt(area)) return std::nullopt; // faces out of the ring
        spread += topo.areas[t] * (p - c) * (p - c).transpose();
    }
    if (!ringCloses(mesh, wall, c, u, v)) return std::nullopt;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(spread);
    const Eigen::Vector2d major = eig.eigenvectors().col(1);
    Opening o;
    o.axis = axis;
    o.centre = c.x() * u + c.y() * v + 0.5 * (lo + hi) * axis;
    o.along = (major.x() * u + major.y() * v).normalized();
    o.lengthMm = hi - lo;
    o.shape = openingShape(mesh, topo, wall, planar, c, u, v, o.along);
    o.wall = wall;
    return o;
}

/// Axes an opening may run along, at most kOpeningAxes, none within 1° of
/// another: those of curved patches that are no cylinder (a slot's, a D's
/// arc), then the fold lines of re-entrant sharp edges (a D's or a
/// rectangular hole's corners).
std::vector<Vec3> openingAxes(const TriangleMesh& mesh, const Topology& topo,
                              const std::vector<std::vector<std::size_t>>& curvedPatches, double cosSharp)
{
    std::vector<Vec3> axes;
    auto add = [&](const Vec3& a) {
        if (axes.size() >= kOpeningAxes) return;
        for (const Vec3& b : axes)
            if (std::abs(a.dot(b)) > std::cos(kPi / 180.0)) return;
        axes.push_back(a);
    };
    for (const auto& patch : curvedPatches)
        if (const auto axis = cylinderAxis(topo, patch)) add(*axis);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const int u = topo.across[t][static_cast<std::size_t>(k)];
            if (u < 0 || static_cast<std::size_t>(u) < t) continue;
            if (!sharpEdge(topo, t, static_cast<std::size_t>(u), cosSharp) || convexEdge(mesh, topo, t, k)) continue;
            add(topo.normals[t].cross(topo.normals[static_cast<std::size_t>(u)]).normalized());
        }
    return axes;
}

/// The openings of the part: for each axis, the rings of triangles square to
/// it (no triangle of a cylinder), joined across every edge but a convex sharp
/// one, that fitOpening takes; a triangle belongs to the first opening found.
std::vector<Opening> findOpenings(const TriangleMesh& mesh, const Topology& topo, const std::vector<int>& planar,
                                  const std::vector<bool>& inCylinder,
                                  const std::vector<std::vector<std::size_t>>& curvedPatches, double cosSharp)
{
    std::vector<Opening> out;
    std::vector<bool> taken = inCylinder;
    for (const Vec3& axis : openingAxes(mesh, topo, curvedPatches, cosSharp)) {
        auto square = [&](std::size_t t) {
            return !taken[t] && !topo.normals[t].isZero() && std::abs(topo.normals[t].dot(axis)) < kCylinderNormalSin;
        };
        const std::vector<int> ring = components(topo, [&](std::size_t, std::size_t t, std::size_t u) {
            if (!square(t) || !square(u)) return false;
            const int k = static_cast<int>(
                std::find(topo.across[t].begin(), topo.across[t].end(), static_cast<int>(u)) - topo.across[t].begin());
            return !sharpEdge(topo, t, u, cosSharp) || !convexEdge(mesh, topo, t, k);
        });
        for (const auto& wall : members(ring)) {
            if (wall.size() < 4 || !square(wall.front())) continue;
            auto o = fitOpening(mesh, topo, wall, planar, axis);
            if (!o) continue;
            for (std::size_t t : wall) taken[t] = true;
            out.push_back(std::move(*o));
        }
    }
    return out;
}

// ---------------------------------------------------------------------------
// Features: every triangle belongs to one — a plane face (a planar region of
// a patch that is not a cylinder), a cylinder (its whole patch), an opening
// (its whole wall), or a curved region of none of these kinds (which gives no
// points of its own).

struct Features {
    std::vector<int> of;                            ///< feature per triangle
    std::vector<std::vector<std::size_t>> members;  ///< triangles per feature
    std::vector<std::optional<Cylinder>> cylinders; ///< per feature
    std::vector<std::optional<Opening>> openings;   ///< per feature
    bool hole(int feature) const
    {
        const auto i = static_cast<std::size_t>(feature);
        return openings[i] || (cylinders[i] && cylinders[i]->bore);
    }
};

Features featuresOf(const TriangleMesh& mesh, const Topology& topo, const CandidateOptions& options)
{
    const double cosSharp = std::cos(options.sharpAngleDeg * kPi / 180.0);
    const double cosPlanar = std::cos(options.planarAngleDeg * kPi / 180.0);
    const std::vector<int> patch =
        components(topo, [&](std::size_t, std::size_t t, std::size_t u) { return !sharpEdge(topo, t, u, cosSharp); });
    const std::vector<int> planar = components(topo, [&](std::size_t seed, std::size_t t, std::size_t u) {
        return patch[t] == patch[u] && topo.normals[seed].dot(topo.normals[u]) >= cosPlanar;
    });
    // A patch of more than one planar region may be a cylinder.
    const auto patches = members(patch);
    std::vector<std::optional<Cylinder>> patchCylinder(patches.size());
    std::vector<std::vector<std::size_t>> curvedPatches;
    std::vector<bool> inCylinder(topo.normals.size(), false);
    for (std::size_t p = 0; p < patches.size(); ++p) {
        const int first = planar[patches[p].front()];
        const bool curved =
            std::any_of(patches[p].begin(), patches[p].end(), [&](std::size_t t) { return planar[t] != first; });
        if (curved) patchCylinder[p] = fitCylinder(mesh, topo, patches[p], planar);
        if (curved && !patchCylinder[p]) curvedPatches.push_back(patches[p]);
        for (std::size_t t : patches[p]) inCylinder[t] = patchCylinder[p].has_value();
    }
    std::vector<Opening> openings = findOpenings(mesh, topo, planar, inCylinder, curvedPatches, cosSharp);
    std::vector<int> openingOf(topo.normals.size(), -1);
    for (std::size_t o = 0; o < openings.size(); ++o)
        for (std::size_t t : openings[o].wall) openingOf[t] = static_cast<int>(o);
    Features f;
    f.of.resize(topo.normals.size());
    // Keyed (0, cylinder patch), (1, opening) or (2, planar region).
    std::map<std::pair<int, int>, int> id;
    for (std::size_t t = 0; t < f.of.size(); ++t) {
        const auto p = static_cast<std::size_t>(patch[t]);
        const auto key = patchCylinder[p]    ? std::make_pair(0, patch[t])
                         : openingOf[t] >= 0 ? std::make_pair(1, openingOf[t])
                                             : std::make_pair(2, planar[t]);
        auto [it, fresh] = id.emplace(key, static_cast<int>(f.members.size()));
        if (fresh) {
            f.members.emplace_back();
            f.cylinders.push_back(patchCylinder[p]);
            f.openings.push_back(key.first == 1 ? std::optional<Opening>(openings[static_cast<std::size_t>(key.second)])
                                                : std::nullopt);
        }
        f.of[t] = it->second;
        f.members[static_cast<std::size_t>(it->second)].push_back(t);
    }
    return f;
}

// ---------------------------------------------------------------------------
// Plane faces: the region's point farthest from its boundary.

double segmentDistance(const Vec3& p, const Vec3& a, const Vec3& b)
{
    const Vec3 e = b - a;
    const double s = e.squaredNorm() > 0.0 ? std::clamp((p - a).dot(e) / e.squaredNorm(), 0.0, 1.0) : 0.0;
    return (a + s * e - p).norm();
}

bool inTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& n)
{
    const double eps = -1e-12 * (b - a).squaredNorm();
    return (b - a).cross(p - a).dot(n) >= eps && (c - b).cross(p - b).dot(n) >= eps &&
           (a - c).cross(p - c).dot(n) >= eps;
}

struct FacePoint {
    Vec3 point = Vec3::Zero();
    double clearanceMm = 0.0;
};

FacePoint deepestPoint(const TriangleMesh& mesh, const Topology& topo, const Features& f, int feature,
                       const Vec3& normal)
{
    const auto& tris = f.members[static_cast<std::size_t>(feature)];
    std::vector<std::pair<Vec3, Vec3>> boundary;
    Vec3 weighted = Vec3::Zero();
    double area = 0.0;
    for (std::size_t t : tris) {
        weighted += topo.areas[t] * topo.centroids[t];
        area += topo.areas[t];
        for (int k = 0; k < 3; ++k) {
            const int u = topo.across[t][static_cast<std::size_t>(k)];
            if (u >= 0 && f.of[static_cast<std::size_t>(u)] == feature) continue;
            const auto& tri = mesh.triangles[t];
            boundary.emplace_back(mesh.vertices[tri[static_cast<std::size_t>(k)]],
                                  mesh.vertices[tri[static_cast<std::size_t>((k + 1) % 3)]]);
        }
    }
    // Trial points: the area centroid when it lies on the face, and the centroids of the largest triangles.
    std::vector<Vec3> trials;
    const Vec3 centroid = area > 0.0 ? Vec3(weighted / area) : topo.centroids[tris.front()];
    for (std::size_t t : tris) {
        const auto& tri = mesh.triangles[t];
        if (inTriangle(centroid, mesh.vertices[tri[0]], mesh.vertices[tri[1]], mesh.vertices[tri[2]], normal)) {
            trials.push_back(centroid);
            break;
        }
    }
    std::vector<std::size_t> bySize = tris;
    std::sort(bySize.begin(), bySize.end(),
              [&](std::size_t a, std::size_t b) { return topo.areas[a] > topo.areas[b]; });
    if (bySize.size() > kFacePointTrials) bySize.resize(kFacePointTrials);
    for (std::size_t t : bySize) trials.push_back(topo.centroids[t]);
    FacePoint best;
    best.clearanceMm = -1.0;
    for (const Vec3& p : trials) {
        double clearance = std::numeric_limits<double>::infinity();
        for (const auto& [a, b] : boundary) clearance = std::min(clearance, segmentDistance(p, a, b));
        if (clearance > best.clearanceMm + 1e-9) best = {p, clearance};
    }
    return best;
}

void addFaces(const TriangleMesh& mesh, const Topology& topo, const Features& f, const CandidateOptions& options,
              std::vector<LandmarkCandidate>& out)
{
    for (std::size_t i = 0; i < f.members.size(); ++i) {
        if (f.cylinders[i] || f.openings[i]) continue;
        Vec3 sum = Vec3::Zero();
        double area = 0.0;
        for (std::size_t t : f.members[i]) {
            sum += topo.areas[t] * topo.normals[t];
            area += topo.areas[t];
        }
        if (sum.norm() < 1e-12) continue;
        const Vec3 normal = sum.normalized();
        // A curved region of no known kind is no plane: its triangles' normals spread.
        const double cosPlanar = std::cos(options.planarAngleDeg * kPi / 180.0);
        if (std::any_of(f.members[i].begin(), f.members[i].end(),
                        [&](std::size_t t) { return topo.normals[t].dot(normal) < cosPlanar; }))
            continue;
        const FacePoint p = deepestPoint(mesh, topo, f, static_cast<int>(i), normal);
        if (p.clearanceMm < options.minClearanceMm) continue;
        out.push_back({FeatureKind::Face, p.point, normal,
                       "plane face, normal " + vecText(normal) + ", " + formatNumber(area, 4) + " mm², this point " +
                           formatNumber(p.clearanceMm, 3) + " mm from its boundary"});
    }
}

/// Four points round a cylinder at mid-length (up, sideways, down, sideways
/// when the axis is not vertical), each the mesh point nearest to the true
/// surface point; the normal is the radial direction (towards the axis in a bore).
void addCylinders(const model::Solid& solid, const Features& f, std::vector<LandmarkCandidate>& out)
{
    for (std::size_t i = 0; i < f.members.size(); ++i) {
        if (!f.cylinders[i]) continue;
        const Cylinder& c = *f.cylinders[i];
        Vec3 up = Vec3::UnitZ() - Vec3::UnitZ().dot(c.axis) * c.axis;
        if (up.norm() < 0.1) up = Vec3::UnitX() - Vec3::UnitX().dot(c.axis) * c.axis;
        up.normalize();
        const Vec3 side = c.axis.cross(up);
        for (const Vec3& d : {up, side, Vec3(-up), Vec3(-side)}) {
            const model::SurfacePoint sp = solid.closestPoint(c.centre + c.radius * d);
            if (f.of[sp.triangle] != static_cast<int>(i)) continue;
            const Vec3 radial = (sp.point - c.centre) - (sp.point - c.centre).dot(c.axis) * c.axis;
            const Vec3 normal = c.bore ? Vec3(-radial.normalized()) : radial.normalized();
            out.push_back({c.bore ? FeatureKind::Hole : FeatureKind::Face, sp.point, normal,
                           cylinderText(c) + ", " + decimal(c.lengthMm, 3) + " mm long: its " +
                               (c.bore ? "wall" : "outside") + " at mid-length"});
        }
    }
}

std::string openingText(const Opening& o)
{
    return o.shape + " through " + vecText(o.centre) + " along " + vecText(o.axis);
}

/// The nearest wall triangle a ray from the opening's centre (square to its
/// axis, at mid-length) meets, and where: Möller–Trumbore against each.
std::optional<std::pair<std::size_t, Vec3>> wallHit(const TriangleMesh& mesh, const Opening& o, const Vec3& d)
{
    std::optional<std::pair<std::size_t, Vec3>> best;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t t : o.wall) {
        const auto& tri = mesh.triangles[t];
        const Vec3& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
        const Vec3 e1 = mesh.vertices[static_cast<std::size_t>(tri[1])] - a;
        const Vec3 e2 = mesh.vertices[static_cast<std::size_t>(tri[2])] - a;
        const Vec3 p = d.cross(e2);
        const double det = e1.dot(p);
        if (std::abs(det) < 1e-15) continue;
        const Vec3 s = o.centre - a;
        const double b1 = s.dot(p) / det;
        const Vec3 q = s.cross(e1);
        const double b2 = d.dot(q) / det;
        const double dist = e2.dot(q) / det;
        const double eps = 1e-9;
        if (b1 < -eps || b2 < -eps || b1 + b2 > 1.0 + eps || dist <= 0.0 || dist >= nearest) continue;
        nearest = dist;
        best = std::make_pair(t, Vec3(o.centre + dist * d));
    }
    return best;
}

/// Four points round an opening's wall at mid-length: where its long
/// direction and the direction across it meet the wall on either side (a
/// slot's ends and the middles of its flats, a D's flat and the arc opposite),
/// the normal that of the wall there, into the opening.
void addOpenings(const TriangleMesh& mesh, const Topology& topo, const Features& f, std::vector<LandmarkCandidate>& out)
{
    for (const auto& opening : f.openings) {
        if (!opening) continue;
        const Opening& o = *opening;
        const Vec3 across = o.axis.cross(o.along).normalized();
        for (const Vec3& d : {o.along, across, Vec3(-o.along), Vec3(-across)}) {
            const auto hit = wallHit(mesh, o, d);
            if (!hit) continue;
            out.push_back({FeatureKind::Hole, hit->second, topo.normals[hit->first],
                           openingText(o) + ", " + decimal(o.lengthMm, 3) + " mm long: its wall at mid-length"});
        }
    }
}

// ---------------------------------------------------------------------------
// Feature lines: convex sharp edges between the same two features, walked
// into polylines.

struct LineEdge {
    int a = 0, b = 0;         ///< vertices
    std::size_t t = 0, u = 0; ///< the two triangles
};

struct Polyline {
    std::vector<Vec3> points;
    std::vector<Vec3> normals; ///< per segment: the bisector of its two triangles' normals
    bool closed = false;
    double apartDeg = 0.0; ///< angle between the two faces' normals at the first segment
    double length() const
    {
        double l = 0.0;
        for (std::size_t i = 1; i < points.size(); ++i) l += (points[i] - points[i - 1]).norm();
        return l;
    }
};

std::map<std::pair<int, int>, std::vector<LineEdge>> sharpConvexEdges(const TriangleMesh& mesh, const Topology& topo,
                                                                      const Features& f, double sharpAngleDeg)
{
    const double cosSharp = std::cos(sharpAngleDeg * kPi / 180.0);
    std::map<std::pair<int, int>, std::vector<LineEdge>> lines;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const int across = topo.across[t][static_cast<std::size_t>(k)];
            if (across < 0 || static_cast<std::size_t>(across) < t) continue; // each edge once
            const auto u = static_cast<std::size_t>(across);
            if (!sharpEdge(topo, t, u, cosSharp) || !convexEdge(mesh, topo, t, k)) continue;
            const auto key = std::minmax(f.of[t], f.of[u]);
            const auto& tri = mesh.triangles[t];
            lines[{key.first, key.second}].push_back(
                {tri[static_cast<std::size_t>(k)], tri[static_cast<std::size_t>((k + 1) % 3)], t, u});
        }
    return lines;
}

/// The polylines of one feature pair's edges: each walk starts at a line end
/// (a vertex with one unused edge) or, for a loop, at its highest vertex.
std::vector<Polyline> walkLines(const TriangleMesh& mesh, const Topology& topo, const std::vector<LineEdge>& edges)
{
    std::multimap<int, std::size_t> at;
    for (std::size_t e = 0; e < edges.size(); ++e) {
        at.emplace(edges[e].a, e);
        at.emplace(edges[e].b, e);
    }
    std::vector<bool> used(edges.size(), false);
    auto unusedAt = [&](int v) {
        std::vector<std::size_t> out;
        for (auto [it, end] = at.equal_range(v); it != end; ++it)
            if (!used[it->second]) out.push_back(it->second);
        return out;
    };
    auto higher = [&](int a, int b) {
        const Vec3& p = mesh.vertices[static_cast<std::size_t>(a)];
        const Vec3& q = mesh.vertices[static_cast<std::size_t>(b)];
        return std::tie(p.z(), p.x(), p.y()) > std::tie(q.z(), q.x(), q.y());
    };
    std::vector<Polyline> out;
    for (;;) {
        std::optional<int> start;
        for (const auto& [v, e] : at) {
            if (used[e]) continue;
            if (unusedAt(v).size() == 1) {
                start = v;
                break;
            }
            if (!start || higher(v, *start)) start = v;
        }
        if (!start) break;
        Polyline line;
        int v = *start;
        line.points.push_back(mesh.vertices[static_cast<std::size_t>(v)]);
        for (auto next = unusedAt(v); !next.empty(); next = unusedAt(v)) {
            const LineEdge& e = edges[next.front()];
            used[next.front()] = true;
            v = e.a == v ? e.b : e.a;
            line.points.push_back(mesh.vertices[static_cast<std::size_t>(v)]);
            line.normals.push_back((topo.normals[e.t] + topo.normals[e.u]).normalized());
            if (line.normals.size() == 1)
                line.apartDeg =
                    std::acos(std::clamp(topo.normals[e.t].dot(topo.normals[e.u]), -1.0, 1.0)) * 180.0 / kPi;
        }
        line.closed = v == *start;
        out.push_back(std::move(line));
    }
    return out;
}

/// The point at arc length `s` along the line, and its segment's normal; at a
/// vertex between two segments the mean of theirs (as the loader's
/// angle-weighted normal has it there, docs/part-program.md "Normals from the
/// mesh").
std::pair<Vec3, Vec3> pointAlong(const Polyline& line, double s)
{
    const std::size_t segments = line.normals.size();
    for (std::size_t i = 0; i < segments; ++i) {
        const Vec3& a = line.points[i];
        const Vec3& b = line.points[i + 1];
        const double l = (b - a).norm();
        if (s > l && i + 1 < segments) {
            s -= l;
            continue;
        }
        const double tol = 1e-9 * std::max(1.0, l);
        const bool atEnd = s >= l - tol && (i + 1 < segments || line.closed);
        const bool atStart = s <= tol && (i > 0 || line.closed);
        if (atEnd) return {b, (line.normals[i] + line.normals[(i + 1) % segments]).normalized()};
        if (atStart) return {a, (line.normals[i] + line.normals[(i + segments - 1) % segments]).normalized()};
        return {a + std::clamp(s / l, 0.0, 1.0) * (b - a), line.normals[i]};
    }
    return {line.points.front(), line.normals.front()};
}

std::string lineText(const Features& f, const std::pair<int, int>& pair, const Polyline& line)
{
    for (int feature : {pair.first, pair.second}) {
        const auto i = static_cast<std::size_t>(feature);
        if (!f.hole(feature)) continue;
        return "rim of the " + (f.openings[i] ? openingText(*f.openings[i]) : cylinderText(*f.cylinders[i])) + ", " +
               decimal(line.length(), 3) + " mm round: one of 4 points a quarter round apart";
    }
    return "convex edge, the faces' normals " + decimal(line.apartDeg, 1) + "° apart, " + decimal(line.length(), 3) +
           " mm " + (line.closed ? "round: one of 4 points a quarter round apart" : "long: its midpoint");
}

void addLines(const TriangleMesh& mesh, const Topology& topo, const Features& f, const CandidateOptions& options,
              std::vector<LandmarkCandidate>& out)
{
    for (const auto& [pair, edges] : sharpConvexEdges(mesh, topo, f, options.sharpAngleDeg)) {
        const bool hole = f.hole(pair.first) || f.hole(pair.second);
        for (const Polyline& line : walkLines(mesh, topo, edges)) {
            const double length = line.length();
            if (length < 2.0 * options.minClearanceMm) continue;
            const std::vector<double> at =
                line.closed ? std::vector<double>{0.0, 0.25, 0.5, 0.75} : std::vector<double>{0.5};
            for (double share : at) {
                const auto [p, n] = pointAlong(line, share * length);
                out.push_back({hole ? FeatureKind::Hole : FeatureKind::Edge, p, n, lineText(f, pair, line)});
            }
        }
    }
}

} // namespace

std::vector<LandmarkCandidate> findCandidates(const model::Solid& solid, const CandidateOptions& options)
{
    const TriangleMesh& mesh = solid.mesh();
    const Topology topo = topologyOf(mesh);
    const Features features = featuresOf(mesh, topo, options);
    std::vector<LandmarkCandidate> out;
    addFaces(mesh, topo, features, options, out);
    addCylinders(solid, features, out);
    addOpenings(mesh, topo, features, out);
    addLines(mesh, topo, features, options, out);
    // On the mesh itself, whatever the rounding of the constructions above.
    for (auto& c : out) c.position = solid.closestPoint(c.position).point;
    return out;
}

std::vector<SpreadPick> spreadSelect(const std::vector<Vec3>& points, const std::vector<FeatureKind>& kinds,
                                     std::size_t count, const std::array<std::size_t, kFeatureKinds>& minimum)
{
    if (kinds.size() != points.size())
        throw ArgumentError("spreadSelect: kinds: one kind per point, found " + std::to_string(kinds.size()) +
                            " kinds for " + std::to_string(points.size()) + " points");
    const std::size_t n = points.size();
    count = std::min(count, n);
    std::array<std::size_t, kFeatureKinds> available{}, need{}, chosen{};
    for (FeatureKind k : kinds) ++available[kindIndex(k)];
    for (std::size_t k = 0; k < kFeatureKinds; ++k) need[k] = std::min(minimum[k], available[k]);
    Vec3 centroid = Vec3::Zero();
    for (const Vec3& p : points) centroid += p / static_cast<double>(n);

    std::vector<double> gap(n, std::numeric_limits<double>::infinity());
    std::vector<std::optional<std::size_t>> nearest(n);
    std::vector<bool> taken(n, false);
    std::vector<SpreadPick> picks;
    while (picks.size() < count) {
        std::size_t unmet = 0;
        for (std::size_t k = 0; k < kFeatureKinds; ++k) unmet += need[k] - std::min(need[k], chosen[k]);
        const bool restrict = unmet > 0 && unmet >= count - picks.size();
        auto score = [&](std::size_t i) { return picks.empty() ? (points[i] - centroid).norm() : gap[i]; };
        auto farthest = [&](bool restricted) {
            std::optional<std::size_t> best;
            for (std::size_t i = 0; i < n; ++i) {
                if (taken[i] || (restricted && chosen[kindIndex(kinds[i])] >= need[kindIndex(kinds[i])])) continue;
                if (!best || score(i) > score(*best) + 1e-9) best = i;
            }
            return *best;
        };
        const std::size_t pick = farthest(restrict);
        picks.push_back({pick, score(pick), nearest[pick], restrict && farthest(false) != pick});
        taken[pick] = true;
        ++chosen[kindIndex(kinds[pick])];
        for (std::size_t i = 0; i < n; ++i) {
            const double d = (points[i] - points[pick]).norm();
            if (d < gap[i]) {
                gap[i] = d;
                nearest[i] = pick;
            }
        }
    }
    return picks;
}

namespace {

/// Moves each candidate onto a STEP part's exact surface, with the B-rep's
/// normal there (docs/part-program.md, "STEP parts").
void snapToBRep(std::vector<LandmarkCandidate>& candidates, const model::StepModel& brep)
{
    for (auto& c : candidates) {
        const model::BRepPoint exact = brep.closestPoint(c.position, kBRepNormalRadiusMm);
        c.position = exact.point;
        if (exact.normal.norm() > 0.5) c.normal = exact.normal.normalized();
    }
}

/// The candidates as `hullgauge plan` takes landmarks: with the sub-voxel
/// deviation (the default) a tolerance below ΔV is planned at ΔV.
PlanProblem planProblem(const SuggestProblem& problem, const SuggestOptions& options,
                        const std::vector<LandmarkCandidate>& candidates)
{
    PlanProblem plan;
    plan.part = "suggestion";
    plan.solid = problem.solid.get();
    plan.station = problem.station;
    plan.frame = problem.frame;
    const double tolerance = std::max(options.toleranceMm, problem.frame.voxelSize());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        PlanLandmark lm;
        lm.id = "candidate-" + std::to_string(i + 1);
        lm.position = candidates[i].position;
        lm.normal = candidates[i].normal;
        lm.toleranceMm = tolerance;
        if (options.toleranceMm < tolerance) lm.drawingToleranceMm = options.toleranceMm;
        plan.landmarks.push_back(lm);
    }
    return plan;
}

/// The verdict is all a candidate needs: no nearest inspectable point for a
/// rejected one, no type-four visibility report (3.3.8; `hullgauge plan`
/// makes it for the landmarks chosen).
PlanOptions verdictOptions(const SuggestOptions& options)
{
    PlanOptions planOptions = options.plan;
    planOptions.nearestSearchLimit = 0;
    planOptions.reportUnseenVoids = false;
    return planOptions;
}

/// The planner's verdict on every candidate (chapter 2, Rules 1-4).
std::vector<LandmarkAnalysis> judge(const SuggestProblem& problem, const SuggestOptions& options,
                                    const std::vector<LandmarkCandidate>& candidates)
{
    if (candidates.empty()) return {};
    return analyseLandmarks(planProblem(problem, options, candidates), verdictOptions(options));
}

/// The chosen landmarks planned as `hullgauge plan` plans them, then the
/// capability check at the planned views over the nest's play (zone ≥ 4 U at
/// every seat, seen on its outline at every seat: program_plan.h
/// capabilityOverPlay), then the caller's screen: `refused` holds every
/// landmark (index into chosen) `plan` or the screen would refuse, with the rule.
struct PlanCheck {
    ViewPlan plan;
    std::vector<Refusal> refused;
};

std::vector<inspect::LandmarkCapability> capabilityOfChosen(const SuggestProblem& problem,
                                                            const SuggestOptions& options,
                                                            const std::vector<LandmarkCandidate>& chosen,
                                                            const ViewPlan& plan)
{
    const inspect::DeviationGauge gauge(problem.solid, problem.station->calibration);
    PlayProblem play{&problem.solid->mesh(), {}, problem.frame.voxelSize(), &gauge, options.alignment};
    for (std::size_t i = 0; i < chosen.size(); ++i)
        play.landmarks.push_back(
            {"candidate-" + std::to_string(i + 1), chosen[i].position, chosen[i].normal, options.toleranceMm});
    std::vector<geometry::FixturePose> poses;
    for (const PlannedView& v : plan.views) poses.push_back(v.pose);
    return capabilityOverPlay(play, *problem.station, poses);
}

PlanCheck planChosen(const SuggestProblem& problem, const SuggestOptions& options,
                     const std::vector<LandmarkCandidate>& chosen)
{
    PlanCheck check;
    if (chosen.empty()) return check;
    check.plan = planViews(planProblem(problem, options, chosen), verdictOptions(options));
    std::vector<bool> observed(chosen.size(), false);
    for (const PlannedView& v : check.plan.views)
        for (std::size_t l : v.landmarks) observed[l] = true;
    for (std::size_t i = 0; i < chosen.size(); ++i) {
        const LandmarkAnalysis& a = check.plan.landmarks[i];
        if (!a.inspectable())
            check.refused.push_back({i, std::string(enumName(a.verdict)), a.reason});
        else if (!observed[i])
            check.refused.push_back({i, "not_observed", "observed by no view planned with the others"});
    }
    if (!check.plan.feasible || !check.refused.empty()) return check;
    const auto capability = capabilityOfChosen(problem, options, chosen, check.plan);
    for (std::size_t i = 0; i < chosen.size(); ++i)
        if (!capability[i].capable)
            check.refused.push_back(
                {i, "capability", inspect::describe(capability[i]) + ", at the worst seat of the nest's play"});
    if (check.refused.empty() && options.screen) check.refused = options.screen(chosen, check.plan, capability);
    return check;
}

/// The spread and the plan of the landmarks it chose.
struct Spread {
    std::vector<std::size_t> usable; ///< candidates (indices into all) the spread chose from
    std::vector<SpreadPick> picks;   ///< indices into usable
    ViewPlan plan;                   ///< of the picks, in their order
    /// Candidates inspectable alone that `plan` or the screen refused with the others.
    std::vector<RefusedCandidate> refused;
};

/// Farthest-point selection among the usable candidates, then planned as the
/// part program will hold them: the planner's candidate poses depend on the
/// other landmarks (a face square to the turntable axis adds its grazing
/// declination for all of them, planner.h), and so does the capability check
/// on the views planned for them all. A pick `plan` or the screen would
/// refuse is left out and the spread made again, until every pick passes.
Spread spreadVerified(const SuggestProblem& problem, const SuggestOptions& options,
                      const std::vector<LandmarkCandidate>& all, std::vector<std::size_t> usable,
                      const std::array<std::size_t, kFeatureKinds>& minimum)
{
    std::vector<RefusedCandidate> refusedSoFar;
    for (;;) {
        std::vector<Vec3> points;
        std::vector<FeatureKind> kinds;
        for (std::size_t i : usable) {
            points.push_back(all[i].position);
            kinds.push_back(all[i].kind);
        }
        Spread s{usable, spreadSelect(points, kinds, options.count, minimum), {}, refusedSoFar};
        std::vector<LandmarkCandidate> chosen;
        for (const SpreadPick& p : s.picks) chosen.push_back(all[usable[p.index]]);
        PlanCheck check = planChosen(problem, options, chosen);
        s.plan = std::move(check.plan);
        if (check.refused.empty()) return s;
        std::vector<std::size_t> refused;
        for (const Refusal& r : check.refused) {
            const std::size_t i = usable[s.picks[r.index].index];
            refused.push_back(i);
            refusedSoFar.push_back({all[i], r.rule, "planned with the others: " + r.why});
            log::category("plan")->info("candidate {} ({} at {}) left out: planned with the others, {}: {}", i + 1,
                                        enumName(all[i].kind), vecText(all[i].position), r.rule, r.why);
        }
        std::erase_if(usable,
                      [&](std::size_t i) { return std::find(refused.begin(), refused.end(), i) != refused.end(); });
    }
}

std::string reasonFor(const SpreadPick& pick, const std::vector<std::string>& idOf, FeatureKind kind,
                      std::size_t minimumOfKind, std::size_t count)
{
    if (!pick.nearest)
        return "the spread starts here: the candidate farthest from the candidates' centroid (" +
               formatNumber(pick.distanceMm, 3) + " mm)";
    const std::string from = formatNumber(pick.distanceMm, 3) + " mm from " + idOf[*pick.nearest];
    if (pick.forMinimumShare)
        return "the " + std::string(enumName(kind)) + " farthest from the earlier suggestions (at least " +
               std::to_string(minimumOfKind) + " of " + std::to_string(count) + " on " + std::string(enumName(kind)) +
               "s): " + from;
    return "farthest from the earlier suggestions: " + from;
}

void addNotes(Suggestion& s, std::size_t asked, std::size_t inspectable)
{
    if (inspectable < asked)
        s.notes.push_back("asked for " + std::to_string(asked) + " landmarks, but only " + std::to_string(inspectable) +
                          " of the " + std::to_string(s.candidates[0] + s.candidates[1] + s.candidates[2]) +
                          " candidates pass `hullgauge plan` at this station (weak convexity, Rules 1-4, the "
                          "capability check over the nest's play): " +
                          std::to_string(s.landmarks.size()) + " suggested");
    for (FeatureKind k : {FeatureKind::Face, FeatureKind::Edge, FeatureKind::Hole})
        if (s.candidates[kindIndex(k)] > 0 && s.inspectable[kindIndex(k)] == 0)
            s.notes.push_back(std::string("none of the ") + std::to_string(s.candidates[kindIndex(k)]) + " " +
                              std::string(enumName(k)) +
                              " candidates is inspectable at this station (weak convexity, Rules 1-4: "
                              "docs/planning.md)");
    for (FeatureKind k : {FeatureKind::Face, FeatureKind::Edge, FeatureKind::Hole}) {
        const bool suggested = std::any_of(s.landmarks.begin(), s.landmarks.end(),
                                           [&](const SuggestedLandmark& l) { return l.candidate.kind == k; });
        std::map<std::string, std::size_t> byRule;
        for (const RefusedCandidate& r : s.refused)
            if (r.candidate.kind == k && r.why.starts_with("planned with the others")) ++byRule[r.rule];
        if (suggested || byRule.empty()) continue;
        std::string rules;
        for (const auto& [rule, n] : byRule) rules += (rules.empty() ? "" : ", ") + std::to_string(n) + " " + rule;
        s.notes.push_back("no " + std::string(enumName(k)) + " is suggested: the " +
                          std::to_string(s.inspectable[kindIndex(k)]) + " inspectable " + std::string(enumName(k)) +
                          " candidates tried with the others were refused (" + rules + ")");
    }
}

} // namespace

Suggestion suggestLandmarks(const SuggestProblem& problem, const SuggestOptions& options)
{
    if (!problem.solid || !problem.station)
        throw ArgumentError(std::string("suggestLandmarks: solid and station needed, found ") +
                            (problem.solid ? "a solid" : "no solid") + " and " +
                            (problem.station ? "a station" : "no station"));
    CandidateOptions candidateOptions = options.candidates;
    // A face point's voxel and its neighbour stay on the face: two voxels from its boundary.
    candidateOptions.minClearanceMm = std::max(candidateOptions.minClearanceMm, 2.0 * problem.frame.voxelSize());
    std::vector<LandmarkCandidate> all = findCandidates(*problem.solid, candidateOptions);
    if (problem.brep) snapToBRep(all, *problem.brep);
    const auto verdicts = judge(problem, options, all);

    Suggestion s;
    std::vector<std::size_t> usable; // indices into all
    for (std::size_t i = 0; i < all.size(); ++i) {
        ++s.candidates[kindIndex(all[i].kind)];
        if (!verdicts[i].inspectable()) {
            log::category("plan")->debug("candidate {} ({} at {}) left out: {}", i + 1, enumName(all[i].kind),
                                         vecText(all[i].position), verdicts[i].reason);
            s.refused.push_back({all[i], std::string(enumName(verdicts[i].verdict)), verdicts[i].reason});
            continue;
        }
        ++s.inspectable[kindIndex(all[i].kind)];
        usable.push_back(i);
    }
    log::category("plan")->info("landmark suggestion: {} candidates ({} face, {} edge, {} hole), {} inspectable",
                                all.size(), s.candidates[0], s.candidates[1], s.candidates[2], usable.size());
    auto share = [&](double fraction) { return static_cast<std::size_t>(std::ceil(fraction * options.count - 1e-9)); };
    std::array<std::size_t, kFeatureKinds> minimum{};
    minimum[kindIndex(FeatureKind::Face)] = share(options.minFaceShare);
    minimum[kindIndex(FeatureKind::Edge)] = share(options.minEdgeShare);
    minimum[kindIndex(FeatureKind::Hole)] = share(options.minHoleShare);

    const Spread spread = spreadVerified(problem, options, all, usable, minimum);
    std::vector<std::string> idOf(spread.usable.size());
    std::array<std::size_t, kFeatureKinds> numbered{};
    for (std::size_t k = 0; k < spread.picks.size(); ++k) {
        const SpreadPick& pick = spread.picks[k];
        const LandmarkCandidate& c = all[spread.usable[pick.index]];
        SuggestedLandmark lm;
        lm.candidate = c;
        lm.id = std::string(enumName(c.kind)) + "-" + std::to_string(++numbered[kindIndex(c.kind)]);
        idOf[pick.index] = lm.id;
        lm.reason = reasonFor(pick, idOf, c.kind, minimum[kindIndex(c.kind)], options.count);
        lm.witnessPoses = spread.plan.landmarks[k].witnessPoses.size();
        lm.bestMedMm = spread.plan.landmarks[k].bestMedMm;
        s.landmarks.push_back(std::move(lm));
    }
    s.plannedViews = spread.plan.views.size();
    s.refused.insert(s.refused.end(), spread.refused.begin(), spread.refused.end());
    addNotes(s, options.count, spread.usable.size());
    return s;
}

SuggestProblem suggestProblem(const model::CadModel& cad, const geometry::Station& station)
{
    SuggestProblem problem;
    problem.solid = cad.solid;
    problem.brep = cad.brep.get();
    problem.station = &station;
    problem.frame = {cad.octree.cubeOrigin, cad.octree.cubeSize, cad.octree.depth};
    return problem;
}

LandmarkCandidate asWritten(const LandmarkCandidate& candidate)
{
    // decimal(v, 6) prints v to 6 decimals and the loader reads the decimal
    // back as the double nearest to it: n / 10⁶ correctly rounded, as here.
    auto written = [](const Vec3& v) { return Vec3((v * 1e6).array().round().matrix() / 1e6); };
    LandmarkCandidate c = candidate;
    c.position = written(candidate.position);
    c.normal = written(candidate.normal).normalized();
    return c;
}

std::string refusedSummary(const Suggestion& suggestion)
{
    std::map<std::string, std::size_t> byRule;
    for (const RefusedCandidate& r : suggestion.refused) ++byRule[r.rule];
    std::string out;
    for (const auto& [rule, n] : byRule) out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + rule;
    return out.empty() ? "none" : out;
}

std::string refusedMarkdown(const Suggestion& suggestion)
{
    std::ostringstream out;
    out << "| # | kind | position (mm) | feature | rule | why |\n|---|---|---|---|---|---|\n";
    std::size_t n = 0;
    for (const RefusedCandidate& r : suggestion.refused)
        out << "| " << ++n << " | " << enumName(r.candidate.kind) << " | " << vecText(r.candidate.position) << " | "
            << r.candidate.feature << " | " << r.rule << " | " << r.why << " |\n";
    return out.str();
}

std::string landmarksYaml(const Suggestion& suggestion, double toleranceMm, const std::vector<std::string>& header)
{
    std::ostringstream out;
    for (const std::string& line : header) out << "# " << line << '\n';
    for (const std::string& note : suggestion.notes) out << "# Note: " << note << ".\n";
    out << "landmarks:\n";
    for (const SuggestedLandmark& lm : suggestion.landmarks) {
        const LandmarkCandidate& c = lm.candidate;
        out << "  # " << enumName(c.kind) << ": " << c.feature << ".\n";
        out << "  #   chosen: " << lm.reason << "; seen against background from " << lm.witnessPoses
            << " reachable poses, finest MED " << formatNumber(lm.bestMedMm, 3) << " mm.\n";
        out << "  - {id: " << lm.id << ", position: " << yamlVector(c.position) << ", normal: " << yamlVector(c.normal)
            << ", tolerance_mm: " << formatNumber(toleranceMm, 6) << "}\n";
    }
    return out.str();
}

} // namespace hg::plan
