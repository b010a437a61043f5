// The V4L2 camera driver against the kernel's own virtual video driver (vivid),
// through the public camera interface only. Runs inside the test VM
// (run-in-vm boots Debian's kernel with vivid loaded as one webcam-type capture
// device); it refuses to touch any device that is not vivid.
//
// Expectations are independent of the driver: vivid's test pattern generator
// draws the ITU-R 75 % colour bars (R', G', B' each 0 or 0.75: white, yellow,
// cyan, green, magenta, red, blue, black, eight equal vertical bars), so each
// bar's grey level follows from the luma equation Y' = Kr R' + (1 - Kr - Kb) G'
// + Kb B' and the quantization range (V4L2 spec, "Colorspaces"):
//   - YUYV carries the Y' of its Y'CbCr encoding, BT.601 (Kr 0.299, Kb 0.114)
//     for vivid's default sRGB colourspace, in limited range: 16 + 219 Y'
//     (the classic 75 % bar levels 180 162 131 112 84 65 35 16);
//   - the luma-only formats GREY/Y12/Y16 are computed by vivid with the
//     Rec. 709 luma coefficients (Kr 0.2126, Kb 0.0722) in full range: 255 Y'
//     (scaled to 12 and 16 bits for Y12 and Y16).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <linux/videodev2.h>
#include <opencv2/core.hpp>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/camera.h"

