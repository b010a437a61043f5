#include "hullgauge/inspect/voxel_test.h"

#include "hullgauge/common/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

namespace hg::inspect {
namespace {

// Internally pixel coordinates are shifted by +0.5 so that pixel (c, r) covers
// [c, c+1] x [r, r+1]; a region's local frame subtracts its top-left corner.

/// A convex polygon on the stack. A footprint has at most 6 outline vertices
/// and each clipping line adds at most one: 4 frame/region sides plus the 2
/// lines of a pixel row give at most 12. The voxel test runs tens of thousands
/// of times per inspection, so it must not touch the heap.
struct Poly {
    static constexpr int kMax = 32;
    std::array<Vec2, kMax> v;
    int n = 0;
    void clear() { n = 0; }
    void push(const Vec2& p) { v[static_cast<std::size_t>(n++)] = p; }
    const Vec2& operator[](int i) const { return v[static_cast<std::size_t>(i)]; }
    Vec2& operator[](int i) { return v[static_cast<std::size_t>(i)]; }
};

double polygonArea(const Poly& p)
{
    double a = 0.0;
    for (int i = 0; i < p.n; ++i) {
        const Vec2& u = p[i];
        const Vec2& w = p[i + 1 == p.n ? 0 : i + 1];
        a += u.x() * w.y() - w.x() * u.y();
    }
    return 0.5 * std::abs(a);
}

/// Sutherland–Hodgman against the half-plane sign * (coord(axis) - bound) >= 0.
void clipHalfPlane(const Poly& in, Poly& out, int axis, double bound, double sign)
{
    out.clear();
    for (int i = 0; i < in.n; ++i) {
        const Vec2& a = in[i];
        const Vec2& b = in[i + 1 == in.n ? 0 : i + 1];
        const double da = sign * (a[axis] - bound);
        const double db = sign * (b[axis] - bound);
        if (da >= 0) out.push(a);
        if ((da >= 0) != (db >= 0)) {
            const double t = da / (da - db);
            Vec2 x = a + t * (b - a);
            x[axis] = bound; // exact on the clip line
            out.push(x);
        }
    }
}

void clipToRect(Poly& poly, double x0, double y0, double x1, double y1)
{
    Poly tmp;
    clipHalfPlane(poly, tmp, 0, x0, 1.0);
    clipHalfPlane(tmp, poly, 0, x1, -1.0);
    clipHalfPlane(poly, tmp, 1, y0, 1.0);
    clipHalfPlane(tmp, poly, 1, y1, -1.0);
}

/// Vertical chord length of a convex polygon at abscissa x.
double chordAt(const Poly& p, double x)
{
    double lo = 1e300, hi = -1e300;
    for (int i = 0; i < p.n; ++i) {
        const Vec2& a = p[i];
        const Vec2& b = p[i + 1 == p.n ? 0 : i + 1];
        const double xmin = std::min(a.x(), b.x()), xmax = std::max(a.x(), b.x());
        if (x < xmin || x > xmax || xmax - xmin <= 0.0) continue;
        const double y = a.y() + (x - a.x()) * (b.y() - a.y()) / (b.x() - a.x());
        lo = std::min(lo, y);
        hi = std::max(hi, y);
    }
    return hi > lo ? hi - lo : 0.0;
}

/// Background area of a convex polygon in region-local shifted coordinates,
/// already clipped to [0, width] x [0, height].
double localBackgroundArea(const Poly& poly, const SilhouetteIndex::Region& reg, double stopAt)
{
    if (poly.n < 3) return 0.0;
    double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
    for (int i = 0; i < poly.n; ++i) {
        xmin = std::min(xmin, poly[i].x());
        xmax = std::max(xmax, poly[i].x());
        ymin = std::min(ymin, poly[i].y());
        ymax = std::max(ymax, poly[i].y());
    }
    const int h = reg.rect.height, w = reg.rect.width;
    const int r0 = std::clamp(static_cast<int>(std::floor(ymin)), 0, h - 1);
    const int r1 = std::clamp(static_cast<int>(std::ceil(ymax)) - 1, 0, h - 1);
    // Most footprints lie wholly in object or wholly in background: when every
    // pixel of the footprint's bounding box has the same label, the answer is
    // 0 or the whole area, exactly, without integrating row by row.
    {
        const int c0 = std::clamp(static_cast<int>(std::floor(xmin)), 0, w - 1);
        const int c1 = std::clamp(static_cast<int>(std::ceil(xmax)) - 1, 0, w - 1);
        std::int64_t bgPixels = 0;
        for (int r = r0; r <= r1; ++r) {
            const std::int32_t* cnt = reg.count.data() + static_cast<std::size_t>(r) * reg.stride;
            bgPixels += cnt[c1 + 1] - cnt[c0];
        }
        if (bgPixels == 0) return 0.0;
        if (bgPixels == static_cast<std::int64_t>(r1 - r0 + 1) * (c1 - c0 + 1)) return polygonArea(poly);
    }
    double bg = 0.0;
    Poly a, b;
    std::array<double, Poly::kMax> xs{};
    for (int r = r0; r <= r1 && bg < stopAt; ++r) {
        clipHalfPlane(poly, a, 1, static_cast<double>(r), 1.0);
        clipHalfPlane(a, b, 1, static_cast<double>(r + 1), -1.0);
        if (b.n < 3) continue;
        const std::int32_t* cnt = reg.count.data() + static_cast<std::size_t>(r) * reg.stride;
        const std::int64_t* mom = reg.moment.data() + static_cast<std::size_t>(r) * reg.stride;
        auto bgAt = [&](int c) { return static_cast<double>(cnt[c + 1] - cnt[c]); };
        for (int k = 0; k < b.n; ++k) xs[static_cast<std::size_t>(k)] = b[k].x();
        std::sort(xs.begin(), xs.begin() + b.n);
        for (int k = 0; k + 1 < b.n; ++k) {
            const double xa = xs[static_cast<std::size_t>(k)], xb = xs[static_cast<std::size_t>(k) + 1];
            if (xb - xa <= 1e-12) continue;
            // w(x) = alpha + beta x is linear between consecutive vertex abscissae.
            const double x1 = xa + (xb - xa) / 3.0, x2 = xa + 2.0 * (xb - xa) / 3.0;
            const double w1 = chordAt(b, x1), w2 = chordAt(b, x2);
            const double beta = (w2 - w1) / (x2 - x1);
            const double alpha = w1 - beta * x1;
            auto integral = [&](double u, double v) { return (v - u) * (alpha + beta * 0.5 * (u + v)); };
            const int ca = std::clamp(static_cast<int>(std::floor(xa)), 0, w - 1);
            int cb = static_cast<int>(std::floor(xb));
            if (static_cast<double>(cb) >= xb) --cb; // xb on a pixel edge ends in the pixel before
            cb = std::clamp(cb, 0, w - 1);
            if (ca == cb) {
                bg += bgAt(ca) * integral(xa, xb);
                continue;
            }
            bg += bgAt(ca) * integral(xa, ca + 1.0);
            if (cb > ca + 1) {
                // Whole pixels ca+1 .. cb-1: Σ b_c ∫_c^{c+1} w = alpha·Σb + beta·Σ b_c (c + 1/2).
                const double s0 = static_cast<double>(cnt[cb] - cnt[ca + 1]);
                const double s1 = static_cast<double>(mom[cb] - mom[ca + 1]);
                bg += alpha * s0 + beta * (s1 + 0.5 * s0);
            }
            bg += bgAt(cb) * integral(static_cast<double>(cb), xb);
        }
    }
    return bg;
}

/// Andrew's monotone chain over pts[0..n) (sorted in place) into `hull`
/// (counter-clockwise in pixel coordinates, collinear points dropped); returns
/// the vertex count. `hull` needs room for 2n points.
int monotoneChain(Vec2* pts, int n, Vec2* hull)
{
    std::sort(pts, pts + n,
              [](const Vec2& a, const Vec2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
    if (n < 3) {
        std::copy(pts, pts + n, hull);
        return n;
    }
    auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
        return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
    };
    int k = 0;
    for (int i = 0; i < n; ++i) {
        while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0) --k;
        hull[k++] = pts[i];
    }
    for (int i = n - 1, t = k + 1; i-- > 0;) {
        while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0) --k;
        hull[k++] = pts[i];
    }
    return k - 1;
}

} // namespace

