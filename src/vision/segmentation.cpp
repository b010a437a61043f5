#include "hullgauge/vision/segmentation.h"

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"

namespace hg::vision {
namespace {

/// Otsu's criterion on a histogram: the threshold t (a bin index) maximising the
/// between-class variance of {v <= t} and {v > t}.
int otsuBin(const std::vector<double>& hist)
{
    double total = 0.0, sumAll = 0.0;
    for (std::size_t i = 0; i < hist.size(); ++i) {
        total += hist[i];
        sumAll += static_cast<double>(i) * hist[i];
    }
    if (total <= 0.0) return 0;
    double w0 = 0.0, sum0 = 0.0, best = -1.0;
    int bestBin = 0;
    int firstPlateau = -1;
    for (std::size_t i = 0; i + 1 < hist.size(); ++i) {
        w0 += hist[i];
        sum0 += static_cast<double>(i) * hist[i];
        const double w1 = total - w0;
        if (w0 <= 0.0 || w1 <= 0.0) continue;
        const double m0 = sum0 / w0;
        const double m1 = (sumAll - sum0) / w1;
        const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
        if (between > best * (1.0 + 1e-12)) {
            best = between;
            bestBin = static_cast<int>(i);
            firstPlateau = bestBin;
        } else if (between >= best * (1.0 - 1e-12) && firstPlateau >= 0) {
            // An empty stretch between the modes keeps the criterion flat: put
            // the threshold in the middle of the flat run, not at its start.
            bestBin = (firstPlateau + static_cast<int>(i) + 1) / 2;
        }
    }
    return bestBin;
}

} // namespace

SegmentationMethod parseSegmentationMethod(const std::string& name)
{
    if (const auto method = parseEnum<SegmentationMethod>(name)) return *method;
    throw ArgumentError("unknown segmentation method '" + name + "' (expected " +
                        enumNameList<SegmentationMethod>(", ", " or ") + ")");
}

SegmentationSettings parseSegmentation(const ConfigNode& node)
{
    node.allowOnlyKeys({"method", "threshold", "object_is_dark"});
    SegmentationSettings s;
    if (auto n = node.optional("method")) {
        const auto method = parseEnum<SegmentationMethod>(n->asString());
        if (!method)
            n->fail("expected " + enumNameList<SegmentationMethod>(", ", " or ") + ", found '" + n->asString() + "'");
        s.method = *method;
    }
    if (auto n = node.optional("threshold"))
        s.threshold = n->asDoubleIn(0.0, kMaxThreshold);
    else if (s.method == SegmentationMethod::Fixed)
        node.fail("threshold: missing (method 'fixed' needs a threshold)");
    if (auto n = node.optional("object_is_dark")) s.objectIsDark = n->asBool();
    return s;
}

SegmentationSettings stationSegmentation(const geometry::Station& station)
{
    if (!station.document) return {};
    const auto section = station.document->optional("segmentation");
    return section ? parseSegmentation(*section) : SegmentationSettings{};
}

cv::Mat toGrey(const cv::Mat& frame)
{
    if (frame.empty()) throw ArgumentError("frame: empty");
    if (frame.depth() != CV_8U && frame.depth() != CV_16U)
        throw ArgumentError("frame must be 8- or 16-bit unsigned, found " + cv::typeToString(frame.type()));
    switch (frame.channels()) {
    case 1:
        return frame;
    case 3: {
        cv::Mat g;
        cv::cvtColor(frame, g, cv::COLOR_BGR2GRAY);
        return g;
    }
    case 4: {
        cv::Mat g;
        cv::cvtColor(frame, g, cv::COLOR_BGRA2GRAY);
        return g;
    }
    default:
        throw ArgumentError("frame must have 1, 3 or 4 channels, found " + std::to_string(frame.channels()));
    }
}

namespace {

/// Four interleaved integer histograms: a backlit frame holds few distinct
/// grey values, and one histogram would serialise every increment on the
/// same counter.
class Histogram {
  public:
    explicit Histogram(const cv::Mat& grey)
        : wide_(grey.depth() == CV_16U), bins_(wide_ ? 65536 : 256), counts_(4 * bins_, 0)
    {
    }
    /// Every `stride`-th pixel of row r from column c0 to c1 (exclusive).
    void tallyRow(const cv::Mat& grey, int r, int c0, int c1, int stride)
    {
        if (wide_)
            tally(grey.ptr<std::uint16_t>(r), c0, c1, stride);
        else
            tally(grey.ptr<std::uint8_t>(r), c0, c1, stride);
    }
    std::vector<double> merged() const
    {
        std::vector<double> hist(bins_, 0.0);
        for (std::size_t k = 0; k < 4; ++k)
            for (std::size_t i = 0; i < bins_; ++i) hist[i] += counts_[k * bins_ + i];
        return hist;
    }
    double fullScale() const { return wide_ ? 65535.0 : 255.0; }

