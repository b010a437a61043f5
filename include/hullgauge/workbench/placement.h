// Where a landmark placed by a point near the part lands (docs/workbench.md,
// "Landmarks"): the nearest point of the surface, moved onto a sharp edge
// (the faces meeting at more than 30°) or a corner within the snap distance,
// where the dissertation places landmarks (Figure 3.5). The normal is left to
// the part program's loader (docs/part-program.md, "Normals from the mesh").
//
// Pure computation on values; units are millimetres in the part frame.
#pragma once

#include "hullgauge/model/mesh.h"
#include "hullgauge/workbench/workspace.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace hg::workbench {

/// The sharp edges of a mesh and the corners where they meet.
struct SharpFeatures {
    std::vector<std::array<Eigen::Vector3d, 2>> edges;
    /// Vertices where three or more sharp edges meet, or two that turn by more than the angle.
    std::vector<Eigen::Vector3d> corners;
};

/// The edges whose two triangles' normals differ by more than `angleDeg`
/// (convex and re-entrant alike), and their corners.
SharpFeatures sharpFeatures(const model::TriangleMesh& mesh, double angleDeg = 30.0);

/// The snap distance of a part: kSnapShareOfDiagonal of its bounding box's diagonal.
double snapDistanceMm(const Eigen::AlignedBox3d& bounds);

struct Snapped {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Placement on = Placement::Face;
};

/// `surfacePoint` (a point of the surface) moved onto the nearest corner
/// within `snapMm`, else onto the nearest sharp edge within `snapMm`, else
/// left where it is (a face).
Snapped snapToFeature(const Eigen::Vector3d& surfacePoint, const SharpFeatures& features, double snapMm);

/// Where a point of the surface lies: at a corner or on a sharp edge when
/// within `toleranceMm` of one, else on a face.
Placement classify(const Eigen::Vector3d& position, const SharpFeatures& features, double toleranceMm);

} // namespace hg::workbench