namespace {

using namespace std::chrono_literals;
using hg::Status;
using hg::drivers::Camera;
using hg::drivers::Frame;
using hg::drivers::FrameStatus;
using hg::drivers::LifecycleState;
using Clock = std::chrono::steady_clock;

constexpr const char* kDevice = "/dev/video0";
// The smallest webcam size vivid offers and a frame rate it lists for it:
// small frames keep the emulated (TCG) guest fast.
constexpr int kWidth = 320;
constexpr int kHeight = 180;
constexpr int kFps = 30;
constexpr auto kFramePeriod = std::chrono::nanoseconds(1'000'000'000 / kFps);
// Generous: the guest is emulated on a shared host, frames can be late.
constexpr auto kGrabTimeout = 3000ms;

/// Sets the capture size and frame rate the way a station's device setup
/// (v4l2-ctl) would: the driver keeps the device's size (no ROI) and rate.
/// Fails when the device is not vivid, so this never drives a real camera.
void prepareVivid()
{
    const int fd = ::open(kDevice, O_RDWR | O_CLOEXEC);
    ASSERT_GE(fd, 0) << kDevice << ": " << std::strerror(errno);
    v4l2_capability cap{};
    ASSERT_EQ(::ioctl(fd, VIDIOC_QUERYCAP, &cap), 0) << std::strerror(errno);
    const std::string driver = reinterpret_cast<const char*>(cap.driver);
    if (driver != "vivid") {
        ::close(fd);
        FAIL() << kDevice << " is driven by '" << driver
               << "', not vivid: this program runs inside the test VM (tests/drivers/camera/vivid/run-in-vm)";
    }
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    ASSERT_EQ(::ioctl(fd, VIDIOC_G_FMT, &fmt), 0) << std::strerror(errno);
    fmt.fmt.pix.width = kWidth;
    fmt.fmt.pix.height = kHeight;
    fmt.fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    ASSERT_EQ(::ioctl(fd, VIDIOC_S_FMT, &fmt), 0) << std::strerror(errno);
    ASSERT_EQ(fmt.fmt.pix.width, static_cast<unsigned>(kWidth));
    ASSERT_EQ(fmt.fmt.pix.height, static_cast<unsigned>(kHeight));
    v4l2_streamparm parm{};
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    parm.parm.capture.timeperframe = {1, kFps};
    ASSERT_EQ(::ioctl(fd, VIDIOC_S_PARM, &parm), 0) << std::strerror(errno);
    ASSERT_EQ(parm.parm.capture.timeperframe.numerator * kFps, parm.parm.capture.timeperframe.denominator);
    ::close(fd);
}

/// vivid controls set by name under camera.driver.features, in this order.
using Features = std::vector<std::pair<std::string, std::string>>;
/// The still 75 % bars without vivid's on-screen text (menu indices of vivid's controls).
const Features kStillBars = {
    {"Test Pattern", "0"}, {"OSD Text Mode", "2"}, {"Horizontal Movement", "3"}, {"Vertical Movement", "3"}};

/// A v4l2 camera from a station snippet; `extra` holds further driver keys;
/// `features` replace or follow the still-bars defaults.
std::unique_ptr<Camera> makeCamera(const std::string& pixelFormat, const std::string& extra = {},
                                   const Features& features = {})
{
    Features all = kStillBars;
    for (const auto& [name, value] : features) {
        auto same = std::find_if(all.begin(), all.end(), [&](const auto& f) { return f.first == name; });
        if (same != all.end())
            same->second = value;
        else
            all.emplace_back(name, value);
    }
    std::string text = "camera:\n  driver:\n    backend: v4l2\n    device: " + std::string(kDevice) +
                       "\n    pixel_format: " + pixelFormat + "\n    trigger: free_run\n    buffer_count: 4\n" + extra +
                       "    features:\n";
    for (const auto& [name, value] : all) text += "      \"" + name + "\": " + value + "\n";
    return hg::drivers::makeCamera(hg::ConfigNode::parse(text, "station.yaml"));
}

/// R', G', B' of the eight 75 % bars, left to right.
constexpr std::array<std::array<double, 3>, 8> kBars75 = {{{0.75, 0.75, 0.75},
                                                           {0.75, 0.75, 0},
                                                           {0, 0.75, 0.75},
                                                           {0, 0.75, 0},
                                                           {0.75, 0, 0.75},
                                                           {0.75, 0, 0},
                                                           {0, 0, 0.75},
                                                           {0, 0, 0}}};

struct Luma {
    double kr, kb;
};
constexpr Luma kRec601{0.299, 0.114};
constexpr Luma kRec709{0.2126, 0.0722};

double lumaOf(const std::array<double, 3>& rgb, Luma k)
{
    return k.kr * rgb[0] + (1.0 - k.kr - k.kb) * rgb[1] + k.kb * rgb[2];
}

/// Min and max of each bar's interior (a few columns off each edge), all rows.
struct BarRange {
    double min, max;
};
std::vector<BarRange> barRanges(const cv::Mat& image)
{
    std::vector<BarRange> out;
    const int w = image.cols;
    for (int i = 0; i < 8; ++i) {
        const int x0 = i * w / 8 + 3;
        const int x1 = (i + 1) * w / 8 - 3;
        double lo = 0, hi = 0;
        cv::minMaxLoc(image(cv::Rect(x0, 0, x1 - x0, image.rows)), &lo, &hi);
        out.push_back({lo, hi});
    }
    return out;
}

/// Every bar lies within `tolerance` of `expected(bar)`. The tolerances below
/// allow vivid's integer arithmetic (8-bit R'G'B' 191 for 0.75, truncating
/// shifts: up to 2 levels low); neighbouring bars differ by 13 levels or more,
/// and BT.601 and Rec. 709 luma by up to 24.
constexpr double kTol8 = 2.0;
void expectBars(const cv::Mat& image, const std::function<double(int)>& expected, double tolerance)
{
    const auto bars = barRanges(image);
    for (int i = 0; i < 8; ++i) {
        EXPECT_NEAR(bars[i].min, expected(i), tolerance) << "bar " << i;
        EXPECT_NEAR(bars[i].max, expected(i), tolerance) << "bar " << i;
    }
}

/// Grabs `n` frames, checking each is complete, of the size and type, with
/// increasing sequence numbers and timestamps; hands each to `check`.
struct StreamStats {
    std::uint64_t firstId = 0, lastId = 0;
    int repeatedIds = 0;
    std::chrono::nanoseconds firstTs{0}, lastTs{0};
};
StreamStats streamFrames(Camera& cam, int n, int cvType, const std::function<void(const Frame&)>& check)
{
    StreamStats st;
    bool first = true;
    for (int k = 0; k < n; ++k) {
        Frame f = cam.grab(kGrabTimeout);
        EXPECT_EQ(f.status, FrameStatus::Ok) << "frame " << k << ": " << f.message;
        if (!f.ok()) return st;
        EXPECT_EQ(f.image.cols, kWidth);
        EXPECT_EQ(f.image.rows, kHeight);
        EXPECT_EQ(f.image.type(), cvType);
        if (!first) {
            // vivid's capture thread runs on the kernel tick; when the guest is
            // starved it can emit two frames within one frame period, and both
            // carry that period's sequence number. Never backwards; how often
            // equal depends on the host's load, so it is counted, not bounded.
            EXPECT_GE(f.frameId, st.lastId) << "frame " << k;
            if (f.frameId == st.lastId) ++st.repeatedIds;
            EXPECT_GT(f.timestamp, st.lastTs) << "frame " << k;
        } else {
            st.firstId = f.frameId;
            st.firstTs = f.timestamp;
        }
        first = false;
        st.lastId = f.frameId;
        st.lastTs = f.timestamp;
        check(f);
    }
    // vivid paces frames by the kernel tick (jiffies): single gaps jitter by a
    // tick (4 ms at HZ=250), the mean period over a long run is the set rate.
    if (st.lastId >= st.firstId + 20) {
        using Ms = std::chrono::duration<double, std::milli>;
        const double meanMs = Ms(st.lastTs - st.firstTs).count() / static_cast<double>(st.lastId - st.firstId);
        EXPECT_NEAR(meanMs, Ms(kFramePeriod).count(), 0.1 * Ms(kFramePeriod).count())
            << "mean frame period over sequence " << st.firstId << ".." << st.lastId;
    }
    return st;
}

class Vivid : public ::testing::Test {
  protected:
    void SetUp() override { prepareVivid(); }
};

TEST_F(Vivid, OpensAndNamesTheDeviceAndItsControls)
{
    auto cam = makeCamera("Mono8", {}, {{"Test Pattern", "1"}});
    ASSERT_TRUE(cam->configure()) << "configure";
    auto info = cam->info();
    ASSERT_TRUE(info.ok()) << info.message();
    EXPECT_EQ(info.value().backend, "v4l2");
    EXPECT_EQ(info.value().vendor, "vivid");
    EXPECT_EQ(info.value().address, kDevice);
    EXPECT_EQ(info.value().sensorWidth, kWidth);
    EXPECT_EQ(info.value().sensorHeight, kHeight);

    auto features = cam->listFeatures();
    ASSERT_TRUE(features.ok()) << features.message();
    auto find = [&](const std::string& name) -> const hg::drivers::FeatureInfo* {
        for (const auto& f : features.value())
            if (f.name == name) return &f;
        return nullptr;
    };
    const auto* pattern = find("Test Pattern");
    ASSERT_NE(pattern, nullptr);
    EXPECT_EQ(pattern->type, "Enumeration");
    EXPECT_EQ(pattern->access, "RW");
    EXPECT_EQ(pattern->value, "1");
    const auto* disconnect = find("Disconnect");
    ASSERT_NE(disconnect, nullptr);
    EXPECT_EQ(disconnect->type, "Command");
    auto value = cam->getFeature("Test Pattern");
    ASSERT_TRUE(value.ok()) << value.message();
    EXPECT_EQ(value.value(), "1");
    auto missing = cam->getFeature("No Such Control");
    EXPECT_FALSE(missing.ok());
    EXPECT_NE(missing.message().find("no control named 'No Such Control'"), std::string::npos) << missing.message();
    ASSERT_TRUE(cam->cleanup());
}

TEST_F(Vivid, GreyStreamsThirtyFramesOfTheSeventyFivePercentBars)
{
    auto cam = makeCamera("Mono8");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    const auto st = streamFrames(*cam, 30, CV_8UC1, [](const Frame& f) {
        // GREY: Rec. 709 luma, full range.
        expectBars(
            f.image, [](int i) { return 255.0 * lumaOf(kBars75[i], kRec709); }, kTol8);
    });
    EXPECT_GE(st.lastId - st.firstId + static_cast<std::uint64_t>(st.repeatedIds), 29u);
    ASSERT_TRUE(cam->deactivate());
    ASSERT_TRUE(cam->cleanup());
}

TEST_F(Vivid, YuyvIsConvertedToItsLuma)
{
    auto cam = makeCamera("Mono8", "    device_format: YUYV\n");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    streamFrames(*cam, 30, CV_8UC1, [](const Frame& f) {
        // YUYV: BT.601 Y', limited range 16..235.
        expectBars(
            f.image, [](int i) { return 16.0 + 219.0 * lumaOf(kBars75[i], kRec601); }, kTol8);
    });
    ASSERT_TRUE(cam->deactivate());

    // The pinned device format cannot serve another pixel format: refused, naming the key.
    hg::drivers::CameraSettings wide = cam->settings();
    wide.pixelFormat = hg::drivers::PixelFormat::Mono16;
    Status s = cam->setSettings(wide);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("camera.driver.device_format: YUYV cannot deliver Mono16"), std::string::npos)
        << s.message();
    (void)cam->cleanup();
}

TEST_F(Vivid, DeviceFormatMustServeThePixelFormatAtLoad)
{
    try {
        (void)makeCamera("Mono16", "    device_format: YUYV\n");
        FAIL() << "device_format YUYV accepted for Mono16";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "camera.driver.device_format");
        EXPECT_EQ(e.problem(), "'YUYV' cannot deliver Mono16; expected Y16");
    }
    // Pinned to GREY, Mono8 is the luma format's Rec. 709 bars, not YUYV's BT.601 ones.
    auto cam = makeCamera("Mono8", "    device_format: GREY\n");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    Frame f = cam->grab(kGrabTimeout);
    ASSERT_TRUE(f.ok()) << f.message;
    expectBars(
        f.image, [](int i) { return 255.0 * lumaOf(kBars75[i], kRec709); }, kTol8);
}

