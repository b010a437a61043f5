#include "hullgauge/geometry/fixture.h"

#include <sstream>

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

std::string toString(const FixturePose& pose, FixtureType type)
{
    std::ostringstream s;
    if (type == FixtureType::Rail)
        s << "rail " << pose.railMm << " mm";
    else
        s << "rotation " << pose.rotationDeg << " deg, declination " << pose.declinationDeg << " deg";
    return s.str();
}

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

} // namespace hg::geometry
