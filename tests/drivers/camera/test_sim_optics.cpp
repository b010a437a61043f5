// The simulated camera's optics and their aging (docs/camera.md, "Optics of the
// simulated camera", "Aging", "The empty fixture") against hand-worked values:
// the back light's level after so many aging steps, its fall-off at the
// corners by the documented formula, each dust speck's centre darkened by its
// depth, the edge profile's 10-90 % width of a Gaussian blur, and the halo's
// shift of a straight edge whose position follows from the pinhole camera.
#include "hgtest/station.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/model/primitives.h"

#include <cmath>
#include <gtest/gtest.h>
#include <numbers>
#include <opencv2/core.hpp>

namespace {

using namespace std::chrono_literals;

// f = 1000 px, principal point (319.5, 239.5), part origin 300 mm in front of
// the camera along the turntable axis. The box of half-size 20 mm shows its
// near face (280 mm away) as a square of half-width 1000 · 20 / 280 px round
// the principal point: edges at u = 319.5 ± 71.428571, v = 239.5 ± 71.428571.
constexpr double kF = 1000.0;
constexpr double kCentreU = 319.5;
constexpr double kCentreV = 239.5;
constexpr double kHalfWidthPx = kF * 20.0 / 280.0;
const std::string kStation = hgtest::stationYaml({.focalPx = kF,
                                                  .principalPointPx = cv::Point2d(kCentreU, kCentreV),
                                                  .cameraKeys = "  driver:\n    backend: sim\n",
                                                  .mount = hgtest::CameraMount::Axis,
                                                  .distanceMm = 300.0});

/// The simulated camera over the box, its controls in `sim_`.
class Twin {
  public:
    /// The sim camera with `extraDriver` keys under camera.driver, configured and active.
    std::unique_ptr<hg::drivers::Camera> make(const std::string& extraDriver)
    {
        auto camera = build(extraDriver);
        EXPECT_TRUE(camera->configure());
        EXPECT_TRUE(camera->activate());
        return camera;
    }

    std::unique_ptr<hg::drivers::Camera> build(const std::string& extraDriver)
    {
        text_ = kStation;
        text_.insert(text_.find("fixture:"), extraDriver);
        auto root = hg::ConfigNode::parse(text_, "station.yaml");
        hg::drivers::CameraEnvironment in;
        in.poseSource = [this] { return pose_; };
        in.parts.emplace_back("box", hg::model::makeBox({-20, -20, -20}, {20, 20, 20}));
        in.simulation = &sim_;
        return hg::drivers::makeCamera(root, std::move(in));
    }

    /// One frame as doubles in grey levels.
    cv::Mat grab(hg::drivers::Camera& camera)
    {
        auto f = camera.grab(100ms);
        EXPECT_TRUE(f.ok()) << f.message;
        cv::Mat out;
        f.image.convertTo(out, CV_64F);
        return out;
    }

    void age(int cycles)
    {
        for (int i = 0; i < cycles; ++i) sim_.camera->countCycle();
    }

