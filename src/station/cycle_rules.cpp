#include "hullgauge/station/cycle_rules.h"

#include <array>

#include "hullgauge/common/enum_table.h"

namespace hg::station {
namespace {

using E = SequencerEvent;

/// The event a device's status feeds to the sequencer after a move and after a grab.
struct StepEvents {
    SequencerEvent move;
    SequencerEvent grab;
};

// A move that failed for a reason the fixture does not name is a communication failure; a
// grab that failed otherwise than by timeout or an incomplete frame, a camera that could not grab.
constexpr auto kStepEvents = std::to_array<EnumRow<StatusCode, StepEvents>>({
    {StatusCode::Ok, {E::InPosition, E::FrameOk}},
    {StatusCode::Timeout, {E::MoveTimeout, E::FrameTimeout}},
    {StatusCode::Fault, {E::MoveFault, E::FrameError}},
    {StatusCode::CommunicationError, {E::MoveCommError, E::FrameError}},
    {StatusCode::IoError, {E::MoveCommError, E::FrameError}},
    {StatusCode::NotAllowed, {E::MoveRefused, E::FrameError}},
    {StatusCode::BadFrame, {E::MoveCommError, E::FrameBad}},
    {StatusCode::Error, {E::MoveCommError, E::FrameError}},
});

/// A code that is no StatusCode (a cast from a number) counts as StatusCode::Error.
StepEvents stepEvents(StatusCode code)
{
    return mapEnum<kStepEvents>(code).value_or(StepEvents{E::MoveCommError, E::FrameError});
}

// STATUS (docs/plc.md): every state of a running cycle is busy.
constexpr auto kPlcStatus = std::to_array<EnumRow<SequencerState, PlcStatus>>({
    {SequencerState::Starting, PlcStatus::Starting},
    {SequencerState::Ready, PlcStatus::Ready},
    {SequencerState::Moving, PlcStatus::Busy},
    {SequencerState::Settling, PlcStatus::Busy},
    {SequencerState::Grabbing, PlcStatus::Busy},
    {SequencerState::Processing, PlcStatus::Busy},
    {SequencerState::Done, PlcStatus::Done},
    {SequencerState::Fault, PlcStatus::Fault},
    {SequencerState::Calibrating, PlcStatus::Maintenance},
});

} // namespace

SequencerEvent moveEvent(StatusCode code)
{
    return stepEvents(code).move;
}

SequencerEvent grabEvent(StatusCode code)
{
    return stepEvents(code).grab;
}

Verdict verdictOf(CycleOutcome outcome, bool inspectionPassed)
{
    switch (outcome) {
    case CycleOutcome::Inspected:
        return inspectionPassed ? Verdict::Pass : Verdict::Fail;
    case CycleOutcome::Aborted:
        return Verdict::Aborted;
    case CycleOutcome::Faulted:
        return Verdict::Error;
    }
    return Verdict::Error;
}

// docs/lamps.md: a fault, a running cycle and a part to re-seat say what the
// operator must do now and come first; the verdict of the part in the nest is
// never hidden (amber steady beside it asks for attention); the refusal shows
// where no verdict is. Amber steady alone stays "busy".
LampPattern lampPattern(SequencerState state, Verdict lastVerdict, FaultCode lastFault, Attention attention)
{
    if (state == SequencerState::Fault) return LampPattern::Fault;
    if (isBusy(state) || state == SequencerState::Calibrating) return LampPattern::Busy;
    if (state != SequencerState::Done && state != SequencerState::Ready) return LampPattern::Off;
    const bool done = state == SequencerState::Done;
    const bool amber = attention.wanted || attention.productionRefused;
    if (done && lastVerdict == Verdict::Pass) return amber ? LampPattern::PassAttention : LampPattern::Pass;
    if (done && lastVerdict == Verdict::Fail) return amber ? LampPattern::FailAttention : LampPattern::Fail;
    if (done && lastFault == FaultCode::PartNotSeated) return LampPattern::Reseat;
    return attention.productionRefused ? LampPattern::Refused : LampPattern::Off;
}

PlcStatus plcStatus(SequencerState state)
{
    return mapEnum<kPlcStatus>(state).value_or(PlcStatus::Busy);
}

} // namespace hg::station
