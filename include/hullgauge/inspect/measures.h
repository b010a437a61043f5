// Accuracy measures of dissertation 4.5 and 4.6 that do not depend on the
// traversal: minimum experimental discrimination per view (MED, eq. 4.4.4-19
// and 4.4.5-11) and the [min, max] brackets of geometric parameters through
// landmarks (4.6.4, eq. 3.3.6-1).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullgauge/geometry/camera.h"

namespace hg::inspect {

/// MED of one view at one landmark.
struct ViewDiscrimination {
    bool observes = false; ///< landmark in front of the camera and inside the frame
    /// d: camera centre to landmark (a telecentric camera: the lens's front
    /// to the landmark along the axis, CameraModel::rangeTo)
    double distanceMm = 0.0;
    double thetaDeg = 0.0; ///< Θ: optical axis to the line of sight (0 for a telecentric camera)
    /// Smallest voxel edge one pixel can discriminate along the line of sight,
    /// eq. 4.4.4-19 solved for ΔV: √2·d / (1.5·f + 1), f = min(fx, fy) in pixels
    /// (the longer pixel side). Written with the pixel's size at the landmark
    /// m = d / f as √2·m / (1.5 + 1/f), it holds for a telecentric camera as
    /// f → ∞ at fixed m = 1 / min(fx, fy) (docs/telecentric.md): √2·m / 1.5.
    double medRangeMm = 0.0;
    /// Eq. 4.4.5-11 solved for ΔV (several voxels off the axis at angle Θ):
    /// 2√2·d·cosΘ / (2f(cosΘ − sinΘ) + 1), i.e. 2√2·m·cosΘ / (2(cosΘ − sinΘ) + 1/f);
    /// infinite from Θ = 45° on; √2·m for a telecentric camera.
    double medAngleMm = 0.0;
};

ViewDiscrimination viewDiscrimination(const geometry::CameraModel& camera, const Eigen::Vector3d& landmark);

/// A closed interval [min, max].
struct Bracket {
    double min = 0.0;
    double max = 0.0;
    double mid() const { return 0.5 * (min + max); }
};

/// Where a landmark may be: the segment position + s·normal, s in [sLow, sHigh].
struct LandmarkEstimate {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    double sLow = 0.0;
    double sHigh = 0.0;
    Eigen::Vector3d at(double s) const { return position + s * normal; }
};

/// Exact range of the distance between two points moving on their segments.
Bracket distanceBracket(const LandmarkEstimate& a, const LandmarkEstimate& b);

/// Perimeter of the closed polygon through the estimates in order: the sum of
/// the exact per-edge distance brackets (a valid bracket; eq. 3.3.6-1).
Bracket perimeterBracket(const std::vector<LandmarkEstimate>& ring);

/// Area of the closed polygon through the estimates, in the best-fit plane of
/// the nominal positions. The shoelace area is multilinear in the segment
/// parameters, so its extremes lie at segment ends: exact by enumeration for up
/// to 16 landmarks, interval arithmetic (valid, wider) beyond.
Bracket areaBracket(const std::vector<LandmarkEstimate>& ring);

} // namespace hg::inspect
