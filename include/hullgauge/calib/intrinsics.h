// Target-based camera intrinsics (Zhang's method through OpenCV's extended
// calibrateCamera overload, Python's calibrateCameraExtended): K, distortion, the RMS reprojection error, the
// error of every view and the standard deviation of every estimated parameter.
// This is the modern replacement of the dissertation's 4.3 rail procedure for
// K; the result feeds the camera model of eq. 4.2.1-1/2 generalised
// (docs/contracts.md: fx = f/Δp_h, fy = f/Δp_v, (cx, cy) = (m_c, n_c)).
#pragma once

#include <string>
#include <vector>

#include "hullgauge/calib/target.h"
#include "hullgauge/geometry/camera.h"

namespace hg::calib {

struct IntrinsicsOptions {
    bool fixAspectRatio = false;    ///< fx / fy fixed (to 1): OpenCV CALIB_FIX_ASPECT_RATIO
    bool zeroTangentDist = false;   ///< p1 = p2 = 0
    bool fixK3 = false;             ///< k3 = 0 (narrow-angle lenses, few views)
    bool fixPrincipalPoint = false; ///< (cx, cy) at the image centre
};

/// Names of the parameters whose standard deviations are reported, in order.
inline const std::vector<std::string>& intrinsicParameterNames()
{
    static const std::vector<std::string> names{"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
    return names;
}

struct IntrinsicsResult {
    geometry::Intrinsics intrinsics; ///< K, dist (k1, k2, p1, p2, k3) and image size
    double rmsPx = 0.0;              ///< RMS reprojection error over all corners
    std::vector<std::string> viewNames;
    std::vector<double> perViewRmsPx;
    /// One standard deviation of fx, fy, cx, cy, k1, k2, p1, p2, k3 (0 for fixed ones).
    std::vector<double> stdDev;
    /// The target's pose in every view (camera_from_target).
    std::vector<geometry::RigidTransform> cameraFromTarget;
    int cornersUsed = 0;
};

/// The report's first lines: `what` with the views, corners and image size,
/// then the RMS reprojection error.
std::string formatReportHead(const IntrinsicsResult& result, const std::string& what);
/// The report's parameter table (value and one standard deviation of each
/// of intrinsicParameterNames()) after a header naming `units`.
std::string formatParameterTable(const IntrinsicsResult& result, const std::string& units);
/// The report's per-view RMS list.
std::string formatPerViewRms(const IntrinsicsResult& result);

/// Calibrates from views of a planar target. At least 3 views are needed;
/// fewer throw hg::InputError naming `field`.
IntrinsicsResult calibrateIntrinsics(const std::vector<TargetView>& views, cv::Size imageSize,
                                     const IntrinsicsOptions& options = {}, const std::string& field = "--images");

/// A human-readable report (for stderr/stdout of the tool).
std::string formatIntrinsicsReport(const IntrinsicsResult& result);

} // namespace hg::calib
