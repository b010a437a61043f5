#include "hullgauge/geometry/fixture.h"

namespace hg::geometry {
namespace {

/// Rotation by `angleDeg` about the line through `point` along `axis`.
RigidTransform rotationAboutLine(const Vec3& axis, const Vec3& point, double angleDeg)
{
    RigidTransform T = RigidTransform::rotation(axis, angleDeg);
    T.t = point - T.R * point;
    return T;
}

} // namespace

RigidTransform FixtureKinematics::cameraFromPart(const FixturePose& pose) const
{
    // docs/contracts.md §2: the turntable turns the part about the rotation axis, the
    // declination tilts the turntable (and the part on it) about its own axis.
    if (type == FixtureType::Rail)
        return cameraFromFixture * RigidTransform::translation(railAxis.normalized() * pose.railMm);
    return cameraFromFixture * rotationAboutLine(declinationAxis, declinationAxisPoint, pose.declinationDeg) *
           rotationAboutLine(rotationAxis, rotationAxisPoint, pose.rotationDeg);
}

bool FixtureKinematics::reachable(const FixturePose& pose) const
{
    if (type == FixtureType::Rail) return railRangeMm.contains(pose.railMm);
    return rotationRangeDeg.contains(pose.rotationDeg) && declinationRangeDeg.contains(pose.declinationDeg);
}

Vec3 FixtureKinematics::cameraCentreInPart(const FixturePose& pose) const
{
    return cameraFromPart(pose).inverse().t;
}

SightLines FixtureKinematics::sightLinesAt(const FixturePose& pose) const
{
    const RigidTransform partFromCamera = cameraFromPart(pose).inverse();
    return {partFromCamera.t, partFromCamera.R.col(2), cameraProjection == Projection::Telecentric};
}

} // namespace hg::geometry

fmt::format_context::iterator fmt::formatter<hg::geometry::PoseOn>::format(const hg::geometry::PoseOn& p,
                                                                           fmt::format_context& ctx) const
{
    using hg::formatNumber;
    if (p.type == hg::geometry::FixtureType::Rail)
        return fmt::format_to(ctx.out(), "rail {} mm", formatNumber(p.pose.railMm));
    return fmt::format_to(ctx.out(), "rotation {} deg, declination {} deg", formatNumber(p.pose.rotationDeg),
                          formatNumber(p.pose.declinationDeg));
}
