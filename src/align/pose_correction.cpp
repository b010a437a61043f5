// Planned poses corrected for the measured seat (docs/alignment.md, "Poses
// corrected for the seat"; dissertation 6.2, item 6, carried into the view
// plan of chapter 5).
#include "hullgauge/align/pose_correction.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace hg::align {
namespace {

using geometry::FixtureKinematics;
using geometry::FixturePose;
using geometry::FixtureType;
using geometry::RigidTransform;
using geometry::Vec3;
using Params = Eigen::VectorXd;

constexpr int kMaxIterations = 20;
constexpr double kStepH = 1e-4;      // central-difference step (degrees or mm)
constexpr double kConverged = 1e-10; // step size that ends the iteration
constexpr double kMaxStep = 5.0;     // the seat is at most 10° off: no step goes farther than this
constexpr double kWorthCorrectingDeg = 1e-6;

/// The fixture's axes as a parameter vector: (rotation, declination) in
/// degrees, or the rail position in mm.
Params paramsOf(const FixtureKinematics& fixture, const FixturePose& pose)
{
    if (fixture.type == FixtureType::Rail) return Params::Constant(1, pose.railMm);
    Params x(2);
    x << pose.rotationDeg, pose.declinationDeg;
    return x;
}

FixturePose poseOf(const FixtureKinematics& fixture, const Params& x)
{
    FixturePose pose;
    if (fixture.type == FixtureType::Rail)
        pose.railMm = x[0];
    else {
        pose.rotationDeg = x[0];
        pose.declinationDeg = x[1];
    }
    return pose;
}

/// Direction from `target` back along its line of sight to the camera, part
/// frame, with the part seated by `seat`: towards the camera centre, or
/// against a telecentric camera's optical axis (docs/telecentric.md).
Vec3 sightDirection(const FixtureKinematics& fixture, const FixturePose& pose, const RigidTransform& seat,
                    const Vec3& target)
{
    const geometry::SightLines sight = fixture.sightLinesAt(pose);
    const RigidTransform unseat = seat.inverse();
    if (sight.parallel) return -(unseat.R * sight.axis);
    return (unseat.apply(sight.centre) - target).normalized();
}

double angleDeg(const Vec3& a, const Vec3& b)
{
    return geometry::radToDeg(std::atan2(a.cross(b).norm(), a.dot(b)));
}

/// Brings `x` into the fixture's ranges: a turn outside its range one turn
/// around where that is inside, else the nearest end. True when an end was taken.
bool keepInRange(const FixtureKinematics& fixture, Params& x)
{
    auto clampTo = [](const geometry::Range& r, double& v) {
        if (r.contains(v)) return false;
        v = std::clamp(v, r.min, r.max);
        return true;
    };
    if (fixture.type == FixtureType::Rail) return clampTo(fixture.railRangeMm, x[0]);
    for (double turn : {360.0, -360.0})
        if (!fixture.rotationRangeDeg.contains(x[0]) && fixture.rotationRangeDeg.contains(x[0] + turn)) x[0] += turn;
    const bool rotationEnd = clampTo(fixture.rotationRangeDeg, x[0]);
    const bool declinationEnd = clampTo(fixture.declinationRangeDeg, x[1]);
    return rotationEnd || declinationEnd;
}

} // namespace

double sightErrorDeg(const FixtureKinematics& fixture, const FixturePose& planned, const FixturePose& commanded,
                     const RigidTransform& seat, const Vec3& target)
{
    return angleDeg(sightDirection(fixture, planned, RigidTransform::identity(), target),
                    sightDirection(fixture, commanded, seat, target));
}

PoseCorrection correctPose(const FixtureKinematics& fixture, const FixturePose& planned, const RigidTransform& seat,
                           const Vec3& target)
{
    PoseCorrection out;
    out.pose = planned;
    out.sightErrorBeforeDeg = sightErrorDeg(fixture, planned, planned, seat, target);
    out.sightErrorAfterDeg = out.sightErrorBeforeDeg;
    if (out.sightErrorBeforeDeg < kWorthCorrectingDeg) return out;

    // The residual: the seated sight direction's components across the planned one.
    const Vec3 wanted = sightDirection(fixture, planned, RigidTransform::identity(), target);
    const Vec3 e1 = wanted.unitOrthogonal();
    const Vec3 e2 = wanted.cross(e1);
    auto residual = [&](const Params& x) {
        const Vec3 u = sightDirection(fixture, poseOf(fixture, x), seat, target);
        return Eigen::Vector2d(e1.dot(u), e2.dot(u));
    };
    Params x = paramsOf(fixture, planned);
    bool limited = false;
    for (int it = 0; it < kMaxIterations; ++it) {
        Eigen::Matrix<double, 2, Eigen::Dynamic> J(2, x.size());
        for (Eigen::Index k = 0; k < x.size(); ++k) {
            Params hi = x, lo = x;
            hi[k] += kStepH;
            lo[k] -= kStepH;
            J.col(k) = (residual(hi) - residual(lo)) / (2.0 * kStepH);
        }
        // Minimum-norm least squares: an axis that does not move the line of
        // sight (the turntable seen along its own axis) stays where it is.
        Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(J);
        cod.setThreshold(1e-6);
        Params step = -cod.solve(Eigen::MatrixXd(residual(x)));
        if (step.norm() > kMaxStep) step *= kMaxStep / step.norm();
        x += step;
        limited = keepInRange(fixture, x);
        if (step.norm() < kConverged) break;
    }
    const FixturePose candidate = poseOf(fixture, x);
    const double after = sightErrorDeg(fixture, planned, candidate, seat, target);
    out.limited = limited;
    if (after > out.sightErrorBeforeDeg - kWorthCorrectingDeg) return out;
    out.pose = candidate;
    out.corrected = true;
    out.sightErrorAfterDeg = after;
    return out;
}

} // namespace hg::align
