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
#include "hullgauge/common/log.h"

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

/// `text` as an error message can show it: bytes that are not printable ASCII as \xNN.
std::string printable(const std::string& text)
{
    std::string out;
    for (unsigned char c : text)
        out += c >= 0x20 && c < 0x7f ? std::string(1, static_cast<char>(c)) : fmt::format("\\x{:02x}", c);
    return out;
}

// PLY: CGAL's reader crashes or hangs instead of failing on four kinds of
// header: a `property` line before any `element` line (it files the property
// under the last element declared), a vertex coordinate x, y or z that is not a
// float or double (it reads the coordinate as one or the other), an element
// count that is negative (read as 2^64 - n) or beyond the file (an element
// without properties is then read for ever), and a header without
// `end_header`. The header is read first so such a file is named at its line.
// Every item of an element takes at least a byte, so a count above the file's
// size cannot be right.
void checkPlyHeader(const std::filesystem::path& file, std::uintmax_t size)
{
    std::ifstream in(file, std::ios::binary);
    std::string line;
    std::optional<std::string> element;
    int number = 1;
    // Lines 1 and 2 are the signature and the format, which the reader checks itself.
    for (; std::getline(in, line); ++number) {
        std::istringstream words(line);
        std::string keyword, type, name;
        words >> keyword >> type >> name;
        if (number == 1 && keyword != "ply") return; // not a PLY file: the reader says so
        if (number <= 2) continue;
        if (keyword == "end_header") return;
        if (keyword == "element") {
            element = type;
            std::uintmax_t count = 0;
            const auto [end, error] = std::from_chars(name.data(), name.data() + name.size(), count);
            if (end == name.data() || error != std::errc() || count > size)
                throw InputError(file.string(), "header",
                                 fmt::format("element '{}': count '{}' is not a whole number of at most {} (the "
                                             "file's size in bytes)",
                                             printable(type), printable(name), size),
                                 number);
        }
        if (keyword != "property") continue;
        if (!element)
            throw InputError(file.string(), "header",
                             "'property' before any 'element' (a property belongs to the element declared above it)",
                             number);
        // `property list COUNT_TYPE ITEM_TYPE NAME`: the name is the fifth word, and a list is no coordinate.
        const bool list = type == "list";
        if (list) words >> type >> name;
        const bool coordinate = name == "x" || name == "y" || name == "z";
        const bool real = !list && (type == "float" || type == "float32" || type == "double" || type == "float64");
        if ((*element == "vertex" || *element == "vertices") && coordinate && !real)
            throw InputError(file.string(), "header",
                             fmt::format("vertex coordinate '{}' is {}{} (a coordinate is a float or a double)",
                                         printable(name), list ? "a list of " : "", printable(type)),
                             number);
    }
    // CGAL's reader takes a header that runs to the file's end as complete and
    // then reads the body from nothing: its list counts are never read, and it
    // sizes the lists with them (docs/fuzzing.md).
    throw InputError(file.string(), "header", "no 'end_header' line: the header runs to the end of the file",
                     number - 1);
}

