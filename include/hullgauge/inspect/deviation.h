// Signed sub-voxel deviation of a landmark's surface (docs/inspection.md,
// "Sub-voxel deviation"). The octree bracket (3.3.8, 4.6.2) knows the surface
// to one voxel; the grey levels of the views that see the landmark on their
// silhouette outline know it to a fraction of a pixel. In every such view the
// CAD model's outline is found along the image direction of the landmark's
// normal (the pixel where the line of sight just misses the solid), the
// image's silhouette edge is located beside it to a fraction of a pixel
// (vision::findEdge), and the distance between the two, divided by how many
// pixels a millimetre along the normal makes at the outline, is the
// surface's offset there, outward positive. The views are combined by their
// noise (a weighted mean); the bracket stays the honest envelope.
//
// Pure computation on values: no I/O, no threads; const methods are safe to
// call from several threads.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hullgauge/align/alignment.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/outcome.h"
#include "hullgauge/inspect/voxel_frame.h"
#include "hullgauge/inspect/voxel_test.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/solid.h"

namespace hg::inspect {

/// Where the CAD model forms the outline beside one landmark in one camera:
/// the points the ray casts found, which an inspection then only projects
/// through its own (seated) camera (docs/inspection.md, "Sub-voxel
/// deviation"). The outline of a curved surface or an edge is stationary
/// under the small motions of a seat, so its image moves with `graze` to
/// second order; a flat face seen edge-on is not — tilted by the seat, its
/// outline is its near or far boundary along the line of sight, the ends of
/// the grazing line's chord through it, whichever lies outermost.
struct OutlinePoint {
    geometry::Vec3 graze; ///< on the outline: where the last line of sight that still meets the solid enters it
    /// Where that line of sight leaves the solid again, when it leaves on the
    /// landmark's surface: the chord's far end on a face seen edge-on.
    std::optional<geometry::Vec3> grazeExit;
    geometry::Vec3 touch; ///< where the line of sight just inside it first meets the solid (the landmark's surface)
    /// Where that line of sight leaves the solid again, when it leaves on the
    /// landmark's surface (the far boundary a surface moved inward is seen by).
    std::optional<geometry::Vec3> exit;
};

/// One camera's outline points, by the map's landmark index; nullopt where
/// the landmark's surface does not form that camera's outline.
struct ViewOutlines {
    std::vector<std::optional<OutlinePoint>> landmarks;
};

/// The frame pixels the sub-voxel step may read beside landmark `lm` in a view
/// through `camera` (inclusive pixel rectangle, not clipped to the frame): the
/// edge search along the image of the normal from where the CAD outline runs
/// (within a pixel of the landmark's image), every pixel findEdge reads, and
/// `marginPx` more all round for a seat that moves the outline (docs/inspection.md,
/// "Pixels in proportion to the goal"). nullopt where the step leaves the
/// view out (the landmark behind the camera, its normal far out of the image plane).
std::optional<cv::Rect> edgeReadRect(const geometry::CameraModel& camera, const MapLandmark& lm, double marginPx);

/// One view's measurement of a landmark.
struct ViewDeviation {
    std::string viewId;
    double deviationMm = 0.0; ///< signed, outward positive
    double sigmaMm = 0.0;     ///< standard uncertainty from the frame's noise
    double pxPerMm = 0.0;     ///< outline motion per millimetre along the normal
    /// How much shorter a local feature is seen because the line of sight
    /// leaves the tangent plane (mm, standard; docs/inspection.md).
    double tiltMm = 0.0;
    /// The calibration's own uncertainty where the outline is predicted (mm, standard).
    double calibrationMm = 0.0;
};

/// The standard uncertainties (mm, k = 1) the expanded one combines (GUM).
struct DeviationBudget {
    double edgeNoise = 0.0; ///< the frames' noise through the edge location, the views combined
    double method = 0.0;    ///< the edge location's own limit and the views' tilt (docs/inspection.md)
    double views = 0.0;     ///< the views' disagreement beyond their noise
    double alignment = 0.0; ///< the seat's covariance at the landmark, along its normal
    /// The intrinsics' standard deviations and the fixture model's residual
    /// where the outline is predicted (0 without calibration records).
    double calibration = 0.0;
};

struct Deviation {
    bool measured = false;
    double deviationMm = 0.0;   ///< signed, outward positive (material added)
    double uncertaintyMm = 0.0; ///< expanded, k = 2
    DeviationBudget budget;
    std::vector<ViewDeviation> views;
    std::string reason; ///< why not measured
};

/// The part program's decision rule (model/part_program.h).
using model::DecisionRule;
/// The decision for a deviation with expanded uncertainty U against the
/// limits [lower, upper] (lower < upper; mm, outward positive).
Decision decide(double deviationMm, double uncertaintyMm, double lowerMm, double upperMm, DecisionRule rule);

/// The views' measurements combined: their weighted mean and its budget
/// (docs/inspection.md, "Uncertainty budget"); not measured without views.
Deviation combine(std::vector<ViewDeviation> views, double alignmentSigmaMm);

class DeviationGauge {
  public:
    /// `calibration`: the station's calibration records (from the station
    /// file, or the capture manifest that carries them), for the budget.
    explicit DeviationGauge(std::shared_ptr<const model::Solid> solid,
                            geometry::CalibrationUncertainty calibration = {});

    /// The uncertainty expected for a landmark before any frame is taken
    /// (the capability check, docs/inspection.md): the views' geometry as
    /// measure() would find it, the edge noise predicted from the image
    /// quality, the method, tilt and calibration terms; deviation 0, no
    /// disagreement between views and no seat term (both are measured per part).
    Deviation expected(const MapLandmark& landmark, const std::vector<geometry::CameraModel>& cameras,
                       const geometry::ImageQuality& quality) const;

    /// The ray casts of the step: where the CAD outline runs beside every
    /// landmark in `camera` (the view's nominal camera). Done once per planned
    /// view when a program is loaded, or as a view is prepared.
    ViewOutlines outlines(const std::vector<MapLandmark>& landmarks, const geometry::CameraModel& camera) const;
    /// One landmark's share of outlines().
    std::optional<OutlinePoint> outlineAt(const MapLandmark& landmark, const geometry::CameraModel& camera) const;

    /// The landmark (the map's landmark `index`) deviation from the views
    /// (cameras as inspected: seated when the part was aligned; frames with
    /// their grey levels; each view's outline points when it has them, else
    /// they are found here). `alignment`, when given, adds the seat's
    /// uncertainty.
    Deviation measure(std::size_t index, const MapLandmark& landmark, const std::vector<SilhouetteView>& views,
                      const std::vector<std::string>& viewIds, const align::AlignmentResult* alignment) const;

    /// One view's share, from the outline point beside the landmark; nullopt
    /// when the view does not see the landmark on its outline or finds no
    /// clean edge there.
    std::optional<ViewDeviation> measureInView(const MapLandmark& landmark, const SilhouetteView& view,
                                               const OutlinePoint& outline) const;

    const geometry::CalibrationUncertainty& calibration() const { return calibration_; }

  private:
    double calibrationSigma(const geometry::CameraModel& camera, const geometry::Vec3& point, const geometry::Vec2& u,
                            double pxPerMm) const;

    std::shared_ptr<const model::Solid> solid_;
    geometry::CalibrationUncertainty calibration_;
};

} // namespace hg::inspect
