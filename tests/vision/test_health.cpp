// The station health monitor (docs/health.md) on frames rendered here from
// their analytic truth: a backlight of known shape, straight edges at known
// sub-pixel places under a known Gaussian blur integrated over each pixel's
// area (closed forms of erf, no sampling), dust specks of known place and
// size, Gaussian noise of known σ, 8-bit quantisation.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "hullgauge/common/error.h"
#include "hullgauge/vision/edge.h"
#include "hullgauge/vision/health.h"

using namespace hg::vision;
using Vec2 = Eigen::Vector2d;

namespace {

double Phi(double x)
{
    return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

double phi(double x)
{
    return std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI);
}

// The mean over one pixel of a straight edge's step blurred by a Gaussian of
// σ px (0: sharp), the pixel's centre `t` px on the background side of the
// edge. The unit square's footprint along the normal n is the sum of two
// boxes |n.x| and |n.y| wide, so the mean is a second difference of the
// step's second antiderivative (a first difference of the first when the
// edge is aligned with the pixels).
double pixelStep(double t, double sigma, const Vec2& normal)
{
    const auto F1 = [&](double s) {
        if (sigma == 0.0) return std::max(s, 0.0);
        const double x = s / sigma;
        return sigma * (x * Phi(x) + phi(x));
    };
    const auto F2 = [&](double s) {
        if (sigma == 0.0) return 0.5 * std::max(s, 0.0) * std::max(s, 0.0);
        const double x = s / sigma;
        return sigma * sigma * 0.5 * ((x * x + 1.0) * Phi(x) + x * phi(x));
    };
    const double a = std::abs(normal.x()), b = std::abs(normal.y());
    if (std::min(a, b) < 1e-6) {
        const double w = std::max(a, b);
        return (F1(t + 0.5 * w) - F1(t - 0.5 * w)) / w;
    }
    return (F2(t + 0.5 * (a + b)) - F2(t + 0.5 * (a - b)) - F2(t - 0.5 * (a - b)) + F2(t - 0.5 * (a + b))) / (a * b);
}

// An edge of the object: the half-plane behind `point` against `normal` (unit,
// from the object to the background) is the object's side.
struct Edge {
    Vec2 point;
    Vec2 normal;
};

// A backlit scene on a sensor: the backlight's level per pixel (grey levels),
// an object (the intersection of the edges' half-planes; exact for one edge
// and wherever the edges' blurs do not overlap) of a level `object`, dark
// specks on the backlight, noise.
struct Scene {
    cv::Size sensor{640, 480};
    std::function<double(double, double)> backlight = [](double, double) { return 200.0; };
    std::vector<Edge> edges; ///< none: no object
    double object = 40.0;
    double blurSigma = 0.0;
    struct Speck {
        cv::Rect pixels;
        double depth = 0.5; ///< fraction of the backlight it takes away
    };
    std::vector<Speck> specks;
    double noiseSigma = 1.0;
    int depth = CV_8U;

    // Pixel (x, y) of the sensor before noise.
    double level(int x, int y) const
    {
        double light = backlight(x, y);
        for (const Speck& s : specks)
            if (s.pixels.contains({x, y})) light *= 1.0 - s.depth;
        if (edges.empty()) return light;
        // Inside every half-plane: the object's share of the pixel.
        double objectness = 1.0;
        for (const Edge& e : edges) objectness *= pixelStep(-(Vec2(x, y) - e.point).dot(e.normal), blurSigma, e.normal);
        return object + (light - object) * (1.0 - objectness);
    }

