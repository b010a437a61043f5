// Robust Gauss–Newton step of the seat (docs/alignment.md, "The solver").
#include "seat_solver.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace hg::align {
namespace {

// Tukey's biweight and Huber's loss at their 95 % efficiency under Gaussian
// residuals; the biweight gives zero weight beyond c·scale, so a defect's
// edges stop pulling the seat altogether.
constexpr double kTukeyC = 4.685;
constexpr double kHuberC = 1.345;
// Median absolute deviation to a Gaussian standard deviation.
constexpr double kMadToSigma = 1.4826;

double median(std::vector<double> v)
{
    if (v.empty()) return 0.0;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}

// Robust scale per group and the biweights.
std::vector<double> robustWeights(const std::vector<Observation>& obs, std::size_t groups, double minScale, Loss loss,
                                  double& scaleOut)
{
    std::vector<std::vector<double>> absolute(groups);
    for (const Observation& o : obs) absolute[static_cast<std::size_t>(o.group)].push_back(std::abs(o.residual));
    std::vector<double> scale(groups);
    scaleOut = 0.0;
    for (std::size_t g = 0; g < groups; ++g) {
        scale[g] = std::max(minScale, kMadToSigma * median(absolute[g]));
        scaleOut = std::max(scaleOut, scale[g]);
    }
    std::vector<double> w(obs.size(), 0.0);
    for (std::size_t j = 0; j < obs.size(); ++j) {
        const double sigma = scale[static_cast<std::size_t>(obs[j].group)];
        const double r = std::abs(obs[j].residual);
        if (loss == Loss::Huber) {
            w[j] = r <= kHuberC * sigma ? 1.0 : kHuberC * sigma / r;
        } else if (r < kTukeyC * sigma) {
            const double u = r / (kTukeyC * sigma);
            w[j] = (1.0 - u * u) * (1.0 - u * u);
        }
    }
    return w;
}

// Standard deviation of a residual of unit weight, from the weighted residuals.
double residualSigma(const std::vector<Observation>& obs, const std::vector<double>& w)
{
    double sw = 0.0, swr = 0.0;
    int n = 0;
    for (std::size_t j = 0; j < obs.size(); ++j) {
        if (w[j] <= 0.0) continue;
        sw += w[j];
        swr += w[j] * obs[j].residual * obs[j].residual;
        ++n;
    }
    if (n <= 6 || sw <= 0.0) return 0.0;
    return std::sqrt(swr / sw * n / (n - 6.0));
}

} // namespace

Step robustStep(const std::vector<Observation>& obs, const std::vector<ObservationGroup>& groups,
                const SolverLimits& limits, Loss loss)
{
    Step step;
    step.weights = robustWeights(obs, groups.size(), limits.minScalePx, loss, step.scalePx);
    const double sigma = residualSigma(obs, step.weights);
    const double sigmaFloor = std::max(sigma, limits.minScalePx);
    const Eigen::Index n = static_cast<Eigen::Index>(obs.size());
    // θ = B·r: the step is linear in the residuals, which carries their
    // variance to the seat's covariance through every stage of 3-2-1.
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(6, n);
    Eigen::MatrixXd free = Matrix6::Identity();
    for (std::size_t g = 0; g < groups.size() && free.cols() > 0; ++g) {
        const Matrix6 P = groups[g].projection;
        Matrix6 H = Matrix6::Zero();
        double weightSum = 0.0;
        Eigen::MatrixXd G = Eigen::MatrixXd::Zero(6, n);
        for (Eigen::Index j = 0; j < n; ++j) {
            const Observation& o = obs[static_cast<std::size_t>(j)];
            const double w = step.weights[static_cast<std::size_t>(j)];
            if (o.group != static_cast<int>(g) || w <= 0.0) continue;
            const Vector6 J = P.transpose() * o.gradient;
            H += w * J * J.transpose();
            weightSum += w;
            G.col(j) = w * J;
        }
        const Eigen::MatrixXd A = free.transpose() * H * free;
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
        const double lambdaMax = eig.eigenvalues().maxCoeff();
        Eigen::MatrixXd pinv = Eigen::MatrixXd::Zero(A.rows(), A.cols());
        std::vector<Eigen::Index> left;
        for (Eigen::Index i = 0; i < A.rows(); ++i) {
            const double l = eig.eigenvalues()(i);
            const Vector6 u = free * eig.eigenvectors().col(i);
            const double range = limits.maxTurnMm * u.head<3>().norm() + limits.maxShiftMm * u.tail<3>().norm();
            const bool determined = l > 0.0 && l >= limits.minRelative * lambdaMax &&
                                    std::sqrt(l / weightSum) * range >= limits.minMotionPx &&
                                    sigmaFloor / std::sqrt(l) <= range;
            if (determined)
                pinv += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose() / l;
            else
                left.push_back(i);
        }
        B += free * (-pinv * free.transpose() * (H * B + G));
        Eigen::MatrixXd next(6, static_cast<Eigen::Index>(left.size()));
        for (std::size_t i = 0; i < left.size(); ++i)
            next.col(static_cast<Eigen::Index>(i)) = free * eig.eigenvectors().col(left[i]);
        free = next;
    }
    Eigen::VectorXd r(n);
    for (Eigen::Index j = 0; j < n; ++j) r(j) = obs[static_cast<std::size_t>(j)].residual;
    step.delta = B * r;
    for (Eigen::Index j = 0; j < n; ++j) {
        const double w = step.weights[static_cast<std::size_t>(j)];
        if (w > 0.0) step.covariance += sigma * sigma / w * B.col(j) * B.col(j).transpose();
    }
    for (Eigen::Index i = 0; i < free.cols(); ++i) step.undetermined.push_back(free.col(i).normalized());
    return step;
}

} // namespace hg::align
