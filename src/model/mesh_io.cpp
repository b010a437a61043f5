// Mesh import and export through CGAL's readers; the repair of what the
// files hold is mesh_repair.cpp (docs/part-program.md, "Meshes as they come").

#include "hullgauge/model/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>
#include <unordered_map>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Polygon_2_algorithms.h>
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/Projection_traits_3.h>
#include <CGAL/Surface_mesh.h>
#include <cmath>
#include <spdlog/fmt/fmt.h>

#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "hullgauge/common/log.h"
#include "mesh_limits.h"
#include "ply_check.h"

namespace hg::model {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Polygon = std::vector<std::size_t>;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

std::string str(const Eigen::Vector3d& p)
{
    return fmt::format("({:.4f}, {:.4f}, {:.4f})", p.x(), p.y(), p.z());
}

std::string lowerExtension(const std::filesystem::path& file)
{
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

// Edge and vertex analysis of an indexed polygon soup (triangles or larger
// polygons), shared by checkMesh and the loader so both name problems alike.
MeshCheck analyse(const std::vector<Eigen::Vector3d>& points, const std::vector<Polygon>& polygons)
{
    MeshCheck check;
    check.vertices = points.size();
    check.triangles = polygons.size();

    struct EdgeUse {
        int forward = 0;  // traversed from the smaller to the larger index
        int backward = 0; // traversed the other way
    };
    std::unordered_map<std::uint64_t, EdgeUse> edges;
    edges.reserve(polygons.size() * 2);
    auto key = [](std::size_t a, std::size_t b) { return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b); };
    // Per vertex: (polygon, neighbouring vertex) pairs for the fan test.
    std::vector<std::vector<std::pair<std::size_t, std::size_t>>> incidence(points.size());

    for (std::size_t p = 0; p < polygons.size(); ++p) {
        const Polygon& poly = polygons[p];
        const std::size_t n = poly.size();
        if (n < 3 || std::any_of(poly.begin(), poly.end(), [&](std::size_t v) { return v >= points.size(); })) {
            ++check.badIndices;
            continue;
        }
        // Vector area: zero for a degenerate polygon.
        Eigen::Vector3d area = Eigen::Vector3d::Zero();
        for (std::size_t k = 0; k < n; ++k) area += points[poly[k]].cross(points[poly[(k + 1) % n]]);
        if (area.squaredNorm() == 0.0) ++check.degenerateTriangles;
        // Signed volume of the cone from the origin (divergence theorem), fan-triangulated.
        for (std::size_t k = 1; k + 1 < n; ++k)
            check.signedVolume += points[poly[0]].dot(points[poly[k]].cross(points[poly[k + 1]])) / 6.0;
        for (std::size_t k = 0; k < n; ++k) {
            std::size_t a = poly[k], b = poly[(k + 1) % n];
            auto& use = edges[key(a, b)];
            (a < b ? use.forward : use.backward)++;
            incidence[a].emplace_back(p, b);
            incidence[b].emplace_back(p, a);
        }
    }

    for (const auto& [k, use] : edges) {
        const std::array<Eigen::Vector3d, 2> coords{points[k >> 32], points[k & 0xffffffffu]};
        const int count = use.forward + use.backward;
        if (count == 1) {
            if (!check.firstOpenEdge) check.firstOpenEdge = coords;
            ++check.openEdges;
        } else if (count > 2) {
            if (!check.firstNonManifoldEdge) check.firstNonManifoldEdge = coords;
            ++check.nonManifoldEdges;
        } else if (use.forward == 2 || use.backward == 2) {
            if (!check.firstInconsistentEdge) check.firstInconsistentEdge = coords;
            ++check.inconsistentEdges;
        }
    }

    // A manifold vertex has one fan: its polygons are connected through the
    // edges at the vertex. Two fans mean two sheets touch at a point.
    for (std::size_t v = 0; v < points.size(); ++v) {
        auto& inc = incidence[v];
        if (inc.size() < 6) continue; // a single polygon pair cannot form two closed fans
        std::vector<std::size_t> polys;
        for (auto& [p, w] : inc) polys.push_back(p);
        std::sort(polys.begin(), polys.end());
        polys.erase(std::unique(polys.begin(), polys.end()), polys.end());
        std::vector<std::size_t> parent(polys.size());
        std::iota(parent.begin(), parent.end(), 0);
        auto find = [&](std::size_t i) {
            while (parent[i] != i) i = parent[i] = parent[parent[i]];
            return i;
        };
        auto local = [&](std::size_t p) {
            return static_cast<std::size_t>(std::lower_bound(polys.begin(), polys.end(), p) - polys.begin());
        };
        std::sort(inc.begin(), inc.end(), [](auto& x, auto& y) { return x.second < y.second; });
        for (std::size_t i = 1; i < inc.size(); ++i)
            if (inc[i].second == inc[i - 1].second) parent[find(local(inc[i].first))] = find(local(inc[i - 1].first));
        std::size_t fans = 0;
        for (std::size_t i = 0; i < polys.size(); ++i) fans += find(i) == i;
        if (fans > 1) {
            if (!check.firstNonManifoldVertex) check.firstNonManifoldVertex = points[v];
            ++check.nonManifoldVertices;
        }
    }
    return check;
}

std::string describeEdge(const std::array<Eigen::Vector3d, 2>& e)
{
    return "from " + str(e[0]) + " to " + str(e[1]);
}

std::vector<Polygon> toPolygons(const TriangleMesh& mesh)
{
    std::vector<Polygon> polys;
    polys.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles)
        polys.push_back(
            {static_cast<std::size_t>(t[0]), static_cast<std::size_t>(t[1]), static_cast<std::size_t>(t[2])});
    return polys;
}

