// The lamp driver's common part: configuration, lifecycle, the station
// indications of CONTRACTS §6 and the blink timer thread. The GPIO backend
// and the simulated twin only drive three output levels.
#include "hullgauge/drivers/lamps.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "backends.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg::drivers {
namespace {

constexpr std::array<std::string_view, 3> kLampKeys{"green", "amber", "red"};

std::size_t index(Lamp lamp)
{
    return static_cast<std::size_t>(lamp);
}

bool isUnsignedInteger(const std::string& s)
{
    return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

LampResult failure(LampStatusCode code, std::string message)
{
    return {code, std::move(message)};
}

LampLine parseLine(const ConfigNode& node, bool defaultActiveLow)
{
    LampLine line;
    line.key = node.path();
    line.activeLow = defaultActiveLow;
    auto setOffset = [&](const ConfigNode& n) { line.offset = static_cast<unsigned>(n.asIntIn(0, 65535)); };
    if (node.isScalar()) {
        // Shorthand: a number is an offset on `lamps.chip`, anything else a line name.
        if (isUnsignedInteger(node.asString()))
            setOffset(node);
        else
            line.name = node.asString();
    } else if (node.isMap()) {
        node.allowOnlyKeys({"line", "offset", "active_low"});
        bool byName = node.has("line");
        bool byOffset = node.has("offset");
        if (byName == byOffset) node.fail("give exactly one of 'line' (a GPIO line name) or 'offset'");
        if (byName) {
            line.name = node["line"].asString();
            if (line.name->empty()) node["line"].fail("line name must not be empty");
        } else {
            setOffset(node["offset"]);
        }
        if (auto al = node.optional("active_low")) line.activeLow = al->asBool();
    } else {
        node.fail("expected a GPIO line name, an offset, or a map {line | offset, active_low}");
    }
    return line;
}

} // namespace

std::string_view toString(Lamp lamp)
{
    return kLampKeys[index(lamp)];
}

std::string_view toString(LampState state)
{
    switch (state) {
    case LampState::Off:
        return "off";
    case LampState::On:
        return "on";
    case LampState::Blinking:
        return "blinking";
    }
    return "?";
}

std::string_view toString(StationIndication indication)
{
    switch (indication) {
    case StationIndication::Dark:
        return "dark";
    case StationIndication::Pass:
        return "pass";
    case StationIndication::Fail:
        return "fail";
    case StationIndication::Busy:
        return "busy";
    case StationIndication::Fault:
        return "fault";
    }
    return "?";
}

std::string_view toString(LampStatusCode code)
{
    switch (code) {
    case LampStatusCode::Ok:
        return "ok";
    case LampStatusCode::IoError:
        return "I/O error";
    case LampStatusCode::NotAllowed:
        return "not allowed";
    }
    return "?";
}

std::string LampLine::describe() const
{
    if (name) return "line '" + *name + "'";
    return "offset " + std::to_string(offset.value_or(0));
}

LampsConfig LampsConfig::parse(const ConfigNode& section)
{
    if (!section.isMap()) section.fail("expected a map with backend, chip and the lines of green, amber and red");
    section.allowOnlyKeys({"backend", "chip", "consumer", "active_low", "blink_period_s", "green", "amber", "red"});
    LampsConfig c;
    c.key = section.path().empty() ? "lamps" : section.path();
    c.file = section.file();
    auto backendNode = section["backend"];
    c.backend = backendNode.asString();
    if (c.backend != "gpiod" && c.backend != "sim")
        backendNode.fail("unknown lamp backend '" + c.backend + "' (gpiod or sim)");
    if (auto n = section.optional("chip")) {
        c.chip = n->asString();
        if (c.chip.empty()) n->fail("chip must not be empty");
    }
    if (auto n = section.optional("consumer")) {
        c.consumer = n->asString();
        if (c.consumer.empty()) n->fail("consumer label must not be empty");
    }
    bool activeLow = false;
    if (auto n = section.optional("active_low")) activeLow = n->asBool();
    if (auto n = section.optional("blink_period_s")) {
        double s = n->asDoubleIn(0.05, 10.0);
        c.blinkPeriod = std::chrono::milliseconds(static_cast<long long>(std::lround(s * 1000.0)));
    }
    for (Lamp lamp : kAllLamps) {
        auto node = section[kLampKeys[index(lamp)]];
        LampLine line = parseLine(node, activeLow);
        if (line.offset && c.chip.empty())
            node.fail("a line given by offset needs '" + c.key + ".chip' (the GPIO chip it belongs to)");
        for (Lamp other : kAllLamps) {
            if (other == lamp) break;
            const LampLine& o = c.lines[index(other)];
            if ((line.name && o.name == line.name) || (line.offset && o.offset == line.offset))
                node.fail(line.describe() + " is already used by " + o.key);
        }
        c.lines[index(lamp)] = std::move(line);
    }
    return c;
}

std::array<LampState, 3> lampStatesFor(StationIndication indication)
{
    using S = LampState;
    switch (indication) {
    case StationIndication::Dark:
        return {S::Off, S::Off, S::Off};
    case StationIndication::Pass:
        return {S::On, S::Off, S::Off};
    case StationIndication::Fail:
        return {S::Off, S::Off, S::On};
    case StationIndication::Busy:
        return {S::Off, S::On, S::Off};
    case StationIndication::Fault:
        return {S::Off, S::Blinking, S::Blinking};
    }
    return {S::Off, S::Off, S::Off};
}

Lamps::Lamps(LampsConfig config) : config_(std::move(config))
{
}

Lamps::~Lamps()
{
    shutdown();
}

void Lamps::shutdown()
{
    {
        std::lock_guard lock(mutex_);
        stopBlinker_ = true;
    }
    wake_.notify_all();
    if (blinker_.joinable()) blinker_.join();
}

LifecycleState Lamps::state() const
{
    std::lock_guard lock(mutex_);
    return state_;
}

LampState Lamps::commanded(Lamp lamp) const
{
    std::lock_guard lock(mutex_);
    return commanded_[index(lamp)];
}

LampResult Lamps::configure()
{
    std::lock_guard lock(mutex_);
    if (!allowed(state_, Transition::Configure))
        return failure(LampStatusCode::NotAllowed,
                       "lamps: configure is not allowed while " + std::string(toString(state_)));
    commanded_.fill(LampState::Off);
    blinkLit_ = true;
    auto r = onConfigure();
    if (!r.ok()) {
        onCleanup();
        hg::log::category("lamps")->error("{}", r.message);
        return r;
    }
    state_ = nextState(state_, Transition::Configure);
    hg::log::category("lamps")->info("{} lamps configured", backend());
    return r;
}

LampResult Lamps::activate()
{
    {
        std::lock_guard lock(mutex_);
        if (!allowed(state_, Transition::Activate))
            return failure(LampStatusCode::NotAllowed,
                           "lamps: activate is not allowed while " + std::string(toString(state_)));
        state_ = nextState(state_, Transition::Activate);
        auto r = applyLocked();
        if (!r.ok()) return r;
        startBlinkerLocked();
    }
    wake_.notify_all();
    return LampResult::success();
}

LampResult Lamps::deactivate()
{
    std::lock_guard lock(mutex_);
    if (!allowed(state_, Transition::Deactivate))
        return failure(LampStatusCode::NotAllowed,
                       "lamps: deactivate is not allowed while " + std::string(toString(state_)));
    commanded_.fill(LampState::Off);
    auto r = writeOutputs({false, false, false});
    if (!r.ok()) {
        state_ = LifecycleState::Failed;
        return r;
    }
    state_ = nextState(state_, Transition::Deactivate);
    return r;
}

LampResult Lamps::cleanup()
{
    std::lock_guard lock(mutex_);
    if (!allowed(state_, Transition::Cleanup))
        return failure(LampStatusCode::NotAllowed,
                       "lamps: cleanup is not allowed while " + std::string(toString(state_)));
    onCleanup();
    commanded_.fill(LampState::Off);
    state_ = nextState(state_, Transition::Cleanup);
    return LampResult::success();
}

LampResult Lamps::requireActiveLocked(std::string_view call) const
{
    if (state_ == LifecycleState::Active) return LampResult::success();
    return failure(LampStatusCode::NotAllowed, "lamps: " + std::string(call) + " needs the driver active (it is " +
                                                   std::string(toString(state_)) + ")");
}

LampResult Lamps::set(Lamp lamp, LampState s)
{
    std::unique_lock lock(mutex_);
    if (auto r = requireActiveLocked("set"); !r.ok()) return r;
    bool blinkedBefore = std::ranges::any_of(commanded_, [](LampState x) { return x == LampState::Blinking; });
    commanded_[index(lamp)] = s;
    // A lamp that starts blinking while none blinked starts lit, so the
    // operator sees the change at once.
    if (!blinkedBefore && s == LampState::Blinking) blinkLit_ = true;
    auto r = applyLocked();
    lock.unlock();
    wake_.notify_all();
    return r;
}

LampResult Lamps::show(StationIndication indication)
{
    std::unique_lock lock(mutex_);
    if (auto r = requireActiveLocked("show " + std::string(toString(indication))); !r.ok()) return r;
    auto states = lampStatesFor(indication);
    bool blinkedBefore = std::ranges::any_of(commanded_, [](LampState x) { return x == LampState::Blinking; });
    if (states != commanded_ && !blinkedBefore) blinkLit_ = true;
    commanded_ = states;
    auto r = applyLocked();
    lock.unlock();
    wake_.notify_all();
    return r;
}

LampResult Lamps::applyLocked()
{
    std::array<bool, 3> lit{};
    for (std::size_t i = 0; i < lit.size(); ++i)
        lit[i] = commanded_[i] == LampState::On || (commanded_[i] == LampState::Blinking && blinkLit_);
    auto r = writeOutputs(lit);
    if (!r.ok()) {
        // A lamp that cannot be driven is a hardware fault the operator must
        // hear about; the driver stays Failed until cleanup() and configure().
        state_ = nextState(state_, Transition::Error);
        hg::log::category("lamps")->error("{}", r.message);
    }
    return r;
}

void Lamps::startBlinkerLocked()
{
    if (blinker_.joinable()) return;
    stopBlinker_ = false;
    blinker_ = std::thread([this] { blinkLoop(); });
}

void Lamps::blinkLoop()
{
    std::unique_lock lock(mutex_);
    const auto half = config_.blinkPeriod / 2;
    while (!stopBlinker_) {
        auto blinking = [&] {
            return state_ == LifecycleState::Active &&
                   std::ranges::any_of(commanded_, [](LampState x) { return x == LampState::Blinking; });
        };
        if (!blinking()) {
            wake_.wait(lock, [&] { return stopBlinker_ || blinking(); });
            continue;
        }
        // Toggle on a fixed schedule so the period does not drift with the
        // time the writes take; a change of the commanded states restarts it.
        auto commandedAtStart = commanded_;
        auto deadline = std::chrono::steady_clock::now() + half;
        bool interrupted = wake_.wait_until(lock, deadline, [&] {
            return stopBlinker_ || commanded_ != commandedAtStart || state_ != LifecycleState::Active;
        });
        if (interrupted) continue;
        blinkLit_ = !blinkLit_;
        (void)applyLocked();
    }
}

std::unique_ptr<Lamps> makeLamps(const ConfigNode& section)
{
    LampsConfig config = LampsConfig::parse(section);
    if (config.backend == "gpiod") return makeGpiodLamps(std::move(config));
    return makeSimulatedLamps(std::move(config));
}

} // namespace hg::drivers
