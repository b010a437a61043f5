// The capture sequencer's state machine: normal cycles, the retries, faults
// with their codes, aborts, recovery, and the transition table.
#include "hullgauge/station/sequencer.h"

#include <gtest/gtest.h>
#include <set>
#include <vector>

namespace hg::station {
namespace {

using S = SequencerState;
using E = SequencerEvent;
using A = SequencerAction::Kind;

CaptureSequencer readySequencer(int retries = 1)
{
    CaptureSequencer s(retries);
    EXPECT_EQ(s.state(), S::Starting);
    EXPECT_EQ(s.onEvent(E::DevicesActive).kind, A::None);
    EXPECT_EQ(s.state(), S::Ready);
    return s;
}

// Drives one view from Moving to the frame and returns the action after the frame.
SequencerAction completeView(CaptureSequencer& s)
{
    EXPECT_EQ(s.state(), S::Moving);
    auto a = s.onEvent(E::InPosition);
    EXPECT_EQ(a, (SequencerAction{A::Settle, s.view(), false, false}));
    a = s.onEvent(E::Settled);
    EXPECT_EQ(a, (SequencerAction{A::Grab, s.view(), false, false}));
    return s.onEvent(E::FrameOk);
}

TEST(Sequencer, VisitsEveryViewInOrderThenProcesses)
{
    auto s = readySequencer();
    auto a = s.trigger(3);
    EXPECT_EQ(a, (SequencerAction{A::MoveTo, 0, false, false}));
    a = completeView(s);
    EXPECT_EQ(a, (SequencerAction{A::MoveTo, 1, false, false}));
    a = completeView(s);
    EXPECT_EQ(a, (SequencerAction{A::MoveTo, 2, false, false}));
    a = completeView(s);
    EXPECT_EQ(a.kind, A::Finish);
    EXPECT_EQ(s.state(), S::Processing);
    EXPECT_TRUE(isBusy(s.state()));
    a = s.onEvent(E::Processed);
    EXPECT_EQ(a.kind, A::Publish);
    EXPECT_FALSE(a.stopMotion);
    EXPECT_EQ(s.state(), S::Done);
    EXPECT_EQ(s.outcome(), CycleOutcome::Inspected);
    EXPECT_EQ(s.faultCode(), FaultCode::None);
    EXPECT_EQ(s.afterPublish().kind, A::None);
    // The next trigger starts over from Done.
    EXPECT_EQ(s.trigger(1), (SequencerAction{A::MoveTo, 0, false, false}));
}

TEST(Sequencer, OneRetryOfAMoveThenSuccessContinues)
{
    auto s = readySequencer();
    (void)s.trigger(2);
    auto a = s.onEvent(E::MoveTimeout);
    EXPECT_EQ(a, (SequencerAction{A::MoveTo, 0, true, false}));
    EXPECT_EQ(s.state(), S::Moving);
    EXPECT_EQ(s.attempt(), 2);
    a = s.onEvent(E::InPosition);
    EXPECT_EQ(a.kind, A::Settle);
    EXPECT_EQ(s.attempt(), 1); // the next step has its own retry
}

struct FailureCase {
    E event;
    bool duringGrab;
    FaultCode code;
};

class SequencerFailure : public ::testing::TestWithParam<FailureCase> {};

TEST_P(SequencerFailure, SecondFailureFaultsWithItsCode)
{
    auto c = GetParam();
    auto s = readySequencer();
    (void)s.trigger(4);
    (void)completeView(s); // view 0 done; now moving to view 1
    if (c.duringGrab) {
        (void)s.onEvent(E::InPosition);
        (void)s.onEvent(E::Settled);
    }
    auto retry = s.onEvent(c.event);
    EXPECT_TRUE(retry.retry);
    EXPECT_EQ(retry.view, 1u);
    auto end = s.onEvent(c.event);
    EXPECT_EQ(end.kind, A::Publish);
    EXPECT_TRUE(end.stopMotion);
    EXPECT_EQ(s.state(), S::Fault);
    EXPECT_EQ(s.outcome(), CycleOutcome::Faulted);
    EXPECT_EQ(s.faultCode(), c.code);
    EXPECT_EQ(s.afterPublish().kind, A::Recover);
    // A trigger in Fault starts nothing (the register map refuses it first).
    EXPECT_EQ(s.trigger(1).kind, A::None);
    EXPECT_EQ(s.onEvent(E::Recovered).kind, A::None);
    EXPECT_EQ(s.state(), S::Ready);
}

INSTANTIATE_TEST_SUITE_P(Codes, SequencerFailure,
                         ::testing::Values(FailureCase{E::MoveTimeout, false, FaultCode::FixtureTimeout},
                                           FailureCase{E::MoveFault, false, FaultCode::FixtureFault},
                                           FailureCase{E::MoveCommError, false, FaultCode::FixtureCommunication},
                                           FailureCase{E::MoveRefused, false, FaultCode::FixtureRefused},
                                           FailureCase{E::FrameTimeout, true, FaultCode::CameraTimeout},
                                           FailureCase{E::FrameBad, true, FaultCode::CameraBadFrame},
                                           FailureCase{E::FrameError, true, FaultCode::CameraError}));

TEST(Sequencer, NoRetriesConfiguredFaultsAtOnce)
{
    auto s = readySequencer(0);
    (void)s.trigger(1);
    EXPECT_EQ(s.onEvent(E::MoveTimeout).kind, A::Publish);
    EXPECT_EQ(s.faultCode(), FaultCode::FixtureTimeout);
}

// A reload's `sequencer.retries` (docs/daemon.md): taken by the next trigger; the running cycle keeps its count.
TEST(Sequencer, RetriesSetBetweenCyclesApplyFromTheNextTrigger)
{
    auto s = readySequencer(1);
    (void)s.trigger(1);
    s.setRetries(0); // mid-cycle: this cycle still has its retry
    EXPECT_EQ(s.retries(), 1);
    EXPECT_TRUE(s.onEvent(E::MoveTimeout).retry);
    EXPECT_EQ(s.onEvent(E::InPosition).kind, A::Settle);
    EXPECT_EQ(s.onEvent(E::Settled).kind, A::Grab);
    EXPECT_EQ(s.onEvent(E::FrameOk).kind, A::Finish);
    EXPECT_EQ(s.onEvent(E::Processed).kind, A::Publish);

    (void)s.trigger(1);
    EXPECT_EQ(s.retries(), 0);
    EXPECT_EQ(s.onEvent(E::MoveTimeout).kind, A::Publish);
    EXPECT_EQ(s.faultCode(), FaultCode::FixtureTimeout);
    (void)s.onEvent(E::Recovered);

    s.setRetries(3);
    (void)s.trigger(1);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(s.onEvent(E::MoveTimeout).retry) << "retry " << k + 1;
    EXPECT_EQ(s.onEvent(E::MoveTimeout).kind, A::Publish);
    EXPECT_EQ(s.retries(), 3);
}

// The operator's sentence names the retries the faulted cycle had.
TEST(Sequencer, FaultDescriptionsSayHowManyRetries)
{
    EXPECT_EQ(describe(FaultCode::CameraTimeout, 0),
              "no frame from the camera within the grab timeout (without a retry)");
    EXPECT_EQ(describe(FaultCode::CameraTimeout, 1),
              "no frame from the camera within the grab timeout (after one retry)");
    EXPECT_EQ(describe(FaultCode::CameraBadFrame, 2), "the camera delivered incomplete frames (after 2 retries)");
    EXPECT_EQ(describe(FaultCode::FixtureTimeout, 5),
              "the fixture did not reach position within the move timeout (after 5 retries)");
    // Codes whose sentence names no retry do not change with the count.
    EXPECT_EQ(describe(FaultCode::ProgramLoad, 3), describe(FaultCode::ProgramLoad, 0));
}

TEST(Sequencer, AbortStopsMotionAndEndsInDone)
{
    for (int stage = 0; stage < 3; ++stage) {
        auto s = readySequencer();
        (void)s.trigger(2);
        if (stage >= 1) (void)s.onEvent(E::InPosition);
        if (stage >= 2) (void)s.onEvent(E::Settled);
        auto a = s.onEvent(E::Abort);
        EXPECT_EQ(a.kind, A::Publish) << "stage " << stage;
        EXPECT_TRUE(a.stopMotion);
        EXPECT_EQ(s.state(), S::Done);
        EXPECT_EQ(s.outcome(), CycleOutcome::Aborted);
        EXPECT_EQ(s.faultCode(), FaultCode::AbortedByPlc);
        // A frame that arrives after the abort changes nothing.
        EXPECT_EQ(s.onEvent(E::FrameOk).kind, A::None);
        EXPECT_EQ(s.state(), S::Done);
    }
}

TEST(Sequencer, ShutdownLetsProcessingFinish)
{
    auto s = readySequencer();
    (void)s.trigger(1);
    (void)completeView(s);
    EXPECT_EQ(s.onEvent(E::Shutdown).kind, A::None);
    EXPECT_EQ(s.state(), S::Processing);
    EXPECT_EQ(s.onEvent(E::Processed).kind, A::Publish);

    auto t = readySequencer();
    (void)t.trigger(3);
    EXPECT_EQ(t.onEvent(E::Shutdown).kind, A::Publish);
    EXPECT_EQ(t.faultCode(), FaultCode::AbortedByShutdown);
    EXPECT_EQ(t.outcome(), CycleOutcome::Aborted);
}

TEST(Sequencer, InspectionErrorEndsTheCycleWithoutStationFault)
{
    auto s = readySequencer();
    (void)s.trigger(1);
    (void)completeView(s);
    EXPECT_EQ(s.onEvent(E::ProcessingFailed).kind, A::Publish);
    EXPECT_EQ(s.state(), S::Done);
    EXPECT_EQ(s.faultCode(), FaultCode::InspectionError);
    EXPECT_EQ(s.outcome(), CycleOutcome::Faulted);
}

TEST(Sequencer, PartNotSeatedEndsTheCycleReadyForTheNextTrigger)
{
    auto s = readySequencer();
    (void)s.trigger(1);
    (void)completeView(s);
    const auto a = s.onEvent(E::NotSeated);
    EXPECT_EQ(a.kind, A::Publish);
    EXPECT_FALSE(a.stopMotion);
    EXPECT_EQ(s.state(), S::Done); // STATUS 2: the PLC re-seats and triggers again, no recovery
    EXPECT_EQ(s.faultCode(), FaultCode::PartNotSeated);
    EXPECT_EQ(static_cast<int>(FaultCode::PartNotSeated), 32);
    EXPECT_EQ(hg::enumName(FaultCode::PartNotSeated), "part-not-seated");
    EXPECT_EQ(s.outcome(), CycleOutcome::Faulted);
    EXPECT_EQ(s.afterPublish().kind, A::None);
    EXPECT_EQ(s.trigger(1).kind, A::MoveTo);

    auto moving = readySequencer();
    (void)moving.trigger(2);
    EXPECT_EQ(moving.onEvent(E::NotSeated).kind, A::None); // only the verdict can say so
    EXPECT_EQ(moving.state(), S::Moving);
}

TEST(Sequencer, DevicesFailingAtStartGoToFaultAndRecover)
{
    CaptureSequencer s;
    auto a = s.onEvent(E::DevicesFailed);
    EXPECT_EQ(a.kind, A::Recover);
    EXPECT_EQ(s.state(), S::Fault);
    EXPECT_EQ(s.faultCode(), FaultCode::DevicesDown);
    EXPECT_EQ(s.onEvent(E::RecoveryFailed).kind, A::Recover);
    EXPECT_EQ(s.state(), S::Fault);
    EXPECT_EQ(s.onEvent(E::Recovered).kind, A::None);
    EXPECT_EQ(s.state(), S::Ready);
}

TEST(Sequencer, TransitionTable)
{
    EXPECT_TRUE(transitionAllowed(S::Starting, S::Ready));
    EXPECT_TRUE(transitionAllowed(S::Grabbing, S::Moving));
    EXPECT_TRUE(transitionAllowed(S::Processing, S::Done));
    EXPECT_FALSE(transitionAllowed(S::Ready, S::Processing));
    EXPECT_FALSE(transitionAllowed(S::Starting, S::Moving));
    EXPECT_FALSE(transitionAllowed(S::Fault, S::Moving)); // a fault must be recovered first
    EXPECT_FALSE(transitionAllowed(S::Processing, S::Moving));
    EXPECT_FALSE(transitionAllowed(S::Done, S::Processing));
}

TEST(Sequencer, FaultCodesHaveNamesAndStableNumbers)
{
    // The numbers are part of the PLC interface (docs/plc.md).
    EXPECT_EQ(static_cast<int>(FaultCode::CameraTimeout), 10);
    EXPECT_EQ(static_cast<int>(FaultCode::FixtureTimeout), 20);
    EXPECT_EQ(static_cast<int>(FaultCode::ProgramLoad), 30);
    EXPECT_EQ(static_cast<int>(FaultCode::AbortedByPlc), 40);
    EXPECT_EQ(hg::enumName(FaultCode::FixtureFault), "fixture-fault");
    EXPECT_EQ(hg::enumName(S::Grabbing), "grabbing");
    EXPECT_EQ(hg::enumName(E::RecoveryFailed), "recovery-failed");
}

} // namespace
} // namespace hg::station

