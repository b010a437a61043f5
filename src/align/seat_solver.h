// One robust Gauss–Newton step of the seat (docs/alignment.md, "The solver").
//
// Parameters θ = (L·ω, v): a small rotation ω (rad) about the part's
// reference point and a shift v (mm) of it, the rotation scaled by the part's
// lever L so that both halves are millimetres at the part's extremes.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace hg::align {

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

/// One residual (px) and its gradient with respect to θ, in group `group`
/// (the datum it belongs to; 0 for the silhouette method).
struct Observation {
    Vector6 gradient;
    double residual = 0.0;
    int group = 0;
};

/// One group of observations: what its residuals may determine. `projection`
/// maps a motion onto the part of it the group's surface can see (identity
/// for the silhouette method; for a datum plane, its normal shift and tilts).
struct ObservationGroup {
    Matrix6 projection = Matrix6::Identity();
};

/// When a direction counts as determined (docs/alignment.md, "Directions the
/// views do not determine"): the outline must move along it at least
/// `minRelative` of the squared sensitivity of the best-seen direction (a
/// turn of a tessellated surface of revolution about its axis shows only
/// its facets: far less), moving the seat along it across the range the
/// limits allow must move the outline by `minMotionPx` (RMS over the
/// samples), and the residuals must pin it to better than that range.
struct SolverLimits {
    double maxShiftMm = 1.0; ///< the range of a shift
    double maxTurnMm = 1.0;  ///< of θ: the range of a rotation (lever × max rotation)
    double minRelative = 1e-2;
    double minMotionPx = 0.25;
    double minScalePx = 0.1; ///< the robust scale never drops below this: the edges' noise floor
};

struct Step {
    Vector6 delta = Vector6::Zero();      ///< θ to add
    Matrix6 covariance = Matrix6::Zero(); ///< of θ, mm²
    std::vector<Vector6> undetermined;    ///< unit θ directions left at nominal
    std::vector<double> weights;          ///< robust weight per observation
    double scalePx = 0.0;                 ///< robust scale of the residuals
};

/// How residuals are weighted: Huber's (convex: a start far from the seat
/// still converges to it) or Tukey's biweight (redescending: an edge far off,
/// a defect's, gets no weight at all once the seat is close).
enum class Loss { Huber, Tukey };

/// Robust (IRLS) Gauss–Newton step, groups solved in order, each in the
/// directions the groups before it left free (3-2-1 for datums).
/// The covariance (the last step's, for the report) only `withCovariance`.
Step robustStep(const std::vector<Observation>& observations, const std::vector<ObservationGroup>& groups,
                const SolverLimits& limits, Loss loss, bool withCovariance = false);

} // namespace hg::align