// Binary STL: an 80-byte header, a uint32 facet count, then 50 bytes per
// facet. CGAL's reader stops silently at a short file, so the size is checked
// against the count first; this names the facet where the file breaks off.
void checkStlSize(const std::filesystem::path& file, std::uintmax_t size)
{
    std::ifstream in(file, std::ios::binary);
    std::string head(std::min<std::uintmax_t>(size, 84), '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    const std::string name = file.string();
    std::uint64_t announced = 0;
    if (head.size() == 84) {
        for (int i = 3; i >= 0; --i) announced = (announced << 8) | static_cast<unsigned char>(head[80 + i]);
        if (84 + 50 * announced == size) return; // a well-formed binary STL
    }
    // Not a binary STL of the announced size: ASCII when it starts with "solid".
    auto first = head.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && head.compare(first, 5, "solid") == 0) return;
    if (head.size() < 84)
        throw InputError(name, "header",
                         fmt::format("file ends after {} of 84 bytes (80-byte header and facet count)", size));
    const std::uintmax_t body = size - 84;
    if (body > 50 * announced) {
        log::category("model")->warn("{}: {} bytes after the {} facets the header announces are ignored", name,
                                     body - 50 * announced, announced);
        return;
    }
    const std::uintmax_t complete = body / 50, rest = body % 50;
    if (rest != 0)
        throw InputError(
            name, fmt::format("facet {}", complete + 1),
            fmt::format("file ends after {} of 50 bytes (the header announces {} facets)", rest, announced));
    throw InputError(name, fmt::format("facet {}", complete + 1),
                     fmt::format("file ends after {} of the {} facets the header announces", complete, announced));
}

} // namespace