bool SilhouetteIndex::Region::background(int frameRow, int frameCol) const
{
    const int r = frameRow - rect.y, c = frameCol - rect.x;
    const std::size_t base = static_cast<std::size_t>(r) * stride;
    return count[base + c + 1] != count[base + c];
}

void SilhouetteIndex::addRegion(const cv::Rect& rect, const cv::Mat& silhouette)
{
    if (silhouette.type() != CV_8UC1 || silhouette.rows != rect.height || silhouette.cols != rect.width)
        throw ArgumentError("silhouette region must be CV_8UC1 of the region's size " + std::to_string(rect.width) +
                            "x" + std::to_string(rect.height) + ", found " + cv::typeToString(silhouette.type()) + " " +
                            std::to_string(silhouette.cols) + "x" + std::to_string(silhouette.rows));
    if ((rect & cv::Rect(0, 0, frameSize_.width, frameSize_.height)) != rect)
        throw ArgumentError("silhouette region " + std::to_string(rect.width) + "x" + std::to_string(rect.height) +
                            "+" + std::to_string(rect.x) + "+" + std::to_string(rect.y) + " is outside the " +
                            std::to_string(frameSize_.width) + "x" + std::to_string(frameSize_.height) + " frame");
    Region reg;
    reg.rect = rect;
    reg.stride = rect.width + 1;
    reg.count.assign(static_cast<std::size_t>(rect.height) * reg.stride, 0);
    reg.moment.assign(reg.count.size(), 0);
    for (int r = 0; r < rect.height; ++r) {
        const auto* s = silhouette.ptr<std::uint8_t>(r);
        std::int32_t* cnt = reg.count.data() + static_cast<std::size_t>(r) * reg.stride;
        std::int64_t* mom = reg.moment.data() + static_cast<std::size_t>(r) * reg.stride;
        for (int c = 0; c < rect.width; ++c) {
            const int bgPixel = s[c] == 0 ? 1 : 0;
            cnt[c + 1] = cnt[c] + bgPixel;
            mom[c + 1] = mom[c] + static_cast<std::int64_t>(bgPixel) * c;
        }
    }
    regions_.push_back(std::move(reg));
}