/// Bytes of a PLY scalar type; 0 for a name PLY does not have.
int plyTypeBytes(const std::string& type)
{
    static const std::map<std::string, int> bytes{{"char", 1},  {"int8", 1},    {"uchar", 1},  {"uint8", 1},
                                                  {"short", 2}, {"int16", 2},   {"ushort", 2}, {"uint16", 2},
                                                  {"int", 4},   {"int32", 4},   {"uint", 4},   {"uint32", 4},
                                                  {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
    const auto it = bytes.find(type);
    return it == bytes.end() ? 0 : it->second;
}

struct PlyProperty {
    std::string name;
    std::string countType; ///< a list's; empty for a scalar
    int countBytes = 0;    ///< 0: a scalar
    int itemBytes = 0;
};

struct PlyElement {
    std::string name;
    std::uintmax_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyLayout {
    std::string format;
    std::vector<PlyElement> elements;
};

/// The header's format and elements as CGAL's reader takes them; the stream
/// is left at the body. Nothing when the header is not one this check can
/// follow (the header check and the reader name those).
std::optional<PlyLayout> readPlyLayout(std::istream& in)
{
    PlyLayout layout;
    std::string line;
    // As CGAL's reader: the format on the second line only, any other `format` line ignored.
    for (int number = 1; std::getline(in, line); ++number) {
        std::istringstream words(line);
        std::string keyword, a, b, c, d;
        words >> keyword >> a >> b >> c >> d;
        if (number == 2) layout.format = a;
        if (number <= 2) continue;
        if (keyword == "end_header") return layout.elements.empty() ? std::nullopt : std::optional(layout);
        if (keyword == "element") {
            PlyElement e{a, 0, {}};
            const auto [end, error] = std::from_chars(b.data(), b.data() + b.size(), e.count);
            if (end == b.data() || error != std::errc()) return std::nullopt;
            layout.elements.push_back(std::move(e));
        }
        if (keyword != "property") continue;
        PlyProperty p =
            a == "list" ? PlyProperty{d, b, plyTypeBytes(b), plyTypeBytes(c)} : PlyProperty{b, "", 0, plyTypeBytes(a)};
        if (layout.elements.empty()) return std::nullopt;
        // A type PLY does not have: CGAL's reader leaves the property out of the element, and so does the walk.
        if (p.itemBytes == 0 || (a == "list" && p.countBytes == 0)) continue;
        layout.elements.back().properties.push_back(std::move(p));
    }
    return std::nullopt;
}

/// A binary list count of `p.countType`, signed where the type is; nothing at the file's end.
std::optional<long long> readBinaryCount(std::istream& in, const PlyProperty& p, bool bigEndian)
{
    unsigned char raw[4] = {};
    if (!in.read(reinterpret_cast<char*>(raw), p.countBytes)) return std::nullopt;
    unsigned long long value = 0;
    for (int i = 0; i < p.countBytes; ++i) value = (value << 8) | raw[bigEndian ? i : p.countBytes - 1 - i];
    const bool isSigned = p.countType == "char" || p.countType == "int8" || p.countType == "short" ||
                          p.countType == "int16" || p.countType == "int" || p.countType == "int32";
    const unsigned long long sign = 1ull << (8 * p.countBytes - 1);
    if (isSigned && (value & sign)) return static_cast<long long>(value) - static_cast<long long>(sign << 1);
    return static_cast<long long>(value);
}

/// An ASCII list count; nothing at the file's end or where it is no whole number (the reader names that).
std::optional<long long> readAsciiCount(std::istream& in)
{
    std::string token;
    if (!(in >> token)) return std::nullopt;
    long long value = 0;
    const std::size_t sign = !token.empty() && token[0] == '+' ? 1 : 0; // as `>>` reads it
    const auto [end, error] = std::from_chars(token.data() + sign, token.data() + token.size(), value);
    if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
    return value;
}

// PLY lists: CGAL's reader sizes each list by the count the file gives before
// reading its items, so a count of 543 million in a file of 600 bytes
// allocated 2 GB, a negative one threw std::length_error (docs/fuzzing.md,
// "Findings, fixed"). The body is walked first: every list's items must fit
// in what is left of the file (a byte per item in ASCII, the item's size in
// binary). A file that ends early is left to the reader, which names it.
void checkPlyLists(const std::filesystem::path& file, std::uintmax_t size)
{
    std::ifstream in(file, std::ios::binary);
    const std::optional<PlyLayout> layout = readPlyLayout(in);
    if (!layout) return;
    const bool ascii = layout->format == "ascii", bigEndian = layout->format == "binary_big_endian";
    for (const PlyElement& e : layout->elements) {
        const bool lists = std::any_of(e.properties.begin(), e.properties.end(),
                                       [](const PlyProperty& p) { return p.countBytes > 0; });
        if (!lists && !ascii) {
            std::uintmax_t stride = 0;
            for (const PlyProperty& p : e.properties) stride += static_cast<std::uintmax_t>(p.itemBytes);
            in.seekg(static_cast<std::streamoff>(std::min(e.count * stride, size)), std::ios::cur);
            continue;
        }
        for (std::uintmax_t item = 0; item < e.count; ++item)
            for (const PlyProperty& p : e.properties) {
                std::string token;
                if (p.countBytes == 0) {
                    if (!(ascii ? static_cast<bool>(in >> token) : static_cast<bool>(in.ignore(p.itemBytes)))) return;
                    continue;
                }
                const std::optional<long long> count = ascii ? readAsciiCount(in) : readBinaryCount(in, p, bigEndian);
                // CGAL's reader sizes the list with a count it failed to read, undefined (docs/fuzzing.md).
                if (!count)
                    throw InputError(file.string(), fmt::format("{} {}", printable(e.name), item + 1),
                                     fmt::format("list '{}': no count where one is due (the file ends or holds "
                                                 "something else there)",
                                                 printable(p.name)));
                const std::streamoff at = in.tellg();
                const std::uintmax_t left = at < 0 ? 0 : size - std::min<std::uintmax_t>(size, at);
                const std::uintmax_t least = ascii ? 1 : static_cast<std::uintmax_t>(p.itemBytes);
                if (*count < 0 || static_cast<std::uintmax_t>(*count) > left / least)
                    throw InputError(file.string(), fmt::format("{} {}", printable(e.name), item + 1),
                                     fmt::format("list '{}' holds {} items: {}", printable(p.name), *count,
                                                 *count < 0 ? std::string("a negative number")
                                                            : fmt::format("more than fit in the {} bytes left of "
                                                                          "the file",
                                                                          left)));
                if (!ascii && !in.ignore(static_cast<std::streamsize>(*count) * p.itemBytes)) return;
                for (long long k = 0; ascii && k < *count; ++k)
                    if (!(in >> token)) return;
            }
    }
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
TriangleMesh readSoup(const std::filesystem::path& file)
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
    if (!std::filesystem::is_regular_file(file, ec)) throw InputError(name, "mesh", "no such file");
    const std::uintmax_t size = std::filesystem::file_size(file, ec);
    if (ec) throw InputError(name, "mesh", "cannot read the file: " + ec.message());
    if (size == 0) throw InputError(name, "mesh", "the file is empty");
    if (ext == ".stl") checkStlSize(file, size);
    if (ext == ".ply") {
        checkPlyHeader(file, size);
        checkPlyLists(file, size);
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
    out.mesh = repairMesh(readSoup(file), name, options, out.repair);
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