std::string MeshCheck::problem() const
{
    if (triangles == 0) return "the mesh has no triangles";
    if (badIndices) return fmt::format("{} polygons with fewer than 3 or out-of-range vertex indices", badIndices);
    if (openEdges)
        return fmt::format("not closed: {} open edge{} (a hole), the first {}", openEdges, openEdges > 1 ? "s" : "",
                           describeEdge(*firstOpenEdge));
    if (nonManifoldEdges)
        return fmt::format("not a 2-manifold: {} edge{} shared by more than two triangles, the first {}",
                           nonManifoldEdges, nonManifoldEdges > 1 ? "s" : "", describeEdge(*firstNonManifoldEdge));
    if (nonManifoldVertices)
        return fmt::format("not a 2-manifold: {} vertex{} where separate sheets touch, the first at {}",
                           nonManifoldVertices, nonManifoldVertices > 1 ? "es" : "", str(*firstNonManifoldVertex));
    if (inconsistentEdges)
        return fmt::format("inconsistent orientation: {} edge{} whose two triangles run the same way, the first {}",
                           inconsistentEdges, inconsistentEdges > 1 ? "s" : "", describeEdge(*firstInconsistentEdge));
    if (signedVolume < 0.0) return fmt::format("inverted orientation (signed volume {:.6g} mm³)", signedVolume);
    if (signedVolume == 0.0) return "the mesh encloses no volume";
    return {};
}

MeshCheck checkMesh(const TriangleMesh& mesh)
{
    return analyse(mesh.vertices, toPolygons(mesh));
}

void requireSolidMesh(TriangleMesh& mesh, const std::string& name)
{
    MeshCheck check = checkMesh(mesh);
    if (check.inverted()) {
        // Only the orientation is wrong: every normal points inward. Flipping
        // is the unique fix, so it is applied rather than refused.
        log::category("model")->warn("{}: mesh is oriented inward (signed volume {:.6g} mm³); flipped", name,
                                     check.signedVolume);
        mesh.flip();
        return;
    }
    if (!check.ok()) throw InputError(name, "mesh", check.problem());
    if (check.degenerateTriangles)
        log::category("model")->warn("{}: {} degenerate (zero-area) triangles", name, check.degenerateTriangles);
}

namespace {

/// The polygon's corners without consecutive repeats (a corner written twice).
std::vector<std::size_t> distinctCorners(const Polygon& polygon)
{
    std::vector<std::size_t> out;
    for (std::size_t v : polygon)
        if (out.empty() || out.back() != v) out.push_back(v);
    while (out.size() > 1 && out.front() == out.back()) out.pop_back();
    return out;
}

/// Whether CGAL's triangulation may be given the polygon: no two corners on
/// one point and a normal (Newell's) of non-zero length, i.e. not all corners
/// on one line. Its preconditions are checked only in debug builds.
bool triangulable(const std::vector<Point>& points, const std::vector<std::size_t>& corners)
{
    std::set<std::tuple<double, double, double>> seen;
    double nx = 0.0, ny = 0.0, nz = 0.0, longest = 0.0;
    for (std::size_t k = 0; k < corners.size(); ++k) {
        const Point& a = points[corners[k]];
        const Point& b = points[corners[(k + 1) % corners.size()]];
        if (!seen.emplace(a.x(), a.y(), a.z()).second) return false;
        longest = std::max(longest, CGAL::squared_distance(a, b));
        nx += (a.y() - b.y()) * (a.z() + b.z());
        ny += (a.z() - b.z()) * (a.x() + b.x());
        nz += (a.x() - b.x()) * (a.y() + b.y());
    }
    const double n = std::sqrt(nx * nx + ny * ny + nz * nz);
    // Twice the polygon's area against its longest side squared: rounding, not area, below 1e-12.
    return std::isfinite(n) && std::isfinite(longest) && n > 1e-12 * longest;
}

/// Whether the polygon face is simple seen along its normal, as CGAL's
/// triangulation projects it. A polygon that is not planar and whose
/// projection crosses itself made that triangulation dereference a null face
/// (docs/fuzzing.md, "Findings, fixed"); a crossing polygon has no inside to
/// triangulate anyway and is fanned like the other failures.
bool simpleAlongItsNormal(const SurfaceMesh& sm, SurfaceMesh::Face_index f)
{
    const Kernel::Vector_3 normal = PMP::compute_face_normal(f, sm);
    std::vector<Point> corners;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) corners.push_back(sm.point(v));
    return CGAL::is_simple_2(corners.begin(), corners.end(), CGAL::Projection_traits_3<Kernel>(normal));
}

