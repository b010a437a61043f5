#include "hullgauge/calib/fixture_axes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "least_squares.h"

namespace hg::calib {
namespace {

using geometry::Mat3;
using geometry::RigidTransform;
using geometry::Vec3;

constexpr double kSameAngleDeg = 1e-6;

/// Two unit vectors spanning the plane perpendicular to `a`.
std::pair<Vec3, Vec3> perpendicularBasis(const Vec3& a)
{
    Vec3 helper = std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    Vec3 b1 = a.cross(helper).normalized();
    return {b1, a.cross(b1)};
}

/// The point of `line` nearest the origin (a unique representative).
AxisLine normalised(AxisLine l)
{
    l.direction.normalize();
    l.point -= l.direction * l.direction.dot(l.point);
    return l;
}

AxisLine transformLine(const RigidTransform& T, const AxisLine& l)
{
    return normalised({T.apply(l.point), T.applyToDirection(l.direction)});
}

/// The screw axis of a rigid motion that is (ideally) a pure rotation by the
/// commanded `angleDeg` about a fixed line: direction from the angle-axis of
/// R, signed so that the commanded angle is positive about it; point from
/// (I - R) p = t - (a.t) a, with a.p = 0.
AxisLine screwAxis(const RigidTransform& G, double angleDeg)
{
    Eigen::AngleAxisd aa(G.R);
    Vec3 a = aa.axis();
    if (angleDeg < 0) a = -a;
    Eigen::Matrix<double, 4, 3> A;
    A.topRows<3>() = Mat3::Identity() - G.R;
    A.row(3) = a.transpose();
    Eigen::Vector4d b;
    b.head<3>() = G.t - a * a.dot(G.t);
    b[3] = 0.0;
    Vec3 p = A.jacobiSvd(Eigen::ComputeFullU | Eigen::ComputeFullV).solve(b);
    return normalised({p, a});
}

/// Mean of nearly identical lines (weights: sine of the relative rotation,
/// since small rotations fix their axis poorly).
AxisLine averageLines(const std::vector<std::pair<AxisLine, double>>& lines)
{
    Vec3 d = Vec3::Zero(), p = Vec3::Zero();
    double w = 0.0;
    for (const auto& [l, weight] : lines) d += weight * l.direction;
    d.normalize();
    for (const auto& [l, weight] : lines) {
        // Move each line's representative point to the plane through the
        // origin perpendicular to the mean direction.
        Vec3 q = l.point - l.direction * (d.dot(l.point) / d.dot(l.direction));
        p += weight * q;
        w += weight;
    }
    return normalised({p / w, d});
}

RigidTransform poseFromPnP(const TargetView& view, const cv::Mat& K, const cv::Mat& dist)
{
    cv::Mat rvec, tvec;
    if (!cv::solvePnP(view.objectPoints, view.imagePoints, K, dist, rvec, tvec, false, cv::SOLVEPNP_IPPE))
        throw InputError(view.name, "target", "the target pose could not be solved from its corners");
    cv::solvePnPRefineLM(view.objectPoints, view.imagePoints, K, dist, rvec, tvec);
    cv::Mat R;
    cv::Rodrigues(rvec, R);
    RigidTransform T;
    cv::cv2eigen(R, T.R);
    T.t = Vec3(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
    return T;
}

Mat3 rotationFromVector(const Vec3& w)
{
    double angle = w.norm();
    if (angle < 1e-15) return Mat3::Identity();
    return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

/// The parameterisation of the joint refinement: small changes of both lines
/// (2 for the direction, 2 for the point, in the plane perpendicular to the
/// initial direction) and of M (rotation vector, translation).
struct Model {
    AxisLine declination, rotation;
    RigidTransform M;

    RigidTransform cameraFromTarget(const geometry::FixturePose& pose) const
    {
        return rotationAboutLine(declination, pose.declinationDeg) * rotationAboutLine(rotation, pose.rotationDeg) * M;
    }
};

Model applyDelta(const Model& base, const Eigen::VectorXd& x)
{
    auto line = [](const AxisLine& l, const double* d) {
        auto [b1, b2] = perpendicularBasis(l.direction);
        return AxisLine{l.point + d[2] * b1 + d[3] * b2, (l.direction + d[0] * b1 + d[1] * b2).normalized()};
    };
    Model m;
    m.declination = line(base.declination, x.data());
    m.rotation = line(base.rotation, x.data() + 4);
    m.M.R = rotationFromVector(x.segment<3>(8)) * base.M.R;
    m.M.t = base.M.t + x.segment<3>(11);
    return m;
}

} // namespace

RigidTransform rotationAboutLine(const AxisLine& line, double angleDeg)
{
    // Rot(L, α) x = R (x - p) + p.
    RigidTransform T = RigidTransform::rotation(line.direction, angleDeg);
    T.t = line.point - T.R * line.point;
    return T;
}

geometry::FixtureKinematics FixtureAxesResult::kinematics(const geometry::FixtureKinematics& base) const
{
    geometry::FixtureKinematics k = base;
    k.type = geometry::FixtureType::RotationDeclination;
    k.cameraFromFixture = cameraFromFixture;
    k.rotationAxis = rotationAxis;
    k.declinationAxis = declinationAxis;
    return k;
}

RigidTransform FixtureAxesResult::cameraFromTarget(const geometry::FixturePose& pose) const
{
    AxisLine d{declinationAxisPoint, declinationAxis}, r{rotationAxisPoint, rotationAxis};
    return cameraFromFixture * rotationAboutLine(d, pose.declinationDeg) * rotationAboutLine(r, pose.rotationDeg) *
           fixtureFromTarget;
}

namespace {

enum class Turn { Declination, Rotation };

/// Screw axes (camera frame) of the relative motions T_j T_i^-1 between two
/// views that differ in one fixture angle only, weighted by |sin Δ|. Same
/// rotation, different declination: a turn about the declination axis. Same
/// declination, different rotation: a turn about the rotation axis as tilted
/// by that declination, turned back to declination 0 (needs `declination`).
std::vector<std::pair<AxisLine, double>> turnAxes(const std::vector<FixtureView>& views,
                                                  const std::vector<RigidTransform>& poses, Turn turn,
                                                  const AxisLine* declination)
{
    std::vector<std::pair<AxisLine, double>> lines;
    for (std::size_t i = 0; i < views.size(); ++i)
        for (std::size_t j = i + 1; j < views.size(); ++j) {
            const auto &pi = views[i].pose, &pj = views[j].pose;
            const bool aboutDeclination = turn == Turn::Declination;
            const double moved =
                aboutDeclination ? pj.declinationDeg - pi.declinationDeg : pj.rotationDeg - pi.rotationDeg;
            const double held =
                aboutDeclination ? pj.rotationDeg - pi.rotationDeg : pj.declinationDeg - pi.declinationDeg;
            if (std::abs(held) > kSameAngleDeg || std::abs(moved) < 1.0 || std::abs(moved) > 179.0) continue;
            RigidTransform G = poses[j] * poses[i].inverse();
            AxisLine axis = screwAxis(G, moved);
            if (!aboutDeclination) axis = transformLine(rotationAboutLine(*declination, -pi.declinationDeg), axis);
            lines.emplace_back(axis, std::abs(std::sin(geometry::degToRad(moved))));
        }
    return lines;
}

/// The target's mount M from every view, averaged (chordal mean of the rotations).
RigidTransform meanMount(const std::vector<FixtureView>& views, const std::vector<RigidTransform>& poses,
                         const AxisLine& declination, const AxisLine& rotation)
{
    Mat3 sumR = Mat3::Zero();
    Vec3 sumT = Vec3::Zero();
    for (std::size_t i = 0; i < views.size(); ++i) {
        RigidTransform Mi = (rotationAboutLine(declination, views[i].pose.declinationDeg) *
                             rotationAboutLine(rotation, views[i].pose.rotationDeg))
                                .inverse() *
                            poses[i];
        sumR += Mi.R;
        sumT += Mi.t;
    }
    RigidTransform M;
    M.R = geometry::nearestRotation(sumR);
    M.t = sumT / static_cast<double>(views.size());
    return M;
}

/// Joint refinement of both axes and the mount on the reprojection error of every corner.
std::pair<Model, detail::LeastSquaresResult> refineOnCorners(const Model& model, const std::vector<FixtureView>& views,
                                                             const geometry::Intrinsics& camera, std::size_t corners)
{
    auto residuals = [&](const Eigen::VectorXd& x, Eigen::VectorXd& r) {
        Model m = applyDelta(model, x);
        r.resize(static_cast<Eigen::Index>(2 * corners));
        Eigen::Index k = 0;
        for (const auto& v : views) {
            geometry::CameraModel cam(camera, m.cameraFromTarget(v.pose));
            for (std::size_t c = 0; c < v.target.imagePoints.size(); ++c) {
                const auto& o = v.target.objectPoints[c];
                auto px = cam.project(Vec3(o.x, o.y, o.z));
                const auto& seen = v.target.imagePoints[c];
                // A corner pushed behind the camera by a wild step costs a lot.
                r[k++] = px ? (*px).x() - seen.x : 1e6;
                r[k++] = px ? (*px).y() - seen.y : 1e6;
            }
        }
    };
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(14);
    Eigen::VectorXd step(14);
    step << 1e-7, 1e-7, 1e-5, 1e-5, 1e-7, 1e-7, 1e-5, 1e-5, 1e-7, 1e-7, 1e-7, 1e-5, 1e-5, 1e-5;
    auto ls = detail::levenbergMarquardt(residuals, x0, step, 100);
    return {applyDelta(model, ls.x), std::move(ls)};
}

/// The fixture frame: origin at the rotation axis' foot of the common
/// perpendicular of the two axes, z along the rotation axis, x towards the
/// declination axis' direction; the axes and the mount expressed in it.
void fixtureFrame(FixtureAxesResult& out, const Model& model, const std::string& field)
{
    out.rotationAxisInCamera = normalised(model.rotation);
    out.declinationAxisInCamera = normalised(model.declination);
    // Common perpendicular of the two axes (closest points o on L_r, q on L_d).
    const Vec3 ar = model.rotation.direction, ad = model.declination.direction;
    const Vec3 w0 = model.rotation.point - model.declination.point;
    double b = ar.dot(ad), d = ar.dot(w0), e = ad.dot(w0);
    double denom = 1.0 - b * b;
    if (denom < 1e-6)
        throw InputError("", field, "the rotation and declination axes came out parallel: check the commanded angles");
    double s = (b * e - d) / denom, t = (e - b * d) / denom;
    Vec3 o = model.rotation.point + s * ar, q = model.declination.point + t * ad;
    out.axesDistanceMm = (q - o).norm();
    out.axesAngleDeg = geometry::radToDeg(std::acos(std::clamp(b, -1.0, 1.0)));

    Vec3 z = ar;
    Vec3 xAxis = (ad - ad.dot(z) * z).normalized();
    Vec3 y = z.cross(xAxis);
    out.cameraFromFixture.R.col(0) = xAxis;
    out.cameraFromFixture.R.col(1) = y;
    out.cameraFromFixture.R.col(2) = z;
    out.cameraFromFixture.t = o;
    RigidTransform fixtureFromCamera = out.cameraFromFixture.inverse();
    out.rotationAxis = Vec3::UnitZ();
    out.rotationAxisPoint = Vec3::Zero();
    out.declinationAxis = fixtureFromCamera.applyToDirection(ad).normalized();
    out.declinationAxisPoint = fixtureFromCamera.apply(q);
    out.fixtureFromTarget = fixtureFromCamera * model.M;
}

/// Residuals in pixels and, scaled by each corner's depth over the focal
/// length, in millimetres on the target.
void residualStatistics(FixtureAxesResult& out, const Eigen::VectorXd& residuals, const Model& model,
                        const std::vector<FixtureView>& views, const geometry::Intrinsics& camera, std::size_t corners)
{
    double focal = 0.5 * (camera.K(0, 0) + camera.K(1, 1));
    double ssPx = 0.0, ssMm = 0.0;
    Eigen::Index k = 0;
    for (const auto& v : views) {
        RigidTransform T = model.cameraFromTarget(v.pose);
        double ssView = 0.0;
        for (const auto& o3 : v.target.objectPoints) {
            double rx = residuals[k++], ry = residuals[k++];
            double px2 = rx * rx + ry * ry;
            double depth = T.apply(Vec3(o3.x, o3.y, o3.z)).z();
            double mm = std::sqrt(px2) * depth / focal;
            ssPx += px2;
            ssView += px2;
            ssMm += mm * mm;
            out.maxPx = std::max(out.maxPx, std::sqrt(px2));
            out.maxMm = std::max(out.maxMm, mm);
        }
        out.perViewRmsPx.push_back(std::sqrt(ssView / static_cast<double>(v.target.objectPoints.size())));
        out.viewNames.push_back(v.target.name);
    }
    out.views = static_cast<int>(views.size());
    out.corners = static_cast<int>(corners);
    out.rmsPx = std::sqrt(ssPx / static_cast<double>(corners));
    out.rmsMm = std::sqrt(ssMm / static_cast<double>(corners));
}

} // namespace

FixtureAxesResult calibrateFixtureAxes(const std::vector<FixtureView>& views, const geometry::Intrinsics& camera,
                                       const std::string& field)
{
    cv::Mat K, dist;
    cv::eigen2cv(camera.K, K);
    dist = cv::Mat(camera.dist, true);
    if (dist.empty()) dist = cv::Mat::zeros(5, 1, CV_64F);
    std::vector<RigidTransform> poses;
    std::size_t corners = 0;
    for (const auto& v : views) {
        if (v.target.imagePoints.size() < 6)
            throw InputError(v.target.name, field, "a view needs at least 6 target corners");
        poses.push_back(poseFromPnP(v.target, K, dist));
        corners += v.target.imagePoints.size();
    }

    const auto declinationLines = turnAxes(views, poses, Turn::Declination, nullptr);
    if (declinationLines.empty())
        throw InputError("", field,
                         "need two views at the same rotation and different declinations (1 to 179 degrees apart)");
    const AxisLine declination = averageLines(declinationLines);
    const auto rotationLines = turnAxes(views, poses, Turn::Rotation, &declination);
    if (rotationLines.empty())
        throw InputError("", field,
                         "need two views at the same declination and different rotations (1 to 179 degrees apart)");
    const AxisLine rotation = averageLines(rotationLines);

    const Model initial{declination, rotation, meanMount(views, poses, declination, rotation)};
    const auto [model, ls] = refineOnCorners(initial, views, camera, corners);
    FixtureAxesResult out;
    fixtureFrame(out, model, field);
    residualStatistics(out, ls.residuals, model, views, camera, corners);
    hg::log::category("calib")->info(
        "fixture axes from {} views: angle {:.3f} deg, distance {:.3f} mm, RMS {:.3f} px / {:.4f} mm", out.views,
        out.axesAngleDeg, out.axesDistanceMm, out.rmsPx, out.rmsMm);
    return out;
}

std::string formatFixtureReport(const FixtureAxesResult& r)
{
    std::ostringstream s;
    char b[256];
    auto vec = [&](const Vec3& v) {
        std::snprintf(b, sizeof b, "[%.6f, %.6f, %.6f]", v.x(), v.y(), v.z());
        return std::string(b);
    };
    s << "fixture axes (" << r.views << " views, " << r.corners << " corners)\n";
    s << "  camera_from_fixture R rows " << vec(r.cameraFromFixture.R.row(0)) << ' '
      << vec(r.cameraFromFixture.R.row(1)) << ' ' << vec(r.cameraFromFixture.R.row(2)) << '\n';
    s << "  camera_from_fixture t " << vec(r.cameraFromFixture.t) << " mm\n";
    s << "  rotation axis    " << vec(r.rotationAxis) << " through " << vec(r.rotationAxisPoint) << '\n';
    s << "  declination axis " << vec(r.declinationAxis) << " through " << vec(r.declinationAxisPoint) << '\n';
    std::snprintf(b, sizeof b, "  angle between axes %.4f deg, distance between axes %.4f mm\n", r.axesAngleDeg,
                  r.axesDistanceMm);
    s << b;
    std::snprintf(b, sizeof b, "  residuals: RMS %.4f px (max %.4f), RMS %.4f mm (max %.4f)\n", r.rmsPx, r.maxPx,
                  r.rmsMm, r.maxMm);
    s << b;
    for (std::size_t i = 0; i < r.viewNames.size(); ++i) {
        std::snprintf(b, sizeof b, "    %-40s %8.4f px\n", r.viewNames[i].c_str(), r.perViewRmsPx[i]);
        s << b;
    }
    return s.str();
}

} // namespace hg::calib
