// The simulated camera against analytic silhouettes: a cube seen face-on by a
// pinhole camera projects to a square whose size follows from similar triangles.
#include "hgtest/log_capture.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/model/primitives.h"

#include <cmath>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace {

using namespace std::chrono_literals;
using hg::drivers::FrameStatus;

// f = 1000 px, principal point at the image centre, part origin 300 mm in front
// of the camera; the turntable axis is the optical axis (fixture z).
constexpr double kF = 1000.0;
constexpr double kDistance = 300.0;
const std::string kStation = hgtest::stationYaml({.focalPx = kF,
                                                  .principalPointPx = cv::Point2d(319.5, 239.5),
                                                  .cameraKeys = "  driver:\n    backend: sim\n",
                                                  .mount = hgtest::CameraMount::Axis,
                                                  .distanceMm = kDistance});

struct Silhouette {
    double area = 0; // dark pixels
    cv::Rect box;
};

Silhouette measure(const cv::Mat& image)
{
    cv::Mat grey;
    image.convertTo(grey, CV_32F, image.depth() == CV_8U ? 1.0 / 255.0 : 1.0 / 65535.0);
    cv::Mat dark = grey < 0.5;
    Silhouette s;
    s.area = cv::countNonZero(dark);
    s.box = cv::boundingRect(dark);
    return s;
}

/// Half the projected width of the near face of a cube of half-size a centred on the axis.
double halfWidthPx(double a)
{
    return kF * a / (kDistance - a);
}

class SimCameraTest : public ::testing::Test {
  protected:
    /// The sim camera from the camera backend table; its controls land in `sim_`.
    std::unique_ptr<hg::drivers::Camera> make(const std::string& extraDriver = "")
    {
        std::string text = kStation;
        text.insert(text.find("fixture:"), extraDriver);
        auto root = hg::ConfigNode::parse(text, "station.yaml");
        hg::drivers::CameraEnvironment in;
        in.poseSource = [this] { return pose_; };
        in.parts.emplace_back("nominal", hg::model::makeBox({-20, -20, -20}, {20, 20, 20}));
        in.parts.emplace_back("short", hg::model::makeBox({-10, -10, -10}, {10, 10, 10}));
        in.simulation = &sim_;
        auto camera = hg::drivers::makeCamera(root, std::move(in));
        if (!sim_.camera) throw std::logic_error("the sim backend published no controls");
        return camera;
    }

    std::optional<hg::geometry::FixturePose> pose_ = hg::geometry::FixturePose{};
    hg::drivers::SimulationControls sim_;
};

TEST_F(SimCameraTest, FaceOnCubeProjectsToTheSquareOfSimilarTriangles)
{
    auto cam = make();
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok()) << f.message;
    ASSERT_EQ(f.image.size(), cv::Size(640, 480));
    const double side = 2 * halfWidthPx(20.0); // 142.86 px
    auto s = measure(f.image);
    // Pixels count as dark when their centre is inside: the area is within half
    // a pixel of the outline all round.
    EXPECT_NEAR(s.area, side * side, 2.0 * side + 1.0);
    EXPECT_NEAR(s.box.width, side, 2.0);
    EXPECT_NEAR(s.box.x + s.box.width / 2.0, 320.0, 1.0);
}

TEST_F(SimCameraTest, TurntableRotationFollowsThePoseSource)
{
    auto cam = make();
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    pose_ = hg::geometry::FixturePose{45.0, 0.0, 0.0};
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok());
    // Rotated 45° about the optical axis: the square's diagonal is now horizontal.
    const double side = 2 * halfWidthPx(20.0);
    EXPECT_NEAR(measure(f.image).box.width, side * std::sqrt(2.0), 3.0);

    pose_.reset(); // fixture moving: no frame, and it says why
    auto g = cam->grab(100ms);
    EXPECT_EQ(g.status, FrameStatus::Timeout);
    EXPECT_NE(g.message.find("pose"), std::string::npos);
}