    std::string text_; ///< the station file of the last build()
    std::optional<hg::geometry::FixturePose> pose_ = hg::geometry::FixturePose{};
    hg::drivers::SimulationControls sim_;
};

class SimOpticsTest : public ::testing::Test, public Twin {};

double meanOf(const cv::Mat& image, const cv::Rect& box)
{
    return cv::mean(image(box))[0];
}

/// Where `profile` (increasing index, dark to bright) first rises through
/// `level` between `from` and `to`, interpolated linearly between samples.
double risingCrossing(const std::vector<double>& profile, double level, int from, int to)
{
    for (int i = from; i < to; ++i)
        if (profile[i] <= level && profile[i + 1] > level)
            return i + (level - profile[i]) / (profile[i + 1] - profile[i]);
    ADD_FAILURE() << "no crossing of " << level << " in [" << from << ", " << to << "]";
    return std::nan("");
}

/// The row `y` of the image, and the column `x` read downwards.
std::vector<double> row(const cv::Mat& image, int y)
{
    return std::vector<double>(image.ptr<double>(y), image.ptr<double>(y) + image.cols);
}
std::vector<double> column(const cv::Mat& image, int x)
{
    std::vector<double> out;
    for (int y = 0; y < image.rows; ++y) out.push_back(image.at<double>(y, x));
    return out;
}

/// The right edge's 50 % crossing on row `y`: halfway between the object (the
/// square's centre) and the back light 60 px right of the edge.
double rightEdge(const cv::Mat& image, int y)
{
    const auto p = row(image, y);
    const double level = 0.5 * (p[320] + p[450]);
    return risingCrossing(p, level, 320, 450);
}

// Four aging steps' dims of 5 %: the lit background at 0.85 · 0.95^k of full scale after k steps.
TEST_F(SimOpticsTest, AgingDimsTheBackLightByItsFractionEveryNCycles)
{
    auto cam = make("    part: none\n    aging: {per_cycles: 4, dim: 0.05}\n");
    const cv::Rect centre(300, 220, 40, 40);
    EXPECT_NEAR(meanOf(grab(*cam), centre), 0.85 * 255.0, 0.5);
    age(11); // two steps taken, the third due at cycle 12
    EXPECT_NEAR(meanOf(grab(*cam), centre), 0.85 * 0.95 * 0.95 * 255.0, 1.0);
    age(1);
    EXPECT_NEAR(meanOf(grab(*cam), centre), 0.85 * 0.95 * 0.95 * 0.95 * 255.0, 1.0); // 185.84
    const auto optics = sim_.camera->optics();
    EXPECT_EQ(optics.cycles, 12u);
    EXPECT_EQ(optics.agingSteps, 3u);
    EXPECT_NEAR(optics.backgroundLevel, 0.85 * 0.857375, 1e-12);

    // The part stays as dark as it was: its level is the sensor's, not the panel's.
    ASSERT_TRUE(sim_.camera->setPart("box"));
    EXPECT_NEAR(meanOf(grab(*cam), centre), 0.08 * 255.0, 1.0);

    // Reset: the optics as configured, the count at 0.
    sim_.camera->resetAging();
    ASSERT_TRUE(sim_.camera->setPart(hg::drivers::kEmptyFixture));
    EXPECT_NEAR(meanOf(grab(*cam), centre), 0.85 * 255.0, 0.5);
    EXPECT_EQ(sim_.camera->optics().cycles, 0u);
    EXPECT_EQ(sim_.camera->optics().agingSteps, 0u);
}

// V = 1 - v ρ², ρ the distance from the sensor's centre (319.5, 239.5) over a
// corner pixel's distance from it: 1 - v at the four corner pixels.
TEST_F(SimOpticsTest, VignettingFallsOffQuadraticallyToItsValueAtTheCorners)
{
    auto cam = make("    part: none\n    vignetting: 0.3\n    pixel_format: Mono16\n");
    const cv::Mat image = grab(*cam);
    const double full = 0.85 * 65535.0;
    for (const cv::Point corner : {cv::Point(0, 0), cv::Point(639, 0), cv::Point(0, 479), cv::Point(639, 479)})
        EXPECT_NEAR(image.at<double>(corner), full * 0.7, 1.0) << corner;
    // (160, 120): ρ² = (159.5² + 119.5²) / (319.5² + 239.5²) = 39720.5 / 159440.5.
    EXPECT_NEAR(image.at<double>(120, 160), full * (1.0 - 0.3 * 39720.5 / 159440.5), 1.0);
    // At the centre the full level (ρ² = 0.5 / 159440.5).
    EXPECT_NEAR(image.at<double>(240, 320), full, 1.0);

    // A region grab is the same part of the sensor: its corner pixel is the sensor's corner.
    ASSERT_TRUE(cam->setRegion({600, 440, 40, 40}).ok());
    const cv::Mat corner = grab(*cam);
    ASSERT_EQ(corner.size(), cv::Size(40, 40));
    EXPECT_NEAR(corner.at<double>(39, 39), full * 0.7, 1.0);
}

TEST_F(SimOpticsTest, EachDustSpeckDarkensTheBackLightAtItsCentreByItsDepth)
{
    auto cam = make("    part: none\n    dust:\n      - {x: 100, y: 80, radius_px: 4, depth: 0.3}\n"
                    "      - {x: 500, y: 300, radius_px: 2, depth: 0.6}\n");
    const cv::Mat image = grab(*cam);
    const double lit = 0.85 * 255.0;
    EXPECT_NEAR(image.at<double>(80, 100), 0.7 * lit, 1.0);
    EXPECT_NEAR(image.at<double>(300, 500), 0.4 * lit, 1.0);
    // Past radius + 0.5 the back light is untouched.
    EXPECT_NEAR(image.at<double>(80, 105), lit, 0.5);
    EXPECT_NEAR(image.at<double>(303, 500), lit, 0.5);
    EXPECT_EQ(sim_.camera->optics().dust.size(), 2u);
}

/// The 10-90 % width of the box's right edge, turned `turnDeg` about the
/// optical axis, by the slanted-edge method: every pixel of rows 200-280 near
/// the edge at its signed distance from the edge's analytic line (outward
/// normal (cos θ, sin θ), a turn of the fixture about +z turning the image so),
/// averaged in 0.1 px bins; the edge spread function sampled finely enough
/// that its crossings are read within a few hundredths of a pixel.
double edgeWidth(const cv::Mat& image, double turnDeg)
{
    const double theta = turnDeg * std::numbers::pi / 180.0;
    constexpr double kBin = 0.1;
    constexpr int kBins = 120; // ±6 px
    std::vector<double> sum(kBins, 0.0), count(kBins, 0.0);
    for (int y = 200; y <= 280; ++y)
        for (int x = 340; x < 460; ++x) {
            const double d = (x - kCentreU) * std::cos(theta) + (y - kCentreV) * std::sin(theta) - kHalfWidthPx;
            const int bin = static_cast<int>(std::floor(d / kBin)) + kBins / 2;
            if (bin < 0 || bin >= kBins) continue;
            sum[bin] += image.at<double>(y, x);
            count[bin] += 1.0;
        }
    std::vector<double> esf(kBins);
    for (int i = 0; i < kBins; ++i) {
        EXPECT_GT(count[i], 0.0) << "bin " << i;
        esf[i] = sum[i] / count[i];
    }
    const double lo = image.at<double>(240, 320), hi = image.at<double>(240, 470);
    return kBin * (risingCrossing(esf, lo + 0.9 * (hi - lo), 0, kBins - 1) -
                   risingCrossing(esf, lo + 0.1 * (hi - lo), 0, kBins - 1));
}

// The edge profile of a step blurred by a Gaussian σ and sampled by 1 px wide
// pixels (a box of variance 1/12): 10-90 % width 2 · 1.2816 · √(σ² + 1/12).
TEST_F(SimOpticsTest, TheEdgeWidthFollowsTheBlurAndGrowsWithDefocus)
{
    pose_ = hg::geometry::FixturePose{5.0, 0.0, 0.0};
    for (const double sigma : {0.6, 1.2, 2.0}) {
        auto cam = make("    pixel_format: Mono16\n    blur_sigma_px: " + std::to_string(sigma) + "\n");
        const double expected = 2.563 * std::sqrt(sigma * sigma + 1.0 / 12.0);
        EXPECT_NEAR(edgeWidth(grab(*cam), 5.0), expected, 0.1 * expected) << "σ " << sigma;
    }
    // Aged: 0.6 px configured, 0.4 px more every 3 cycles; after 6 cycles σ = 1.4 px.
    auto cam = make("    pixel_format: Mono16\n    blur_sigma_px: 0.6\n    aging: {per_cycles: 3, defocus_px: 0.4}\n");
    age(6);
    EXPECT_NEAR(sim_.camera->optics().blurSigmaPx, 1.4, 1e-12);
    const double expected = 2.563 * std::sqrt(1.4 * 1.4 + 1.0 / 12.0);
    EXPECT_NEAR(edgeWidth(grab(*cam), 5.0), expected, 0.1 * expected);
}

// The halo erodes the silhouette: every straight edge's 50 % crossing moves h
// px into the object, on the box's right, left and bottom edges alike.
TEST_F(SimOpticsTest, TheHaloShrinksAStraightEdgesCrossingByItsWidth)
{
    for (const double halo : {0.0, 0.5, 1.5}) {
        auto cam =
            make("    pixel_format: Mono16\n    blur_sigma_px: 1.0\n    halo_px: " + std::to_string(halo) + "\n");
        const cv::Mat image = grab(*cam);
        EXPECT_NEAR(rightEdge(image, 240), kCentreU + kHalfWidthPx - halo, 0.05) << "halo " << halo;
        auto left = row(image, 240);
        std::reverse(left.begin(), left.end()); // dark to bright towards the left
        const double leftLevel = 0.5 * (left[639 - 320] + left[639 - 190]);
        EXPECT_NEAR(639 - risingCrossing(left, leftLevel, 639 - 320, 639 - 190), kCentreU - kHalfWidthPx + halo, 0.05)
            << "halo " << halo;
        const auto down = column(image, 320);
        EXPECT_NEAR(risingCrossing(down, 0.5 * (down[240] + down[380]), 240, 380), kCentreV + kHalfWidthPx - halo, 0.05)
            << "halo " << halo;
    }
}

// Turned 30° about the optical axis the square's right edge is slanted: its
// crossing on a row moves h / cos 30° for a shift h along its normal. Rows 239
// and 240 straddle the centre's height, so their mean crossing is the one at
// v = 239.5, where the edge lies at u = 319.5 + (a - h) / cos 30°.
TEST_F(SimOpticsTest, TheHaloShiftsASlantedEdgeAlongItsNormal)
{
    pose_ = hg::geometry::FixturePose{30.0, 0.0, 0.0};
    const double cos30 = std::cos(std::numbers::pi / 6.0);
    for (const double halo : {0.0, 1.0}) {
        auto cam =
            make("    pixel_format: Mono16\n    blur_sigma_px: 1.0\n    halo_px: " + std::to_string(halo) + "\n");
        const cv::Mat image = grab(*cam);
        const double crossing = 0.5 * (rightEdge(image, 239) + rightEdge(image, 240));
        EXPECT_NEAR((crossing - kCentreU) * cos30, kHalfWidthPx - halo, 0.05) << "halo " << halo;
    }
    // Aged: 0.25 px more every 2 cycles, four steps.
    auto cam = make("    pixel_format: Mono16\n    blur_sigma_px: 1.0\n    aging: {per_cycles: 2, halo_px: 0.25}\n");
    age(8);
    EXPECT_NEAR(sim_.camera->optics().haloPx, 1.0, 1e-12);
    const cv::Mat image = grab(*cam);
    EXPECT_NEAR((0.5 * (rightEdge(image, 239) + rightEdge(image, 240)) - kCentreU) * cos30, kHalfWidthPx - 1.0, 0.05);
}

// The empty fixture: the back light alone, dark only where dust lies on it,
// the configured specks and those aging added at seeded places.
TEST_F(SimOpticsTest, TheEmptyFixtureShowsNoDarkPixelButDust)
{
    auto cam = make("    part: box\n    dust:\n      - {x: 100, y: 80, radius_px: 3, depth: 0.4}\n"
                    "    aging: {per_cycles: 2, dust_specks: 3, seed: 11}\n");
    age(6);
    ASSERT_TRUE(sim_.camera->setPart(hg::drivers::kEmptyFixture));
    EXPECT_EQ(sim_.camera->part(), "none");
    const auto optics = sim_.camera->optics();
    ASSERT_EQ(optics.dust.size(), 1u + 3u * 3u);
    EXPECT_EQ(optics.dust[0], cv::Vec4d(100, 80, 3, 0.4));
    const cv::Mat image = grab(*cam);
    const double lit = 0.85 * 255.0;
    int dark = 0, unexplained = 0;
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            if (image.at<double>(y, x) > lit - 1.0) continue;
            ++dark;
            bool underSpeck = false;
            for (const auto& d : optics.dust) underSpeck = underSpeck || std::hypot(x - d[0], y - d[1]) < d[2] + 0.5;
            if (!underSpeck) ++unexplained;
        }
    EXPECT_GT(dark, 50);
    EXPECT_EQ(unexplained, 0);
    // Every speck's centre pixel darkened by its depth at least (overlapping specks darken more).
    for (const auto& d : optics.dust) {
        const cv::Point at(static_cast<int>(std::lround(d[0])), static_cast<int>(std::lround(d[1])));
        if (std::hypot(at.x - d[0], at.y - d[1]) + 0.5 > d[2]) continue; // a speck too small to cover its pixel
        EXPECT_LE(image.at<double>(at), (1.0 - d[3]) * lit + 1.0) << d;
    }
    EXPECT_EQ(cv::countNonZero(image < 0.5 * lit), 0) << "nothing in the fixture";

