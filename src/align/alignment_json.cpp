// The measured seat as JSON: the result's `alignment` object and the seat
// transforms the cycle records (docs/alignment.md, docs/contracts.md §4),
// written here alone, apart from the measurement.
#include "hullgauge/align/alignment.h"

#include "hullgauge/geometry/json.h"
#include "hullgauge/geometry/transform.h"

namespace hg::align {

nlohmann::json seatJson(const geometry::RigidTransform& seat, const Vec3& pivot)
{
    return {{"R", geometry::toJson(seat.R)},
            {"t", geometry::toJson(seat.t)},
            {"centre", geometry::toJson(pivot)},
            {"shift_mm", (seat.apply(pivot) - pivot).norm()},
            {"rotation_deg", geometry::rotationAngleDeg(geometry::Mat3::Identity(), seat.R)}};
}

nlohmann::json toJson(const AlignmentResult& r)
{
    using geometry::toJson;
    nlohmann::json fixed = nlohmann::json::array();
    for (const FixedDof& d : r.fixedDofs) {
        nlohmann::json j{{"kind", d.kind == FixedDof::Kind::Rotation ? "rotation" : "translation"},
                         {"axis", toJson(d.axis)},
                         {"label", d.label}};
        if (d.kind == FixedDof::Kind::Rotation) j["point"] = toJson(d.point);
        fixed.push_back(std::move(j));
    }
    return {{"method", enumName(r.method)},
            {"measured", r.measured},
            {"R", toJson(r.seat.R)},
            {"t", toJson(r.seat.t)},
            {"reference_point", toJson(r.referencePoint)},
            {"shift_mm", r.shiftMm},
            {"rotation_deg", r.rotationDeg},
            {"residual_px", r.residualPx},
            {"edge_bias_px", r.edgeBiasPx},
            {"shift_uncertainty_mm", r.shiftUncertaintyMm},
            {"rotation_uncertainty_deg", r.rotationUncertaintyDeg},
            {"fixed_dofs", fixed},
            {"samples", r.samples},
            {"inliers", r.inliers},
            {"iterations", r.iterations},
            {"within_limits", r.withinLimits},
            {"message", r.message},
            {"ms", r.ms}};
}

} // namespace hg::align
