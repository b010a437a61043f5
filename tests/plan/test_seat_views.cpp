// Views for the seat (docs/alignment.md, "Views for the seat"): a program's
// `alignment.seat_views` are taken first, in the order given, and the
// planner's own views follow without repeating one of them; a pose the
// fixture cannot reach is refused by name.
//
// The simulated telecentric line's program (config/sim-telecentric) plans
// two views of its block: level along the extrusion (rotation 0, declination
// 0) and along x from 5° above (rotation -90°, declination 5°). Its seat views
// are rotation 45°/declination 30° and the level view: the plan must be those
// two, then the view along x alone — three views, the level one once.
#include "hgtest/paths.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/program_plan.h"

#include <gtest/gtest.h>

namespace hg::plan {
namespace {

using geometry::FixturePose;

struct TelecentricLine {
    model::PartProgram program =
        model::loadPartProgram(hgtest::sourceDir() / "config/sim-telecentric/stepped-block.yaml");
    geometry::Station station = geometry::loadStation(hgtest::sourceDir() / "config/sim-telecentric/station.yaml");
};

std::vector<FixturePose> posesOf(const ViewPlan& plan)
{
    std::vector<FixturePose> poses;
    for (const PlannedView& v : plan.views) poses.push_back(v.pose);
    return poses;
}

TEST(SeatViews, AreTakenFirstAndAPlannedViewAmongThemOnlyOnce)
{
    TelecentricLine line;
    ASSERT_EQ(line.program.alignment.seatViews.size(), 2u);
    model::PartProgram without = line.program;
    without.alignment.seatViews.clear();
    const ProgramPlan own = planProgram(without, line.station, {});
    ASSERT_TRUE(own.plan.feasible);
    ASSERT_EQ(posesOf(own.plan), (std::vector<FixturePose>{{0, 0}, {-90, 5}}));

    const ProgramPlan planned = planProgram(line.program, line.station, {});
    ASSERT_TRUE(planned.plan.feasible);
    EXPECT_EQ(posesOf(planned.plan), (std::vector<FixturePose>{{45, 30}, {0, 0}, {-90, 5}}));
    for (std::size_t k = 0; k < planned.plan.views.size(); ++k)
        EXPECT_EQ(planned.plan.views[k].id, "v" + std::to_string(k));
    // The level view observes what it observed in the planner's own plan.
    EXPECT_EQ(planned.plan.views[1].landmarks, own.plan.views[0].landmarks);
    // The cycle's moves start at home and go through the three views in this order.
    EXPECT_EQ(planned.plan.cycleTime.predicted.moves.size(), 3u);
    EXPECT_GT(planned.plan.cycleTime.predicted.totalS, own.plan.cycleTime.predicted.totalS);
}

TEST(SeatViews, APoseTheFixtureCannotReachIsRefusedByName)
{
    TelecentricLine line;
    // The declination range is [0, 60]°.
    line.program.alignment.seatViews = {{45, 75}};
    const ProgramPlan planned = planProgram(line.program, line.station, {});
    EXPECT_FALSE(planned.plan.feasible);
    ASSERT_FALSE(planned.plan.problems.empty());
    EXPECT_NE(planned.plan.problems.front().find("view for the seat 1 (rotation 45°, declination 75°) lies outside "
                                                 "the fixture's ranges"),
              std::string::npos)
        << planned.plan.problems.front();
}

} // namespace
} // namespace hg::plan
