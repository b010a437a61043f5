// The lifecycle every driver follows (after ros2_control's hardware_interface):
//
//   Unconfigured --configure--> Inactive --activate--> Active
//   Active --deactivate--> Inactive --cleanup--> Unconfigured
//   any --error--> Failed --cleanup--> Unconfigured (then configure again to recover)
//
// `init` (constructing the driver from its configuration section) only parses
// and validates — it opens nothing. `configure` opens communication, `activate`
// starts motion/streaming/power. The cyclic path (grab, moveTo, setLamp, ...)
// returns small status values and never throws; only load-time errors throw.
#pragma once

#include <array>
#include <string_view>

namespace hg::drivers {

enum class LifecycleState { Unconfigured, Inactive, Active, Failed };

enum class Transition { Configure, Activate, Deactivate, Cleanup, Error };

/// The transition table: the state reached by `t` from `from`, or `from`
/// itself when the transition is not allowed there (callers check).
constexpr LifecycleState nextState(LifecycleState from, Transition t)
{
    using S = LifecycleState;
    switch (t) {
    case Transition::Configure:
        return from == S::Unconfigured ? S::Inactive : from;
    case Transition::Activate:
        return from == S::Inactive ? S::Active : from;
    case Transition::Deactivate:
        return from == S::Active ? S::Inactive : from;
    case Transition::Cleanup:
        return (from == S::Inactive || from == S::Failed) ? S::Unconfigured : from;
    case Transition::Error:
        return S::Failed;
    }
    return from;
}

constexpr bool allowed(LifecycleState from, Transition t)
{
    return t == Transition::Error || nextState(from, t) != from;
}

constexpr std::string_view toString(LifecycleState s)
{
    constexpr std::array<std::string_view, 4> names{"unconfigured", "inactive", "active", "failed"};
    return names[static_cast<int>(s)];
}

} // namespace hg::drivers
