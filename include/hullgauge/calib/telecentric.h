// Telecentric camera calibration (docs/telecentric-calibration.md): an
// object-side telecentric lens images along parallel lines of sight, so the
// camera is affine. The model fitted here:
//
//     X_cam = R·X_target + t                      (t_z = 0 by convention)
//     (x_n, y_n) = (X_cam.x, X_cam.y)             millimetres, no division by z
//     (x_d, y_d) = OpenCV's distortion of (x_n, y_n), exactly as
//                  cv::projectPoints applies it to (x/z, y/z); k1 in mm⁻², ...
//     pixel = (fx·x_d + cx, fy·y_d + cy)          fx, fy in px per mm of object
//
// fx = magnification / horizontal pixel pitch, fy = magnification / vertical
// pitch; the returned geometry::Intrinsics holds K = [[fx, 0, cx], [0, fy, cy],
// [0, 0, 1]], dist (k1, k2, p1, p2, k3) and the image size, and stands for a
// camera whose `projection` is Telecentric (geometry/camera.h).
//
// What a planar target cannot show such a camera, fixed by convention:
//  - depth: every pose's t_z = 0 (the target's distance along the axis does
//    not change its image);
//  - the tilt's sign: R and D·R·D (D = diag(1, 1, −1)) give the same image of
//    a plane; the pose reported is the one with R₃₁ > 0 (the target's x axis
//    leans away from the lens), or R₃₂ ≥ 0 when R₃₁ = 0;
//  - the principal point: without distortion it trades one-for-one with every
//    pose's (t_x, t_y); it is the centre of the radial distortion, so it is
//    fixed at the image centre ((w − 1)/2, (h − 1)/2) when distortion is off;
//  - tangential distortion: to first order p1, p2 are a shift of the radial
//    distortion's centre, so freeing them fixes the principal point at the
//    image centre too;
//  - the pixel aspect from views whose target planes are all parallel (a
//    tilt's foreshortening and the aspect are then indistinguishable): such
//    view sets are refused unless the aspect ratio is fixed.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "hullgauge/calib/intrinsics.h"
#include "hullgauge/calib/rail.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/geometry/camera.h"

namespace hg::calib {

struct TelecentricOptions {
    bool fixAspectRatio = false;    ///< fy = fx
    bool distortion = true;         ///< false: dist all zero, principal point at the image centre
    bool tangential = false;        ///< p1, p2 free (principal point then at the image centre)
    bool fixK3 = false;             ///< k3 = 0
    bool fixPrincipalPoint = false; ///< (cx, cy) at the image centre
};

/// Views whose target planes all lie within this angle of each other (the
/// tilt's sign not counted) are refused when the aspect ratio is free.
constexpr double kMinTiltSpreadDeg = 5.0;

/// The affine camera's calibration: the pinhole result's fields (K with fx,
/// fy in px/mm; dist k1, k2, p1, p2, k3 with k1 in mm⁻²; `projection`
/// Telecentric; each target pose with t_z = 0) and what only it has.
struct TelecentricCalibration : IntrinsicsResult {
    /// Largest angle between two views' target planes (tilt sign not counted).
    double tiltSpreadDeg = 0.0;
    /// The parameters fixed by convention, with the reason, for the report.
    std::vector<std::string> conventions;

    double pixelAspect() const { return intrinsics.K(1, 1) / intrinsics.K(0, 0); }
};

/// Calibrates a telecentric camera from views of a planar target. Refuses
/// with hg::InputError naming `field`: fewer than 3 views, a view with fewer
/// than 6 corners, target planes all parallel (free aspect ratio), or views
/// that leave a parameter undetermined.
TelecentricCalibration calibrateTelecentric(const std::vector<TargetView>& views, cv::Size imageSize,
                                            const TelecentricOptions& options = {},
                                            const std::string& field = "--images");

/// The calibration's projection of a camera-frame point (mm) to pixels.
geometry::Vec2 projectTelecentric(const geometry::Intrinsics& intrinsics, const geometry::Vec3& cameraPoint);

/// A human-readable report (the layout of formatIntrinsicsReport).
std::string formatTelecentricReport(const TelecentricCalibration& result);

/// The rail procedure of dissertation 4.3 for a telecentric camera: a target
/// point moved along the rail keeps its size, so instead of f/Δp the rail's
/// image shifts give the rail's direction relative to the optical axis.
/// Model: X_cam(d) = P_j + d·a for track j at rail reading d, a the unit
/// direction in the camera frame in which the target moves as the reading
/// grows (a_z > 0 by convention: the reading grows away from the lens).
struct TelecentricRailAxis {
    geometry::Vec3 direction = geometry::Vec3::UnitZ();   ///< a, camera frame
    double angleToAxisDeg = 0.0;                          ///< between a and the optical axis
    double azimuthDeg = 0.0;                              ///< of (a_x, a_y) in the image, from +x towards +y
    geometry::Vec2 shiftPxPerMm = geometry::Vec2::Zero(); ///< image motion per mm of rail
    /// One standard deviation of a_x, a_y and of the angle (deg).
    double stdDevAx = 0.0, stdDevAy = 0.0, stdDevAngleDeg = 0.0;
    double rmsPx = 0.0;
    int tracks = 0;
    int observations = 0;
};

/// Fits the rail direction to image tracks (each a point seen at several
/// rail readings) through a calibrated telecentric camera. Needs at least one
/// track with two different readings; throws hg::InputError naming `field`.
TelecentricRailAxis calibrateTelecentricRail(const std::vector<std::vector<RailSample>>& tracks,
                                             const geometry::Intrinsics& camera,
                                             const std::string& field = "--observations");

std::string formatTelecentricRailReport(const TelecentricRailAxis& axis);

/// Reads a telecentric rail observations file (docs/telecentric-calibration.md):
/// `tracks`, a list of tracks, each a list of {range_mm, pixel: [x, y]};
/// optional `units: mm` and `note`. Errors name file, line and key.
std::vector<std::vector<RailSample>> loadTelecentricRailTracks(const std::filesystem::path& file);

} // namespace hg::calib
