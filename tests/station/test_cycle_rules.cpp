// The rules beside the sequencer: device status -> event, verdict, lamps
// (docs/contracts.md §6) and STATUS (docs/plc.md), each case written out by hand.
#include "hullgauge/station/cycle_rules.h"

#include <gtest/gtest.h>

namespace hg::station {
namespace {

using S = SequencerState;

TEST(CycleRules, DeviceStatusCodesBecomeTheirEvents)
{
    EXPECT_EQ(moveEvent(StatusCode::Ok), SequencerEvent::InPosition);
    EXPECT_EQ(moveEvent(StatusCode::Timeout), SequencerEvent::MoveTimeout);
    EXPECT_EQ(moveEvent(StatusCode::Fault), SequencerEvent::MoveFault);
    EXPECT_EQ(moveEvent(StatusCode::NotAllowed), SequencerEvent::MoveRefused);
    EXPECT_EQ(moveEvent(StatusCode::CommunicationError), SequencerEvent::MoveCommError);
    EXPECT_EQ(moveEvent(StatusCode::Error), SequencerEvent::MoveCommError);
    EXPECT_EQ(grabEvent(StatusCode::Ok), SequencerEvent::FrameOk);
    EXPECT_EQ(grabEvent(StatusCode::Timeout), SequencerEvent::FrameTimeout);
    EXPECT_EQ(grabEvent(StatusCode::BadFrame), SequencerEvent::FrameBad);
    EXPECT_EQ(grabEvent(StatusCode::IoError), SequencerEvent::FrameError);
    EXPECT_EQ(grabEvent(StatusCode::NotAllowed), SequencerEvent::FrameError);
}

TEST(CycleRules, VerdictOfACycle)
{
    EXPECT_EQ(verdictOf(CycleOutcome::Inspected, true), Verdict::Pass);
    EXPECT_EQ(verdictOf(CycleOutcome::Inspected, false), Verdict::Fail);
    EXPECT_EQ(verdictOf(CycleOutcome::Aborted, true), Verdict::Aborted);
    EXPECT_EQ(verdictOf(CycleOutcome::Faulted, true), Verdict::Error);
    EXPECT_EQ(verdictOf(CycleOutcome::Faulted, false), Verdict::Error);
}

TEST(CycleRules, LampsFollowTheStateAndInDoneTheVerdict)
{
    for (auto v : {Verdict::Pass, Verdict::Fail, Verdict::Aborted, Verdict::Error}) {
        EXPECT_EQ(lampPattern(S::Fault, v), LampPattern::Fault);
        EXPECT_EQ(lampPattern(S::Starting, v), LampPattern::Off);
        EXPECT_EQ(lampPattern(S::Ready, v), LampPattern::Off);
        for (auto busy : {S::Moving, S::Settling, S::Grabbing, S::Processing, S::Calibrating})
            EXPECT_EQ(lampPattern(busy, v), LampPattern::Busy);
    }
    EXPECT_EQ(lampPattern(S::Done, Verdict::Pass), LampPattern::Pass);
    EXPECT_EQ(lampPattern(S::Done, Verdict::Fail), LampPattern::Fail);
    EXPECT_EQ(lampPattern(S::Done, Verdict::Aborted), LampPattern::Off);
    EXPECT_EQ(lampPattern(S::Done, Verdict::Error), LampPattern::Off);
    // A part not seated: amber blinks alone until the next cycle (re-seat it).
    EXPECT_EQ(lampPattern(S::Done, Verdict::Error, FaultCode::PartNotSeated), LampPattern::Reseat);
    EXPECT_EQ(lampPattern(S::Done, Verdict::Error, FaultCode::InspectionError), LampPattern::Off);
    EXPECT_EQ(lampPattern(S::Moving, Verdict::Error, FaultCode::PartNotSeated), LampPattern::Busy);
    EXPECT_EQ(lampPattern(S::Fault, Verdict::Error, FaultCode::PartNotSeated), LampPattern::Fault);
    EXPECT_EQ(hg::enumName(LampPattern::Fault), "fault");
}

// docs/lamps.md, the station asking for attention between cycles: amber
// steady beside the verdict; production refused: amber steady with red
// blinking where no verdict is shown. Faults, running cycles and a part to
// re-seat show as without attention; amber steady alone stays "busy".
TEST(CycleRules, AttentionLightsAmberBesideTheVerdictAndRefusedWhereNoVerdictIsShown)
{
    const Attention wanted{.wanted = true};
    const Attention refused{.wanted = true, .productionRefused = true};
    const Attention refusedOnly{.productionRefused = true};
    for (const Attention& a : {wanted, refused, refusedOnly}) {
        EXPECT_EQ(lampPattern(S::Done, Verdict::Pass, FaultCode::None, a), LampPattern::PassAttention);
        EXPECT_EQ(lampPattern(S::Done, Verdict::Fail, FaultCode::None, a), LampPattern::FailAttention);
        EXPECT_EQ(lampPattern(S::Done, Verdict::Error, FaultCode::PartNotSeated, a), LampPattern::Reseat);
        EXPECT_EQ(lampPattern(S::Fault, Verdict::Pass, FaultCode::None, a), LampPattern::Fault);
        EXPECT_EQ(lampPattern(S::Starting, Verdict::Pass, FaultCode::None, a), LampPattern::Off);
        for (auto busy : {S::Moving, S::Settling, S::Grabbing, S::Processing, S::Calibrating})
            EXPECT_EQ(lampPattern(busy, Verdict::Pass, FaultCode::None, a), LampPattern::Busy);
    }
    // No verdict to show (ready, an aborted or faulted cycle): off while only attention is
    // asked for (amber alone would read "busy"), refused while production is.
    for (auto [state, verdict] : {std::pair{S::Ready, Verdict::Pass}, std::pair{S::Done, Verdict::Aborted},
                                  std::pair{S::Done, Verdict::Error}}) {
        EXPECT_EQ(lampPattern(state, verdict, FaultCode::None, wanted), LampPattern::Off);
        EXPECT_EQ(lampPattern(state, verdict, FaultCode::None, refused), LampPattern::Refused);
        EXPECT_EQ(lampPattern(state, verdict, FaultCode::InspectionError, refusedOnly), LampPattern::Refused);
    }
    EXPECT_EQ(hg::enumName(LampPattern::PassAttention), "pass_attention");
    EXPECT_EQ(hg::enumName(LampPattern::FailAttention), "fail_attention");
    EXPECT_EQ(hg::enumName(LampPattern::Refused), "refused");
}

TEST(CycleRules, StatusRegisterForEachState)
{
    // STATUS values of docs/contracts.md §6 (and 5, maintenance, docs/plc.md).
    EXPECT_EQ(static_cast<int>(plcStatus(S::Ready)), 0);
    for (auto busy : {S::Moving, S::Settling, S::Grabbing, S::Processing})
        EXPECT_EQ(static_cast<int>(plcStatus(busy)), 1);
    EXPECT_EQ(static_cast<int>(plcStatus(S::Done)), 2);
    EXPECT_EQ(static_cast<int>(plcStatus(S::Fault)), 3);
    EXPECT_EQ(static_cast<int>(plcStatus(S::Starting)), 4);
    EXPECT_EQ(static_cast<int>(plcStatus(S::Calibrating)), 5);
}

} // namespace
} // namespace hg::station
