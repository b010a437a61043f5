// Sub-pixel silhouette edges (docs/inspection.md, "Sub-voxel deviation";
// dissertation 4.4.2 on what thresholding discards).
#include "hullgauge/vision/edge.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace hg::vision {
namespace {

using Vec2 = Eigen::Vector2d;

// The integral window and where the two levels are taken (pixels).
constexpr double kHalfWindow = 3.0, kLevelSpan = 1.5, kStep = 0.5;

double grey(const cv::Mat& image, int row, int col)
{
    return image.depth() == CV_8U ? image.at<std::uint8_t>(row, col) : image.at<std::uint16_t>(row, col);
}

// Reads grey levels at sensor positions from a frame that may be a region of
// the sensor (edge.h): off the sensor a read fails as it always did; on the
// sensor but outside the delivered region it fails and marks the search
// `missed`, which then finds no edge (docs/inspection.md, "Frames that are regions").
class SensorReader {
  public:
    explicit SensorReader(const EdgeImage& image)
        : image_(image.grey), origin_(image.origin),
          sensor_(image.sensor.empty() ? cv::Size(image.origin.x + image.grey.cols, image.origin.y + image.grey.rows)
                                       : image.sensor)
    {
    }

    // Bilinear grey level at sensor (x, y); false off the sensor or the region.
    bool sample(const Vec2& at, double& value)
    {
        const double x = at.x(), y = at.y();
        if (!(x >= 0.0 && y >= 0.0 && x <= sensor_.width - 1.0 && y <= sensor_.height - 1.0)) return false;
        const int c = std::min(static_cast<int>(x), sensor_.width - 2),
                  r = std::min(static_cast<int>(y), sensor_.height - 2);
        const int u = c - origin_.x, v = r - origin_.y;
        if (u < 0 || v < 0 || u + 1 >= image_.cols || v + 1 >= image_.rows) {
            missed_ = true;
            return false;
        }
        const double fx = x - c, fy = y - r;
        value = (1 - fy) * ((1 - fx) * grey(image_, v, u) + fx * grey(image_, v, u + 1)) +
                fy * ((1 - fx) * grey(image_, v + 1, u) + fx * grey(image_, v + 1, u + 1));
        return true;
    }

    // The whole pixel (col, row) of the sensor; false off the sensor or the region.
    bool pixel(int col, int row, double& value)
    {
        if (col < 0 || row < 0 || col >= sensor_.width || row >= sensor_.height) return false;
        const int u = col - origin_.x, v = row - origin_.y;
        if (u < 0 || v < 0 || u >= image_.cols || v >= image_.rows) {
            missed_ = true;
            return false;
        }
        value = grey(image_, v, u);
        return true;
    }

    bool missed() const { return missed_; }

  private:
    const cv::Mat& image_;
    cv::Point origin_;
    cv::Size sensor_;
    bool missed_ = false;
};

// Signed "background-ness" of a grey level: > 0 on the background side.
double side(const EdgeImage& image, double value)
{
    return image.objectIsDark ? value - image.threshold : image.threshold - value;
}

// The threshold crossing (object -> background going outward) nearest s = 0,
// from a profile sampled every pixel.
bool nearestCrossing(const EdgeImage& image, SensorReader& reader, const Vec2& pixel, const Vec2& normal, double band,
                     double& crossing)
{
    const int n = static_cast<int>(std::ceil(band));
    double best = 1e300;
    double prev = 0.0;
    bool havePrev = false;
    for (int k = -n; k <= n; ++k) {
        double v = 0.0;
        if (!reader.sample(pixel + k * normal, v)) {
            havePrev = false;
            continue;
        }
        const double sv = side(image, v);
        if (havePrev && prev <= 0.0 && sv > 0.0) {
            const double s = (k - 1) + (-prev) / (sv - prev);
            if (std::abs(s) < std::abs(best)) best = s;
        }
        prev = sv;
        havePrev = true;
    }
    if (std::abs(best) > band) return false;
    crossing = best;
    return true;
}

// The frame's noise on the background beyond the edge: whole pixels 4-20 px
// out, from their mean absolute deviation about the median (× √(π/2) for a
// Gaussian; robust to a stray feature, and not zero where most pixels share
// one grey level as the median absolute deviation is), never below the
// quantisation's 1/√12 level.
double backgroundNoise(SensorReader& reader, const Vec2& edge, const Vec2& normal)
{
    // On the stack: this runs for every edge the aligner and the gauge look at.
    constexpr int kFirst = 4, kLast = 20, kCount = kLast - kFirst + 1;
    std::array<double, kCount> values{};
    for (int k = kFirst; k <= kLast; ++k) {
        const Vec2 p = edge + k * normal;
        const int c = static_cast<int>(std::lround(p.x())), r = static_cast<int>(std::lround(p.y()));
        if (!reader.pixel(c, r, values[static_cast<std::size_t>(k - kFirst)])) return 0.0;
    }
    std::array<double, kCount> sorted = values;
    std::nth_element(sorted.begin(), sorted.begin() + kCount / 2, sorted.end());
    const double m = sorted[kCount / 2];
    double sum = 0.0;
    for (double v : values) sum += std::abs(v - m);
    return std::max(1.2533 * sum / kCount, 1.0 / std::sqrt(12.0));
}

} // namespace

