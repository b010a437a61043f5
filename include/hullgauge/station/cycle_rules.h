// The rules that turn what a cycle's steps reported into what the station
// shows: the sequencer's events from the devices' status codes, the verdict of
// a cycle, the operator lamps (docs/contracts.md §6) and the PLC's STATUS for a
// sequencer state (docs/plc.md). Pure functions beside the sequencer; the
// daemon's cycle runner applies them.
#pragma once

#include "hullgauge/common/status.h"
#include "hullgauge/station/lamp_pattern.h"
#include "hullgauge/station/plc_registers.h"
#include "hullgauge/station/result_record.h"
#include "hullgauge/station/sequencer.h"

namespace hg::station {

/// The event a move's status feeds to the sequencer.
SequencerEvent moveEvent(StatusCode code);
/// The event a grab's status feeds to the sequencer.
SequencerEvent grabEvent(StatusCode code);

/// A published cycle's verdict: pass or fail when it was inspected, aborted, else error.
Verdict verdictOf(CycleOutcome outcome, bool inspectionPassed);

/// What the station asks of the operator between cycles (docs/lamps.md). The
/// daemon's cycle runner says when: re-mastering due of the active program
/// (docs/mastering.md, "Due in the daemon"), and any other warning of the
/// station's that wants a person to act.
struct Attention {
    bool wanted = false;            ///< amber steady beside the verdict lamp
    bool productionRefused = false; ///< production triggers are refused: amber steady, red blinking
};

/// The lamps for the sequencer's state; in Done they show the last verdict
/// (an aborted or failed cycle leaves them off, a part not seated blinks amber),
/// with amber steady beside it while the station asks for attention. While
/// production is refused, Refused shows where no verdict is shown. A fault, a
/// running cycle and a part to re-seat show as they do without attention.
LampPattern lampPattern(SequencerState state, Verdict lastVerdict, FaultCode lastFault = FaultCode::None,
                        Attention attention = {});

/// STATUS for the sequencer's state: busy while a cycle runs, maintenance while calibrating.
PlcStatus plcStatus(SequencerState state);

} // namespace hg::station
