// Pose space: grazing poses solve the tangent-plane condition exactly, grids
// cover the ranges, travel ordering is optimal on small sets.
#include "hgtest/station.h"
#include "hullgauge/plan/pose_space.h"
#include "hullgauge/plan/view_rules.h"

#include <cmath>
#include <gtest/gtest.h>

namespace hg::plan {
namespace {

// Camera 300 mm from the fixture origin on -y, looking along +y (image x = part
// x, image y = -part z). Positive declination raises the camera: its centre is
// (0, -300 cos δ, 300 sin δ) at rotation 0.
FixtureKinematics turntable(geometry::Range rotation, geometry::Range declination)
{
    return hgtest::station({.rotationRangeDeg = rotation, .declinationRangeDeg = declination}).fixture;
}

PoseGrid steps(double rotationDeg, double declinationDeg, double railMm)
{
    PoseGrid g;
    g.rotationStepDeg = rotationDeg;
    g.declinationStepDeg = declinationDeg;
    g.railStepMm = railMm;
    return g;
}

TEST(PoseSpace, GridValuesIncludeBothEnds)
{
    auto v = gridValues(0, 60, 25);
    ASSERT_EQ(v.size(), 4u);
    EXPECT_DOUBLE_EQ(v[2], 50);
    EXPECT_DOUBLE_EQ(v[3], 60);
    EXPECT_EQ(gridValues(5, 5, 1).size(), 1u);
}

TEST(PoseSpace, FullTurnGridKeepsOneEnd)
{
    auto f = turntable({-180, 180}, {0, 10});
    auto poses = gridPoses(f, steps(90, 10, 5));
    // rotations -180, -90, 0, 90 (180 is -180 again) x declinations 0, 10
    EXPECT_EQ(poses.size(), 8u);
}

TEST(PoseSpace, CameraCentreMatchesTheHandDerivedTurntable)
{
    auto f = turntable({-180, 180}, {0, 60});
    const double d = geometry::degToRad(30);
    Vec3 c = f.cameraCentreInPart({0, 30, 0});
    EXPECT_NEAR(c.y(), -300 * std::cos(d), 1e-9);
    EXPECT_NEAR(c.z(), 300 * std::sin(d), 1e-9);
    // Rotation 90°: the part turns, the camera (in the part frame) moves to -x.
    c = f.cameraCentreInPart({90, 0, 0});
    EXPECT_NEAR(c.x(), -300, 1e-9);
    EXPECT_NEAR(c.y(), 0, 1e-9);
}

TEST(PoseSpace, HorizontalTangentPlaneIsOneDeclination)
{
    // Top face of a 20 mm cube standing on the turntable: plane z = 20. The
    // camera centre is in it where 300 sin δ = 20, at every rotation.
    auto f = turntable({-180, 180}, {0, 60});
    auto poses = grazingPoses(f, Vec3(0, 0, 20), Vec3::UnitZ(), steps(10, 5, 5));
    ASSERT_FALSE(poses.empty());
    const double expected = geometry::radToDeg(std::asin(20.0 / 300.0));
    for (const auto& p : poses) EXPECT_NEAR(p.declinationDeg, expected, 1e-9) << p.rotationDeg;
    EXPECT_GE(poses.size(), 36u); // one per grid rotation
}

TEST(PoseSpace, VerticalTangentPlaneSolvedExactlyInRotation)
{
    // Plane y = -6 (a U channel's inner wall): at declination δ the centre is
    // (-300 cos δ sin θ ... ); every returned pose must put it in the plane.
    auto f = turntable({-180, 180}, {0, 60});
    const Vec3 x(0, -6, 8), n(0, 1, 0);
    auto poses = grazingPoses(f, x, n, steps(5, 5, 5));
    ASSERT_GE(poses.size(), 2u * 13u);
    for (const auto& p : poses) {
        EXPECT_NEAR(n.dot(f.cameraCentreInPart(p) - x), 0.0, 1e-8) << p.rotationDeg << " " << p.declinationDeg;
        EXPECT_TRUE(f.reachable(p));
    }
    // At declination 0 the centre is (-300 sin θ', -300 cos θ', 0) for some
    // convention; y = -6 means |cos θ| = 6/300 — rotation within 1.15° of ±90°.
    int atZero = 0;
    for (const auto& p : poses)
        if (p.declinationDeg == 0.0) {
            ++atZero;
            EXPECT_NEAR(std::abs(p.rotationDeg), 90.0, 1.2);
        }
    EXPECT_EQ(atZero, 2);
}

TEST(PoseSpace, RangesExcludeGrazingPoses)
{
    auto f = turntable({-30, 30}, {0, 60});
    for (const auto& p : grazingPoses(f, Vec3(0, -6, 8), Vec3(0, 1, 0), steps(5, 5, 5))) {
        // Only poses with the camera high above can reach plane y = -6 now.
        EXPECT_TRUE(f.reachable(p));
        EXPECT_NEAR(Vec3(0, 1, 0).dot(f.cameraCentreInPart(p) - Vec3(0, -6, 8)), 0.0, 1e-8);
    }
}

TEST(PoseSpace, RailSolvesTheSinglePosition)
{
    const FixtureKinematics f = hgtest::station({.fixtureType = FixtureType::Rail}).fixture; // along x, ±100 mm
    // Camera centre in the part frame is (-s, -300, 0): plane x = 12 needs s = -12.
    auto poses = grazingPoses(f, Vec3(12, 0, 0), Vec3::UnitX(), {});
    ASSERT_EQ(poses.size(), 1u);
    EXPECT_NEAR(poses[0].railMm, -12.0, 1e-9);
}

TEST(PoseSpace, TravelOrderIsTheShortestPath)
{
    std::vector<FixturePose> poses{{90, 0, 0}, {10, 0, 0}, {50, 20, 0}, {-40, 0, 0}};
    auto order = orderForTravel(poses, FixtureType::RotationDeclination, {0, 0, 0});
    // From 0: -40 first (40) then 10, 50, 90 (50 + 40 + 40) = 170, versus
    // 10, 50, 90, -40 = 10 + 40 + 40 + 130 = 220.
    ASSERT_EQ(order.size(), 4u);
    EXPECT_EQ(order[0], 3u);
    EXPECT_EQ(order[1], 1u);
    EXPECT_EQ(order[2], 2u);
    EXPECT_EQ(order[3], 0u);
}

TEST(PoseSpace, TravelOrderImprovesLargeSets)
{
    // 12 poses on a line, shuffled: the best path from 0 visits them in order.
    std::vector<FixturePose> poses;
    for (int k : {7, 3, 11, 1, 9, 5, 12, 2, 8, 4, 10, 6}) poses.push_back({10.0 * k, 0, 0});
    auto order = orderForTravel(poses, FixtureType::RotationDeclination, {0, 0, 0});
    for (std::size_t i = 1; i < order.size(); ++i)
        EXPECT_LT(poses[order[i - 1]].rotationDeg, poses[order[i]].rotationDeg);
}

TEST(ViewRulesMed, Equation536_3ByHand)
{
    // f/Δp = 4000 px, d = 300 mm, θ = 0: MED = 2√2·300 / (2·4000 + 1) = 0.10605 mm.
    EXPECT_NEAR(predictedMedMm(4000, 300, 0.0), 2 * std::sqrt(2.0) * 300 / 8001, 1e-12);
    // θ = 10°: cos − sin = 0.81116; MED = 2√2·300·0.98481 / (8000·0.81116 + 1).
    const double t = geometry::degToRad(10);
    EXPECT_NEAR(predictedMedMm(4000, 300, t),
                2 * std::sqrt(2.0) * 300 * std::cos(t) / (8000 * (std::cos(t) - std::sin(t)) + 1), 1e-12);
    EXPECT_TRUE(std::isinf(predictedMedMm(4000, 300, geometry::degToRad(46))));
    // Inverse: the largest θ for MED 0.2 mm gives back 0.2 mm.
    const double theta = maxViewAngleRad(4000, 300, 0.2);
    EXPECT_GT(theta, 0.3);
    EXPECT_NEAR(predictedMedMm(4000, 300, theta), 0.2, 1e-9);
    EXPECT_EQ(maxViewAngleRad(4000, 300, 0.05), 0.0); // below the θ = 0 MED
}

} // namespace
} // namespace hg::plan