    // The sensor's frame (or the region `region` of it), noise seeded by `seed`.
    cv::Mat render(std::uint64_t seed, cv::Rect region = {}) const
    {
        if (region.empty()) region = {{0, 0}, sensor};
        std::mt19937_64 rng(seed);
        std::normal_distribution<double> noise(0.0, noiseSigma);
        const double full = depth == CV_8U ? 255.0 : 65535.0;
        cv::Mat out(region.size(), depth == CV_8U ? CV_8UC1 : CV_16UC1);
        for (int v = 0; v < region.height; ++v)
            for (int u = 0; u < region.width; ++u) {
                const double value = std::clamp(std::round(level(region.x + u, region.y + v) + noise(rng)), 0.0, full);
                if (depth == CV_8U)
                    out.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(value);
                else
                    out.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(value);
            }
        return out;
    }
};

// A backlight that falls off towards the corners by 20 % (vignetting).
double vignetted(double x, double y)
{
    const double dx = (x - 320.0) / 400.0, dy = (y - 240.0) / 400.0;
    return 200.0 * (1.0 - 0.2 * (dx * dx + dy * dy) / 0.5);
}

FlatField referenceOf(const Scene& scene, int frames = 4)
{
    std::vector<cv::Mat> shots;
    for (int i = 0; i < frames; ++i) shots.push_back(scene.render(1000 + static_cast<std::uint64_t>(i)));
    return buildFlatField(shots, 1'790'000'000'000, 32);
}

EdgeImage imageOf(cv::Mat grey, const Scene& scene, cv::Point origin = {0, 0})
{
    EdgeImage image;
    image.grey = std::move(grey);
    image.threshold = 0.5 * (scene.object + 200.0);
    image.objectIsDark = true;
    image.origin = origin;
    image.sensor = scene.sensor;
    return image;
}

// `count` probes along an edge, `spacing` px apart from `from` px along it,
// each placed `offset` px off the edge along its normal.
std::vector<EdgeProbe> probesAlong(const Edge& e, int count, double spacing, double from = 0.0, double offset = 0.0)
{
    const Vec2 along(-e.normal.y(), e.normal.x());
    std::vector<EdgeProbe> out;
    for (int i = 0; i < count; ++i)
        out.push_back({e.point + (from + i * spacing) * along + offset * e.normal, e.normal});
    return out;
}

Vec2 unit(double degrees)
{
    return {std::cos(degrees * M_PI / 180.0), std::sin(degrees * M_PI / 180.0)};
}

} // namespace

// --- The reference -----------------------------------------------------------

TEST(FlatField, BlockLevelsNoiseAndItsOwnSpecks)
{
    Scene empty;
    empty.backlight = vignetted;
    empty.noiseSigma = 1.5;
    empty.specks = {{{100, 100, 3, 3}, 0.5}, {{401, 250, 2, 1}, 0.4}};
    const FlatField ref = referenceOf(empty);
    ASSERT_EQ(ref.sensor, empty.sensor);
    ASSERT_EQ(ref.level.size(), cv::Size(20, 15)); // 640 / 32, 480 / 32
    EXPECT_EQ(ref.takenUnixMs, 1'790'000'000'000);
    // Each block's level: the backlight's mean over its pixels (noise averages
    // out over 4 × 1024 pixels to ±0.03 grey levels, the rounding to ±0.005).
    for (int by : {0, 7, 14})
        for (int bx : {0, 9, 19}) {
            double sum = 0.0;
            for (int y = by * 32; y < by * 32 + 32; ++y)
                for (int x = bx * 32; x < bx * 32 + 32; ++x) sum += vignetted(x, y);
            EXPECT_NEAR(ref.level.at<float>(by, bx), sum / 1024.0 / 255.0, 0.2 / 255.0) << bx << ", " << by;
        }
    // The frame's noise: σ and the rounding's 1/√12 together.
    EXPECT_NEAR(ref.noise, std::sqrt(1.5 * 1.5 + 1.0 / 12.0) / 255.0, 0.1 * 1.5 / 255.0);
    ASSERT_EQ(ref.dustSpecks, 2);
    ASSERT_EQ(ref.dustAt.size(), 2u);
    std::vector<cv::Point2f> at = ref.dustAt;
    std::sort(at.begin(), at.end(), [](auto a, auto b) { return a.x < b.x; });
    EXPECT_NEAR(at[0].x, 101.0, 1e-3);
    EXPECT_NEAR(at[0].y, 101.0, 1e-3);
    EXPECT_NEAR(at[1].x, 401.5, 1e-3);
    EXPECT_NEAR(at[1].y, 250.0, 1e-3);
}

