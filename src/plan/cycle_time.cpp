#include "hullgauge/plan/cycle_time.h"

namespace hg::plan {

CycleTime predictCycleTime(const std::vector<FixturePose>& poses, const FixtureMotion& motion, const FixturePose& start)
{
    CycleTime c;
    c.start = start;
    FixturePose at = start;
    for (std::size_t k = 0; k < poses.size(); ++k) {
        CycleMove m;
        m.view = k;
        m.distance = travelDistance(at, poses[k], motion.type);
        m.axisSeconds = motion.axisSeconds(at, poses[k]);
        m.seconds = motion.moveSeconds(at, poses[k]);
        c.movesS += m.seconds;
        c.moves.push_back(std::move(m));
        at = poses[k];
    }
    const auto n = static_cast<double>(poses.size());
    c.settlesS = n * motion.settleS;
    c.grabsS = n * motion.grabS;
    c.inspectionS = poses.empty() ? 0.0 : kInspectionSeconds;
    c.totalS = c.movesS + c.settlesS + c.grabsS + c.inspectionS;
    return c;
}

} // namespace hg::plan
