// Telecentric calibration (include/hullgauge/calib/telecentric.h,
// docs/telecentric-calibration.md): a closed-form affine start per view, then
// one Levenberg–Marquardt fit of the intrinsics and every pose on the
// reprojection error of every corner.
#include "hullgauge/calib/telecentric.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "hullgauge/calib/intrinsics.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "least_squares.h"

namespace hg::calib {
namespace {

using geometry::Mat3;
using geometry::Vec2;
using geometry::Vec3;

constexpr double kPi = 3.14159265358979323846;
constexpr int kIntrinsicCount = 9; // fx fy cx cy k1 k2 p1 p2 k3 (intrinsicParameterNames())
constexpr int kPoseCount = 5;      // Rodrigues vector, t_x, t_y (t_z = 0 by convention)
enum Intrinsic { Fx, Fy, Cx, Cy, K1, K2, P1, P2, K3 };

using Coefficients = std::array<double, kIntrinsicCount>;

/// cv::projectPoints' distortion with (k1, k2, p1, p2, k3), applied to
/// millimetres instead of x/z, y/z; then K.
Vec2 projectNormalised(const Coefficients& c, double x, double y)
{
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (c[K1] + r2 * (c[K2] + r2 * c[K3]));
    const double xd = x * radial + 2.0 * c[P1] * x * y + c[P2] * (r2 + 2.0 * x * x);
    const double yd = y * radial + c[P1] * (r2 + 2.0 * y * y) + 2.0 * c[P2] * x * y;
    return {c[Fx] * xd + c[Cx], c[Fy] * yd + c[Cy]};
}

Mat3 rotationFromVector(const Vec3& r)
{
    const double angle = r.norm();
    if (angle < 1e-300) return Mat3::Identity();
    return Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
}

Vec3 vectorFromRotation(const Mat3& R)
{
    Eigen::AngleAxisd aa(R);
    return aa.angle() * aa.axis();
}

/// The mirror pose that images a plane identically: D·R·D, D = diag(1, 1, −1).
Mat3 mirrored(const Mat3& R)
{
    const Eigen::Vector3d d(1.0, 1.0, -1.0);
    return d.asDiagonal() * R * d.asDiagonal();
}

/// The header's sign convention: R₃₁ > 0, or R₃₂ ≥ 0 when R₃₁ = 0.
Mat3 canonicalTilt(const Mat3& R)
{
    const bool flip = std::abs(R(2, 0)) > 1e-12 ? R(2, 0) < 0.0 : R(2, 1) < 0.0;
    return flip ? mirrored(R) : R;
}

/// pixel ≈ A·(X, Y) + b, least squares over the view's corners.
struct AffineView {
    Eigen::Matrix2d A;
    Eigen::Vector2d b;
};

AffineView fitAffine(const TargetView& v)
{
    const auto n = static_cast<Eigen::Index>(v.imagePoints.size());
    Eigen::MatrixXd M(n, 3);
    Eigen::MatrixXd uv(n, 2);
    for (Eigen::Index i = 0; i < n; ++i) {
        const auto& o = v.objectPoints[static_cast<std::size_t>(i)];
        const auto& p = v.imagePoints[static_cast<std::size_t>(i)];
        M.row(i) << o.x, o.y, 1.0;
        uv.row(i) << p.x, p.y;
    }
    const Eigen::MatrixXd sol = M.colPivHouseholderQr().solve(uv); // 3x2
    AffineView a;
    a.A = sol.topRows(2).transpose();
    a.b = sol.row(2).transpose();
    return a;
}

/// A rotation whose upper-left 2x2 block is B (B's larger singular value
/// taken as 1, the smaller clamped to at most 1): B = U·diag(1, c)·Vᵀ is the
/// block of diag(U, 1)·Rx(acos c)·diag(V, 1)ᵀ.
Mat3 rotationFromBlock(const Eigen::Matrix2d& B)
{
    Eigen::JacobiSVD<Eigen::Matrix2d> svd(B, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix2d U = svd.matrixU(), V = svd.matrixV();
    double c = std::min(svd.singularValues()[1] / std::max(svd.singularValues()[0], 1e-300), 1.0);
    if (U.determinant() * V.determinant() < 0) { // det B < 0: the second singular value is negative
        U.col(1) = -U.col(1);
        c = -c;
    }
    Mat3 Ux = Mat3::Identity(), Vx = Mat3::Identity(), Rx = Mat3::Identity();
    Ux.topLeftCorner<2, 2>() = U;
    Vx.topLeftCorner<2, 2>() = V;
    const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
    Rx << 1, 0, 0, 0, c, -s, 0, s, c;
    if (U.determinant() < 0) { // both reflections: their product is a rotation
        Ux(2, 2) = -1.0;
        Vx(2, 2) = -1.0;
    }
    return Ux * Rx * Vx.transpose();
}

/// Angle between two target planes, the tilt's sign (the mirror pose) not counted.
double planeAngleDeg(const Mat3& a, const Mat3& b)
{
    const Vec3 na = a.col(2), nb = b.col(2), nbm = mirrored(b).col(2);
    const double cosine = std::min(1.0, std::max(std::abs(na.dot(nb)), std::abs(na.dot(nbm))));
    return std::acos(cosine) * 180.0 / kPi;
}

double tiltSpreadDeg(const std::vector<Mat3>& rotations)
{
    double spread = 0.0;
    for (std::size_t i = 0; i < rotations.size(); ++i)
        for (std::size_t j = i + 1; j < rotations.size(); ++j)
            spread = std::max(spread, planeAngleDeg(rotations[i], rotations[j]));
    return spread;
}

/// The least-squares problem: the free intrinsics, then 5 numbers per view,
/// each divided by a scale that makes a unit change move the image by about
/// a pixel (so the damping and the finite differences treat them alike).
class TelecentricProblem {
  public:
    TelecentricProblem(const std::vector<TargetView>& views, Coefficients start, std::vector<int> freeIntrinsics,
                       double fieldRadiusMm)
        : views_(views), fixed_(start), free_(std::move(freeIntrinsics))
    {
        const double f = std::max(start[Fx], start[Fy]), r = fieldRadiusMm;
        const Coefficients intrinsicScale{1.0 / r,
                                          1.0 / r,
                                          1.0,
                                          1.0,
                                          1.0 / (f * std::pow(r, 3)),
                                          1.0 / (f * std::pow(r, 5)),
                                          1.0 / (f * r * r),
                                          1.0 / (f * r * r),
                                          1.0 / (f * std::pow(r, 7))};
        for (int i : free_) scale_.push_back(intrinsicScale[static_cast<std::size_t>(i)]);
        for (std::size_t v = 0; v < views.size(); ++v)
            for (double s : {1.0 / (f * r), 1.0 / (f * r), 1.0 / (f * r), 1.0 / f, 1.0 / f}) scale_.push_back(s);
    }

    Eigen::Index size() const { return static_cast<Eigen::Index>(scale_.size()); }
    double scale(Eigen::Index i) const { return scale_[static_cast<std::size_t>(i)]; }

    Eigen::VectorXd pack(const std::vector<Mat3>& R, const std::vector<Vec2>& t) const
    {
        Eigen::VectorXd x(size());
        Eigen::Index k = 0;
        for (int i : free_) x[k++] = fixed_[static_cast<std::size_t>(i)];
        for (std::size_t v = 0; v < R.size(); ++v) {
            const Vec3 r = vectorFromRotation(R[v]);
            for (double value : {r.x(), r.y(), r.z(), t[v].x(), t[v].y()}) x[k++] = value;
        }
        for (Eigen::Index i = 0; i < x.size(); ++i) x[i] /= scale(i);
        return x;
    }

    Coefficients intrinsics(const Eigen::VectorXd& x) const
    {
        Coefficients c = fixed_;
        for (std::size_t k = 0; k < free_.size(); ++k)
            c[static_cast<std::size_t>(free_[k])] = x[static_cast<Eigen::Index>(k)] * scale_[k];
        return c;
    }

    geometry::RigidTransform pose(const Eigen::VectorXd& x, std::size_t view) const
    {
        const auto k = static_cast<Eigen::Index>(free_.size() + kPoseCount * view);
        auto at = [&](Eigen::Index i) { return x[k + i] * scale(k + i); };
        geometry::RigidTransform T;
        T.R = rotationFromVector(Vec3(at(0), at(1), at(2)));
        T.t = Vec3(at(3), at(4), 0.0);
        return T;
    }

    /// Pixel residuals (projected − observed), x then y, corner by corner.
    void residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const
    {
        const Coefficients c = intrinsics(x);
        std::size_t count = 0;
        for (const auto& v : views_) count += v.imagePoints.size();
        r.resize(static_cast<Eigen::Index>(2 * count));
        Eigen::Index k = 0;
        for (std::size_t v = 0; v < views_.size(); ++v) {
            const auto T = pose(x, v);
            for (std::size_t i = 0; i < views_[v].imagePoints.size(); ++i) {
                const auto& o = views_[v].objectPoints[i];
                const Vec3 p = T.R * Vec3(o.x, o.y, o.z) + T.t;
                const Vec2 px = projectNormalised(c, p.x(), p.y());
                r[k++] = px.x() - views_[v].imagePoints[i].x;
                r[k++] = px.y() - views_[v].imagePoints[i].y;
            }
        }
    }

    const std::vector<int>& freeIntrinsics() const { return free_; }

  private:
    const std::vector<TargetView>& views_;
    Coefficients fixed_;
    std::vector<int> free_;
    std::vector<double> scale_;
};

void checkViews(const std::vector<TargetView>& views, const std::string& field)
{
    if (views.size() < 3)
        throw InputError("", field,
                         "the target was found in " + std::to_string(views.size()) +
                             " image(s); a telecentric calibration needs at least 3 views at different tilts");
    for (const auto& v : views)
        if (v.imagePoints.size() < 6 || v.imagePoints.size() != v.objectPoints.size())
            throw InputError(v.name, field, "a view needs at least 6 corners with matching target points");
}

/// Which of fx..k3 are estimated, and the conventions that fix the others.
std::vector<int> freeIntrinsics(const TelecentricOptions& o, std::vector<std::string>& conventions)
{
    conventions.emplace_back("every pose's t_z = 0: depth along the optical axis is not observable");
    conventions.emplace_back("each pose is the one of the mirror pair with R31 > 0 (the target's x axis leans away)");
    std::vector<int> free{Fx};
    if (o.fixAspectRatio)
        conventions.emplace_back("fy = fx (aspect ratio fixed by request)");
    else
        free.push_back(Fy);
    const bool centreFixed = o.fixPrincipalPoint || !o.distortion || o.tangential;
    if (!centreFixed)
        free.insert(free.end(), {Cx, Cy});
    else if (o.fixPrincipalPoint)
        conventions.emplace_back("principal point at the image centre (by request)");
    else if (!o.distortion)
        conventions.emplace_back("principal point at the image centre: without distortion it is not observable");
    else
        conventions.emplace_back(
            "principal point at the image centre: with tangential distortion free it is not observable");
    if (!o.distortion) {
        conventions.emplace_back("no distortion (k1 = k2 = p1 = p2 = k3 = 0, by request)");
        return free;
    }
    free.insert(free.end(), {K1, K2});
    if (o.tangential)
        free.insert(free.end(), {P1, P2});
    else
        conventions.emplace_back("p1 = p2 = 0: tangential distortion is a shift of the distortion centre");
    if (!o.fixK3)
        free.push_back(K3);
    else
        conventions.emplace_back("k3 = 0 (by request)");
    return free;
}

struct StartingPoint {
    Coefficients intrinsics{};
    std::vector<Mat3> R;
    std::vector<Vec2> t;
};

/// Closed-form start: each view's affine map A = diag(fx, fy)·(upper-left
/// block of R) has 1 as the larger singular value of that block, so with
/// fx ≈ fy the median of the views' larger singular values is fx.
StartingPoint startingPoint(const std::vector<TargetView>& views, cv::Size imageSize)
{
    std::vector<AffineView> affine;
    std::vector<double> largest;
    for (const auto& v : views) {
        affine.push_back(fitAffine(v));
        largest.push_back(Eigen::JacobiSVD<Eigen::Matrix2d>(affine.back().A).singularValues()[0]);
    }
    std::nth_element(largest.begin(), largest.begin() + static_cast<std::ptrdiff_t>(largest.size() / 2), largest.end());
    const double f = largest[largest.size() / 2];
    StartingPoint s;
    s.intrinsics = {f, f, (imageSize.width - 1) / 2.0, (imageSize.height - 1) / 2.0, 0, 0, 0, 0, 0};
    for (const auto& a : affine) {
        s.R.push_back(canonicalTilt(rotationFromBlock(a.A / f)));
        s.t.emplace_back((a.b.x() - s.intrinsics[Cx]) / f, (a.b.y() - s.intrinsics[Cy]) / f);
    }
    return s;
}

} // namespace

Vec2 projectTelecentric(const geometry::Intrinsics& in, const Vec3& cameraPoint)
{
    Coefficients c{in.K(0, 0), in.K(1, 1), in.K(0, 2), in.K(1, 2), 0, 0, 0, 0, 0};
    for (std::size_t i = 0; i < in.dist.size() && i < 5; ++i) c[K1 + i] = in.dist[i];
    return projectNormalised(c, cameraPoint.x(), cameraPoint.y());
}

TelecentricCalibration calibrateTelecentric(const std::vector<TargetView>& views, cv::Size imageSize,
                                            const TelecentricOptions& options, const std::string& field)
{
    checkViews(views, field);
    TelecentricCalibration result;
    const auto free = freeIntrinsics(options, result.conventions);
    const StartingPoint start = startingPoint(views, imageSize);
    const double spread = tiltSpreadDeg(start.R);
    if (!options.fixAspectRatio && spread < kMinTiltSpreadDeg)
        throw InputError("", field,
                         fmt::format("the target planes of all {} views lie within {:.2f} deg of each other (the "
                                     "tilt's sign not counted): the pixel aspect cannot be told from the tilt's "
                                     "foreshortening; tilt the target about different axes, at least {} deg apart "
                                     "(or fix the aspect ratio)",
                                     views.size(), spread, kMinTiltSpreadDeg));

    const double fieldRadiusMm =
        0.5 * std::hypot(imageSize.width, imageSize.height) / std::max(start.intrinsics[Fx], 1e-300);
    TelecentricProblem problem(views, start.intrinsics, free, fieldRadiusMm);
    const Eigen::VectorXd x0 = problem.pack(start.R, start.t);
    auto fit =
        detail::levenbergMarquardt([&](const Eigen::VectorXd& x, Eigen::VectorXd& r) { problem.residuals(x, r); }, x0,
                                   Eigen::VectorXd::Constant(x0.size(), 1e-4), 300);
    if (!fit.covariance.allFinite())
        throw InputError("", field,
                         "the views leave the camera undetermined (too few corners or too little tilt for "
                         "the parameters estimated)");

    Coefficients c = problem.intrinsics(fit.x);
    if (options.fixAspectRatio) c[Fy] = c[Fx];
    result.intrinsics.K << c[Fx], 0.0, c[Cx], 0.0, c[Fy], c[Cy], 0.0, 0.0, 1.0;
    result.intrinsics.dist = {c[K1], c[K2], c[P1], c[P2], c[K3]};
    result.intrinsics.imageSize = imageSize;
    result.intrinsics.projection = geometry::Projection::Telecentric;
    result.stdDev.assign(kIntrinsicCount, 0.0);
    for (std::size_t k = 0; k < free.size(); ++k) {
        const auto i = static_cast<Eigen::Index>(k);
        result.stdDev[static_cast<std::size_t>(free[k])] = problem.scale(i) * std::sqrt(fit.covariance(i, i));
    }
    if (options.fixAspectRatio) result.stdDev[Fy] = result.stdDev[Fx];

    double total = 0.0;
    Eigen::Index k = 0;
    std::vector<Mat3> rotations;
    for (std::size_t v = 0; v < views.size(); ++v) {
        double sum = 0.0;
        const auto n = views[v].imagePoints.size();
        for (std::size_t i = 0; i < 2 * n; ++i, ++k) sum += fit.residuals[k] * fit.residuals[k];
        total += sum;
        result.perViewRmsPx.push_back(std::sqrt(sum / static_cast<double>(n)));
        result.viewNames.push_back(views[v].name);
        result.cornersUsed += static_cast<int>(n);
        auto T = problem.pose(fit.x, v);
        T.R = canonicalTilt(T.R);
        rotations.push_back(T.R);
        result.cameraFromTarget.push_back(T);
    }
    result.rmsPx = std::sqrt(total / result.cornersUsed);
    result.tiltSpreadDeg = tiltSpreadDeg(rotations);
    hg::log::category("calib")->info("telecentric intrinsics from {} views, {} corners: RMS {:.4f} px", views.size(),
                                     result.cornersUsed, result.rmsPx);
    return result;
}

std::string formatTelecentricReport(const TelecentricCalibration& r)
{
    std::ostringstream s;
    char line[256];
    s << formatReportHead(r, "telecentric camera");
    std::snprintf(line, sizeof line, "  pixel aspect fy/fx      %.6f\n  tilt spread             %.1f deg\n",
                  r.pixelAspect(), r.tiltSpreadDeg);
    s << line;
    s << formatParameterTable(r, "fx, fy in px/mm; k1 in mm^-2, k2 mm^-4, p mm^-1, k3 mm^-6");
    s << "  fixed by convention:\n";
    for (const auto& c : r.conventions) s << "    " << c << '\n';
    s << formatPerViewRms(r);
    return s.str();
}

} // namespace hg::calib
