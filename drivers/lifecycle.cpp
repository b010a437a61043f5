// The driver lifecycle written once (lifecycle.h, docs/drivers.md).
#include "hullgauge/drivers/lifecycle.h"

#include <array>

#include "hullgauge/common/log.h"

namespace hg::drivers {

namespace {
constexpr std::array<LifecycleState, 4> kStates{LifecycleState::Unconfigured, LifecycleState::Inactive,
                                                LifecycleState::Active, LifecycleState::Failed};
} // namespace

Status Device::notAllowed(std::string_view call, const std::string& needs) const
{
    return Status::failure(StatusCode::NotAllowed, kind_ + ": " + std::string(call) + " is not allowed while " +
                                                       std::string(enumName(state())) + " (needs " + needs + ")");
}

Status Device::require(std::initializer_list<LifecycleState> states, std::string_view call) const
{
    std::string needs;
    for (LifecycleState s : states) {
        if (s == state()) return Status::success();
        needs += (needs.empty() ? "" : " or ") + std::string(enumName(s));
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
            if (allowed(s, t)) needs += (needs.empty() ? "" : " or ") + std::string(enumName(s));
        return notAllowed(enumName(t), needs);
    }
    HookResult r = hook(t);
    auto log = log::category(kind_);
    if (r.status().ok()) {
        state_ = target(t);
        log->info("{}: {} -> {}", kind_, enumName(from), enumName(target(t)));
    } else if (r.isError()) {
        state_ = LifecycleState::Failed;
        log->error("{} failed: {} (now failed)", enumName(t), r.status().message());
    } else {
        // Configure leaves nothing half open: whatever the hook opened is released.
        if (t == Transition::Configure) onCleanup();
        log->error("{} failed: {} (still {})", enumName(t), r.status().message(), enumName(from));
    }
    return r.status();
}

} // namespace hg::drivers