  private:
    template <typename T> void tally(const T* row, int c0, int c1, int stride)
    {
        std::size_t k = 0;
        for (int c = c0; c < c1; c += stride, k = (k + 1) & 3) ++counts_[k * bins_ + row[c]];
    }
    bool wide_;
    std::size_t bins_;
    std::vector<std::uint32_t> counts_;
};

/// The means of the two classes Otsu's threshold t separates, {v <= t} and {v > t};
/// nullopt when one is empty.
std::optional<std::pair<double, double>> classMeans(const std::vector<double>& hist, int t)
{
    double w0 = 0.0, s0 = 0.0, w1 = 0.0, s1 = 0.0;
    for (std::size_t i = 0; i < hist.size(); ++i) {
        const bool low = static_cast<int>(i) <= t;
        (low ? w0 : w1) += hist[i];
        (low ? s0 : s1) += static_cast<double>(i) * hist[i];
    }
    if (w0 <= 0.0 || w1 <= 0.0) return std::nullopt;
    return std::make_pair(s0 / w0, s1 / w1);
}

} // namespace

double computeThreshold(const cv::Mat& grey, const SegmentationSettings& settings)
{
    if (grey.channels() != 1)
        throw ArgumentError("computeThreshold needs a single-channel frame, found " + std::to_string(grey.channels()) +
                            " channels");
    switch (settings.method) {
    case SegmentationMethod::Fixed:
        return settings.threshold;
    case SegmentationMethod::Mask:
        return 0.0;
    case SegmentationMethod::Otsu:
        break;
    }
    const int stride = std::max(1, settings.otsuStride);
    Histogram h(grey);
    for (int r = 0; r < grey.rows; r += stride) h.tallyRow(grey, r, 0, grey.cols, stride);
    return static_cast<double>(otsuBin(h.merged()));
}

double computeThreshold(const cv::Mat& grey, const std::vector<cv::Rect>& regions, const SegmentationSettings& settings)
{
    if (grey.channels() != 1)
        throw ArgumentError("computeThreshold needs a single-channel frame, found " + std::to_string(grey.channels()) +
                            " channels");
    if (settings.method != SegmentationMethod::Otsu) return computeThreshold(grey, settings);
    Histogram h(grey);
    const cv::Rect frame(0, 0, grey.cols, grey.rows);
    for (const cv::Rect& region : regions) {
        const cv::Rect r = region & frame;
        for (int row = r.y; row < r.y + r.height; ++row) h.tallyRow(grey, row, r.x, r.x + r.width, 1);
    }
    const std::vector<double> hist = h.merged();
    const int t = otsuBin(hist);
    // Regions that show one class only (every landmark's network inside the
    // part in this view, or outside it) give Otsu noise to split: then the
    // middle of the grey range, which separates a backlit frame's two levels.
    const auto means = classMeans(hist, t);
    if (!means || means->second - means->first < kMinClassContrast * h.fullScale()) return 0.5 * h.fullScale();
    return static_cast<double>(t);
}

cv::Mat segmentRegion(const cv::Mat& grey, const cv::Rect& roi, double threshold, const SegmentationSettings& settings)
{
    if (grey.channels() != 1)
        throw ArgumentError("segmentRegion needs a single-channel frame, found " + std::to_string(grey.channels()) +
                            " channels");
    const cv::Rect r = roi & cv::Rect(0, 0, grey.cols, grey.rows);
    cv::Mat out(r.height, r.width, CV_8U);
    if (r.empty()) return out;
    const cv::Mat src = grey(r);
    if (settings.method == SegmentationMethod::Mask) {
        cv::compare(src, 0, out, cv::CMP_GT);
    } else if (settings.objectIsDark) {
        // Object where v <= t: compare against the largest grey value not above t.
        cv::compare(src, std::floor(threshold), out, cv::CMP_LE);
    } else {
        cv::compare(src, std::floor(threshold), out, cv::CMP_GT);
    }
    return out;
}

cv::Mat segment(const cv::Mat& frame, const SegmentationSettings& settings)
{
    const cv::Mat grey = toGrey(frame);
    return segmentRegion(grey, cv::Rect(0, 0, grey.cols, grey.rows), computeThreshold(grey, settings), settings);
}

} // namespace hg::vision
