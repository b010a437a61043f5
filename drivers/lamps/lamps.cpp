// The lamp driver's common part: configuration, lifecycle, the station
// indications of docs/contracts.md §6 and the blink timer thread. The GPIO backend
// and the simulated twin only drive three output levels.
#include "hullgauge/drivers/lamps.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "../backend_table.h"
#include "backends.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg::drivers {
namespace {

std::size_t index(Lamp lamp)
{
    return static_cast<std::size_t>(lamp);
}

bool isUnsignedInteger(const std::string& s)
{
    return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

using LampsFactory = std::unique_ptr<Lamps> (*)(LampsConfig config, SimulationControls* simulation, Clock& clock);

/// The lamp backends (docs/lamps.md); the simulated twin is always built.
constexpr Backend<LampsFactory> kLampBackends[] = {
    {"gpiod",
     [](LampsConfig config, SimulationControls*, Clock& clock) { return makeGpiodLamps(std::move(config), clock); }},
    {"sim", makeSimulatedLamps},
};

bool anyBlinking(const std::array<LampState, 3>& states)
{
    return std::ranges::any_of(states, [](LampState x) { return x == LampState::Blinking; });
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
    (void)chooseBackend(kLampBackends, backendNode, "lamp");
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
        auto node = section[enumName(lamp)];
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

std::array<LampState, 3> lampStatesFor(station::LampPattern pattern)
{
    using S = LampState;
    using P = station::LampPattern;
    // docs/contracts.md §6 and its extensions (docs/lamps.md); each row green, amber, red.
    switch (pattern) {
    case P::Off:
        break;
    case P::Busy:
        return {S::Off, S::On, S::Off};
    case P::Pass:
        return {S::On, S::Off, S::Off};
    case P::Fail:
        return {S::Off, S::Off, S::On};
    case P::Fault:
        return {S::Off, S::Blinking, S::Blinking};
    case P::Reseat:
        return {S::Off, S::Blinking, S::Off};
    case P::PassAttention:
        return {S::On, S::On, S::Off};
    case P::FailAttention:
        return {S::Off, S::On, S::On};
    case P::Refused:
        return {S::Off, S::On, S::Blinking};
    }
    return {S::Off, S::Off, S::Off};
}

Lamps::Lamps(LampsConfig config, Clock& clock) : Device("lamps", clock), config_(std::move(config))
{
}

Lamps::~Lamps()
{
    shutdown();
}

void Lamps::shutdown()
{
    blinker_.stop();
}

LampState Lamps::commanded(Lamp lamp) const
{
    std::lock_guard lock(mutex());
    return commanded_[index(lamp)];
}

HookResult Lamps::onConfigure()
{
    commanded_.fill(LampState::Off);
    written_.fill(false);
    return openLines();
}

HookResult Lamps::onActivate()
{
    if (Status s = writeLocked(/*always=*/true); !s) return HookResult::error(s);
    if (!blinker_.running()) blinker_.start([this](std::stop_token stop) { blinkLoop(stop); }, wakeOn(mutex(), wake_));
    return Status::success();
}

HookResult Lamps::onDeactivate()
{
    commanded_.fill(LampState::Off);
    if (Status s = writeLocked(/*always=*/true); !s) return HookResult::error(s);
    return Status::success();
}

void Lamps::onCleanup()
{
    closeLines();
    commanded_.fill(LampState::Off);
    written_.fill(false);
}

void Lamps::command(const std::array<LampState, 3>& states)
{
    if (states == commanded_) return;
    // A lamp that starts blinking while none blinked starts lit, so the
    // operator sees the change at once; any change keeps the phase the
    // blinking lamps show and restarts its half period.
    const auto now = clock().now();
    const auto half = config_.blinkPeriod / 2;
    const bool dark = anyBlinking(commanded_) && ((now - phaseStart_) / half) % 2 == 1;
    phaseStart_ = dark ? now - half : now;
    commanded_ = states;
}

Status Lamps::set(Lamp lamp, LampState s)
{
    std::unique_lock lock(mutex());
    if (auto r = require({LifecycleState::Active}, "set " + std::string(enumName(lamp))); !r) return r;
    auto states = commanded_;
    states[index(lamp)] = s;
    command(states);
    auto r = applyLocked();
    lock.unlock();
    wake_.notify_all();
    return r;
}

Status Lamps::show(station::LampPattern pattern)
{
    std::unique_lock lock(mutex());
    if (auto r = require({LifecycleState::Active}, "show " + std::string(enumName(pattern))); !r) return r;
    command(lampStatesFor(pattern));
    auto r = applyLocked();
    lock.unlock();
    wake_.notify_all();
    return r;
}

Status Lamps::tick()
{
    std::lock_guard lock(mutex());
    if (state() != LifecycleState::Active) return Status::success();
    return applyLocked();
}

bool Lamps::blinking() const
{
    return state() == LifecycleState::Active && anyBlinking(commanded_);
}

Status Lamps::writeLocked(bool always)
{
    const bool litPhase = ((clock().now() - phaseStart_) / (config_.blinkPeriod / 2)) % 2 == 0;
    std::array<bool, 3> lit{};
    for (std::size_t i = 0; i < lit.size(); ++i)
        lit[i] = commanded_[i] == LampState::On || (commanded_[i] == LampState::Blinking && litPhase);
    if (lit == written_ && !always) return Status::success();
    if (Status s = writeOutputs(lit); !s) return s;
    written_ = lit;
    return Status::success();
}

Status Lamps::applyLocked()
{
    // A lamp that cannot be driven is a hardware fault the operator must
    // hear about; the driver stays Failed until cleanup() and configure().
    if (Status s = writeLocked(/*always=*/false); !s) return fail(s);
    return Status::success();
}

void Lamps::blinkLoop(std::stop_token stop)
{
    std::unique_lock lock(mutex());
    const auto half = config_.blinkPeriod / 2;
    while (!stop.stop_requested()) {
        if (!blinking()) {
            wake_.wait(lock, [&] { return stop.stop_requested() || blinking(); });
            continue;
        }
        // Wake at the next half-period boundary of the phase, so the period does
        // not drift with the time the writes take; a new command moves the phase.
        const auto origin = phaseStart_;
        const auto next = origin + ((clock().now() - origin) / half + 1) * half;
        clock().waitUntil(lock, wake_, next,
                          [&] { return stop.stop_requested() || phaseStart_ != origin || !blinking(); });
        if (blinking()) (void)applyLocked();
    }
}

std::unique_ptr<Lamps> makeLamps(const ConfigNode& section, SimulationControls* simulation, Clock& clock)
{
    LampsConfig config = LampsConfig::parse(section);
    auto make = chooseBackend(kLampBackends, section["backend"], "lamp");
    return make(std::move(config), simulation, clock);
}

} // namespace hg::drivers
