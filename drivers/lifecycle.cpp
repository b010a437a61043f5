// The driver lifecycle written once (lifecycle.h, docs/drivers.md).
#include "hullgauge/drivers/lifecycle.h"

#include <array>

#include "hullgauge/common/log.h"

namespace hg::drivers {

std::string_view toString(LifecycleState s)
{
    constexpr std::array<std::string_view, 4> names{"unconfigured", "inactive", "active", "failed"};
    return names[static_cast<int>(s)];
}

std::string_view toString(Transition t)
{
    constexpr std::array<std::string_view, 4> names{"configure", "activate", "deactivate", "cleanup"};
    return names[static_cast<int>(t)];
}

namespace {
constexpr std::array<LifecycleState, 4> kStates{LifecycleState::Unconfigured, LifecycleState::Inactive,
                                                LifecycleState::Active, LifecycleState::Failed};
} // namespace

Status Device::notAllowed(std::string_view call, const std::string& needs) const
{
    return Status::failure(StatusCode::NotAllowed, kind_ + ": " + std::string(call) + " is not allowed while " +
                                                       std::string(toString(state())) + " (needs " + needs + ")");
}

Status Device::require(std::initializer_list<LifecycleState> states, std::string_view call) const
{
    std::string needs;
    for (LifecycleState s : states) {
        if (s == state()) return Status::success();
        needs += (needs.empty() ? "" : " or ") + std::string(toString(s));
    }
    return notAllowed(call, needs);
}

Status Device::fail(Status failure)
{
    state_ = LifecycleState::Failed;
    log::category(kind_)->error("{} (now failed; cleanup and configure recover)", failure.message());
    return failure;
}

HookResult Device::hook(Transition t)
{
    switch (t) {
    case Transition::Configure:
        return onConfigure();
    case Transition::Activate:
        return onActivate();
    case Transition::Deactivate:
        return onDeactivate();
    case Transition::Cleanup:
        onCleanup();
        return Status::success();
    }
    return Status::success();
}

Status Device::run(Transition t)
{
    std::lock_guard lock(mutex_);
    const LifecycleState from = state();
    if (!allowed(from, t)) {
        std::string needs;
        for (LifecycleState s : kStates)
            if (allowed(s, t)) needs += (needs.empty() ? "" : " or ") + std::string(toString(s));
        return notAllowed(toString(t), needs);
    }
    HookResult r = hook(t);
    auto log = log::category(kind_);
    if (r.status().ok()) {
        state_ = target(t);
        log->info("{}: {} -> {}", kind_, toString(from), toString(target(t)));
    } else if (r.isError()) {
        state_ = LifecycleState::Failed;
        log->error("{} failed: {} (now failed)", toString(t), r.status().message());
    } else {
        // Configure leaves nothing half open: whatever the hook opened is released.
        if (t == Transition::Configure) onCleanup();
        log->error("{} failed: {} (still {})", toString(t), r.status().message(), toString(from));
    }
    return r.status();
}

} // namespace hg::drivers
