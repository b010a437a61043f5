#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <thread>

#include "hgtest/manual_clock.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/simulation.h"

using namespace hg::drivers;
using hg::station::LampPattern;
using namespace std::chrono_literals;

namespace {

hg::ConfigNode section(const std::string& yaml)
{
    return hg::ConfigNode::parse(yaml, "station.yaml")["lamps"];
}

const char* kSim = R"(lamps:
  backend: sim
  chip: gpiochip0
  blink_period_s: 0.1
  green: LAMP_GREEN
  amber: {line: LAMP_AMBER}
  red: {offset: 7, active_low: true}
)";

/// The simulated lamps on a clock the test moves by hand: the timer thread
/// waits on it and tick() applies the phase at its now, so the blink pattern
/// is checked against hand-computed instants.
struct SteppedLamps {
    hgtest::ManualClock clock{hgtest::ManualClock::Sleeps::WaitForTheHand};
    SimulationControls controls;
    std::unique_ptr<Lamps> lamps = makeLamps(section(kSim), &controls, clock);
    SimLampsControl& sim = *controls.lamps;

    SteppedLamps()
    {
        EXPECT_TRUE(lamps->configure().ok());
        EXPECT_TRUE(lamps->activate().ok());
    }
    /// Advances the clock by `dt` and lets the driver step the blink.
    void after(std::chrono::milliseconds dt)
    {
        clock.advance(dt);
        EXPECT_TRUE(lamps->tick().ok());
    }
};

std::string inputErrorOf(const std::string& yaml)
{
    try {
        (void)makeLamps(section(yaml));
    } catch (const hg::InputError& e) {
        return e.what();
    }
    return "no error";
}

} // namespace

TEST(LampsConfig, ParsesNamesOffsetsPolarityAndPeriod)
{
    auto c = LampsConfig::parse(section(kSim));
    EXPECT_EQ(c.backend, "sim");
    EXPECT_EQ(c.chip, "gpiochip0");
    EXPECT_EQ(c.blinkPeriod, 100ms);
    EXPECT_EQ(c.lines[0].name.value_or(""), "LAMP_GREEN");
    EXPECT_FALSE(c.lines[0].activeLow);
    EXPECT_EQ(c.lines[1].name.value_or(""), "LAMP_AMBER");
    EXPECT_EQ(c.lines[2].offset.value_or(0), 7u);
    EXPECT_TRUE(c.lines[2].activeLow);
    EXPECT_EQ(c.lines[2].key, "lamps.red");
}

TEST(LampsConfig, SectionDefaultPolarityAndNumericShorthand)
{
    auto c = LampsConfig::parse(section("lamps: {backend: gpiod, chip: /dev/gpiochip1, active_low: true,"
                                        " green: 3, amber: 4, red: {offset: 5, active_low: false}}"));
    EXPECT_EQ(c.lines[0].offset.value_or(99), 3u);
    EXPECT_TRUE(c.lines[0].activeLow);
    EXPECT_TRUE(c.lines[1].activeLow);
    EXPECT_FALSE(c.lines[2].activeLow);
    EXPECT_EQ(c.blinkPeriod, 1000ms); // default
}

TEST(LampsConfig, ErrorsNameFileLineAndKey)
{
    EXPECT_EQ(inputErrorOf("lamps:\n  backend: relay\n  green: A\n  amber: B\n  red: C\n"),
              "station.yaml:2: lamps.backend: unknown lamp backend 'relay' (expected gpiod or sim)");
    EXPECT_NE(inputErrorOf("lamps: {backend: sim, green: A, amber: B}").find("lamps: missing required key 'red'"),
              std::string::npos);
    EXPECT_NE(inputErrorOf("lamps:\n  backend: sim\n  green: A\n  amber: 4\n  red: C\n")
                  .find("station.yaml:4: lamps.amber: a line given by offset needs 'lamps.chip'"),
              std::string::npos);
    EXPECT_NE(inputErrorOf("lamps: {backend: sim, green: A, amber: B, red: A}")
                  .find("lamps.red: line 'A' is already used by lamps.green"),
              std::string::npos);
    EXPECT_NE(inputErrorOf("lamps: {backend: sim, blink_period_s: 0.001, green: A, amber: B, red: C}")
                  .find("lamps.blink_period_s"),
              std::string::npos);
    EXPECT_NE(inputErrorOf("lamps: {backend: sim, green: {line: A, offset: 2}, amber: B, red: C}")
                  .find("lamps.green: give exactly one of"),
              std::string::npos);
    EXPECT_NE(inputErrorOf("lamps: {backend: sim, blink_period: 1, green: A, amber: B, red: C}").find("blink_period"),
              std::string::npos);
}

