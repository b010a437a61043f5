// The fixture's motion model and the predicted cycle time (docs/fixture.md
// "Motion model", docs/planning.md "Cycle time") against hand-worked moves:
// the triangular and the trapezoidal profile, two axes moving together, an
// order where the least distance is not the least time, and the simulated
// line's five views on its station.
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/fixture_motion.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/plan/cycle_time.h"

#include <cmath>
#include <gtest/gtest.h>
#include <regex>

namespace hg::plan {
namespace {

using geometry::AxisMotion;
using geometry::FixtureMotion;

/// A rotation/declination fixture with the given axes and no station settle or grab.
FixtureMotion motion(AxisMotion rotation, AxisMotion declination)
{
    FixtureMotion m;
    m.type = FixtureType::RotationDeclination;
    rotation.name = "rotation";
    declination.name = "declination";
    m.axes = {rotation, declination};
    m.settleS = 0.0;
    m.grabS = 0.0;
    return m;
}

TEST(FixtureMotion, ShortMoveIsTriangular)
{
    // 10° at 90 °/s, 360 °/s²: v²/a = 22.5° > 10°, so the axis never cruises:
    // t = 2·sqrt(d/a) = 2·sqrt(10/360) = 1/3 s. The still declination settles in 0.
    const auto m = motion({"", 90, 360, 0.0}, {"", 45, 180, 0.0});
    EXPECT_NEAR(m.moveSeconds({0, 0, 0}, {10, 0, 0}), 1.0 / 3.0, 1e-12);
    EXPECT_NEAR(m.moveSeconds({10, 0, 0}, {0, 0, 0}), 1.0 / 3.0, 1e-12); // either direction
}

TEST(FixtureMotion, LongMoveIsTrapezoidal)
{
    // 45° at 90 °/s, 360 °/s²: d ≥ v²/a, t = d/v + v/a = 0.5 + 0.25 = 0.75 s.
    const auto m = motion({"", 90, 360, 0.0}, {"", 45, 180, 0.0});
    EXPECT_NEAR(m.moveSeconds({-20, 0, 0}, {25, 0, 0}), 0.75, 1e-12);
    // At d = v²/a = 22.5° both profiles agree: 2·sqrt(22.5/360) = 22.5/90 + 90/360 = 0.5 s.
    EXPECT_NEAR(m.moveSeconds({0, 0, 0}, {22.5, 0, 0}), 0.5, 1e-12);
    EXPECT_NEAR(m.moveSeconds({0, 0, 0}, {22.5 - 1e-9, 0, 0}), 0.5, 1e-9);
}

TEST(FixtureMotion, AxesMoveTogetherAndTheLastToSettleEndsTheMove)
{
    // Rotation 45°: 0.75 s + settle 0.01 = 0.76 s. Declination 10° at 45 °/s,
    // 180 °/s² (v²/a = 11.25° > 10°): 2·sqrt(10/180) = 0.471405 s + settle 0.05.
    auto m = motion({"", 90, 360, 0.01}, {"", 45, 180, 0.05});
    const FixturePose from{0, 0, 0}, to{45, 10, 0};
    const auto axes = m.axisSeconds(from, to);
    ASSERT_EQ(axes.size(), 2u);
    EXPECT_NEAR(axes[0], 0.76, 1e-12);
    EXPECT_NEAR(axes[1], 2 * std::sqrt(10.0 / 180.0) + 0.05, 1e-12);
    EXPECT_NEAR(m.moveSeconds(from, to), 0.76, 1e-12); // the rotation's
    // With a long declination settle (0.4 s) the shorter profile ends the move last: 0.871405 s.
    m.axes[1].settleS = 0.4;
    EXPECT_NEAR(m.moveSeconds(from, to), 2 * std::sqrt(10.0 / 180.0) + 0.4, 1e-12);
}

TEST(CycleTime, LeastTimeIsNotLeastDistance)
{
    // A fast turntable (360 °/s, 3600 °/s²) and a slow tilt (10 °/s, 20 °/s²),
    // no settle. From home A = rotation 100°, B = declination 20°:
    //   distance (larger axis move): A then B 100 + 100 = 200°, B then A 20 + 100 = 120°;
    //   time: rotation 100° (≥ v²/a = 36°) 100/360 + 0.1 = 0.377778 s,
    //         declination 20° (≥ v²/a = 5°) 20/10 + 0.5 = 2.5 s, so
    //   A then B 0.377778 + max(0.377778, 2.5) = 2.877778 s, B then A 2.5 + 2.5 = 5 s.
    const auto m = motion({"", 360, 3600, 0.0}, {"", 10, 20, 0.0});
    const std::vector<FixturePose> poses{{0, 20, 0}, {100, 0, 0}}; // B, A
    const FixturePose home{0, 0, 0};
    EXPECT_EQ(orderForTravel(poses, FixtureType::RotationDeclination, home), (std::vector<std::size_t>{0, 1}));
    const auto order = orderForTime(poses, m, home);
    EXPECT_EQ(order, (std::vector<std::size_t>{1, 0}));
    EXPECT_NEAR(predictCycleTime({poses[1], poses[0]}, m, home).totalS, 100.0 / 360 + 0.1 + 2.5 + kInspectionSeconds,
                1e-12);
    EXPECT_NEAR(predictCycleTime(poses, m, home).totalS, 5.0 + kInspectionSeconds, 1e-12);
}

TEST(CycleTime, TwelvePosesOnALineInOrder)
{
    // Beyond 8 poses the heuristic (nearest neighbour, 2-opt) still finds the
    // obvious best: poses on one axis visited outwards from home.
    const auto m = motion({"", 90, 360, 0.05}, {"", 45, 180, 0.05});
    std::vector<FixturePose> poses;
    for (int k : {7, 3, 11, 1, 9, 5, 12, 2, 8, 4, 10, 6}) poses.push_back({10.0 * k, 0, 0});
    const auto order = orderForTime(poses, m, {0, 0, 0});
    ASSERT_EQ(order.size(), poses.size());
    for (std::size_t i = 1; i < order.size(); ++i)
        EXPECT_LT(poses[order[i - 1]].rotationDeg, poses[order[i]].rotationDeg);
}

TEST(CycleTime, SumsMovesSettlesGrabsAndTheInspection)
{
    auto m = motion({"", 90, 360, 0.0}, {"", 45, 180, 0.0});
    m.settleS = 0.02;
    m.grabS = 0.03;
    // Moves 1/3 s (10°, triangular) and 0.75 s (45°, trapezoidal); 2 settles, 2 grabs, 1 ms.
    const auto c = predictCycleTime({{10, 0, 0}, {55, 0, 0}}, m, {0, 0, 0});
    ASSERT_EQ(c.moves.size(), 2u);
    EXPECT_NEAR(c.moves[0].seconds, 1.0 / 3.0, 1e-12);
    EXPECT_NEAR(c.moves[1].seconds, 0.75, 1e-12);
    EXPECT_NEAR(c.moves[1].distance, 45.0, 1e-12);
    EXPECT_NEAR(c.settlesS, 0.04, 1e-12);
    EXPECT_NEAR(c.grabsS, 0.06, 1e-12);
    EXPECT_NEAR(c.totalS, 1.0 / 3.0 + 0.75 + 0.04 + 0.06 + 0.001, 1e-12);
}

TEST(CycleTime, TheSimulatedLinesViews)
{
    // config/sim/station.yaml: no fixture.motion axes, so the simulated drive's:
    // the Modbus simulator moves at the speed registers' 360 and 180 °/s (below
    // its max_speed 720 and 360), 3600 and 1800 °/s², settle 0.01 s per axis;
    // fixture.motion.settle_s 0.02 (the daemon's sequencer.settle_s), camera.grab_s.
    const auto station = geometry::loadStation(hgtest::sourceDir() / "config/sim/station.yaml");
    const auto poses = geometry::loadPoses(hgtest::sourceDir() / "config/sim/stepped-block-views.yaml");
    const auto m = geometry::stationMotion(station);
    EXPECT_EQ(m.source, "fixture.driver.simulator");
    ASSERT_EQ(m.axes.size(), 2u);
    EXPECT_EQ(m.axes[0].speed, 360.0);
    EXPECT_EQ(m.axes[1].speed, 180.0);
    EXPECT_EQ(m.axes[0].acceleration, 3600.0);
    EXPECT_EQ(m.axes[1].acceleration, 1800.0);
    EXPECT_EQ(m.settleS, 0.02);
    EXPECT_EQ(m.grabS, 0.01);
    const auto c = predictCycleTime(poses, m, homePose(station.fixture));
    ASSERT_EQ(c.moves.size(), 5u);
    // home → (0, 2.1506): declination 2.1506° < 18° = v²/a: 2·sqrt(2.1506/1800) + 0.01 = 0.079131 s.
    EXPECT_NEAR(c.moves[0].seconds, 0.079131, 1e-6);
    // → (-92.886, 5): rotation 92.886° ≥ 36°: 92.886/360 + 0.1 + 0.01 = 0.368018 s.
    EXPECT_NEAR(c.moves[1].seconds, 0.368018, 1e-6);
    // → (-4.4985, 15): rotation 88.388°: 0.355522 s (declination 10°: 0.159071 s).
    EXPECT_NEAR(c.moves[2].seconds, 0.355522, 1e-6);
    EXPECT_NEAR(c.moves[2].axisSeconds[1], 2 * std::sqrt(10.0 / 1800) + 0.01, 1e-9);
    // → (87.003, 15): rotation 91.501°: 0.364170 s.
    EXPECT_NEAR(c.moves[3].seconds, 0.364170, 1e-6);
    // → (175.70, 0): rotation 88.696°: 0.356378 s (declination 15°: 0.192574 s).
    EXPECT_NEAR(c.moves[4].seconds, 0.356378, 1e-6);
    EXPECT_NEAR(c.movesS, 1.523219, 1e-6);
    EXPECT_NEAR(c.settlesS, 5 * 0.02, 1e-12);
    EXPECT_NEAR(c.grabsS, 5 * 0.01, 1e-12);
    EXPECT_NEAR(c.totalS, 1.523219 + 0.1 + 0.05 + 0.001, 1e-6);
    // The next part starts at the last view: the first move turns 175.70° back,
    // 175.70/360 + 0.1 + 0.01 = 0.598052 s instead of 0.079131 s.
    const auto next = predictCycleTime(poses, m, poses.back());
    EXPECT_NEAR(next.movesS - c.movesS, 0.598052 - 0.079131, 1e-6);
}

geometry::Station stationWith(const std::string& fixtureKeys, const std::string& cameraKeys = "")
{
    return hgtest::station({.cameraKeys = cameraKeys, .fixtureKeys = fixtureKeys});
}

TEST(FixtureMotion, StationKeysAndFallbacks)
{
    // No driver, no motion: the simulator's defaults (docs/fixture.md).
    auto m = geometry::stationMotion(stationWith(""));
    EXPECT_EQ(m.source, "defaults");
    EXPECT_EQ(m.axes[0].speed, 90.0);
    EXPECT_EQ(m.axes[1].acceleration, 180.0);
    EXPECT_EQ(m.settleS, 0.05);
    EXPECT_EQ(m.grabS, 0.0);
    // fixture.motion overrides what it gives; the rest is the driver's simulator.
    m = geometry::stationMotion(
        stationWith("  motion:\n    rotation: {speed_deg_s: 200, acceleration_deg_s2: 800, settle_s: 0.002}\n"
                    "    settle_s: 0.03\n"
                    "  driver:\n    backend: sim\n    simulator:\n      axes:\n"
                    "        declination: {max_speed: 30, acceleration: 60, settle_s: 0.1}\n",
                    "  grab_s: 0.015\n"));
    EXPECT_EQ(m.source, "fixture.motion");
    EXPECT_EQ(m.axes[0].speed, 200.0);
    EXPECT_EQ(m.axes[0].acceleration, 800.0);
    EXPECT_EQ(m.axes[0].settleS, 0.002);
    EXPECT_EQ(m.axes[1].speed, 30.0);
    EXPECT_EQ(m.axes[1].acceleration, 60.0);
    EXPECT_EQ(m.axes[1].settleS, 0.1);
    EXPECT_EQ(m.settleS, 0.03);
    EXPECT_EQ(m.grabS, 0.015);
    // Without grab_s the camera's exposure is the grab's floor.
    m = geometry::stationMotion(stationWith("", "  driver: {backend: sim, exposure_us: 8000}\n"));
    EXPECT_NEAR(m.grabS, 0.008, 1e-15);
    // A rail.
    m = geometry::stationMotion(
        hgtest::station({.fixtureType = FixtureType::Rail, .fixtureKeys = "  motion:\n    rail: {speed_mm_s: 250}\n"}));
    ASSERT_EQ(m.axes.size(), 1u);
    EXPECT_EQ(m.axes[0].speed, 250.0);
    EXPECT_EQ(m.axes[0].acceleration, 500.0);
}

std::string loadError(const std::string& fixtureKeys)
{
    try {
        (void)stationWith(fixtureKeys);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(FixtureMotion, BadKeysAreNamedWhenTheStationIsLoaded)
{
    auto msg = loadError("  motion:\n    rail: {speed_mm_s: 10}\n");
    EXPECT_TRUE(std::regex_search(msg, std::regex("^station\\.yaml:[0-9]+: .*fixture\\.motion\\.rail"))) << msg;
    EXPECT_NE(msg.find("no axis 'rail'"), std::string::npos) << msg;
    msg = loadError("  motion:\n    rotation: {speed_mm_s: 10}\n");
    EXPECT_NE(msg.find("fixture.motion.rotation.speed_mm_s"), std::string::npos) << msg;
    msg = loadError("  motion:\n    rotation: {speed_deg_s: 0}\n");
    EXPECT_NE(msg.find("fixture.motion.rotation.speed_deg_s"), std::string::npos) << msg;
    msg = loadError("  motion:\n    settle_s: -1\n");
    EXPECT_NE(msg.find("fixture.motion.settle_s"), std::string::npos) << msg;
}

} // namespace
} // namespace hg::plan
