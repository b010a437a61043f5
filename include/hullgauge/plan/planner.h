// Weak convexity per landmark and view planning (dissertation chapters 2 and 5).
//
// For every landmark the planner decides, over the station's reachable poses,
// whether the landmark lies on the visual hull relative to that viewing
// region (Definition 2 with Assumptions 2.7-2.10: a line of sight from a
// reachable camera centre passes the landmark's void neighbour on to
// background without meeting the part or the floor). The witnesses it looks
// for first are the grazing poses — camera centre in the landmark's tangent
// plane, solved analytically (pose_space.h) — because a void voxel beside a
// flat face is proven void only from there (docs/architecture.md,
// "Perspective and grazing views"); a coarse pose grid within a small band of
// the tangent plane adds the rest. Each candidate is judged by Rules 1-4 (view_rules.h).
//
// Then the view pattern analysis of 5.5/5.6.1 (view_pattern.h): every landmark
// gets its best views (the designer's AND-of-OR lists, 5.3.2, or derived: the
// grazing poses that pass Rules 1-4), their view variation lists over the
// candidate poses, OR removal and AND combination by largest intersection, and
// one final pose per group (minimum summed distance to its landmarks, median
// orientation among ties, 5.4.4), ordered for the least cycle time of the
// station's fixture (cycle_time.h).
#pragma once

#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/inspection_map.h"
#include "hullgauge/model/solid.h"
#include "hullgauge/plan/cycle_time.h"
#include "hullgauge/plan/pose_space.h"
#include "hullgauge/plan/view_rules.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace hg::plan {

/// A landmark as the planner sees it: the map's landmark (position, outward
/// unit normal, tolerance) and the designer's best views: AND over the outer
/// list, OR inside (eq. 5.3.2-1/2); empty: derive them.
struct PlanLandmark : inspect::MapLandmark {
    std::vector<std::vector<FixturePose>> bestViews;
    /// The drawing's tolerance when it is finer than the voxel size ΔV the
    /// views must resolve: `toleranceMm` then holds ΔV, and the tolerance
    /// itself is decided to U by the sub-voxel deviation (program_plan.h).
    /// The verdicts then speak of the voxel size, not of the tolerance.
    std::optional<double> drawingToleranceMm;
};

struct PlanProblem {
    std::string part;
    const model::Solid* solid = nullptr;
    const geometry::Station* station = nullptr;
    /// The inspection map's frame; the planner works at its depth (ΔV), on
    /// each landmark's voxel as the map has it (VoxelFrame::landmarkVoxel).
    inspect::VoxelFrame frame;
    std::vector<PlanLandmark> landmarks;
    /// Poses the plan takes first, in this order (a program's views for the
    /// seat, docs/alignment.md "Views for the seat"); the planned views
    /// follow in the order of least cycle time from the last of them, and a
    /// planned pose equal to one of them is not taken twice.
    std::vector<FixturePose> firstViews;
};

struct PlanOptions {
    PoseGrid grid;
    RuleOptions rules;
    /// Grid poses and other landmarks' poses are tried for a landmark only when
    /// its line of sight lies within this angle (degrees) of its tangent plane.
    double bandDeg = 2.0;
    /// AND combination threshold (5.6.1): views merge while they share this many poses.
    std::size_t minIntersection = 1;
    /// Requested view count (5.5): fail when the accuracy needs more; 0 = no limit.
    std::size_t maxViews = 0;
    /// Also solve the set cover exactly with GLPK (to measure the greedy's gap).
    bool exact = false;
    double exactTimeLimitSeconds = 10.0;
    /// Type-four layers checked for visibility (3.3.8 paring), >= 1.
    int pareLayers = 1;
    /// Report the void type-four neighbours no pose proves void
    /// (LandmarkAnalysis::unseenVoids); off where only the verdicts are
    /// wanted (the landmark suggestion, landmark_suggest.h): it does not
    /// change a verdict and costs most for landmarks near concave features.
    bool reportUnseenVoids = true;
    /// Surface points tried when looking for the nearest inspectable point.
    std::size_t nearestSearchLimit = 500;
};