TEST(Lamps, CyclicCallsNeedTheDriverActive)
{
    SimulationControls controls;
    auto lamps = makeLamps(section(kSim), &controls);
    ASSERT_NE(controls.lamps, nullptr);
    EXPECT_EQ(lamps->show(LampPattern::Pass).code(), hg::StatusCode::NotAllowed);
    EXPECT_EQ(lamps->activate().code(), hg::StatusCode::NotAllowed);
    ASSERT_TRUE(lamps->configure().ok());
    EXPECT_TRUE(controls.lamps->linesRequested());
    auto r = lamps->set(Lamp::Red, LampState::On);
    EXPECT_EQ(r.code(), hg::StatusCode::NotAllowed);
    EXPECT_EQ(r.message(), "lamps: set red is not allowed while inactive (needs active)");
    EXPECT_EQ(lamps->configure().code(), hg::StatusCode::NotAllowed);
    ASSERT_TRUE(lamps->activate().ok());
    EXPECT_EQ(lamps->state(), LifecycleState::Active);
    EXPECT_TRUE(lamps->set(Lamp::Red, LampState::On).ok());
    EXPECT_EQ(lamps->cleanup().code(), hg::StatusCode::NotAllowed); // must deactivate first
}

TEST(Lamps, StationIndicationsFollowContracts)
{
    SteppedLamps l;
    struct Case {
        LampPattern what;
        bool green, amber, red;
    };
    for (auto c : {Case{LampPattern::Pass, true, false, false}, Case{LampPattern::Fail, false, false, true},
                   Case{LampPattern::Busy, false, true, false}, Case{LampPattern::Off, false, false, false}}) {
        ASSERT_TRUE(l.lamps->show(c.what).ok());
        EXPECT_EQ(l.sim.lit(Lamp::Green), c.green) << hg::enumName(c.what);
        EXPECT_EQ(l.sim.lit(Lamp::Amber), c.amber) << hg::enumName(c.what);
        EXPECT_EQ(l.sim.lit(Lamp::Red), c.red) << hg::enumName(c.what);
    }
    ASSERT_TRUE(l.lamps->show(LampPattern::Fault).ok());
    EXPECT_EQ(l.lamps->commanded(Lamp::Red), LampState::Blinking);
    EXPECT_EQ(l.lamps->commanded(Lamp::Amber), LampState::Blinking);
    EXPECT_EQ(l.lamps->commanded(Lamp::Green), LampState::Off);
    // Re-seat the part: amber blinks alone.
    ASSERT_TRUE(l.lamps->show(LampPattern::Reseat).ok());
    EXPECT_EQ(l.lamps->commanded(Lamp::Amber), LampState::Blinking);
    EXPECT_EQ(l.lamps->commanded(Lamp::Red), LampState::Off);
    EXPECT_EQ(l.lamps->commanded(Lamp::Green), LampState::Off);
    EXPECT_EQ(hg::enumName(LampPattern::Reseat), "reseat");
}

// docs/lamps.md's table, row by row, as the three lamps are commanded (green, amber, red).
TEST(Lamps, EachRowOfTheTableIsItsLampStates)
{
    using S = LampState;
    struct Row {
        LampPattern pattern;
        std::array<LampState, 3> states;
    };
    for (const Row& row :
         {Row{LampPattern::Pass, {S::On, S::Off, S::Off}}, Row{LampPattern::Fail, {S::Off, S::Off, S::On}},
          Row{LampPattern::Busy, {S::Off, S::On, S::Off}}, Row{LampPattern::Fault, {S::Off, S::Blinking, S::Blinking}},
          Row{LampPattern::Reseat, {S::Off, S::Blinking, S::Off}},
          Row{LampPattern::PassAttention, {S::On, S::On, S::Off}},
          Row{LampPattern::FailAttention, {S::Off, S::On, S::On}},
          Row{LampPattern::Refused, {S::Off, S::On, S::Blinking}}, Row{LampPattern::Off, {S::Off, S::Off, S::Off}}}) {
        EXPECT_EQ(lampStatesFor(row.pattern), row.states) << hg::enumName(row.pattern);
        SteppedLamps l;
        ASSERT_TRUE(l.lamps->show(row.pattern).ok());
        for (Lamp lamp : kAllLamps) {
            const auto i = static_cast<std::size_t>(lamp);
            EXPECT_EQ(l.lamps->commanded(lamp), row.states[i])
                << hg::enumName(row.pattern) << " " << hg::enumName(lamp);
            // Blinking lamps start lit (docs/lamps.md, "Lifecycle").
            EXPECT_EQ(l.sim.lit(lamp), row.states[i] != S::Off)
                << hg::enumName(row.pattern) << " " << hg::enumName(lamp);
        }
    }
}