TEST(FlatField, RefusesFramesThatAreNotOneEmptyFixture)
{
    Scene empty;
    const cv::Mat a = empty.render(1), b = empty.render(2);
    const auto refusal = [](std::vector<cv::Mat> frames) -> std::string {
        try {
            buildFlatField(frames, 0);
        } catch (const hg::InputError& e) {
            return e.what();
        }
        return "accepted";
    };
    EXPECT_NE(refusal({}).find("no frames"), std::string::npos);
    EXPECT_NE(refusal({a, b(cv::Rect(0, 0, 320, 240)).clone()}).find("frame 2: 320x240"), std::string::npos);
    cv::Mat colour;
    cv::merge(std::vector<cv::Mat>{a, a, a}, colour);
    EXPECT_NE(refusal({a, colour}).find("frame 2: expected an 8- or 16-bit grey frame"), std::string::npos);
    EXPECT_NE(refusal({cv::Mat(480, 640, CV_8UC1, cv::Scalar(0))}).find("black"), std::string::npos);
    // Something in the fixture: the block at pixel (64, 96) is dark.
    Scene dirty = empty;
    dirty.edges = {{{60.0, 100.0}, {-1.0, 0.0}},
                   {{100.0, 100.0}, {1.0, 0.0}},
                   {{80.0, 90.0}, {0.0, -1.0}},
                   {{80.0, 130.0}, {0.0, 1.0}}};
    const std::string dark = refusal({dirty.render(3)});
    EXPECT_NE(dark.find("block at pixel (64, 96)"), std::string::npos) << dark;
    EXPECT_NE(dark.find("something is in the fixture"), std::string::npos) << dark;
    EXPECT_THROW(buildFlatField(std::vector<cv::Mat>{a}, 0, 0), hg::ArgumentError);
}

// --- Backlight and uniformity -----------------------------------------------

TEST(HealthMonitor, BacklightDimmedTo70PercentReads0Point70)
{
    Scene empty;
    empty.backlight = vignetted;
    HealthMonitor monitor(referenceOf(empty));
    Scene dimmed = empty;
    dimmed.backlight = [](double x, double y) { return 0.7 * vignetted(x, y); };
    dimmed.object = 20.0;
    dimmed.edges = {{{250.0, 0.0}, unit(10.0)}}; // a part on the left, its edge 10° off the columns
    monitor.beginCycle();
    for (std::size_t view = 0; view < 4; ++view) {
        EdgeImage image = imageOf(dimmed.render(view), dimmed);
        image.threshold = 80.0;
        monitor.addView(view, image, {});
    }
    const HealthFigures f = monitor.endCycle();
    EXPECT_EQ(f.views, 4);
    EXPECT_NEAR(f.backlight, 0.70, 0.007);
    // A panel dimmed evenly keeps its shape.
    EXPECT_LT(f.uniformity, 0.01);
    EXPECT_TRUE(std::isnan(f.edgeWidthPx)); // no probes
}

// Uniformity: the worst zone (about 128 px square, docs/health.md) against
// the median. A gradient of ±15 % across 640 px puts the outermost zones'
// centres 256 px from the middle: 0.30 · 256 / 640 = 0.12.
TEST(HealthMonitor, UniformityOfALinearGradient)
{
    Scene empty;
    empty.backlight = vignetted;
    HealthMonitor monitor(referenceOf(empty));
    Scene aged = empty;
    aged.backlight = [](double x, double y) { return vignetted(x, y) * (1.0 + 0.30 * (x - 319.5) / 640.0); };
    monitor.beginCycle();
    for (std::size_t view = 0; view < 8; ++view) monitor.addView(view, imageOf(aged.render(10 + view), aged), {});
    const HealthFigures f = monitor.endCycle();
    const double expected = 0.30 * (575.5 - 319.5) / 640.0;
    EXPECT_NEAR(f.uniformity, expected, 0.1 * expected);
    EXPECT_NEAR(f.backlight, 1.0, 0.01);
    EXPECT_EQ(f.dustSpecks, 0.0); // the first band surveyed: a gradient is no dust
}

// A part whose top edge runs nearly along the rows, blurred, leaves a strip
// of backlight a few pixels high above it in the zones it crosses: the fringe
// there is brighter than the threshold and its row neighbours are as bright
// as it is, but it is no dim panel. The panel is as flat as the reference:
// uniformity at the noise floor (docs/health.md, "Background samples"). A
// check along the row only read these scenes 0.085, 0.095, 0.115 and 0.122.
TEST(HealthMonitor, AFringeAlongTheRowsIsNoDimZone)
{
    Scene empty;
    empty.backlight = vignetted;
    const FlatField reference = referenceOf(empty);
    struct Case {
        double row, degrees, blur; // the edge through (320, row), turned off the rows, its blur σ
    };
    for (const Case c : {Case{266.0, 1.0, 1.5}, Case{270.0, 1.0, 1.5}, Case{262.0, 3.0, 2.5}, Case{270.0, 0.3, 2.5}}) {
        SCOPED_TRACE("edge through row " + std::to_string(c.row) + ", " + std::to_string(c.degrees) + "°, σ " +
                     std::to_string(c.blur));
        HealthMonitor monitor(reference);
        Scene seated = empty;
        seated.blurSigma = c.blur;
        seated.edges = {{{320.0, c.row}, unit(-90.0 + c.degrees)}}; // the object below
        monitor.beginCycle();
        for (std::size_t view = 0; view < 8; ++view)
            monitor.addView(view, imageOf(seated.render(40 + view), seated), {});
        const HealthFigures f = monitor.endCycle();
        EXPECT_NEAR(f.backlight, 1.0, 0.005);
        EXPECT_LT(f.uniformity, 0.01);
    }
}

