// hullgauge fixture home|move|status|stop|reset — maintenance access to the
// fixture drive named by the station's fixture.driver section (real Modbus
// drive, the fixture simulator, or the in-process twin). The final drive
// status goes to stdout as JSON; progress and errors go to stderr.
// Exit status: 0 done, 2 bad station file or arguments, 3 drive or
// communication fault, timeout (docs/contracts.md §5).
#include "command.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/drivers/fixture.h"
#include "hullgauge/geometry/station.h"

#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

namespace hg::cli {
namespace {

struct FixtureArgs {
    std::string station;
    std::optional<double> rotation;
    std::optional<double> declination;
    std::optional<double> rail;
    std::optional<double> timeoutS;
    bool noWait = false;
};

/// Turns a failed call into the exception main() maps to exit status 3.
void check(const Status& r, const std::string& what)
{
    if (!r.ok()) throw FaultError("fixture " + what + ": " + std::string(enumName(r.code())) + ": " + r.message());
}

nlohmann::json statusJson(const drivers::Fixture& fixture, const drivers::FixtureStatus& st)
{
    nlohmann::json j;
    j["backend"] = std::string(fixture.backend());
    j["state"] = std::string(enumName(fixture.state()));
    j["type"] = enumName(fixture.type());
    if (fixture.type() == geometry::FixtureType::Rail)
        j["position"] = {{"rail_mm", st.position.railMm}};
    else
        j["position"] = {{"rotation_deg", st.position.rotationDeg}, {"declination_deg", st.position.declinationDeg}};
    j["in_position"] = st.inPosition;
    j["busy"] = st.busy;
    j["homed"] = st.homed;
    j["fault"] = st.fault;
    j["fault_code"] = st.faultCode;
    j["fault_text"] = st.faultText;
    return j;
}

/// The commanded pose from the options, checked against the station's ranges.
geometry::FixturePose requestedPose(const FixtureArgs& a, const geometry::FixtureKinematics& k)
{
    geometry::FixturePose pose;
    auto inRange = [](double v, const geometry::Range& r, const std::string& option, const std::string& unit) {
        if (!r.contains(v))
            throw InputError("", option,
                             formatNumber(v) + " " + unit + " is outside the fixture range [" + formatNumber(r.min) +
                                 ", " + formatNumber(r.max) + "] of the station");
    };
    if (k.type == geometry::FixtureType::Rail) {
        if (!a.rail) throw InputError("", "--rail", "a rail fixture moves to --rail MM");
        if (a.rotation || a.declination)
            throw InputError("", a.rotation ? "--rotation" : "--declination", "the station's fixture is a rail");
        inRange(*a.rail, k.railRangeMm, "--rail", "mm");
        pose.railMm = *a.rail;
    } else {
        if (a.rail) throw InputError("", "--rail", "the station's fixture is a rotation/declination fixture");
        if (!a.rotation || !a.declination)
            throw InputError("", a.rotation ? "--declination" : "--rotation",
                             "a rotation/declination fixture moves to --rotation DEG --declination DEG");
        inRange(*a.rotation, k.rotationRangeDeg, "--rotation", "deg");
        inRange(*a.declination, k.declinationRangeDeg, "--declination", "deg");
        pose.rotationDeg = *a.rotation;
        pose.declinationDeg = *a.declination;
    }
    return pose;
}

int runFixture(const std::string& action, const FixtureArgs& a)
{
    auto station = geometry::loadStation(a.station);
    std::optional<geometry::FixturePose> pose;
    if (action == "move") pose = requestedPose(a, station.fixture);
    auto fixture = drivers::makeFixture(station);
    check(fixture->configure(), "configure");

    drivers::FixtureStatus st;
    bool moving = action == "home" || action == "move";
    if (action != "status") {
        check(fixture->activate(), "activate");
        if (action == "home") check(fixture->home(), "home");
        if (action == "move") check(fixture->moveTo(*pose), "move");
        if (action == "stop") check(fixture->stop(), "stop");
        if (action == "reset") check(fixture->resetFault(), "reset");
        if (moving && !a.noWait) {
            auto timeout = a.timeoutS         ? std::chrono::milliseconds(static_cast<long long>(*a.timeoutS * 1000.0))
                           : action == "home" ? fixture->homeTimeout()
                                              : fixture->moveTimeout();
            std::cerr << (action == "home" ? "homing"
                                           : fmt::format("moving to {}", geometry::PoseOn{*pose, fixture->type()}))
                      << " ..." << std::endl;
            check(fixture->waitInPosition(timeout), action);
        }
    }
    check(fixture->status(st), "status");
    std::cout << statusJson(*fixture, st).dump(2) << '\n';
    // A move left running (--no-wait) must not be stopped by deactivation:
    // the connection simply closes with the driver.
    if (fixture->state() == drivers::LifecycleState::Active && !(moving && a.noWait))
        check(fixture->deactivate(), "deactivate");
    if (fixture->state() == drivers::LifecycleState::Inactive) check(fixture->cleanup(), "cleanup");
    return static_cast<int>(ExitStatus::Ok);
}

std::function<int()> fixtureCommand(CLI::App& app)
{
    auto* cmd = app.add_subcommand("fixture", "home, move, stop, reset or query the fixture drive of a station");
    cmd->require_subcommand(1);
    auto args = std::make_shared<FixtureArgs>();
    auto action = std::make_shared<std::string>();
    struct Spec {
        const char* name;
        const char* help;
    };
    for (auto [name, help] : {Spec{"home", "home the fixture and wait until it is homed"},
                              Spec{"move", "move to a pose and wait until it is in position"},
                              Spec{"status", "print the drive status as JSON"}, Spec{"stop", "stop any motion"},
                              Spec{"reset", "acknowledge a latched drive fault"}}) {
        auto* sub = cmd->add_subcommand(name, help);
        sub->add_option("--station", args->station, "station YAML with the fixture.driver section")
            ->required()
            ->check(CLI::ExistingFile);
        if (std::string(name) == "move") {
            sub->add_option("--rotation", args->rotation, "turntable rotation in degrees");
            sub->add_option("--declination", args->declination, "declination (tilt) in degrees");
            sub->add_option("--rail", args->rail, "rail position in millimetres");
        }
        if (std::string(name) == "home" || std::string(name) == "move") {
            sub->add_option("--timeout", args->timeoutS, "seconds to wait (default move_timeout_s / home_timeout_s)")
                ->check(CLI::PositiveNumber);
            sub->add_flag("--no-wait", args->noWait, "return once the drive has accepted the command");
        }
        sub->callback([action, n = std::string(name)] { *action = n; });
    }
    return [args, action] { return runFixture(*action, *args); };
}

} // namespace

HG_REGISTER_COMMAND("fixture", fixtureCommand);

} // namespace hg::cli
