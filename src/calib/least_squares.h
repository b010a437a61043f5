// A small Levenberg-Marquardt solver for the calibration fits (rail pinhole
// fit, fixture-axis refinement): a few to a few dozen parameters, residuals in
// pixels, central-difference Jacobians. Internal to src/calib.
#pragma once

#include <functional>

#include <Eigen/Core>

namespace hg::calib::detail {

/// Fills `residuals` (its size fixed by the first call) for parameters `x`.
using ResidualFunction = std::function<void(const Eigen::VectorXd& x, Eigen::VectorXd& residuals)>;

struct LeastSquaresResult {
    Eigen::VectorXd x;
    Eigen::VectorXd residuals;
    /// Covariance of x: s^2 (J^T J)^-1 with s^2 = |r|^2 / (m - n).
    Eigen::MatrixXd covariance;
    int iterations = 0;
    bool converged = false;
};

/// Minimises |residuals(x)|^2 from `x0`. `step` is the finite-difference step
/// per parameter (scaled to each parameter's unit).
LeastSquaresResult levenbergMarquardt(const ResidualFunction& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& step,
                                      int maxIterations = 100);

} // namespace hg::calib::detail
