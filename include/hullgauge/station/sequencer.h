// The capture sequencer as an explicit state machine (docs/style.md point 6).
//
// Pure logic: it consumes events (what the devices and the pipeline reported)
// and answers the next action; the daemon's cycle runner performs the actions
// against the drivers and feeds their outcomes back. So every path — timeouts,
// the retries, aborts, faults — is decided here and unit-tested without
// hardware.
//
//   Starting --devices active--> Ready --trigger--> Moving(0)
//   Moving(k) --in position--> Settling(k) --settled--> Grabbing(k)
//   Grabbing(k) --frame ok--> Moving(k+1), or Processing after the last view
//   Processing --processed--> Done --trigger--> Moving(0)
//   Processing --not seated--> Done (result error, part-not-seated: re-seat, trigger again)
//   Moving/Grabbing --device failure--> same state again (up to `retries` times), then Fault
//   busy --program or inspection error--> Done (result error; devices are fine)
//   Moving/Settling/Grabbing --abort--> Done (result aborted)
//   Fault --recovered--> Ready;  any --devices failed--> Fault
// The table of allowed transitions is transitionAllowed(), checked on every
// transition in every build: a transition the table does not list is not
// taken; the sequencer goes to Fault with FaultCode::Internal instead (Fault
// is reachable from every state), so a bug in the table or the rules shows as
// a recorded internal error, not as a silently inconsistent state. The
// runner's view of "busy" is Moving, Settling, Grabbing and Processing together.
//
// Recovery (docs/plc.md, "The handshake"): the sequencer says when the runner
// recovers the devices — at once after a faulted cycle or on COMMAND = 2
// (FaultReset), after `recoveryRetry` (2 s by default) when the devices failed
// to start or a recovery failed.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "hullgauge/common/enum_names.h"

