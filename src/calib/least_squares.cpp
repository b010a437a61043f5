#include "least_squares.h"

#include <algorithm>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace hg::calib::detail {
namespace {

Eigen::MatrixXd jacobian(const ResidualFunction& f, const Eigen::VectorXd& x, const Eigen::VectorXd& step,
                         Eigen::Index m)
{
    Eigen::MatrixXd J(m, x.size());
    Eigen::VectorXd rp(m), rm(m);
    for (Eigen::Index j = 0; j < x.size(); ++j) {
        Eigen::VectorXd xp = x, xm = x;
        xp[j] += step[j];
        xm[j] -= step[j];
        f(xp, rp);
        f(xm, rm);
        J.col(j) = (rp - rm) / (2.0 * step[j]);
    }
    return J;
}

} // namespace

LeastSquaresResult levenbergMarquardt(const ResidualFunction& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& step,
                                      int maxIterations)
{
    LeastSquaresResult out;
    Eigen::VectorXd x = x0;
    Eigen::VectorXd r;
    f(x, r);
    const Eigen::Index m = r.size(), n = x.size();
    double cost = r.squaredNorm();
    double lambda = 1e-3;
    Eigen::MatrixXd J = jacobian(f, x, step, m);
    for (int it = 0; it < maxIterations; ++it) {
        out.iterations = it + 1;
        Eigen::MatrixXd A = J.transpose() * J;
        Eigen::VectorXd g = J.transpose() * r;
        bool improved = false;
        while (lambda < 1e12) {
            // Marquardt's scaling: damp each parameter by its own curvature.
            Eigen::MatrixXd Ad = A;
            for (Eigen::Index i = 0; i < n; ++i) Ad(i, i) += lambda * std::max(A(i, i), 1e-12);
            Eigen::VectorXd dx = Ad.ldlt().solve(-g);
            Eigen::VectorXd xn = x + dx;
            Eigen::VectorXd rn;
            f(xn, rn);
            double costNew = rn.squaredNorm();
            if (costNew < cost) {
                bool small = (dx.array().abs() < 1e-10 * (x.array().abs() + step.array())).all() ||
                             (cost - costNew) < 1e-14 * cost;
                x = xn;
                r = rn;
                cost = costNew;
                lambda = std::max(lambda / 10.0, 1e-12);
                improved = true;
                if (small) out.converged = true;
                break;
            }
            lambda *= 10.0;
        }
        if (!improved) {
            out.converged = true; // no step reduces the cost: at a minimum
            break;
        }
        J = jacobian(f, x, step, m);
        if (out.converged) break;
    }
    out.x = x;
    out.residuals = r;
    Eigen::MatrixXd A = J.transpose() * J;
    double s2 = m > n ? cost / static_cast<double>(m - n) : 0.0;
    Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
    out.covariance = lu.isInvertible() ? Eigen::MatrixXd(s2 * lu.inverse())
                                       : Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
    return out;
}

} // namespace hg::calib::detail
