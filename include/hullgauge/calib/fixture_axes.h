// Fixture-axis calibration: from views of a target (chessboard) carried by
// the fixture at several rotation and declination angles, the two axes as
// lines in space — in general skew and not at right angles — and
// camera_from_fixture (docs/contracts.md §2), with residuals in pixels and mm.
//
// Model (camera frame; declination is the outer axis, it tilts the turntable):
//   camera_from_target(θ, φ) = Rot(L_d, φ) · Rot(L_r, θ) · M
// where Rot(L, α) turns by α about the line L (right-handed about its
// direction), L_r is the rotation axis at declination 0, and M the target's
// pose at (0, 0). Every view's target pose comes from cv::solvePnP; the axes
// are first extracted as screw axes of the relative motions between views
// that differ in one angle only, then all parameters (two lines, four degrees
// of freedom each, and M) are refined jointly on the reprojection error.
//
// Fixture frame (the gauge choice, docs/calibration.md): origin on the
// rotation axis at the foot of the common perpendicular with the declination
// axis; z along the rotation axis; x along the declination axis projected
// perpendicular to z. So rotation_axis = (0, 0, 1) through the origin, and the
// declination axis passes through `declinationAxisPoint` = (0, e, 0), e being
// the distance between the axes (0 when they intersect).
#pragma once

#include <string>
#include <vector>

#include "hullgauge/calib/target.h"
#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/fixture.h"

namespace hg::calib {

struct FixtureView {
    geometry::FixturePose pose; ///< commanded rotation and declination (degrees)
    TargetView target;
};

/// A line in space: point + s * direction, direction unit length.
struct AxisLine {
    geometry::Vec3 point = geometry::Vec3::Zero();
    geometry::Vec3 direction = geometry::Vec3::UnitZ();
};

struct FixtureAxesResult {
    geometry::RigidTransform cameraFromFixture;
    /// Axes in the fixture frame (unit directions; rotation axis is +z).
    geometry::Vec3 rotationAxis = geometry::Vec3::UnitZ();
    geometry::Vec3 declinationAxis = geometry::Vec3::UnitX();
    geometry::Vec3 rotationAxisPoint = geometry::Vec3::Zero();
    geometry::Vec3 declinationAxisPoint = geometry::Vec3::Zero();
    /// The same axes in the camera frame (rotation axis at declination 0).
    AxisLine rotationAxisInCamera, declinationAxisInCamera;
    /// The target's pose on the turntable (fixture frame at rotation 0, declination 0).
    geometry::RigidTransform fixtureFromTarget;
    double axesAngleDeg = 0.0;   ///< angle between the axes (90 for a perpendicular fixture)
    double axesDistanceMm = 0.0; ///< length of their common perpendicular (0 when they intersect)
    double rmsPx = 0.0, maxPx = 0.0;
    /// Object-space residuals: each pixel residual scaled to its corner's depth.
    double rmsMm = 0.0, maxMm = 0.0;
    std::vector<double> perViewRmsPx;
    std::vector<std::string> viewNames;
    int views = 0;
    int corners = 0;

    /// The docs/contracts.md §2 kinematics with these axes (ranges left at `base`'s).
    /// It keeps both axes through the origin: the declination axis offset
    /// (axesDistanceMm) is not part of the §2 model.
    geometry::FixtureKinematics kinematics(const geometry::FixtureKinematics& base = {}) const;
    /// The full model's prediction of the target pose at a fixture pose.
    geometry::RigidTransform cameraFromTarget(const geometry::FixturePose& pose) const;
};

/// Solves the axes. Needs at least two views differing only in rotation and
/// two differing only in declination (else hg::InputError naming `field`).
FixtureAxesResult calibrateFixtureAxes(const std::vector<FixtureView>& views, const geometry::Intrinsics& camera,
                                       const std::string& field = "views");

/// Rotation by `angleDeg` about a line (right-handed about its direction).
geometry::RigidTransform rotationAboutLine(const AxisLine& line, double angleDeg);

std::string formatFixtureReport(const FixtureAxesResult& result);

} // namespace hg::calib
