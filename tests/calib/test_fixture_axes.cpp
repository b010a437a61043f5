#include <gtest/gtest.h>

#include <iostream>
#include <random>

#include "fixture_rig.h"
#include "hullgauge/calib/fixture_axes.h"
#include "hullgauge/common/error.h"

using namespace hg::calib;
using namespace hg::geometry;
using calibtest::Rig;

namespace {

double angleBetweenDeg(const Vec3& a, const Vec3& b)
{
    return radToDeg(std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)));
}

/// Distance from point p to a line.
double distanceToLine(const Vec3& p, const AxisLine& l)
{
    Vec3 d = l.direction.normalized();
    Vec3 v = p - l.point;
    return (v - d * d.dot(v)).norm();
}

void expectRecovered(const Rig& rig, const FixtureAxesResult& r)
{
    // Axes in the camera frame: direction within 0.05 degrees, position
    // within 0.1 mm over the working volume (checked at the fixture origin
    // and 60 mm either side along each axis).
    AxisLine trueRot = {rig.cameraFromFixture.apply(rig.rotation.point),
                        rig.cameraFromFixture.applyToDirection(rig.rotation.direction)};
    AxisLine trueDec = {rig.cameraFromFixture.apply(rig.declination.point),
                        rig.cameraFromFixture.applyToDirection(rig.declination.direction)};
    EXPECT_LT(angleBetweenDeg(r.rotationAxisInCamera.direction, trueRot.direction), 0.05);
    EXPECT_LT(angleBetweenDeg(r.declinationAxisInCamera.direction, trueDec.direction), 0.05);
    for (double s : {-60.0, 0.0, 60.0}) {
        EXPECT_LT(distanceToLine(trueRot.point + s * trueRot.direction, r.rotationAxisInCamera), 0.1) << s;
        EXPECT_LT(distanceToLine(trueDec.point + s * trueDec.direction, r.declinationAxisInCamera), 0.1) << s;
    }
    // The fixture frame follows the same convention as the rig's: same pose.
    EXPECT_LT(rotationAngleDeg(r.cameraFromFixture.R, rig.cameraFromFixture.R), 0.05);
    EXPECT_LT((r.cameraFromFixture.t - rig.cameraFromFixture.t).norm(), 0.1);
    EXPECT_LT(angleBetweenDeg(r.declinationAxis, rig.declination.direction), 0.05);
    EXPECT_LT((r.declinationAxisPoint - rig.declination.point).norm(), 0.1);
    EXPECT_NEAR(r.axesDistanceMm, rig.declination.point.norm(), 0.1);
    EXPECT_NEAR(r.axesAngleDeg, angleBetweenDeg(rig.rotation.direction, rig.declination.direction), 0.05);
    EXPECT_NEAR(r.rmsPx, rig.noisePx * std::sqrt(2.0), 0.05);
    // Object-space residual: the pixel residual at the target's depth (~450 mm) over f = 2400 px.
    EXPECT_NEAR(r.rmsMm, r.rmsPx * 450.0 / 2400.0, 0.2 * r.rmsPx * 450.0 / 2400.0);
}

} // namespace

TEST(FixtureAxes, SkewNonPerpendicularAxesAreRecovered)
{
    Rig rig(0.6, 0.3);
    auto result = calibrateFixtureAxes(rig.views(11), rig.camera);
    std::cout << formatFixtureReport(result);
    expectRecovered(rig, result);
    // The full model predicts unseen poses: target corners within 0.1 mm.
    FixturePose unseen{45.0, 20.0, 0.0};
    RigidTransform truth = rig.cameraFromFixture * rotationAboutLine(rig.declination, 20.0) *
                           rotationAboutLine(rig.rotation, 45.0) * rig.fixtureFromTarget;
    RigidTransform predicted = result.cameraFromTarget(unseen);
    for (int id : {0, 11, 96, 107}) {
        auto p = rig.board.cornerPosition(id);
        Vec3 x(p.x, p.y, p.z);
        EXPECT_LT((truth.apply(x) - predicted.apply(x)).norm(), 0.1) << id;
    }
}

TEST(FixtureAxes, IntersectingPerpendicularAxesGiveTheContractModel)
{
    Rig rig(0.0, 0.0);
    auto result = calibrateFixtureAxes(rig.views(5), rig.camera);
    expectRecovered(rig, result);
    EXPECT_LT(result.axesDistanceMm, 0.1);
    // With intersecting axes the docs/contracts.md §2 kinematics reproduce the rig.
    auto k = result.kinematics();
    FixturePose pose{-20.0, 35.0, 0.0};
    RigidTransform truth =
        rig.cameraFromFixture * rotationAboutLine(rig.declination, 35.0) * rotationAboutLine(rig.rotation, -20.0);
    RigidTransform model = k.cameraFromPart(pose);
    EXPECT_LT(rotationAngleDeg(model.R, truth.R), 0.05);
    EXPECT_LT((model.t - truth.t).norm(), 0.1);
}

TEST(FixtureAxes, ViewsThatDoNotIsolateAnAxisAreBadInput)
{
    Rig rig(0.0, 0.0);
    auto all = rig.views(3);
    std::vector<FixtureView> onlyRotation;
    for (const auto& v : all)
        if (v.pose.declinationDeg == 0.0) onlyRotation.push_back(v);
    try {
        (void)calibrateFixtureAxes(onlyRotation, rig.camera);
        ADD_FAILURE() << "accepted views without a declination change";
    } catch (const hg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find("different declinations"), std::string::npos) << e.what();
    }
}