TEST_F(SimCameraTest, PartIsSwitchableWhileStreaming)
{
    auto cam = make();
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    const double big = 2 * halfWidthPx(20.0), small = 2 * halfWidthPx(10.0);
    EXPECT_NEAR(measure(cam->grab(100ms).image).box.width, big, 2.0);
    ASSERT_TRUE(sim_.camera->setPart("short"));
    EXPECT_EQ(sim_.camera->part(), "short");
    EXPECT_NEAR(measure(cam->grab(100ms).image).box.width, small, 2.0);
    ASSERT_TRUE(cam->setFeature("Part", "nominal"));
    EXPECT_NEAR(measure(cam->grab(100ms).image).box.width, big, 2.0);
    auto bad = sim_.camera->setPart("cracked");
    EXPECT_FALSE(bad);
    EXPECT_NE(bad.message().find("short"), std::string::npos) << bad.message();
}

TEST_F(SimCameraTest, RoiCropsAndSixteenBitFormatsScale)
{
    auto cam = make("    pixel_format: Mono12\n    roi: [320, 240, 200, 150]\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok());
    ASSERT_EQ(f.image.size(), cv::Size(200, 150));
    ASSERT_EQ(f.image.type(), CV_16UC1);
    double maxV = 0;
    cv::minMaxLoc(f.image, nullptr, &maxV);
    EXPECT_LE(maxV, 4095.0);
    EXPECT_GT(maxV, 3000.0); // lit background at 85 % of 12-bit full scale
    // The square's lower-right quadrant: from the ROI origin (the image centre) to 71.4 px on.
    cv::Mat dark = f.image < 2048;
    const auto box = cv::boundingRect(dark);
    EXPECT_EQ(box.x, 0);
    EXPECT_EQ(box.y, 0);
    EXPECT_NEAR(box.width, halfWidthPx(20.0) - 0.5, 1.5);
}

TEST_F(SimCameraTest, HeldFramesStarveThePoolAndReleaseRefillsIt)
{
    auto cam = make("    buffer_count: 2\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto a = cam->grab(10ms);
    auto b = cam->grab(10ms);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_NE(a.image.data, b.image.data);
    auto c = cam->grab(10ms);
    EXPECT_EQ(c.status, FrameStatus::Timeout);
    a.release();
    EXPECT_TRUE(cam->grab(10ms).ok());
}

TEST_F(SimCameraTest, UnknownInitialPartIsAConfigError)
{
    try {
        (void)make("    part: bent\n");
        FAIL() << "accepted an unknown part";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "camera.driver.part");
    }
}

// A 9x6 chessboard of 12 mm squares facing the camera, its first inner corner
// at (-48, -30) mm in the part frame, 300 mm in front of the camera (the
// fixture at rest): corner (c, r) is seen at u = 319.5 + 1000 (-48 + 12 c) / 300,
// v = 239.5 + 1000 (-30 + 12 r) / 300 (similar triangles).
const char* kTarget = "    target:\n      pattern: chessboard:9x6:12\n"
                      "      part_from_target: {R: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], t: [-48, -30, 0]}\n";

TEST_F(SimCameraTest, BacklitChessboardTargetIsDetectedAtItsProjectedCorners)
{
    auto cam = make(std::string(kTarget) + "    part: target\n    blur_sigma_px: 0.6\n    noise_sigma: 1\n");
    EXPECT_EQ(sim_.camera->part(), "target");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok()) << f.message;
    const auto spec = hg::calib::TargetSpec::parse("chessboard:9x6:12");
    auto view = hg::calib::detectTarget(f.image, spec, "frame");
    ASSERT_TRUE(view) << "the rendered chessboard was not found";
    ASSERT_EQ(view->imagePoints.size(), 54u);
    double worst = 0.0;
    for (int id = 0; id < 54; ++id) {
        const int c = id % 9, r = id / 9;
        const cv::Point2d expected(319.5 + kF * (-48.0 + 12.0 * c) / kDistance,
                                   239.5 + kF * (-30.0 + 12.0 * r) / kDistance);
        const cv::Point2d found = view->imagePoints[id];
        worst = std::max(worst, cv::norm(found - expected));
    }
    // Corner 0 comes first (the board's dark corner square fixes the order),
    // and every corner sits where the pinhole puts it.
    EXPECT_LT(worst, 0.1) << "largest corner error in px";
    // The margin around the squares is the back light.
    EXPECT_GT(f.image.at<std::uint8_t>(239, 100), 200);
}

