#include "hullgauge/geometry/camera.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"

#include <cmath>
#include <string>

#include <Eigen/LU>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace hg::geometry {

bool Intrinsics::hasDistortion() const
{
    if (distortionModel == DistortionModel::Division && kappa != 0.0) return true;
    for (double d : dist)
        if (d != 0.0) return true;
    return false;
}

// The messages start with the key they concern ("K: ", "dist: ", "image_size: "): the station file's loader
// names that key's line with the rest of the message (docs/style.md point 4).
void Intrinsics::validate() const
{
    if (!(K(0, 0) > 0) || !(K(1, 1) > 0)) throw ArgumentError("K: fx and fy must be positive");
    if (K(1, 0) != 0 || K(2, 0) != 0 || K(2, 1) != 0 || K(2, 2) != 1)
        throw ArgumentError("K: must be upper triangular with K[2][2] = 1");
    switch (dist.size()) {
    case 0:
    case 4:
    case 5:
    case 8:
    case 12:
        break;
    case 14:
        throw ArgumentError("dist: the 14-coefficient tilted-sensor model is not supported");
    default:
        throw ArgumentError("dist: expected 4, 5, 8 or 12 OpenCV coefficients, found " + std::to_string(dist.size()));
    }
    if (imageSize.width <= 0 || imageSize.height <= 0)
        throw ArgumentError("image_size: must be positive, found " + std::to_string(imageSize.width) + "x" +
                            std::to_string(imageSize.height));
    // Plausibility, so that a typo (or a fuzzer's 1e308) is named here rather
    // than overflowing a projection far downstream: focal lengths below 10^7 px,
    // the principal point within ten image sizes of the image, coefficients
    // within 10^6.
    if (K(0, 0) > 1e7 || K(1, 1) > 1e7 || std::abs(K(0, 1)) > 1e7)
        throw ArgumentError("K: fx, fy and the skew must be below 1e7 px");
    const double w = imageSize.width, h = imageSize.height;
    if (std::abs(K(0, 2) - w / 2) > 10 * w || std::abs(K(1, 2) - h / 2) > 10 * h)
        throw ArgumentError("K: the principal point (cx, cy) lies more than ten image sizes from the image");
    for (double d : dist)
        if (!std::isfinite(d) || std::abs(d) > 1e6)
            throw ArgumentError("dist: coefficients must lie within ±1e6, found " + formatNumber(d));
    if (distortionModel == DistortionModel::Division)
        for (double d : dist)
            if (d != 0.0) throw ArgumentError("dist: the division model takes kappa, not OpenCV's coefficients");
    if (!std::isfinite(kappa) || std::abs(kappa) > 1e6)
        throw ArgumentError("kappa: must lie within ±1e6, found " + formatNumber(kappa));
    if (!(workingDistanceMm > 0))
        throw ArgumentError("working_distance_mm: must be positive, found " + formatNumber(workingDistanceMm));
}

namespace {

/// With no working distance stated, a telecentric camera's lines of sight
/// start on a plane this far (mm) before the focus plane: beyond any part a
/// station holds, near enough that a point on it keeps 1e-12 mm of precision.
constexpr double kUnstatedWorkingDistanceMm = 1e4;

} // namespace

CameraModel::CameraModel(Intrinsics intrinsics, RigidTransform cameraFromPart)
    : intrinsics_(std::move(intrinsics)), cameraFromPart_(cameraFromPart),
      centre_(-(cameraFromPart.R.transpose() * cameraFromPart.t)), distorted_(intrinsics_.hasDistortion())
{
}

CameraModel CameraModel::telecentric(Intrinsics intrinsics, RigidTransform cameraFromPart)
{
    intrinsics.projection = Projection::Telecentric;
    return CameraModel(std::move(intrinsics), cameraFromPart);
}

CameraModel CameraModel::telecentricFromAxes(double mOverDph, double mOverDpv, double mc, double nc, const Vec3& P0,
                                             const Vec3& h, const Vec3& v, const Vec3& a, cv::Size imageSize)
{
    // The same axes and principal point as fromDissertation; the centre C
    // becomes a point of the axis on the focus plane (camera-frame origin).
    CameraModel c = fromDissertation(mOverDph, mOverDpv, mc, nc, P0, h, v, a, imageSize);
    return telecentric(c.intrinsics_, c.cameraFromPart_);
}

std::optional<Vec3> CameraModel::centre() const
{
    if (isTelecentric()) return std::nullopt;
    return centre_;
}

double CameraModel::lensFrontZ() const
{
    const double wd = intrinsics_.workingDistanceMm;
    return -(std::isfinite(wd) ? wd : kUnstatedWorkingDistanceMm);
}

Vec3 CameraModel::lineOfSight(const Vec3& partPoint) const
{
    if (isTelecentric()) return opticalAxis();
    return (partPoint - centre_).normalized();
}

Vec3 CameraModel::sightOrigin(const Vec3& partPoint) const
{
    if (!isTelecentric()) return centre_;
    // The point moved along the axis to the lens front's plane.
    return partPoint + (lensFrontZ() - depthOf(partPoint)) * opticalAxis();
}