    // The aging's specks come from its seed: the same places on another camera, others with another seed.
    Twin other;
    const auto otherCamera = other.build("    dust:\n      - {x: 100, y: 80, radius_px: 3, depth: 0.4}\n"
                                         "    aging: {per_cycles: 2, dust_specks: 3, seed: 11}\n");
    other.age(6);
    EXPECT_EQ(other.sim_.camera->optics().dust, optics.dust);
    Twin reseeded;
    const auto reseededCamera = reseeded.build("    aging: {per_cycles: 2, dust_specks: 3, seed: 12}\n");
    reseeded.age(2);
    EXPECT_NE(reseeded.sim_.camera->optics().dust[0], optics.dust[1]);
}

// A region grab is the same window of the whole frame, with every optical effect on.
TEST_F(SimOpticsTest, RegionGrabsEqualTheSameWindowWithTheBackLightsFallOffDustAndHalo)
{
    pose_ = hg::geometry::FixturePose{30.0, 0.0, 0.0};
    auto cam = make("    blur_sigma_px: 1.5\n    vignetting: 0.2\n    halo_px: 1.2\n    dust:\n"
                    "      - {x: 310, y: 210, radius_px: 4, depth: 0.5}\n"
                    "      - {x: 449, y: 250, radius_px: 3, depth: 0.3}\n");
    const cv::Mat whole = grab(*cam);
    ASSERT_TRUE(cam->setRegion({300, 200, 150, 100}).ok());
    const cv::Mat window = grab(*cam);
    ASSERT_EQ(window.size(), cv::Size(150, 100));
    EXPECT_EQ(cv::norm(window, whole(cv::Rect(300, 200, 150, 100)), cv::NORM_INF), 0.0);
}