TEST_F(SimCameraTest, TruthStationGeometryIsWhatTheTwinRenders)
{
    hgtest::TempDir dir;
    // The rig as it is: the fixture origin 10 mm to the right of where the
    // station file (nominal) says, so the cube's near face moves 1000 * 10 / 280 px right.
    hgtest::writeFile(dir / "truth.yaml", hgtest::replaced(kStation, "t: [0, 0, 300]", "t: [10, 0, 300]"));
    std::string text = kStation;
    text.insert(text.find("fixture:"), "    truth_station: truth.yaml\n");
    auto file = hgtest::writeFile(dir / "station.yaml", text);
    auto root = hg::ConfigNode::loadFile(file);
    hg::drivers::CameraEnvironment in;
    in.poseSource = [] { return hg::geometry::FixturePose{}; };
    in.parts.emplace_back("nominal", hg::model::makeBox({-20, -20, -20}, {20, 20, 20}));
    auto cam = hg::drivers::makeCamera(root, std::move(in));
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok()) << f.message;
    auto box = measure(f.image).box;
    // The near face (20 mm closer) bounds the silhouette.
    EXPECT_NEAR(box.x + box.width / 2.0, 320.0 + kF * 10.0 / (kDistance - 20.0), 1.0);
}

TEST_F(SimCameraTest, FaultSwitchesTimeOutCutPacketsAndDropAFrame)
{
    auto cam = make();
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto first = cam->grab(100ms);
    ASSERT_TRUE(first.ok()) << first.message;
    const auto id = first.frameId;
    first.release();

    // Silent camera: the grab costs its whole timeout and says so.
    sim_.camera->injectFault(hg::drivers::SimulatedCameraFault::Timeout);
    const auto t0 = std::chrono::steady_clock::now();
    auto silent = cam->grab(30ms);
    EXPECT_GE(std::chrono::steady_clock::now() - t0, 30ms);
    EXPECT_EQ(silent.status, FrameStatus::Timeout);
    EXPECT_TRUE(silent.image.empty());

    // Missing packets: a frame arrives but is flagged, bands of rows read 0
    // (row 0 lies in the background, 85 % of full scale without the fault).
    ASSERT_TRUE(cam->setFeature("Fault", "incomplete"));
    EXPECT_EQ(cam->getFeature("Fault").value(), "incomplete");
    auto cut = cam->grab(100ms);
    EXPECT_EQ(cut.status, FrameStatus::Incomplete);
    ASSERT_FALSE(cut.image.empty());
    EXPECT_EQ(cut.image.at<std::uint8_t>(0, 0), 0);
    EXPECT_EQ(cut.frameId, id + 1);
    cut.release();

    // One dropped frame: that grab times out, the next frame's id skips it.
    sim_.camera->injectFault(hg::drivers::SimulatedCameraFault::Dropped);
    EXPECT_EQ(cam->grab(10ms).status, FrameStatus::Timeout);
    auto next = cam->grab(100ms);
    ASSERT_TRUE(next.ok()) << next.message;
    EXPECT_EQ(next.frameId, id + 3);
    EXPECT_GT(next.image.at<std::uint8_t>(0, 0), 200);
    EXPECT_FALSE(cam->setFeature("Fault", "sometimes"));
}

