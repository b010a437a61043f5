#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/lamps.h"

using namespace hg::drivers;
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

std::unique_ptr<Lamps> activeSim(const char* yaml = kSim)
{
    auto lamps = makeLamps(section(yaml));
    EXPECT_TRUE(lamps->configure().ok());
    EXPECT_TRUE(lamps->activate().ok());
    return lamps;
}

SimulatedLamps& sim(Lamps& lamps)
{
    auto* s = dynamic_cast<SimulatedLamps*>(&lamps);
    if (!s) throw std::logic_error("not the simulated twin");
    return *s;
}

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
              "station.yaml:2: lamps.backend: unknown lamp backend 'relay' (gpiod or sim)");
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
    auto lamps = makeLamps(section(kSim));
    EXPECT_EQ(lamps->show(StationIndication::Pass).code, LampStatusCode::NotAllowed);
    EXPECT_EQ(lamps->activate().code, LampStatusCode::NotAllowed);
    ASSERT_TRUE(lamps->configure().ok());
    EXPECT_TRUE(sim(*lamps).linesRequested());
    EXPECT_EQ(lamps->set(Lamp::Red, LampState::On).code, LampStatusCode::NotAllowed);
    EXPECT_EQ(lamps->configure().code, LampStatusCode::NotAllowed);
    ASSERT_TRUE(lamps->activate().ok());
    EXPECT_EQ(lamps->state(), LifecycleState::Active);
    EXPECT_TRUE(lamps->set(Lamp::Red, LampState::On).ok());
    EXPECT_EQ(lamps->cleanup().code, LampStatusCode::NotAllowed); // must deactivate first
}

TEST(Lamps, StationIndicationsFollowContracts)
{
    auto lamps = activeSim();
    auto& s = sim(*lamps);
    struct Case {
        StationIndication what;
        bool green, amber, red;
    };
    for (auto c :
         {Case{StationIndication::Pass, true, false, false}, Case{StationIndication::Fail, false, false, true},
          Case{StationIndication::Busy, false, true, false}, Case{StationIndication::Dark, false, false, false}}) {
        ASSERT_TRUE(lamps->show(c.what).ok());
        EXPECT_EQ(s.lit(Lamp::Green), c.green) << toString(c.what);
        EXPECT_EQ(s.lit(Lamp::Amber), c.amber) << toString(c.what);
        EXPECT_EQ(s.lit(Lamp::Red), c.red) << toString(c.what);
    }
    ASSERT_TRUE(lamps->show(StationIndication::Fault).ok());
    EXPECT_EQ(lamps->commanded(Lamp::Red), LampState::Blinking);
    EXPECT_EQ(lamps->commanded(Lamp::Amber), LampState::Blinking);
    EXPECT_EQ(lamps->commanded(Lamp::Green), LampState::Off);
}

TEST(Lamps, ActiveLowLinesAreInverted)
{
    auto lamps = activeSim();
    auto& s = sim(*lamps);
    // Red is active-low: dark means a high line.
    EXPECT_FALSE(s.lit(Lamp::Red));
    EXPECT_TRUE(s.lineLevel(Lamp::Red));
    EXPECT_FALSE(s.lineLevel(Lamp::Green));
    ASSERT_TRUE(lamps->show(StationIndication::Fail).ok());
    EXPECT_TRUE(s.lit(Lamp::Red));
    EXPECT_FALSE(s.lineLevel(Lamp::Red));
}