TEST_F(Vivid, SixteenAndTwelveBitGreyKeepTheirDepth)
{
    {
        auto cam = makeCamera("Mono16");
        ASSERT_TRUE(cam->configure()) << "configure Mono16";
        ASSERT_TRUE(cam->activate()) << "activate Mono16";
        streamFrames(*cam, 5, CV_16UC1, [](const Frame& f) {
            expectBars(
                f.image, [](int i) { return 65535.0 * lumaOf(kBars75[i], kRec709); }, (kTol8 + 1) * 257);
        });
        ASSERT_TRUE(cam->deactivate());
        ASSERT_TRUE(cam->cleanup());
    }
    {
        auto cam = makeCamera("Mono12");
        ASSERT_TRUE(cam->configure()) << "configure Mono12";
        ASSERT_TRUE(cam->activate()) << "activate Mono12";
        streamFrames(*cam, 5, CV_16UC1, [](const Frame& f) {
            // 12 significant bits in the low bits of each 16-bit word.
            expectBars(
                f.image, [](int i) { return 4095.0 * lumaOf(kBars75[i], kRec709); }, (kTol8 + 1) * 16);
            double lo = 0, hi = 0;
            cv::minMaxLoc(f.image, &lo, &hi);
            EXPECT_LE(hi, 4095.0);
        });
        ASSERT_TRUE(cam->deactivate());
        ASSERT_TRUE(cam->cleanup());
    }
}