// --- Dust --------------------------------------------------------------------

// Specks of the reference are not new; the others are counted once the survey
// went through every band, once each: a speck across a band's boundary, a
// speck the part hides in one view and the next view shows.
TEST(HealthMonitor, DustSpecksBeyondTheReferenceAfterTheSurvey)
{
    Scene empty;
    empty.backlight = vignetted;
    const std::vector<Scene::Speck> old = {{{40, 40, 3, 3}, 0.5}, {{600, 400, 2, 2}, 0.3}};
    empty.specks = old;
    const FlatField ref = referenceOf(empty);
    ASSERT_EQ(ref.dustSpecks, 2);
    HealthMonitor monitor(ref);
    ASSERT_EQ(monitor.dustSurveyBands(), 15); // 480 rows in bands of 32

    Scene dusty = empty;
    dusty.specks.push_back({{500, 60, 1, 1}, 0.6});   // one pixel
    dusty.specks.push_back({{300, 95, 4, 3}, 0.4});   // across the boundary of bands 2 and 3 (row 96)
    dusty.specks.push_back({{450, 300, 5, 5}, 0.25}); // 25 px, a quarter dark
    dusty.specks.push_back({{200, 200, 3, 3}, 0.5});  // behind the part in view 0, free in view 1
    dusty.specks.push_back({{560, 150, 7, 7}, 0.5});  // 49 px: a smear, not a speck
    dusty.object = 20.0;
    Scene view0 = dusty, view1 = dusty;
    view0.edges = {{{150.0, 0.0}, {-1.0, 0.0}}, {{260.0, 0.0}, {1.0, 0.0}}}; // the part over columns 150-260
    view1.edges = {{{30.0, 0.0}, {-1.0, 0.0}},
                   {{120.0, 0.0}, {1.0, 0.0}}}; // turned: over columns 30-120 and a speck of the reference
    const std::array<EdgeImage, 2> images = {imageOf(view0.render(20), view0), imageOf(view1.render(21), view1)};

    HealthFigures f;
    for (int cycle = 0; cycle < monitor.dustSurveyBands(); ++cycle) {
        monitor.beginCycle();
        monitor.addView(0, images[0], {});
        monitor.addView(1, images[1], {});
        f = monitor.endCycle();
        EXPECT_EQ(f.dustBandsSurveyed, cycle + 1);
    }
    EXPECT_EQ(f.dustSpecks, 4.0);
    // Another round of the survey finds the same.
    for (int cycle = 0; cycle < monitor.dustSurveyBands(); ++cycle) {
        monitor.beginCycle();
        monitor.addView(0, images[0], {});
        monitor.addView(1, images[1], {});
        f = monitor.endCycle();
    }
    EXPECT_EQ(f.dustSpecks, 4.0);
    EXPECT_EQ(f.dustBandsSurveyed, 15);
}

TEST(HealthMonitor, DustSurveyOfRegionFrames)
{
    Scene empty;
    empty.backlight = vignetted;
    HealthMonitor monitor(referenceOf(empty));
    Scene dusty = empty;
    const std::vector<cv::Point> at = {{20, 20}, {330, 100}, {610, 470}, {100, 300}, {400, 401}};
    for (const cv::Point& p : at) dusty.specks.push_back({{p.x, p.y, 2, 2}, 0.5});
    // Four views cut to regions that together cover the sensor, overlapping
    // by 40 px: a speck in an overlap is one speck.
    const std::vector<cv::Rect> regions = {
        {0, 0, 360, 260}, {320, 0, 320, 260}, {0, 220, 360, 260}, {300, 220, 340, 260}};
    std::vector<EdgeImage> images;
    for (std::size_t v = 0; v < regions.size(); ++v)
        images.push_back(imageOf(dusty.render(30 + v, regions[v]), dusty, regions[v].tl()));
    HealthFigures f;
    for (int cycle = 0; cycle < monitor.dustSurveyBands(); ++cycle) {
        monitor.beginCycle();
        for (std::size_t v = 0; v < images.size(); ++v) monitor.addView(v, images[v], {});
        f = monitor.endCycle();
    }
    EXPECT_EQ(f.dustSpecks, 5.0);
    EXPECT_NEAR(f.backlight, 1.0, 0.01);
}

