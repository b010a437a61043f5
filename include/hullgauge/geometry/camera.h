// Pinhole or telecentric camera with OpenCV lens distortion, posed relative to
// the part (docs/telecentric.md for the telecentric projection).
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

#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core/types.hpp>

#include "hullgauge/geometry/transform.h"

namespace hg::geometry {

/// How camera-frame points reach the normalised image plane (docs/telecentric.md):
/// Pinhole (x/z, y/z), unitless; Telecentric (x, y) in millimetres, no division
/// by depth (an object-side telecentric lens: parallel lines of sight).
enum class Projection { Pinhole, Telecentric };

/// The lens distortion: OpenCV's polynomial model (`dist`), or HALCON's
/// division model, undistorted = distorted / (1 + κ·r_d²) with r_d the
/// distorted normalised radius (docs/telecentric.md, "The division model").
enum class DistortionModel { OpenCV, Division };

struct Intrinsics {
    /// Pinhole: fx, fy in pixels; telecentric: fx, fy in pixels per millimetre
    /// of object (magnification over pixel pitch), and the distortion terms
    /// act on millimetres (k1 in mm⁻², ...).
    Projection projection = Projection::Pinhole;
    /// Telecentric only: the distance (mm) from the lens's front to the camera
    /// frame's z = 0 (the plane of best focus, docs/telecentric.md). Points
    /// nearer the lens than its front (z <= −workingDistanceMm) are not imaged;
    /// infinite when not stated (nothing is refused for depth).
    double workingDistanceMm = std::numeric_limits<double>::infinity();
    /// Upper-triangular camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] in pixels.
    Mat3 K = Mat3::Identity();
    /// OpenCV distortion coefficients; empty or all zero for none (and for the division model).
    std::vector<double> dist;
    DistortionModel distortionModel = DistortionModel::OpenCV;
    /// The division model's κ (per squared normalised unit: mm⁻² for a
    /// telecentric camera); 0 for none.
    double kappa = 0.0;
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

    /// A telecentric lens (parallel lines of sight) rather than a pinhole.
    static CameraModel telecentric(Intrinsics intrinsics, RigidTransform cameraFromPart);
    /// The telecentric counterpart of fromDissertation(): magnification over
    /// pixel pitch mOverDph, mOverDpv (px per mm of object), principal point
    /// (m_c, n_c), a point P0 of the optical axis in the plane of best focus and
    /// the axes h, v, a, all in the part frame.
    static CameraModel telecentricFromAxes(double mOverDph, double mOverDpv, double mc, double nc, const Vec3& P0,
                                           const Vec3& h, const Vec3& v, const Vec3& a, cv::Size imageSize);

    bool isTelecentric() const { return intrinsics_.projection == Projection::Telecentric; }

    /// The centre of projection in the part frame (−Rᵀt); nullopt for a
    /// telecentric camera, which has none (its lines of sight are parallel):
    /// a step that needs where a point is seen from uses lineOfSight().
    std::optional<Vec3> centre() const;
    /// Optical axis (the camera's +z) in the part frame.
    Vec3 opticalAxis() const { return cameraFromPart_.R.row(2).transpose(); }
    /// The unit direction of the line of sight that images `partPoint`, from
    /// the camera towards the point: from the centre for a pinhole, the
    /// optical axis for every point of a telecentric camera.
    Vec3 lineOfSight(const Vec3& partPoint) const;
    /// Where the line of sight through `partPoint` enters the scene: the
    /// pinhole's centre, or the telecentric lens's front (its working-distance
    /// plane, 10 m before the focus plane when not stated) on the point's
    /// parallel line. Everything imaged lies beyond it along lineOfSight().
    Vec3 sightOrigin(const Vec3& partPoint) const;
    /// Distance (mm) along the line of sight from sightOrigin() to the point.
    double rangeTo(const Vec3& partPoint) const;
    /// Depth along the optical axis: the camera-frame z of a part-frame point.
    double depthOf(const Vec3& partPoint) const { return cameraFromPart_.apply(partPoint).z(); }
    /// True when a camera-frame depth is imaged at all: in front of the
    /// pinhole (z > 0), or beyond the telecentric lens's front.
    bool depthInFront(double depthMm) const;

    /// Projects a part-frame point to pixel coordinates, distortion included.
    /// Points not in front of the camera (depthInFront) give std::nullopt.
    std::optional<Vec2> project(const Vec3& partPoint) const;
    /// As project(), for a point already in the camera frame.
    std::optional<Vec2> projectCameraPoint(const Vec3& cameraPoint) const;
    /// Normalised, undistorted image coordinates of a camera-frame point:
    /// (x/z, y/z) for a pinhole, (x, y) mm for a telecentric camera; nullopt
    /// when not in front.
    std::optional<Vec2> normalise(const Vec3& cameraPoint) const;
    /// How the undistorted pixel moves with the camera-frame point (px per mm):
    /// the derivative of K·normalise(X) at X.
    Eigen::Matrix<double, 2, 3> undistortedPointJacobian(const Vec3& cameraPoint) const;

    /// How the pixel of a part-frame point moves with each intrinsic
    /// parameter, in the order fx, fy, cx, cy, k1, k2, p1, p2, k3 (OpenCV's,
    /// and the calibration's standard deviations'); nullopt behind the camera.
    /// Under the division model the OpenCV terms' columns are zero.
    std::optional<Eigen::Matrix<double, 2, 9>> intrinsicsJacobian(const Vec3& partPoint) const;

    /// Normalised, undistorted image coordinates of a pixel: (x/z, y/z) for a
    /// pinhole, (x, y) in mm for a telecentric camera.
    Vec2 undistortPixel(const Vec2& pixel) const;
    /// The line of sight through a pixel, in the part frame: from the centre
    /// for a pinhole; for a telecentric camera parallel to the optical axis
    /// through the unprojected point, starting at the lens's front (sightOrigin).
    Ray backProject(const Vec2& pixel) const;

    /// Pixel footprint at depth z along the optical axis in mm per pixel
    /// (horizontal, vertical) — the quantity of eq. 4.4.4 (view range
    /// magnification). A telecentric camera's is the same at every depth.
    Vec2 millimetresPerPixelAt(double depthMm) const;

  private:
    Vec2 distortNormalised(const Vec2& xy) const;
    /// The lens's distortion of normalised coordinates under either model;
    /// nullopt where the division model has none (1 − 4κr² < 0).
    std::optional<Vec2> distort(const Vec2& xy) const;
    /// The camera-frame z of a telecentric camera's lens front.
    double lensFrontZ() const;

    Intrinsics intrinsics_;
    RigidTransform cameraFromPart_;
    Vec3 centre_ = Vec3::Zero();
    bool distorted_ = false;
};

} // namespace hg::geometry