enum class LandmarkVerdict {
    Inspectable,         ///< weakly convex for the station, a pose passes Rules 1-4
    NoVoidNeighbour,     ///< the landmark's voxel has no void neighbour at the inspection depth
    Concavity,           ///< no line of sight reaches background, whatever the fixture ranges
    OutOfFixtureRange,   ///< only poses outside the fixture's ranges would see it
    OutsideDepthOfField, ///< seen only from poses whose depth is outside the depth of field
    /// seen only from poses that put it outside a telecentric lens's field
    OutsideTelecentricField,
    BelowStationMed, ///< seen, but no view resolves the tolerance (eq. 5.3.6-3)
    VoxelTooCoarse,  ///< tolerance below the map's voxel size (eq. 5.3.6-1)
    BestViewsFail,   ///< a designer AND term has no usable pose
};
constexpr auto nameTable(LandmarkVerdict)
{
    using enum LandmarkVerdict;
    return std::to_array<EnumName<LandmarkVerdict>>({{Inspectable, "inspectable"},
                                                     {NoVoidNeighbour, "no_void_neighbour"},
                                                     {Concavity, "concavity"},
                                                     {OutOfFixtureRange, "out_of_fixture_range"},
                                                     {OutsideDepthOfField, "outside_depth_of_field"},
                                                     {OutsideTelecentricField, "outside_telecentric_field"},
                                                     {BelowStationMed, "below_station_med"},
                                                     {VoxelTooCoarse, "voxel_too_coarse"},
                                                     {BestViewsFail, "best_views_fail"}});
}

struct LandmarkAnalysis {
    std::string id;
    Vec3 position = Vec3::Zero();
    Vec3 normal = Vec3::UnitZ();
    double toleranceMm = 0.0;
    Eigen::Vector3i voxel = Eigen::Vector3i::Zero();
    std::optional<Eigen::Vector3i> witnessVoxel;
    LandmarkVerdict verdict = LandmarkVerdict::Concavity;
    /// A sentence the designer can act on, empty when inspectable.
    std::string reason;
    /// Reachable poses that see the landmark against background (Rules 1, 2, 4).
    std::vector<FixturePose> witnessPoses;
    /// Unit lines of sight (camera centre to landmark, part frame) of the witnesses.
    std::vector<Vec3> witnessDirections;
    /// Poses outside the fixture's ranges that would see it (OutOfFixtureRange).
    std::vector<FixturePose> unreachableWitnesses;
    bool designerBestViews = false;
    /// Smallest predicted MED over the witnesses (eq. 5.3.6-3), mm.
    double bestMedMm = 0.0;
    /// The part region blocking it (Concavity): a triangle and the hit point.
    std::optional<std::size_t> blockingTriangle;
    std::optional<Vec3> blockingPoint;
    /// The nearest surface point that is inspectable from the station.
    std::optional<Vec3> nearestInspectablePoint;
    /// Void type-four neighbours no reachable pose proves void: to be pared
    /// from the inspection map (3.3.8), as keys at the inspection depth.
    std::vector<inspect::VoxelKey> unseenVoids;
    std::vector<std::string> warnings;

    bool inspectable() const { return verdict == LandmarkVerdict::Inspectable; }
};

struct PlannedView {
    std::string id;
    FixturePose pose;
    geometry::CameraModel camera;
    /// Landmarks (indices) this view observes under Rules 1-4, with the predicted MED of each.
    std::vector<std::size_t> landmarks;
    std::vector<double> predictedMedMm;
};

struct ViewPlan {
    std::vector<LandmarkAnalysis> landmarks;
    std::vector<PlannedView> views; ///< in travel order: the least predicted cycle time
    /// The predicted cycle time of `views` from the home pose, and of the
    /// orders it is compared with (docs/planning.md, "Cycle time").
    PlanCycleTime cycleTime;
    bool feasible = false;
    /// Why the plan failed, one sentence each.
    std::vector<std::string> problems;
    std::size_t candidatePoses = 0;
    std::size_t greedyViews = 0;
    std::optional<std::size_t> exactViews;
    bool exactOptimal = false;
    double seconds = 0.0;
};

/// Weak convexity and best views of every landmark (no view combination).
std::vector<LandmarkAnalysis> analyseLandmarks(const PlanProblem& problem, const PlanOptions& options = {});

/// The whole plan: analysis, view pattern analysis, final views.
ViewPlan planViews(const PlanProblem& problem, const PlanOptions& options = {});

} // namespace hg::plan