std::optional<EdgeFound> findEdge(const EdgeImage& image, const Vec2& pixel, const Vec2& normal, double bandPx)
{
    SensorReader reader(image);
    double crossing = 0.0;
    if (!nearestCrossing(image, reader, pixel, normal, bandPx, crossing) || reader.missed()) return std::nullopt;
    // Levels of object and background on either side of the edge, then the
    // integral of the normalised profile over a window across it: the
    // window's start plus the covered length is the edge.
    double object = 0.0, background = 0.0;
    int no = 0, nb = 0;
    for (double s = 0.0; s <= kLevelSpan + 1e-9; s += kStep) {
        double v = 0.0;
        if (reader.sample(pixel + (crossing - kHalfWindow - s) * normal, v)) object += v, ++no;
        if (reader.sample(pixel + (crossing + kHalfWindow + s) * normal, v)) background += v, ++nb;
    }
    if (no == 0 || nb == 0 || reader.missed()) return std::nullopt;
    object /= no;
    background /= nb;
    const double contrast = background - object;
    const double full = image.grey.depth() == CV_8U ? 255.0 : 65535.0;
    // Both levels clearly on their side of the threshold, and a real step.
    if (std::abs(contrast) < 0.03 * full) return std::nullopt;
    if (side(image, object) > -0.25 * std::abs(contrast) || side(image, background) < 0.25 * std::abs(contrast))
        return std::nullopt;
    double covered = 0.0;
    const int steps = static_cast<int>(std::lround(2.0 * kHalfWindow / kStep));
    for (int k = 0; k <= steps; ++k) {
        double v = 0.0;
        if (!reader.sample(pixel + (crossing - kHalfWindow + k * kStep) * normal, v)) return std::nullopt;
        const double objectness = (background - v) / contrast;
        covered += (k == 0 || k == steps ? 0.5 : 1.0) * objectness * kStep;
    }
    EdgeFound out;
    out.offset = crossing - kHalfWindow + covered;
    if (std::abs(out.offset - crossing) > 1.0) return std::nullopt;
    out.contrast = contrast;
    out.noise = backgroundNoise(reader, pixel + crossing * normal, normal);
    if (reader.missed()) return std::nullopt;
    out.sigmaPx = edgeSigmaPx(out.noise, contrast, covered);
    return out;
}

EdgeReach findEdgeReach(double bandPx)
{
    // nearestCrossing reads whole steps up to ceil(band); the levels reach
    // kHalfWindow + kLevelSpan beyond the crossing; backgroundNoise reads
    // pixels kLast = 20 px out, rounded to the nearest.
    const double search = std::ceil(bandPx);
    EdgeReach r;
    r.inside = std::max(search, bandPx + kHalfWindow + kLevelSpan);
    r.outside = std::max(search, bandPx + 20.0 + 0.5);
    r.lateral = 1.0;
    return r;
}

// covered = ∫ (B − v)/C over the window W: the noise of the W pixels it
// integrates, and of the levels B and O (each a mean over the level span,
// about kLevelSpan + 0.5 pixels' worth), weighted by ∂covered/∂B =
// (W − covered)/C and ∂covered/∂O = covered/C.
double edgeSigmaPx(double noise, double contrast, double covered)
{
    const double W = 2.0 * kHalfWindow, levelPixels = kLevelSpan + 0.5;
    const double variance = W + (W - covered) * (W - covered) / levelPixels + covered * covered / levelPixels;
    return noise / std::abs(contrast) * std::sqrt(variance);
}

} // namespace hg::vision