double CameraModel::rangeTo(const Vec3& partPoint) const
{
    if (isTelecentric()) return depthOf(partPoint) - lensFrontZ();
    return (partPoint - centre_).norm();
}

bool CameraModel::depthInFront(double depthMm) const
{
    if (isTelecentric()) return depthMm > -intrinsics_.workingDistanceMm;
    return depthMm > 0;
}

CameraModel CameraModel::fromProjectionMatrix(const Eigen::Matrix<double, 3, 4>& P, cv::Size imageSize)
{
    cv::Mat Pcv, Kcv, Rcv, Ccv;
    cv::eigen2cv(P, Pcv);
    cv::decomposeProjectionMatrix(Pcv, Kcv, Rcv, Ccv);
    Mat3 K, R;
    Eigen::Vector4d Ch;
    cv::cv2eigen(Kcv, K);
    cv::cv2eigen(Rcv, R);
    cv::cv2eigen(Ccv, Ch);
    if (std::abs(Ch(3)) < 1e-15)
        throw ArgumentError("P: camera centre at infinity (affine camera, w = " + formatNumber(Ch(3)) + ")");
    // RQ leaves the signs of K's diagonal free: make fx, fy > 0 by moving the
    // sign into R (K R is unchanged), then scale K so that K[2][2] = 1.
    for (int i = 0; i < 3; ++i)
        if (K(i, i) < 0) {
            K.col(i) *= -1.0;
            R.row(i) *= -1.0;
        }
    K /= K(2, 2);
    if (R.determinant() < 0)
        throw ArgumentError("P: left-handed camera (det R = " + formatNumber(R.determinant()) + " < 0)");
    Vec3 C = Ch.head<3>() / Ch(3);
    Intrinsics in;
    in.K = K;
    in.K(1, 0) = in.K(2, 0) = in.K(2, 1) = 0.0;
    in.imageSize = imageSize;
    return CameraModel(in, RigidTransform{R, -(R * C)});
}

CameraModel CameraModel::fromDissertation(double fOverDph, double fOverDpv, double mc, double nc, const Vec3& C,
                                          const Vec3& h, const Vec3& v, const Vec3& a, cv::Size imageSize)
{
    Mat3 R;
    R.row(0) = h.normalized().transpose();
    R.row(1) = v.normalized().transpose();
    R.row(2) = a.normalized().transpose();
    if (!isRotation(R, 1e-6)) {
        // The dissertation measured n from the lower-left corner of the
        // display (v up): a left-handed h, v, a. Flip v and count rows from
        // the top so the model stays a proper rotation: row = (H-1) - n.
        R.row(1) *= -1.0;
        nc = (imageSize.height - 1) - nc;
        if (!isRotation(R, 1e-6)) throw ArgumentError("camera axes h, v, a must be orthonormal");
    }
    Intrinsics in;
    in.K << fOverDph, 0, mc, 0, fOverDpv, nc, 0, 0, 1;
    in.imageSize = imageSize;
    return CameraModel(in, RigidTransform{R, -(R * C)});
}

Vec2 CameraModel::distortNormalised(const Vec2& xy) const
{
    // cv::projectPoints' model; missing coefficients are zero.
    const auto& d = intrinsics_.dist;
    auto k = [&](std::size_t i) { return i < d.size() ? d[i] : 0.0; };
    const double x = xy.x(), y = xy.y();
    const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
    const double radial = (1 + k(0) * r2 + k(1) * r4 + k(4) * r6) / (1 + k(5) * r2 + k(6) * r4 + k(7) * r6);
    const double p1 = k(2), p2 = k(3);
    return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + k(8) * r2 + k(9) * r4,
            y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + k(10) * r2 + k(11) * r4};
}

std::optional<Vec2> CameraModel::normalise(const Vec3& pc) const
{
    if (!depthInFront(pc.z())) return std::nullopt;
    // Telecentric: the orthographic image, in mm (docs/telecentric.md).
    if (isTelecentric()) return Vec2(pc.x(), pc.y());
    return Vec2(pc.x() / pc.z(), pc.y() / pc.z());
}

Eigen::Matrix<double, 2, 3> CameraModel::undistortedPointJacobian(const Vec3& pc) const
{
    const Mat3& K = intrinsics_.K;
    Eigen::Matrix<double, 2, 3> J;
    if (isTelecentric()) {
        J << K(0, 0), K(0, 1), 0.0, 0.0, K(1, 1), 0.0;
        return J;
    }
    const double z = pc.z();
    J << K(0, 0) / z, K(0, 1) / z, -(K(0, 0) * pc.x() + K(0, 1) * pc.y()) / (z * z), 0.0, K(1, 1) / z,
        -K(1, 1) * pc.y() / (z * z);
    return J;
}

std::optional<Vec2> CameraModel::distort(const Vec2& xy) const
{
    if (intrinsics_.distortionModel == DistortionModel::OpenCV) return distortNormalised(xy);
    // The division model solved for the distorted point (HALCON's closed
    // form): r_u = r_d / (1 + κ r_d²) gives r_d = 2 r_u / (1 + √(1 − 4κ r_u²)).
    const double disc = 1.0 - 4.0 * intrinsics_.kappa * xy.squaredNorm();
    if (disc < 0.0) return std::nullopt;
    return Vec2(xy * (2.0 / (1.0 + std::sqrt(disc))));
}

