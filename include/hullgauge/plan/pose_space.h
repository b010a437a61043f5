// The station's pose space for view planning (dissertation 5.4, 5.5.1) and the
// analytic grazing poses of a landmark (docs/architecture.md, "Perspective and
// grazing views").
//
// A pose is a fixture position (docs/contracts.md §2). The camera centre in the part
// frame, C(pose), is what decides what a view sees of the part. For a
// rotation/declination fixture C(θ, δ) = Rot(rot_axis, θ)ᵀ Rot(decl_axis, δ)ᵀ c_f
// with c_f the camera centre in the fixture frame, so at a fixed declination
// every coordinate of C is a cos θ + b sin θ + c (and likewise in δ at a fixed
// rotation); for a rail C is affine in the rail position. A plane condition
// n·C = n·x is therefore solved exactly in the free variable.
#pragma once

#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/fixture_motion.h"

#include <cstddef>
#include <vector>

namespace hg::plan {

using geometry::FixtureKinematics;
using geometry::FixturePose;
using geometry::FixtureType;
using geometry::Vec3;

/// Discretisation of the pose space (dissertation 5.5.1: view variation lists
/// are filled in over a grid between bounds).
struct PoseGrid {
    double rotationStepDeg = 5.0;
    double declinationStepDeg = 5.0;
    double railStepMm = 5.0;
    /// Declinations solved for exactly besides the grid (grazingPoses only):
    /// the planner adds the grazing declinations of faces square to the
    /// turntable axis, so other landmarks' curves are solved where they cross.
    std::vector<double> extraDeclinationsDeg;
};

/// Grid values from lo to hi inclusive (hi added when the step does not land on it).
std::vector<double> gridValues(double lo, double hi, double step);

/// Every grid pose within the fixture's ranges.
std::vector<FixturePose> gridPoses(const FixtureKinematics& fixture, const PoseGrid& grid);

/// Reachable poses whose camera centre lies in the plane {X : n·X = n·point}
/// (the landmark's tangent plane: its line of sight grazes the surface) — for
/// a telecentric camera, whose optical axis lies in that plane (n·a = 0). For a
/// rotation/declination fixture: at every grid declination the rotations are
/// solved exactly, and at every grid rotation the declinations, so the curve
/// is found whatever the plane's orientation (a horizontal plane is a
/// declination, a vertical one mostly a rotation). For a rail: the single rail
/// position. Duplicates (within 1e-9°) are removed.
std::vector<FixturePose> grazingPoses(const FixtureKinematics& fixture, const Vec3& point, const Vec3& normal,
                                      const PoseGrid& grid);

/// Fixture travel between two poses: the axes move together, so the larger of
/// the rotation and declination moves (degrees), or the rail move (mm).
double travelDistance(const FixturePose& a, const FixturePose& b, FixtureType type);

/// Order of `poses` (indices) that visits them all starting from `start` with
/// the least total travel distance (travelDistance): exact for up to 8 poses,
/// nearest neighbour then 2-opt improvement beyond.
std::vector<std::size_t> orderForTravel(const std::vector<FixturePose>& poses, FixtureType type,
                                        const FixturePose& start);

/// As orderForTravel, for the least total travel time: each move costs
/// `motion.moveSeconds` (the slowest axis' trapezoidal profile plus settle,
/// fixture_motion.h), so a long move of a fast axis can beat a short one of
/// a slow axis.
std::vector<std::size_t> orderForTime(const std::vector<FixturePose>& poses, const geometry::FixtureMotion& motion,
                                      const FixturePose& start);

/// The pose the fixture sits at when homed: zero on every axis, clamped into the ranges.
FixturePose homePose(const FixtureKinematics& fixture);

} // namespace hg::plan
