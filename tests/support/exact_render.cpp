// The independent test renderer (hgtest/exact_render.h): the method and its
// accuracy are described there.
#include "hgtest/exact_render.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>

namespace hgtest {

using hg::geometry::CameraModel;
using hg::geometry::Vec2;
using hg::geometry::Vec3;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Contour walk: largest step between two projected points (px), and how far
/// around a point pixels are marked (px): at least half a step plus the sag.
constexpr double kWalkStepPx = 0.25;
constexpr double kMarkMarginPx = 0.25;
/// Side of a cell of the triangle grid, in pixels at the image centre.
constexpr double kCellPx = 4.0;
constexpr int kMaxCellsPerSide = 4096;

/// The camera's normalised plane and its pixels. A pinhole camera's plane is
/// the perspective one, (x/z, y/z), reached through the camera's own lens
/// model (CameraModel::projectCameraPoint and undistortPixel, whose round trip
/// tests/sim/test_exact_render.cpp checks). A telecentric camera's is the
/// orthographic one, (x, y) in mm, and its pixel K·(x, y, 1) — written here
/// from docs/telecentric.md's equations, sharing no code with the camera, so
/// that the telecentric accuracy tests judge src/'s projection on frames it
/// did not make. A telecentric camera with lens distortion is refused.
class PlaneMap {
  public:
    explicit PlaneMap(const CameraModel& camera)
        : camera_(camera), orthographic_(camera.intrinsics().projection == hg::geometry::Projection::Telecentric)
    {
        const auto& K = camera.intrinsics().K;
        fx_ = K(0, 0);
        skew_ = K(0, 1);
        cx_ = K(0, 2);
        fy_ = K(1, 1);
        cy_ = K(1, 2);
        if (orthographic_)
            for (double d : camera.intrinsics().dist)
                if (d != 0.0)
                    throw std::invalid_argument(
                        "exactCoverage: a telecentric camera's lens distortion is not drawn; give dist zero");
    }

    /// A camera-frame point on the plane; the perspective plane needs z beyond the near limit.
    bool toPlane(const Vec3& pc, double nearPlaneMm, Vec2& q) const
    {
        if (orthographic_) {
            q = Vec2(pc.x(), pc.y());
            return true;
        }
        if (!(pc.z() > nearPlaneMm)) return false;
        q = Vec2(pc.x() / pc.z(), pc.y() / pc.z());
        return true;
    }
    Vec2 toPixel(const Vec2& q) const
    {
        if (!orthographic_) return *camera_.projectCameraPoint(Vec3(q.x(), q.y(), 1.0));
        return {fx_ * q.x() + skew_ * q.y() + cx_, fy_ * q.y() + cy_};
    }
    Vec2 fromPixel(const Vec2& p) const
    {
        if (!orthographic_) return camera_.undistortPixel(p);
        const double y = (p.y() - cy_) / fy_;
        return {(p.x() - cx_ - skew_ * y) / fx_, y};
    }

  private:
    const CameraModel& camera_;
    bool orthographic_;
    double fx_ = 1, skew_ = 0, cx_ = 0, fy_ = 1, cy_ = 0;
};

/// An axis-aligned box in the camera's normalised plane.
struct PlaneBox {
    double xMin = kInf, xMax = -kInf, yMin = kInf, yMax = -kInf;

    void add(const Vec2& p)
    {
        xMin = std::min(xMin, p.x());
        xMax = std::max(xMax, p.x());
        yMin = std::min(yMin, p.y());
        yMax = std::max(yMax, p.y());
    }
    bool empty() const { return !(xMin <= xMax && yMin <= yMax); }
    PlaneBox intersected(const PlaneBox& o) const
    {
        return {std::max(xMin, o.xMin), std::min(xMax, o.xMax), std::max(yMin, o.yMin), std::min(yMax, o.yMax)};
    }
};

/// A triangle of the normalised plane as three edge functions a·x + b·y + c,
/// each >= 0 on the triangle's side. Each line's coefficients are computed
/// from its end points in a fixed order and then only negated, so two
/// triangles sharing an edge see exactly opposite values: no point falls in
/// a crack between them.
struct PlaneTriangle {
    std::array<Vec2, 3> v;
    std::array<std::array<double, 3>, 3> edge{};

