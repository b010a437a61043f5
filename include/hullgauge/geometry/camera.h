// Pinhole camera with OpenCV lens distortion, posed relative to the part.
//
// Frames (docs/contracts.md): the part frame is the CAD frame; the camera frame is
// OpenCV's (x right, y down, z forward). `cameraFromPart` maps part to camera:
// X_cam = R * X_part + t. Pixels: x = column, y = row, and the centre of pixel
// (c, r) is at (c, r) — so pixel (c, r) covers [c-0.5, c+0.5] x [r-0.5, r+0.5]
// (OpenCV's convention). The renderer and the voxel test share it.
//
// Distortion follows cv::projectPoints exactly: coefficients
// (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4]]]) — 4, 5, 8 or 12 of
// them. The 14-coefficient tilted-sensor model is rejected at load time.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core/types.hpp>

#include "hullgauge/geometry/transform.h"

namespace hg::geometry {

struct Intrinsics {
    /// Upper-triangular camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] in pixels.
    Mat3 K = Mat3::Identity();
    /// OpenCV distortion coefficients; empty or all zero for none.
    std::vector<double> dist;
    /// Image width and height in pixels.
    cv::Size imageSize;

    bool hasDistortion() const;
    /// Throws ArgumentError with the reason when K or dist cannot be used.
    void validate() const;
};

/// A ray in the part frame: origin + s * direction, s >= 0, direction unit length.
struct Ray {
    Vec3 origin;
    Vec3 direction;
};

class CameraModel {
  public:
    CameraModel() = default;
    CameraModel(Intrinsics intrinsics, RigidTransform cameraFromPart);

    /// A camera from a 3x4 projection matrix P (part frame to pixels), decomposed into K, R, t.
    static CameraModel fromProjectionMatrix(const Eigen::Matrix<double, 3, 4>& P, cv::Size imageSize);

    /// Dissertation eq. 4.2.1-1/2: focal length over pixel size f/Δp_h, f/Δp_v,
    /// optical centre (m_c, n_c) in pixels, camera centre C and camera axes
    /// h (image horizontal), v (image vertical) and a (optical axis), all in the
    /// part frame. The equations are this model with fx = f/Δp_h, fy = f/Δp_v,
    /// (cx, cy) = (m_c, n_c), no distortion, and R's rows h, v, a.
    static CameraModel fromDissertation(double fOverDph, double fOverDpv, double mc, double nc, const Vec3& C,
                                        const Vec3& h, const Vec3& v, const Vec3& a, cv::Size imageSize);

    const Intrinsics& intrinsics() const { return intrinsics_; }
    const RigidTransform& cameraFromPart() const { return cameraFromPart_; }
    cv::Size imageSize() const { return intrinsics_.imageSize; }

    /// Camera centre in the part frame (−Rᵀt).
    Vec3 centre() const { return centre_; }
    /// Optical axis (the camera's +z) in the part frame.
    Vec3 opticalAxis() const { return cameraFromPart_.R.row(2).transpose(); }

    /// Projects a part-frame point to pixel coordinates, distortion included.
    /// Points at or behind the camera plane (z <= 0) give std::nullopt.
    std::optional<Vec2> project(const Vec3& partPoint) const;
    /// As project(), for a point already in the camera frame.
    std::optional<Vec2> projectCameraPoint(const Vec3& cameraPoint) const;

    /// How the pixel of a part-frame point moves with each intrinsic
    /// parameter, in the order fx, fy, cx, cy, k1, k2, p1, p2, k3 (OpenCV's,
    /// and the calibration's standard deviations'); nullopt behind the camera.
    std::optional<Eigen::Matrix<double, 2, 9>> intrinsicsJacobian(const Vec3& partPoint) const;

    /// Normalised, undistorted image coordinates (x/z, y/z) of a pixel.
    Vec2 undistortPixel(const Vec2& pixel) const;
    /// The line of sight through a pixel, in the part frame.
    Ray backProject(const Vec2& pixel) const;

    /// Pixel footprint at depth z along the optical axis in mm per pixel
    /// (horizontal, vertical) — the quantity of eq. 4.4.4 (view range magnification).
    Vec2 millimetresPerPixelAt(double depthMm) const;

  private:
    Vec2 distortNormalised(const Vec2& xy) const;

    Intrinsics intrinsics_;
    RigidTransform cameraFromPart_;
    Vec3 centre_ = Vec3::Zero();
    bool distorted_ = false;
};

} // namespace hg::geometry
