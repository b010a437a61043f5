// Repair of meshes as CAD systems export them (docs/part-program.md, "Meshes
// as they come"): duplicated and coincident faces, degenerate faces, small
// gaps, faces and shells oriented the wrong way, and surfaces that meet
// themselves are repaired before the mesh is judged; only what cannot be read
// as a solid is refused. The ideal object must still be an exact, closed
// description (dissertation 3.5.1), so every repair is counted and reported.
//
// Units: millimetres in the part frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hullgauge/common/enum_names.h"
#include "hullgauge/model/mesh.h"

namespace hg::model {

/// `mesh_repair` of a part program: repair and report (the default), or refuse
/// a mesh that needed any repair, naming the defect.
enum class MeshRepairMode { Repair, Strict };
constexpr auto nameTable(MeshRepairMode)
{
    using enum MeshRepairMode;
    return std::to_array<EnumName<MeshRepairMode>>({{Repair, "repair"}, {Strict, "strict"}});
}

struct MeshRepairOptions {
    MeshRepairMode mode = MeshRepairMode::Repair;
    /// Vertices on open edges closer than this to another vertex on an open
    /// edge are merged (a gap the export left between two faces), mm.
    double gapToleranceMm = 0.02;
    /// The largest mesh a file may announce, checked before its body is read
    /// (docs/part-program.md, "Mesh size limits"): a reload must not take the
    /// line PC's memory, nor its watchdog's seconds, on a wrong file.
    std::uint64_t maxTriangles = 4'000'000;
    /// The largest mesh file, any format (ASCII STL and OBJ announce no count).
    std::uint64_t maxFileBytes = std::uint64_t(1) << 30;
};

/// What the repair did, per kind; every count zero for a mesh that needed none.
struct MeshRepairReport {
    double gapToleranceMm = 0.0;    ///< the tolerance the gaps were closed with
    std::size_t duplicateFaces = 0; ///< exact repeats of another face, removed
    std::size_t opposedFaces = 0; ///< coincident faces of opposite orientation (zero-thickness walls), removed in pairs
    std::size_t degenerateFaces = 0;     ///< faces without area, removed
    std::size_t mergedVertices = 0;      ///< vertices on open edges merged into another within the tolerance
    std::size_t closedEdges = 0;         ///< open edges those merges closed (borders stitched)
    std::size_t reorientedFaces = 0;     ///< faces running against their neighbours, reversed
    std::size_t flippedShells = 0;       ///< closed shells oriented the wrong way (outer inward, void outward), flipped
    std::size_t selfIntersections = 0;   ///< self-intersecting triangle pairs found, all removed
    std::size_t retriangulatedFaces = 0; ///< planar faces folded over themselves, re-triangulated
    std::size_t autorefinedPairs = 0;    ///< of the pairs, those removed by autorefinement (crossing shells)
    /// The volume the surface bounded as read (closed, its faces oriented
    /// alike, before self-intersections were resolved and shells flipped:
    /// two shells never united count the volume they share twice) and the
    /// repaired solid's (mm³); 0 when the mesh was not repaired.
    double volumeAsReadMm3 = 0.0;
    double volumeMm3 = 0.0;

    /// True when nothing was repaired.
    bool clean() const;
    /// The defects found, "2 duplicate faces, 1 shell oriented inward" (strict mode's refusal).
    std::string defects() const;
    /// The repairs made, "2 duplicate faces removed, 1 shell flipped" (the warning).
    std::string repairs() const;
    /// One entry per kind repaired, as in repairs(), and last, when anything
    /// was repaired and the volume moved, by how much.
    std::vector<std::string> items() const;
};

/// Repairs a triangle soup (indices into `soup.vertices`; points meant to be
/// one already merged) into a closed, outward-oriented 2-manifold without
/// self-intersections, counting each repair in `report`. What cannot be read
/// as a solid (a hole wider than the tolerance, edges shared by more than two
/// faces, sheets touching at a point, a self-intersection the repair cannot
/// remove) throws InputError(name, "mesh", problem) naming the first place.
TriangleMesh repairMesh(TriangleMesh soup, const std::string& name, const MeshRepairOptions& options,
                        MeshRepairReport& report);

} // namespace hg::model
