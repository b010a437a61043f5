// Landmark suggestion: an automatic determination of the significant points
// of a part (dissertation 6.2, future work 6), for the engineer to edit into a
// part program (docs/part-program.md, "Suggesting landmarks").
//
// The significant features of 3.3.1 are "a region, hole, or corner": a plane
// face (Figure 3.7), the edges of a post (Figure 3.5), the perimeter of a hole
// (Figure 3.6). They are found on the CAD mesh, one or a few candidate points
// each (findCandidates):
//  * face — a planar region of the mesh (triangles whose normals agree with
//    the region's first within `planarAngleDeg`, joined across shared edges):
//    its point farthest from the region's boundary, among the region's area
//    centroid and its triangles' centroids; a region whose best point lies
//    closer than `minClearanceMm` to its boundary is no face (a facet of a
//    curved surface, a sliver); the outside of a cylinder (a boss, a shaft)
//    gives four points round it at mid-length;
//  * edge — a convex sharp edge: the normals of its two triangles differ by
//    more than `sharpAngleDeg` and the edge bulges out of the part (re-entrant
//    edges lie in a groove the silhouette does not show). Sharp edges between
//    the same two features form a feature line; an open line gives its
//    midpoint, a closed one four points a quarter round apart;
//  * hole — a bore: a smooth region (no sharp edge inside) whose normals are
//    all square to one axis, whose facets' normal lines (through the middle
//    of each facet, along its normal) meet that axis, that runs at least 300°
//    round it and whose normals point to it.
//    Four points round its wall at mid-length, and the feature lines where it
//    meets a face (its rims, as edges above) are holes too;
//  * hole — an opening that is not round (a slot, a D-shaped, double-D or
//    rectangular hole): a ring of triangles square to one axis (the axis of
//    a curved patch that is no cylinder, or the fold line of a re-entrant
//    edge), joined across smooth and re-entrant edges, whose normals all
//    point into the ring and whose angular spans about its centre run at
//    least 300° round. Four points on its wall at mid-length, where its long
//    direction and the direction across it meet the wall (a slot's ends and
//    the middles of its flats), and its rims.
// The normal is the face's, the bisector of the two faces on an edge (what
// the part program's loader derives there, docs/part-program.md "Normals from
// the mesh"), the radial direction towards the axis in a bore.
//
// Every candidate is then judged by the view planner at the station
// (analyseLandmarks, planner.h: weak convexity of chapter 2 relative to the
// fixture's reachable poses and Rules 1-4 of 5.3.4-5.3.6), and of the
// inspectable ones `count` are chosen by farthest-point selection
// (spreadSelect) with a minimum share of faces, of edges and of holes when the
// part has inspectable ones. The chosen set is planned as `hullgauge plan`
// plans it (planViews, then the capability check at the planned views over
// the nest's play, program_plan.h capabilityOverPlay: capable at every
// seat), then screened by the caller (`hullgauge
// landmarks suggest` and `hullgauge commission` take it through seats on the
// station's digital twin, docs/commissioning.md); a landmark refused is left
// out and the spread made again. Every candidate left out is kept with the
// rule that removed it.
#pragma once

#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/inspect/voxel_frame.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/solid.h"
#include "hullgauge/plan/planner.h"

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace hg::model {
class StepModel;
}

