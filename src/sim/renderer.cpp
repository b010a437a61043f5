#include "hullgauge/sim/renderer.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>

namespace hg::sim {
namespace {

using geometry::Vec2;
using geometry::Vec3;

/// One edge of a projected triangle, stored from its lower end (smaller y) so
/// that two triangles sharing the edge compute bit-identical crossings.
struct ScreenEdge {
    double xLow = 0.0;
    double yLow = 0.0;
    double yHigh = 0.0;
    double dxdy = 0.0;
};

struct ScreenTriangle {
    std::array<ScreenEdge, 3> edges;
    int firstSub = 0; // first and last sub-scanline index crossing it
    int lastSub = -1;
};

/// Collects projected triangles clipped to the image's sub-scanline range.
class TriangleSink {
  public:
    TriangleSink(cv::Size size, int sub) : size_(size), sub_(sub) {}

    void add(const Vec2& a, const Vec2& b, const Vec2& c)
    {
        const double ymin = std::min({a.y(), b.y(), c.y()});
        const double ymax = std::max({a.y(), b.y(), c.y()});
        const double xmin = std::min({a.x(), b.x(), c.x()});
        const double xmax = std::max({a.x(), b.x(), c.x()});
        if (!(ymax > -0.5 && ymin < size_.height - 0.5 && xmax > -0.5 && xmin < size_.width - 0.5)) return;
        // Sub-scanline k lies at y_k = (k + 0.5) / S - 0.5.
        const double first = std::ceil((ymin + 0.5) * sub_ - 0.5);
        const double last = std::floor((ymax + 0.5) * sub_ - 0.5);
        const int total = size_.height * sub_;
        ScreenTriangle t;
        t.firstSub = static_cast<int>(std::max(0.0, first));
        t.lastSub = static_cast<int>(std::min(static_cast<double>(total - 1), last));
        if (t.firstSub > t.lastSub) return;
        const Vec2* p[3] = {&a, &b, &c};
        for (int i = 0; i < 3; ++i) {
            const Vec2* lo = p[i];
            const Vec2* hi = p[(i + 1) % 3];
            if (hi->y() < lo->y() || (hi->y() == lo->y() && hi->x() < lo->x())) std::swap(lo, hi);
            ScreenEdge& e = t.edges[static_cast<std::size_t>(i)];
            e.xLow = lo->x();
            e.yLow = lo->y();
            e.yHigh = hi->y();
            e.dxdy = hi->y() > lo->y() ? (hi->x() - lo->x()) / (hi->y() - lo->y()) : 0.0;
        }
        triangles_.push_back(t);
    }

    std::vector<ScreenTriangle>& triangles() { return triangles_; }