TEST(Lamps, FaultBlinksRedAndAmberTogetherAtTheConfiguredPeriod)
{
    auto lamps = activeSim(); // blink period 100 ms: a toggle every 50 ms
    auto& s = sim(*lamps);
    ASSERT_TRUE(lamps->show(StationIndication::Fault).ok());
    EXPECT_TRUE(s.lit(Lamp::Red)); // starts in the lit half
    EXPECT_TRUE(s.lit(Lamp::Amber));
    auto start = std::chrono::steady_clock::now();
    auto transitionsAtStart = s.transitions();
    bool sawDark = false, sawLit = false;
    while (std::chrono::steady_clock::now() - start < 400ms) {
        bool red = s.lit(Lamp::Red), amber = s.lit(Lamp::Amber);
        EXPECT_EQ(red, amber) << "red and amber must blink in phase";
        EXPECT_FALSE(s.lit(Lamp::Green));
        (red ? sawLit : sawDark) = true;
        std::this_thread::sleep_for(5ms);
    }
    auto elapsed = std::chrono::steady_clock::now() - start;
    auto toggles = s.transitions() - transitionsAtStart;
    EXPECT_TRUE(sawDark && sawLit);
    // The timer never toggles early (deadline schedule); a loaded machine may
    // make it late, so the lower bound is lenient.
    auto maxToggles = static_cast<std::uint64_t>(elapsed / 50ms) + 1;
    EXPECT_LE(toggles, maxToggles);
    EXPECT_GE(toggles, 3u);

    // Leaving the fault stops the blinking at once.
    ASSERT_TRUE(lamps->show(StationIndication::Busy).ok());
    auto after = s.transitions();
    std::this_thread::sleep_for(150ms);
    EXPECT_EQ(s.transitions(), after);
    EXPECT_TRUE(s.lit(Lamp::Amber));
    EXPECT_FALSE(s.lit(Lamp::Red));
}

TEST(Lamps, DeactivateDarkensAndStopsBlinking)
{
    auto lamps = activeSim();
    auto& s = sim(*lamps);
    ASSERT_TRUE(lamps->set(Lamp::Green, LampState::Blinking).ok());
    ASSERT_TRUE(lamps->deactivate().ok());
    EXPECT_FALSE(s.lit(Lamp::Green));
    auto after = s.transitions();
    std::this_thread::sleep_for(120ms);
    EXPECT_EQ(s.transitions(), after);
    ASSERT_TRUE(lamps->cleanup().ok());
    EXPECT_FALSE(s.linesRequested());
    EXPECT_EQ(lamps->state(), LifecycleState::Unconfigured);
}

TEST(Lamps, WriteFailureFailsTheDriverAndCleanupRecovers)
{
    auto lamps = activeSim();
    auto& s = sim(*lamps);
    s.injectWriteFailure(true);
    auto r = lamps->show(StationIndication::Pass);
    EXPECT_EQ(r.code, LampStatusCode::IoError);
    EXPECT_NE(r.message.find("lamps"), std::string::npos);
    EXPECT_EQ(lamps->state(), LifecycleState::Failed);
    EXPECT_EQ(lamps->show(StationIndication::Pass).code, LampStatusCode::NotAllowed);
    ASSERT_TRUE(lamps->cleanup().ok());
    EXPECT_EQ(lamps->configure().code, LampStatusCode::IoError); // still unplugged
    EXPECT_EQ(lamps->state(), LifecycleState::Unconfigured);
    s.injectWriteFailure(false);
    ASSERT_TRUE(lamps->configure().ok());
    ASSERT_TRUE(lamps->activate().ok());
    ASSERT_TRUE(lamps->show(StationIndication::Pass).ok());
    EXPECT_TRUE(s.lit(Lamp::Green));
}

TEST(GpiodLamps, MissingChipFailsConfigureNamingTheKey)
{
    auto lamps = makeLamps(section("lamps: {backend: gpiod, chip: hg-no-such-chip, green: 1, amber: 2, red: 3}"));
    EXPECT_EQ(lamps->backend(), "gpiod");
    auto r = lamps->configure();
    EXPECT_EQ(r.code, LampStatusCode::IoError);
    EXPECT_NE(r.message.find("lamps.chip: cannot open GPIO chip 'hg-no-such-chip'"), std::string::npos) << r.message;
    EXPECT_EQ(lamps->state(), LifecycleState::Unconfigured);
    EXPECT_EQ(lamps->show(StationIndication::Fault).code, LampStatusCode::NotAllowed);
}

TEST(GpiodLamps, UnknownLineNameFailsConfigureNamingTheLamp)
{
    auto lamps = makeLamps(
        section("lamps: {backend: gpiod, green: HG_NO_SUCH_LINE_G, amber: HG_NO_SUCH_LINE_A, red: HG_NO_SUCH_LINE_R}"));
    auto r = lamps->configure();
    EXPECT_EQ(r.code, LampStatusCode::IoError);
    EXPECT_NE(r.message.find("lamps.green: no GPIO chip has a line named 'HG_NO_SUCH_LINE_G'"), std::string::npos)
        << r.message;
    EXPECT_EQ(lamps->state(), LifecycleState::Unconfigured);
}