// Refused: amber stays lit while red blinks, at the configured period.
TEST(Lamps, RefusedBlinksRedBesideASteadyAmber)
{
    SteppedLamps l; // blink period 100 ms
    ASSERT_TRUE(l.lamps->show(LampPattern::Refused).ok());
    EXPECT_TRUE(l.sim.lit(Lamp::Red));
    EXPECT_TRUE(l.sim.lit(Lamp::Amber));
    l.after(std::chrono::milliseconds(50));
    EXPECT_FALSE(l.sim.lit(Lamp::Red));
    EXPECT_TRUE(l.sim.lit(Lamp::Amber));
    EXPECT_FALSE(l.sim.lit(Lamp::Green));
    l.after(std::chrono::milliseconds(50));
    EXPECT_TRUE(l.sim.lit(Lamp::Red));
    EXPECT_TRUE(l.sim.lit(Lamp::Amber));
}

TEST(Lamps, ActiveLowLinesAreInverted)
{
    SteppedLamps l;
    // Red is active-low: dark means a high line.
    EXPECT_FALSE(l.sim.lit(Lamp::Red));
    EXPECT_TRUE(l.sim.lineLevel(Lamp::Red));
    EXPECT_FALSE(l.sim.lineLevel(Lamp::Green));
    ASSERT_TRUE(l.lamps->show(LampPattern::Fail).ok());
    EXPECT_TRUE(l.sim.lit(Lamp::Red));
    EXPECT_FALSE(l.sim.lineLevel(Lamp::Red));
}

TEST(Lamps, FaultBlinksRedAndAmberTogetherAtTheConfiguredPeriod)
{
    SteppedLamps l; // blink period 100 ms: lit for [0, 50) ms, dark for [50, 100) ms
    ASSERT_TRUE(l.lamps->show(LampPattern::Fault).ok());
    auto both = [&](bool lit) {
        return l.sim.lit(Lamp::Red) == lit && l.sim.lit(Lamp::Amber) == lit && !l.sim.lit(Lamp::Green);
    };
    EXPECT_TRUE(both(true)); // starts in the lit half
    const auto writes = l.sim.transitions();
    l.after(std::chrono::milliseconds(49));
    EXPECT_TRUE(both(true));
    EXPECT_EQ(l.sim.transitions(), writes); // nothing changed, nothing written
    l.after(std::chrono::milliseconds(1));  // 50 ms
    EXPECT_TRUE(both(false));
    l.after(std::chrono::milliseconds(49)); // 99 ms
    EXPECT_TRUE(both(false));
    l.after(std::chrono::milliseconds(1)); // 100 ms
    EXPECT_TRUE(both(true));
    l.after(std::chrono::milliseconds(150)); // 250 ms: the sixth half period
    EXPECT_TRUE(both(false));
    EXPECT_EQ(l.sim.transitions(), writes + 3);

    // Leaving the fault stops the blinking at once.
    ASSERT_TRUE(l.lamps->show(LampPattern::Busy).ok());
    const auto after = l.sim.transitions();
    for (int i = 0; i < 10; ++i) l.after(std::chrono::milliseconds(25));
    EXPECT_EQ(l.sim.transitions(), after);
    EXPECT_TRUE(l.sim.lit(Lamp::Amber));
    EXPECT_FALSE(l.sim.lit(Lamp::Red));
}

TEST(Lamps, ANewCommandKeepsTheBlinkPhaseAndRestartsItsHalfPeriod)
{
    SteppedLamps l;
    ASSERT_TRUE(l.lamps->set(Lamp::Red, LampState::Blinking).ok());
    l.after(std::chrono::milliseconds(60)); // dark half, 10 ms in
    ASSERT_FALSE(l.sim.lit(Lamp::Red));
    ASSERT_TRUE(l.lamps->set(Lamp::Green, LampState::On).ok()); // the dark half starts again now
    EXPECT_FALSE(l.sim.lit(Lamp::Red));
    l.after(std::chrono::milliseconds(49));
    EXPECT_FALSE(l.sim.lit(Lamp::Red));
    l.after(std::chrono::milliseconds(1));
    EXPECT_TRUE(l.sim.lit(Lamp::Red));
    EXPECT_TRUE(l.sim.lit(Lamp::Green));
}

