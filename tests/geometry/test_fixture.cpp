// Fixture kinematics (docs/contracts.md §2) against poses worked out by hand.
#include <gtest/gtest.h>

#include "hullgauge/geometry/fixture.h"

namespace hg::geometry {
namespace {

void expectNear(const Vec3& a, const Vec3& b, double tol = 1e-12)
{
    EXPECT_LT((a - b).norm(), tol) << "got " << a.transpose() << " expected " << b.transpose();
}

// Camera 300 mm from the fixture origin looking along fixture +y:
// camera x = fixture x, camera y = fixture -z (image down = world down),
// camera z = fixture +y; the fixture origin is at camera (0, 0, 300).
FixtureKinematics sideCamera()
{
    FixtureKinematics k;
    k.cameraFromFixture.R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
    k.cameraFromFixture.t = Vec3(0, 0, 300);
    k.rotationAxis = Vec3::UnitZ();
    k.declinationAxis = Vec3::UnitX();
    return k;
}

TEST(FixtureKinematics, HomePoseIsCameraFromFixture)
{
    auto k = sideCamera();
    expectNear(k.cameraFromPart({}).apply({10, 0, 5}), {10, -5, 300});
    expectNear(k.cameraCentreInPart({}), {0, -300, 0});
}

TEST(FixtureKinematics, RotationTurnsThePartAboutTheTurntableAxis)
{
    auto k = sideCamera();
    // Rotating the part +90° about z carries part +x to fixture +y, i.e.
    // straight away from the camera: camera (0, 0, 310).
    expectNear(k.cameraFromPart({90, 0, 0}).apply({10, 0, 0}), {0, 0, 310});
    // Seen from the part, the camera turns the other way: Rz(-90°) carries
    // its home position (0, -300, 0) to (-300, 0, 0).
    expectNear(k.cameraCentreInPart({90, 0, 0}), {-300, 0, 0}, 1e-9);
}

TEST(FixtureKinematics, DeclinationTiltsTheTurntable)
{
    auto k = sideCamera();
    // Tilt +90° about fixture x: part +z (the turntable axis) goes to fixture
    // -y, towards the camera: camera z = 300 - 10.
    expectNear(k.cameraFromPart({0, 90, 0}).apply({0, 0, 10}), {0, 0, 290}, 1e-9);
    // Rotation first, then the tilt: part +x -> (+90° about z) fixture +y ->
    // (+90° about x) fixture +z -> camera y = -10.
    expectNear(k.cameraFromPart({90, 90, 0}).apply({10, 0, 0}), {0, -10, 300}, 1e-9);
    // 30° tilt: part (0, 0, 10) -> fixture (0, -10 sin30, 10 cos30).
    expectNear(k.cameraFromPart({0, 30, 0}).apply({0, 0, 10}), {0, -10 * std::cos(degToRad(30)), 300 - 5}, 1e-9);
}

TEST(FixtureKinematics, SkewDeclinationAxisThroughItsOwnPoint)
{
    // Declination axis parallel to x through (0, 0, -20) in the fixture frame
    // (20 mm below the turntable): a 90° tilt about that line carries the
    // part origin, 20 mm above the axis, a quarter circle towards the camera
    // to fixture (0, -20, -20), i.e. camera (0, 20, 280).
    auto k = sideCamera();
    k.declinationAxisPoint = Vec3(0, 0, -20);
    expectNear(k.cameraFromPart({0, 90, 0}).apply({0, 0, 0}), {0, 20, 280}, 1e-9);
    // The rotation axis is unaffected at declination 0, and points on the
    // declination line stay put whatever the tilt.
    expectNear(k.cameraFromPart({90, 0, 0}).apply({10, 0, 0}), {0, 0, 310}, 1e-9);
    expectNear(k.cameraFromPart({0, 37, 0}).apply({5, 0, -20}), k.cameraFromPart({}).apply({5, 0, -20}), 1e-9);
    // A rotation axis through (3, 0, 0): part point (3, 0, 0) is on it.
    k.rotationAxisPoint = Vec3(3, 0, 0);
    expectNear(k.cameraFromPart({70, 0, 0}).apply({3, 0, 5}), k.cameraFromPart({}).apply({3, 0, 5}), 1e-9);
}

TEST(FixtureKinematics, RailTranslatesAlongItsAxis)
{
    FixtureKinematics k;
    k.type = FixtureType::Rail;
    k.cameraFromFixture.t = Vec3(0, 0, 200);
    k.railAxis = Vec3(0, 0, 2); // need not be unit
    k.railRangeMm = {0, 300};
    expectNear(k.cameraFromPart({0, 0, 120}).apply({1, 2, 3}), {1, 2, 323});
    EXPECT_TRUE(k.reachable({0, 0, 300}));
    EXPECT_FALSE(k.reachable({0, 0, 300.5}));
}

TEST(FixtureKinematics, Reachability)
{
    auto k = sideCamera();
    k.rotationRangeDeg = {-180, 180};
    k.declinationRangeDeg = {0, 60};
    EXPECT_TRUE(k.reachable({-180, 0, 0}));
    EXPECT_TRUE(k.reachable({45, 60, 0}));
    EXPECT_FALSE(k.reachable({45, 61, 0}));
    EXPECT_FALSE(k.reachable({45, -1, 0}));
}

} // namespace
} // namespace hg::geometry