  private:
    cv::Size size_;
    int sub_;
    std::vector<ScreenTriangle> triangles_;
};

/// The x-interval where the horizontal line at `y` crosses the triangle.
/// Edges count on the half-open range [yLow, yHigh), so a line through a
/// vertex meets exactly two edges or none.
bool crossing(const ScreenTriangle& t, double y, double& x0, double& x1)
{
    int n = 0;
    double xs[3];
    for (const ScreenEdge& e : t.edges) {
        if (y >= e.yLow && y < e.yHigh) xs[n++] = e.xLow + (y - e.yLow) * e.dxdy;
    }
    if (n < 2) return false;
    x0 = std::min(xs[0], xs[1]);
    x1 = std::max(xs[0], xs[1]);
    return x1 > x0;
}

/// Scan conversion of the union of the triangles into per-pixel coverage.
cv::Mat rasterise(std::vector<ScreenTriangle>& triangles, cv::Size size, int sub)
{
    cv::Mat coverage(size, CV_32FC1, cv::Scalar(0));
    std::sort(triangles.begin(), triangles.end(),
              [](const ScreenTriangle& a, const ScreenTriangle& b) { return a.firstSub < b.firstSub; });

    const int width = size.width;
    const double weight = 1.0 / sub;
    const double left = -0.5;
    const double right = width - 0.5;
    // Per row: fractional end pixels go to `partial`; runs of fully covered
    // pixels go into `runs` as +w/-w steps, summed once per row.
    std::vector<double> partial(static_cast<std::size_t>(width), 0.0);
    std::vector<double> runs(static_cast<std::size_t>(width) + 1, 0.0);
    std::vector<std::size_t> active;
    std::vector<std::pair<double, double>> intervals;
    std::size_t next = 0;

    auto addSpan = [&](double a, double b) {
        a = std::max(a, left);
        b = std::min(b, right);
        if (b <= a) return;
        int ca = static_cast<int>(std::floor(a + 0.5));
        int cb = std::min(static_cast<int>(std::floor(b + 0.5)), width - 1);
        ca = std::min(ca, width - 1);
        if (ca == cb) {
            partial[static_cast<std::size_t>(ca)] += weight * (b - a);
            return;
        }
        partial[static_cast<std::size_t>(ca)] += weight * (ca + 0.5 - a);
        partial[static_cast<std::size_t>(cb)] += weight * (b - (cb - 0.5));
        runs[static_cast<std::size_t>(ca) + 1] += weight;
        runs[static_cast<std::size_t>(cb)] -= weight;
    };

    for (int row = 0; row < size.height; ++row) {
        bool touched = false;
        for (int s = 0; s < sub; ++s) {
            const int k = row * sub + s;
            while (next < triangles.size() && triangles[next].firstSub <= k) active.push_back(next++);
            if (active.empty()) continue;
            const double y = (k + 0.5) / sub - 0.5;
            intervals.clear();
            std::size_t kept = 0;
            for (std::size_t idx : active) {
                const ScreenTriangle& t = triangles[idx];
                if (t.lastSub < k) continue; // finished: drop from the active list
                active[kept++] = idx;
                double x0 = 0.0, x1 = 0.0;
                if (crossing(t, y, x0, x1) && x1 > left && x0 < right) intervals.emplace_back(x0, x1);
            }
            active.resize(kept);
            if (intervals.empty()) continue;
            touched = true;
            std::sort(intervals.begin(), intervals.end());
            double a = intervals.front().first;
            double b = intervals.front().second;
            for (std::size_t i = 1; i < intervals.size(); ++i) {
                if (intervals[i].first <= b) {
                    b = std::max(b, intervals[i].second);
                } else {
                    addSpan(a, b);
                    a = intervals[i].first;
                    b = intervals[i].second;
                }
            }
            addSpan(a, b);
        }
        if (!touched) continue;
        float* out = coverage.ptr<float>(row);
        double run = 0.0;
        for (int c = 0; c < width; ++c) {
            run += runs[static_cast<std::size_t>(c)];
            const double v = run + partial[static_cast<std::size_t>(c)];
            out[c] = static_cast<float>(std::clamp(v, 0.0, 1.0));
        }
        std::fill(partial.begin(), partial.end(), 0.0);
        std::fill(runs.begin(), runs.end(), 0.0);
    }
    return coverage;
}

/// Clips the camera-frame triangle to z >= near (Sutherland–Hodgman against
/// one plane). Crossing points are computed from the edge's end points in a
/// fixed order so a shared edge is cut at the same point in both triangles.
int clipNear(const Vec3 (&in)[3], double near, Vec3 (&out)[4])
{
    auto cut = [near](Vec3 p, Vec3 q) {
        if (std::lexicographical_compare(q.data(), q.data() + 3, p.data(), p.data() + 3)) std::swap(p, q);
        const double s = (near - p.z()) / (q.z() - p.z());
        return Vec3(p + s * (q - p));
    };
    int n = 0;
    for (int i = 0; i < 3; ++i) {
        const Vec3& p = in[i];
        const Vec3& q = in[(i + 1) % 3];
        const bool pIn = p.z() >= near;
        const bool qIn = q.z() >= near;
        if (pIn) out[n++] = p;
        if (pIn != qIn) out[n++] = cut(p, q);
    }
    return n;
}

/// Normalised radius beyond which OpenCV's radial distortion stops being
/// monotonic: past it the polynomial folds far-away points back into the
/// image, which a real lens never does, so geometry there is not drawn.
/// Searched up to `reach` in steps of reach / 10⁴.
double monotonicRadius(const std::vector<double>& d, double reach)
{
    auto at = [&d](std::size_t i) { return i < d.size() ? d[i] : 0.0; };
    const double k1 = at(0), k2 = at(1), k3 = at(4), k4 = at(5), k5 = at(6), k6 = at(7);
    auto radial = [&](double r) {
        const double r2 = r * r;
        const double num = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
        const double den = 1 + r2 * (k4 + r2 * (k5 + r2 * k6));
        return std::pair{r * num / den, den};
    };
    const double step = reach * 1e-4;
    double prev = 0.0;
    for (double r = step; r <= reach; r += step) {
        auto [g, den] = radial(r);
        if (den <= 0.0 || g <= prev) return r - step;
        prev = g;
    }
    return std::numeric_limits<double>::infinity();
}

/// The squared normalised radius within which the camera's distortion is
/// drawn: OpenCV's while monotonic (searched to 10 normalised units, or for
/// a telecentric camera ten times the image's half diagonal in mm); the
/// division model's while it has a solution, r² < 1/(4κ) for κ > 0.
double validRadius2(const geometry::Intrinsics& in)
{
    if (in.distortionModel == geometry::DistortionModel::Division)
        return in.kappa > 0.0 ? 1.0 / (4.0 * in.kappa) : std::numeric_limits<double>::infinity();
    double reach = 10.0;
    if (in.projection == geometry::Projection::Telecentric)
        reach = 5.0 * std::hypot(in.imageSize.width / in.K(0, 0), in.imageSize.height / in.K(1, 1));
    return std::pow(monotonicRadius(in.dist, reach), 2);
}

/// Projects camera-frame triangles through a distorted camera, subdividing
/// edges until their images are straight within the sag tolerance.
class DistortedProjector {
  public:
    DistortedProjector(const geometry::CameraModel& camera, double sagPx, TriangleSink& sink)
        : camera_(camera), sagPx_(sagPx), sink_(sink), limit2_(validRadius2(camera.intrinsics())), minEdge_(kMinEdge),
          maxEdge_(kMaxEdge)
    {
        // A telecentric camera's normalised units are millimetres: the same
        // bounds in pixels as a pinhole's at 1000 px focal length (kMinEdge
        // ~1e-3 px, kMaxEdge ~50 px).
        if (camera.isTelecentric()) {
            const double pxPerMm = camera.intrinsics().K.diagonal().head<2>().maxCoeff();
            minEdge_ = 1e3 * kMinEdge / pxPerMm;
            maxEdge_ = 1e3 * kMaxEdge / pxPerMm;
        }
    }

