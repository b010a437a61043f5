// A part program planned at a station: what `hullgauge plan` and
// `hullgauge commission` both do (docs/planning.md, docs/commissioning.md) —
// the planner's problem made from the program, the views planned, the
// capability check at the planned views (docs/inspection.md, "Capability")
// and the frame check: the whole part must stay inside every planned view's
// frame at every seat the nest allows (the alignment limits), else the plan
// refuses the lens.
#pragma once

#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/planner.h"

#include <optional>
#include <string>
#include <vector>

namespace hg::plan {

/// The nest's play assumed, as a share of the alignment limits, where none is
/// given: the limits are where a seat is refused, and a nest whose play
/// reached them would have every part at its edge refused half the time, as
/// its seat is measured with noise (docs/commissioning.md, "The twin").
inline constexpr double kPlayOfLimits = 0.8;

/// Seats at the edge of the nest's play (kPlayOfLimits of the alignment
/// limits): the part shifted by the play along ± each axis, turned by it
/// about ± each axis through its bounding-box centre, and every shift with
/// every turn (48 seats; the part as drawn is not among them).
std::vector<geometry::RigidTransform> playSeats(const model::TriangleMesh& mesh,
                                                const model::AlignmentSettings& alignment);

/// What the capability over the play is judged on: the part, its landmarks as
/// the inspection map holds them, ΔV at the inspection level, the deviation
/// gauge (null without the sub-voxel deviation) and the alignment settings
/// (the limits the play is a share of, the views the seat is measured on).
struct PlayProblem {
    const model::TriangleMesh* mesh = nullptr;
    std::vector<inspect::MapLandmark> landmarks;
    double voxelMm = 0.0;
    const inspect::DeviationGauge* gauge = nullptr;
    model::AlignmentSettings alignment;
};

/// The capability check (docs/inspection.md, "Capability") of the views at
/// these poses over the nest's play: per landmark the assessment with the
/// largest expected U, over the part as drawn and every playSeats seat, each
/// seen as the daemon's cycle sees it (the first `correct_poses_after` views
/// at their poses, the rest corrected for the seat: docs/alignment.md). A
/// seat at which no view sees the landmark on its outline is decided on the
/// voxel bracket (`bracket`), whose U is the larger.
std::vector<inspect::LandmarkCapability> capabilityOverPlay(const PlayProblem& problem,
                                                            const geometry::Station& station,
                                                            const std::vector<geometry::FixturePose>& poses);

/// The same for a part program's landmarks, gauge and alignment settings.
std::vector<inspect::LandmarkCapability> capabilityOverPlay(const model::PartProgram& program,
                                                            const geometry::Station& station,
                                                            const std::vector<geometry::FixturePose>& poses);

/// The planner's problem for a program at a station (pointers into both,
/// which must outlive it). With the sub-voxel deviation a landmark's
/// tolerance is decided to U, not to a voxel: the planner's tolerance rules
/// (eq. 5.3.6-1, Rule 3) then ask the views to resolve ΔV.
PlanProblem planProblem(const model::PartProgram& program, const geometry::Station& station);

/// How far (pixels) the part's silhouette stays inside a frame: the smallest
/// distance of a projected vertex of `mesh` from the sensor's edge (negative:
/// the part is cut; -infinity: a vertex lies behind the camera).
double frameMarginPx(const model::TriangleMesh& mesh, const geometry::CameraModel& camera);

/// The frame check of one planned view.
struct FrameCheck {
    std::string view;
    double nominalMarginPx = 0.0; ///< frameMarginPx of the part as drawn
    /// The most a seat within the play moves a point of the part in the image:
    /// (shift + rotation · the part's radius about its centre) · f / the nearest depth.
    double seatAllowancePx = 0.0;
    bool holdsPart() const { return nominalMarginPx - seatAllowancePx >= 1.0; }
};

/// The finest octree depth whose voxels the station's views resolve at every
/// point of the part (docs/commissioning.md, "The depth"): with the sub-voxel
/// deviation a tolerance is decided to U, not to a voxel, and a voxel finer
/// than a pixel's footprint is one no view discriminates (Rule 3, eq.
/// 5.3.6-3, and the engine's eq. 4.4.4-19). ΔV of the default cube
/// (model::boundingCube) is compared with eq. 5.3.6-3 at the part's far side
/// (d = the fixture's camera distance + the part's radius) and the angle the
/// part's radius makes at the camera; depths from 4 to 15 are tried, the
/// finest that passes with 10 % to spare is returned (4 when none does).
int finestResolvedDepth(const model::TriangleMesh& mesh, const geometry::Station& station, int adjacencyDepth);

struct ProgramPlan {
    PlanProblem problem; ///< what was planned (planProblem of the program)
    ViewPlan plan;
    /// Expected U per landmark at the planned views, the largest over the part
    /// as drawn and the playSeats (the outline a view sees, and so U, changes
    /// with the seat); none when the plan is infeasible.
    std::optional<std::vector<inspect::LandmarkCapability>> capability;
    std::vector<FrameCheck> frames;
};

/// planViews on planProblem, then the capability and frame checks; a view
/// that cannot hold the part makes the plan infeasible with a problem naming
/// the view and the numbers.
ProgramPlan planProgram(const model::PartProgram& program, const geometry::Station& station,
                        const PlanOptions& options);

/// plan.json (docs/planning.md): planToJson of the plan, and `capability`
/// (the assessment per landmark over the play) when the plan is feasible.
nlohmann::json toJson(const ProgramPlan& planned);

} // namespace hg::plan