namespace hg::station {
namespace {

// The maintenance calibration: only from an idle station (ready or done),
// back to ready when it ends; a fault or a running cycle does not start it.
TEST(Sequencer, CalibrationRunsOnlyFromAnIdleStationAndReturnsToReady)
{
    CaptureSequencer s = readySequencer();
    s.onEvent(SequencerEvent::CalibrationStart);
    EXPECT_EQ(s.state(), SequencerState::Calibrating);
    EXPECT_TRUE(transitionAllowed(SequencerState::Calibrating, SequencerState::Ready));
    EXPECT_FALSE(transitionAllowed(SequencerState::Calibrating, SequencerState::Moving)); // no trigger in between
    s.onEvent(SequencerEvent::CalibrationEnd);
    EXPECT_EQ(s.state(), SequencerState::Ready);
    EXPECT_EQ(hg::enumName(SequencerState::Calibrating), "calibrating");

    CaptureSequencer busy = readySequencer();
    busy.trigger(2);
    const auto before = busy.state();
    busy.onEvent(SequencerEvent::CalibrationStart);
    EXPECT_EQ(busy.state(), before);

    CaptureSequencer fault = readySequencer();
    fault.onEvent(SequencerEvent::DevicesFailed);
    ASSERT_EQ(fault.state(), SequencerState::Fault);
    fault.onEvent(SequencerEvent::CalibrationStart);
    EXPECT_EQ(fault.state(), SequencerState::Fault);
}

} // namespace
} // namespace hg::station

