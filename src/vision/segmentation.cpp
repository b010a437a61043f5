#include "hullgauge/vision/segmentation.h"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hullgauge/common/config_node.h"
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
    if (name == "otsu") return SegmentationMethod::Otsu;
    if (name == "fixed") return SegmentationMethod::Fixed;
    if (name == "mask") return SegmentationMethod::Mask;
    throw std::invalid_argument("unknown segmentation method '" + name + "' (expected otsu, fixed or mask)");
}

std::string toString(SegmentationMethod method)
{
    switch (method) {
    case SegmentationMethod::Otsu:
        return "otsu";
    case SegmentationMethod::Fixed:
        return "fixed";
    case SegmentationMethod::Mask:
        return "mask";
    }
    return "otsu";
}

SegmentationSettings parseSegmentation(const ConfigNode& node)
{
    node.allowOnlyKeys({"method", "threshold", "object_is_dark"});
    SegmentationSettings s;
    if (auto n = node.optional("method")) {
        try {
            s.method = parseSegmentationMethod(n->asString());
        } catch (const std::invalid_argument&) {
            n->fail("expected otsu, fixed or mask, found '" + n->asString() + "'");
        }
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
    if (frame.empty()) throw std::invalid_argument("empty frame");
    if (frame.depth() != CV_8U && frame.depth() != CV_16U)
        throw std::invalid_argument("frame must be 8- or 16-bit unsigned");
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
        throw std::invalid_argument("frame must have 1, 3 or 4 channels");
    }
}

double computeThreshold(const cv::Mat& grey, const SegmentationSettings& settings)
{
    if (grey.channels() != 1) throw std::invalid_argument("computeThreshold needs a single-channel frame");
    switch (settings.method) {
    case SegmentationMethod::Fixed:
        return settings.threshold;
    case SegmentationMethod::Mask:
        return 0.0;
    case SegmentationMethod::Otsu:
        break;
    }
    const int stride = std::max(1, settings.otsuStride);
    const bool wide = grey.depth() == CV_16U;
    const std::size_t bins = wide ? 65536 : 256;
    // Four interleaved integer histograms: a backlit frame holds few distinct
    // grey values, and one histogram would serialise every increment on the
    // same counter (this pass is a fifth of an inspection's compute otherwise).
    std::vector<std::uint32_t> counts(4 * bins, 0);
    auto tally = [&](const auto* row) {
        int c = 0, k = 0;
        for (; c < grey.cols; c += stride, k = (k + 1) & 3) ++counts[static_cast<std::size_t>(k) * bins + row[c]];
    };
    for (int r = 0; r < grey.rows; r += stride) {
        if (wide)
            tally(grey.ptr<std::uint16_t>(r));
        else
            tally(grey.ptr<std::uint8_t>(r));
    }
    std::vector<double> hist(bins, 0.0);
    for (std::size_t k = 0; k < 4; ++k)
        for (std::size_t i = 0; i < bins; ++i) hist[i] += counts[k * bins + i];
    return static_cast<double>(otsuBin(hist));
}

cv::Mat segmentRegion(const cv::Mat& grey, const cv::Rect& roi, double threshold, const SegmentationSettings& settings)
{
    if (grey.channels() != 1) throw std::invalid_argument("segmentRegion needs a single-channel frame");
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
