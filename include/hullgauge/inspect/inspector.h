// Goal-driven inspection (dissertation 3.3.8, 3.3.6, 4.6): one traversal of
// the octree inspection map, reconstructing only the voxels the landmarks need,
// then per-landmark error measures, statistics and parameters. Pure
// computation on values: frames in, result out; no I/O, no threads.
//
// Traversal, per landmark at the chosen level: reconstruct the landmark voxel
// (type three). If object, reconstruct its 26 neighbours and recurse outward
// from every neighbour reconstructed wrongly (label differs from the CAD
// label), out to `adjacency` layers from the landmark voxel. If void, search
// the neighbours ring by ring for object voxels — candidate landmark locations —
// and continue from those. Every voxel is reconstructed at most once per
// inspection (memoised beside the map, so the map itself stays shareable).
//
// Boundary estimate (docs/inspection.md): along the landmark normal through the
// landmark, the voxels of the network the line crosses are reconstructed in
// order; each has a normal coordinate s_c = (centre − landmark)·normal. A plane
// surface at signed offset e is ≥ 50 % inside a cube exactly when e ≥ s_c, so
// every object→void change between consecutive voxels i, i+1 brackets the
// surface in [s_c(i), s_c(i+1)]. The landmark's bracket [sLow, sHigh] is the
// hull of all such changes; error_min/error_max are the smallest and largest
// |s| over it, error_mm their mean (4.6.2).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "hullgauge/align/alignment.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/geometry/camera.h"
#include "hullgauge/inspect/correction.h"
#include "hullgauge/inspect/deviation.h"
#include "hullgauge/inspect/inspection_map.h"
#include "hullgauge/inspect/measures.h"
#include "hullgauge/inspect/outcome.h"
#include "hullgauge/inspect/regions.h"
#include "hullgauge/inspect/voxel_test.h"
#include "hullgauge/vision/segmentation.h"

