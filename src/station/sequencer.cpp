#include "hullgauge/station/sequencer.h"

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "hullgauge/common/enum_table.h"

namespace hg::station {
namespace {

using S = SequencerState;
using E = SequencerEvent;
using A = SequencerAction::Kind;

// The allowed transitions (from, to); self-transitions are the retries (and, from
// Done, a trigger whose plan has no views, which ends at once as program-load).
constexpr std::array<std::pair<S, S>, 28> kTransitions{{
    {S::Starting, S::Ready},    {S::Starting, S::Fault},    {S::Ready, S::Moving},      {S::Ready, S::Fault},
    {S::Done, S::Moving},       {S::Done, S::Fault},        {S::Moving, S::Moving},     {S::Moving, S::Settling},
    {S::Moving, S::Done},       {S::Moving, S::Fault},      {S::Settling, S::Grabbing}, {S::Settling, S::Done},
    {S::Settling, S::Fault},    {S::Grabbing, S::Grabbing}, {S::Grabbing, S::Moving},   {S::Grabbing, S::Processing},
    {S::Grabbing, S::Done},     {S::Grabbing, S::Fault},    {S::Processing, S::Done},   {S::Processing, S::Fault},
    {S::Fault, S::Ready},       {S::Fault, S::Fault},       {S::Ready, S::Calibrating}, {S::Done, S::Calibrating},
    {S::Calibrating, S::Ready}, {S::Calibrating, S::Fault}, {S::Ready, S::Done},        {S::Done, S::Done},
}};

/// How an operator reads a fault code (docs/plc.md, "Fault codes") and what
/// to do about it: the one table of these words — `hullgauge ctl status` shows
/// the sentence, the line view (docs/hmi.md, "Line view") both.
struct FaultSentence {
    std::string_view text;
    bool afterRetries = false; ///< the step was retried: the sentence says how often
    std::string_view action = {};
};
constexpr bool kAfterRetries = true;

constexpr auto kFaultSentences = std::to_array<EnumRow<FaultCode, FaultSentence>>({
    {FaultCode::None, {"no fault"}},
    {FaultCode::CameraTimeout,
     {"no frame from the camera within the grab timeout", kAfterRetries,
      "The station restarts the camera by itself. If the fault returns, check the camera's cable and power and call "
      "maintenance."}},
    {FaultCode::CameraBadFrame,
     {"the camera delivered incomplete frames", kAfterRetries,
      "The station restarts the camera by itself. If the fault returns, check the camera's network cable and call "
      "maintenance."}},
    {FaultCode::CameraError,
     {"the camera could not grab", false,
      "The station restarts the camera by itself. If the fault stays, check the camera's power and call maintenance."}},
    {FaultCode::FixtureTimeout,
     {"the fixture did not reach position within the move timeout", kAfterRetries,
      "Check that nothing blocks the fixture; the station re-homes it by itself. Then inspect the part again."}},
    {FaultCode::FixtureFault,
     {"the fixture drive reports a fault that a reset did not clear", false,
      "Check the fixture drive (emergency stop, overload), clear its fault, then reset the fault from the PLC."}},
    {FaultCode::FixtureCommunication,
     {"the fixture does not answer", false,
      "Check the fixture drive's power and cable; the station reconnects by itself."}},
    {FaultCode::FixtureRefused,
     {"the fixture refused the pose (out of range or not homed)", false,
      "The station re-homes the fixture by itself. If the fault stays, call maintenance."}},
    {FaultCode::ProgramLoad,
     {"the part program or its view plan could not be loaded", false,
      "Call the manufacturing engineer: the part program cannot be used. The part was not inspected."}},
    {FaultCode::InspectionError,
     {"the inspection could not be computed", false,
      "Inspect the part again. If the fault returns, set the part aside and call maintenance."}},
    {FaultCode::PartNotSeated,
     {"the part is not seated within the part program's alignment limits: re-seat it and trigger again", false,
      "Re-seat the part in the nest and inspect it again."}},
    {FaultCode::AbortedByPlc, {"the PLC aborted the cycle", false, "The part was not judged: inspect it again."}},
    {FaultCode::AbortedByShutdown,
     {"the daemon was stopped during the cycle", false,
      "The part was not judged: inspect it again once the station is back."}},
    {FaultCode::ResultStore,
     {"the result could not be committed to the result database", false,
      "Set the part aside (its result was not recorded) and call maintenance: the result disk may be full."}},
    {FaultCode::DevicesDown,
     {"the camera or fixture could not be started", false,
      "Check the camera's and the fixture's power and cables; the station tries again every few seconds."}},
    {FaultCode::Internal,
     {"internal error", false, "Call maintenance with the time shown; the station recovers by itself."}},
});

} // namespace

bool transitionAllowed(SequencerState from, SequencerState to)
{
    for (auto [f, t] : kTransitions)
        if (f == from && t == to) return true;
    return false;
}

bool isBusy(SequencerState s)
{
    return s == S::Moving || s == S::Settling || s == S::Grabbing || s == S::Processing;
}

std::string describe(FaultCode c)
{
    const std::optional<FaultSentence> sentence = mapEnum<kFaultSentences>(c);
    return sentence ? std::string(sentence->text) : "unknown fault";
}

std::string describe(FaultCode c, int retries)
{
    const std::optional<FaultSentence> sentence = mapEnum<kFaultSentences>(c);
    if (!sentence) return "unknown fault";
    if (!sentence->afterRetries) return std::string(sentence->text);
    // A step that failed after its retries says how many the cycle had (docs/plc.md, "Fault codes").
    const std::string afterRetries = retries <= 0   ? " (without a retry)"
                                     : retries == 1 ? " (after one retry)"
                                                    : " (after " + std::to_string(retries) + " retries)";
    return std::string(sentence->text) + afterRetries;
}

std::string_view faultAction(FaultCode c)
{
    const std::optional<FaultSentence> sentence = mapEnum<kFaultSentences>(c);
    return sentence ? sentence->action : std::string_view("Call maintenance: the station reports an unknown fault.");
}

CaptureSequencer::CaptureSequencer(int retries, std::chrono::milliseconds recoveryRetry, TransitionCheck allowed)
    : retries_(retries < 0 ? 0 : retries), nextRetries_(retries_), recoveryRetry_(recoveryRetry), allowed_(allowed)
{
}

void CaptureSequencer::setRetries(int retries)
{
    nextRetries_ = retries < 0 ? 0 : retries;
}

SequencerAction CaptureSequencer::go(SequencerState to, SequencerAction action)
{
    if (!allowed_(state_, to)) return internalFault(to);
    state_ = to;
    return action;
}

SequencerAction CaptureSequencer::internalFault(SequencerState refusedTo)
{
    // Fault is entered directly: it is the state every other one may fall into.
    refused_ = {state_, refusedTo};
    const bool inCycle = isBusy(state_);
    state_ = S::Fault;
    faultCode_ = FaultCode::Internal;
    if (!inCycle) return recoverAfter(std::chrono::milliseconds(0));
    outcome_ = CycleOutcome::Faulted;
    return {A::Publish, view_, false, true};
}

SequencerAction CaptureSequencer::recoverAfter(std::chrono::milliseconds delay)
{
    SequencerAction a{A::Recover, 0, false, false};
    a.delay = delay;
    return a;
}

SequencerAction CaptureSequencer::trigger(std::size_t viewCount)
{
    if (state_ != S::Ready && state_ != S::Done) return {};
    retries_ = nextRetries_;
    viewCount_ = viewCount;
    view_ = 0;
    attempt_ = 1;
    faultCode_ = FaultCode::None;
    outcome_ = CycleOutcome::Inspected;
    if (viewCount == 0) {
        // A view plan without views cannot be inspected; the loader refuses it, so this is a bug upstream.
        return endCycle(CycleOutcome::Faulted, FaultCode::ProgramLoad, false, false);
    }
    return go(S::Moving, {A::MoveTo, 0, false, false});
}

SequencerAction CaptureSequencer::failStep(FaultCode code, SequencerAction retryAction)
{
    if (attempt_ <= retries_) {
        ++attempt_;
        retryAction.retry = true;
        return go(state_, retryAction);
    }
    return endCycle(CycleOutcome::Faulted, code, true, true);
}

SequencerAction CaptureSequencer::endCycle(CycleOutcome outcome, FaultCode code, bool stopMotion, bool toFault)
{
    outcome_ = outcome;
    faultCode_ = code;
    auto to = toFault ? S::Fault : S::Done;
    return go(to, {A::Publish, view_, false, stopMotion});
}

SequencerAction CaptureSequencer::afterPublish() const
{
    return state_ == S::Fault ? SequencerAction{A::Recover, 0, false, false} : SequencerAction{};
}

SequencerAction CaptureSequencer::onEvent(SequencerEvent event)
{
    if (auto action = onStationEvent(event)) return *action;
    return onStepEvent(event);
}

// The events that mean the same in every state: devices, commands, recovery, calibration.
std::optional<SequencerAction> CaptureSequencer::onStationEvent(SequencerEvent event)
{
    const bool busy = isBusy(state_);
    switch (event) {
    case E::DevicesActive:
        if (state_ == S::Starting) return go(S::Ready, {});
        return SequencerAction{};
    case E::DevicesFailed:
        if (busy) return endCycle(CycleOutcome::Faulted, FaultCode::DevicesDown, true, true);
        if (state_ == S::Fault) return SequencerAction{};
        faultCode_ = FaultCode::DevicesDown;
        return go(S::Fault, recoverAfter(recoveryRetry_));
    case E::Trigger:
        return SequencerAction{}; // use trigger(viewCount)
    case E::Abort:
    case E::Shutdown:
        // Processing takes milliseconds and needs no device: let it finish so its result is recorded.
        if (state_ == S::Moving || state_ == S::Settling || state_ == S::Grabbing)
            return endCycle(CycleOutcome::Aborted,
                            event == E::Abort ? FaultCode::AbortedByPlc : FaultCode::AbortedByShutdown, true, false);
        return SequencerAction{};
    case E::Recovered:
        if (state_ == S::Fault) return go(S::Ready, {});
        return SequencerAction{};
    case E::RecoveryFailed:
        if (state_ == S::Fault) return go(S::Fault, recoverAfter(recoveryRetry_));
        return SequencerAction{};
    case E::FaultReset:
        if (state_ == S::Fault) return go(S::Fault, recoverAfter(std::chrono::milliseconds(0)));
        return SequencerAction{};
    case E::ProgramFailed:
        if (busy) return endCycle(CycleOutcome::Faulted, FaultCode::ProgramLoad, true, false);
        return SequencerAction{};
    case E::CalibrationStart:
        if (state_ == S::Ready || state_ == S::Done) return go(S::Calibrating, {});
        return SequencerAction{};
    case E::CalibrationEnd:
        if (state_ == S::Calibrating) return go(S::Ready, {});
        return SequencerAction{};
    default:
        return std::nullopt;
    }
}

// The outcomes of the cycle's steps, in the state that performs the step.
SequencerAction CaptureSequencer::onStepEvent(SequencerEvent event)
{
    switch (state_) {
    case S::Moving:
        switch (event) {
        case E::InPosition:
            attempt_ = 1;
            return go(S::Settling, {A::Settle, view_, false, false});
        case E::MoveTimeout:
            return failStep(FaultCode::FixtureTimeout, {A::MoveTo, view_, true, false});
        case E::MoveFault:
            return failStep(FaultCode::FixtureFault, {A::MoveTo, view_, true, false});
        case E::MoveCommError:
            return failStep(FaultCode::FixtureCommunication, {A::MoveTo, view_, true, false});
        case E::MoveRefused:
            return failStep(FaultCode::FixtureRefused, {A::MoveTo, view_, true, false});
        default:
            return {};
        }
    case S::Settling:
        if (event == E::Settled) return go(S::Grabbing, {A::Grab, view_, false, false});
        return {};
    case S::Grabbing:
        switch (event) {
        case E::FrameOk:
            attempt_ = 1;
            if (view_ + 1 < viewCount_) {
                ++view_;
                return go(S::Moving, {A::MoveTo, view_, false, false});
            }
            return go(S::Processing, {A::Finish, view_, false, false});
        case E::FrameTimeout:
            return failStep(FaultCode::CameraTimeout, {A::Grab, view_, true, false});
        case E::FrameBad:
            return failStep(FaultCode::CameraBadFrame, {A::Grab, view_, true, false});
        case E::FrameError:
            return failStep(FaultCode::CameraError, {A::Grab, view_, true, false});
        default:
            return {};
        }
    case S::Processing:
        if (event == E::Processed) return endCycle(CycleOutcome::Inspected, FaultCode::None, false, false);
        if (event == E::ProcessingFailed)
            return endCycle(CycleOutcome::Faulted, FaultCode::InspectionError, false, false);
        // Nothing is wrong with the station: the PLC re-seats the part and triggers again.
        if (event == E::NotSeated) return endCycle(CycleOutcome::Faulted, FaultCode::PartNotSeated, false, false);
        return {};
    default:
        return {};
    }
}

} // namespace hg::station