// --- Edges: focus, contrast, noise, the prediction ---------------------------

// The 10–90 % width of a straight edge blurred by a Gaussian σ and integrated
// over the pixel's area: 2.563·√(σ² + 1/12) px. Below half a pixel of blur a
// profile cannot tell the blur from where the edge lies within its pixel: a
// sharp edge reads between 0 and 1.6 times that, the median over these probes
// about 1.3 times (docs/health.md, "Limits") — sharp, far below any limit.
TEST(HealthMonitor, EdgeWidthFollowsTheBlur)
{
    double sharp = 0.0;
    for (double sigma : {0.0, 0.5, 1.0, 2.0}) {
        Scene scene;
        scene.blurSigma = sigma;
        const Edge edge{{320.3, 240.0}, unit(17.0)};
        scene.edges = {edge};
        HealthMonitor monitor;
        monitor.beginCycle();
        const std::vector<EdgeProbe> probes = probesAlong(edge, 24, 7.3, -84.0, 0.6);
        monitor.addView(0, imageOf(scene.render(40), scene), probes);
        const HealthFigures f = monitor.endCycle();
        const double expected = 2.5631 * std::sqrt(sigma * sigma + 1.0 / 12.0);
        EXPECT_EQ(f.probes, 24) << sigma;
        EXPECT_TRUE(std::isnan(f.backlight)); // no reference
        if (sigma == 0.0) {
            sharp = f.edgeWidthPx;
            EXPECT_LT(sharp, 1.6 * expected);
            continue;
        }
        EXPECT_NEAR(f.edgeWidthPx, expected, 0.1 * expected) << "sigma " << sigma;
        EXPECT_GT(f.edgeWidthPx, sharp);
    }
}

TEST(HealthMonitor, ContrastAndNoise)
{
    for (double noise : {1.0, 2.0}) {
        Scene scene;
        scene.object = 50.0;
        scene.noiseSigma = noise;
        scene.blurSigma = 0.8;
        const Edge left{{200.0, 240.0}, unit(180.0 + 5.0)}, right{{440.0, 240.0}, unit(-5.0)};
        scene.edges = {left, right};
        HealthMonitor monitor;
        monitor.beginCycle();
        std::vector<EdgeProbe> probes = probesAlong(left, 3, 40.0, -40.0);
        for (const EdgeProbe& p : probesAlong(right, 3, 40.0, -40.0)) probes.push_back(p);
        monitor.addView(0, imageOf(scene.render(50), scene), probes);
        monitor.addView(1, imageOf(scene.render(51), scene), probes);
        const HealthFigures f = monitor.endCycle();
        EXPECT_EQ(f.probes, 12);
        EXPECT_NEAR(f.contrast, 150.0 / 255.0, 0.02 * 150.0 / 255.0);
        EXPECT_NEAR(f.noise, noise / 255.0, 0.1 * noise / 255.0);
    }
}

