// Station health from the frames a cycle already grabbed (docs/health.md;
// dissertation 4.4.2 on what the grey levels across an edge carry, 4.4.1 on
// the depth of field a lens out of focus leaves).
#include "hullgauge/vision/health.h"

#include "hullgauge/common/error.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <utility>

namespace hg::vision {
namespace {

using Vec2 = Eigen::Vector2d;

// 2·Φ⁻¹(0.9): the 10–90 % width of a step blurred by a Gaussian of σ = 1 px.
constexpr double kTenNinety = 2.5631031310892007;
// A profile read by bilinear interpolation is the pixels' profile smoothed by
// the unit triangle, variance 1/6 px² (docs/health.md, "Figures").
constexpr double kInterpolationVariance = 1.0 / 6.0;
// 1.4826 · MAD is σ for a Gaussian; a difference of two pixels has √2 σ.
constexpr double kMadToSigma = 1.4826;

// Background samples per view, each with the pixels kClearPx either side in
// its row and in its column also on the background side of the threshold
// (the fringe of an edge running along the row passes a check along the row
// only: docs/health.md, "Background samples"); kept above
// kRatioCut of the view's median (docs/health.md, "Figures"). The grid's rows
// lie kRowsApart times further apart than its columns: a frame is read by
// rows, and a row's samples share its cache lines (docs/health.md, "Cost").
constexpr int kSamplesPerView = 256, kRowsApart = 4, kClearPx = 4;
constexpr double kRatioCut = 0.6;
// Uniformity zones about kZonePx square; a zone with fewer samples in a cycle
// is not judged (the worst of many zones of few samples would measure the
// noise). The dust survey takes a zone's level from kMinLocalSamples of the
// view, else of the cycle so far, else the view's median.
constexpr int kZonePx = 128, kMinZoneSamples = 16, kMinLocalSamples = 3;

// The dust survey: the bands' height, the margin read around what is
// examined, the largest speck, how far below the local backlight a speck
// lies, and how near a speck of the reference must be to be the same.
constexpr int kBandRows = 32, kSpeckMargin = 8, kSpeckMaxArea = 30, kSpeckMaxSide = 8;
constexpr double kSpeckMinDepth = 0.10, kSpeckNoiseK = 6.0, kSpeckMatchPx = 2.0;

// The edge profile: the threshold crossing searched over ±kSearchPx in whole
// steps, the profile read ±kProfilePx about it every kProfileStep, the two
// levels from the outer kLevelSpan of either side; as vision::findEdge, a step
// under 3 % of full scale is no edge.
constexpr int kSearchPx = 4;
constexpr double kProfilePx = 7.0, kProfileStep = 0.25, kLevelSpan = 1.5, kMinContrast = 0.03;
// findEdge's integral window is 6 px wide, its levels the means of reads 3,
// 3.5, 4 and 4.5 px beyond the crossing (edge.h, edge.cpp).
constexpr double kFindEdgeHalfWindow = 3.0;
constexpr std::array<double, 4> kFindEdgeLevelsAt = {3.0, 3.5, 4.0, 4.5};

double fullScale(const cv::Mat& grey)
{
    return grey.depth() == CV_8U ? 255.0 : 65535.0;
}

int greyAt(const cv::Mat& grey, int row, int col)
{
    return grey.depth() == CV_8U ? grey.at<std::uint8_t>(row, col) : grey.at<std::uint16_t>(row, col);
}

double medianOf(std::vector<double>& values)
{
    if (values.empty()) return kNoFigure;
    const std::size_t half = values.size() / 2;
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(half), values.end());
    if (values.size() % 2 == 1) return values[half];
    const double below = *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(half));
    return 0.5 * (below + values[half]);
}

// Ratios to the reference are counted in bins of 1/1024 up to 4 (the last bin
// holds anything brighter); |differences| of grey levels in bins of one level
// (8-bit) or of 16 (16-bit frames: a 12-bit sensor's step), the whole range.
// Medians from counts cost one pass and no sorting (docs/health.md, "Cost").
constexpr int kRatioBins = 4096;
constexpr double kRatioBinWidth = 1.0 / 1024.0;

int stepQuantum(double full)
{
    return full > 255.0 ? 16 : 1;
}

std::size_t stepBinCount(double full)
{
    // Rounded to the nearest quantum, the largest difference falls one bin beyond full / quantum.
    return static_cast<std::size_t>(full) / static_cast<std::size_t>(stepQuantum(full)) + 2;
}

std::size_t ratioBin(double ratio)
{
    return static_cast<std::size_t>(std::min(ratio / kRatioBinWidth, kRatioBins - 1.0));
}

// A |difference| of grey levels to its bin: rounded, bins centred on whole quanta.
std::size_t stepBin(int step, int quantum)
{
    return static_cast<std::size_t>((step + quantum / 2) / quantum);
}

// The median of the `total` values counted in `bins`, in bin units, placed
// within its bin by the share of the values below it. Bin k spans [k, k + 1)
// or, `centred` on whole numbers, [k − ½, k + ½) and the first [0, ½): the
// plain median of |differences| of 8-bit grey levels jumps by whole levels,
// this one follows σ smoothly down to the quantisation.
double binnedMedian(const std::vector<int>& bins, long total, bool centred, std::size_t first = 0)
{
    if (total <= 0) return kNoFigure;
    const double half = 0.5 * static_cast<double>(total);
    long below = 0;
    // Integers compared (below + n > total / 2 ⇔ 2 (below + n) > total), from
    // the first bin that can hold anything: a per-view histogram of 4096 bins
    // is otherwise walked from 0 on every view.
    for (std::size_t k = first; k < bins.size(); ++k) {
        if (2 * (below + bins[k]) > total) {
            const double lower = !centred ? static_cast<double>(k) : k == 0 ? 0.0 : k - 0.5;
            const double width = centred && k == 0 ? 0.5 : 1.0;
            return lower + width * (half - static_cast<double>(below)) / bins[k];
        }
        below += bins[k];
    }
    return static_cast<double>(bins.size());
}