TEST_F(SimCameraTest, RegionGrabsEqualTheSameWindowOfAWholeFrame)
{
    using hg::drivers::Roi;
    auto cam = make("    blur_sigma_px: 1.5\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    pose_ = hg::geometry::FixturePose{30.0, 0.0, 0.0}; // slanted, blurred edges: every grey level counts
    auto whole = cam->grab(100ms);
    ASSERT_TRUE(whole.ok()) << whole.message;
    EXPECT_EQ(whole.region, (Roi{0, 0, 640, 480}));
    EXPECT_EQ(whole.payloadBytes, 640u * 480u);
    const cv::Mat full = whole.image.clone();
    whole.release();

    // The twin's increments are 1: the region is the request itself.
    auto region = cam->setRegion(Roi{300, 200, 150, 100});
    ASSERT_TRUE(region.ok()) << region.message();
    EXPECT_EQ(region.value(), (Roi{300, 200, 150, 100}));
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok()) << f.message;
    EXPECT_EQ(f.region, (Roi{300, 200, 150, 100}));
    ASSERT_EQ(f.image.size(), cv::Size(150, 100));
    EXPECT_EQ(f.payloadBytes, 150u * 100u);
    const cv::Mat window = full(cv::Rect(300, 200, 150, 100));
    EXPECT_EQ(cv::norm(f.image, window, cv::NORM_INF), 0.0);
    double lo = 0, hi = 0;
    cv::minMaxLoc(window, &lo, &hi);
    EXPECT_LT(lo, 100.0) << "the window must cut the silhouette's edge";
    EXPECT_GT(hi, 200.0);
    f.release();

    // Partly off the sensor: clamped to it. Wholly off, or empty: refused.
    EXPECT_EQ(cam->setRegion(Roi{600, 450, 100, 100}).value(), (Roi{600, 450, 40, 30}));
    auto corner = cam->grab(100ms);
    ASSERT_TRUE(corner.ok());
    EXPECT_EQ(cv::norm(corner.image, full(cv::Rect(600, 450, 40, 30)), cv::NORM_INF), 0.0);
    corner.release();
    auto outside = cam->setRegion(Roi{700, 10, 10, 10});
    EXPECT_EQ(outside.code(), hg::StatusCode::NotAllowed);
    EXPECT_NE(outside.message().find("region [700, 10, 10, 10] lies outside the sensor region [0, 0, 640, 480]"),
              std::string::npos)
        << outside.message();
    EXPECT_EQ(cam->setRegion(Roi{10, 10, 0, 5}).code(), hg::StatusCode::NotAllowed);

    // Roi{} returns to whole frames.
    EXPECT_EQ(cam->setRegion(Roi{}).value(), (Roi{0, 0, 640, 480}));
    auto again = cam->grab(100ms);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(cv::norm(again.image, full, cv::NORM_INF), 0.0);
    again.release();

    ASSERT_TRUE(cam->deactivate());
    auto inactive = cam->setRegion(Roi{0, 0, 10, 10});
    EXPECT_EQ(inactive.code(), hg::StatusCode::NotAllowed);
    EXPECT_NE(inactive.message().find("not allowed while inactive (needs active)"), std::string::npos);
}

