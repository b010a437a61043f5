// Sub-pixel silhouette edges in grey frames (docs/alignment.md, "Method";
// docs/inspection.md, "Sub-voxel deviation"). The 50 % rule of the
// dissertation's segmentation (4.4.2) keeps only which side of the threshold
// a pixel lies on; the grey levels across an edge say where, within the
// pixel, the edge lies. Along a line through the frame the edge is located by
// the integral of the normalised grey profile across a 6-pixel window: the
// window's start plus the covered length — exact for a straight edge under any
// symmetric optical blur and for the pixel-area coverage a sensor integrates.
//
// Pure computation on values: no I/O, no state.
#pragma once

#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace hg::vision {

/// A grey frame as the edge search reads it. Positions are sensor pixels;
/// the frame may be a region of the sensor (docs/camera.md, "Regions per
/// grab"): its pixel (u, v) is sensor pixel (origin.x + u, origin.y + v).
/// A read off the sensor is treated as before (the search skips it); a read
/// on the sensor but outside the delivered region finds no edge — a pixel
/// the camera did not send is never guessed (docs/inspection.md, "Frames
/// that are regions").
struct EdgeImage {
    cv::Mat grey;           ///< CV_8UC1 or CV_16UC1
    double threshold = 0.0; ///< the silhouette's grey level
    bool objectIsDark = true;
    cv::Point origin{0, 0}; ///< sensor position of grey's pixel (0, 0)
    cv::Size sensor{};      ///< the sensor's size; empty: origin + grey's size
};

/// A silhouette edge found along pixel + s·normal.
struct EdgeFound {
    double offset = 0.0;   ///< s of the edge, pixels
    double contrast = 0.0; ///< background level − object level (grey levels, signed)
    /// Standard deviation of the grey level on the flat background beyond the
    /// edge (from whole pixels 4–20 px out, robustly, at least the
    /// quantisation's 1/√12): the frame's own noise there; 0 when those pixels
    /// leave the frame.
    double noise = 0.0;
    /// Standard uncertainty of `offset` (pixels) from that noise: the profile
    /// integral over the window and the two levels it is normalised by.
    double sigmaPx = 0.0;
};

/// The standard uncertainty (px) of an edge located by the profile integral
/// under background noise `noise` and contrast `contrast` (grey levels),
/// `covered` the object's length of the 6-pixel window (px; half of it for
/// an edge centred in it): the noise of the window's pixels the integral sums
/// and of the two levels it is normalised by.
double edgeSigmaPx(double noise, double contrast, double covered = 3.0);

/// How far from `pixel` along its normal findEdge reads grey levels (pixels):
/// the crossing search over [-band, band], the object level up to 4.5 px
/// inside the crossing, the background noise up to 20 px beyond it (rounded
/// to whole pixels). Every pixel read lies within `lateral` of that segment
/// (bilinear reads take the pixel after). docs/inspection.md, "Pixels in
/// proportion to the goal".
struct EdgeReach {
    double inside = 0.0;  ///< px towards the object
    double outside = 0.0; ///< px towards the background
    double lateral = 1.0; ///< px either side, in rows and columns
};
EdgeReach findEdgeReach(double bandPx);

/// The silhouette edge along pixel + s·normal (normal: unit, pointing from the
/// object to the background), s in [-band, band]: the threshold crossing
/// nearest s = 0, refined by the integral of the normalised profile. nullopt
/// without a clean crossing (contrast under 3 % of full scale, a level within
/// a quarter of the contrast of the threshold, the window leaving the
/// sensor, or any read on the sensor outside the delivered region).
std::optional<EdgeFound> findEdge(const EdgeImage& image, const Eigen::Vector2d& pixel, const Eigen::Vector2d& normal,
                                  double bandPx);

} // namespace hg::vision
