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

TEST(CameraFrame, PixelFormatNames)
{
    EXPECT_EQ(hg::drivers::pixelFormatFromString("Mono16"), PixelFormat::Mono16);
    EXPECT_FALSE(hg::drivers::pixelFormatFromString("mono8").has_value());
    EXPECT_EQ(hg::drivers::cvTypeOf(PixelFormat::Mono12), CV_16UC1);
    EXPECT_EQ(toString(FrameStatus::Incomplete), "incomplete");
}

} // namespace
