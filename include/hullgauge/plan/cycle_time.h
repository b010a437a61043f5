// The predicted cycle time of a view plan (docs/planning.md, "Cycle time"):
// the fixture's moves through the views from where it starts, the station's
// settle and a grab per view, and the inspection after the last frame.
//
// A move takes the time of the fixture's motion model (fixture_motion.h: the
// slowest axis' trapezoidal profile plus its settle); the daemon's cycle is
// the moves, settles and grabs one after the other (docs/daemon.md, "The
// cycle": a frame's preparation overlaps the next move), then the inspection
// (≈ 1 ms after the last frame, docs/daemon.md "The pipeline").
#pragma once

#include "hullgauge/geometry/fixture_motion.h"
#include "hullgauge/plan/pose_space.h"

#include <cstddef>
#include <vector>

namespace hg::plan {

using geometry::FixtureMotion;

/// The inspection after the last frame, s: the goal-driven traversal
/// (docs/daemon.md, "The pipeline").
constexpr double kInspectionSeconds = 0.001;

/// One move of the cycle, to the view at `view` of the ordered poses.
struct CycleMove {
    std::size_t view = 0;
    double distance = 0.0;           ///< travelDistance (degrees or mm)
    double seconds = 0.0;            ///< the move: slowest axis' profile plus settle
    std::vector<double> axisSeconds; ///< per axis (geometry::axisNames order) profile plus settle
};

struct CycleTime {
    FixturePose start;
    std::vector<CycleMove> moves; ///< start → view 0, view 0 → view 1, ...
    double movesS = 0.0;
    double settlesS = 0.0;
    double grabsS = 0.0;
    double inspectionS = 0.0;
    /// movesS + settlesS + grabsS + inspectionS
    double totalS = 0.0;
};

/// The cycle through `poses` in the order given, from `start`.
CycleTime predictCycleTime(const std::vector<FixturePose>& poses, const FixtureMotion& motion,
                           const FixturePose& start);

/// The cycle-time figures of a plan: the chosen order and the alternatives.
struct PlanCycleTime {
    FixtureMotion motion;
    CycleTime predicted; ///< the views in travel order, from the home pose
    /// The views in the order the view pattern analysis chose them.
    double unorderedS = 0.0;
    /// The views in the order of least travel distance (the larger axis move).
    double leastDistanceS = 0.0;
    /// The next part's cycle on a line that leaves the fixture at the last
    /// view between parts (the daemon does not home between cycles): the
    /// same order from the last view.
    double repeatS = 0.0;
};

} // namespace hg::plan