namespace hg::station {

/// Calibrating: the live fixture calibration runs from the maintenance socket
/// (production paused, PLC STATUS 5).
enum class SequencerState { Starting, Ready, Moving, Settling, Grabbing, Processing, Done, Fault, Calibrating };
constexpr auto nameTable(SequencerState)
{
    using enum SequencerState;
    return std::to_array<EnumName<SequencerState>>({{Starting, "starting"},
                                                    {Ready, "ready"},
                                                    {Moving, "moving"},
                                                    {Settling, "settling"},
                                                    {Grabbing, "grabbing"},
                                                    {Processing, "processing"},
                                                    {Done, "done"},
                                                    {Fault, "fault"},
                                                    {Calibrating, "calibrating"}});
}

enum class SequencerEvent {
    DevicesActive,    ///< drivers configured and active (start, or after recovery)
    DevicesFailed,    ///< drivers could not be started or were lost
    Trigger,          ///< an accepted trigger
    InPosition,       ///< the fixture reached the view's pose
    MoveTimeout,      ///< no position within the move timeout
    MoveFault,        ///< the drive reports a fault
    MoveCommError,    ///< no answer from the fixture
    MoveRefused,      ///< pose out of range, not homed, wrong state
    Settled,          ///< settle time after the move elapsed
    FrameOk,          ///< a complete frame of the view
    FrameTimeout,     ///< no frame within the grab timeout
    FrameBad,         ///< incomplete frame (lost packets, wrong size)
    FrameError,       ///< the camera could not grab (wrong state, device lost)
    Processed,        ///< the pipeline delivered the verdict
    ProcessingFailed, ///< the pipeline could not decide (error in the inspection)
    NotSeated,        ///< the part is seated beyond the part program's alignment limits (docs/alignment.md)
    ProgramFailed,    ///< the part program or its view plan could not be loaded
    Abort,            ///< COMMAND = abort from the PLC (or the maintenance socket)
    Shutdown,         ///< SIGTERM: abort unless only processing remains
    Recovered,        ///< recovery after a fault succeeded
    RecoveryFailed,   ///< recovery after a fault failed (the runner tries again later)
    CalibrationStart, ///< a calibration requested on the maintenance socket begins (idle station only)
    CalibrationEnd,   ///< the calibration sequence ended (solved, failed or cancelled)
    FaultReset,       ///< COMMAND = 2 from the PLC: retry the recovery now (in Fault only)
};
constexpr auto nameTable(SequencerEvent)
{
    using enum SequencerEvent;
    return std::to_array<EnumName<SequencerEvent>>({{DevicesActive, "devices-active"},
                                                    {DevicesFailed, "devices-failed"},
                                                    {Trigger, "trigger"},
                                                    {InPosition, "in-position"},
                                                    {MoveTimeout, "move-timeout"},
                                                    {MoveFault, "move-fault"},
                                                    {MoveCommError, "move-comm-error"},
                                                    {MoveRefused, "move-refused"},
                                                    {Settled, "settled"},
                                                    {FrameOk, "frame-ok"},
                                                    {FrameTimeout, "frame-timeout"},
                                                    {FrameBad, "frame-bad"},
                                                    {FrameError, "frame-error"},
                                                    {Processed, "processed"},
                                                    {ProcessingFailed, "processing-failed"},
                                                    {NotSeated, "not-seated"},
                                                    {ProgramFailed, "program-failed"},
                                                    {Abort, "abort"},
                                                    {Shutdown, "shutdown"},
                                                    {Recovered, "recovered"},
                                                    {RecoveryFailed, "recovery-failed"},
                                                    {CalibrationStart, "calibration-start"},
                                                    {CalibrationEnd, "calibration-end"},
                                                    {FaultReset, "fault-reset"}});
}

/// FAULT_CODE register values (docs/plc.md lists them for PLC programmers).
/// 1x camera, 2x fixture, 3x part program / inspection, 4x daemon.
enum class FaultCode : std::uint16_t {
    None = 0,
    CameraTimeout = 10,        ///< no frame within grab_timeout_s, after the retries
    CameraBadFrame = 11,       ///< incomplete frames (lost packets), after the retries
    CameraError = 12,          ///< the camera could not grab (state, device lost)
    FixtureTimeout = 20,       ///< not in position within move_timeout_s, after the retries
    FixtureFault = 21,         ///< the drive latched a fault, still there after reset and retry
    FixtureCommunication = 22, ///< the fixture does not answer
    FixtureRefused = 23,       ///< pose out of range or fixture not homed, after re-homing
    ProgramLoad = 30,          ///< part program or view plan failed to load
    InspectionError = 31,      ///< the inspection could not be computed
    PartNotSeated = 32,        ///< extension: the seat is beyond the alignment limits; re-seat and trigger again
    AbortedByPlc = 40,         ///< COMMAND = 1 during a cycle
    AbortedByShutdown = 41,    ///< the daemon was stopped during a cycle
    ResultStore = 42,          ///< the result could not be committed to the database
    DevicesDown = 43,          ///< drivers could not be started or recovered
    Internal = 44,             ///< unexpected internal error
};
constexpr auto nameTable(FaultCode)
{
    using enum FaultCode;
    return std::to_array<EnumName<FaultCode>>({{None, "none"},
                                               {CameraTimeout, "camera-timeout"},
                                               {CameraBadFrame, "camera-bad-frame"},
                                               {CameraError, "camera-error"},
                                               {FixtureTimeout, "fixture-timeout"},
                                               {FixtureFault, "fixture-fault"},
                                               {FixtureCommunication, "fixture-communication"},
                                               {FixtureRefused, "fixture-refused"},
                                               {ProgramLoad, "program-load"},
                                               {InspectionError, "inspection-error"},
                                               {PartNotSeated, "part-not-seated"},
                                               {AbortedByPlc, "aborted-by-plc"},
                                               {AbortedByShutdown, "aborted-by-shutdown"},
                                               {ResultStore, "result-store"},
                                               {DevicesDown, "devices-down"},
                                               {Internal, "internal"}});
}

/// A sentence for operators ("the fixture did not reach position within the move
/// timeout (after 2 retries)"); `retries`: the extra attempts the faulted cycle had.
std::string describe(FaultCode c, int retries);
/// The sentence alone, without the retries ("unknown fault" for a code not in the table).
std::string describe(FaultCode c);
/// What the operator does about the fault (empty for None): the line view
/// shows it under the sentence (docs/hmi.md, "Line view").
std::string_view faultAction(FaultCode c);

/// The transition table: may the sequencer go from `from` to `to`?
bool transitionAllowed(SequencerState from, SequencerState to);

/// True in Moving, Settling, Grabbing and Processing (STATUS busy).
bool isBusy(SequencerState s);

/// What the runner does next.
struct SequencerAction {
    enum class Kind {
        None,    ///< wait for the next event (idle, or a step still running)
        MoveTo,  ///< move the fixture to `view`'s pose; `retry`: reset a drive fault / re-home first
        Settle,  ///< wait the settle time at `view`
        Grab,    ///< grab `view`; hand the frame to the pipeline as soon as it is in
        Finish,  ///< all views grabbed: wait for the pipeline's verdict
        Publish, ///< the cycle ended: commit the record, then show the result to the PLC
        Recover, ///< bring the devices back (reset faults, re-home, restart streaming) after `delay`
    };
    Kind kind = Kind::None;
    std::size_t view = 0;
    bool retry = false;
    /// Publish: stop the fixture first (the cycle ended while it may be moving).
    bool stopMotion = false;
    /// Recover: wait this long first (0: at once).
    std::chrono::milliseconds delay{0};
    bool operator==(const SequencerAction&) const = default;
};

/// How a published cycle ended.
enum class CycleOutcome { Inspected, Aborted, Faulted };

class CaptureSequencer {
  public:
    /// The transition check; tests pass a stricter one to see an illegal transition handled.
    using TransitionCheck = bool (*)(SequencerState from, SequencerState to);