// Grey-level σ from the |differences| of disjoint pairs of neighbouring pixels
// (robust: a speck or an edge among them moves the median little), never
// below the quantisation's 1/√12.
double noiseOf(const std::vector<int>& stepBins, long total, int quantum)
{
    const double mad = binnedMedian(stepBins, total, true) * quantum;
    if (std::isnan(mad)) return kNoFigure;
    return std::max(kMadToSigma * mad / std::sqrt(2.0), 1.0 / std::sqrt(12.0));
}

// --- The reference's level ---------------------------------------------------

// One axis of the interpolation between block centres: the first block of
// the pair and the weight of the second, extrapolated linearly half a block
// beyond the outer centres (a vignetted panel keeps falling towards the border).
std::pair<int, double> blockPair(double px, int cell, int blocks)
{
    if (blocks < 2) return {0, 0.0};
    const double at = (px + 0.5) / cell - 0.5;
    const int first = std::clamp(static_cast<int>(std::floor(at)), 0, blocks - 2);
    return {first, at - first};
}

// The reference's level along sensor row y (fraction of full scale): bilinear
// between the centres of its blocks, whose levels are their means.
class LevelRow {
  public:
    LevelRow() = default;
    LevelRow(const cv::Mat& level, int cell, double y) : cell_(cell), cols_(level.cols)
    {
        const auto [r, down] = blockPair(y, cell, level.rows);
        top_ = level.ptr<float>(r);
        bottom_ = level.ptr<float>(std::min(r + 1, level.rows - 1));
        down_ = down;
    }

    double at(double x) const
    {
        const auto [c, across] = blockPair(x, cell_, cols_);
        const int c1 = std::min(c + 1, cols_ - 1);
        return (1.0 - down_) * ((1.0 - across) * top_[c] + across * top_[c1]) +
               down_ * ((1.0 - across) * bottom_[c] + across * bottom_[c1]);
    }

  private:
    int cell_ = 1, cols_ = 1;
    const float* top_ = nullptr;
    const float* bottom_ = nullptr;
    double down_ = 0.0;
};

// The lowest level the interpolation gives within block (bx, by): at one of
// its corners or where it crosses a line through the block centres.
double lowestLevelIn(const cv::Mat& level, int cell, cv::Size sensor, int bx, int by)
{
    const int x0 = bx * cell, y0 = by * cell;
    const int x1 = std::min(x0 + cell, sensor.width) - 1, y1 = std::min(y0 + cell, sensor.height) - 1;
    double lowest = std::numeric_limits<double>::infinity();
    for (double x : {double(x0), 0.5 * (x0 + x1), double(x1)})
        for (double y : {double(y0), 0.5 * (y0 + y1), double(y1)})
            lowest = std::min(lowest, LevelRow(level, cell, y).at(x));
    return lowest;
}

// --- Dark specks -------------------------------------------------------------

// A run of dark pixels in one row (sensor pixels, x1 inclusive); `parent`
// links runs of one connected set, the root being its first run in raster order.
struct DarkRun {
    int row = 0, x0 = 0, x1 = 0;
    int parent = 0;
};

// A connected set (8-neighbourhood) of dark pixels.
struct DarkSet {
    int area = 0, firstRun = 0;
    int x0 = INT_MAX, x1 = INT_MIN, y0 = INT_MAX, y1 = INT_MIN;
    double sumX = 0.0, sumY = 0.0;
    bool cut = false; ///< touches an edge of what was read that is not the sensor's

    // Small and compact, whole: a speck rather than the part's silhouette or a
    // piece of something cut off by the read.
    bool speck() const { return !cut && area <= kSpeckMaxArea && x1 - x0 < kSpeckMaxSide && y1 - y0 < kSpeckMaxSide; }
    cv::Point2f centroid() const { return {static_cast<float>(sumX / area), static_cast<float>(sumY / area)}; }
};

int rootOf(std::vector<DarkRun>& runs, int i)
{
    while (runs[static_cast<std::size_t>(i)].parent != i) {
        auto& r = runs[static_cast<std::size_t>(i)];
        r.parent = runs[static_cast<std::size_t>(r.parent)].parent;
        i = r.parent;
    }
    return i;
}

void unite(std::vector<DarkRun>& runs, int a, int b)
{
    a = rootOf(runs, a);
    b = rootOf(runs, b);
    // The earlier run becomes the root: a set's root is its first pixel in raster order.
    if (a < b) runs[static_cast<std::size_t>(b)].parent = a;
    if (b < a) runs[static_cast<std::size_t>(a)].parent = b;
}

// Where the blocks' darkness limits are: the blocks `blocks` covers (block
// units), the limit of block (bx, by) at limits[(by − blocks.y)·blocks.width + bx − blocks.x].
template <class Limit> struct DarkLimits {
    int cell = 32;
    cv::Rect blocks;
    std::vector<Limit> limits;
};

// Whether any of `count` pixels lies below `limit` (a loop the compiler vectorises).
template <class Pixel, class Limit> bool anyBelow(const Pixel* pixels, int count, Limit limit)
{
    unsigned below = 0;
    for (int i = 0; i < count; ++i) below |= pixels[i] < limit ? 1u : 0u;
    return below != 0;
}

