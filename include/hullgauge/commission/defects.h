// Seeded defects (docs/commissioning.md, "Seeded defects"): the nominal part
// with material added or removed at one landmark, so that the surface along
// the landmark's normal line lies exactly `depthMm` out (added) or in
// (removed) — the true deviation the program must catch.
//
// Added material is the part united with a box from a little inside the
// surface out to +depth, square to the normal and `halfWidthMm` each side of
// the normal line: a burr, a boss too tall — a patch that stands out of the
// outline wherever a view grazes it.
//
// Removed material is the part less a box whose inner face is the plane at
// −depth along the normal, reaching out past the surface. A silhouette shows
// a surface only where it is on the visual hull of the views (dissertation
// chapter 2): a pocket milled into the middle of a face is a concavity that
// no line of sight grazing the face can enter, so no silhouette gauge can
// see it. What a silhouette sees is material removed along the line of sight
// — the face cut low across the part, an edge chamfered, a bore's wall
// milled along it. So each removed box is long along one line of sight that
// observes the landmark (`sightDirections`, projected into the tangent plane;
// as long as the part) and `halfWidthMm` across it; the union over the
// observing views is removed. Without sight directions the box is the
// square patch.
//
// On a face, an edge (bisector normal) or a bore the point landmark −
// depth·normal lies in the material, so the removed box's plane is the
// surface there; the added box's outer face is the surface along the line.
//
// Pure computation on values (CGAL's corefinement through csg.h).
#pragma once

#include "hullgauge/common/enum_names.h"
#include "hullgauge/model/mesh.h"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace hg::commission {

enum class DefectKind { Added, Removed };
constexpr auto nameTable(DefectKind)
{
    using enum DefectKind;
    return std::to_array<EnumName<DefectKind>>({{Added, "added"}, {Removed, "removed"}});
}

struct SeededDefect {
    DefectKind kind = DefectKind::Removed;
    double depthMm = 0.0;
    /// The true signed deviation at the landmark: +depth added, −depth removed.
    double trueDeviationMm() const { return kind == DefectKind::Added ? depthMm : -depthMm; }
};

/// The box of a seeded defect as a closed mesh, centred on the landmark's
/// normal line, square to `normal` (unit, outward): `halfWidthMm` each side
/// across, and along `along` (a unit vector of the tangent plane; zero: the
/// square patch) `halfLengthMm` each side.
model::TriangleMesh defectBox(const Eigen::Vector3d& landmark, const Eigen::Vector3d& normal,
                              const SeededDefect& defect, double halfWidthMm,
                              const Eigen::Vector3d& along = Eigen::Vector3d::Zero(), double halfLengthMm = 0.0);

/// `nominal` with the defect seeded at the landmark (the header's
/// construction); `sightDirections`: the lines of sight (part frame) of the
/// views that observe the landmark. Throws InputError naming the boolean
/// operation when it fails.
model::TriangleMesh seedDefect(const model::TriangleMesh& nominal, const Eigen::Vector3d& landmark,
                               const Eigen::Vector3d& normal, const SeededDefect& defect, double halfWidthMm,
                               const std::vector<Eigen::Vector3d>& sightDirections = {});

} // namespace hg::commission