std::optional<Vec2> CameraModel::projectCameraPoint(const Vec3& pc) const
{
    auto n = normalise(pc);
    if (!n) return std::nullopt;
    Vec2 xy = *n;
    if (distorted_) {
        const auto d = distort(xy);
        if (!d) return std::nullopt;
        xy = *d;
    }
    const Mat3& K = intrinsics_.K;
    return Vec2(K(0, 0) * xy.x() + K(0, 1) * xy.y() + K(0, 2), K(1, 1) * xy.y() + K(1, 2));
}

// Differentiating pixel = K·distort(normalise(X)) by its parameters: fx, fy,
// cx, cy act on the distorted coordinates, k1, k2, k3 (r², r⁴, r⁶) and the
// tangential p1, p2 on the undistorted ones through cv::projectPoints' model.
std::optional<Eigen::Matrix<double, 2, 9>> CameraModel::intrinsicsJacobian(const Vec3& partPoint) const
{
    const auto n = normalise(cameraFromPart_.apply(partPoint));
    if (!n) return std::nullopt;
    const double x = n->x(), y = n->y();
    const auto distorted = distorted_ ? distort({x, y}) : std::optional<Vec2>(Vec2(x, y));
    if (!distorted) return std::nullopt;
    const Vec2 d = *distorted;
    const double fx = intrinsics_.K(0, 0), fy = intrinsics_.K(1, 1);
    const double r2 = x * x + y * y;
    Eigen::Matrix<double, 2, 9> J = Eigen::Matrix<double, 2, 9>::Zero();
    J(0, 0) = d.x();
    J(1, 1) = d.y();
    J(0, 2) = 1.0;
    J(1, 3) = 1.0;
    if (intrinsics_.distortionModel == DistortionModel::Division) return J;
    const double radial[3] = {r2, r2 * r2, r2 * r2 * r2};
    const int radialColumn[3] = {4, 5, 8};
    for (int i = 0; i < 3; ++i) {
        J(0, radialColumn[i]) = fx * x * radial[i];
        J(1, radialColumn[i]) = fy * y * radial[i];
    }
    J(0, 6) = fx * 2.0 * x * y;
    J(1, 6) = fy * (r2 + 2.0 * y * y);
    J(0, 7) = fx * (r2 + 2.0 * x * x);
    J(1, 7) = fy * 2.0 * x * y;
    return J;
}

std::optional<Vec2> CameraModel::project(const Vec3& partPoint) const
{
    return projectCameraPoint(cameraFromPart_.apply(partPoint));
}

Vec2 CameraModel::undistortPixel(const Vec2& pixel) const
{
    const Mat3& K = intrinsics_.K;
    // Invert K exactly (upper triangular).
    const double yn = (pixel.y() - K(1, 2)) / K(1, 1);
    const double xn = (pixel.x() - K(0, 2) - K(0, 1) * yn) / K(0, 0);
    Vec2 distortedTarget(xn, yn);
    if (!distorted_) return distortedTarget;
    // The division model undistorts in closed form.
    if (intrinsics_.distortionModel == DistortionModel::Division)
        return distortedTarget / (1.0 + intrinsics_.kappa * distortedTarget.squaredNorm());
    // Newton iterations on distort(xy) = target, started at the target; the
    // Jacobian by central differences is plenty at this scale. Matches
    // project() to ~1e-12 rather than cv::undistortPoints' default tolerance.
    Vec2 xy = distortedTarget;
    for (int it = 0; it < 30; ++it) {
        Vec2 r = distortNormalised(xy) - distortedTarget;
        if (r.norm() < 1e-15) break;
        const double h = 1e-7;
        Eigen::Matrix2d J;
        J.col(0) = (distortNormalised(xy + Vec2(h, 0)) - distortNormalised(xy - Vec2(h, 0))) / (2 * h);
        J.col(1) = (distortNormalised(xy + Vec2(0, h)) - distortNormalised(xy - Vec2(0, h))) / (2 * h);
        xy -= J.partialPivLu().solve(r);
    }
    return xy;
}

Ray CameraModel::backProject(const Vec2& pixel) const
{
    Vec2 xy = undistortPixel(pixel);
    const Mat3 Rt = cameraFromPart_.R.transpose();
    if (isTelecentric()) {
        const Vec3 onLensFront(xy.x(), xy.y(), lensFrontZ());
        return {Rt * (onLensFront - cameraFromPart_.t), opticalAxis()};
    }
    Vec3 dirCam(xy.x(), xy.y(), 1.0);
    return {centre_, (Rt * dirCam).normalized()};
}

Vec2 CameraModel::millimetresPerPixelAt(double depthMm) const
{
    if (isTelecentric()) return {1.0 / intrinsics_.K(0, 0), 1.0 / intrinsics_.K(1, 1)};
    return {depthMm / intrinsics_.K(0, 0), depthMm / intrinsics_.K(1, 1)};
}

} // namespace hg::geometry