TEST_F(Vivid, SolidPatternsFollowTheQuantizationRange)
{
    // 100 % white and black through YUYV: limited range 235 / 16, full range 255 / 0.
    struct Case {
        const char* pattern;
        const char* quantization; // vivid's menu: 1 Full Range, 2 Limited Range
        double level;
    };
    for (const Case& c : {Case{"6", "2", 235.0}, Case{"5", "2", 16.0}, Case{"6", "1", 255.0}, Case{"5", "1", 0.0}}) {
        SCOPED_TRACE(std::string("pattern ") + c.pattern + ", quantization " + c.quantization);
        auto cam = makeCamera("Mono8", "    device_format: YUYV\n",
                              {{"Test Pattern", c.pattern}, {"Quantization", c.quantization}});
        ASSERT_TRUE(cam->configure()) << "configure";
        ASSERT_TRUE(cam->activate()) << "activate";
        Frame f = cam->grab(kGrabTimeout);
        ASSERT_TRUE(f.ok()) << f.message;
        double lo = 0, hi = 0;
        cv::minMaxLoc(f.image, &lo, &hi);
        EXPECT_NEAR(lo, c.level, 1.0);
        EXPECT_NEAR(hi, c.level, 1.0);
        f.release();
        ASSERT_TRUE(cam->deactivate());
        ASSERT_TRUE(cam->cleanup());
    }
}