// The prediction against what findEdge does: the scatter of the edges it
// locates on independent noise along straight edges (4 frames × 240 probes,
// its standard error about 2.5 %). The integral's own part, edgeSigmaPx, is
// an upper estimate (docs/inspection.md, "Uncertainty budget": here 1.5 times
// the scatter of a sharp edge); the blur's part keeps the prediction above
// the scatter as the scatter doubles (σ = 3 px: edgeSigmaPx alone falls 23 % short).
TEST(HealthMonitor, PredictionBoundsTheEdgeScatterUnderBlur)
{
    for (double sigma : {0.0, 1.0, 2.0, 2.5, 3.0}) {
        Scene scene;
        scene.sensor = {200, 1000};
        scene.object = 50.0;
        scene.noiseSigma = 2.0;
        scene.blurSigma = sigma;
        const Edge edge{{100.0, 500.0}, unit(3.0)};
        scene.edges = {edge};
        const std::vector<EdgeProbe> probes = probesAlong(edge, 240, 4.0, -480.0);
        std::vector<double> offsets;
        HealthMonitor monitor;
        monitor.beginCycle();
        for (std::uint64_t seed = 0; seed < 4; ++seed) {
            const EdgeImage image = imageOf(scene.render(60 + seed), scene);
            for (const EdgeProbe& p : probes)
                if (const auto found = findEdge(image, p.pixel, p.normal, 3.0)) offsets.push_back(found->offset);
            monitor.addView(seed, image, std::span(probes).first(6));
        }
        ASSERT_GT(offsets.size(), 900u);
        double mean = 0.0, square = 0.0;
        for (double o : offsets) mean += o / static_cast<double>(offsets.size());
        for (double o : offsets) square += (o - mean) * (o - mean) / static_cast<double>(offsets.size() - 1);
        const double scatter = std::sqrt(square);
        const HealthFigures f = monitor.endCycle();
        EXPECT_GE(f.predictedSigmaPx, 0.95 * scatter) << "sigma " << sigma;
        EXPECT_LE(f.predictedSigmaPx, 1.6 * scatter) << "sigma " << sigma;
    }
}

// The rule of docs/health.md, "Prediction", worked by hand for an edge of
// σ = 2 px (width 2·2.5631 px), noise 0.01 and contrast 0.5 of full scale:
// k = 2·Q(1.5) + 6·mean(φ(1.5), φ(1.75), φ(2), φ(2.25))/2 = 0.13361 + 0.22614,
// rise = erf(0.25/√2) = 0.19741, r = 0.02;
// σ² = r²·(15 + (2/3)·k²/rise² + 2·k/rise), 15 the integral's (edgeSigmaPx with c = 3).
TEST(HealthMonitor, PredictionWorkedByHand)
{
    const double k = 0.13361 + 0.22614, rise = 0.19741, r = 0.02;
    const double expected = r * std::sqrt(15.0 + 2.0 / 3.0 * k * k / (rise * rise) + 2.0 * k / rise);
    EXPECT_NEAR(predictedEdgeSigmaPx(0.01, 0.5, 2.0 * 2.5631), expected, 1e-4 * expected);
    // A sharp edge: the integral's alone; at the focus limit (3 px) within 1 %.
    const double sharp = edgeSigmaPx(0.01, 0.5);
    EXPECT_NEAR(sharp, r * std::sqrt(15.0), 1e-12);
    EXPECT_DOUBLE_EQ(predictedEdgeSigmaPx(0.01, 0.5, 0.74), sharp);
    EXPECT_NEAR(predictedEdgeSigmaPx(0.01, 0.5, 3.0), sharp, 0.01 * sharp);
    EXPECT_TRUE(std::isnan(predictedEdgeSigmaPx(kNoFigure, 0.5, 1.0)));
    EXPECT_TRUE(std::isnan(predictedEdgeSigmaPx(0.01, kNoFigure, 1.0)));
    EXPECT_DOUBLE_EQ(predictedEdgeSigmaPx(0.01, 0.5, kNoFigure), sharp);
}

// --- Regions, refusals, warnings ----------------------------------------------

// A region of the sensor is read where it lies: the same figures as the whole
// frame; a probe whose profile leaves the region is not read.
TEST(HealthMonitor, RegionsOfTheSensor)
{
    Scene empty;
    empty.backlight = vignetted;
    const FlatField ref = referenceOf(empty);
    Scene scene = empty;
    scene.backlight = [](double x, double y) { return 0.9 * vignetted(x, y); };
    scene.blurSigma = 1.0;
    const Edge edge{{300.0, 240.0}, unit(180.0 + 8.0)};
    scene.edges = {edge};
    const std::vector<EdgeProbe> probes = probesAlong(edge, 6, 10.0, -25.0);
    const cv::Rect region(250, 150, 300, 200);
    HealthMonitor whole(ref), part(ref);
    whole.beginCycle();
    part.beginCycle();
    const cv::Mat frame = scene.render(70);
    whole.addView(0, imageOf(frame, scene), probes);
    part.addView(0, imageOf(frame(region).clone(), scene, region.tl()), probes);
    // A probe whose profile runs off the region (its pixel 3 px inside the region's top).
    const std::vector<EdgeProbe> outside = {{{293.0, 153.0}, unit(98.0)}};
    part.addView(1, imageOf(scene.render(71, region), scene, region.tl()), outside);
    const HealthFigures w = whole.endCycle(), p = part.endCycle();
    EXPECT_EQ(p.probes, 6);
    EXPECT_NEAR(p.backlight, 0.9, 0.009);
    EXPECT_NEAR(w.backlight, 0.9, 0.009);
    EXPECT_NEAR(p.edgeWidthPx, 2.5631 * std::sqrt(1.0 + 1.0 / 12.0), 0.1 * 2.78);
    EXPECT_DOUBLE_EQ(p.edgeWidthPx, w.edgeWidthPx); // the same pixels, the same profiles
    EXPECT_DOUBLE_EQ(p.contrast, w.contrast);
}