SilhouetteIndex SilhouetteIndex::fromSilhouette(const cv::Mat& silhouette)
{
    SilhouetteIndex idx(silhouette.size());
    idx.addRegion(cv::Rect(0, 0, silhouette.cols, silhouette.rows), silhouette);
    return idx;
}

const SilhouetteIndex::Region* SilhouetteIndex::regionContaining(const cv::Rect& rect) const
{
    for (const Region& r : regions_)
        if ((r.rect & rect) == rect) return &r;
    return nullptr;
}

const SilhouetteIndex::Region* SilhouetteIndex::regionAt(int col, int row) const
{
    for (const Region& r : regions_)
        if (r.rect.contains(cv::Point(col, row))) return &r;
    return nullptr;
}

std::vector<Vec2> convexHull(std::vector<Vec2> pts)
{
    std::vector<Vec2> hull(2 * pts.size() + 1);
    hull.resize(static_cast<std::size_t>(monotoneChain(pts.data(), static_cast<int>(pts.size()), hull.data())));
    return hull;
}

double backgroundArea(const std::vector<Vec2>& polygon, const SilhouetteIndex::Region& region, double stopAt)
{
    // Two row clips add at most two vertices to the convex polygon.
    if (polygon.size() + 2 > static_cast<std::size_t>(Poly::kMax))
        throw ArgumentError("backgroundArea: polygon has more than " + std::to_string(Poly::kMax - 2) +
                            " vertices, found " + std::to_string(polygon.size()));
    Poly local;
    for (const Vec2& v : polygon) local.push(Vec2(v.x() + 0.5 - region.rect.x, v.y() + 0.5 - region.rect.y));
    return localBackgroundArea(local, region, stopAt);
}

