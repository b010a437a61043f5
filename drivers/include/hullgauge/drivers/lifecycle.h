// The lifecycle every driver follows, written once (after ros2_control's
// hardware components; docs/drivers.md):
//
//   Unconfigured --configure--> Inactive --activate--> Active
//   Active --deactivate--> Inactive --cleanup--> Unconfigured
//   any hook's error --> Failed --cleanup--> Unconfigured (configure again to recover)
//
// Constructing a driver from its configuration section only parses and
// validates (throws hg::InputError naming the key); it opens nothing.
// `configure` opens communication, `activate` starts motion, streaming or
// power. Each backend hook answers success, failure (the transition did not
// happen: the driver stays where it was) or error (the device is in an unknown
// state: Failed); only this class sets the state. Every call after
// construction returns an hg::Status and never throws.
#pragma once

#include <atomic>
#include <initializer_list>
#include <mutex>
#include <string>
#include <string_view>

#include "hullgauge/common/clock.h"
#include "hullgauge/common/status.h"

namespace hg::drivers {

enum class LifecycleState { Unconfigured, Inactive, Active, Failed };
constexpr auto nameTable(LifecycleState)
{
    using enum LifecycleState;
    return std::to_array<EnumName<LifecycleState>>(
        {{Unconfigured, "unconfigured"}, {Inactive, "inactive"}, {Active, "active"}, {Failed, "failed"}});
}

enum class Transition { Configure, Activate, Deactivate, Cleanup };
constexpr auto nameTable(Transition)
{
    using enum Transition;
    return std::to_array<EnumName<Transition>>(
        {{Configure, "configure"}, {Activate, "activate"}, {Deactivate, "deactivate"}, {Cleanup, "cleanup"}});
}

/// The transition table: where `t` may start from (cleanup: Inactive or Failed).
constexpr bool allowed(LifecycleState from, Transition t)
{
    using S = LifecycleState;
    switch (t) {
    case Transition::Configure:
        return from == S::Unconfigured;
    case Transition::Activate:
        return from == S::Inactive;
    case Transition::Deactivate:
        return from == S::Active;
    case Transition::Cleanup:
        return from == S::Inactive || from == S::Failed;
    }
    return false;
}

/// The state a successful `t` leads to.
constexpr LifecycleState target(Transition t)
{
    using S = LifecycleState;
    constexpr LifecycleState to[] = {S::Inactive, S::Active, S::Inactive, S::Unconfigured};
    return to[static_cast<int>(t)];
}

/// What a lifecycle hook answers: success, failure (stay) or error (Failed).
class [[nodiscard]] HookResult {
  public:
    /// Success, or a failure after which the driver stays in its state.
    HookResult(Status status) : status_(std::move(status)) {} // NOLINT: implicit by design
    /// The device is left in an unknown state: the driver enters Failed.
    static HookResult error(Status status)
    {
        HookResult r(std::move(status));
        r.error_ = true;
        return r;
    }
    const Status& status() const { return status_; }
    bool isError() const { return error_ && !status_.ok(); }

  private:
    Status status_;
    bool error_ = false;
};

/// The base of Camera, Fixture and Lamps: the public transitions around the
/// backends' hooks, and the one state check of every public call.
class Device {
  public:
    virtual ~Device() = default;
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;

    LifecycleState state() const { return state_.load(); }

    /// Unconfigured -> Inactive. A failure runs the cleanup hook (nothing stays half open).
    Status configure() { return run(Transition::Configure); }
    /// Inactive -> Active.
    Status activate() { return run(Transition::Activate); }
    /// Active -> Inactive.
    Status deactivate() { return run(Transition::Deactivate); }
    /// Inactive/Failed -> Unconfigured, always: the hook releases what it can.
    Status cleanup() { return run(Transition::Cleanup); }

    /// The device kind ("camera", "fixture", "lamps"): message prefix and log category.
    const std::string& kind() const { return kind_; }
    /// The clock the driver times and waits on: the one its factory was given
    /// (docs/drivers.md), the steady clock unless a test injects its own.
    Clock& clock() const { return clock_; }

  protected:
    Device(std::string kind, Clock& clock) : kind_(std::move(kind)), clock_(clock) {}

    virtual HookResult onConfigure() = 0;
    virtual HookResult onActivate() = 0;
    virtual HookResult onDeactivate() = 0;
    virtual void onCleanup() = 0;

    /// Success when the driver is in one of `states`, else NotAllowed naming
    /// the call, the current state and the states it needs.
    Status require(std::initializer_list<LifecycleState> states, std::string_view call) const;
    /// A failure of a cyclic call that leaves the device unusable: enters
    /// Failed (cleanup and configure recover) and returns `failure`.
    Status fail(Status failure);
    /// Held by every transition while its hook runs; drivers used from several
    /// threads (the lamps' blink timer) hold it for their own calls too.
    std::mutex& mutex() const { return mutex_; }

  private:
    Status run(Transition t);
    HookResult hook(Transition t);
    Status notAllowed(std::string_view call, const std::string& needs) const;

    std::string kind_;
    Clock& clock_;
    mutable std::mutex mutex_;
    std::atomic<LifecycleState> state_{LifecycleState::Unconfigured};
};

} // namespace hg::drivers