// 16-bit frames: the same figures, in fractions of 65535.
TEST(HealthMonitor, SixteenBitFrames)
{
    Scene empty;
    empty.depth = CV_16U;
    empty.backlight = [](double x, double y) { return 250.0 * vignetted(x, y); };
    empty.noiseSigma = 200.0;
    HealthMonitor monitor(referenceOf(empty));
    Scene scene = empty;
    scene.backlight = [](double x, double y) { return 0.8 * 250.0 * vignetted(x, y); };
    scene.object = 5000.0;
    scene.blurSigma = 1.0;
    const Edge edge{{200.0, 240.0}, unit(180.0 + 12.0)};
    scene.edges = {edge};
    const std::vector<EdgeProbe> probes = probesAlong(edge, 6, 12.0, -30.0);
    monitor.beginCycle();
    for (std::size_t view = 0; view < 4; ++view) {
        EdgeImage image = imageOf(scene.render(80 + view), scene);
        image.threshold = 20000.0;
        monitor.addView(view, image, probes);
    }
    const HealthFigures f = monitor.endCycle();
    EXPECT_NEAR(f.backlight, 0.8, 0.008);
    EXPECT_NEAR(f.noise, 200.0 / 65535.0, 0.1 * 200.0 / 65535.0);
    EXPECT_EQ(f.probes, 24);
    // The backlight beside the probes (the part lies on their right), within the 7 px the levels are read at.
    const double background = 0.8 * 250.0 * vignetted(190.0, 240.0);
    EXPECT_NEAR(f.contrast, (background - 5000.0) / 65535.0, 0.02 * (background - 5000.0) / 65535.0);
    EXPECT_NEAR(f.edgeWidthPx, 2.5631 * std::sqrt(1.0 + 1.0 / 12.0), 0.1 * 2.78);
}

// The reference is the backlight of one sensor: the frames of another are
// judged without it (noise and edges only).
TEST(HealthMonitor, AReferenceOfAnotherSensorIsNotApplied)
{
    Scene empty;
    HealthMonitor monitor(referenceOf(empty));
    Scene other = empty;
    other.sensor = {320, 240};
    monitor.beginCycle();
    monitor.addView(0, imageOf(other.render(90), other), {});
    const HealthFigures f = monitor.endCycle();
    EXPECT_EQ(f.views, 1);
    EXPECT_TRUE(std::isnan(f.backlight));
    EXPECT_TRUE(std::isnan(f.uniformity));
    EXPECT_TRUE(std::isnan(f.dustSpecks));
    EXPECT_NEAR(f.noise, std::sqrt(1.0 + 1.0 / 12.0) / 255.0, 0.1 / 255.0);
}

TEST(HealthMonitor, RefusesFramesItCannotRead)
{
    HealthMonitor monitor;
    monitor.beginCycle();
    EdgeImage colour;
    colour.grey = cv::Mat(10, 10, CV_8UC3, cv::Scalar(0, 0, 0));
    try {
        monitor.addView(3, colour, {});
        FAIL() << "accepted a colour frame";
    } catch (const hg::ArgumentError& e) {
        EXPECT_NE(std::string(e.what()).find("view 3: expected an 8- or 16-bit grey frame"), std::string::npos);
    }
    EdgeImage off;
    off.grey = cv::Mat(100, 100, CV_8UC1, cv::Scalar(200));
    off.origin = {600, 0};
    off.sensor = {640, 480};
    EXPECT_THROW(monitor.addView(4, off, {}), hg::ArgumentError);
    EXPECT_EQ(monitor.endCycle().views, 0);
    // A reference whose levels do not cover its sensor in its cells.
    FlatField odd;
    odd.sensor = {640, 480};
    odd.level = cv::Mat(14, 20, CV_32FC1, cv::Scalar(0.8)); // 480 / 32 = 15 rows of blocks
    EXPECT_THROW(HealthMonitor{odd}, hg::ArgumentError);
}