TEST_F(Vivid, GainIsSetByNameAndExposureIsRefusedWithoutTheControl)
{
    auto cam = makeCamera("Mono8", {}, {{"Gain, Automatic", "false"}, {"Gain", "57"}});
    ASSERT_TRUE(cam->configure()) << "configure";
    auto gain = cam->getFeature("Gain");
    ASSERT_TRUE(gain.ok()) << gain.message();
    EXPECT_EQ(gain.value(), "57");
    ASSERT_TRUE(cam->activate());
    ASSERT_TRUE(cam->setFeature("Gain", "201")) << "while streaming";
    EXPECT_EQ(cam->getFeature("Gain").value(), "201");
    Status refused = cam->setFeature("Gain", "300"); // outside vivid's 0..255
    EXPECT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("cannot set Gain = 300: outside the control's range 0..255"), std::string::npos)
        << refused.message();
    EXPECT_EQ(cam->getFeature("Gain").value(), "201") << "a refused value leaves the control alone";
    ASSERT_TRUE(cam->deactivate());
    ASSERT_TRUE(cam->cleanup());

    // vivid has no absolute exposure: exposure_us must fail at configure, saying so.
    auto exposed = makeCamera("Mono8", "    exposure_us: 5000\n");
    Status s = exposed->configure();
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("no absolute exposure control"), std::string::npos) << s.message();
    EXPECT_EQ(exposed->state(), LifecycleState::Unconfigured);
}

TEST_F(Vivid, RoiIsRefusedWhenTheDeviceCannotCropExactly)
{
    // vivid's webcam input has no crop rectangle: the ROI must not be silently dropped.
    auto cam = makeCamera("Mono8", "    roi: [16, 8, 160, 90]\n");
    Status s = cam->configure();
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("cannot crop to the ROI"), std::string::npos) << s.message();
}

TEST_F(Vivid, GrabTimesOutWhenFramesStopAndResumesWhenTheyReturn)
{
    auto cam = makeCamera("Mono8");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    {
        Frame f = cam->grab(kGrabTimeout);
        ASSERT_TRUE(f.ok()) << f.message;
    }
    // vivid drops every frame: the stream runs but delivers nothing.
    ASSERT_TRUE(cam->setFeature("Percentage of Dropped Buffers", "100"));
    const auto t0 = Clock::now();
    Frame silent = cam->grab(400ms);
    const auto waited = Clock::now() - t0;
    EXPECT_EQ(silent.status, FrameStatus::Timeout) << silent.message;
    EXPECT_NE(silent.message.find("no frame within 400 ms"), std::string::npos) << silent.message;
    EXPECT_GE(waited, 400ms);
    EXPECT_LT(waited, 400ms + 1500ms);
    ASSERT_TRUE(cam->setFeature("Percentage of Dropped Buffers", "0"));
    Frame back = cam->grab(kGrabTimeout);
    ASSERT_TRUE(back.ok()) << back.message;
    EXPECT_GT(back.frameId, 0u);
    back.release();

    // Holding every pool buffer starves the stream the same way; releasing one revives it.
    std::vector<Frame> held;
    for (int k = 0; k < 4; ++k) {
        held.push_back(cam->grab(kGrabTimeout));
        ASSERT_TRUE(held.back().ok()) << held.back().message;
    }
    EXPECT_EQ(cam->grab(400ms).status, FrameStatus::Timeout);
    held.front().release();
    Frame revived = cam->grab(kGrabTimeout);
    EXPECT_TRUE(revived.ok()) << revived.message;
    ASSERT_TRUE(cam->deactivate());
}