    void add(const Vec3& a, const Vec3& b, const Vec3& c) { subdivide(a, b, c, 0); }

  private:
    // Pieces smaller than this (normalised units, ~1e-3 px) are never split:
    // it bounds the recursion by the geometry alone, which keeps the split
    // decision a function of the edge's end points.
    static constexpr double kMinEdge = 1e-6;
    // Longest edge (normalised units, ~3° of view) projected without a sag
    // test, so that wide triangles cannot hide a curve between test points.
    static constexpr double kMaxEdge = 0.05;
    static constexpr int kMaxDepth = 40;

    // Pieces are in front of the camera (clipped at the near plane).
    Vec2 normalised(const Vec3& p) const { return *camera_.normalise(p); }

    std::optional<Vec2> project(const Vec3& p) const
    {
        if (normalised(p).squaredNorm() > limit2_) return std::nullopt;
        return camera_.projectCameraPoint(p);
    }

    bool needsSplit(Vec3 p, Vec3 q) const
    {
        if (std::lexicographical_compare(q.data(), q.data() + 3, p.data(), p.data() + 3)) std::swap(p, q);
        const double len = (normalised(p) - normalised(q)).norm();
        if (len < minEdge_) return false;
        if (len > maxEdge_) return true;
        auto P = project(p);
        auto Q = project(q);
        if (!P || !Q) return false; // outside the lens' valid field: dropped at the leaves
        const Vec2 chord = *Q - *P;
        const double chordLen = chord.norm();
        for (double s : {0.25, 0.5, 0.75}) {
            auto M = project(Vec3(p + s * (q - p)));
            if (!M) return true;
            const Vec2 d = *M - *P;
            const double off = chordLen > 0 ? std::abs(chord.x() * d.y() - chord.y() * d.x()) / chordLen : d.norm();
            if (off > sagPx_) return true;
        }
        return false;
    }