TEST_F(SimCameraTest, ConfiguredRoiBoundsTheRegions)
{
    using hg::drivers::Roi;
    auto cam = make("    roi: [100, 80, 400, 300]\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto whole = cam->grab(100ms);
    ASSERT_TRUE(whole.ok());
    EXPECT_EQ(whole.region, (Roi{100, 80, 400, 300}));
    const cv::Mat roi = whole.image.clone();
    whole.release();
    // The pool holds the configured ROI: a region reaching out of it is cut to it.
    EXPECT_EQ(cam->setRegion(Roi{50, 50, 100, 100}).value(), (Roi{100, 80, 50, 70}));
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(f.region, (Roi{100, 80, 50, 70}));
    EXPECT_EQ(cv::norm(f.image, roi(cv::Rect(0, 0, 50, 70)), cv::NORM_INF), 0.0);
    EXPECT_EQ(cam->setRegion(Roi{}).value(), (Roi{100, 80, 400, 300}));
}

TEST_F(SimCameraTest, RefusedRegionFallsBackToWholeFramesWithOneWarning)
{
    using hg::drivers::Roi;
    hgtest::LogCapture log("camera");
    auto cam = make("    fault: refuse_region\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    EXPECT_EQ(cam->getFeature("Fault").value(), "refuse_region");
    for (int k = 0; k < 3; ++k) {
        auto region = cam->setRegion(Roi{300, 200, 150, 100});
        ASSERT_TRUE(region.ok()) << region.message();
        EXPECT_EQ(region.value(), (Roi{0, 0, 640, 480})) << "request " << k;
        auto f = cam->grab(100ms);
        ASSERT_TRUE(f.ok()) << f.message;
        EXPECT_EQ(f.region, (Roi{0, 0, 640, 480}));
        EXPECT_EQ(f.image.size(), cv::Size(640, 480));
    }
    EXPECT_EQ(log.count(spdlog::level::warn, "delivering whole frames"), 1) << log.text();
    EXPECT_NE(log.text().find("OffsetX, OffsetY, Width and Height are not writable"), std::string::npos);
    // A fresh configure of a camera that can set regions again does.
    ASSERT_TRUE(cam->deactivate());
    ASSERT_TRUE(cam->cleanup());
    sim_.camera->injectFault(hg::drivers::SimulatedCameraFault::None);
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    EXPECT_EQ(cam->setRegion(Roi{300, 200, 150, 100}).value(), (Roi{300, 200, 150, 100}));
}

TEST(SimCameraTable, OpensFromTheStationAloneAndShowsTheBareBackLight)
{
    // `hullgauge camera` builds the sim with nothing but the station file.
    auto cam = hg::drivers::makeCamera(hg::ConfigNode::parse(kStation, "station.yaml"));
    ASSERT_TRUE(cam->configure());
    EXPECT_EQ(cam->info().value().backend, "sim");
    ASSERT_TRUE(cam->activate());
    auto f = cam->grab(100ms);
    ASSERT_TRUE(f.ok()) << f.message;
    EXPECT_EQ(measure(f.image).area, 0.0);
}

TEST_F(SimCameraTest, BadTargetAndTruthKeysNameTheKey)
{
    auto field = [&](const std::string& extra) {
        try {
            (void)make(extra);
        } catch (const hg::InputError& e) {
            return e.field() + ": " + e.problem();
        }
        return std::string("accepted");
    };
    EXPECT_EQ(field("    target:\n      pattern: charuco:5x5:10:7\n      part_from_target: {R: [[1, 0, 0], [0, 1, "
                    "0], [0, 0, 1]], t: [0, 0, 0]}\n")
                  .rfind("camera.driver.target.pattern: ", 0),
              0u);
    EXPECT_EQ(field("    target:\n      pattern: chessboard:9x6:12\n      part_from_target: {R: [[2, 0, 0], [0, 1, "
                    "0], [0, 0, 1]], t: [0, 0, 0]}\n")
                  .rfind("camera.driver.target.part_from_target.R: not a rotation", 0),
              0u);
    EXPECT_EQ(field("    target:\n      pattern: chessboard:9x6:12\n")
                  .rfind("camera.driver.target: missing required key 'part_from_target'", 0),
              0u);
    EXPECT_EQ(
        field("    truth_station: /nonexistent/truth.yaml\n").rfind("camera.driver.truth_station: no such file", 0),
        0u);
    EXPECT_EQ(field("    fault: sometimes\n").rfind("camera.driver.fault: unknown fault 'sometimes'", 0), 0u);
}

} // namespace