// The connected sets of the pixels of `scan` (sensor pixels, inside the frame
// at `origin`) darker than their block's limit: runs per row, joined to the
// runs of the row above that touch them (docs/health.md, "Figures": dust).
template <class Pixel, class Limit>
std::vector<DarkSet> darkSets(const cv::Mat& grey, cv::Point origin, const cv::Rect& scan, cv::Size sensor,
                              const DarkLimits<Limit>& dark, std::vector<DarkRun>& runs)
{
    runs.clear();
    std::size_t previous = 0; // the first run of the row above
    for (int y = scan.y; y < scan.y + scan.height; ++y) {
        const Pixel* row = grey.ptr<Pixel>(y - origin.y);
        const Limit* limits =
            &dark.limits[static_cast<std::size_t>((y / dark.cell - dark.blocks.y) * dark.blocks.width)];
        const std::size_t current = runs.size();
        std::size_t above = previous;
        auto close = [&](int x0, int x1) {
            const int index = static_cast<int>(runs.size());
            runs.push_back({y, x0, x1, index});
            while (above < current && runs[above].x1 < x0 - 1) ++above;
            for (std::size_t q = above; q < current && runs[q].x0 <= x1 + 1; ++q)
                unite(runs, static_cast<int>(q), index);
        };
        int start = -1;
        for (int x = scan.x; x < scan.x + scan.width;) {
            const int blockEnd = std::min(scan.x + scan.width, (x / dark.cell + 1) * dark.cell);
            const Limit limit = limits[x / dark.cell - dark.blocks.x];
            // Most of a band is bright backlight: a block's row without a dark pixel is passed at once.
            if (!anyBelow(row + (x - origin.x), blockEnd - x, limit)) {
                if (start >= 0) close(start, x - 1);
                start = -1;
                x = blockEnd;
                continue;
            }
            for (; x < blockEnd; ++x) {
                const bool isDark = row[x - origin.x] < limit;
                if (isDark && start < 0) start = x;
                if (!isDark && start >= 0) {
                    close(start, x - 1);
                    start = -1;
                }
            }
        }
        if (start >= 0) close(start, scan.x + scan.width - 1);
        previous = current;
    }
    std::vector<int> roots(runs.size()), setOf(runs.size(), -1);
    for (std::size_t i = 0; i < runs.size(); ++i) roots[i] = rootOf(runs, static_cast<int>(i));
    std::vector<DarkSet> sets;
    const int right = scan.x + scan.width - 1, bottom = scan.y + scan.height - 1;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const auto root = static_cast<std::size_t>(roots[i]);
        if (setOf[root] < 0) {
            setOf[root] = static_cast<int>(sets.size());
            sets.emplace_back().firstRun = static_cast<int>(root);
        }
        DarkSet& s = sets[static_cast<std::size_t>(setOf[root])];
        const DarkRun& r = runs[i];
        const int length = r.x1 - r.x0 + 1;
        s.area += length;
        s.sumX += length * 0.5 * (r.x0 + r.x1);
        s.sumY += static_cast<double>(length) * r.row;
        s.x0 = std::min(s.x0, r.x0);
        s.x1 = std::max(s.x1, r.x1);
        s.y0 = std::min(s.y0, r.row);
        s.y1 = std::max(s.y1, r.row);
        s.cut = s.cut || (r.x0 == scan.x && scan.x > 0) || (r.x1 == right && right < sensor.width - 1) ||
                (r.row == scan.y && scan.y > 0) || (r.row == bottom && bottom < sensor.height - 1);
        runs[i].parent = setOf[root]; // from here on: the run's set
    }
    return sets;
}

// The blocks a rectangle of sensor pixels covers.
cv::Rect blocksOf(const cv::Rect& pixels, int cell)
{
    const int bx0 = pixels.x / cell, by0 = pixels.y / cell;
    const int bx1 = (pixels.x + pixels.width - 1) / cell, by1 = (pixels.y + pixels.height - 1) / cell;
    return {bx0, by0, bx1 - bx0 + 1, by1 - by0 + 1};
}

// How far below its local backlight `background` (grey levels) a pixel must
// lie to be a speck: 10 %, more where the noise would reach that.
double speckLimit(double background, double noiseGrey)
{
    if (!(background > 0.0)) return 0.0; // no backlight there: nothing is darker
    return background * (1.0 - std::max(kSpeckMinDepth, kSpeckNoiseK * noiseGrey / background));
}

// --- Edge profiles -----------------------------------------------------------

// Bilinear grey levels at sensor positions of a frame that may be a region
// of the sensor; a read off the sensor or outside the region fails (a pixel
// the camera did not send is never guessed: docs/inspection.md, "Frames that are regions").
template <class Pixel> class FrameReader {
  public:
    FrameReader(const cv::Mat& grey, cv::Point origin, cv::Size sensor) : grey_(grey), origin_(origin), sensor_(sensor)
    {
    }

    bool sample(const Vec2& at, double& value) const
    {
        const double x = at.x(), y = at.y();
        if (!(x >= 0.0 && y >= 0.0 && x <= sensor_.width - 1.0 && y <= sensor_.height - 1.0)) return false;
        const int c = std::min(static_cast<int>(x), sensor_.width - 2),
                  r = std::min(static_cast<int>(y), sensor_.height - 2);
        const int u = c - origin_.x, v = r - origin_.y;
        if (u < 0 || v < 0 || u + 1 >= grey_.cols || v + 1 >= grey_.rows) return false;
        const double fx = x - c, fy = y - r;
        const Pixel* top = grey_.ptr<Pixel>(v) + u;
        const Pixel* bottom = grey_.ptr<Pixel>(v + 1) + u;
        value = (1 - fy) * ((1 - fx) * top[0] + fx * top[1]) + fy * ((1 - fx) * bottom[0] + fx * bottom[1]);
        return true;
    }

  private:
    const cv::Mat& grey_;
    cv::Point origin_;
    cv::Size sensor_;
};

struct ProfileRead {
    double widthPx = 0.0;  ///< 10–90 % width of the edge's own profile
    double contrast = 0.0; ///< |background − object|, grey levels
};

// The threshold crossing (object → background going along the normal)
// nearest the probe, from whole steps; NaN without one or off the frame.
template <class Pixel>
double nearestCrossing(const EdgeImage& image, const FrameReader<Pixel>& reader, const Vec2& pixel, const Vec2& normal)
{
    double best = kNoFigure, previous = 0.0;
    for (int k = -kSearchPx; k <= kSearchPx; ++k) {
        double v = 0.0;
        if (!reader.sample(pixel + k * normal, v)) return kNoFigure;
        const double side = image.objectIsDark ? v - image.threshold : image.threshold - v;
        if (k > -kSearchPx && previous <= 0.0 && side > 0.0) {
            const double s = (k - 1) + (-previous) / (side - previous);
            if (!(std::abs(s) >= std::abs(best))) best = s;
        }
        previous = side;
    }
    return best;
}

