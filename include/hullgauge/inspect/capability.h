// The capability check before production (docs/inspection.md, "Capability"):
// can this station decide a landmark's tolerance at all? A gauge should be
// at least four times finer than the zone it decides (the test uncertainty
// ratio 4:1: zone ≥ 4 U); under the guarded rule of ISO 14253-1 a zone
// narrower than 2 U can never conform. Before any frame is taken, U is the
// uncertainty the sub-voxel gauge expects at the planned views
// (DeviationGauge::expected); without the gauge, or at a landmark no planned
// view sees on its outline, the landmark is decided on the voxel bracket,
// one voxel wide: U = ΔV/2, its half-width, which holds the offset with
// certainty (a rectangular distribution's 95 % interval is ±0.95 of it,
// GUM G.1.3) — so a zone of 2 tolerance needs tolerance ≥ ΔV, the planner's
// own rule (docs/planning.md).
//
// Pure computation on values: no I/O.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/deviation.h"
#include "hullgauge/inspect/voxel_frame.h"

namespace hg::inspect {

/// The test uncertainty ratio a landmark's tolerance zone must reach: zone ≥ 4 U.
inline constexpr double kTestUncertaintyRatio = 4.0;

struct LandmarkCapability {
    std::string id;
    double zoneMm = 0.0;     ///< upper − lower limit
    double expectedMm = 0.0; ///< expected U (k = 2)
    bool bracket = false;    ///< decided on the voxel bracket (no gauge, or no view sees the outline)
    int views = 0;           ///< planned views that see the landmark on its outline (the gauge)
    bool capable = false;    ///< zone ≥ kTestUncertaintyRatio · U
    Deviation prediction;    ///< the gauge's budget (not measured when `bracket`)
};

/// Every landmark's expected U at these cameras (the planned views); `gauge`
/// null when the program does not measure deviations. `voxelMm`: ΔV at the
/// inspection level.
std::vector<LandmarkCapability> assessCapability(const std::vector<MapLandmark>& landmarks, double voxelMm,
                                                 const DeviationGauge* gauge,
                                                 const std::vector<geometry::CameraModel>& cameras,
                                                 const geometry::ImageQuality& quality);

/// The largest share of its capability bound a landmark's U takes — 4 U / zone,
/// 1 at the bound (kTestUncertaintyRatio) — when the edge location's standard
/// uncertainty is `sigmaPx` where the assessment predicted `plannedSigmaPx`:
/// each view's noise term scales with it and the views are combined again as
/// the gauge combines them (their method, tilt and calibration terms as they
/// were); a landmark decided on the voxel bracket keeps its U (docs/health.md, "Capability"). Only the landmarks the
/// assessment found capable count: a forced one is beyond its bound from the start and says so where it is inspected.
/// NaN when none counts or either σ is not positive and finite.
double capabilityUsed(const std::vector<LandmarkCapability>& assessment, double plannedSigmaPx, double sigmaPx);

/// One sentence naming the landmark and the numbers, e.g. "landmark post-nx:
/// tolerance zone 0.01 mm is narrower than 4 U = 4 × 0.0071 mm (sub-voxel
/// deviation, 3 views): this station cannot prove it".
std::string describe(const LandmarkCapability& capability);
/// Each one described, joined by "; ": one line for an error or the journal.
std::string describe(const std::vector<LandmarkCapability>& capabilities);

nlohmann::json toJson(const LandmarkCapability& capability);

} // namespace hg::inspect
