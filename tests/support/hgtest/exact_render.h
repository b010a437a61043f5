// An independent test renderer: each pixel's covered area, estimated without
// bias by stratified jittered supersampling.
//
// What it is for. Accuracy tests must judge the inspection on frames that the
// code under test did not render. The product's renderer (src/sim, the
// digital twin) computes coverage by merging x-intervals on sub-scanlines of
// the front-facing triangles; this one shares no code and no method with it:
// it asks, for points of a pixel, whether they fall inside any triangle of
// the meshes, in the camera's undistorted normalised plane. OpenCV's polygon
// fill is not used (cv::fillPoly counts boundary samples in and grows every
// silhouette by about 0.1 px).
//
// The silhouette is the union of the projections of all triangles of the
// meshes, front- and back-facing (the union is the same and needs no
// orientation). The triangles are projected onto the normalised plane
// (x/z, y/z of the camera frame), where they are straight; a sample point of
// pixel coordinates (u, v) is undistorted with CameraModel::undistortPixel —
// Newton's method to a residual below 1e-15 in normalised units, i.e. a
// round trip project(undistortPixel(p)) within 1e-9 px
// (tests/sim/test_exact_render.cpp checks it), where cv::undistortPoints'
// default criteria stop at ~1e-3 px — and tested against the triangles, so
// lens distortion bends the edges exactly as the camera does.
// Pixel convention (camera.h): pixel (c, r) covers [c-0.5, c+0.5] x [r-0.5, r+0.5].
// A telecentric camera (docs/telecentric.md) is drawn on its orthographic
// plane, (x, y) of the camera frame in mm, with the pixel K·(x, y, 1)
// computed here from the intrinsics' numbers — no code of the camera's — and
// no lens distortion (refused); depth then plays no part (no near limit).
//
// Method. A pixel that the silhouette's boundary may cross is cut into S x S
// strata (S = samplesPerSide) with one uniformly jittered sample in each,
// drawn from a std::mt19937_64 seeded from `seed` and the pixel's index (so
// the image is reproducible and independent of the threads' order);
// coverage = inside samples / S². Every other pixel is entirely inside or
// entirely outside and gets exactly 1 or 0:
//  - The boundary of the union lies on the contour edges: an edge shared by
//    exactly two triangles whose third vertices project to opposite sides of
//    it has the union on both sides, and a vertex whose every edge is such an
//    edge is surrounded by its fan, so neither can be on the boundary. Every
//    other edge (a fold, a border, an edge of three or more triangles or of a
//    triangle seen edge-on) is a contour edge. Vertices are welded by exact
//    position first, so triangle soups (STL) work; whatever is not welded
//    only adds contour edges — conservative, never wrong.
//  - The contour edges (straight in the normalised plane) are walked through
//    the camera's projection in steps of at most 0.25 px and every pixel
//    within 0.25 px of a step's end is marked: a pixel whose square meets an
//    edge is marked (the curve lies within half a step of a step's end; the
//    sag of a distorted edge over 0.25 px is below 1e-4 px for any radius of
//    curvature above 100 px).
//  - The unmarked pixels fall into 4-connected regions that no boundary
//    crosses; one point test at the centre of one pixel per region decides
//    the whole region, 1 or 0.
// This replaces the test "the pixel's four corners lie in one triangle": on a
// tessellated part most silhouette pixels straddle an internal edge and
// would be supersampled. Point tests look up their triangles in a grid over
// the normalised plane filled with the cells each triangle overlaps (exact,
// no margin needed under distortion). `sampleEveryPixel` supersamples every
// pixel instead — slow; the test checks that the images are identical.
// Assumption: the lens distortion is one-to-one over the image (as
// undistortPixel assumes); geometry that the distortion model folds back
// into the image from far outside it is not drawn.
//
// Accuracy. The estimate of a pixel is unbiased: each stratum's sample is
// inside with the probability of the stratum's covered fraction p_i, so the
// expected coverage is the pixel's exact covered area, and the mean position
// of an edge over many pixels (and the summed area) is unbiased. Its error is
// Σ(I_i − p_i)/S² over the strata the boundary cuts: variance
// Σ p_i(1 − p_i)/S⁴ ≤ n/(4 S⁴) for n cut strata. A straight edge cuts at
// most 2S − 1 strata (at most two per stratum row, each adding at most
// 1/(4 S⁴) of variance), so the standard deviation of a pixel crossed by one
// straight edge is at most √(2S − 1)/(2S²) — 0.011 for S = 16, 0.0039 for
// S = 32 — and its error can never exceed (2S − 1)/S² < 2/S.
// Uncut pixels are exact.
//
// Cost: the supersampled pixels follow the contour's length, not the image's
// area; the point tests of the samples run on `threads` threads (each pixel
// written by one thread, its result independent of which).
#pragma once