// The edge profile across a probe (docs/health.md, "Figures": focus,
// contrast): read along the normal, normalised between the object's and the
// background's levels, its 10–90 % width with the interpolation's share taken out.
template <class Pixel>
std::optional<ProfileRead> readProfile(const EdgeImage& image, const FrameReader<Pixel>& reader, const EdgeProbe& probe)
{
    const double length = probe.normal.norm();
    if (!probe.pixel.allFinite() || !std::isfinite(length) || length < 1e-9) return std::nullopt;
    const Vec2 normal = probe.normal / length;
    const double crossing = nearestCrossing(image, reader, probe.pixel, normal);
    if (std::isnan(crossing)) return std::nullopt;
    constexpr int kSamples = static_cast<int>(2.0 * kProfilePx / kProfileStep) + 1;
    constexpr int kLevelSamples = static_cast<int>(kLevelSpan / kProfileStep) + 1;
    std::array<double, kSamples> v{};
    for (int i = 0; i < kSamples; ++i)
        if (!reader.sample(probe.pixel + (crossing - kProfilePx + i * kProfileStep) * normal, v[i]))
            return std::nullopt;
    double object = 0.0, background = 0.0;
    for (int i = 0; i < kLevelSamples; ++i) {
        object += v[i];
        background += v[kSamples - 1 - i];
    }
    object /= kLevelSamples;
    background /= kLevelSamples;
    const double step = background - object, contrast = std::abs(step);
    const auto side = [&](double level) {
        return image.objectIsDark ? level - image.threshold : image.threshold - level;
    };
    // A real step with both levels clearly on their side of the threshold (as findEdge asks).
    if ((image.objectIsDark ? step : -step) < kMinContrast * fullScale(image.grey)) return std::nullopt;
    if (side(object) > -0.25 * contrast || side(background) < 0.25 * contrast) return std::nullopt;
    std::array<double, kSamples> u{}; // 0 on the object, 1 on the background
    for (int i = 0; i < kSamples; ++i) u[i] = (v[i] - object) / step;
    // The 50 % crossing nearest the middle, then outward to 10 % and 90 %.
    int mid = -1;
    for (int i = 0; i + 1 < kSamples; ++i)
        if (u[i] < 0.5 && u[i + 1] >= 0.5 &&
            (mid < 0 || std::abs(2 * i + 1 - kSamples + 1) < std::abs(2 * mid + 1 - kSamples + 1)))
            mid = i;
    if (mid < 0) return std::nullopt;
    int lo = mid;
    while (lo > 0 && u[lo] > 0.1) --lo;
    const double s10 = u[lo] > 0.1 ? 0.0 : lo + (0.1 - u[lo]) / (u[lo + 1] - u[lo]);
    int hi = mid + 1;
    while (hi < kSamples - 1 && u[hi] < 0.9) ++hi;
    const double s90 = u[hi] < 0.9 ? hi : hi - 1 + (0.9 - u[hi - 1]) / (u[hi] - u[hi - 1]);
    const double read = (s90 - s10) * kProfileStep / kTenNinety;
    return ProfileRead{kTenNinety * std::sqrt(std::max(read * read - kInterpolationVariance, 0.0)), contrast};
}

// --- Background samples ------------------------------------------------------

// A background pixel of the grid: its level against the reference (or full
// scale without one), its uniformity zone (-1 without a reference), the
// |differences| of the disjoint pairs (x, x + 1) and (x + 2, x + 3) for the noise.
struct BackgroundSample {
    float ratio = 0.0f;
    int zone = -1;
    std::array<int, 2> steps{};
};

// Where a view's grid lies and what its samples are compared with.
struct BackgroundGrid {
    cv::Rect frame;  ///< the sensor pixels the frame holds
    int step = 2;    ///< px between samples
    cv::Point first; ///< the first sample (sensor px)
    double threshold = 0.0;
    bool objectIsDark = true;
    double full = 255.0;
    const cv::Mat* level = nullptr; ///< the reference's levels, or none
    int cell = 32, zoneSide = 128, zonesAcross = 1;
};

// The grid's background pixels: each and the pixels kClearPx either side in
// its row and its column on the background side of the threshold.
template <class Pixel> void sampleGrid(const cv::Mat& grey, const BackgroundGrid& g, std::vector<BackgroundSample>& out)
{
    const auto background = [&](int v) { return g.objectIsDark ? v > g.threshold : v < g.threshold; };
    const int right = g.frame.x + g.frame.width - kClearPx;
    const int bottom = g.frame.y + g.frame.height - kClearPx;
    for (int y = g.first.y; y < bottom; y += kRowsApart * g.step) {
        const Pixel* row = grey.ptr<Pixel>(y - g.frame.y);
        const Pixel* above = grey.ptr<Pixel>(y - g.frame.y - kClearPx);
        const Pixel* below = grey.ptr<Pixel>(y - g.frame.y + kClearPx);
        const int zoneRow = (y / g.zoneSide) * g.zonesAcross;
        const LevelRow levels = g.level != nullptr ? LevelRow(*g.level, g.cell, y) : LevelRow();
        for (int x = g.first.x; x < right; x += g.step) {
            const Pixel* at = row + (x - g.frame.x);
            const int p = at[0];
            const int column = x - g.frame.x;
            if (!background(p) || !background(at[-kClearPx]) || !background(at[kClearPx]) ||
                !background(above[column]) || !background(below[column]))
                continue;
            BackgroundSample s;
            s.steps = {std::abs(int(at[1]) - p), std::abs(int(at[3]) - int(at[2]))};
            if (g.level == nullptr) {
                s.ratio = static_cast<float>(p / g.full);
            } else {
                const double level = levels.at(x);
                if (!(level > 0.0)) continue;
                s.ratio = static_cast<float>(p / (g.full * level));
                s.zone = zoneRow + x / g.zoneSide;
            }
            out.push_back(s);
        }
    }
}

} // namespace

