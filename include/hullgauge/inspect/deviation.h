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
#include "hullgauge/inspect/voxel_frame.h"
#include "hullgauge/inspect/voxel_test.h"
#include "hullgauge/model/solid.h"

namespace hg::inspect {

/// One view's measurement of a landmark.
struct ViewDeviation {
    std::string viewId;
    double deviationMm = 0.0; ///< signed, outward positive
    double sigmaMm = 0.0;     ///< standard uncertainty from the frame's noise
    double pxPerMm = 0.0;     ///< outline motion per millimetre along the normal
    /// How much shorter a local feature is seen because the line of sight
    /// leaves the tangent plane (mm, standard; docs/inspection.md).
    double tiltMm = 0.0;
};

/// The standard uncertainties (mm, k = 1) the expanded one combines (GUM).
struct DeviationBudget {
    double edgeNoise = 0.0; ///< the frames' noise through the edge location, the views combined
    double method = 0.0;    ///< the edge location's own limit and the views' tilt (docs/inspection.md)
    double views = 0.0;     ///< the views' disagreement beyond their noise
    double alignment = 0.0; ///< the seat's covariance at the landmark, along its normal
};

struct Deviation {
    bool measured = false;
    double deviationMm = 0.0;   ///< signed, outward positive (material added)
    double uncertaintyMm = 0.0; ///< expanded, k = 2
    DeviationBudget budget;
    std::vector<ViewDeviation> views;
    std::string reason; ///< why not measured
};

/// ISO 14253-1 decision rules (docs/inspection.md, "Decisions"): `guarded`
/// — conformance must be proven: the deviation lies inside the limits by at
/// least U, nonconformance when it lies outside by at least U, else
/// uncertain; `simple` — the deviation against the limits, U ignored.
enum class DecisionRule { Guarded, Simple };
enum class Decision { Conforms, Nonconforms, Uncertain };
const char* toString(DecisionRule rule);
const char* toString(Decision decision);
/// The decision for a deviation with expanded uncertainty U against the
/// limits [lower, upper] (lower < upper; mm, outward positive).
Decision decide(double deviationMm, double uncertaintyMm, double lowerMm, double upperMm, DecisionRule rule);

class DeviationGauge {
  public:
    explicit DeviationGauge(std::shared_ptr<const model::Solid> solid);

    /// The landmark's deviation from the views (cameras as inspected: seated
    /// when the part was aligned; frames with their grey levels). `alignment`,
    /// when given, adds the seat's uncertainty.
    Deviation measure(const MapLandmark& landmark, const std::vector<SilhouetteView>& views,
                      const std::vector<std::string>& viewIds, const align::AlignmentResult* alignment) const;

    /// One view's share; nullopt when the view does not see the landmark on
    /// its outline or finds no clean edge there.
    std::optional<ViewDeviation> measureInView(const MapLandmark& landmark, const SilhouetteView& view) const;

  private:
    std::shared_ptr<const model::Solid> solid_;
};

nlohmann::json toJson(const Deviation& deviation);

} // namespace hg::inspect