    void subdivide(const Vec3& a, const Vec3& b, const Vec3& c, int depth)
    {
        if (depth < kMaxDepth) {
            // Bisect the longest edge that bends (longest-edge bisection keeps
            // the pieces well shaped; bisecting any bending edge first breeds
            // slivers whose long sides bend again). The order does not matter
            // for cracks: an edge that bends is split in every triangle
            // holding it, at the same midpoint.
            const Vec3* v[3] = {&a, &b, &c};
            int worst = -1;
            double worstLength = 0.0;
            for (int i = 0; i < 3; ++i) {
                const Vec3& p = *v[i];
                const Vec3& q = *v[(i + 1) % 3];
                const double length = (normalised(p) - normalised(q)).squaredNorm();
                if (length > worstLength && needsSplit(p, q)) {
                    worst = i;
                    worstLength = length;
                }
            }
            if (worst >= 0) {
                const Vec3& p = *v[worst];
                const Vec3& q = *v[(worst + 1) % 3];
                const Vec3& r = *v[(worst + 2) % 3];
                const Vec3 m = 0.5 * (p + q);
                subdivide(p, m, r, depth + 1);
                subdivide(m, q, r, depth + 1);
                return;
            }
        }
        auto A = project(a);
        auto B = project(b);
        auto C = project(c);
        if (A && B && C) sink_.add(*A, *B, *C);
    }