TEST_F(Vivid, CorruptFramesAreReportedIncomplete)
{
    auto cam = makeCamera("Mono8");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    ASSERT_TRUE(cam->setFeature("Inject V4L2_BUF_FLAG_ERROR", "1"));
    bool sawIncomplete = false;
    for (int k = 0; k < 8 && !sawIncomplete; ++k) {
        Frame f = cam->grab(kGrabTimeout);
        ASSERT_NE(f.status, FrameStatus::Timeout) << f.message;
        if (f.status == FrameStatus::Incomplete) {
            sawIncomplete = true;
            EXPECT_NE(f.message.find("corrupt"), std::string::npos) << f.message;
        }
    }
    EXPECT_TRUE(sawIncomplete) << "no frame flagged V4L2_BUF_FLAG_ERROR after the injection";
    Frame after = cam->grab(kGrabTimeout);
    EXPECT_TRUE(after.ok()) << after.message;
}

TEST_F(Vivid, StopsAndStartsAgain)
{
    auto cam = makeCamera("Mono8");
    ASSERT_TRUE(cam->configure()) << "configure";
    StreamStats previous;
    for (int run = 0; run < 2; ++run) {
        SCOPED_TRACE("streaming session " + std::to_string(run));
        ASSERT_TRUE(cam->activate()) << "activate";
        const auto st = streamFrames(*cam, 30, CV_8UC1, [](const Frame& f) {
            expectBars(
                f.image, [](int i) { return 255.0 * lumaOf(kBars75[i], kRec709); }, kTol8);
        });
        if (run > 0) {
            // A new stream: vivid counts from 0 again, on the same monotonic clock.
            EXPECT_LT(st.firstId, previous.lastId);
            EXPECT_GT(st.firstTs, previous.lastTs);
        }
        previous = st;
        ASSERT_TRUE(cam->deactivate());
        Frame idle = cam->grab(100ms);
        EXPECT_EQ(idle.status, FrameStatus::Error) << "grab while stopped: " << idle.message;
    }
    ASSERT_TRUE(cam->cleanup());
}

TEST_F(Vivid, AFrameHeldAcrossStopStaysValidAndTheNextStartWorks)
{
    auto cam = makeCamera("Mono8");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    Frame kept = cam->grab(kGrabTimeout);
    ASSERT_TRUE(kept.ok()) << kept.message;
    ASSERT_TRUE(cam->deactivate());
    // The kept frame's pixels are still the bars after the stream stopped.
    expectBars(
        kept.image, [](int i) { return 255.0 * lumaOf(kBars75[i], kRec709); }, kTol8);
    Status again = cam->activate();
    ASSERT_TRUE(again.ok()) << again.message();
    Frame next = cam->grab(kGrabTimeout);
    EXPECT_TRUE(next.ok()) << next.message;
    kept.release();
    next.release();
    ASSERT_TRUE(cam->deactivate());
    ASSERT_TRUE(cam->cleanup());
}

// Last (GoogleTest runs tests in file order): vivid's "Disconnect" unregisters
// the device until the module is reloaded.
TEST_F(Vivid, UnplugMidStreamIsAnErrorNotAHang)
{
    auto cam = makeCamera("Mono8");
    ASSERT_TRUE(cam->configure()) << "configure";
    ASSERT_TRUE(cam->activate()) << "activate";
    ASSERT_TRUE(cam->grab(kGrabTimeout).ok());
    ASSERT_TRUE(cam->setFeature("Disconnect", "1"));
    const auto t0 = Clock::now();
    Frame f = cam->grab(kGrabTimeout);
    EXPECT_EQ(f.status, FrameStatus::Error) << f.message;
    EXPECT_LT(Clock::now() - t0, kGrabTimeout);
    (void)cam->deactivate();
    (void)cam->cleanup();
}

} // namespace
