// Mesh booleans by CGAL corefinement on an exact kernel (Epeck): the
// intersection curves are computed exactly, so coplanar faces, shared edges
// and touching parts (a cutter flush with a face) come out right.

#include "hullgauge/model/csg.h"

#include <string>

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include "hullgauge/common/error.h"
#include "hullgauge/model/mesh_io.h"

namespace hg::model {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using EK = CGAL::Exact_predicates_exact_constructions_kernel;
using ExactMesh = CGAL::Surface_mesh<EK::Point_3>;

ExactMesh toExact(const TriangleMesh& mesh, const std::string& operation, const char* operand)
{
    const MeshCheck check = checkMesh(mesh);
    if (!check.ok()) throw InputError("", std::string(operation) + " " + operand, check.problem());
    ExactMesh m;
    for (const auto& v : mesh.vertices) m.add_vertex(EK::Point_3(v.x(), v.y(), v.z()));
    for (const auto& t : mesh.triangles)
        m.add_face(ExactMesh::Vertex_index(t[0]), ExactMesh::Vertex_index(t[1]), ExactMesh::Vertex_index(t[2]));
    if (PMP::does_self_intersect(m))
        throw InputError("", std::string(operation) + " " + operand, "the surface intersects itself");
    return m;
}

TriangleMesh fromExact(const ExactMesh& m)
{
    TriangleMesh out;
    std::vector<int> index(m.number_of_vertices() + m.number_of_removed_vertices(), -1);
    for (auto v : m.vertices()) {
        index[v] = static_cast<int>(out.vertices.size());
        const auto& p = m.point(v);
        out.vertices.emplace_back(CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z()));
    }
    for (auto f : m.faces()) {
        auto h = m.halfedge(f);
        out.triangles.push_back({index[m.source(h)], index[m.target(h)], index[m.target(m.next(h))]});
    }
    return out;
}

enum class Op { Difference, Union, Intersection };

TriangleMesh boolean(const TriangleMesh& a, const TriangleMesh& b, Op op)
{
    const std::string name = op == Op::Difference ? "difference" : op == Op::Union ? "union" : "intersection";
    ExactMesh ma = toExact(a, name, "(first operand)");
    ExactMesh mb = toExact(b, name, "(second operand)");
    ExactMesh result;
    bool ok = false;
    switch (op) {
    case Op::Difference:
        ok = PMP::corefine_and_compute_difference(ma, mb, result);
        break;
    case Op::Union:
        ok = PMP::corefine_and_compute_union(ma, mb, result);
        break;
    case Op::Intersection:
        ok = PMP::corefine_and_compute_intersection(ma, mb, result);
        break;
    }
    // Corefinement refuses results that would not be 2-manifold (two
    // operands touching along an edge only, for example).
    if (!ok) throw InputError("", name, "the result would not be a closed 2-manifold (operands touch along an edge?)");
    return fromExact(result);
}

} // namespace

TriangleMesh difference(const TriangleMesh& a, const TriangleMesh& b)
{
    return boolean(a, b, Op::Difference);
}
TriangleMesh difference(const TriangleMesh& a, const std::vector<TriangleMesh>& cutters)
{
    // Exact from the first cut to the last: a result rounded to doubles
    // between two cuts can cross itself by a rounding error.
    ExactMesh m = toExact(a, "difference", "(the part)");
    for (std::size_t i = 0; i < cutters.size(); ++i) {
        ExactMesh cutter = toExact(cutters[i], "difference", ("(cutter " + std::to_string(i + 1) + ")").c_str());
        ExactMesh result;
        if (!PMP::corefine_and_compute_difference(m, cutter, result))
            throw InputError("", "difference",
                             "cutter " + std::to_string(i + 1) +
                                 ": the result would not be a closed 2-manifold (operands touch "
                                 "along an edge?)");
        m = std::move(result);
    }
    return fromExact(m);
}

TriangleMesh unionOf(const TriangleMesh& a, const TriangleMesh& b)
{
    return boolean(a, b, Op::Union);
}
TriangleMesh intersectionOf(const TriangleMesh& a, const TriangleMesh& b)
{
    return boolean(a, b, Op::Intersection);
}

} // namespace hg::model