namespace hg::inspect {

/// Run-time adaptation of the map (3.4) and the mode of the traversal.
struct InspectionOptions {
    /// Octree level to inspect at; -1 = the map's depth. Must lie within the
    /// map's [coarsestLevel, depth].
    int level = -1;
    /// Type-four layers searched; -1 = the map's adjacency depth (at most that).
    int adjacency = -1;
    /// Landmark ids left out of this inspection (masked branches).
    std::vector<std::string> maskedLandmarks;
    /// Stop at the first landmark that is not ok (3.3.6); the rest are not_inspected.
    bool earlyExit = false;
    VoxelTestMethod method = VoxelTestMethod::VolumeSource;
    /// Require eq. 4.4.4-19 (MED <= ΔV) from at least one observing view per
    /// landmark; a landmark without one is not_observable.
    bool requireResolution = true;
    /// How a measured sub-voxel deviation decides a landmark (with a gauge).
    DecisionRule decisionRule = DecisionRule::Guarded;
    /// Landmarks whose tolerance zone the capability check found narrower
    /// than 4 U and the user inspects anyway (`inspect --force`): never ok,
    /// at best uncertain (docs/inspection.md, "Capability").
    std::vector<std::string> unprovenLandmarks;
    /// Segment and index every pixel of every frame, Otsu's threshold from the
    /// whole frame, instead of the regions of interest alone
    /// (docs/inspection.md, "Pixels in proportion to the goal"): the
    /// reference the regions are tested against. Never on the line.
    bool wholeFrame = false;
    /// The material's linear expansion coefficient (1/K, the part program's
    /// `material.expansion_per_k`) and the point the part grows about (mm):
    /// with a temperature, deviations are referred to 20 °C (docs/mastering.md).
    double expansionPerK = 0.0;
    Eigen::Vector3d expansionCentre = Eigen::Vector3d::Zero();
};

struct ViewReport {
    std::string viewId;
    ViewDiscrimination discrimination;
};

struct LandmarkResult {
    std::string id;
    LandmarkStatus status = LandmarkStatus::NotInspected;
    std::string reason;    ///< why a landmark is not ok (human readable)
    int errorNumber = 0;   ///< wrongly reconstructed voxels near the landmark (3.3.6)
    bool measured = false; ///< the error fields hold values
    double errorMinMm = 0.0;
    double errorMaxMm = 0.0;
    double errorMm = 0.0;
    double toleranceMm = 0.0;
    double offsetLowMm = 0.0; ///< signed boundary bracket along the outward normal
    double offsetHighMm = 0.0;
    bool overflowLow = false;    ///< the boundary lies deeper than the network reaches
    bool overflowHigh = false;   ///< ... or farther out
    int voxelsReconstructed = 0; ///< voxels this landmark caused to be reconstructed
    std::optional<double> medMm; ///< best (smallest) eq. 4.4.4-19 MED over observing views
    std::vector<ViewReport> views;
    /// The signed sub-voxel deviation and its uncertainty, when the inspector
    /// measures them (docs/inspection.md, "Sub-voxel deviation").
    std::optional<Deviation> deviation;
    /// The decision on the deviation against the limits, when it was measured.
    std::optional<Decision> decision;
    /// The part program's asymmetric limits, when it gives them.
    std::optional<std::pair<double, double>> limitsMm;
    /// How the measured deviation was referred to 20 °C and corrected by the
    /// master (docs/mastering.md); `deviation` then holds the corrected value
    /// and its enlarged U, this the raw ones. Absent: neither applied.
    std::optional<AppliedReferral> referral;
};

struct ParameterResult {
    std::string id;
    ParameterKind kind = ParameterKind::Distance;
    bool measured = false;
    Bracket value;
    double nominal = 0.0;
    double tolerance = 0.0;
    ParameterStatus status = ParameterStatus::NotMeasured;
};

struct Statistics {
    double aveErrorMin = 0, aveErrorMax = 0, aveError = 0;
    double stdErrorMin = 0, stdErrorMax = 0, stdError = 0;
    double maxError = 0, minError = 0;
    double totalVolumeError = 0; ///< mm³: distinct wrong voxels × ΔV³
    int landmarksMeasured = 0;
};

struct InspectionResult {
    std::string part;
    bool pass = false;
    int level = 0;
    int adjacency = 0;
    double voxelSizeMm = 0.0;
    int viewsUsed = 0;
    std::uint64_t voxelsReconstructed = 0;
    std::vector<LandmarkResult> landmarks;
    Statistics statistics;
    std::vector<ParameterResult> parameters;
    /// Run times (docs/contracts.md §4 `timing_ms`), never an input to a decision.
    Milliseconds segmentationTime{}, reconstructionTime{}, totalTime{};
    /// The measured seat, when the inspector aligns (docs/alignment.md).
    std::optional<align::AlignmentResult> alignment;
    /// The seat is beyond the program's limits: nothing was inspected (every
    /// landmark not_inspected), the part is neither passed nor failed.
    bool seatingFault = false;
};

/// docs/contracts.md §4 plus the documented extensions.
nlohmann::json toJson(const InspectionResult& result);
/// A landmark's sub-voxel deviation with its budget and its views (docs/inspection.md, "Sub-voxel deviation").
nlohmann::json toJson(const Deviation& deviation);

/// A reconstruction oracle: the label of a voxel box (Void, Object or Undecided).
using VoxelOracle = std::function<VoxelLabel(const Box3&)>;

/// A captured view: id, calibrated camera (the whole sensor), grey or colour
/// frame (8/16 bit) — the whole sensor or a region of it: frame pixel (u, v)
/// is sensor pixel (origin.x + u, origin.y + v) (docs/camera.md, "Regions per
/// grab"; docs/inspection.md, "Frames that are regions").
struct CapturedView {
    std::string id;
    geometry::CameraModel camera;
    cv::Mat frame;
    cv::Point origin{0, 0};
};

class Inspector {
  public:
    /// Validates `options` against the map; throws ArgumentError.
    /// With an aligner every inspection from frames first measures the seat
    /// and inspects through the seated cameras (docs/alignment.md); the
    /// regions of interest then carry the aligner's margin.
    /// With a gauge every inspection from frames also measures each
    /// landmark's signed sub-voxel deviation (docs/inspection.md).
    Inspector(const InspectionMap& map, InspectionOptions options = {},
              std::shared_ptr<const align::Aligner> aligner = nullptr,
              std::shared_ptr<const DeviationGauge> gauge = nullptr);

