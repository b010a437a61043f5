// Views for the seat chosen on the twin (docs/commissioning.md, "--fix"):
// the candidates a fixture offers, worked out by hand, and the choice on the
// simulated telecentric line, whose planned two views leave the seat open
// (docs/alignment.md, "Views for the seat"): the view chosen first, with the
// level view second, must measure the seat so that no landmark is moved
// beyond its U at other seats than those it was chosen at.
#include "hgtest/paths.h"
#include "hullgauge/commission/screen.h"
#include "hullgauge/commission/seat_views.h"
#include "hullgauge/plan/program_plan.h"

#include <gtest/gtest.h>
#include <iostream>

namespace hg::commission {
namespace {

using geometry::FixturePose;

TEST(SeatViewCandidates, ATurntableEvery45DegreesAt30And60AboveWithinItsRanges)
{
    geometry::FixtureKinematics turntable;
    turntable.rotationRangeDeg = {-180, 180};
    turntable.declinationRangeDeg = {0, 60};
    const std::vector<FixturePose> all = seatViewCandidates(turntable);
    ASSERT_EQ(all.size(), 16u);
    EXPECT_EQ(all.front(), (FixturePose{-135, 30}));
    EXPECT_EQ(all[7], (FixturePose{180, 30}));
    EXPECT_EQ(all.back(), (FixturePose{180, 60}));
    // A turntable of half a turn and a declination up to 40°: the turns clamp
    // to -90 (three of them, one kept) and 90 (three, one kept): -90, -45, 0,
    // 45, 90 at 30° and at 40°.
    turntable.rotationRangeDeg = {-90, 90};
    turntable.declinationRangeDeg = {0, 40};
    const std::vector<FixturePose> half = seatViewCandidates(turntable);
    ASSERT_EQ(half.size(), 10u);
    EXPECT_EQ(half.front(), (FixturePose{-90, 30}));
    EXPECT_EQ(half[4], (FixturePose{90, 30}));
    EXPECT_EQ(half.back(), (FixturePose{90, 40}));
}

TEST(SeatViewCandidates, ARailFivePlacesAcrossItsTravel)
{
    geometry::FixtureKinematics rail;
    rail.type = geometry::FixtureType::Rail;
    rail.railRangeMm = {20, 220};
    const std::vector<FixturePose> all = seatViewCandidates(rail);
    ASSERT_EQ(all.size(), 5u);
    for (int k = 0; k < 5; ++k) EXPECT_DOUBLE_EQ(all[static_cast<std::size_t>(k)].railMm, 20.0 + 50.0 * k);
}

TEST(ChooseSeatViews, OnTheTelecentricLineAViewThatMeasuresTheSeatComesFirst)
{
    const auto dir = hgtest::sourceDir() / "config/sim-telecentric";
    model::PartProgram program = model::loadPartProgram(dir / "stepped-block.yaml");
    program.alignment.seatViews.clear(); // the planner's two views alone
    const geometry::Station station = geometry::loadStation(dir / "station.yaml");
    const plan::ProgramPlan planned = plan::planProgram(program, station, {});
    ASSERT_TRUE(planned.plan.feasible);
    ASSERT_EQ(planned.plan.views.size(), 2u);
    const VerificationProblem problem = verificationProblem(program, station, planned.plan, *planned.capability);
    VerificationOptions options; // the twin's play: 80 % of the limits (0.32 mm, 0.32°)
    const SeatViewChoice choice = chooseSeatViews(problem, options, twinFrames(station, 1), 4);
    ASSERT_EQ(choice.seatViews.size(), 2u);
    EXPECT_EQ(choice.seatViews[1], planned.plan.views[0].pose);
    EXPECT_EQ(choice.trials.size(), 16u); // none of the candidates is the level view

    // Judged at 8 other seats: the seat test passes with the chosen views first.
    VerificationProblem seated = problem;
    seated.poses.insert(seated.poses.begin(), choice.seatViews[0]);
    seated.viewLandmarks.insert(seated.viewLandmarks.begin(), std::vector<std::string>{});
    options.seats = 8;
    options.defectMultiples = {};
    options.seed = 9;
    const VerificationReport r = verifyProgram(seated, options, twinFrames(station, 9));
    for (const Finding& f : r.findings) EXPECT_NE(f.test, "seat") << f.what;
    EXPECT_LT(r.seatErrorMaxShiftMm, 0.002);
    std::cout << "chosen first: rotation " << choice.seatViews[0].rotationDeg << "°, declination "
              << choice.seatViews[0].declinationDeg << "°; judged at 8 other seats: the seat within "
              << 1000.0 * r.seatErrorMaxShiftMm << " µm and " << r.seatErrorMaxRotationDeg << "°\n";
    for (const SeatViewTrial& t : choice.trials)
        std::cout << "  tried " << t.pose.rotationDeg << "/" << t.pose.declinationDeg << ": beyond U " << t.beyondU
                  << ", landmark error " << t.landmarkErrorMaxMm << " mm, seat " << 1000.0 * t.shiftMm << " µm "
                  << t.rotationDeg << "°\n";
}

} // namespace
} // namespace hg::commission