namespace {

/// Background pixels of the pixel rectangle [c0, c1] x [r0, r1] (region-local)
/// from the per-row prefix counts.
std::int64_t backgroundPixels(const SilhouetteIndex::Region& reg, int c0, int c1, int r0, int r1)
{
    std::int64_t n = 0;
    for (int r = r0; r <= r1; ++r) {
        const std::int32_t* cnt = reg.count.data() + static_cast<std::size_t>(r) * reg.stride;
        n += cnt[c1 + 1] - cnt[c0];
    }
    return n;
}

/// The footprint's pixel bounding box (frame pixels) from shifted corners.
struct CornerBounds {
    double xmin = 1e300, ymin = 1e300, xmax = -1e300, ymax = -1e300;
    explicit CornerBounds(const std::array<Vec2, 8>& corners)
    {
        for (const Vec2& c : corners) {
            xmin = std::min(xmin, c.x());
            xmax = std::max(xmax, c.x());
            ymin = std::min(ymin, c.y());
            ymax = std::max(ymax, c.y());
        }
    }
    /// The pixels the footprint's bounding box touches (a pixel is touched
    /// from its low edge up to, not including, its high edge).
    cv::Rect pixels() const
    {
        const int c0 = static_cast<int>(std::floor(xmin)), r0 = static_cast<int>(std::floor(ymin));
        return {c0, r0, static_cast<int>(std::floor(xmax)) - c0 + 1, static_cast<int>(std::floor(ymax)) - r0 + 1};
    }
};

/// The one label of every pixel under the footprint's bounding box — 1 all
/// background, 0 all object — the exact answer without the outline; -1 when
/// the box holds both.
int uniformLabel(const SilhouetteIndex::Region& reg, const CornerBounds& b)
{
    const int c0 = static_cast<int>(std::floor(b.xmin)) - reg.rect.x;
    const int r0 = static_cast<int>(std::floor(b.ymin)) - reg.rect.y;
    const int c1 = std::max(c0, static_cast<int>(std::ceil(b.xmax)) - 1 - reg.rect.x);
    const int r1 = std::max(r0, static_cast<int>(std::ceil(b.ymax)) - 1 - reg.rect.y);
    const std::int64_t bg = backgroundPixels(reg, c0, c1, r0, r1);
    if (bg == 0) return 0;
    if (bg == static_cast<std::int64_t>(r1 - r0 + 1) * (c1 - c0 + 1)) return 1;
    return -1;
}

} // namespace

VoxelTester::VoxelTester(const std::vector<SilhouetteView>* views, VoxelTestMethod method)
    : views_(views), method_(method)
{
    state_.resize(views->size());
    for (std::size_t v = 0; v < views->size(); ++v)
        state_[v].undistorted = !(*views)[v].camera.intrinsics().hasDistortion();
}

