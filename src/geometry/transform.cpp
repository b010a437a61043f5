#include "hullgauge/geometry/transform.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

namespace hg::geometry {

Eigen::Matrix<double, 3, 4> RigidTransform::matrix() const
{
    Eigen::Matrix<double, 3, 4> m;
    m.leftCols<3>() = R;
    m.col(3) = t;
    return m;
}

RigidTransform RigidTransform::rotation(const Vec3& axis, double angleDeg)
{
    RigidTransform T;
    T.R = Eigen::AngleAxisd(degToRad(angleDeg), axis.normalized()).toRotationMatrix();
    return T;
}

bool isRotation(const Mat3& R, double tol)
{
    return (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() <= tol &&
           std::abs(R.determinant() - 1.0) <= tol;
}

Mat3 nearestRotation(const Mat3& M)
{
    Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 D = Mat3::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
    return svd.matrixU() * D * svd.matrixV().transpose();
}

double rotationAngleDeg(const Mat3& Ra, const Mat3& Rb)
{
    double c = ((Ra.transpose() * Rb).trace() - 1.0) / 2.0;
    return radToDeg(std::acos(std::clamp(c, -1.0, 1.0)));
}

} // namespace hg::geometry