// Whatever the frames and probes, a figure is read or is NaN: probes with no
// place, no direction or far off the sensor; black, saturated and
// checkerboard frames (every difference the largest a 16-bit frame holds).
TEST(HealthMonitor, OddFramesAndProbesAreReadOrLeftOut)
{
    Scene empty;
    HealthMonitor monitor(referenceOf(empty));
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<EdgeProbe> odd = {{{nan, 10.0}, {1.0, 0.0}},
                                        {{100.0, 100.0}, {0.0, 0.0}},
                                        {{1e12, -1e12}, {0.0, 1.0}},
                                        {{100.0, 100.0}, {nan, 1.0}}};
    monitor.beginCycle();
    EdgeImage black = imageOf(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), empty);
    EdgeImage white = imageOf(cv::Mat(480, 640, CV_8UC1, cv::Scalar(255)), empty);
    cv::Mat board(480, 640, CV_16UC1);
    for (int y = 0; y < board.rows; ++y)
        for (int x = 0; x < board.cols; ++x) board.at<std::uint16_t>(y, x) = (x + y) % 2 == 0 ? 65535 : 0;
    EdgeImage checker = imageOf(board, empty);
    checker.threshold = 100.0;
    EdgeImage unknown = imageOf(empty.render(95), empty);
    unknown.threshold = nan;
    const std::array<const EdgeImage*, 4> images = {&black, &white, &checker, &unknown};
    for (std::size_t view = 0; view < images.size(); ++view) monitor.addView(view, *images[view], odd);
    const HealthFigures f = monitor.endCycle();
    EXPECT_EQ(f.views, 4);
    EXPECT_EQ(f.probes, 0);
    EXPECT_TRUE(std::isnan(f.edgeWidthPx));
    EXPECT_TRUE(std::isnan(f.predictedSigmaPx));
    // The saturated frame and the checkerboard's white squares: all background, at full scale.
    EXPECT_NEAR(f.backlight, 255.0 / 200.0, 0.01);
}

TEST(HealthMonitor, WarningsAndTheirBits)
{
    HealthFigures f;
    EXPECT_TRUE(healthWarnings(f, {}).empty()); // nothing measured warns of nothing
    f.backlight = 0.79;
    f.uniformity = 0.05;
    f.dustSpecks = 6.0;
    f.edgeWidthPx = 2.9;
    f.contrast = 0.39;
    f.noise = 0.021;
    const std::vector<HealthFigure> w = healthWarnings(f, {});
    EXPECT_EQ(w, (std::vector<HealthFigure>{HealthFigure::Backlight, HealthFigure::Dust, HealthFigure::Contrast,
                                            HealthFigure::Noise}));
    EXPECT_EQ(healthWarningBits(w), 0b110101);
    HealthLimits strict;
    strict.maxUniformity = 0.04;
    strict.maxEdgeWidthPx = 2.5;
    EXPECT_EQ(healthWarningBits(healthWarnings(f, strict)), 0b111111);
    EXPECT_EQ(hg::enumName(HealthFigure::Focus), "focus");
    // The edge bias warns either way, beyond 0.25 px by default.
    f.edgeBiasPx = -0.24;
    EXPECT_EQ(healthWarningBits(healthWarnings(f, strict)), 0b111111);
    f.edgeBiasPx = -0.26;
    EXPECT_EQ(healthWarningBits(healthWarnings(f, strict)), 0b1111111);
    f.edgeBiasPx = 0.26;
    EXPECT_EQ(healthWarnings(f, {}).back(), HealthFigure::EdgeBias);
    EXPECT_EQ(hg::enumName(HealthFigure::EdgeBias), "edge_bias");
    // The capability share warns above 0.9 of the bound by default: bit 7.
    f.capability = 0.9;
    EXPECT_EQ(healthWarningBits(healthWarnings(f, {})) & 0x80, 0);
    f.capability = 0.91;
    EXPECT_EQ(healthWarningBits(healthWarnings(f, {})) & 0x80, 0x80);
    EXPECT_EQ(hg::enumName(HealthFigure::Capability), "capability");
}