    const geometry::CameraModel& camera_;
    double sagPx_;
    TriangleSink& sink_;
    double limit2_;
    double minEdge_, maxEdge_;
};

/// Φ⁻¹(p) for p in (0, 1): Acklam's rational approximation, refined by one
/// Halley step on erfc (then accurate to about 1e-15 relative).
double inverseNormalCdf(double p)
{
    static constexpr std::array<double, 6> a{-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
    static constexpr std::array<double, 5> b{-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                             6.680131188771972e+01, -1.328068155288572e+01};
    static constexpr std::array<double, 6> c{-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
    static constexpr std::array<double, 4> d{7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                             3.754408661907416e+00};
    auto tail = [&](double q) {
        return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
               ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
    };
    constexpr double low = 0.02425;
    double x = 0.0;
    if (p < low) {
        x = tail(std::sqrt(-2.0 * std::log(p)));
    } else if (p > 1.0 - low) {
        x = -tail(std::sqrt(-2.0 * std::log1p(-p)));
    } else {
        const double q = p - 0.5;
        const double r = q * q;
        x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
            (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
    }
    // Halley's step on the residual in the smaller tail, where it keeps its precision.
    const double e =
        p < 0.5 ? 0.5 * std::erfc(-x / std::sqrt(2.0)) - p : (1.0 - p) - 0.5 * std::erfc(x / std::sqrt(2.0));
    const double u = e * std::sqrt(2.0 * std::numbers::pi) * std::exp(0.5 * x * x);
    return x - u / (1.0 + 0.5 * x * u);
}

/// σ_h of erodeCoverage's probe: at least 1 px, so the blurred edge is
/// Gaussian to well under 0.01 px, and a third of the reach it reads distances
/// out to, so they lie within 3σ, where the blurred coverage keeps its precision.
double haloProbeSigma(double haloPx)
{
    return std::max(1.0, (haloPx + 0.5) / 3.0);
}

/// Pixels beyond which erodeCoverage does not look (the probe's kernel radius, 6σ_h).
int haloReach(double haloPx)
{
    return haloPx > 0.0 ? static_cast<int>(std::ceil(6.0 * haloProbeSigma(haloPx))) : 0;
}

/// Pixels around a window whose coverage reaches the window's grey values:
/// the halo's probe, then the optics blur (OpenCV's kernel for a float image
/// reaches 4σ from its centre).
int renderMargin(const RenderOptions& options)
{
    const int blur = options.blurSigmaPx > 0.0 ? static_cast<int>(std::ceil(4.0 * options.blurSigmaPx)) + 1 : 0;
    return blur + haloReach(options.haloPx);
}

/// The back light's level (grey levels) over the window of `sensor` at
/// `origin` of `size`: `level` · V · D (renderer.h, RenderOptions).
cv::Mat backLight(cv::Size size, const RenderOptions& options, cv::Point origin, cv::Size sensor, double level)
{
    cv::Mat light(size, CV_32FC1, cv::Scalar(level));
    const double cx = (sensor.width - 1) / 2.0;
    const double cy = (sensor.height - 1) / 2.0;
    const double corner2 = cx * cx + cy * cy; // ρ = 1 at a corner pixel's centre
    if (options.vignetting > 0.0 && corner2 > 0.0) {
        for (int r = 0; r < size.height; ++r) {
            float* row = light.ptr<float>(r);
            const double dy = origin.y + r - cy;
            for (int c = 0; c < size.width; ++c) {
                const double dx = origin.x + c - cx;
                row[c] = static_cast<float>(level * (1.0 - options.vignetting * (dx * dx + dy * dy) / corner2));
            }
        }
    }
    const cv::Rect window(origin, size);
    for (const DustSpeck& speck : options.dust) {
        // Pixels whose centre lies within radius + 0.5 of the speck's centre (the anti-aliased rim).
        const double reach = speck.radiusPx + 0.5;
        const cv::Rect box =
            cv::Rect(static_cast<int>(std::floor(speck.x - reach)), static_cast<int>(std::floor(speck.y - reach)),
                     static_cast<int>(std::ceil(2.0 * reach)) + 2, static_cast<int>(std::ceil(2.0 * reach)) + 2) &
            window;
        for (int y = box.y; y < box.y + box.height; ++y) {
            float* row = light.ptr<float>(y - origin.y);
            for (int x = box.x; x < box.x + box.width; ++x) {
                const double cover = std::clamp(reach - std::hypot(x - speck.x, y - speck.y), 0.0, 1.0);
                row[x - origin.x] *= static_cast<float>(1.0 - speck.depth * cover);
            }
        }
    }
    return light;
}

} // namespace

void RenderOptions::validate() const
{
    // The option's name, what it must be, and the value it has.
    auto fail = [](const std::string& option, const std::string& must, double value) {
        throw ArgumentError(option + " must be " + must + ", found " + formatNumber(value));
    };
    if (subScanlines < 4 || subScanlines > 256) fail("subScanlines", "within [4, 256]", subScanlines);
    if (!(maxEdgeSagPx > 0.0) || !std::isfinite(maxEdgeSagPx)) fail("maxEdgeSagPx", "positive", maxEdgeSagPx);
    if (!(nearPlaneMm > 0.0) || !std::isfinite(nearPlaneMm)) fail("nearPlaneMm", "positive", nearPlaneMm);
    if (!(backgroundLevel >= 0.0 && backgroundLevel <= 1.0)) fail("backgroundLevel", "within [0, 1]", backgroundLevel);
    if (!(objectLevel >= 0.0 && objectLevel <= 1.0)) fail("objectLevel", "within [0, 1]", objectLevel);
    if (bitDepth != 8 && bitDepth != 16) fail("bitDepth", "8 or 16", bitDepth);
    if (!(blurSigmaPx >= 0.0) || !std::isfinite(blurSigmaPx)) fail("blurSigmaPx", ">= 0", blurSigmaPx);
    if (!(noiseSigma >= 0.0) || !std::isfinite(noiseSigma)) fail("noiseSigma", ">= 0", noiseSigma);
    if (!(vignetting >= 0.0 && vignetting <= 0.95)) fail("vignetting", "within [0, 0.95]", vignetting);
    if (!(haloPx >= 0.0 && haloPx <= 10.0)) fail("haloPx", "within [0, 10]", haloPx);
    for (std::size_t i = 0; i < dust.size(); ++i) {
        const DustSpeck& d = dust[i];
        const std::string name = "dust[" + std::to_string(i) + "].";
        if (!std::isfinite(d.x) || std::abs(d.x) > 1e6) fail(name + "x", "within ±1e6", d.x);
        if (!std::isfinite(d.y) || std::abs(d.y) > 1e6) fail(name + "y", "within ±1e6", d.y);
        if (!(d.radiusPx >= 0.5 && d.radiusPx <= 500.0)) fail(name + "radiusPx", "within [0.5, 500]", d.radiusPx);
        if (!(d.depth >= 0.0 && d.depth <= 1.0)) fail(name + "depth", "within [0, 1]", d.depth);
    }
}

SilhouetteRenderer::SilhouetteRenderer(std::vector<model::TriangleMesh> meshes) : meshes_(std::move(meshes))
{
}

cv::Mat SilhouetteRenderer::coverage(const geometry::CameraModel& camera, const RenderOptions& options) const
{
    options.validate();
    const cv::Size size = camera.imageSize();
    if (size.width <= 0 || size.height <= 0)
        throw ArgumentError(fmt::format("camera: no image size, found {}x{}", size.width, size.height));
    const int sub = options.subScanlines;
    const bool telecentric = camera.isTelecentric();
    // A telecentric camera images everything beyond its lens's front
    // (docs/telecentric.md): clipped there when the working distance is stated.
    const double near = !telecentric ? options.nearPlaneMm : -camera.intrinsics().workingDistanceMm;
    const auto& pose = camera.cameraFromPart();
    const geometry::Mat3& K = camera.intrinsics().K;
    const bool distorted = camera.intrinsics().hasDistortion();

    TriangleSink sink(size, sub);
    DistortedProjector distortedProjector(camera, options.maxEdgeSagPx, sink);
    // Pinhole projection x = K X / Z (eq. 4.2.1-1/2 with skew), or the
    // telecentric x = K (X, Y, 1); no distortion.
    auto pinhole = [&K, telecentric](const Vec3& p) {
        const double x = telecentric ? p.x() : p.x() / p.z();
        const double y = telecentric ? p.y() : p.y() / p.z();
        return Vec2(K(0, 0) * x + K(0, 1) * y + K(0, 2), K(1, 1) * y + K(1, 2));
    };

    std::vector<Vec3> cam;
    std::vector<Vec2> pix;
    std::size_t front = 0;
    for (const model::TriangleMesh& mesh : meshes_) {
        // A mesh stored inside out still renders: its front faces are the
        // ones whose normals point away from the camera.
        const double orientation = mesh.signedVolume() < 0.0 ? -1.0 : 1.0;
        cam.resize(mesh.vertices.size());
        for (std::size_t i = 0; i < cam.size(); ++i) cam[i] = pose.apply(mesh.vertices[i]);
        if (!distorted) {
            pix.resize(cam.size());
            for (std::size_t i = 0; i < cam.size(); ++i)
                if (cam[i].z() >= near) pix[i] = pinhole(cam[i]);
        }
        for (const auto& tri : mesh.triangles) {
            const Vec3 v[3] = {cam[static_cast<std::size_t>(tri[0])], cam[static_cast<std::size_t>(tri[1])],
                               cam[static_cast<std::size_t>(tri[2])]};
            // Front-facing: the outward normal points towards the camera
            // centre (the origin), or against a telecentric camera's +z.
            const Vec3 n = orientation * (v[1] - v[0]).cross(v[2] - v[0]);
            if (!((telecentric ? n.z() : n.dot(v[0])) < 0.0)) continue;
            ++front;
            const bool allIn = v[0].z() >= near && v[1].z() >= near && v[2].z() >= near;
            if (allIn && !distorted) {
                sink.add(pix[static_cast<std::size_t>(tri[0])], pix[static_cast<std::size_t>(tri[1])],
                         pix[static_cast<std::size_t>(tri[2])]);
                continue;
            }
            Vec3 poly[4];
            const int n3 = allIn ? 3 : clipNear(v, near, poly);
            if (allIn) std::copy(std::begin(v), std::end(v), poly);
            for (int i = 1; i + 1 < n3; ++i) {
                if (distorted) {
                    distortedProjector.add(poly[0], poly[i], poly[i + 1]);
                } else {
                    sink.add(pinhole(poly[0]), pinhole(poly[i]), pinhole(poly[i + 1]));
                }
            }
        }
    }
    log::category("sim")->trace("coverage {}x{}: {} front-facing triangles, {} projected pieces", size.width,
                                size.height, front, sink.triangles().size());
    return rasterise(sink.triangles(), size, sub);
}

cv::Mat SilhouetteRenderer::render(const geometry::CameraModel& camera, const RenderOptions& options) const
{
    return shadeCoverage(coverage(camera, options), options);
}

cv::Mat SilhouetteRenderer::render(const geometry::CameraModel& camera, const RenderOptions& options,
                                   const cv::Rect& window) const
{
    const cv::Rect sensor(cv::Point(0, 0), camera.imageSize());
    if (window.empty() || (window & sensor) != window)
        throw ArgumentError(fmt::format("render window {}x{}+{}+{} is not within the {}x{} sensor", window.width,
                                        window.height, window.x, window.y, sensor.width, sensor.height));
    const int margin = renderMargin(options);
    const cv::Rect padded =
        cv::Rect(window.x - margin, window.y - margin, window.width + 2 * margin, window.height + 2 * margin) & sensor;
    // A crop is the same camera with its principal point moved by the crop's corner.
    geometry::Intrinsics cropped = camera.intrinsics();
    cropped.K(0, 2) -= padded.x;
    cropped.K(1, 2) -= padded.y;
    cropped.imageSize = padded.size();
    // The back light's fall-off and dust are the sensor's: shaded at the crop's place on it.
    const cv::Mat image = shadeCoverage(coverage(geometry::CameraModel(cropped, camera.cameraFromPart()), options),
                                        options, padded.tl(), sensor.size());
    return image(window - padded.tl());
}

cv::Mat erodeCoverage(const cv::Mat& coverage, double haloPx)
{
    if (coverage.type() != CV_32FC1)
        throw ArgumentError("coverage image must be CV_32FC1, found " + cv::typeToString(coverage.type()));
    if (!(haloPx > 0.0 && haloPx <= 10.0))
        throw ArgumentError("haloPx must be within (0, 10], found " + formatNumber(haloPx));
    const double probe = haloProbeSigma(haloPx);
    const int reach = haloReach(haloPx);
    // Doubles: a distance of 3σ leaves 1e-3 of the blurred coverage to read it from.
    cv::Mat blurred;
    coverage.convertTo(blurred, CV_64FC1);
    cv::GaussianBlur(blurred, blurred, cv::Size(2 * reach + 1, 2 * reach + 1), probe, probe, cv::BORDER_REPLICATE);
    const double sigma = std::sqrt(probe * probe + 1.0 / 12.0);
    // Only pixels within half a pixel of the shrunk edge, d in (h - 0.5, h + 0.5), are partly
    // covered: the blurred coverage of that band, Φ(d / σ), bounds the pixels that need Φ⁻¹.
    const auto normalCdf = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
    const double outside = normalCdf((haloPx - 0.5) / sigma);
    const double inside = normalCdf((haloPx + 0.5) / sigma);
    cv::Mat out(coverage.size(), CV_32FC1);
    for (int r = 0; r < coverage.rows; ++r) {
        const double* in = blurred.ptr<double>(r);
        float* row = out.ptr<float>(r);
        for (int c = 0; c < coverage.cols; ++c) {
            const double s = in[c];
            if (!(s > outside && s < inside)) {
                row[c] = s >= inside ? 1.0f : 0.0f;
                continue;
            }
            // Signed distance from the edge into the object, then the coverage of the shrunk silhouette.
            const double distance = sigma * inverseNormalCdf(s);
            row[c] = static_cast<float>(std::clamp(distance - haloPx + 0.5, 0.0, 1.0));
        }
    }
    return out;
}

cv::Mat shadeCoverage(const cv::Mat& coverage, const RenderOptions& options, cv::Point origin, cv::Size sensor)
{
    options.validate();
    if (coverage.type() != CV_32FC1)
        throw ArgumentError("coverage image must be CV_32FC1, found " + cv::typeToString(coverage.type()));
    if (sensor.width <= 0 || sensor.height <= 0) sensor = coverage.size();
    const double full = options.bitDepth == 8 ? 255.0 : 65535.0;
    const double background = options.backgroundLevel * full;
    const double object = options.objectLevel * full;
    const cv::Mat covered = options.haloPx > 0.0 ? erodeCoverage(coverage, options.haloPx) : coverage;
    // Backlit model: value = B + (object - B) * coverage, B the back light's level at the pixel.
    cv::Mat grey;
    if (options.vignetting > 0.0 || !options.dust.empty()) {
        const cv::Mat light = backLight(coverage.size(), options, origin, sensor, background);
        grey = light + (object - light).mul(covered);
    } else {
        covered.convertTo(grey, CV_32FC1, object - background, background);
    }
    if (options.blurSigmaPx > 0.0) {
        // The back light continues beyond the sensor edge: replicate the border.
        cv::GaussianBlur(grey, grey, cv::Size(0, 0), options.blurSigmaPx, options.blurSigmaPx, cv::BORDER_REPLICATE);
    }
    if (options.noiseSigma > 0.0) {
        cv::RNG rng(options.seed);
        cv::Mat noise(grey.size(), CV_32FC1);
        rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noiseSigma);
        grey += noise;
    }
    cv::Mat out;
    grey.convertTo(out, options.bitDepth == 8 ? CV_8UC1 : CV_16UC1); // rounds and saturates
    return out;
}

CoverageStats measureCoverage(const cv::Mat& coverage)
{
    if (coverage.type() != CV_32FC1)
        throw ArgumentError("coverage image must be CV_32FC1, found " + cv::typeToString(coverage.type()));
    CoverageStats stats;
    stats.areaPx = cv::sum(coverage)[0];
    cv::Mat mask = coverage > 0.0f;
    if (cv::countNonZero(mask) == 0) return stats;
    stats.boundingBox = cv::boundingRect(mask);
    const cv::Rect& b = stats.boundingBox;
    stats.touchesBorder = b.x == 0 || b.y == 0 || b.x + b.width == coverage.cols || b.y + b.height == coverage.rows;
    return stats;
}

} // namespace hg::sim