// --- The reference -----------------------------------------------------------

FlatField buildFlatField(std::span<const cv::Mat> frames, std::int64_t takenUnixMs, int cell)
{
    if (cell < 1) throw ArgumentError("buildFlatField: cell must be at least 1 px, found " + std::to_string(cell));
    if (frames.empty()) throw InputError("", "flat field", "no frames of the empty fixture");
    const cv::Mat& first = frames[0];
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const cv::Mat& f = frames[i];
        const std::string field = "flat field frame " + std::to_string(i + 1);
        if (f.empty()) throw InputError("", field, "empty");
        if (f.type() != CV_8UC1 && f.type() != CV_16UC1)
            throw InputError("", field, "expected an 8- or 16-bit grey frame, found " + cv::typeToString(f.type()));
        if (f.size() != first.size() || f.type() != first.type())
            throw InputError("", field,
                             std::to_string(f.cols) + "x" + std::to_string(f.rows) + " " + cv::typeToString(f.type()) +
                                 ", the first frame is " + std::to_string(first.cols) + "x" +
                                 std::to_string(first.rows) + " " + cv::typeToString(first.type()));
    }
    const double full = fullScale(first);
    cv::Mat sum(first.size(), CV_64FC1, cv::Scalar(0.0));
    const int quantum = stepQuantum(full);
    std::vector<int> steps(stepBinCount(full), 0);
    long pairs = 0;
    for (const cv::Mat& f : frames) {
        cv::Mat grey;
        f.convertTo(grey, CV_64FC1);
        sum += grey;
        // Each frame's own noise, from disjoint horizontal pairs of every second row.
        for (int r = 0; r < f.rows; r += 2)
            for (int c = 0; c + 1 < f.cols; c += 2, ++pairs)
                ++steps[stepBin(std::abs(greyAt(f, r, c + 1) - greyAt(f, r, c)), quantum)];
    }
    cv::Mat mean;
    sum.convertTo(mean, CV_32FC1, 1.0 / static_cast<double>(frames.size()));

    FlatField out;
    out.sensor = first.size();
    out.cell = cell;
    out.takenUnixMs = takenUnixMs;
    const cv::Rect blocks = blocksOf({{0, 0}, out.sensor}, cell);
    out.level.create(blocks.height, blocks.width, CV_32FC1);
    for (int by = 0; by < blocks.height; ++by)
        for (int bx = 0; bx < blocks.width; ++bx) {
            const cv::Rect block = cv::Rect(bx * cell, by * cell, cell, cell) & cv::Rect({0, 0}, out.sensor);
            out.level.at<float>(by, bx) = static_cast<float>(cv::mean(mean(block))[0] / full);
        }
    std::vector<double> levels(out.level.begin<float>(), out.level.end<float>());
    const double median = medianOf(levels);
    if (!(median * full >= 1.0)) throw InputError("", "flat field", "the frames are black: is the backlight on?");
    for (int by = 0; by < blocks.height; ++by)
        for (int bx = 0; bx < blocks.width; ++bx)
            if (out.level.at<float>(by, bx) < 0.5 * median)
                throw InputError(
                    "",
                    "flat field block at pixel (" + std::to_string(bx * cell) + ", " + std::to_string(by * cell) + ")",
                    "its level " + std::to_string(out.level.at<float>(by, bx)) + " is below half the median level " +
                        std::to_string(median) + ": something is in the fixture");
    out.noise = noiseOf(steps, pairs, quantum) / full;

    // The reference's own specks, found as the monitor finds them (on the mean of the frames).
    DarkLimits<float> dark{cell, blocks, {}};
    for (int by = 0; by < blocks.height; ++by)
        for (int bx = 0; bx < blocks.width; ++bx) {
            const double background = lowestLevelIn(out.level, cell, out.sensor, bx, by) * full;
            dark.limits.push_back(static_cast<float>(speckLimit(background, out.noise * full)));
        }
    std::vector<DarkRun> runs;
    for (const DarkSet& s : darkSets<float>(mean, {0, 0}, {{0, 0}, out.sensor}, out.sensor, dark, runs))
        if (s.speck()) out.dustAt.push_back(s.centroid());
    out.dustSpecks = static_cast<int>(out.dustAt.size());
    return out;
}

// --- The monitor -------------------------------------------------------------

struct HealthMonitor::ViewContext {
    std::size_t index = 0;
    const EdgeImage* image = nullptr;
    cv::Rect frame; ///< the sensor pixels the frame holds
    cv::Size sensor;
    double full = 255.0;
    bool referenced = false;        ///< the reference applies: its sensor, a dark object on the backlight
    double medianRatio = kNoFigure; ///< of the view's background samples
    double noise = kNoFigure;       ///< grey levels
};

