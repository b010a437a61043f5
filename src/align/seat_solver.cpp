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

namespace {

// One datum's (or the silhouette's) normal equations in the projected motion.
struct Stage {
    Matrix6 H = Matrix6::Zero();
    Vector6 g = Vector6::Zero();
    double weightSum = 0.0;
};

Stage stageOf(const std::vector<Observation>& obs, const std::vector<double>& w, int group, const Matrix6& P)
{
    Stage st;
    for (std::size_t j = 0; j < obs.size(); ++j) {
        if (obs[j].group != group || w[j] <= 0.0) continue;
        const Vector6 J = P.transpose() * obs[j].gradient;
        st.H += w[j] * J * J.transpose();
        st.g += w[j] * J * obs[j].residual;
        st.weightSum += w[j];
    }
    return st;
}

// The inverse of the stage's normal matrix over the free directions it
// determines (SolverLimits); the directions it leaves go to `left`.
Eigen::MatrixXd determinedInverse(const Stage& st, const Eigen::MatrixXd& free, const SolverLimits& limits,
                                  double sigmaFloor, Eigen::MatrixXd& left)
{
    const Eigen::MatrixXd A = free.transpose() * st.H * free;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
    const double lambdaMax = eig.eigenvalues().maxCoeff();
    Eigen::MatrixXd pinv = Eigen::MatrixXd::Zero(A.rows(), A.cols());
    std::vector<Eigen::Index> undetermined;
    for (Eigen::Index i = 0; i < A.rows(); ++i) {
        const double l = eig.eigenvalues()(i);
        const Vector6 u = free * eig.eigenvectors().col(i);
        const double range = limits.maxTurnMm * u.head<3>().norm() + limits.maxShiftMm * u.tail<3>().norm();
        const bool determined = l > 0.0 && l >= limits.minRelative * lambdaMax &&
                                std::sqrt(l / st.weightSum) * range >= limits.minMotionPx &&
                                sigmaFloor / std::sqrt(l) <= range;
        if (determined)
            pinv += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose() / l;
        else
            undetermined.push_back(i);
    }
    left.resize(6, static_cast<Eigen::Index>(undetermined.size()));
    for (std::size_t i = 0; i < undetermined.size(); ++i)
        left.col(static_cast<Eigen::Index>(i)) = free * eig.eigenvectors().col(undetermined[i]);
    return pinv;
}

// θ = B·r: the step is linear in the residuals, which carries their variance
// to the seat's covariance through every stage of 3-2-1.
Matrix6 covarianceOf(const std::vector<Observation>& obs, const std::vector<ObservationGroup>& groups,
                     const std::vector<double>& w, const std::vector<Eigen::MatrixXd>& frees,
                     const std::vector<Eigen::MatrixXd>& pinvs, double sigma)
{
    const auto n = static_cast<Eigen::Index>(obs.size());
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(6, n);
    for (std::size_t g = 0; g < pinvs.size(); ++g) {
        const Matrix6& P = groups[g].projection;
        Matrix6 H = Matrix6::Zero();
        Eigen::MatrixXd G = Eigen::MatrixXd::Zero(6, n);
        for (Eigen::Index j = 0; j < n; ++j) {
            const auto k = static_cast<std::size_t>(j);
            if (obs[k].group != static_cast<int>(g) || w[k] <= 0.0) continue;
            const Vector6 J = P.transpose() * obs[k].gradient;
            H += w[k] * J * J.transpose();
            G.col(j) = w[k] * J;
        }
        B += frees[g] * (-pinvs[g] * frees[g].transpose() * (H * B + G));
    }
    Matrix6 cov = Matrix6::Zero();
    for (Eigen::Index j = 0; j < n; ++j) {
        const double wj = w[static_cast<std::size_t>(j)];
        if (wj > 0.0) cov += sigma * sigma / wj * B.col(j) * B.col(j).transpose();
    }
    return cov;
}

} // namespace

Step robustStep(const std::vector<Observation>& obs, const std::vector<ObservationGroup>& groups,
                const SolverLimits& limits, Loss loss, bool withCovariance)
{
    Step step;
    step.weights = robustWeights(obs, groups.size(), limits.minScalePx, loss, step.scalePx);
    const double sigma = residualSigma(obs, step.weights);
    const double sigmaFloor = std::max(sigma, limits.minScalePx);
    Eigen::MatrixXd free = Matrix6::Identity();
    std::vector<Eigen::MatrixXd> frees, pinvs;
    for (std::size_t g = 0; g < groups.size() && free.cols() > 0; ++g) {
        const Stage st = stageOf(obs, step.weights, static_cast<int>(g), groups[g].projection);
        Eigen::MatrixXd left;
        const Eigen::MatrixXd pinv = determinedInverse(st, free, limits, sigmaFloor, left);
        // Solve in the directions the earlier stages left free.
        step.delta += free * (-pinv * free.transpose() * (st.H * step.delta + st.g));
        frees.push_back(free);
        pinvs.push_back(pinv);
        free = left;
    }
    if (withCovariance) step.covariance = covarianceOf(obs, groups, step.weights, frees, pinvs, sigma);
    for (Eigen::Index i = 0; i < free.cols(); ++i) step.undetermined.push_back(free.col(i).normalized());
    return step;
}

} // namespace hg::align