    /// `retries`: extra attempts of a failed move or grab (the station's default is 1);
    /// `recoveryRetry`: the wait before another recovery after one failed.
    explicit CaptureSequencer(int retries = 1, std::chrono::milliseconds recoveryRetry = std::chrono::seconds(2),
                              TransitionCheck allowed = transitionAllowed);

    /// The retries of the cycles triggered from now on (a reloaded
    /// `sequencer.retries`, docs/daemon.md); a cycle under way keeps the count it started with.
    void setRetries(int retries);
    /// The extra attempts of a failed step in the current (or last) cycle.
    int retries() const { return retries_; }

    SequencerState state() const { return state_; }
    /// Current view (0-based) while busy.
    std::size_t view() const { return view_; }
    std::size_t viewCount() const { return viewCount_; }
    /// Attempts made at the current step (1 = first try).
    int attempt() const { return attempt_; }
    /// Why the last cycle faulted or was aborted (None after a clean cycle).
    FaultCode faultCode() const { return faultCode_; }
    CycleOutcome outcome() const { return outcome_; }
    /// The last transition the table refused ({from, to}); equal states when none was.
    std::pair<SequencerState, SequencerState> refusedTransition() const { return refused_; }

    /// Starts a cycle over `viewCount` views (only from Ready or Done; a
    /// trigger in any other state is the caller's bug: the register map refuses it).
    SequencerAction trigger(std::size_t viewCount);
    /// Feeds an event; returns the next action. Events that do not apply in
    /// the current state (a late frame after an abort) change nothing and return None.
    SequencerAction onEvent(SequencerEvent event);
    /// After the runner published a cycle: Recover at once when the cycle left
    /// the station in Fault, None otherwise.
    SequencerAction afterPublish() const;

  private:
    std::optional<SequencerAction> onStationEvent(SequencerEvent event);
    SequencerAction onStepEvent(SequencerEvent event);
    SequencerAction go(SequencerState to, SequencerAction action);
    SequencerAction internalFault(SequencerState refusedTo);
    SequencerAction recoverAfter(std::chrono::milliseconds delay);
    SequencerAction failStep(FaultCode code, SequencerAction retryAction);
    /// `toFault`: the devices need recovery before the next cycle (else Done).
    SequencerAction endCycle(CycleOutcome outcome, FaultCode code, bool stopMotion, bool toFault);

    int retries_;     ///< of the current (or last) cycle
    int nextRetries_; ///< taken by the next trigger
    std::chrono::milliseconds recoveryRetry_;
    TransitionCheck allowed_;
    std::pair<SequencerState, SequencerState> refused_{SequencerState::Starting, SequencerState::Starting};
    SequencerState state_ = SequencerState::Starting;
    std::size_t view_ = 0;
    std::size_t viewCount_ = 0;
    int attempt_ = 0;
    FaultCode faultCode_ = FaultCode::None;
    CycleOutcome outcome_ = CycleOutcome::Inspected;
};

} // namespace hg::station
