#include "hullgauge/calib/intrinsics.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg::calib {

IntrinsicsResult calibrateIntrinsics(const std::vector<TargetView>& views, cv::Size imageSize,
                                     const IntrinsicsOptions& options, const std::string& field)
{
    if (views.size() < 3)
        throw InputError("", field,
                         "the target was found in " + std::to_string(views.size()) +
                             " image(s); at least 3 views at different tilts are needed");
    std::vector<std::vector<cv::Point3f>> objectPoints;
    std::vector<std::vector<cv::Point2f>> imagePoints;
    IntrinsicsResult result;
    for (const auto& v : views) {
        if (v.imagePoints.size() < 6 || v.imagePoints.size() != v.objectPoints.size())
            throw InputError(v.name, field, "a view needs at least 6 corners with matching target points");
        objectPoints.push_back(v.objectPoints);
        imagePoints.push_back(v.imagePoints);
        result.viewNames.push_back(v.name);
        result.cornersUsed += static_cast<int>(v.imagePoints.size());
    }

    int flags = 0;
    cv::Mat K = cv::Mat::eye(3, 3, CV_64F);
    if (options.fixAspectRatio) flags |= cv::CALIB_FIX_ASPECT_RATIO; // with K's fx/fy = 1
    if (options.zeroTangentDist) flags |= cv::CALIB_ZERO_TANGENT_DIST;
    if (options.fixK3) flags |= cv::CALIB_FIX_K3;
    if (options.fixPrincipalPoint) flags |= cv::CALIB_FIX_PRINCIPAL_POINT;
    cv::Mat dist = cv::Mat::zeros(5, 1, CV_64F);
    std::vector<cv::Mat> rvecs, tvecs;
    cv::Mat stdIntr, stdExtr, perView;
    result.rmsPx =
        cv::calibrateCamera(objectPoints, imagePoints, imageSize, K, dist, rvecs, tvecs, stdIntr, stdExtr, perView,
                            flags, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, DBL_EPSILON));

    cv::cv2eigen(K, result.intrinsics.K);
    result.intrinsics.dist.assign(dist.begin<double>(), dist.end<double>());
    result.intrinsics.imageSize = imageSize;
    for (int i = 0; i < perView.rows; ++i) result.perViewRmsPx.push_back(perView.at<double>(i));
    for (int i = 0; i < 9 && i < stdIntr.rows; ++i) result.stdDev.push_back(stdIntr.at<double>(i));
    for (std::size_t i = 0; i < rvecs.size(); ++i) {
        cv::Mat R;
        cv::Rodrigues(rvecs[i], R);
        geometry::RigidTransform T;
        cv::cv2eigen(R, T.R);
        cv::Vec3d t = tvecs[i];
        T.t = geometry::Vec3(t[0], t[1], t[2]);
        result.cameraFromTarget.push_back(T);
    }
    hg::log::category("calib")->info("intrinsics from {} views, {} corners: RMS {:.3f} px", views.size(),
                                     result.cornersUsed, result.rmsPx);
    return result;
}

std::string formatParameterTable(const IntrinsicsResult& r, const std::string& units)
{
    std::ostringstream s;
    char line[256];
    const auto& K = r.intrinsics.K;
    const auto& names = intrinsicParameterNames();
    std::vector<double> values{K(0, 0), K(1, 1), K(0, 2), K(1, 2)};
    for (double d : r.intrinsics.dist) values.push_back(d);
    s << "  parameter        value         std dev" << (units.empty() ? "" : "   (" + units + ")") << "\n";
    for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) {
        std::snprintf(line, sizeof line, "  %-6s %16.6g %14.4g\n", names[i].c_str(), values[i],
                      i < r.stdDev.size() ? r.stdDev[i] : 0.0);
        s << line;
    }
    return s.str();
}

std::string formatPerViewRms(const IntrinsicsResult& r)
{
    std::ostringstream s;
    char line[256];
    s << "  per-view RMS (px):\n";
    for (std::size_t i = 0; i < r.viewNames.size(); ++i) {
        std::snprintf(line, sizeof line, "    %-40s %8.4f\n", r.viewNames[i].c_str(),
                      i < r.perViewRmsPx.size() ? r.perViewRmsPx[i] : 0.0);
        s << line;
    }
    return s.str();
}

std::string formatReportHead(const IntrinsicsResult& r, const std::string& what)
{
    std::ostringstream s;
    char line[256];
    s << what << " (" << r.viewNames.size() << " views, " << r.cornersUsed << " corners, image "
      << r.intrinsics.imageSize.width << "x" << r.intrinsics.imageSize.height << ")\n";
    std::snprintf(line, sizeof line, "  RMS reprojection error  %.4f px\n", r.rmsPx);
    s << line;
    return s.str();
}

std::string formatIntrinsicsReport(const IntrinsicsResult& r)
{
    return formatReportHead(r, "camera intrinsics") + formatParameterTable(r, "") + formatPerViewRms(r);
}

} // namespace hg::calib