/// CGAL's triangulation of a polygon face; false where it fails, as it does on
/// a polygon whose distinct corners lie on one point or one line (a
/// precondition of its constrained triangulation, thrown as an exception).
bool triangulatedWithoutFailure(SurfaceMesh& sm)
{
    try {
        return PMP::triangulate_faces(sm);
    } catch (const CGAL::Failure_exception&) {
        return false;
    }
}

// OBJ, PLY and OFF may hold polygons: each is triangulated on its own
// (CGAL's triangulation of a face, a fan where that fails), so the repair
// sees triangles only. A polygon of fewer than three corners stays a
// degenerate triangle for the repair to count.
void appendTriangles(const std::vector<Point>& points, const Polygon& polygon, TriangleMesh& soup)
{
    const std::vector<std::size_t> corners = distinctCorners(polygon);
    auto add = [&](std::size_t a, std::size_t b, std::size_t c) {
        soup.triangles.push_back({static_cast<int>(a), static_cast<int>(b), static_cast<int>(c)});
    };
    if (corners.size() < 3) return add(polygon[0], polygon[0], polygon[polygon.size() - 1]);
    if (corners.size() == 3) return add(corners[0], corners[1], corners[2]);
    if (!triangulable(points, corners)) {
        for (std::size_t k = 1; k + 1 < corners.size(); ++k) add(corners[0], corners[k], corners[k + 1]);
        return;
    }
    SurfaceMesh sm;
    std::vector<SurfaceMesh::Vertex_index> face;
    for (std::size_t v : corners) face.push_back(sm.add_vertex(points[v]));
    const SurfaceMesh::Face_index whole = sm.add_face(face);
    if (whole != SurfaceMesh::null_face() && simpleAlongItsNormal(sm, whole) && triangulatedWithoutFailure(sm)) {
        for (auto f : sm.faces()) {
            auto h = sm.halfedge(f);
            add(corners[sm.source(h)], corners[sm.target(h)], corners[sm.target(sm.next(h))]);
        }
        return;
    }
    for (std::size_t k = 1; k + 1 < corners.size(); ++k) add(corners[0], corners[k], corners[k + 1]);
}

/// CGAL's reader of the four formats. It sizes a PLY list by the count the
/// file gives before reading the items: a negative count in a signed count
/// type (`property list char int ...`) throws std::length_error, a count far
/// beyond the file std::bad_alloc — bad input either way (docs/fuzzing.md,
/// "Findings, fixed").
void readPolygonSoup(const std::filesystem::path& file, const std::string& ext, std::vector<Point>& points,
                     std::vector<Polygon>& polygons)
{
    const std::string name = file.string();
    bool read = false;
    try {
        read = CGAL::IO::read_polygon_soup(name, points, polygons, CGAL::parameters::verbose(false));
    } catch (const std::length_error&) {
        throw InputError(name, "mesh", "a list's length is negative or beyond what memory holds");
    } catch (const std::bad_alloc&) {
        throw InputError(name, "mesh", "a list's length is beyond what memory holds");
    }
    if (!read) throw InputError(name, "mesh", "not a readable " + ext.substr(1) + " file");
}