namespace hg::station {
namespace {

using namespace std::chrono_literals;

// Recovery (docs/plc.md): at once after a faulted cycle and on COMMAND = 2,
// after the retry wait when the devices failed to start or a recovery failed.
TEST(Sequencer, RecoveryTimingIsTheSequencersDecision)
{
    CaptureSequencer s(1, 1500ms);
    auto a = s.onEvent(E::DevicesFailed);
    EXPECT_EQ(a.kind, A::Recover);
    EXPECT_EQ(a.delay, 1500ms);
    a = s.onEvent(E::RecoveryFailed);
    EXPECT_EQ(a.kind, A::Recover);
    EXPECT_EQ(a.delay, 1500ms);
    a = s.onEvent(E::FaultReset);
    EXPECT_EQ(a.kind, A::Recover);
    EXPECT_EQ(a.delay, 0ms);
    EXPECT_EQ(s.state(), S::Fault);
    (void)s.onEvent(E::Recovered);
    ASSERT_EQ(s.state(), S::Ready);
    // Outside a fault a reset has nothing to do.
    EXPECT_EQ(s.onEvent(E::FaultReset).kind, A::None);
    EXPECT_EQ(s.state(), S::Ready);

    (void)s.trigger(1);
    (void)s.onEvent(E::MoveFault);
    (void)s.onEvent(E::MoveFault);
    ASSERT_EQ(s.state(), S::Fault);
    EXPECT_EQ(s.afterPublish().kind, A::Recover);
    EXPECT_EQ(s.afterPublish().delay, 0ms);
}

TEST(Sequencer, PlanWithoutViewsEndsTheCycleAsProgramLoad)
{
    auto s = readySequencer();
    auto a = s.trigger(0);
    EXPECT_EQ(a.kind, A::Publish);
    EXPECT_EQ(s.state(), S::Done);
    EXPECT_EQ(s.faultCode(), FaultCode::ProgramLoad);
    EXPECT_EQ(s.trigger(0).kind, A::Publish); // from Done too
    EXPECT_EQ(s.faultCode(), FaultCode::ProgramLoad);
}

// A table without Moving -> Settling: the check runs in every build and turns
// the refused transition into an internal fault that ends the cycle.
bool withoutSettling(SequencerState from, SequencerState to)
{
    return !(from == S::Moving && to == S::Settling) && transitionAllowed(from, to);
}

TEST(Sequencer, RefusedTransitionIsAnInternalFault)
{
    CaptureSequencer s(1, 2s, withoutSettling);
    (void)s.onEvent(E::DevicesActive);
    (void)s.trigger(2);
    auto a = s.onEvent(E::InPosition);
    EXPECT_EQ(a.kind, A::Publish);
    EXPECT_TRUE(a.stopMotion);
    EXPECT_EQ(s.state(), S::Fault);
    EXPECT_EQ(s.faultCode(), FaultCode::Internal);
    EXPECT_EQ(s.outcome(), CycleOutcome::Faulted);
    EXPECT_EQ(s.refusedTransition(), std::make_pair(S::Moving, S::Settling));
    EXPECT_EQ(s.afterPublish().kind, A::Recover);

    // Outside a cycle the refused transition asks for recovery at once.
    CaptureSequencer idle(1, 2s, [](SequencerState from, SequencerState to) {
        return !(from == S::Starting && to == S::Ready) && transitionAllowed(from, to);
    });
    a = idle.onEvent(E::DevicesActive);
    EXPECT_EQ(a.kind, A::Recover);
    EXPECT_EQ(a.delay, 0ms);
    EXPECT_EQ(idle.state(), S::Fault);
    EXPECT_EQ(idle.faultCode(), FaultCode::Internal);
}

// Every event in every reachable state: the rules never ask for a transition
// the table refuses (no internal fault anywhere).
TEST(Sequencer, RulesStayInsideTheTable)
{
    // Reach each state by a known path, then feed every event to a copy.
    std::vector<CaptureSequencer> states;
    CaptureSequencer s;
    states.push_back(s); // starting
    (void)s.onEvent(E::DevicesActive);
    states.push_back(s); // ready
    auto moving = s;
    (void)moving.trigger(2);
    states.push_back(moving);
    auto settling = moving;
    (void)settling.onEvent(E::InPosition);
    states.push_back(settling);
    auto grabbing = settling;
    (void)grabbing.onEvent(E::Settled);
    states.push_back(grabbing);
    auto lastGrab = grabbing;
    (void)lastGrab.onEvent(E::FrameOk);
    (void)lastGrab.onEvent(E::InPosition);
    (void)lastGrab.onEvent(E::Settled);
    states.push_back(lastGrab);
    auto processing = lastGrab;
    (void)processing.onEvent(E::FrameOk);
    states.push_back(processing);
    auto done = processing;
    (void)done.onEvent(E::Processed);
    states.push_back(done);
    auto fault = s;
    (void)fault.onEvent(E::DevicesFailed);
    states.push_back(fault);
    auto calibrating = s;
    (void)calibrating.onEvent(E::CalibrationStart);
    states.push_back(calibrating);
    std::set<S> seen;
    for (const auto& start : states) seen.insert(start.state());
    EXPECT_EQ(seen.size(), 9u) << "every state is reached";

    for (const auto& start : states) {
        for (int e = 0; e <= static_cast<int>(E::FaultReset); ++e) {
            auto copy = start;
            (void)copy.onEvent(static_cast<E>(e));
            EXPECT_NE(copy.faultCode(), FaultCode::Internal)
                << hg::enumName(start.state()) << " + " << hg::enumName(static_cast<E>(e));
            // Three failures in a row exhaust the retry from any state.
            (void)copy.onEvent(static_cast<E>(e));
            (void)copy.onEvent(static_cast<E>(e));
            EXPECT_NE(copy.faultCode(), FaultCode::Internal)
                << hg::enumName(start.state()) << " + 3 x " << hg::enumName(static_cast<E>(e));
        }
        auto copy = start;
        (void)copy.trigger(0);
        EXPECT_NE(copy.faultCode(), FaultCode::Internal) << hg::enumName(start.state()) << " + trigger(0)";
    }
}

} // namespace
} // namespace hg::station