HealthMonitor::HealthMonitor(FlatField reference) : reference_(std::move(reference))
{
    if (!reference_.empty()) {
        const cv::Rect blocks = blocksOf({{0, 0}, reference_.sensor}, std::max(reference_.cell, 1));
        if (reference_.sensor.width < 1 || reference_.sensor.height < 1 || reference_.cell < 1 ||
            reference_.level.type() != CV_32FC1 || reference_.level.cols != blocks.width ||
            reference_.level.rows != blocks.height)
            throw ArgumentError("HealthMonitor: the reference's level must be CV_32FC1 of ceil(sensor / cell) blocks");
        if (!(reference_.noise >= 0.0 && reference_.noise < 1.0))
            throw ArgumentError("HealthMonitor: the reference's noise must lie in [0, 1), found " +
                                std::to_string(reference_.noise));
        zoneSide_ = reference_.cell * std::max(1, static_cast<int>(std::lround(double(kZonePx) / reference_.cell)));
        zones_ = {(reference_.sensor.width + zoneSide_ - 1) / zoneSide_,
                  (reference_.sensor.height + zoneSide_ - 1) / zoneSide_};
        zoneSum_.assign(static_cast<std::size_t>(zones_.area()), 0.0);
        zoneCount_.assign(zoneSum_.size(), 0);
        viewZoneSum_ = zoneSum_;
        viewZoneCount_ = zoneCount_;
        bands_ = (reference_.sensor.height + kBandRows - 1) / kBandRows;
        bandSeen_.assign(static_cast<std::size_t>(kBandRows) * static_cast<std::size_t>(reference_.sensor.width), 0);
        lowestLevel_.create(blocks.height, blocks.width, CV_32FC1);
        for (int by = 0; by < blocks.height; ++by)
            for (int bx = 0; bx < blocks.width; ++bx)
                lowestLevel_.at<float>(by, bx) =
                    static_cast<float>(lowestLevelIn(reference_.level, reference_.cell, reference_.sensor, bx, by));
        referenceSpecks_ = reference_.dustAt;
        std::sort(referenceSpecks_.begin(), referenceSpecks_.end(),
                  [](const cv::Point2f& a, const cv::Point2f& b) { return a.y < b.y; });
    }
    beginCycle();
    cycle_ = 0;
}

void HealthMonitor::beginCycle()
{
    band_ = bands_ > 0 ? static_cast<int>(cycle_ % static_cast<std::uint64_t>(bands_)) : 0;
    ++cycle_;
    views_ = 0;
    ratioBins_.assign(static_cast<std::size_t>(kRatioBins), 0);
    ratioCount_ = 0;
    std::fill(zoneSum_.begin(), zoneSum_.end(), 0.0);
    std::fill(zoneCount_.begin(), zoneCount_.end(), 0);
    widths_.clear();
    contrasts_.clear();
    stepBins_.clear();
    stepCount_ = 0;
    stepsFull_ = 0.0;
    bandExamined_ = false;
    bandFound_ = 0;
    std::fill(bandSeen_.begin(), bandSeen_.end(), std::uint8_t{0});
}

void HealthMonitor::addView(std::size_t view, const EdgeImage& image, std::span<const EdgeProbe> probes)
{
    const cv::Mat& grey = image.grey;
    const std::string name = "health: view " + std::to_string(view);
    if (grey.empty() || (grey.type() != CV_8UC1 && grey.type() != CV_16UC1))
        throw ArgumentError(name + ": expected an 8- or 16-bit grey frame, found " +
                            (grey.empty() ? std::string("an empty one") : cv::typeToString(grey.type())));
    ViewContext ctx;
    ctx.index = view;
    ctx.image = &image;
    ctx.frame = {image.origin, grey.size()};
    ctx.sensor = image.sensor.empty() ? cv::Size(image.origin.x + grey.cols, image.origin.y + grey.rows) : image.sensor;
    if (image.origin.x < 0 || image.origin.y < 0 || ctx.frame.br().x > ctx.sensor.width ||
        ctx.frame.br().y > ctx.sensor.height)
        throw ArgumentError(name + ": the " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
                            " frame at (" + std::to_string(image.origin.x) + ", " + std::to_string(image.origin.y) +
                            ") leaves the " + std::to_string(ctx.sensor.width) + "x" +
                            std::to_string(ctx.sensor.height) + " sensor");
    ctx.full = fullScale(grey);
    ctx.referenced = !reference_.empty() && ctx.sensor == reference_.sensor && image.objectIsDark;
    ++views_;

    const auto readProfiles = [&](const auto& reader) {
        for (const EdgeProbe& probe : probes)
            if (const auto read = readProfile(image, reader, probe)) {
                widths_.push_back(read->widthPx);
                contrasts_.push_back(read->contrast / ctx.full);
            }
    };
    if (grey.depth() == CV_8U)
        readProfiles(FrameReader<std::uint8_t>(grey, image.origin, ctx.sensor));
    else
        readProfiles(FrameReader<std::uint16_t>(grey, image.origin, ctx.sensor));
    sampleBackground(ctx);
    if (ctx.referenced && bands_ > 0 && !std::isnan(ctx.medianRatio)) surveyBand(ctx);
}

// A sparse grid of background pixels (docs/health.md, "Figures"): each
// against the reference's level there, its neighbours' differences for the noise.
void HealthMonitor::sampleBackground(ViewContext& ctx)
{
    const EdgeImage& image = *ctx.image;
    const cv::Rect& f = ctx.frame;
    const int step =
        std::max(2, static_cast<int>(std::ceil(std::sqrt(double(f.area()) / (kSamplesPerView * kRowsApart)))));
    // Each view and each cycle samples other pixels of the grid's cells.
    const int ox = static_cast<int>((ctx.index * 5 + cycle_ * 3) % static_cast<std::uint64_t>(step));
    const int oy = static_cast<int>((ctx.index * 37 + cycle_ * 7) % static_cast<std::uint64_t>(kRowsApart * step));
    BackgroundGrid grid;
    grid.frame = f;
    grid.step = step;
    grid.first = {f.x + kClearPx + ox, f.y + kClearPx + oy};
    grid.threshold = image.threshold;
    grid.objectIsDark = image.objectIsDark;
    grid.full = ctx.full;
    if (ctx.referenced) {
        grid.level = &reference_.level;
        grid.cell = reference_.cell;
        grid.zoneSide = zoneSide_;
        grid.zonesAcross = zones_.width;
    }
    std::vector<BackgroundSample> samples;
    samples.reserve(static_cast<std::size_t>(2 * kSamplesPerView));
    if (image.grey.depth() == CV_8U)
        sampleGrid<std::uint8_t>(image.grey, grid, samples);
    else
        sampleGrid<std::uint16_t>(image.grey, grid, samples);
    if (samples.empty()) return;
    std::vector<int> ratios(static_cast<std::size_t>(kRatioBins), 0), steps(stepBinCount(ctx.full), 0);
    std::size_t lowest = ratios.size();
    for (const BackgroundSample& s : samples) {
        const std::size_t bin = ratioBin(s.ratio);
        ++ratios[bin];
        lowest = std::min(lowest, bin);
    }
    ctx.medianRatio = binnedMedian(ratios, static_cast<long>(samples.size()), false, lowest) * kRatioBinWidth;
    const double cut = kRatioCut * ctx.medianRatio;
    // The cycle's noise from the differences of all its views (a view's few
    // hundred give σ to ±5 %); a view of another depth than the first is left out of it.
    if (stepsFull_ == 0.0) {
        stepsFull_ = ctx.full;
        stepBins_.assign(steps.size(), 0);
    }
    const bool pooled = stepsFull_ == ctx.full;
    const int quantum = stepQuantum(ctx.full);
    long pairs = 0;
    if (ctx.referenced) {
        std::fill(viewZoneSum_.begin(), viewZoneSum_.end(), 0.0);
        std::fill(viewZoneCount_.begin(), viewZoneCount_.end(), 0);
    }
    for (const BackgroundSample& s : samples) {
        if (s.ratio < cut) continue;
        for (int difference : s.steps) {
            const std::size_t bin = stepBin(difference, quantum);
            ++steps[bin];
            if (pooled) ++stepBins_[bin];
        }
        pairs += 2;
        if (!ctx.referenced) continue;
        ++ratioBins_[ratioBin(s.ratio)];
        ++ratioCount_;
        const auto z = static_cast<std::size_t>(s.zone);
        zoneSum_[z] += s.ratio;
        ++zoneCount_[z];
        viewZoneSum_[z] += s.ratio;
        ++viewZoneCount_[z];
    }
    if (pooled) stepCount_ += pairs;
    ctx.noise = noiseOf(steps, pairs, quantum);
}

