// The telecentric calibration's rig for the tests: a lens, a chessboard and
// twelve tilts rendered by the independent renderer (hgtest/exact_render.h).
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <string>
#include <vector>

#include "hgtest/exact_render.h"

namespace telecentrictest {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDeg = kPi / 180.0;

/// A lens of 0.55x on 5.5 µm pixels (100 px/mm), a slightly non-square pixel,
/// the principal point 12 px and 13 px off the image centre and barrel
/// distortion of 1.5 % at the farthest image corner (8.4 mm off the axis): the
/// principal point is seen only through the distortion
/// (docs/telecentric-calibration.md), and this much puts it within 0.3 px.
inline hgtest::TelecentricLens trueLens()
{
    hgtest::TelecentricLens lens;
    lens.imageSize = cv::Size(1280, 1024);
    lens.fx = 100.0;
    lens.fy = 100.15;
    lens.cx = 651.5;
    lens.cy = 498.5;
    lens.dist = {-2.5e-4, 4.0e-7, 0.0, 0.0, 0.0};
    return lens;
}

inline const hgtest::PlanarChessboard kBoard{15, 12, 0.45}; // 16 x 13 squares of 0.45 mm
inline const std::string kPattern = "chessboard:15x12:0.45";

/// The board's pose: tilted by `tiltDeg` about the in-plane axis at
/// `azimuthDeg`, turned by `spinDeg` in its plane, its centre at (ox, oy) mm
/// from the optical axis (depth 0: a telecentric image does not depend on it).
struct BoardPose {
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
};

inline BoardPose boardPose(double tiltDeg, double azimuthDeg, double spinDeg, double ox, double oy)
{
    const Eigen::Vector3d axis(std::cos(azimuthDeg * kDeg), std::sin(azimuthDeg * kDeg), 0.0);
    BoardPose p;
    p.R = (Eigen::AngleAxisd(tiltDeg * kDeg, axis) * Eigen::AngleAxisd(spinDeg * kDeg, Eigen::Vector3d::UnitZ()))
              .toRotationMatrix();
    const Eigen::Vector3d centre(0.5 * (kBoard.innerCols - 1) * kBoard.squareMm,
                                 0.5 * (kBoard.innerRows - 1) * kBoard.squareMm, 0.0);
    p.t = Eigen::Vector3d(ox, oy, 0.0) - p.R * centre;
    return p;
}

/// Twelve tilts of 25–45° about axes every 30° around the optical axis, the
/// board moved about the field (as an operator covers the image with it).
inline std::vector<BoardPose> twelveTilts()
{
    std::vector<BoardPose> poses;
    for (int k = 0; k < 12; ++k) {
        const double around = (45.0 + 75.0 * k) * kDeg, reach = k % 4 == 0 ? 0.3 : 1.0;
        poses.push_back(boardPose(25.0 + 10.0 * (k % 3), 30.0 * k, -10.0 + 2.0 * k, reach * 2.4 * std::cos(around),
                                  reach * 1.9 * std::sin(around)));
    }
    return poses;
}

inline cv::Mat renderView(const hgtest::TelecentricLens& lens, const BoardPose& pose, std::uint64_t seed)
{
    const cv::Mat coverage = hgtest::telecentricChessboardCoverage(kBoard, pose.R, pose.t, lens);
    hgtest::ExactShading shading;
    shading.noiseSigma = 1.0;
    shading.blurSigmaPx = 0.7; // the lens's blur
    shading.seed = seed;
    return hgtest::shadeExact(coverage, shading);
}

} // namespace telecentrictest
