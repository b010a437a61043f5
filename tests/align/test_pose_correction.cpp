// Planned poses corrected for the measured seat (docs/alignment.md, "Poses
// corrected for the seat"): seats the fixture's own axes absorb exactly,
// worked out by hand, and random seats, judged by the direction of sight the
// fixture's kinematics (docs/contracts.md §2) give at the corrected pose.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hgtest/station.h"
#include "hullgauge/align/pose_correction.h"

namespace {

using hg::align::correctPose;
using hg::align::sightErrorDeg;
using hg::geometry::FixtureKinematics;
using hg::geometry::FixturePose;
using hg::geometry::RigidTransform;
using hg::geometry::Vec3;

// The tests' station: the camera 300 mm away on the part's -y side, a
// turntable about z turning [-180, 180]°, tilted about x within [0, 60]°.
FixtureKinematics turntable()
{
    return hgtest::station().fixture;
}

RigidTransform turnAbout(const Vec3& axis, const Vec3& point, double deg)
{
    RigidTransform r = RigidTransform::rotation(axis, deg);
    r.t = point - r.R * point;
    return r;
}

TEST(PoseCorrection, AYawAboutTheTurntableAxisIsTakenOffTheRotation)
{
    // Seat: the part turned ρ about the turntable axis. The camera centre seen
    // from the part is Rz(−(θ + ρ))·c(δ): the turntable at θ − ρ sees the part
    // as the planned θ sees the drawn part, exactly.
    const auto fixture = turntable();
    const double rho = 0.37;
    const RigidTransform seat = turnAbout(Vec3::UnitZ(), Vec3::Zero(), rho);
    for (const FixturePose planned : {FixturePose{0, 2.15}, FixturePose{-92.9, 5}, FixturePose{87, 15}}) {
        const auto c = correctPose(fixture, planned, seat, Vec3(0, 0, 15));
        EXPECT_TRUE(c.corrected);
        EXPECT_FALSE(c.limited);
        EXPECT_NEAR(c.pose.rotationDeg, planned.rotationDeg - rho, 1e-9);
        EXPECT_NEAR(c.pose.declinationDeg, planned.declinationDeg, 1e-9);
        EXPECT_LT(c.sightErrorAfterDeg, 1e-7);
        // From the planned pose the line of sight is off by the turn projected across it.
        EXPECT_GT(c.sightErrorBeforeDeg, 0.3);
    }
}

TEST(PoseCorrection, ATiltAboutTheDeclinationAxisIsTakenOffTheDeclination)
{
    // At rotation 0 the camera centre is Rx(−δ)·(0, −d, 0); the part tilted τ
    // about x sees it at Rx(−(δ + τ))·(0, −d, 0): the declination δ − τ.
    const auto fixture = turntable();
    const RigidTransform seat = turnAbout(Vec3::UnitX(), Vec3::Zero(), 0.25);
    const auto c = correctPose(fixture, FixturePose{0, 15}, seat, Vec3::Zero());
    EXPECT_TRUE(c.corrected);
    EXPECT_NEAR(c.pose.rotationDeg, 0.0, 1e-9);
    EXPECT_NEAR(c.pose.declinationDeg, 15 - 0.25, 1e-9);
    EXPECT_LT(c.sightErrorAfterDeg, 1e-7);
    EXPECT_NEAR(c.sightErrorBeforeDeg, 0.25, 1e-9);
}

TEST(PoseCorrection, TheEndOfTheDeclinationRangeStopsATiltCorrection)
{
    const auto fixture = turntable(); // declination [0, 60]
    // Tilted −0.3°: the declination 0 + 0.3 is within range.
    auto c = correctPose(fixture, FixturePose{0, 0}, turnAbout(Vec3::UnitX(), Vec3::Zero(), -0.3), Vec3::Zero());
    EXPECT_TRUE(c.corrected);
    EXPECT_NEAR(c.pose.declinationDeg, 0.3, 1e-9);
    // Tilted +0.3°: it would need −0.3°. The turntable cannot tilt the sight
    // at rotation 0 either, so the planned pose is kept, the error reported.
    c = correctPose(fixture, FixturePose{0, 0}, turnAbout(Vec3::UnitX(), Vec3::Zero(), 0.3), Vec3::Zero());
    EXPECT_FALSE(c.corrected);
    EXPECT_TRUE(c.limited);
    EXPECT_EQ(c.pose, (FixturePose{0, 0}));
    EXPECT_NEAR(c.sightErrorAfterDeg, 0.3, 1e-9);
    // Yawed and tilted: the yaw is still taken off, the tilt only as far as the range goes.
    const RigidTransform both =
        turnAbout(Vec3::UnitZ(), Vec3::Zero(), 0.2) * turnAbout(Vec3::UnitX(), Vec3::Zero(), 0.3);
    c = correctPose(fixture, FixturePose{0, 0}, both, Vec3::Zero());
    EXPECT_TRUE(c.corrected);
    EXPECT_TRUE(c.limited);
    EXPECT_EQ(c.pose.declinationDeg, 0.0);
    // Before: the yaw and the tilt across each other, √(0.2² + 0.3²) ≈ 0.36°; after: the tilt alone.
    EXPECT_NEAR(c.sightErrorBeforeDeg, 0.3606, 1e-3);
    EXPECT_NEAR(c.sightErrorAfterDeg, 0.3, 1e-3);
}

TEST(PoseCorrection, ARotationPastHalfATurnWrapsIntoTheRange)
{
    const auto fixture = turntable(); // rotation [-180, 180]
    const auto c =
        correctPose(fixture, FixturePose{179.9, 10}, turnAbout(Vec3::UnitZ(), Vec3::Zero(), -0.3), Vec3::Zero());
    EXPECT_TRUE(c.corrected);
    EXPECT_NEAR(c.pose.rotationDeg, 180.2 - 360.0, 1e-9);
    EXPECT_NEAR(c.pose.declinationDeg, 10, 1e-9);
    EXPECT_LT(c.sightErrorAfterDeg, 1e-7);
}

TEST(PoseCorrection, ARailTakesAShiftAlongItsTravel)
{
    hgtest::StationOptions options;
    options.fixtureType = hg::geometry::FixtureType::Rail; // travel along part x, [-100, 100] mm
    const FixtureKinematics rail = hgtest::station(options).fixture;
    FixturePose planned;
    planned.railMm = 40;
    // Shifted 0.4 mm along the travel: the rail 0.4 mm short of the plan sees it as planned.
    const RigidTransform seat = RigidTransform::translation(Vec3(0.4, 0, 0));
    const auto c = correctPose(rail, planned, seat, Vec3::Zero());
    EXPECT_TRUE(c.corrected);
    EXPECT_NEAR(c.pose.railMm, 40 - 0.4, 1e-9);
    EXPECT_LT(c.sightErrorAfterDeg, 1e-7);
    // A turn about the vertical swings the line of sight sideways, along the
    // travel: the rail slides the part until the target is seen along the
    // planned line again. A tilt about the travel it cannot take.
    const auto turned = correctPose(rail, planned, turnAbout(Vec3::UnitZ(), Vec3::Zero(), 0.3), Vec3::Zero());
    EXPECT_TRUE(turned.corrected);
    EXPECT_LT(turned.sightErrorAfterDeg, 1e-7);
    const auto tilted = correctPose(rail, planned, turnAbout(Vec3::UnitX(), Vec3::Zero(), 0.3), Vec3::Zero());
    EXPECT_FALSE(tilted.corrected);
    // The line of sight (−40, −300, 0) turned 0.3° about x moves by 0.3° · sin of its angle to x.
    EXPECT_NEAR(tilted.sightErrorAfterDeg, 0.3 * 300 / std::hypot(300.0, 40.0), 1e-6);
}

TEST(PoseCorrection, ThePartAsDrawnKeepsThePlannedPose)
{
    const auto c =
        correctPose(turntable(), FixturePose{-4.49854756206, 15}, RigidTransform::identity(), Vec3(0, 0, 15));
    EXPECT_FALSE(c.corrected);
    EXPECT_EQ(c.pose, (FixturePose{-4.49854756206, 15}));
    EXPECT_EQ(c.sightErrorBeforeDeg, 0.0);
}

TEST(PoseCorrection, RandomSeatsAreSeenFromThePlannedDirectionAfterCorrection)
{
    // Seats within 0.5 mm and 0.5° about random axes through the reference
    // point; poses away from the ends of the ranges. Two axes match the two
    // angles of a direction of sight: the corrected pose must restore it.
    const auto fixture = turntable();
    const Vec3 reference(0, 0, 15);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> g(0.0, 1.0);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 200; ++i) {
        const Vec3 axis = Vec3(g(rng), g(rng), g(rng)).normalized();
        const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
        RigidTransform seat = turnAbout(axis, reference, 0.5 * u(rng));
        seat.t += 0.5 * u(rng) * dir;
        const FixturePose planned{-170 + 340 * u(rng), 5 + 50 * u(rng)};
        const auto c = correctPose(fixture, planned, seat, reference);
        ASSERT_TRUE(c.corrected) << i;
        EXPECT_LT(c.sightErrorAfterDeg, 1e-6) << i;
        // Judged independently of the solver: the kinematics at the commanded pose.
        EXPECT_NEAR(sightErrorDeg(fixture, planned, c.pose, seat, reference), c.sightErrorAfterDeg, 1e-12);
        // A seat this small is taken up by a small move.
        EXPECT_LT(std::abs(c.pose.rotationDeg - planned.rotationDeg), 2.0) << i;
        EXPECT_LT(std::abs(c.pose.declinationDeg - planned.declinationDeg), 1.0) << i;
    }
}

} // namespace