    bool contains(double x, double y) const
    {
        for (const auto& e : edge)
            if (e[0] * x + e[1] * y + e[2] < 0) return false;
        return true;
    }
};

double cross(const Vec2& a, const Vec2& b)
{
    return a.x() * b.y() - a.y() * b.x();
}

bool lexicographicLess(const Vec2& a, const Vec2& b)
{
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
}

/// The triangle a, b, c; false for one of zero area (it covers nothing).
bool makePlaneTriangle(const Vec2& a, const Vec2& b, const Vec2& c, PlaneTriangle& t)
{
    const double area2 = cross(b - a, c - a);
    if (!(std::abs(area2) > 0) || !std::isfinite(area2)) return false;
    t.v = {a, b, c};
    const double orientation = area2 > 0 ? 1.0 : -1.0;
    for (int k = 0; k < 3; ++k) {
        const Vec2& p = t.v[k];
        const Vec2& q = t.v[(k + 1) % 3];
        const bool swapped = lexicographicLess(q, p);
        const Vec2& s = swapped ? q : p;
        const Vec2& e = swapped ? p : q;
        // cross(e - s, x - s) = -(e.y - s.y)·x + (e.x - s.x)·y + (e.y - s.y)·s.x - (e.x - s.x)·s.y
        const double sign = swapped ? -orientation : orientation;
        const double dx = e.x() - s.x(), dy = e.y() - s.y();
        t.edge[k] = {-dy * sign, dx * sign, (dy * s.x() - dx * s.y()) * sign};
    }
    return true;
}

/// The meshes in the normalised plane: vertices welded by exact position (so
/// edges shared in space are shared here) and every triangle, degenerate ones
/// included (their edges count as contour edges).
struct PlaneScene {
    std::vector<Vec2> points;
    std::vector<std::array<int, 3>> triangles;
};

struct PositionHash {
    std::size_t operator()(const Vec3& p) const
    {
        std::uint64_t h = 0x9e3779b97f4a7c15ULL;
        for (int i = 0; i < 3; ++i) h = (h ^ std::bit_cast<std::uint64_t>(p[i] + 0.0)) * 0x100000001b3ULL;
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};

PlaneScene projectMeshes(const std::vector<hg::model::TriangleMesh>& meshes, const CameraModel& camera,
                         const PlaneMap& map, double nearPlaneMm)
{
    PlaneScene scene;
    std::unordered_map<Vec3, int, PositionHash> welded;
    for (std::size_t m = 0; m < meshes.size(); ++m) {
        const auto& mesh = meshes[m];
        std::vector<int> id(mesh.vertices.size());
        for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
            const Vec3 key = mesh.vertices[i] + Vec3::Zero(); // -0 and +0 weld
            auto [it, added] = welded.try_emplace(key, static_cast<int>(scene.points.size()));
            id[i] = it->second;
            if (!added) continue;
            const Vec3 pc = camera.cameraFromPart().apply(mesh.vertices[i]);
            Vec2 q;
            if (!map.toPlane(pc, nearPlaneMm, q))
                throw std::invalid_argument("exactCoverage: mesh " + std::to_string(m) + " vertex " +
                                            std::to_string(i) + " lies at camera z = " + std::to_string(pc.z()) +
                                            " mm, not beyond the near limit " + std::to_string(nearPlaneMm) + " mm");
            scene.points.push_back(q);
        }
        for (const auto& t : mesh.triangles) {
            for (int k : t)
                if (k < 0 || static_cast<std::size_t>(k) >= id.size())
                    throw std::invalid_argument("exactCoverage: mesh " + std::to_string(m) +
                                                " has a triangle with vertex index " + std::to_string(k) +
                                                " out of range");
            scene.triangles.push_back({id[t[0]], id[t[1]], id[t[2]]});
        }
    }
    return scene;
}

/// True when the third vertices `p` and `q` lie strictly on opposite sides of
/// the line through `a` and `b` (a relative margin of 1e-12 for rounding).
bool strictlyOpposite(const Vec2& a, const Vec2& b, const Vec2& p, const Vec2& q)
{
    const Vec2 e = b - a;
    const double sp = cross(e, p - a), sq = cross(e, q - a);
    const double tp = 1e-12 * e.norm() * (p - a).norm(), tq = 1e-12 * e.norm() * (q - a).norm();
    return (sp > tp && sq < -tq) || (sp < -tp && sq > tq);
}

/// The contour edges (header: "the boundary of the union lies on the contour
/// edges") as pairs of welded vertex indices.
std::vector<std::pair<int, int>> contourEdges(const PlaneScene& scene)
{
    struct EdgeUse {
        int lo, hi, third;
    };
    std::vector<EdgeUse> uses;
    uses.reserve(scene.triangles.size() * 3);
    for (const auto& t : scene.triangles)
        for (int k = 0; k < 3; ++k) {
            const int a = t[k], b = t[(k + 1) % 3];
            if (a != b) uses.push_back({std::min(a, b), std::max(a, b), t[(k + 2) % 3]});
        }
    std::sort(uses.begin(), uses.end(),
              [](const EdgeUse& x, const EdgeUse& y) { return x.lo < y.lo || (x.lo == y.lo && x.hi < y.hi); });
    std::vector<std::pair<int, int>> contour;
    for (std::size_t i = 0; i < uses.size();) {
        std::size_t j = i;
        while (j < uses.size() && uses[j].lo == uses[i].lo && uses[j].hi == uses[i].hi) ++j;
        const auto& P = scene.points;
        const bool interior =
            j - i == 2 && strictlyOpposite(P[uses[i].lo], P[uses[i].hi], P[uses[i].third], P[uses[i + 1].third]);
        if (!interior) contour.emplace_back(uses[i].lo, uses[i].hi);
        i = j;
    }
    return contour;
}

/// The triangles in a uniform grid over the normalised plane; each cell lists
/// the triangles that overlap it. Cells of the outermost rows and columns
/// reach to infinity (insertion and look-up both clamp), so the grid answers
/// exactly for every point, wherever it covers.
class TriangleGrid {
  public:
    TriangleGrid(std::vector<PlaneTriangle> triangles, const PlaneBox& area, double cellSize)
        : triangles_(std::move(triangles)), x0_(area.xMin), y0_(area.yMin)
    {
        const double w = std::max(area.xMax - area.xMin, 0.0), h = std::max(area.yMax - area.yMin, 0.0);
        cell_ = std::max({cellSize, w / kMaxCellsPerSide, h / kMaxCellsPerSide});
        nx_ = std::max(1, static_cast<int>(std::ceil(w / cell_)));
        ny_ = std::max(1, static_cast<int>(std::ceil(h / cell_)));
        std::vector<int> count(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
        for (const auto& t : triangles_) forEachCell(t, [&](std::size_t c) { ++count[c + 1]; });
        for (std::size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
        start_ = count;
        items_.resize(static_cast<std::size_t>(count.back()));
        for (std::size_t i = 0; i < triangles_.size(); ++i)
            forEachCell(triangles_[i], [&](std::size_t c) { items_[static_cast<std::size_t>(count[c]++)] = int(i); });
    }

    /// A triangle containing (x, y) — `hint` is tried first — or -1.
    int find(double x, double y, int hint) const
    {
        if (hint >= 0 && triangles_[static_cast<std::size_t>(hint)].contains(x, y)) return hint;
        const std::size_t c = static_cast<std::size_t>(row(y)) * nx_ + column(x);
        for (int k = start_[c]; k < start_[c + 1]; ++k) {
            const int i = items_[static_cast<std::size_t>(k)];
            if (triangles_[static_cast<std::size_t>(i)].contains(x, y)) return i;
        }
        return -1;
    }

  private:
    int column(double x) const { return clampIndex((x - x0_) / cell_, nx_); }
    int row(double y) const { return clampIndex((y - y0_) / cell_, ny_); }
    static int clampIndex(double f, int n)
    {
        if (!(f >= 0)) return 0; // also NaN
        return f >= n - 1 ? n - 1 : static_cast<int>(f);
    }

    /// Calls fn(cell index) for every cell the triangle overlaps: per row of
    /// cells, the x extent of the triangle within the row's band. Bands and
    /// extents are widened by a hair, so a point that rounding puts in a
    /// neighbouring cell still finds the triangle.
    template <class Fn> void forEachCell(const PlaneTriangle& t, Fn fn) const
    {
        const double slack = 1e-9 * cell_;
        double yLow = kInf, yHigh = -kInf;
        for (const Vec2& p : t.v) yLow = std::min(yLow, p.y()), yHigh = std::max(yHigh, p.y());
        for (int j = row(yLow - slack); j <= row(yHigh + slack); ++j) {
            const double bandLow = j == 0 ? -kInf : y0_ + j * cell_ - slack;
            const double bandHigh = j == ny_ - 1 ? kInf : y0_ + (j + 1) * cell_ + slack;
            double xLow = kInf, xHigh = -kInf;
            for (int k = 0; k < 3; ++k) {
                const Vec2 &a = t.v[k], &b = t.v[(k + 1) % 3];
                if (a.y() >= bandLow && a.y() <= bandHigh) xLow = std::min(xLow, a.x()), xHigh = std::max(xHigh, a.x());
                for (double line : {bandLow, bandHigh}) {
                    if (!std::isfinite(line) || !((a.y() - line) * (b.y() - line) < 0)) continue;
                    const double x = a.x() + (line - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
                    xLow = std::min(xLow, x), xHigh = std::max(xHigh, x);
                }
            }
            if (xLow > xHigh) { // rounding at a band's edge: fall back to the whole triangle
                for (const Vec2& p : t.v) xLow = std::min(xLow, p.x()), xHigh = std::max(xHigh, p.x());
            }
            for (int i = column(xLow - slack); i <= column(xHigh + slack); ++i)
                fn(static_cast<std::size_t>(j) * nx_ + i);
        }
    }

    std::vector<PlaneTriangle> triangles_;
    double x0_, y0_, cell_ = 1.0;
    int nx_ = 1, ny_ = 1;
    std::vector<int> start_, items_;
};

/// The part of the normalised plane the image sees: the undistorted outline
/// of the sensor [-0.5, W-0.5] x [-0.5, H-0.5] every 4 px, widened by 2 px
/// for the outline's bulge between its points.
PlaneBox imageExtent(const CameraModel& camera, const PlaneMap& map)
{
    const cv::Size size = camera.imageSize();
    const double right = size.width - 0.5, bottom = size.height - 0.5;
    PlaneBox box;
    for (double x = -0.5;; x = std::min(x + 4.0, right)) {
        box.add(map.fromPixel({x, -0.5}));
        box.add(map.fromPixel({x, bottom}));
        if (x == right) break;
    }
    for (double y = -0.5;; y = std::min(y + 4.0, bottom)) {
        box.add(map.fromPixel({-0.5, y}));
        box.add(map.fromPixel({right, y}));
        if (y == bottom) break;
    }
    const auto& K = camera.intrinsics().K;
    const double margin = 2.0 / std::min(K(0, 0), K(1, 1));
    return {box.xMin - margin, box.xMax + margin, box.yMin - margin, box.yMax + margin};
}

/// Liang–Barsky: the part of segment [a, b] within `box`; false when none.
bool clipSegment(Vec2& a, Vec2& b, const PlaneBox& box)
{
    double t0 = 0.0, t1 = 1.0;
    const Vec2 d = b - a;
    const double p[4] = {-d.x(), d.x(), -d.y(), d.y()};
    const double q[4] = {a.x() - box.xMin, box.xMax - a.x(), a.y() - box.yMin, box.yMax - a.y()};
    for (int i = 0; i < 4; ++i) {
        if (p[i] == 0) {
            if (q[i] < 0) return false;
            continue;
        }
        const double t = q[i] / p[i];
        if (p[i] < 0)
            t0 = std::max(t0, t);
        else
            t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
    const Vec2 start = a + t0 * d, end = a + t1 * d;
    a = start;
    b = end;
    return true;
}

/// Marks every pixel whose square, widened by kMarkMarginPx, holds `p`.
void markAround(cv::Mat1b& mask, const Vec2& p)
{
    const double reach = 0.5 + kMarkMarginPx;
    const int c0 = std::max(0, static_cast<int>(std::ceil(p.x() - reach)));
    const int c1 = std::min(mask.cols - 1, static_cast<int>(std::floor(p.x() + reach)));
    const int r0 = std::max(0, static_cast<int>(std::ceil(p.y() - reach)));
    const int r1 = std::min(mask.rows - 1, static_cast<int>(std::floor(p.y() + reach)));
    for (int r = r0; r <= r1; ++r)
        for (int c = c0; c <= c1; ++c) mask(r, c) = 1;
}

/// Marks the pixels a contour edge (straight in the normalised plane) may
/// touch: its projection walked by halving until each step is at most
/// kWalkStepPx long, every step's ends marked.
void markContourEdge(cv::Mat1b& mask, Vec2 a, Vec2 b, const PlaneMap& map, const PlaneBox& extent)
{
    if (!clipSegment(a, b, extent)) return;
    auto pixel = [&](const Vec2& q) { return map.toPixel(q); };
    struct Piece {
        Vec2 qa, pa, qb, pb;
        int depth;
    };
    std::vector<Piece> stack{{a, pixel(a), b, pixel(b), 0}};
    while (!stack.empty()) {
        const Piece s = stack.back();
        stack.pop_back();
        if ((s.pb - s.pa).norm() <= kWalkStepPx || s.depth >= 60) {
            markAround(mask, s.pa);
            markAround(mask, s.pb);
            continue;
        }
        const Vec2 qm = 0.5 * (s.qa + s.qb), pm = pixel(qm);
        stack.push_back({s.qa, s.pa, qm, pm, s.depth + 1});
        stack.push_back({qm, pm, s.qb, s.pb, s.depth + 1});
    }
}

/// Everything a point test needs; shared read-only by the threads.
struct Sampler {
    const PlaneMap& map;
    const TriangleGrid& grid;

    /// Whether the pixel-coordinate point (u, v) is in the silhouette;
    /// `hint` carries the last triangle hit.
    bool covered(double u, double v, int& hint) const
    {
        const Vec2 q = map.fromPixel({u, v});
        const int t = grid.find(q.x(), q.y(), hint);
        if (t >= 0) hint = t;
        return t >= 0;
    }
};

std::uint64_t splitMix64(std::uint64_t x)
{
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

/// Stratified jittered estimate of one pixel's coverage (header: "Method").
float supersamplePixel(const Sampler& sampler, int c, int r, int width, int S, std::uint64_t seed)
{
    const std::uint64_t index = static_cast<std::uint64_t>(r) * static_cast<std::uint64_t>(width) + c;
    std::mt19937_64 rng(splitMix64(seed ^ splitMix64(index)));
    auto uniform = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }; // [0, 1)
    const double stratum = 1.0 / S;
    int inside = 0, hint = -1;
    for (int j = 0; j < S; ++j)
        for (int i = 0; i < S; ++i) {
            const double u = c - 0.5 + (i + uniform()) * stratum;
            const double v = r - 0.5 + (j + uniform()) * stratum;
            inside += sampler.covered(u, v, hint) ? 1 : 0;
        }
    return static_cast<float>(static_cast<double>(inside) / (static_cast<double>(S) * S));
}

/// Supersamples the marked pixels on `threads` threads. Each pixel is
/// written by one thread and its value depends on its index alone.
void supersampleMarked(cv::Mat& out, const cv::Mat1b& mask, const Sampler& sampler, const ExactRenderOptions& o)
{
    std::vector<int> pixels;
    for (int r = 0; r < mask.rows; ++r)
        for (int c = 0; c < mask.cols; ++c)
            if (mask(r, c)) pixels.push_back(r * mask.cols + c);
    constexpr std::size_t kChunk = 64;
    std::atomic<std::size_t> next{0};
    auto work = [&] {
        for (;;) {
            const std::size_t begin = next.fetch_add(kChunk);
            if (begin >= pixels.size()) return;
            for (std::size_t k = begin; k < std::min(pixels.size(), begin + kChunk); ++k) {
                const int r = pixels[k] / mask.cols, c = pixels[k] % mask.cols;
                out.at<float>(r, c) = supersamplePixel(sampler, c, r, mask.cols, o.samplesPerSide, o.seed);
            }
        }
    };
    const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
    const std::size_t wanted = o.threads > 0 ? static_cast<std::size_t>(o.threads) : hardware;
    const std::size_t threads = std::clamp<std::size_t>(pixels.size() / kChunk, 1, wanted);
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
}

/// The unmarked pixels: 4-connected regions that no boundary crosses, each
/// decided by one point test at the centre of its first pixel.
void fillUnmarkedRegions(cv::Mat& out, const cv::Mat1b& mask, const Sampler& sampler)
{
    cv::Mat1b unmarked = mask == 0;
    cv::Mat1i labels;
    const int n = cv::connectedComponents(unmarked, labels, 4, CV_32S);
    std::vector<float> value(static_cast<std::size_t>(n), -1.0f);
    for (int r = 0; r < labels.rows; ++r)
        for (int c = 0; c < labels.cols; ++c) {
            const int l = labels(r, c);
            if (l == 0) continue;
            float& v = value[static_cast<std::size_t>(l)];
            if (v < 0) {
                int hint = -1;
                v = sampler.covered(c, r, hint) ? 1.0f : 0.0f;
            }
            out.at<float>(r, c) = v;
        }
}

} // namespace

void ExactRenderOptions::validate() const
{
    if (samplesPerSide < 1 || samplesPerSide > 256)
        throw std::invalid_argument("samplesPerSide: must lie in 1..256, is " + std::to_string(samplesPerSide));
    if (!(nearPlaneMm > 0) || !std::isfinite(nearPlaneMm))
        throw std::invalid_argument("nearPlaneMm: must be positive and finite");
    if (threads < 0) throw std::invalid_argument("threads: must be >= 0 (0 = one per hardware thread)");
}

cv::Mat exactCoverage(const std::vector<hg::model::TriangleMesh>& meshes, const CameraModel& camera,
                      const ExactRenderOptions& options)
{
    options.validate();
    camera.intrinsics().validate();
    const PlaneMap map(camera);
    const PlaneScene scene = projectMeshes(meshes, camera, map, options.nearPlaneMm);

    std::vector<PlaneTriangle> triangles;
    PlaneBox reach;
    for (const auto& t : scene.triangles) {
        PlaneTriangle pt;
        if (!makePlaneTriangle(scene.points[t[0]], scene.points[t[1]], scene.points[t[2]], pt)) continue;
        for (const Vec2& p : pt.v) reach.add(p);
        triangles.push_back(pt);
    }
    const PlaneBox extent = imageExtent(camera, map);
    const PlaneBox seen = reach.intersected(extent);
    const auto& K = camera.intrinsics().K;
    const TriangleGrid grid(std::move(triangles), seen.empty() ? extent : seen, kCellPx / std::max(K(0, 0), K(1, 1)));
    const Sampler sampler{map, grid};

    const cv::Size size = camera.imageSize();
    cv::Mat1b mask(size, options.sampleEveryPixel ? 1 : 0);
    if (!options.sampleEveryPixel)
        for (const auto& [a, b] : contourEdges(scene))
            markContourEdge(mask, scene.points[a], scene.points[b], map, extent);

    cv::Mat out = cv::Mat::zeros(size, CV_32FC1);
    fillUnmarkedRegions(out, mask, sampler);
    supersampleMarked(out, mask, sampler, options);
    return out;
}

cv::Mat shadeExact(const cv::Mat& coverage, const ExactShading& s)
{
    if (coverage.type() != CV_32FC1) throw std::invalid_argument("shadeExact: coverage must be CV_32FC1");
    if (!std::isfinite(s.background) || !std::isfinite(s.object))
        throw std::invalid_argument("shadeExact: background and object levels must be finite");
    if (!(s.blurSigmaPx >= 0) || !std::isfinite(s.blurSigmaPx) || !(s.noiseSigma >= 0) || !std::isfinite(s.noiseSigma))
        throw std::invalid_argument("shadeExact: blurSigmaPx and noiseSigma must be finite and >= 0");
    cv::Mat1d grey(coverage.size());
    for (int r = 0; r < grey.rows; ++r)
        for (int c = 0; c < grey.cols; ++c)
            grey(r, c) = s.background + (s.object - s.background) * static_cast<double>(coverage.at<float>(r, c));
    if (s.blurSigmaPx > 0) cv::GaussianBlur(grey, grey, cv::Size(), s.blurSigmaPx, s.blurSigmaPx, cv::BORDER_REPLICATE);
    std::mt19937_64 rng(s.seed);
    std::normal_distribution<double> noise(0.0, s.noiseSigma > 0 ? s.noiseSigma : 1.0);
    cv::Mat1b out(coverage.size());
    for (int r = 0; r < grey.rows; ++r)
        for (int c = 0; c < grey.cols; ++c) {
            const double v = grey(r, c) + (s.noiseSigma > 0 ? noise(rng) : 0.0);
            out(r, c) = static_cast<unsigned char>(std::clamp(std::round(v), 0.0, 255.0));
        }
    return out;
}

cv::Mat lineFrame(const std::vector<hg::model::TriangleMesh>& meshes, const hg::geometry::CameraModel& camera,
                  std::uint64_t seed, std::uint64_t view)
{
    ExactRenderOptions r;
    r.samplesPerSide = 32;
    r.seed = seed * 100 + view;
    ExactShading s;
    s.blurSigmaPx = 0.6;
    s.noiseSigma = 1.5;
    s.seed = seed * 100 + 50 + view;
    return shadeExact(exactCoverage(meshes, camera, r), s);
}

} // namespace hgtest
