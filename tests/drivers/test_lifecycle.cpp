// The driver lifecycle (docs/drivers.md), table-driven: every transition from
// every state with a hook that succeeds, fails or errs, on a scripted device;
// then the same table over each device kind's simulated twin built from its
// backend table, with the failures and errors the twins can be made to show.
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fixture/station_yaml.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/drivers/simulation.h"

namespace {

using hg::StatusCode;
using hg::drivers::Device;
using hg::drivers::HookResult;
using hg::drivers::LifecycleState;
using hg::drivers::Transition;
using S = LifecycleState;
using T = Transition;

enum class Answer { Success, Failure, Error };

/// A device whose hooks answer as told and record that they ran.
class ScriptedDevice : public Device {
  public:
    ScriptedDevice() : Device("scripted", hg::Clock::steady()) {}
    Answer answer = Answer::Success;
    std::vector<std::string> calls;

  protected:
    HookResult reply(const char* hook)
    {
        calls.emplace_back(hook);
        switch (answer) {
        case Answer::Success:
            return hg::Status::success();
        case Answer::Failure:
            return hg::Status::failure(StatusCode::Timeout, "scripted: no answer");
        case Answer::Error:
            return HookResult::error(hg::Status::failure(StatusCode::Fault, "scripted: stuck"));
        }
        return hg::Status::success();
    }
    HookResult onConfigure() override { return reply("configure"); }
    HookResult onActivate() override { return reply("activate"); }
    HookResult onDeactivate() override { return reply("deactivate"); }
    void onCleanup() override { calls.emplace_back("cleanup"); }
};

hg::Status run(Device& d, Transition t)
{
    switch (t) {
    case T::Configure:
        return d.configure();
    case T::Activate:
        return d.activate();
    case T::Deactivate:
        return d.deactivate();
    case T::Cleanup:
        return d.cleanup();
    }
    return hg::Status::failure("?");
}

/// One row: from `from`, `t` is refused naming `needs`, or reaches the state
/// given for a hook that succeeds, fails and errs.
struct Row {
    S from;
    T t;
    const char* needs; ///< nullptr: allowed
    S success, failure, error;
};

// Written out by hand from docs/drivers.md, not derived from the code's table.
const std::vector<Row> kTable = {
    {S::Unconfigured, T::Configure, nullptr, S::Inactive, S::Unconfigured, S::Failed},
    {S::Unconfigured, T::Activate, "inactive", S::Unconfigured, S::Unconfigured, S::Unconfigured},
    {S::Unconfigured, T::Deactivate, "active", S::Unconfigured, S::Unconfigured, S::Unconfigured},
    {S::Unconfigured, T::Cleanup, "inactive or failed", S::Unconfigured, S::Unconfigured, S::Unconfigured},
    {S::Inactive, T::Configure, "unconfigured", S::Inactive, S::Inactive, S::Inactive},
    {S::Inactive, T::Activate, nullptr, S::Active, S::Inactive, S::Failed},
    {S::Inactive, T::Deactivate, "active", S::Inactive, S::Inactive, S::Inactive},
    {S::Inactive, T::Cleanup, nullptr, S::Unconfigured, S::Unconfigured, S::Unconfigured},
    {S::Active, T::Configure, "unconfigured", S::Active, S::Active, S::Active},
    {S::Active, T::Activate, "inactive", S::Active, S::Active, S::Active},
    {S::Active, T::Deactivate, nullptr, S::Inactive, S::Active, S::Failed},
    {S::Active, T::Cleanup, "inactive or failed", S::Active, S::Active, S::Active},
    {S::Failed, T::Configure, "unconfigured", S::Failed, S::Failed, S::Failed},
    {S::Failed, T::Activate, "inactive", S::Failed, S::Failed, S::Failed},
    {S::Failed, T::Deactivate, "active", S::Failed, S::Failed, S::Failed},
    {S::Failed, T::Cleanup, nullptr, S::Unconfigured, S::Unconfigured, S::Unconfigured},
};

std::string name(const Row& r)
{
    return std::string(hg::enumName(r.t)) + " from " + std::string(hg::enumName(r.from));
}

/// Drives a fresh device into `state` with hooks that succeed (Failed: an erring activate).
void bring(ScriptedDevice& d, S state)
{
    if (state == S::Unconfigured) return;
    ASSERT_TRUE(d.configure());
    if (state == S::Active) {
        ASSERT_TRUE(d.activate());
    }
    if (state == S::Failed) {
        d.answer = Answer::Error;
        ASSERT_FALSE(d.activate());
    }
    ASSERT_EQ(d.state(), state);
    d.calls.clear();
}

TEST(Lifecycle, EveryTransitionFromEveryStateWithEveryHookAnswer)
{
    for (const Row& row : kTable)
        for (Answer answer : {Answer::Success, Answer::Failure, Answer::Error}) {
            SCOPED_TRACE(name(row) + ", hook answer " + std::to_string(static_cast<int>(answer)));
            ScriptedDevice d;
            bring(d, row.from);
            d.answer = answer;
            const hg::Status s = run(d, row.t);
            if (row.needs) {
                EXPECT_EQ(s.code(), StatusCode::NotAllowed);
                EXPECT_EQ(s.message(), "scripted: " + std::string(hg::enumName(row.t)) + " is not allowed while " +
                                           std::string(hg::enumName(row.from)) + " (needs " + row.needs + ")");
                EXPECT_TRUE(d.calls.empty()) << "a refused transition runs no hook";
                EXPECT_EQ(d.state(), row.from);
                continue;
            }
            const S expected = answer == Answer::Success   ? row.success
                               : answer == Answer::Failure ? row.failure
                                                           : row.error;
            EXPECT_EQ(d.state(), expected);
            // Cleanup cannot fail: its hook releases what it can.
            const bool ok = answer == Answer::Success || row.t == T::Cleanup;
            EXPECT_EQ(s.ok(), ok);
            if (!ok) {
                EXPECT_EQ(s.code(), answer == Answer::Failure ? StatusCode::Timeout : StatusCode::Fault)
                    << "the hook's own status reaches the caller";
            }
            // A configure that fails releases what it half opened.
            std::vector<std::string> hooks{std::string(hg::enumName(row.t))};
            if (row.t == T::Configure && answer == Answer::Failure) hooks.emplace_back("cleanup");
            EXPECT_EQ(d.calls, hooks);
        }
}

// ---------------------------------------------------------------------------
// Every kind's twin, built from its backend table.

std::string stationText()
{
    fixturetest::StationOptions o;
    o.backend = "sim";
    o.responseTimeoutS = 0.01;
    o.retries = 0;
    std::string text = fixturetest::stationYaml(o);
    text.insert(text.find("fixture:"), "  driver: {backend: sim}\n");
    return text + "lamps: {backend: sim, green: G, amber: A, red: R}\n";
}

struct Twin {
    std::unique_ptr<Device> device;
    hg::drivers::SimulationControls sim;
};

using TwinFactory = std::function<void(Twin&)>;

struct Kind {
    const char* name;
    TwinFactory make;
};

const hg::ConfigNode& station()
{
    static const hg::ConfigNode root = hg::ConfigNode::parse(stationText(), "station.yaml");
    return root;
}

const std::vector<Kind> kKinds = {
    {"camera",
     [](Twin& t) {
         hg::drivers::CameraEnvironment env;
         env.simulation = &t.sim;
         t.device = hg::drivers::makeCamera(station(), std::move(env));
     }},
    {"fixture",
     [](Twin& t) {
         t.device = hg::drivers::makeFixture(station()["fixture"]["driver"], hg::geometry::FixtureKinematics{}, &t.sim);
     }},
    {"lamps", [](Twin& t) { t.device = hg::drivers::makeLamps(station()["lamps"], &t.sim); }},
};

TEST(Lifecycle, EveryKindFollowsTheTableWhenItsHooksSucceed)
{
    for (const Kind& kind : kKinds)
        for (const Row& row : kTable) {
            if (row.from == S::Failed) continue; // reached per kind below
            SCOPED_TRACE(std::string(kind.name) + ": " + name(row));
            Twin t;
            kind.make(t);
            Device& d = *t.device;
            EXPECT_EQ(d.kind(), kind.name);
            if (row.from != S::Unconfigured) {
                ASSERT_TRUE(d.configure());
            }
            if (row.from == S::Active) {
                ASSERT_TRUE(d.activate());
            }
            const hg::Status s = run(d, row.t);
            EXPECT_EQ(s.ok(), row.needs == nullptr) << s.message();
            if (row.needs) {
                EXPECT_EQ(s.code(), StatusCode::NotAllowed);
            }
            EXPECT_EQ(d.state(), row.success);
        }
}

TEST(Lifecycle, TheLampsTwinFailsStaysAndErrs)
{
    Twin t;
    kKinds[2].make(t);
    t.sim.lamps->injectWriteFailure(true);
    EXPECT_EQ(t.device->configure().code(), StatusCode::IoError); // failure: stays, lines released
    EXPECT_EQ(t.device->state(), S::Unconfigured);
    EXPECT_FALSE(t.sim.lamps->linesRequested());
    t.sim.lamps->injectWriteFailure(false);
    ASSERT_TRUE(t.device->configure());
    t.sim.lamps->injectWriteFailure(true);
    EXPECT_EQ(t.device->activate().code(), StatusCode::IoError); // a line that cannot be written: error
    EXPECT_EQ(t.device->state(), S::Failed);
    ASSERT_TRUE(t.device->cleanup());
    EXPECT_EQ(t.device->state(), S::Unconfigured);
}

TEST(Lifecycle, TheFixtureTwinFailsStaysAndErrs)
{
    Twin t;
    kKinds[1].make(t);
    t.sim.fixture->injectFault(hg::drivers::SimulatedFault::Disconnect);
    EXPECT_EQ(t.device->configure().code(), StatusCode::CommunicationError); // failure: stays
    EXPECT_EQ(t.device->state(), S::Unconfigured);
    t.sim.fixture->injectFault(hg::drivers::SimulatedFault::None);
    ASSERT_TRUE(t.device->configure());
    t.sim.fixture->injectFault(hg::drivers::SimulatedFault::Disconnect);
    EXPECT_EQ(t.device->activate().code(), StatusCode::CommunicationError);
    EXPECT_EQ(t.device->state(), S::Inactive);
    t.sim.fixture->injectFault(hg::drivers::SimulatedFault::None);
    ASSERT_TRUE(t.device->activate());
    t.sim.fixture->injectFault(hg::drivers::SimulatedFault::Disconnect);
    EXPECT_FALSE(t.device->deactivate()); // motion that cannot be stopped: error
    EXPECT_EQ(t.device->state(), S::Failed);
    EXPECT_EQ(t.device->configure().code(), StatusCode::NotAllowed);
    ASSERT_TRUE(t.device->cleanup());
    EXPECT_EQ(t.device->state(), S::Unconfigured);
}

TEST(Lifecycle, TheCameraTwinFailsAndStays)
{
    Twin t;
    kKinds[0].make(t);
    auto& camera = static_cast<hg::drivers::Camera&>(*t.device);
    auto settings = camera.settings();
    settings.roi = {600, 0, 100, 100}; // beyond the 640 px sensor: refused at configure
    ASSERT_TRUE(camera.setSettings(settings));
    EXPECT_FALSE(camera.configure());
    EXPECT_EQ(camera.state(), S::Unconfigured);
    settings.roi = {};
    ASSERT_TRUE(camera.setSettings(settings));
    ASSERT_TRUE(camera.configure());
    ASSERT_TRUE(camera.activate());
    EXPECT_EQ(camera.setSettings(settings).code(), StatusCode::NotAllowed); // stop streaming first
}

} // namespace
