// The capture sequencer's state machine: normal cycles, the one retry, faults
// with their codes, aborts, recovery, and the transition table.
#include "hullgauge/station/sequencer.h"

#include <gtest/gtest.h>

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
    EXPECT_EQ(toString(FaultCode::FixtureFault), "fixture-fault");
    EXPECT_EQ(toString(S::Grabbing), "grabbing");
    EXPECT_EQ(toString(E::RecoveryFailed), "recovery-failed");
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
    EXPECT_EQ(toString(SequencerState::Calibrating), "calibrating");

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