#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/mesh.h"

#include <array>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

namespace hgtest {

struct ExactRenderOptions {
    /// Strata per pixel side S (S² samples per supersampled pixel), 1..256.
    int samplesPerSide = 16;
    /// Seed of the jitter; equal seeds give identical images.
    std::uint64_t seed = 0;
    /// Vertices at camera-frame z <= nearPlaneMm (mm) are refused with
    /// std::invalid_argument: the perspective projection needs z > 0 (a
    /// telecentric camera's does not).
    double nearPlaneMm = 1.0;
    /// Threads supersampling the boundary pixels; 0 = one per hardware thread.
    int threads = 0;
    /// Supersample every pixel of the image (slow): for testing the
    /// acceleration, which must give an identical image.
    bool sampleEveryPixel = false;

    /// Throws std::invalid_argument naming the offending option.
    void validate() const;
};

/// CV_32FC1 image of camera.imageSize(): the fraction of each pixel's area
/// covered by the union of the projections of every triangle of `meshes`
/// (part frame, mm), estimated as described above. Throws
/// std::invalid_argument for bad options, a bad camera, or a vertex at or
/// behind the near limit.
cv::Mat exactCoverage(const std::vector<hg::model::TriangleMesh>& meshes, const hg::geometry::CameraModel& camera,
                      const ExactRenderOptions& options = {});

/// How a coverage image becomes a backlit grey image (8-bit grey levels).
struct ExactShading {
    /// Grey level of the lit background and of the object, 0..255.
    double background = 216.75;
    double object = 20.4;
    /// Optics blur: Gaussian σ in pixels (0 = none; borders replicated).
    double blurSigmaPx = 0.0;
    /// Sensor noise: Gaussian σ in grey levels (0 = none).
    double noiseSigma = 0.0;
    /// Seed of the noise (std::mt19937_64, pixels in raster order).
    std::uint64_t seed = 0;
};

/// grey = background + (object − background)·coverage, then the blur, then
/// the noise, rounded to the nearest level and saturated: CV_8UC1. Independent
/// of hg::sim::shadeCoverage. Throws std::invalid_argument unless `coverage`
/// is CV_32FC1 and the levels and σs are finite (σ >= 0).
cv::Mat shadeExact(const cv::Mat& coverage, const ExactShading& shading);

/// A line's frame as the accuracy tests take it: coverage from 32 × 32
/// samples per pixel (jitter seed `seed`·100 + `view`), blur σ 0.6 px and
/// noise σ 1.5 grey levels (seed `seed`·100 + 50 + `view`).
cv::Mat lineFrame(const std::vector<hg::model::TriangleMesh>& meshes, const hg::geometry::CameraModel& camera,
                  std::uint64_t seed, std::uint64_t view);

/// A lens for telecentricChessboardCoverage(), described without any of the
/// product's types: a camera-frame point (x, y, z) in mm is imaged at
/// (x, y) — no division by z —, distorted as cv::projectPoints distorts
/// (x/z, y/z) with (k1, k2, p1, p2, k3) (k1 in mm⁻², ...), then
/// pixel = (fx·x_d + cx, fy·y_d + cy), fx and fy in px per mm.
struct TelecentricLens {
    double fx = 100.0, fy = 100.0, cx = 0.0, cy = 0.0;
    std::array<double, 5> dist{};
    cv::Size imageSize;
};

/// A chessboard of (innerCols + 1) x (innerRows + 1) squares of `squareMm`,
/// in its own frame: the first inner corner at the origin, x along the
/// columns, y along the rows, z = 0; the square that spans
/// [(i−1)s, i·s] x [(j−1)s, j·s] is black when i + j is even. Nothing else is
/// drawn: the rest of the plane is white.
struct PlanarChessboard {
    int innerCols = 9, innerRows = 6;
    double squareMm = 1.0;
};

/// CV_32FC1: the exact fraction of each pixel covered by the black squares of
/// `board` at pose camera_from_board (R, t) through `lens`. Each square's
/// outline is mapped point by point through the lens (every edge cut into
/// pieces of at most `maxPiecePx` pixels, so a distorted edge is followed to
/// within its sag, below 1e-5 px for the pieces of 0.25 px and curvature
/// radii above 1000 px), and the polygon's area in every pixel is integrated
/// exactly, row by row, from the signed area right of each edge — no
/// sampling, no noise. Throws std::invalid_argument for a bad lens or board.
cv::Mat telecentricChessboardCoverage(const PlanarChessboard& board, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                      const TelecentricLens& lens, double maxPiecePx = 0.25);

/// The pixel of a board point (x, y, 0) through `lens` at pose (R, t), by the
/// lens's definition above (the corners' true positions for a test).
Eigen::Vector2d telecentricPixel(const TelecentricLens& lens, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                 double xMm, double yMm);

} // namespace hgtest
