// Backlit silhouette renderer: what a camera sees of a part in front of a
// diffuse back light — a bright background and a dark object.
//
// Coverage is computed analytically, not by point sampling: the silhouette of a
// closed mesh is the union of the projections of its front-facing triangles
// (every line of sight that meets the solid enters it through one). Each pixel
// row is cut into `subScanlines` horizontal sub-scanlines; on each one the
// projected triangles give x-intervals which are merged (a union, so overlap
// between triangles or between meshes counts once) and added to the pixels with
// their exact horizontal coverage. Horizontally the result is exact; vertically
// it is the midpoint rule over the sub-scanlines, which is exact for straight
// edges. The cost grows with triangles x rows, not with the image area.
//
// Pixel convention (camera.h): the centre of pixel (c, r) is at (c, r); the
// pixel covers [c-0.5, c+0.5] x [r-0.5, r+0.5].
//
// Lens distortion bends straight edges: triangles are subdivided (in the camera
// frame, before projection) until every projected edge is straight within
// `maxEdgeSagPx`. The split decision depends on an edge's end points only, so
// neighbouring triangles split a shared edge identically and no cracks open.
//
// The grey image follows the backlit model: value = B + (object - B) * coverage,
// with B the back light's level at the pixel, then optional optics blur
// (Gaussian, σ in pixels) and sensor noise (Gaussian, σ in grey levels), both
// reproducible from a seed. The back light need not be even (docs/camera.md,
// "Optics of the simulated camera"): B = background · V · D, a quadratic
// radial fall-off V towards the sensor's corners and dark dust specks D on the
// panel; a halo of light wrapping round the part's edge erodes the silhouette.
#pragma once

#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/mesh.h"

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

namespace hg::sim {

/// A dark speck of dust on the back light, fixed on the sensor (pixels, the
/// centre convention of camera.h): within `radiusPx` of its centre the back
/// light is darkened by the fraction `depth`, the rim anti-aliased over one pixel.
struct DustSpeck {
    double x = 0.0;
    double y = 0.0;
    double radiusPx = 1.0;
    double depth = 0.0;
};

struct RenderOptions {
    /// Sub-scanlines per pixel row (vertical anti-aliasing), >= 4.
    int subScanlines = 16;
    /// Distorted cameras: largest allowed distance (px) between a projected
    /// edge and the straight chord that stands in for it.
    double maxEdgeSagPx = 0.01;
    /// Geometry closer to the camera plane than this (mm, camera z) is clipped.
    double nearPlaneMm = 1.0;

    /// Grey level of the lit background and of the object, as fractions of
    /// full scale (255 or 65535).
    double backgroundLevel = 0.85;
    double objectLevel = 0.08;
    /// Output depth: 8 (CV_8UC1) or 16 (CV_16UC1).
    int bitDepth = 8;
    /// Optics blur: Gaussian σ in pixels (0 = none).
    double blurSigmaPx = 0.0;
    /// Sensor noise: Gaussian σ in grey levels of the output depth (0 = none).
    double noiseSigma = 0.0;
    /// Seed of the noise generator (cv::RNG); equal seeds give equal images.
    std::uint64_t seed = 0;

    /// Back light fall-off at the sensor's corners, a fraction in [0, 0.95]:
    /// V = 1 - vignetting · ρ², ρ the distance from the sensor's centre over
    /// the distance of a corner pixel's centre from it (1 at the corners).
    double vignetting = 0.0;
    /// Dark specks on the back light (sensor pixels).
    std::vector<DustSpeck> dust;
    /// Light wrapping round the part's edge (px, 0–10): the silhouette is
    /// eroded by this distance before shading, so a straight edge's 50 %
    /// crossing moves `haloPx` into the object (erodeCoverage).
    double haloPx = 0.0;

    /// Throws ArgumentError naming the offending option and its value.
    void validate() const;
};

/// Renders the union of one or several closed, outward-oriented meshes (part
/// frame, mm). The renderer keeps its own copies of the meshes.
class SilhouetteRenderer {
  public:
    SilhouetteRenderer() = default;
    explicit SilhouetteRenderer(std::vector<model::TriangleMesh> meshes);

    const std::vector<model::TriangleMesh>& meshes() const { return meshes_; }

    /// CV_32FC1 image of camera.imageSize(): the fraction of each pixel's area
    /// covered by the silhouette, in [0, 1]. Uses subScanlines, maxEdgeSagPx
    /// and nearPlaneMm of `options`.
    cv::Mat coverage(const geometry::CameraModel& camera, const RenderOptions& options = {}) const;

    /// The backlit grey image (CV_8UC1 or CV_16UC1).
    cv::Mat render(const geometry::CameraModel& camera, const RenderOptions& options = {}) const;

    /// The backlit grey image of `window` (within camera.imageSize()) alone,
    /// what a camera sending a region delivers: the part is projected with the
    /// principal point moved by the window's corner and the blur sees a margin
    /// of its kernel's reach around the window (or the sensor's edge), so the
    /// pixels are the whole image's; the noise is drawn for the window alone
    /// (same σ, same seed). Memory and time go with the window, not the sensor.
    /// Throws ArgumentError when the window is empty or leaves the sensor.
    cv::Mat render(const geometry::CameraModel& camera, const RenderOptions& options, const cv::Rect& window) const;

  private:
    std::vector<model::TriangleMesh> meshes_;
};

/// Turns a coverage image (CV_32FC1) into the backlit grey image: halo,
/// shading, blur, noise and quantisation of `options`. The image is the
/// window of `sensor` whose top-left pixel is `origin` (the whole sensor by
/// default): the back light's fall-off and dust are the sensor's.
cv::Mat shadeCoverage(const cv::Mat& coverage, const RenderOptions& options, cv::Point origin = {},
                      cv::Size sensor = {});

/// The silhouette shrunk by `haloPx` (> 0) along its normals: from the
/// coverage blurred by a Gaussian of σ_h = max(1, (haloPx + 0.5) / 3) px a
/// pixel's signed distance to the edge is read as d = σ Φ⁻¹(blurred), σ² =
/// σ_h² + 1/12 (a pixel's box adds 1/12 along any normal), and its coverage
/// becomes clamp(d - haloPx + 0.5, 0, 1). Exact for straight edges to well
/// under 0.01 px; corners and features narrower than ≈ 2σ_h are approximated.
cv::Mat erodeCoverage(const cv::Mat& coverage, double haloPx);

/// Silhouette statistics of a coverage image.
struct CoverageStats {
    /// Object area in pixels (sum of coverage).
    double areaPx = 0.0;
    /// Bounding box of the pixels with any coverage; empty when none.
    cv::Rect boundingBox;
    /// True when the silhouette reaches the image border (part not fully in view).
    bool touchesBorder = false;
};

CoverageStats measureCoverage(const cv::Mat& coverage);

} // namespace hg::sim