/// The file's facets as a triangle soup, points written more than once (STL
/// stores each vertex once per facet) merged.
TriangleMesh readSoup(const std::filesystem::path& file, const MeshRepairOptions& limits)
{
    const std::string name = file.string();
    const std::string ext = lowerExtension(file);
    if (ext == ".step" || ext == ".stp")
        throw InputError(name, "mesh",
                         "a STEP file is read as a part program's mesh only (docs/part-program.md); here export the "
                         "part as STL, OBJ or PLY");
    if (ext != ".stl" && ext != ".obj" && ext != ".ply" && ext != ".off")
        throw InputError(name, "mesh", "unknown mesh format '" + ext + "' (expected .stl, .obj, .ply or .off)");
    std::error_code ec;
    if (auto problem = notARegularFile(file); !problem.empty()) throw InputError(name, "mesh", problem);
    const std::uintmax_t size = std::filesystem::file_size(file, ec);
    if (ec) throw InputError(name, "mesh", "cannot read the file: " + ec.message());
    if (size == 0) throw InputError(name, "mesh", "the file is empty");
    detail::checkAnnouncedSize(file, ext, size, limits);
    if (ext == ".stl") checkStlSize(file, size);
    if (ext == ".ply") {
        detail::checkPly(file, size);
    }

    std::vector<Point> points;
    std::vector<Polygon> polygons;
    readPolygonSoup(file, ext, points, polygons);
    if (polygons.empty()) throw InputError(name, "mesh", "the file holds no facets");
    // The soup repair below indexes the points without checking: an index past
    // them (a PLY face naming vertex 1e6 of 8) or a non-finite coordinate is bad input.
    for (std::size_t f = 0; f < polygons.size(); ++f) {
        if (polygons[f].empty()) throw InputError(name, fmt::format("face {}", f + 1), "the face has no vertices");
        for (auto v : polygons[f])
            if (v >= points.size())
                throw InputError(name, fmt::format("face {}", f + 1),
                                 fmt::format("vertex index {} is past the file's {} vertices", v, points.size()));
    }
    for (std::size_t i = 0; i < points.size(); ++i)
        if (!std::isfinite(points[i].x()) || !std::isfinite(points[i].y()) || !std::isfinite(points[i].z()))
            throw InputError(name, fmt::format("vertex {}", i + 1), "coordinate is not a finite number");
    if (points.size() > std::size_t(std::numeric_limits<int>::max()))
        throw InputError(name, "mesh", fmt::format("{} vertices are more than a mesh may hold", points.size()));

    PMP::merge_duplicate_points_in_polygon_soup(points, polygons);
    TriangleMesh soup;
    soup.vertices.reserve(points.size());
    for (const auto& p : points) soup.vertices.emplace_back(p.x(), p.y(), p.z());
    for (const Polygon& polygon : polygons) appendTriangles(points, polygon, soup);
    return soup;
}

} // namespace

ImportedMesh importMesh(const std::filesystem::path& file, const MeshRepairOptions& options)
{
    const std::string name = file.string();
    ImportedMesh out;
    out.mesh = repairMesh(readSoup(file, options), name, options, out.repair);
    if (options.mode == MeshRepairMode::Strict && !out.repair.clean())
        throw InputError(name, "mesh", "needs repair (mesh_repair: strict): " + out.repair.defects());
    if (!out.repair.clean()) log::category("model")->warn("{}: mesh repaired: {}", name, out.repair.repairs());
    requireSolidMesh(out.mesh, name);
    log::category("model")->debug("{}: {} vertices, {} triangles, volume {:.6g} mm³", name, out.mesh.vertices.size(),
                                  out.mesh.triangles.size(), out.mesh.signedVolume());
    return out;
}

TriangleMesh loadMesh(const std::filesystem::path& file)
{
    return importMesh(file).mesh;
}

void saveMesh(const TriangleMesh& mesh, const std::filesystem::path& file, MeshEncoding encoding)
{
    const std::string ext = lowerExtension(file);
    if (ext != ".stl" && ext != ".obj" && ext != ".ply" && ext != ".off")
        throw FaultError(file.string() + ": cannot write meshes with extension '" + ext + "'");
    std::vector<Point> points;
    points.reserve(mesh.vertices.size());
    for (const auto& v : mesh.vertices) points.emplace_back(v.x(), v.y(), v.z());
    std::vector<Polygon> polygons = toPolygons(mesh);
    if (!CGAL::IO::write_polygon_soup(
            file.string(), points, polygons,
            CGAL::parameters::use_binary_mode(encoding == MeshEncoding::Binary).stream_precision(17)))
        throw FaultError(file.string() + ": cannot write the mesh");
}

} // namespace hg::model
