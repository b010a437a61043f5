// Re-mastering due (docs/mastering.md, "Re-mastering due"), each cause on a
// clock moved by hand: the age of the set, the production parts judged with
// it, a new calibration, a new release of the program and the part's
// temperature moved from the master's; production refused past the grace
// count while master and study cycles run on; a new set clears it.
#include "hgtest/manual_clock.h"
#include "hullgauge/station/mastering_due.h"

#include <gtest/gtest.h>

namespace hg::station {
namespace {

using namespace std::chrono_literals;
using Cause = MasteringDueCause;
using P = CyclePurpose;

/// The set in force: computed now on release 3 with the station's calibration "cal-A".
MasteringInForce setNow(const Clock& clock, const std::string& id = "p1-v3-a")
{
    return {id, clock.wallMs(), 3, "cal-A"};
}

TEST(MasteringDue, DueByAgeOnceTheSetIsEightHoursOld)
{
    hgtest::ManualClock clock;
    MasteringDue due({.maxAge = 8h}, clock, "cal-A");
    due.programIs(3);
    due.mastered(setNow(clock));
    clock.advance(8h - 1ms);
    EXPECT_EQ(due.cause(), Cause::None);
    clock.advance(1ms);
    EXPECT_EQ(due.cause(), Cause::Age);
    EXPECT_EQ(enumName(due.cause()), "age");
}

TEST(MasteringDue, DueByCountAfterTheThousandthProductionPart)
{
    hgtest::ManualClock clock;
    MasteringDue due({.maxParts = 1000}, clock, "cal-A");
    due.programIs(3);
    due.mastered(setNow(clock));
    for (int i = 0; i < 999; ++i) due.judged(P::Production);
    // Master and study cycles are not production parts.
    for (int i = 0; i < 50; ++i) due.judged(P::Master), due.judged(P::Study);
    EXPECT_EQ(due.cause(), Cause::None);
    due.judged(P::Production);
    EXPECT_EQ(due.cause(), Cause::Parts);
}

TEST(MasteringDue, DueByANewCalibrationAndItStaysDueIfTheOldOneIsRestored)
{
    hgtest::ManualClock clock;
    MasteringDue due({}, clock, "cal-A");
    due.programIs(3);
    due.mastered(setNow(clock));
    EXPECT_FALSE(due.due());
    due.calibrationIs("cal-B");
    EXPECT_EQ(due.cause(), Cause::Calibration);
    due.calibrationIs("cal-A");
    EXPECT_EQ(due.cause(), Cause::Calibration);
    // Off in the policy: a new calibration alone does not make it due.
    MasteringDue off({.onCalibrationChange = false}, clock, "cal-A");
    off.programIs(3);
    off.mastered(setNow(clock));
    off.calibrationIs("cal-B");
    EXPECT_FALSE(off.due());
}

TEST(MasteringDue, DueByANewReleaseOfTheProgramAndWithoutAnySet)
{
    hgtest::ManualClock clock;
    MasteringDue due({}, clock, "cal-A");
    due.programIs(3);
    EXPECT_EQ(due.cause(), Cause::NotMastered);
    due.mastered(setNow(clock));
    EXPECT_FALSE(due.due());
    due.programIs(4);
    EXPECT_EQ(due.cause(), Cause::Program);
    EXPECT_EQ(enumName(due.cause()), "program_changed");
    // A set mastered on release 4 clears it.
    due.mastered({"p1-v4-a", clock.wallMs(), 4, "cal-A"});
    EXPECT_FALSE(due.due());
}

TEST(MasteringDue, ProductionRefusedPastTheGraceCountMasterAndStudyCyclesStillAccepted)
{
    hgtest::ManualClock clock;
    MasteringDue due({.maxAge = 24h, .graceCycles = 3}, clock, "cal-A");
    due.programIs(3);
    due.mastered(setNow(clock));
    for (int i = 0; i < 10; ++i) {
        EXPECT_TRUE(due.admits(P::Production));
        due.judged(P::Production);
    }
    EXPECT_EQ(due.graceLeft(), 3u);
    clock.advance(24h);
    ASSERT_TRUE(due.due());
    // Three production cycles of grace, then refused.
    for (std::uint64_t left = 3; left > 0; --left) {
        EXPECT_EQ(due.graceLeft(), left);
        EXPECT_TRUE(due.admits(P::Production));
        due.judged(P::Production);
    }
    EXPECT_EQ(due.graceLeft(), 0u);
    EXPECT_FALSE(due.admits(P::Production));
    EXPECT_TRUE(due.admits(P::Master));
    EXPECT_TRUE(due.admits(P::Study));
    // The master measured again: its set clears the due and production runs.
    for (int i = 0; i < 5; ++i) due.judged(P::Master);
    due.mastered(setNow(clock, "p1-v3-b"));
    EXPECT_FALSE(due.due());
    EXPECT_TRUE(due.admits(P::Production));
    EXPECT_EQ(due.graceLeft(), 3u);
    // Its age counts from its own time.
    clock.advance(24h - 1ms);
    EXPECT_FALSE(due.due());
}

TEST(MasteringDue, WithoutGraceTheFirstProductionTriggerAfterTheDueIsRefused)
{
    hgtest::ManualClock clock;
    MasteringDue due({.maxParts = 2}, clock, "cal-A");
    due.programIs(3);
    due.mastered(setNow(clock));
    due.judged(P::Production);
    EXPECT_TRUE(due.admits(P::Production));
    due.judged(P::Production);
    EXPECT_EQ(due.cause(), Cause::Parts);
    EXPECT_FALSE(due.admits(P::Production));
    EXPECT_TRUE(due.admits(P::Master));
}

// The temperature step (docs/mastering.md, "Re-mastering due"): 2 °C from the
// set's 20.0 °C. A part at 21.9 °C (a step of 1.9) is within it, at 22.1 °C
// (2.1) it is due; back at 20.0 °C it stays due until a new set.
TEST(MasteringDue, DueWhenThePartsTemperatureMovesMoreThanTheStepFromTheSets)
{
    hgtest::ManualClock clock;
    MasteringDue due({.graceCycles = 1, .maxTemperatureStepC = 2.0}, clock, "cal-A");
    due.programIs(3);
    MasteringInForce set = setNow(clock);
    set.temperatureC = 20.0;
    due.mastered(set);
    due.judged(P::Production);
    due.temperatureIs(21.9);
    EXPECT_EQ(due.cause(), Cause::None);
    due.judged(P::Production);
    due.temperatureIs(18.1); // 1.9 below
    EXPECT_EQ(due.cause(), Cause::None);
    clock.advance(1h);
    due.judged(P::Production);
    due.temperatureIs(22.1);
    EXPECT_EQ(due.cause(), Cause::Temperature);
    EXPECT_EQ(enumName(due.cause()), "temperature");
    // The part that made it due used none of the grace.
    EXPECT_EQ(due.graceLeft(), 1u);
    due.judged(P::Production);
    due.temperatureIs(20.0);
    EXPECT_EQ(due.cause(), Cause::Temperature);
    EXPECT_FALSE(due.admits(P::Production));
    EXPECT_TRUE(due.admits(P::Master));
    // The master measured at 22.0 °C: its set clears the due and is the new reference.
    MasteringInForce warm = setNow(clock, "p1-v3-b");
    warm.temperatureC = 22.0;
    due.mastered(warm);
    EXPECT_FALSE(due.due());
    due.judged(P::Production);
    due.temperatureIs(23.9); // 1.9 above 22.0
    EXPECT_FALSE(due.due());
    due.judged(P::Production);
    due.temperatureIs(19.9); // 2.1 below 22.0
    EXPECT_EQ(due.cause(), Cause::Temperature);
}

// A set without its masters' temperature takes the first reading after it came
// into force as its reference; without a step the temperature never makes it due.
TEST(MasteringDue, ASetWithoutATemperatureIsReferredToTheFirstReadingWithIt)
{
    hgtest::ManualClock clock;
    MasteringDue due({.maxTemperatureStepC = 2.0}, clock, "cal-A");
    due.programIs(3);
    due.temperatureIs(30.0); // no set yet: not a reference
    due.mastered(setNow(clock));
    EXPECT_FALSE(due.due());
    due.judged(P::Study);
    due.temperatureIs(24.0); // the reference: master and study cycles read the temperature too
    due.judged(P::Production);
    due.temperatureIs(25.9);
    EXPECT_FALSE(due.due());
    due.judged(P::Production);
    due.temperatureIs(26.1);
    EXPECT_EQ(due.cause(), Cause::Temperature);

    MasteringDue off({}, clock, "cal-A");
    off.programIs(3);
    MasteringInForce set = setNow(clock);
    set.temperatureC = 20.0;
    off.mastered(set);
    off.temperatureIs(35.0);
    EXPECT_FALSE(off.due());
}

// A set coming into force again with what the result store holds judged with
// it (a restart): the count goes on from there, and the grace used is the
// parts judged after the count made it due (the 5th of 5 is not one of them)
// or after the age did, whichever is more.
TEST(MasteringDue, TheCountsGoOnFromThePartsAlreadyJudgedWithTheSet)
{
    hgtest::ManualClock clock;
    // 4 of 5 judged: the 5th makes it due with the whole grace of 2; 2 more use it up.
    MasteringDue due({.maxParts = 5, .graceCycles = 2}, clock, "cal-A");
    due.programIs(3);
    due.mastered(setNow(clock), {.parts = 4});
    EXPECT_FALSE(due.due());
    due.judged(P::Production);
    EXPECT_EQ(due.cause(), Cause::Parts);
    EXPECT_EQ(due.graceLeft(), 2u);
    due.judged(P::Production);
    due.judged(P::Production);
    EXPECT_FALSE(due.admits(P::Production));

    // 6 of 5 judged: due, one part of the grace used.
    MasteringDue past({.maxParts = 5, .graceCycles = 2}, clock, "cal-A");
    past.programIs(3);
    past.mastered(setNow(clock), {.parts = 6});
    EXPECT_EQ(past.cause(), Cause::Parts);
    EXPECT_EQ(past.graceLeft(), 1u);

    // Past the age with 3 parts started since then: a grace of 5 has 2 left.
    MasteringDue aged({.maxAge = 8h, .graceCycles = 5}, clock, "cal-A");
    aged.programIs(3);
    const auto set = setNow(clock);
    clock.advance(9h);
    aged.mastered(set, {.parts = 40, .partsPastAge = 3});
    EXPECT_EQ(aged.cause(), Cause::Age);
    EXPECT_EQ(aged.graceLeft(), 2u);
    // Both: the larger use of the grace holds (the earlier of the two made it due).
    MasteringDue both({.maxAge = 8h, .maxParts = 38, .graceCycles = 5}, clock, "cal-A");
    both.programIs(3);
    both.mastered(set, {.parts = 40, .partsPastAge = 3});
    EXPECT_EQ(both.graceLeft(), 2u);
    both.mastered(set, {.parts = 40, .partsPastAge = 1});
    EXPECT_EQ(both.graceLeft(), 3u);
}

} // namespace
} // namespace hg::station
