// Rigid transforms between frames.
//
// Convention (docs/contracts.md): a transform named `a_from_b` maps coordinates of a
// point in frame b to frame a: X_a = R * X_b + t. Composition reads right to
// left: a_from_c = a_from_b * b_from_c. Units: millimetres, angles in degrees
// at the interfaces, radians inside Eigen.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hg::geometry {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

struct RigidTransform {
    Mat3 R = Mat3::Identity();
    Vec3 t = Vec3::Zero();

    Vec3 apply(const Vec3& x) const { return R * x + t; }
    Vec3 applyToDirection(const Vec3& d) const { return R * d; }
    RigidTransform inverse() const { return {R.transpose(), -(R.transpose() * t)}; }
    RigidTransform operator*(const RigidTransform& rhs) const { return {R * rhs.R, R * rhs.t + t}; }
    Eigen::Matrix<double, 3, 4> matrix() const;

    static RigidTransform identity() { return {}; }
    /// Right-handed rotation by `angleDeg` about `axis` (need not be unit) through the origin.
    static RigidTransform rotation(const Vec3& axis, double angleDeg);
    static RigidTransform translation(const Vec3& v) { return {Mat3::Identity(), v}; }
};

/// True when `R` is a proper rotation (orthonormal, det +1) within `tol`.
bool isRotation(const Mat3& R, double tol = 1e-6);

/// The nearest proper rotation to `M` (polar decomposition by SVD).
Mat3 nearestRotation(const Mat3& M);

/// Angle of the rotation R_a^T R_b in degrees.
double rotationAngleDeg(const Mat3& Ra, const Mat3& Rb);

inline double degToRad(double d)
{
    return d * (3.14159265358979323846 / 180.0);
}
inline double radToDeg(double r)
{
    return r * (180.0 / 3.14159265358979323846);
}

} // namespace hg::geometry
