// Reading and writing CAD meshes, and the closedness check every part mesh
// must pass before it becomes a Solid (dissertation 3.5.1: the ideal object
// must be an exact, closed description to label the inspection map).
//
// Units are millimetres in the part frame; files carry no unit, so a mesh
// exported in metres or inches must be rescaled before use.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

#include "hullgauge/model/mesh.h"
#include "hullgauge/model/mesh_repair.h"

namespace hg::model {

/// What checkMesh found. Edges are undirected vertex pairs; coordinates of
/// the first offending edge or vertex locate the problem in the CAD model.
struct MeshCheck {
    std::size_t vertices = 0;
    std::size_t triangles = 0;
    /// Edges used by exactly one triangle (holes in the surface).
    std::size_t openEdges = 0;
    std::optional<std::array<Eigen::Vector3d, 2>> firstOpenEdge;
    /// Edges shared by more than two triangles.
    std::size_t nonManifoldEdges = 0;
    std::optional<std::array<Eigen::Vector3d, 2>> firstNonManifoldEdge;
    /// Vertices whose triangles form more than one fan (two solids touching at a point).
    std::size_t nonManifoldVertices = 0;
    std::optional<Eigen::Vector3d> firstNonManifoldVertex;
    /// Edges whose two triangles run through them in the same direction.
    std::size_t inconsistentEdges = 0;
    std::optional<std::array<Eigen::Vector3d, 2>> firstInconsistentEdge;
    /// Triangles of zero area (harmless for the queries, reported for the designer).
    std::size_t degenerateTriangles = 0;
    /// Out-of-range vertex indices (a corrupt mesh).
    std::size_t badIndices = 0;
    double signedVolume = 0.0;

    bool closedManifold() const
    {
        return triangles > 0 && badIndices == 0 && openEdges == 0 && nonManifoldEdges == 0 && nonManifoldVertices == 0;
    }
    bool consistentlyOriented() const { return inconsistentEdges == 0; }
    /// Closed, consistent, but oriented inward (negative volume): fixable by flipping.
    bool inverted() const { return closedManifold() && consistentlyOriented() && signedVolume < 0.0; }
    /// Closed 2-manifold, consistently and outward oriented.
    bool ok() const { return closedManifold() && consistentlyOriented() && signedVolume > 0.0; }
    /// The first problem in words ("3 open edges, the first from (x, y, z) to (x, y, z)"); empty when ok().
    std::string problem() const;
};

/// Topological and orientation check of a triangle mesh (no geometry repair).
MeshCheck checkMesh(const TriangleMesh& mesh);

/// Throws InputError(`name`, "mesh", problem) unless `mesh` is a closed,
/// consistently oriented 2-manifold; an inverted mesh is flipped in place with
/// a warning (log category "model").
void requireSolidMesh(TriangleMesh& mesh, const std::string& name);

/// A mesh file as read: the solid, and what was repaired to make it one.
struct ImportedMesh {
    TriangleMesh mesh;
    MeshRepairReport repair;
};

/// Loads STL (ASCII or binary), OBJ, PLY or OFF through CGAL's readers, merges
/// points written more than once, triangulates polygons and repairs what CAD
/// exports leave (mesh_repair.h; docs/part-program.md, "Meshes as they
/// come"). The result bounds a volume (closed 2-manifold, no
/// self-intersection, outward). A mesh that cannot be read as a solid, or
/// with MeshRepairMode::Strict one that needed any repair, throws InputError
/// naming the file and the record, e.g. "m.stl: facet 812: file ends after 40
/// of 50 bytes"; repairs are logged as a warning (category "model").
ImportedMesh importMesh(const std::filesystem::path& file, const MeshRepairOptions& options = {});

/// importMesh with the default options, the mesh only.
TriangleMesh loadMesh(const std::filesystem::path& file);

enum class MeshEncoding { Binary, Ascii };

/// Writes STL or PLY (binary or ASCII) or OBJ/OFF (always ASCII), chosen by
/// the extension. Failures throw FaultError.
void saveMesh(const TriangleMesh& mesh, const std::filesystem::path& file,
              MeshEncoding encoding = MeshEncoding::Binary);

} // namespace hg::model
