#include "hullgauge/station/cycle_rules.h"

namespace hg::station {

SequencerEvent moveEvent(StatusCode code)
{
    switch (code) {
    case StatusCode::Ok:
        return SequencerEvent::InPosition;
    case StatusCode::Timeout:
        return SequencerEvent::MoveTimeout;
    case StatusCode::Fault:
        return SequencerEvent::MoveFault;
    case StatusCode::NotAllowed:
        return SequencerEvent::MoveRefused;
    default:
        return SequencerEvent::MoveCommError;
    }
}

SequencerEvent grabEvent(StatusCode code)
{
    switch (code) {
    case StatusCode::Ok:
        return SequencerEvent::FrameOk;
    case StatusCode::Timeout:
        return SequencerEvent::FrameTimeout;
    case StatusCode::BadFrame:
        return SequencerEvent::FrameBad;
    default:
        return SequencerEvent::FrameError;
    }
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

LampPattern lampPattern(SequencerState state, Verdict lastVerdict, FaultCode lastFault)
{
    if (state == SequencerState::Fault) return LampPattern::Fault;
    if (isBusy(state) || state == SequencerState::Calibrating) return LampPattern::Busy;
    if (state != SequencerState::Done) return LampPattern::Off;
    if (lastVerdict == Verdict::Pass) return LampPattern::Pass;
    if (lastVerdict == Verdict::Fail) return LampPattern::Fail;
    if (lastFault == FaultCode::PartNotSeated) return LampPattern::Reseat;
    return LampPattern::Off;
}

PlcStatus plcStatus(SequencerState state)
{
    switch (state) {
    case SequencerState::Starting:
        return PlcStatus::Starting;
    case SequencerState::Ready:
        return PlcStatus::Ready;
    case SequencerState::Done:
        return PlcStatus::Done;
    case SequencerState::Fault:
        return PlcStatus::Fault;
    case SequencerState::Calibrating:
        return PlcStatus::Maintenance;
    default:
        return PlcStatus::Busy;
    }
}

} // namespace hg::station