// The 8 corners of `voxel` in pixel coordinates shifted by +0.5 (pixel (c, r)
// covers [c, c+1] x [r, r+1]); false when one lies behind the camera. The
// corners in the camera frame are the low corner plus the box's edges turned
// into the camera (three vectors), not 8 full transforms; without distortion
// the projection is done here, all 8 corners at once: pinhole (x/z, y/z) or
// telecentric (x, y), the footprint the same hull of the corners' images
// either way (docs/telecentric.md).
bool VoxelTester::projectCorners(std::size_t viewIndex, const Box3& voxel, std::array<Vec2, 8>& corners) const
{
    using Corners = Eigen::Array<double, 8, 1>;
    // Eigen's corner order: bit 0 = x, bit 1 = y, bit 2 = z.
    static const Corners bx = (Corners() << 0, 1, 0, 1, 0, 1, 0, 1).finished();
    static const Corners by = (Corners() << 0, 0, 1, 1, 0, 0, 1, 1).finished();
    static const Corners bz = (Corners() << 0, 0, 0, 0, 1, 1, 1, 1).finished();
    const geometry::CameraModel& camera = (*views_)[viewIndex].camera;
    const geometry::RigidTransform& T = camera.cameraFromPart();
    const Vec3 lo = T.apply(voxel.min());
    const Vec3 size = voxel.sizes();
    const Vec3 ex = T.R.col(0) * size.x(), ey = T.R.col(1) * size.y(), ez = T.R.col(2) * size.z();
    const Corners X = lo.x() + bx * ex.x() + by * ey.x() + bz * ez.x();
    const Corners Y = lo.y() + bx * ex.y() + by * ey.y() + bz * ez.y();
    const Corners Z = lo.z() + bx * ex.z() + by * ey.z() + bz * ez.z();
    for (Eigen::Index k = 0; k < 8; ++k)
        if (!camera.depthInFront(Z[k])) return false;
    if (state_[viewIndex].undistorted) {
        const geometry::Mat3& K = camera.intrinsics().K;
        const bool telecentric = camera.isTelecentric();
        const Corners x = telecentric ? X : Corners(X / Z), y = telecentric ? Y : Corners(Y / Z);
        const Corners u = K(0, 0) * x + K(0, 1) * y + (K(0, 2) + 0.5), v = K(1, 1) * y + (K(1, 2) + 0.5);
        for (std::size_t i = 0; i < 8; ++i)
            corners[i] = Vec2(u[static_cast<Eigen::Index>(i)], v[static_cast<Eigen::Index>(i)]);
        return true;
    }
    for (std::size_t i = 0; i < 8; ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        const Vec2 px = *camera.projectCameraPoint(Vec3(X[k], Y[k], Z[k]));
        corners[i] = Vec2(px.x() + 0.5, px.y() + 0.5);
    }
    return true;
}

const SilhouetteIndex::Region* VoxelTester::regionContaining(std::size_t viewIndex, const cv::Rect& rect) const
{
    const ViewState& s = state_[viewIndex];
    if (s.lastRegion && (s.lastRegion->rect & rect) == rect) return s.lastRegion;
    const SilhouetteIndex::Region* r = (*views_)[viewIndex].index.regionContaining(rect);
    if (r) s.lastRegion = r;
    return r;
}

FootprintMeasure VoxelTester::measure(const Box3& voxel, std::size_t viewIndex, double stopFraction) const
{
    FootprintMeasure m;
    std::array<Vec2, 8> corners;
    if (!projectCorners(viewIndex, voxel, corners)) return m;
    m.inFront = true;
    measureFootprint(corners, viewIndex, stopFraction, m);
    return m;
}

