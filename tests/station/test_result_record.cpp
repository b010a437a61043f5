// The inspection record's JSON: the cycle-time breakdown under the names the
// result's `timing_ms` has always had (docs/daemon.md, "Maintenance socket").
#include "hullgauge/station/result_record.h"

#include <gtest/gtest.h>

namespace hg::station {
namespace {

TEST(CycleTimings, EachStepUnderItsNameInMilliseconds)
{
    const CycleTimings timings{{CycleStep::Move, Milliseconds(812.5)},
                               {CycleStep::WaitForVerdict, Milliseconds(0.0)},
                               {CycleStep::CorrectPoses, Milliseconds(1.25)},
                               {CycleStep::LastFrameToPublish, Milliseconds(3.0625)}};
    EXPECT_EQ(toJson(timings).dump(),
              R"({"correct_poses":1.25,"last_frame_to_publish":3.0625,"move":812.5,"wait_for_verdict":0.0})");
    EXPECT_EQ(toJson(CycleTimings{}).dump(), "{}");
}

TEST(CycleTimings, TheStepsAreNamedAsTheResultHasThem)
{
    EXPECT_EQ(enumNameList<CycleStep>(),
              "move, settle, grab, region, prepare, traversal, processing, wait_for_verdict, correct_poses, commit, "
              "publish, last_frame_to_publish");
}

} // namespace
} // namespace hg::station