TEST(Lamps, TheTimerThreadBlinksOnTheSteadyClock)
{
    SimulationControls controls;
    auto lamps = makeLamps(section(kSim), &controls); // the driver's own timer
    ASSERT_TRUE(lamps->configure().ok());
    ASSERT_TRUE(lamps->activate().ok());
    ASSERT_TRUE(lamps->show(LampPattern::Fault).ok());
    // Only that it blinks at all (the pattern is checked on a stepped clock
    // above): polled under a generous deadline, never early, never a sleep.
    const auto writes = controls.lamps->transitions();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (controls.lamps->transitions() < writes + 2 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    EXPECT_GE(controls.lamps->transitions(), writes + 2);
    ASSERT_TRUE(lamps->deactivate().ok());
}

TEST(Lamps, DeactivateDarkensAndStopsBlinking)
{
    SteppedLamps l;
    ASSERT_TRUE(l.lamps->set(Lamp::Green, LampState::Blinking).ok());
    ASSERT_TRUE(l.lamps->deactivate().ok());
    EXPECT_FALSE(l.sim.lit(Lamp::Green));
    const auto after = l.sim.transitions();
    for (int i = 0; i < 10; ++i) l.after(std::chrono::milliseconds(25));
    EXPECT_EQ(l.sim.transitions(), after);
    ASSERT_TRUE(l.lamps->cleanup().ok());
    EXPECT_FALSE(l.sim.linesRequested());
    EXPECT_EQ(l.lamps->state(), LifecycleState::Unconfigured);
}

TEST(Lamps, WriteFailureFailsTheDriverAndCleanupRecovers)
{
    SteppedLamps l;
    l.sim.injectWriteFailure(true);
    auto r = l.lamps->show(LampPattern::Pass);
    EXPECT_EQ(r.code(), hg::StatusCode::IoError);
    EXPECT_NE(r.message().find("lamps"), std::string::npos);
    EXPECT_EQ(l.lamps->state(), LifecycleState::Failed);
    EXPECT_EQ(l.lamps->show(LampPattern::Pass).code(), hg::StatusCode::NotAllowed);
    ASSERT_TRUE(l.lamps->cleanup().ok());
    EXPECT_EQ(l.lamps->configure().code(), hg::StatusCode::IoError); // still unplugged
    EXPECT_EQ(l.lamps->state(), LifecycleState::Unconfigured);
    l.sim.injectWriteFailure(false);
    ASSERT_TRUE(l.lamps->configure().ok());
    ASSERT_TRUE(l.lamps->activate().ok());
    ASSERT_TRUE(l.lamps->show(LampPattern::Pass).ok());
    EXPECT_TRUE(l.sim.lit(Lamp::Green));
}

TEST(GpiodLamps, MissingChipFailsConfigureNamingTheKey)
{
    auto lamps = makeLamps(section("lamps: {backend: gpiod, chip: hg-no-such-chip, green: 1, amber: 2, red: 3}"));
    EXPECT_EQ(lamps->backend(), "gpiod");
    auto r = lamps->configure();
    EXPECT_EQ(r.code(), hg::StatusCode::IoError);
    EXPECT_NE(r.message().find("lamps.chip: cannot open GPIO chip 'hg-no-such-chip'"), std::string::npos)
        << r.message();
    EXPECT_EQ(lamps->state(), LifecycleState::Unconfigured);
    EXPECT_EQ(lamps->show(LampPattern::Fault).code(), hg::StatusCode::NotAllowed);
}

TEST(GpiodLamps, UnknownLineNameFailsConfigureNamingTheLamp)
{
    auto lamps = makeLamps(
        section("lamps: {backend: gpiod, green: HG_NO_SUCH_LINE_G, amber: HG_NO_SUCH_LINE_A, red: HG_NO_SUCH_LINE_R}"));
    auto r = lamps->configure();
    EXPECT_EQ(r.code(), hg::StatusCode::IoError);
    EXPECT_NE(r.message().find("lamps.green: no GPIO chip has a line named 'HG_NO_SUCH_LINE_G'"), std::string::npos)
        << r.message();
    EXPECT_EQ(lamps->state(), LifecycleState::Unconfigured);
}