namespace hg::plan {

/// The kind of feature a landmark lies on (3.3.1: a region, a corner, a hole).
enum class FeatureKind { Face = 0, Edge = 1, Hole = 2 };
inline constexpr std::size_t kFeatureKinds = 3;
constexpr auto nameTable(FeatureKind)
{
    using enum FeatureKind;
    return std::to_array<EnumName<FeatureKind>>({{Face, "face"}, {Edge, "edge"}, {Hole, "hole"}});
}

/// A point of the part that could be a landmark.
struct LandmarkCandidate {
    FeatureKind kind = FeatureKind::Face;
    Vec3 position = Vec3::Zero(); ///< on the mesh, mm, part frame
    Vec3 normal = Vec3::UnitZ();  ///< outward unit normal
    /// The feature in words, e.g. "plane face, normal (0, 0, 1), 1200 mm²".
    std::string feature;
};

struct CandidateOptions {
    /// An edge is sharp when its two triangles' normals differ by more than this (degrees).
    double sharpAngleDeg = 30.0;
    /// Triangles of one plane face: normals within this angle of the face's first (degrees).
    double planarAngleDeg = 1.0;
    /// A face point lies at least this far from the face's boundary; a feature
    /// line shorter than twice this gives no point (mm).
    double minClearanceMm = 0.5;
};

/// Candidate points on the features of `solid`'s mesh (the header's list),
/// each on the mesh (the closest mesh point), in a fixed order: faces, then
/// cylinders, then feature lines.
std::vector<LandmarkCandidate> findCandidates(const model::Solid& solid, const CandidateOptions& options = {});

/// One pick of the spread.
struct SpreadPick {
    std::size_t index = 0;
    /// Distance to the nearest earlier pick (mm); for the first pick its distance from the points' centroid.
    double distanceMm = 0.0;
    /// The nearest earlier pick (index into the points); none for the first.
    std::optional<std::size_t> nearest;
    /// Chosen among the kinds still short of their minimum, not among all points.
    bool forMinimumShare = false;
};

/// Farthest-point selection of up to `count` of `points`: first the point
/// farthest from their centroid, then each time the point farthest from the
/// points already chosen (ties: the lower index). `minimum[k]` points of kind
/// k are guaranteed (capped at the number there are): once the slots left are
/// no more than the picks those minimums still need, only the kinds short of
/// theirs are considered. Without binding minimums the smallest pairwise
/// distance of the picks is at least half the largest achievable by any
/// `count` of the points (the farthest-point 2-approximation).
std::vector<SpreadPick> spreadSelect(const std::vector<Vec3>& points, const std::vector<FeatureKind>& kinds,
                                     std::size_t count, const std::array<std::size_t, kFeatureKinds>& minimum = {});

/// A chosen landmark refused (index into the chosen), the rule that refused
/// it — a planner verdict (its name in LandmarkVerdict's table), "not_observed",
/// "capability" (over the nest's play), or the screen's own — and why, with the numbers.
struct Refusal {
    std::size_t index = 0;
    std::string rule;
    std::string why;
};

/// A further test of the chosen landmarks at the views planned for them, with
/// their capability over the play (e.g. on the station's digital twin): the
/// landmarks it refuses.
using SuggestScreen =
    std::function<std::vector<Refusal>(const std::vector<LandmarkCandidate>& chosen, const ViewPlan& plan,
                                       const std::vector<inspect::LandmarkCapability>& capability)>;

struct SuggestOptions {
    std::size_t count = 8;
    /// The tolerance the suggested landmarks are judged with (Rule 3) and
    /// written with: a placeholder for the drawing's.
    double toleranceMm = 0.5;
    /// Minimum shares of the suggestions on faces, on edges and on holes
    /// (rounded up), when the part has inspectable candidates of that kind:
    /// farthest-point selection alone favours the extremes of a part, its
    /// outer edges, over its faces and holes.
    double minFaceShare = 0.25;
    double minEdgeShare = 0.25;
    double minHoleShare = 0.125;
    CandidateOptions candidates;
    /// The planner's options (pose grid, band, rule sampling) as `hullgauge plan` uses them.
    PlanOptions plan;
    /// The alignment settings of the program the landmarks go into: the nest's
    /// play is plan::kPlayOfLimits of its limits (program_plan.h).
    model::AlignmentSettings alignment;
    /// Applied to the chosen landmarks once `plan` takes them all; none: no further test.
    SuggestScreen screen;
};

/// What the suggestion works on: the part (a STEP part's B-rep, when given, is
/// where the candidates are snapped to, as the part program's loader snaps
/// landmarks), the station and the inspection map's frame (ΔV).
struct SuggestProblem {
    std::shared_ptr<const model::Solid> solid;
    const model::StepModel* brep = nullptr;
    const geometry::Station* station = nullptr;
    inspect::VoxelFrame frame;
};

struct SuggestedLandmark {
    std::string id; ///< "face-1", "edge-2", "hole-1", numbered per kind
    LandmarkCandidate candidate;
    /// Why it was chosen (its place in the spread), in words.
    std::string reason;
    /// Reachable poses that see it against background, and the finest MED among them (eq. 5.3.6-3).
    std::size_t witnessPoses = 0;
    double bestMedMm = 0.0;
};

/// A candidate the suggestion left out, the rule that removed it and why.
struct RefusedCandidate {
    LandmarkCandidate candidate;
    std::string rule;
    std::string why;
};

struct Suggestion {
    std::vector<SuggestedLandmark> landmarks;             ///< in the order chosen
    std::array<std::size_t, kFeatureKinds> candidates{};  ///< found on the part, per kind
    std::array<std::size_t, kFeatureKinds> inspectable{}; ///< of those, inspectable at the station
    /// Views `hullgauge plan` plans for the suggested landmarks.
    std::size_t plannedViews = 0;
    /// Remarks for the engineer: fewer suggestions than asked for, a kind the station cannot inspect.
    std::vector<std::string> notes;
    /// Every candidate left out: alone (a planner verdict), then with the others.
    std::vector<RefusedCandidate> refused;
};

/// The suggestion's problem for a CAD model read on its own (loadCadModel):
/// its solid, its B-rep and its octree's frame (pointers into both).
SuggestProblem suggestProblem(const model::CadModel& cad, const geometry::Station& station);

/// Candidates, the planner's verdict on each, and the spread (the header's steps).
Suggestion suggestLandmarks(const SuggestProblem& problem, const SuggestOptions& options = {});

/// The suggestion as a part program's `landmarks:` list (docs/part-program.md):
/// `header` lines as comments first, then one comment line per landmark (its
/// kind, its feature, why it was chosen) above its entry
/// `- {id: ..., position: [...], normal: [...], tolerance_mm: ...}`.
std::string landmarksYaml(const Suggestion& suggestion, double toleranceMm, const std::vector<std::string>& header);

/// A candidate as the `landmarks:` list writes it (6 decimals) and the part
/// program's loader reads it back (the normal then of unit length): what a
/// program made from the suggestion holds.
LandmarkCandidate asWritten(const LandmarkCandidate& candidate);

/// The refused candidates per rule, e.g. "12 concavity, 3 capability".
std::string refusedSummary(const Suggestion& suggestion);

/// The refused candidates as a Markdown table (kind, position, feature, rule, why).
std::string refusedMarkdown(const Suggestion& suggestion);

} // namespace hg::plan