    /// Segments only the regions the map's voxels project to, then inspects.
    /// Each frame, placed at its origin, must lie on its camera's sensor
    /// (ArgumentError naming the view); pixels of the sensor the frame
    /// does not hold are unknown, never read (docs/inspection.md, "Frames
    /// that are regions").
    InspectionResult inspect(const std::vector<CapturedView>& views, const vision::SegmentationSettings& segmentation,
                             const DeviationReferral& referral = {}) const;
    /// Segments one view's regions of interest into its silhouette index: the
    /// per-view half of `inspect`, so a caller can prepare view k while the
    /// fixture moves to view k+1 (docs/daemon.md, "The pipeline"). Const and free of shared
    /// state: safe to call from several threads. Throws ArgumentError
    /// naming the view when the frame leaves its camera's sensor.
    SilhouetteView prepareView(const CapturedView& view, const vision::SegmentationSettings& segmentation) const;
    /// Inspects prepared silhouettes (ids name the views in the result): aligns
    /// first when the inspector has an aligner (the views' cameras are the
    /// nominal ones; the seated ones are used from then on). `referral`: the
    /// part's temperature and the master's correction (docs/mastering.md),
    /// applied to every measured deviation before it is decided.
    InspectionResult inspect(std::vector<SilhouetteView> views, const std::vector<std::string>& viewIds,
                             const DeviationReferral& referral = {}) const;
    /// The seat measured on prepared views (their nominal cameras), e.g. on
    /// the first views of a cycle while the fixture moves on, to correct the
    /// remaining poses (docs/alignment.md, "Poses corrected for the seat").
    /// nullopt when the inspector does not align.
    std::optional<align::AlignmentResult> measureSeat(const std::vector<SilhouetteView>& views) const;
    /// Inspects with any voxel oracle (no views: no MED check, views_used 0).
    InspectionResult inspectWith(const VoxelOracle& oracle) const;

    /// Finds the CAD outline beside every landmark in these cameras now — the
    /// ray casts of the sub-voxel step — so that a view later prepared with
    /// the same camera (to the last bit: a planned view) only projects them
    /// (docs/inspection.md, "Sub-voxel deviation", cost). Without a gauge, nothing.
    void prepareOutlines(const std::vector<geometry::CameraModel>& cameras);

    /// Frame rectangles (merged, non-overlapping) holding every footprint the
    /// inspection can ask for in this camera.
    std::vector<cv::Rect> regionsOfInterest(const geometry::CameraModel& camera) const;
    /// Every pixel an inspection through this (nominal) camera touches: the
    /// voxels' rectangles, the sub-pixel edges' reads (with a gauge; with an
    /// aligner the seat's margin on both and the aligner's search band along
    /// the outline) and their bounding box (docs/inspection.md, "Pixels in
    /// proportion to the goal").
    ViewRegions regions(const geometry::CameraModel& camera) const;
    /// The query `regions` answers with viewRegions (and the aligner's band).
    RegionQuery regionQuery() const;

    int level() const { return level_; }
    int adjacency() const { return adjacency_; }

  private:
    /// Measures the seat and moves the views' cameras onto it; false (and
    /// `result` the seating fault) when the part is not seated within the limits.
    bool seat(std::vector<SilhouetteView>& views, InspectionResult& result) const;
    /// The sub-voxel step after the traversal: deviations and the decisions on them.
    /// The deviation referred to 20 °C and corrected (docs/mastering.md); nullopt when nothing applies.
    std::optional<AppliedReferral> refer(Deviation& d, const MapLandmark& lm, const DeviationReferral& referral) const;
    void measureDeviations(InspectionResult& r, const std::vector<SilhouetteView>& views,
                           const std::vector<std::string>& viewIds, const DeviationReferral& referral) const;
    void markUnproven(InspectionResult& r) const;
    std::shared_ptr<const ViewOutlines> cachedOutlines(const geometry::CameraModel& camera) const;
    std::shared_ptr<const ViewOutlines> outlinesFor(const geometry::CameraModel& camera) const;
    InspectionResult run(const VoxelOracle& oracle, const std::vector<SilhouetteView>* views,
                         const std::vector<std::string>* viewIds) const;

    const InspectionMap* map_;
    InspectionOptions options_;
    int level_;
    int adjacency_;
    std::vector<std::uint8_t> active_;
    /// Per landmark, the network voxels on its normal line (map geometry).
    std::vector<std::vector<std::int32_t>> normalLines_;
    std::shared_ptr<const align::Aligner> aligner_;
    std::shared_ptr<const DeviationGauge> gauge_;
    /// Outline points of the planned views, found when the program was loaded.
    std::vector<std::pair<geometry::CameraModel, std::shared_ptr<const ViewOutlines>>> outlineCache_;
};

} // namespace hg::inspect
