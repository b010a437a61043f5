// camera.driver parsing, the lifecycle bookkeeping and frames, without a device.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/camera.h"

namespace {

using namespace std::chrono_literals;
using hg::drivers::FrameStatus;
using hg::drivers::LifecycleState;
using hg::drivers::PixelFormat;
using hg::drivers::TriggerMode;

hg::ConfigNode station(const std::string& driverBody)
{
    return hg::ConfigNode::parse("camera:\n  image_size: [640, 480]\n  driver:\n" + driverBody, "station.yaml");
}

/// The InputError thrown by makeCamera, or a failure.
hg::InputError errorOf(const std::string& driverBody)
{
    try {
        (void)hg::drivers::makeCamera(station(driverBody));
    } catch (const hg::InputError& e) {
        return e;
    }
    ADD_FAILURE() << "no InputError for:\n" << driverBody;
    return hg::InputError("", "", "");
}

TEST(CameraConfig, UnknownBackendNamesTheKeyAndLine)
{
    auto e = errorOf("    backend: firewire\n    address: 10.0.0.2\n");
    EXPECT_EQ(e.field(), "camera.driver.backend");
    EXPECT_EQ(e.line(), 4);
    EXPECT_NE(e.problem().find("firewire"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("station.yaml:4: camera.driver.backend"), std::string::npos) << e.what();
}

TEST(CameraConfig, MissingDriverSectionIsNamed)
{
    try {
        (void)hg::drivers::makeCamera(hg::ConfigNode::parse("camera:\n  image_size: [640, 480]\n", "s.yaml"));
        FAIL() << "accepted a station without camera.driver";
    } catch (const hg::InputError& e) {
        // The missing key is named in the problem of its parent map.
        EXPECT_EQ(e.field(), "camera");
        EXPECT_NE(e.problem().find("driver"), std::string::npos) << e.what();
    }
}

TEST(CameraConfig, AravisNeedsExactlyOneOfAddressAndSerial)
{
    EXPECT_EQ(errorOf("    backend: aravis\n").field(), "camera.driver");
    EXPECT_EQ(errorOf("    backend: aravis\n    address: 10.0.0.2\n    serial: AB12\n").field(),
              "camera.driver.serial");
    EXPECT_EQ(errorOf("    backend: aravis\n    address: camera-1.local\n").field(), "camera.driver.address");
    EXPECT_EQ(errorOf("    backend: aravis\n    address: 10.0.0.300\n").field(), "camera.driver.address");
}

TEST(CameraConfig, RejectsBadValuesNamingEachKey)
{
    const std::string a = "    backend: aravis\n    address: 10.0.0.2\n";
    EXPECT_EQ(errorOf(a + "    pixel_format: RGB8\n").field(), "camera.driver.pixel_format");
    EXPECT_EQ(errorOf(a + "    trigger: hardware\n").field(), "camera.driver.trigger");
    EXPECT_EQ(errorOf(a + "    roi: [0, 0, 100]\n").field(), "camera.driver.roi");
    EXPECT_EQ(errorOf(a + "    roi: [0, 0, 100, 0]\n").field(), "camera.driver.roi");
    EXPECT_EQ(errorOf(a + "    roi: [0.5, 0, 100, 100]\n").field(), "camera.driver.roi");
    EXPECT_EQ(errorOf(a + "    exposure_us: -3\n").field(), "camera.driver.exposure_us");
    EXPECT_EQ(errorOf(a + "    buffer_count: 1\n").field(), "camera.driver.buffer_count");
    EXPECT_EQ(errorOf(a + "    reconnect_backoff_ms: [500, 100]\n").field(), "camera.driver.reconnect_backoff_ms");
    EXPECT_EQ(errorOf(a + "    features: [ExposureAuto]\n").field(), "camera.driver.features");
    // A typo is caught, not ignored.
    EXPECT_EQ(errorOf(a + "    exposure_usec: 100\n").field(), "camera.driver.exposure_usec");
}

TEST(CameraConfig, V4l2NeedsADeviceAndRefusesUnitlessGain)
{
    auto noDevice = errorOf("    backend: v4l2\n");
    EXPECT_EQ(noDevice.field(), "camera.driver");
    EXPECT_NE(noDevice.problem().find("device"), std::string::npos) << noDevice.what();
    EXPECT_EQ(errorOf("    backend: v4l2\n    device: /dev/video0\n    gain_db: 3\n").field(), "camera.driver.gain_db");
}

TEST(CameraConfig, SharedSettingsAreParsed)
{
    auto s = hg::drivers::parseCameraSettings(
        station("    backend: aravis\n    pixel_format: Mono12\n    exposure_us: 1500\n    gain_db: 2.5\n"
                "    roi: [8, 4, 320, 240]\n    trigger: free_run\n")["camera"]["driver"]);
    EXPECT_EQ(s.pixelFormat, PixelFormat::Mono12);
    EXPECT_DOUBLE_EQ(*s.exposureUs, 1500.0);
    EXPECT_DOUBLE_EQ(*s.gainDb, 2.5);
    EXPECT_EQ(s.roi, (hg::drivers::Roi{8, 4, 320, 240}));
    EXPECT_EQ(s.trigger, TriggerMode::FreeRun);

    auto d = hg::drivers::parseCameraSettings(station("    backend: aravis\n")["camera"]["driver"]);
    EXPECT_EQ(d.pixelFormat, PixelFormat::Mono8);
    EXPECT_FALSE(d.exposureUs.has_value());
    EXPECT_TRUE(d.roi.isFullSensor());
    EXPECT_EQ(d.trigger, TriggerMode::Software);
}

TEST(CameraConfig, ConstructionOpensNothingAndStateIsChecked)
{
    // A V4L2 device that does not exist: construction succeeds (parse only),
    // grab before configure fails with a status, configure names the key.
    auto cam = hg::drivers::makeCamera(station("    backend: v4l2\n    device: /dev/hullgauge-no-such-video\n"));
    EXPECT_EQ(cam->state(), LifecycleState::Unconfigured);
    auto f = cam->grab(10ms);
    EXPECT_EQ(f.status, FrameStatus::Error);
    EXPECT_NE(f.message.find("unconfigured"), std::string::npos) << f.message;
    EXPECT_FALSE(cam->activate());
    EXPECT_FALSE(cam->getFeature("Gain"));
    auto s = cam->configure();
    EXPECT_FALSE(s);
    EXPECT_NE(s.message().find("camera.driver.device"), std::string::npos) << s.message();
    // A failed configure changes nothing (docs/drivers.md): configure again to retry.
    EXPECT_EQ(cam->state(), LifecycleState::Unconfigured);
}

TEST(CameraFrame, ReleaseGivesTheBufferBackExactlyOnce)
{
    int recycled = 0;
    cv::Mat buffer(4, 4, CV_8UC1, cv::Scalar(7));
    {
        auto f = hg::drivers::Frame::over(buffer, 42, 1000ns, FrameStatus::Ok, [&] { ++recycled; });
        EXPECT_EQ(f.image.data, buffer.data); // a view, not a copy
        EXPECT_EQ(f.frameId, 42u);
        hg::drivers::Frame moved = std::move(f);
        EXPECT_EQ(recycled, 0);
        moved.release();
        EXPECT_EQ(recycled, 1);
        EXPECT_TRUE(moved.image.empty());
        moved.release();
    }
    EXPECT_EQ(recycled, 1);
    {
        auto g = hg::drivers::Frame::over(buffer, 1, 0ns, FrameStatus::Ok, [&] { ++recycled; });
        hg::drivers::Frame h;
        h = std::move(g);
    }
    EXPECT_EQ(recycled, 2);
}

// alignRegion against hand-rounded boxes. Rules of a typical GigE camera:
// offsets in steps of 4 (x) and 2 (y), widths 8, 16, 24, ..., heights 2, 4, ...
constexpr hg::drivers::RegionRules kCoarse{{0, 4, 8, 8}, {0, 2, 2, 2}};
using hg::drivers::alignRegion;
using hg::drivers::Roi;

TEST(CameraConfigRegions, RequestsAreRoundedOutwardToTheIncrements)
{
    const Roi sensor{0, 0, 160, 120};
    // x: 13 -> 12; right edge 63 -> width 51 -> 56. y: 7 -> 6; bottom 38 -> height 32.
    EXPECT_EQ(alignRegion(Roi{13, 7, 50, 31}, sensor, kCoarse).value(), (Roi{12, 6, 56, 32}));
    EXPECT_EQ(alignRegion(Roi{0, 0, 8, 2}, sensor, kCoarse).value(), (Roi{0, 0, 8, 2}));
    EXPECT_EQ(alignRegion(Roi{}, sensor, kCoarse).value(), sensor);
    // Width 1 -> the minimum, 8.
    EXPECT_EQ(alignRegion(Roi{41, 3, 1, 1}, sensor, kCoarse).value(), (Roi{40, 2, 8, 2}));
}

TEST(CameraConfigRegions, RequestsOverTheEdgeAreClampedAndShiftedInside)
{
    const Roi sensor{0, 0, 160, 120};
    // x: [150, 160) -> offset 148, width 12 -> 16 ends at 164 > 160: one offset step back to 144.
    EXPECT_EQ(alignRegion(Roi{150, 100, 30, 40}, sensor, kCoarse).value(), (Roi{144, 100, 16, 20}));
    // Negative origin: clamped to [0, 15) on both axes; 15 -> 16 wide and high.
    EXPECT_EQ(alignRegion(Roi{-5, -5, 20, 20}, sensor, kCoarse).value(), (Roi{0, 0, 16, 16}));
    // Within a configured ROI [16, 10, 96, 64]: clamped to [16, 20) x [10, 12).
    EXPECT_EQ(alignRegion(Roi{0, 0, 20, 12}, Roi{16, 10, 96, 64}, kCoarse).value(), (Roi{16, 10, 8, 2}));
    // A 100 px sensor with steps of 16: [85, 100) needs offset 80 width 32 (past 100);
    // stepping back to 64 no longer reaches 100, so x takes the whole sensor.
    const hg::drivers::RegionRules steps16{{0, 16, 16, 16}, {0, 1, 1, 1}};
    EXPECT_EQ(alignRegion(Roi{85, 0, 15, 10}, Roi{0, 0, 100, 50}, steps16).value(), (Roi{0, 0, 100, 10}));
}

TEST(CameraConfigRegions, EmptyOrOutsideRequestsAreRefusedNamingBothBoxes)
{
    const Roi sensor{0, 0, 160, 120};
    auto outside = alignRegion(Roi{200, 10, 10, 10}, sensor, kCoarse);
    EXPECT_EQ(outside.code(), hg::StatusCode::NotAllowed);
    EXPECT_EQ(outside.message(), "region [200, 10, 10, 10] lies outside the sensor region [0, 0, 160, 120] the "
                                 "camera delivers");
    // Touching the edge is not overlapping it.
    EXPECT_FALSE(alignRegion(Roi{160, 0, 10, 10}, sensor, kCoarse).ok());
    auto empty = alignRegion(Roi{10, 10, 0, 4}, sensor, kCoarse);
    EXPECT_EQ(empty.code(), hg::StatusCode::NotAllowed);
    EXPECT_NE(empty.message().find("width and height must both be positive"), std::string::npos);
    EXPECT_FALSE(alignRegion(Roi{10, 10, -4, 4}, sensor, kCoarse).ok());
}

TEST(CameraConfigRegions, EveryAnswerContainsTheRequestOnTheIncrementsInsideTheBounds)
{
    // Seeded random requests against the definition, not against the algorithm.
    cv::RNG rng(7);
    const Roi bounds{8, 6, 144, 100};
    for (int k = 0; k < 2000; ++k) {
        const Roi r{rng.uniform(-20, 170), rng.uniform(-20, 130), rng.uniform(1, 120), rng.uniform(1, 90)};
        auto a = alignRegion(r, bounds, kCoarse);
        const int x0 = std::max(r.x, bounds.x), x1 = std::min(r.x + r.width, bounds.x + bounds.width);
        const int y0 = std::max(r.y, bounds.y), y1 = std::min(r.y + r.height, bounds.y + bounds.height);
        if (x0 >= x1 || y0 >= y1) {
            EXPECT_FALSE(a.ok()) << r;
            continue;
        }
        ASSERT_TRUE(a.ok()) << r << ": " << a.message();
        const Roi g = a.value();
        SCOPED_TRACE(fmt::format("{} -> {}", r, g));
        EXPECT_TRUE(g.x <= x0 && g.y <= y0 && g.x + g.width >= x1 && g.y + g.height >= y1);
        EXPECT_TRUE(g.x >= bounds.x && g.y >= bounds.y && g.x + g.width <= bounds.x + bounds.width &&
                    g.y + g.height <= bounds.y + bounds.height);
        EXPECT_EQ(g.x % 4, 0);
        EXPECT_EQ(g.y % 2, 0);
        EXPECT_EQ(g.width % 8, 0);
        EXPECT_EQ(g.height % 2, 0);
    }
}

TEST(CameraFrame, PixelFormatNames)
{
    EXPECT_EQ(hg::parseEnum<PixelFormat>("Mono16"), PixelFormat::Mono16);
    EXPECT_FALSE(hg::parseEnum<PixelFormat>("mono8").has_value());
    EXPECT_EQ(hg::drivers::cvTypeOf(PixelFormat::Mono12), CV_16UC1);
    EXPECT_EQ(hg::enumName(FrameStatus::Incomplete), "incomplete");
}

} // namespace
