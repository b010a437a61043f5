// Segmentation of backlit grey frames into silhouettes (docs/contracts.md §3,
// dissertation 3.3.8 "the views ... are segmented and thresholded").
//
// Convention of every silhouette produced here: CV_8U, 255 = object (the part
// blocks the backlight), 0 = background. Frames may be 8- or 16-bit, grey or
// colour; thresholds are in the frame's own grey units (0..255 or 0..65535).
//
// Goal-driven use: the inspection needs only the pixels its voxels project to,
// so `segmentRegion` thresholds a rectangle of the frame and the Otsu
// threshold is taken from the histogram of those rectangles' pixels alone
// (docs/inspection.md, "Pixels in proportion to the goal"). Where they show
// one class only — every landmark's network inside the part in that view —
// the middle of the grey range stands in. Whole frames (the archive's
// silhouettes, maintenance) take Otsu's threshold from a strided histogram of
// the whole frame (`otsuStride`).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullgauge/common/enum_names.h"

namespace hg {
class ConfigNode;
}
namespace hg::geometry {
struct Station;
}

namespace hg::vision {

enum class SegmentationMethod {
    Otsu,  ///< threshold from Otsu's between-class variance criterion
    Fixed, ///< `threshold` as given
    Mask,  ///< the frames already are silhouettes: non-zero = object
};
constexpr auto nameTable(SegmentationMethod)
{
    using enum SegmentationMethod;
    return std::to_array<EnumName<SegmentationMethod>>({{Otsu, "otsu"}, {Fixed, "fixed"}, {Mask, "mask"}});
}

struct SegmentationSettings {
    SegmentationMethod method = SegmentationMethod::Otsu;
    /// Grey level (frame units) for `Fixed`; pixels darker than or equal to it
    /// are object when `objectIsDark`.
    double threshold = 128.0;
    /// Backlit part: the object is dark against a bright background.
    bool objectIsDark = true;
    /// Row and column step of the histogram sample used by Otsu (1 = every pixel).
    int otsuStride = 16;
};

/// "otsu", "fixed", "mask"; throws ArgumentError for anything else.
SegmentationMethod parseSegmentationMethod(const std::string& name);

/// Largest `threshold` accepted in a file: the top grey level of a 16-bit frame.
constexpr double kMaxThreshold = 65535.0;

/// A `segmentation` map with the keys of the capture manifest's (docs/contracts.md §3):
/// `method` (otsu | fixed | mask), `threshold` (required for fixed, grey
/// levels 0..65535), `object_is_dark`. Absent keys keep the defaults; a bad
/// value or an unknown key throws InputError naming file, line and key.
SegmentationSettings parseSegmentation(const ConfigNode& node);

/// How the station segments its frames: the station file's optional
/// `segmentation` section (docs/config-reference.md), else the defaults (Otsu,
/// dark object). The daemon inspects with it and writes it into each archived
/// capture's manifest.
SegmentationSettings stationSegmentation(const geometry::Station& station);

/// A single-channel frame of the same depth (8 or 16 bit); colour frames are
/// converted by luminance. Throws ArgumentError for other depths.
cv::Mat toGrey(const cv::Mat& frame);

/// The object/background threshold of a grey frame: Otsu over a strided
/// histogram (full 16-bit resolution for 16-bit frames), or the fixed value.
/// A pixel is object when `objectIsDark ? v <= t : v > t`. For `Mask` the
/// threshold is 0 (object is v > 0 regardless of polarity).
double computeThreshold(const cv::Mat& grey, const SegmentationSettings& settings);

/// Two class means of an Otsu split closer than this fraction of full scale
/// are one class split by noise (the edge search's own minimum contrast, docs/alignment.md).
constexpr double kMinClassContrast = 0.03;

/// The threshold from the pixels of `regions` (clipped to the frame) only:
/// Otsu over every one of them; when they show no two classes (one empty, or
/// their means closer than kMinClassContrast of full scale) the middle of the
/// grey range (127.5 or 32767.5). `Fixed` and `Mask` as above.
double computeThreshold(const cv::Mat& grey, const std::vector<cv::Rect>& regions,
                        const SegmentationSettings& settings);

/// Silhouette of `roi` (clipped to the frame) of a grey frame at threshold `t`:
/// CV_8U of the roi's size, 255 = object.
cv::Mat segmentRegion(const cv::Mat& grey, const cv::Rect& roi, double threshold, const SegmentationSettings& settings);

/// Silhouette of the whole frame (any depth and channel count accepted).
cv::Mat segment(const cv::Mat& frame, const SegmentationSettings& settings);

} // namespace hg::vision