TEST_F(SimOpticsTest, BadOpticsKeysAreRefusedNamingTheKeyAndItsLine)
{
    struct Case {
        std::string keys;  // camera.driver lines
        std::string field; // the key path the error names
        std::string line;  // the text of the line it names
        std::string problem;
    };
    const std::vector<Case> cases{
        {"    vignetting: 1.2\n", "camera.driver.vignetting", "vignetting", "outside [0, 0.95]"},
        {"    halo_px: -1\n", "camera.driver.halo_px", "halo_px", "outside [0, 10]"},
        {"    dust:\n      - {x: 700, y: 10, radius_px: 2, depth: 0.3}\n", "camera.driver.dust[0].x", "x: 700",
         "outside [-0.5, 639.5]"},
        {"    dust:\n      - {x: 10, y: 10, radius_px: 2, depth: 0.3}\n      - {x: 10, y: 10, radius_px: 2, depth: "
         "1.5}\n",
         "camera.driver.dust[1].depth", "depth: 1.5", "outside [0, 1]"},
        {"    dust:\n      - {x: 10, y: 10, radius: 2, depth: 0.5}\n", "camera.driver.dust[0].radius", "radius: 2",
         "unknown key 'radius'"},
        {"    dust: {x: 10, y: 10}\n", "camera.driver.dust", "dust:", "expected a sequence"},
        {"    aging: {dim: 0.1}\n", "camera.driver.aging", "aging:", "missing required key 'per_cycles'"},
        {"    aging: {per_cycles: 0}\n", "camera.driver.aging.per_cycles", "aging:", "outside [1, 1000000000]"},
        {"    aging:\n      per_cycles: 5\n      dim: 0.9\n", "camera.driver.aging.dim", "dim: 0.9",
         "outside [0, 0.5]"},
        {"    aging:\n      per_cycles: 5\n      speck_depth: [0.5, 0.2]\n", "camera.driver.aging.speck_depth",
         "speck_depth", "min <= max"},
        {"    aging:\n      per_cycles: 5\n      colour: 1\n", "camera.driver.aging.colour", "colour",
         "unknown key 'colour'"},
    };
    for (const auto& c : cases) {
        try {
            (void)build(c.keys);
            ADD_FAILURE() << "accepted " << c.keys;
        } catch (const hg::InputError& e) {
            EXPECT_EQ(e.field(), c.field) << c.keys;
            EXPECT_EQ(e.line(), hgtest::lineOf(text_, c.line)) << c.keys << e.what();
            EXPECT_NE(e.problem().find(c.problem), std::string::npos) << e.what();
        }
    }
}

} // namespace