// One band of the dust survey in this view (docs/health.md, "Figures": dust):
// the part of the band the frame holds and no earlier view of the cycle
// showed as backlight, read with a margin so that a speck near its edge is
// seen whole. A speck is counted in the band of its first pixel.
void HealthMonitor::surveyBand(const ViewContext& ctx)
{
    const cv::Rect& f = ctx.frame;
    const auto width = static_cast<std::size_t>(reference_.sensor.width);
    const int bandTop = band_ * kBandRows, bandBottom = std::min(bandTop + kBandRows, reference_.sensor.height);
    const int top = std::max(bandTop, f.y), bottom = std::min(bandBottom, f.y + f.height);
    const auto seenAt = [&](int x, int y) -> std::uint8_t& {
        return bandSeen_[static_cast<std::size_t>(y - bandTop) * width + static_cast<std::size_t>(x)];
    };
    int x0 = INT_MAX, x1 = -1, y0 = INT_MAX, y1 = -1;
    for (int y = top; y < bottom; ++y) {
        const auto* hole =
            static_cast<const std::uint8_t*>(std::memchr(&seenAt(f.x, y), 0, static_cast<std::size_t>(f.width)));
        if (hole == nullptr) continue;
        const auto* last =
            static_cast<const std::uint8_t*>(memrchr(&seenAt(f.x, y), 0, static_cast<std::size_t>(f.width)));
        x0 = std::min(x0, f.x + static_cast<int>(hole - &seenAt(f.x, y)));
        x1 = std::max(x1, f.x + static_cast<int>(last - &seenAt(f.x, y)));
        y0 = std::min(y0, y);
        y1 = y;
    }
    if (x1 < 0) return;
    bandExamined_ = true;
    const cv::Rect scan = cv::Rect(cv::Point(x0 - kSpeckMargin, y0 - kSpeckMargin),
                                   cv::Point(x1 + kSpeckMargin + 1, y1 + kSpeckMargin + 1)) &
                          f;
    // Each block's limit: the lowest reference level within it times the
    // backlight of its zone (kMinLocalSamples), less the depth.
    const int cell = reference_.cell;
    DarkLimits<int> dark{cell, blocksOf(scan, cell), {}};
    const double noise = std::max(reference_.noise * ctx.full, ctx.noise);
    for (int by = dark.blocks.y; by < dark.blocks.y + dark.blocks.height; ++by)
        for (int bx = dark.blocks.x; bx < dark.blocks.x + dark.blocks.width; ++bx) {
            const auto z = static_cast<std::size_t>((by * cell / zoneSide_) * zones_.width + bx * cell / zoneSide_);
            const double local = viewZoneCount_[z] >= kMinLocalSamples ? viewZoneSum_[z] / viewZoneCount_[z]
                                 : zoneCount_[z] >= kMinLocalSamples   ? zoneSum_[z] / zoneCount_[z]
                                                                       : ctx.medianRatio;
            const double background = lowestLevel_.at<float>(by, bx) * ctx.full * local;
            dark.limits.push_back(static_cast<int>(std::ceil(speckLimit(background, noise))));
        }
    std::vector<DarkRun> runs;
    const cv::Mat& grey = ctx.image->grey;
    const std::vector<DarkSet> sets = grey.depth() == CV_8U
                                          ? darkSets<std::uint8_t>(grey, f.tl(), scan, ctx.sensor, dark, runs)
                                          : darkSets<std::uint16_t>(grey, f.tl(), scan, ctx.sensor, dark, runs);
    for (const DarkSet& s : sets) {
        if (!s.speck()) continue;
        const DarkRun& first = runs[static_cast<std::size_t>(s.firstRun)];
        if (first.row < top || first.row >= bottom || seenAt(first.x0, first.row) != 0) continue;
        const cv::Point2f at = s.centroid();
        auto near = std::lower_bound(referenceSpecks_.begin(), referenceSpecks_.end(), at.y - kSpeckMatchPx,
                                     [](const cv::Point2f& p, double y) { return p.y < y; });
        bool known = false;
        for (; near != referenceSpecks_.end() && near->y <= at.y + kSpeckMatchPx && !known; ++near)
            known = std::hypot(near->x - at.x, near->y - at.y) <= kSpeckMatchPx;
        if (!known) ++bandFound_;
    }
    // Surveyed: the band's pixels read here and not seen before, but those of
    // a dark set that hides the backlight (the part, or what the read cut off):
    // a later view of the cycle may show the backlight there.
    const int rowTop = std::max(top, scan.y), rowBottom = std::min(bottom, scan.y + scan.height);
    for (int y = rowTop; y < rowBottom; ++y) {
        std::uint8_t* seen = &seenAt(scan.x, y);
        for (int i = 0; i < scan.width; ++i) seen[i] = seen[i] == 0 ? 2 : seen[i];
    }
    for (const DarkRun& r : runs)
        if (r.row >= rowTop && r.row < rowBottom && !sets[static_cast<std::size_t>(r.parent)].speck()) {
            std::uint8_t* seen = &seenAt(r.x0, r.row);
            for (int i = 0; i <= r.x1 - r.x0; ++i) seen[i] = seen[i] == 2 ? 0 : seen[i];
        }
    for (int y = rowTop; y < rowBottom; ++y) {
        std::uint8_t* seen = &seenAt(scan.x, y);
        for (int i = 0; i < scan.width; ++i) seen[i] = seen[i] == 2 ? 1 : seen[i];
    }
}