void VoxelTester::measureFootprint(std::array<Vec2, 8>& corners, std::size_t viewIndex, double stopFraction,
                                   FootprintMeasure& m) const
{
    const SilhouetteView& view = (*views_)[viewIndex];
    const CornerBounds bounds(corners);
    Poly outline;
    outline.n = monotoneChain(corners.data(), 8, outline.v.data());
    m.outlineVertices = outline.n;
    m.area = polygonArea(outline);
    if (outline.n < 3 || m.area <= 0.0) return;
    // The region that holds the footprint (by its bounding box); what lies
    // outside that region (or the frame) is unknown.
    const SilhouetteIndex::Region* reg = regionContaining(viewIndex, bounds.pixels());
    if (reg) {
        // Most footprints lie wholly in object or wholly in background.
        const int uniform = uniformLabel(*reg, bounds);
        if (uniform >= 0) {
            m.background = uniform == 1 ? m.area : 0.0;
            return;
        }
    } else {
        reg = view.index.regionAt(static_cast<int>(std::floor(0.5 * (bounds.xmin + bounds.xmax))),
                                  static_cast<int>(std::floor(0.5 * (bounds.ymin + bounds.ymax))));
    }
    if (!reg) {
        m.unknown = m.area;
        return;
    }
    for (int i = 0; i < outline.n; ++i) outline[i] -= Vec2(reg->rect.x, reg->rect.y);
    clipToRect(outline, 0.0, 0.0, reg->rect.width, reg->rect.height);
    const double inside = outline.n >= 3 ? polygonArea(outline) : 0.0;
    m.unknown = std::max(0.0, m.area - inside);
    if (inside > 0.0) m.background = localBackgroundArea(outline, *reg, stopFraction * m.area);
}

// One view's share of the 50 % rule. A footprint whose bounding box lies in a
// region with one label throughout decides without its outline: all
// background is void, all object (and nothing unknown) is object — the
// common case, as most voxels the traversal tests lie clear of the outline.
// Its area is positive without computing it: a box with volume, wholly in
// front of the camera, projects onto a set with an interior.
VoxelTester::Vote VoxelTester::vote(const Box3& voxel, std::size_t viewIndex) const
{
    std::array<Vec2, 8> corners;
    if (!projectCorners(viewIndex, voxel, corners)) return Vote::None;
    const CornerBounds bounds(corners);
    if (const SilhouetteIndex::Region* reg = regionContaining(viewIndex, bounds.pixels())) {
        const int uniform = uniformLabel(*reg, bounds);
        if (uniform >= 0 && voxel.sizes().minCoeff() > 0.0) return uniform == 1 ? Vote::Void : Vote::Object;
    }
    // The relative 1e-9 keeps "exactly 50 %" void in spite of rounding in the area sums.
    FootprintMeasure m;
    m.inFront = true;
    measureFootprint(corners, viewIndex, 0.5, m);
    if (m.area <= 0.0) return Vote::None;
    const double half = 0.5 * m.area * (1.0 - 1e-9);
    if (m.background >= half) return Vote::Void;
    return m.background + m.unknown < half ? Vote::Object : Vote::None;
}

VoxelLabel VoxelTester::centrePointLabel(const Box3& voxel, std::size_t viewIndex) const
{
    const SilhouetteView& view = (*views_)[viewIndex];
    const auto px = view.camera.project(voxel.center());
    if (!px) return VoxelLabel::Undecided;
    const int c = static_cast<int>(std::floor(px->x() + 0.5)), r = static_cast<int>(std::floor(px->y() + 0.5));
    const SilhouetteIndex::Region* reg = view.index.regionAt(c, r);
    if (!reg) return VoxelLabel::Undecided;
    return reg->background(r, c) ? VoxelLabel::Void : VoxelLabel::Object;
}

VoxelLabel VoxelTester::classify(const Box3& voxel) const
{
    ++tests_;
    bool objectDecided = false;
    for (std::size_t v = 0; v < views_->size(); ++v) {
        if (method_ == VoxelTestMethod::CentrePoint) {
            const VoxelLabel l = centrePointLabel(voxel, v);
            if (l == VoxelLabel::Void) return VoxelLabel::Void;
            objectDecided = objectDecided || l == VoxelLabel::Object;
            continue;
        }
        // 50 % rule (3.3.4, Rule 1): half the footprint in background in one
        // view proves the voxel void.
        const Vote vote = this->vote(voxel, v);
        if (vote == Vote::Void) return VoxelLabel::Void;
        objectDecided = objectDecided || vote == Vote::Object;
    }
    return objectDecided ? VoxelLabel::Object : VoxelLabel::Undecided;
}

} // namespace hg::inspect