HealthFigures HealthMonitor::endCycle()
{
    HealthFigures out;
    out.views = views_;
    out.probes = static_cast<int>(widths_.size());
    if (ratioCount_ > 0) {
        out.backlight = binnedMedian(ratioBins_, ratioCount_, false) * kRatioBinWidth;
        double worst = -1.0;
        for (std::size_t z = 0; z < zoneSum_.size(); ++z)
            if (zoneCount_[z] >= kMinZoneSamples)
                worst = std::max(worst, std::abs(zoneSum_[z] / zoneCount_[z] / out.backlight - 1.0));
        if (worst >= 0.0) out.uniformity = worst;
    }
    if (bandExamined_) bandSpecks_[band_] = bandFound_;
    out.dustBandsSurveyed = static_cast<int>(bandSpecks_.size());
    if (!reference_.empty() && !bandSpecks_.empty()) {
        int found = 0;
        for (const auto& [band, specks] : bandSpecks_) found += specks;
        // A reference that counts specks it does not place has its count taken off the whole.
        const int unplaced = std::max(0, reference_.dustSpecks - static_cast<int>(reference_.dustAt.size()));
        out.dustSpecks = std::max(0, found - unplaced);
    }
    out.edgeWidthPx = medianOf(widths_);
    out.contrast = medianOf(contrasts_);
    if (stepCount_ > 0) out.noise = noiseOf(stepBins_, stepCount_, stepQuantum(stepsFull_)) / stepsFull_;
    out.predictedSigmaPx = predictedEdgeSigmaPx(out.noise, out.contrast, out.edgeWidthPx);
    return out;
}

// docs/health.md, "Prediction". findEdge (edge.cpp) places its 6-px window at
// the threshold crossing read from whole steps and takes the two levels over
// 3–4.5 px beyond the crossing either side. Noise moves that crossing by
// σ_c = noise·√(2/3) / rise (rise: the profile's climb over one step at the
// edge, linear interpolation between two pixels). Once the edge is blurred, a
// crossing moved by δ moves the located edge by k·δ: the transition's share
// outside the window, 2·Q(3 px / σ), and the two levels read on its tails,
// W·(their mean slope)/C. The crossing's pixels are pixels of the integral
// too, so the two moves are correlated: + 2·k·noise²/(C·rise).
double predictedEdgeSigmaPx(double noise, double contrast, double edgeWidthPx)
{
    if (!(noise >= 0.0) || !(std::abs(contrast) > 0.0)) return kNoFigure;
    const double integral = edgeSigmaPx(noise, contrast);
    if (!(edgeWidthPx > 0.0)) return integral;
    const double blur = edgeWidthPx / kTenNinety; // σ of the edge's profile, px
    double slope = 0.0;                           // of the normalised profile where findEdge reads the levels, 1/px
    for (double s : kFindEdgeLevelsAt)
        slope += std::exp(-0.5 * (s / blur) * (s / blur)) / (std::sqrt(2.0 * M_PI) * blur);
    slope /= static_cast<double>(kFindEdgeLevelsAt.size());
    const double k = std::erfc(kFindEdgeHalfWindow / (blur * std::sqrt(2.0))) + 2.0 * kFindEdgeHalfWindow * slope;
    const double rise = std::erf(0.5 / (blur * std::sqrt(2.0)));
    const double r = noise / std::abs(contrast);
    return std::sqrt(integral * integral + r * r * (2.0 / 3.0 * k * k / (rise * rise) + 2.0 * k / rise));
}

std::vector<HealthFigure> healthWarnings(const HealthFigures& figures, const HealthLimits& limits)
{
    // Comparisons with NaN are false: a figure not measured never warns.
    std::vector<HealthFigure> out;
    if (figures.backlight < limits.minBacklight) out.push_back(HealthFigure::Backlight);
    if (figures.uniformity > limits.maxUniformity) out.push_back(HealthFigure::Uniformity);
    if (figures.dustSpecks > limits.maxDustSpecks) out.push_back(HealthFigure::Dust);
    if (figures.edgeWidthPx > limits.maxEdgeWidthPx) out.push_back(HealthFigure::Focus);
    if (figures.contrast < limits.minContrast) out.push_back(HealthFigure::Contrast);
    if (figures.noise > limits.maxNoise) out.push_back(HealthFigure::Noise);
    if (std::abs(figures.edgeBiasPx) > limits.maxEdgeBiasPx) out.push_back(HealthFigure::EdgeBias);
    if (figures.capability > limits.maxCapability) out.push_back(HealthFigure::Capability);
    return out;
}

std::uint16_t healthWarningBits(std::span<const HealthFigure> warnings)
{
    unsigned bits = 0;
    for (HealthFigure w : warnings) bits |= 1u << static_cast<unsigned>(w);
    return static_cast<std::uint16_t>(bits);
}

} // namespace hg::vision
