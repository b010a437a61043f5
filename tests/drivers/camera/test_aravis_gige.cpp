// The Aravis driver end to end against hullgauge-gige-sim over real GVCP/GVSP
// on 127.0.0.1 (in a private network namespace per test process). Expected
// pixels are the images the test itself wrote for the simulator to serve.
#include "gige_sim_process.h"
#include "hgtest/log_capture.h"
#include "hgtest/manual_clock.h"
#include "hgtest/paths.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/drivers/camera.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <glib.h>
#include <gtest/gtest.h>
#include <iostream>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace {

using namespace std::chrono_literals;
using hg::drivers::Camera;
using hg::drivers::FrameStatus;
using hg::drivers::LifecycleState;
using Clock = std::chrono::steady_clock;

constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr int kImages = 7;

class AravisGige : public ::testing::Test {
  protected:
    void SetUp() override
    {
        if (auto why = hgtest::isolateNetwork(); !why.empty()) GTEST_SKIP() << why;
        // Seeded noise images: every pixel differs between images, so a frame
        // can only match the image it was made from.
        cv::RNG rng(20240517);
        for (int i = 0; i < kImages; ++i) {
            cv::Mat img(kHeight, kWidth, CV_8UC1);
            rng.fill(img, cv::RNG::UNIFORM, 0, 256);
            char name[32];
            std::snprintf(name, sizeof name, "view%02d.png", i);
            ASSERT_TRUE(cv::imwrite((dir_ / name).string(), img));
            images_.push_back(img);
        }
    }

    void startSim() { sim_.start({"--images", dir_.path().string(), "--frame-rate", "100"}); }

    std::unique_ptr<Camera> makeCamera(const std::string& extra, hg::Clock& clock = hg::Clock::steady())
    {
        auto root = hg::ConfigNode::parse("camera:\n  driver:\n    backend: aravis\n    address: 127.0.0.1\n" + extra,
                                          "station.yaml");
        return hg::drivers::makeCamera(root, {}, clock);
    }

    static double maxDifference(const cv::Mat& a, const cv::Mat& b)
    {
        if (a.size() != b.size() || a.type() != b.type()) return -1.0;
        return cv::norm(a, b, cv::NORM_INF);
    }

    /// Index of the served image `frame` equals exactly, or -1.
    int matchingImage(const cv::Mat& frame) const
    {
        for (int i = 0; i < kImages; ++i)
            if (maxDifference(frame, images_[i]) == 0.0) return i;
        return -1;
    }

    hgtest::TempDir dir_;
    std::vector<cv::Mat> images_;
    hgtest::GigeSim sim_;
};

TEST_F(AravisGige, SetsExposureGainAndRoiByNameAndReadsThemBack)
{
    startSim();
    auto cam = makeCamera("    exposure_us: 2500\n    gain_db: 6.5\n    roi: [16, 8, 96, 64]\n");
    ASSERT_TRUE(cam->configure()) << cam->configure().message();
    auto number = [&](const char* name) {
        auto v = cam->getFeature(name);
        EXPECT_TRUE(v.ok()) << name << ": " << v.message();
        return v.ok() ? std::stod(v.value()) : -1.0;
    };
    EXPECT_DOUBLE_EQ(number("ExposureTime"), 2500.0);
    EXPECT_DOUBLE_EQ(number("Gain"), 6.5);
    EXPECT_EQ(number("OffsetX"), 16);
    EXPECT_EQ(number("OffsetY"), 8);
    EXPECT_EQ(number("Width"), 96);
    EXPECT_EQ(number("Height"), 64);
    EXPECT_EQ(cam->getFeature("PixelFormat").value(), "Mono8");
    EXPECT_EQ(cam->getFeature("TriggerSource").value(), "Software");

    // Set by name through the maintenance path, read back through the device.
    EXPECT_TRUE(cam->setFeature("ExposureTime", "12000"));
    EXPECT_DOUBLE_EQ(number("ExposureTime"), 12000.0);
    EXPECT_TRUE(cam->setFeature("Gain", "3"));
    EXPECT_DOUBLE_EQ(number("Gain"), 3.0);
    EXPECT_TRUE(cam->setFeature("Width", "64"));
    EXPECT_EQ(number("Width"), 64);

    auto bad = cam->setFeature("NoSuchFeature", "1");
    EXPECT_FALSE(bad);
    EXPECT_NE(bad.message().find("NoSuchFeature"), std::string::npos);

    auto info = cam->info();
    ASSERT_TRUE(info.ok()) << info.message();
    EXPECT_EQ(info.value().serial, "HGSIM0001");
    EXPECT_EQ(info.value().sensorWidth, kWidth);
    EXPECT_EQ(info.value().sensorHeight, kHeight);

    auto features = cam->listFeatures();
    ASSERT_TRUE(features.ok());
    bool sawGain = false;
    for (const auto& f : features.value())
        if (f.name == "Gain") sawGain = f.type == "Float" && f.access == "RW" && std::stod(f.value) == 3.0;
    EXPECT_TRUE(sawGain);
    EXPECT_TRUE(cam->cleanup());
}

TEST_F(AravisGige, HundredTriggeredFramesEqualTheServedImagesInOrder)
{
    startSim();
    auto cam = makeCamera("    trigger: software\n    buffer_count: 4\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    int first = -1;
    std::uint64_t lastId = 0;
    for (int k = 0; k < 100; ++k) {
        auto frame = cam->grab(2000ms);
        ASSERT_EQ(frame.status, FrameStatus::Ok) << "frame " << k << ": " << frame.message;
        ASSERT_EQ(frame.image.type(), CV_8UC1);
        int match = matchingImage(frame.image);
        ASSERT_GE(match, 0) << "frame " << k << " equals none of the served images";
        if (first < 0) first = match;
        // One trigger, one exposure: the simulator serves its images in turn.
        EXPECT_EQ(match, (first + k) % kImages) << "frame " << k;
        if (k > 0) {
            EXPECT_GT(frame.frameId, lastId);
        }
        lastId = frame.frameId;
    }
    EXPECT_TRUE(cam->deactivate());
    EXPECT_TRUE(cam->cleanup());
}

TEST_F(AravisGige, RoiAndWidePixelFormatsCarryTheServedPixels)
{
    startSim();
    auto cam = makeCamera("    roi: [24, 10, 64, 48]\n");
    ASSERT_TRUE(cam->configure());
    const cv::Rect roi(24, 10, 64, 48);

    struct Case {
        hg::drivers::PixelFormat format;
        double scale; // expected = served * scale
    };
    for (Case c : {Case{hg::drivers::PixelFormat::Mono8, 1.0}, Case{hg::drivers::PixelFormat::Mono12, 16.0},
                   Case{hg::drivers::PixelFormat::Mono16, 257.0}}) {
        auto s = cam->settings();
        s.pixelFormat = c.format;
        ASSERT_TRUE(cam->setSettings(s));
        ASSERT_TRUE(cam->activate());
        for (int k = 0; k < 5; ++k) {
            auto frame = cam->grab(2000ms);
            ASSERT_TRUE(frame.ok()) << frame.message;
            ASSERT_EQ(frame.image.size(), roi.size());
            bool matched = false;
            for (const auto& img : images_) {
                cv::Mat expected;
                img(roi).convertTo(expected, hg::drivers::cvTypeOf(c.format), c.scale);
                matched = matched || maxDifference(frame.image, expected) == 0.0;
            }
            EXPECT_TRUE(matched) << hg::enumName(c.format) << " frame " << k;
        }
        ASSERT_TRUE(cam->deactivate());
    }
    EXPECT_TRUE(cam->cleanup());
}

TEST_F(AravisGige, FreeRunDeliversFreshServedFrames)
{
    startSim();
    auto cam = makeCamera("    trigger: free_run\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    // Streaming over UDP, a loaded machine may drop packets of a frame: the
    // driver then reports it Incomplete (its own test below), which is right,
    // not a failure of free run. Twenty complete frames must come, fresh and
    // in order, within a bounded number of grabs; anything else fails.
    std::uint64_t lastId = 0;
    int complete = 0;
    for (int attempt = 0; attempt < 200 && complete < 20; ++attempt) {
        auto frame = cam->grab(5000ms);
        if (frame.status == hg::drivers::FrameStatus::Incomplete) continue;
        ASSERT_TRUE(frame.ok()) << frame.message;
        EXPECT_GE(matchingImage(frame.image), 0);
        if (complete > 0) {
            EXPECT_GT(frame.frameId, lastId);
        }
        lastId = frame.frameId;
        ++complete;
    }
    EXPECT_EQ(complete, 20);
}

TEST_F(AravisGige, FramesHeldByTheCallerAreNotOverwritten)
{
    startSim();
    auto cam = makeCamera("    buffer_count: 3\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    // Hold two frames (views of pool buffers) while grabbing more.
    auto a = cam->grab(2000ms);
    auto b = cam->grab(2000ms);
    ASSERT_TRUE(a.ok() && b.ok());
    const cv::Mat aCopy = a.image.clone();
    const cv::Mat bCopy = b.image.clone();
    for (int k = 0; k < 10; ++k) {
        auto c = cam->grab(2000ms);
        ASSERT_TRUE(c.ok()) << c.message;
        EXPECT_NE(c.image.data, a.image.data);
        EXPECT_NE(c.image.data, b.image.data);
    }
    EXPECT_EQ(maxDifference(a.image, aCopy), 0.0);
    EXPECT_EQ(maxDifference(b.image, bCopy), 0.0);
    // Frames may outlive the stream: their buffers are then freed, not requeued.
    ASSERT_TRUE(cam->deactivate());
    EXPECT_EQ(maxDifference(a.image, aCopy), 0.0);
    a.release();
    EXPECT_TRUE(a.image.empty());
}

/// The product's promise for a dead camera: every grab returns within its own
/// timeout plus a small margin (generous here for a loaded 2-core machine),
/// fails with a message naming the camera, and frames come back within a
/// bounded number of grabs once the camera returns.
/// `away`: how long the camera stays dead. 6 s covers the loss being noticed
/// and the old connection being closed; 16 s also failed reopen attempts with
/// backoff (closing a dead connection costs Aravis ~10 s of GVCP timeouts).
void killAndRecover(Camera& cam, hgtest::GigeSim& sim, const std::function<void()>& restart,
                    const std::function<int(const cv::Mat&)>& match, std::chrono::seconds away)
{
    for (int k = 0; k < 10; ++k) ASSERT_TRUE(cam.grab(2000ms).ok());

    sim.kill();
    const auto timeout = 400ms;
    const auto margin = 500ms;
    // Probe, close and reopen attempts all run off the grab path.
    const auto deadAfter = Clock::now() + away;
    int grabs = 0;
    FrameStatus firstStatus = FrameStatus::Ok;
    bool sawLost = false;
    bool sawFailedReopen = false;
    while (Clock::now() < deadAfter) {
        const auto t0 = Clock::now();
        auto f = cam.grab(timeout);
        const auto took = Clock::now() - t0;
        EXPECT_LE(took, timeout + margin)
            << "grab " << grabs << " took " << std::chrono::duration_cast<std::chrono::milliseconds>(took).count()
            << " ms: " << f.message;
        EXPECT_FALSE(f.ok()) << "grab " << grabs << " delivered a frame from a dead camera";
        EXPECT_NE(f.message.find("camera 127.0.0.1"), std::string::npos) << f.message;
        if (grabs == 0) firstStatus = f.status;
        sawLost = sawLost || (f.status == FrameStatus::Error && f.message.find("lost") != std::string::npos);
        sawFailedReopen = sawFailedReopen || f.message.find("reconnect failed") != std::string::npos;
        ++grabs;
    }
    EXPECT_EQ(firstStatus, FrameStatus::Timeout);
    EXPECT_TRUE(sawLost) << "the driver never declared the camera lost";
    if (away >= 16s) {
        EXPECT_TRUE(sawFailedReopen) << "no reopen attempt failed while the camera was away";
    }
    EXPECT_GE(grabs, 6) << "grabs must not block while the driver reconnects";
    EXPECT_EQ(cam.state(), LifecycleState::Active);

    restart();
    // Reconnection: backoff at most 400 ms (the test's reconnect_backoff_ms)
    // plus one reopen attempt in flight; 40 grabs of 400 ms bound it.
    int recoveredAfter = -1;
    for (int k = 0; k < 40 && recoveredAfter < 0; ++k) {
        const auto t0 = Clock::now();
        auto f = cam.grab(timeout);
        EXPECT_LE(Clock::now() - t0, timeout + margin) << f.message;
        if (f.ok()) {
            recoveredAfter = k;
            EXPECT_GE(match(f.image), 0);
        }
    }
    ASSERT_GE(recoveredAfter, 0) << "no frame within 40 grabs of the camera's return";
    for (int k = 0; k < 5; ++k) {
        auto f = cam.grab(2000ms);
        ASSERT_TRUE(f.ok()) << f.message;
        EXPECT_GE(match(f.image), 0);
    }
    EXPECT_EQ(cam.state(), LifecycleState::Active);
}

TEST_F(AravisGige, SoftwareTriggeredGrabsOfADeadCameraAreBoundedAndRecover)
{
    startSim();
    auto cam = makeCamera("    trigger: software\n    reconnect_backoff_ms: [100, 400]\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    killAndRecover(
        *cam, sim_, [&] { startSim(); }, [&](const cv::Mat& m) { return matchingImage(m); }, 6s);
    // Deactivate and clean up are bounded too after a recovery.
    const auto t0 = Clock::now();
    EXPECT_TRUE(cam->deactivate());
    EXPECT_TRUE(cam->cleanup());
    EXPECT_LE(Clock::now() - t0, 5s);
}

TEST_F(AravisGige, FreeRunGrabsOfACameraAwayLongerAreBoundedThroughFailedReopensAndRecover)
{
    startSim();
    auto cam = makeCamera("    trigger: free_run\n    reconnect_backoff_ms: [100, 400]\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    killAndRecover(
        *cam, sim_, [&] { startSim(); }, [&](const cv::Mat& m) { return matchingImage(m); }, 16s);
}

TEST_F(AravisGige, DeactivatingWhileTheCameraIsLostIsBounded)
{
    startSim();
    auto cam = makeCamera("    trigger: software\n    reconnect_backoff_ms: [100, 400]\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    ASSERT_TRUE(cam->grab(2000ms).ok());
    sim_.kill();
    for (int k = 0; k < 8; ++k) (void)cam->grab(300ms); // probe and reopen attempts under way
    const auto t0 = Clock::now();
    EXPECT_TRUE(cam->deactivate());
    EXPECT_TRUE(cam->cleanup());
    // Bounded by Aravis' GVCP timeouts: the exchange in flight (~2.5 s), then
    // telling the dead device to stop its stream and to release control
    // (~5 s each); see docs/camera.md.
    EXPECT_LE(Clock::now() - t0, 15s);
    EXPECT_EQ(cam->state(), LifecycleState::Unconfigured);
    // And the camera comes back through the ordinary lifecycle.
    startSim();
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto f = cam->grab(2000ms);
    ASSERT_TRUE(f.ok()) << f.message;
    EXPECT_GE(matchingImage(f.image), 0);
}

// docs/camera.md, "Recovery", and docs/drivers.md, "Clock": the link worker
// reopens a lost camera after `reconnect_backoff_ms` min, doubling up to max,
// on the driver's clock. The loss itself is Aravis' to notice (the probe's
// GVCP read times out after its own ~2.5 s, real time: polled under a
// generous deadline). The back-off is then the test's: on a clock it holds,
// the worker waits exactly 1 s, reopens a dead camera once the clock has
// passed it (the attempt fails: the next wait is 2 s), and does not reopen a
// camera that is back before the clock has passed that wait — only then.
TEST_F(AravisGige, TheLinkWorkerReconnectsAtItsBackOffOnTheDriversClockAndNotBefore)
{
    startSim();
    hgtest::ManualClock clock(hgtest::ManualClock::Sleeps::WaitForTheHand);
    auto cam = makeCamera("    trigger: software\n    reconnect_backoff_ms: [1000, 4000]\n", clock);
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    ASSERT_TRUE(cam->grab(2000ms).ok());
    sim_.kill();

    // Grabs of 400 ms until the driver says what it waits for (it closes the dead
    // connection first: ~10 s of Aravis' GVCP timeouts against a dead camera).
    auto grabUntil = [&](const std::string& wanted) {
        std::string last;
        const auto giveUp = Clock::now() + 120s;
        while (Clock::now() < giveUp) {
            auto f = cam->grab(400ms);
            EXPECT_FALSE(f.ok()) << "a frame from a dead camera";
            last = f.message;
            if (last.find(wanted) != std::string::npos) return last;
        }
        ADD_FAILURE() << "no grab said '" << wanted << "' within 120 s; the last: " << last;
        return last;
    };
    const auto lostAt = clock.now(); // the clock has not moved since the kill
    std::string message = grabUntil("next attempt in");
    EXPECT_NE(message.find("camera 127.0.0.1: lost (not answering"), std::string::npos) << message;
    EXPECT_NE(message.find("next attempt in 1000 ms"), std::string::npos) << message;
    ASSERT_EQ(clock.nextWake(), lostAt + 1000ms) << "the worker does not wait the back-off on the driver's clock";

    // 999 ms: nothing yet. 1 ms more: the attempt, against the dead camera, fails.
    clock.advance(999ms);
    ASSERT_EQ(clock.nextWake(), lostAt + 1000ms);
    EXPECT_NE(cam->grab(400ms).message.find("next attempt in 1 ms"), std::string::npos);
    clock.advance(1ms);
    message = grabUntil("reconnect failed");
    EXPECT_NE(message.find("next attempt in 2000 ms"), std::string::npos) << message;
    ASSERT_EQ(clock.nextWake(), lostAt + 3000ms) << "the wait did not double";

    // The camera is back and answers: no reconnection before the clock has passed the wait.
    startSim();
    for (int k = 0; k < 5; ++k) {
        auto f = cam->grab(400ms);
        EXPECT_EQ(f.status, FrameStatus::Error) << "grab " << k << ": " << f.message;
        EXPECT_NE(f.message.find("next attempt in 2000 ms"), std::string::npos) << f.message;
    }
    clock.advance(1999ms);
    ASSERT_EQ(clock.nextWake(), lostAt + 3000ms);
    EXPECT_NE(cam->grab(400ms).message.find("next attempt in 1 ms"), std::string::npos);
    clock.advance(1ms);
    int recoveredAfter = -1;
    for (int k = 0; k < 40 && recoveredAfter < 0; ++k) {
        auto f = cam->grab(2000ms);
        if (f.ok()) {
            recoveredAfter = k;
            EXPECT_GE(matchingImage(f.image), 0);
        }
    }
    ASSERT_GE(recoveredAfter, 0) << "no frame within 40 grabs once the back-off had passed";
    EXPECT_EQ(cam->state(), LifecycleState::Active);
    EXPECT_TRUE(cam->deactivate());
    EXPECT_TRUE(cam->cleanup());
}

/// GLib's messages (g_log, every domain without a handler of its own) while
/// alive. A call given a GError* that is already set says so there: Aravis'
/// guard "error == NULL || *error == NULL" or GLib's "GError set over the top".
class GLibMessages {
  public:
    GLibMessages() : previous_(g_log_set_default_handler(&GLibMessages::record, this)) {}
    ~GLibMessages() { g_log_set_default_handler(previous_, nullptr); }
    GLibMessages(const GLibMessages&) = delete;
    GLibMessages& operator=(const GLibMessages&) = delete;

    /// The messages that report a GError passed in already set.
    std::vector<std::string> reusedErrors() const
    {
        std::lock_guard lock(mutex_);
        std::vector<std::string> out;
        for (const auto& m : messages_)
            if (m.find("*error == NULL") != std::string::npos || m.find("over the top") != std::string::npos)
                out.push_back(m);
        return out;
    }

  private:
    static void record(const gchar* domain, GLogLevelFlags, const gchar* message, gpointer self)
    {
        auto* messages = static_cast<GLibMessages*>(self);
        std::lock_guard lock(messages->mutex_);
        messages->messages_.push_back(std::string(domain ? domain : "") + ": " + (message ? message : ""));
    }
    GLogFunc previous_;
    mutable std::mutex mutex_;
    std::vector<std::string> messages_;
};

// GLib's rule for GError (each call that may set one is given a NULL GError*,
// checked and cleared before the next): a camera that stopped answering fails
// the first read of its identity, and the reads after it are not made with
// that error still set.
TEST_F(AravisGige, InfoOfACameraThatStoppedAnsweringFailsWithoutReusingItsError)
{
    startSim();
    auto cam = makeCamera("");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->info().ok());
    GLibMessages messages;
    sim_.kill();
    auto info = cam->info();
    EXPECT_FALSE(info.ok());
    EXPECT_NE(info.message().find("camera 127.0.0.1"), std::string::npos) << info.message();
    EXPECT_EQ(messages.reusedErrors(), std::vector<std::string>{});
}

TEST_F(AravisGige, UnreachableCameraFailsAtConfigureNamingTheKey)
{
    // No simulator: nothing answers on 127.0.0.1.
    auto cam = makeCamera("");
    const auto t0 = Clock::now();
    auto s = cam->configure();
    EXPECT_FALSE(s);
    EXPECT_NE(s.message().find("camera.driver.address"), std::string::npos) << s.message();
    EXPECT_LE(Clock::now() - t0, 10s);
    // A failed configure changes nothing (docs/drivers.md): configure again to retry.
    EXPECT_EQ(cam->state(), LifecycleState::Unconfigured);
}

// --- Regions per grab (docs/camera.md "Regions per grab") ------------------------

using hg::drivers::Roi;

/// One served image; the fake camera with a GigE camera's coarser region
/// increments: offsets in steps of 4 (x) and 2 (y), widths 8, 16, ..., heights 2, 4, ...
class AravisRegions : public AravisGige {
  protected:
    void startRegionSim(const std::vector<std::string>& extra = {})
    {
        std::vector<std::string> args{"--image", (dir_ / "view00.png").string(), "--frame-rate",
                                      "100",     "--region-increments",          "4,2,8,2"};
        args.insert(args.end(), extra.begin(), extra.end());
        sim_.start(args);
    }

    /// Grabs until a complete frame (free run over UDP may lose packets of one), at most 20 tries.
    static hg::drivers::Frame grabComplete(Camera& cam)
    {
        for (int attempt = 0; attempt < 20; ++attempt) {
            auto f = cam.grab(2000ms);
            if (f.status != FrameStatus::Incomplete) return f;
        }
        return hg::drivers::Frame::failed(FrameStatus::Incomplete, "20 incomplete frames in a row");
    }

    /// Each request, the region it must give (rounded out by hand), then two
    /// grabs of it: size, origin, bytes and pixels of the served image's window.
    void grabRegions(Camera& cam)
    {
        const cv::Mat& served = images_[0];
        struct Case {
            Roi request;
            Roi expected;
        };
        const Case cases[] = {
            // x 13 -> 12, right edge 63 -> width 56; y 7 -> 6, bottom 38 -> height 32
            {{13, 7, 50, 31}, {12, 6, 56, 32}},
            // the same size moved: written while streaming (offsets not locked)
            {{40, 20, 56, 32}, {40, 20, 56, 32}},
            // clamped to [150, 160) x [100, 120): 148 + 16 > 160, one step back to 144
            {{150, 100, 30, 40}, {144, 100, 16, 20}},
            {{0, 0, 8, 2}, {0, 0, 8, 2}},
            {{}, {0, 0, kWidth, kHeight}},
        };
        for (const Case& c : cases) {
            SCOPED_TRACE(fmt::format("request {}", c.request));
            auto region = cam.setRegion(c.request);
            ASSERT_TRUE(region.ok()) << region.message();
            EXPECT_EQ(region.value(), c.expected);
            for (int k = 0; k < 2; ++k) {
                auto f = grabComplete(cam);
                ASSERT_TRUE(f.ok()) << f.message;
                EXPECT_EQ(f.region, c.expected);
                ASSERT_EQ(f.image.size(), cv::Size(c.expected.width, c.expected.height));
                EXPECT_EQ(f.payloadBytes, static_cast<std::size_t>(c.expected.width) * c.expected.height);
                const cv::Rect window(c.expected.x, c.expected.y, c.expected.width, c.expected.height);
                EXPECT_EQ(maxDifference(f.image, served(window)), 0.0) << "grab " << k;
                if (k == 1) {
                    EXPECT_EQ(f.regionChangeMs, 0.0) << "no change before the second grab";
                }
            }
        }
    }
};

TEST_F(AravisRegions, SoftwareTriggeredRegionsAreRoundedOutwardAndCarryTheServedPixels)
{
    startRegionSim();
    auto cam = makeCamera("    trigger: software\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    auto whole = cam->grab(2000ms);
    ASSERT_TRUE(whole.ok()) << whole.message;
    EXPECT_EQ(whole.region, (Roi{0, 0, kWidth, kHeight}));
    EXPECT_EQ(whole.payloadBytes, static_cast<std::size_t>(kWidth) * kHeight);
    EXPECT_EQ(maxDifference(whole.image, images_[0]), 0.0);
    whole.release();

    grabRegions(*cam);

    auto outside = cam->setRegion(Roi{200, 10, 10, 10});
    EXPECT_EQ(outside.code(), hg::StatusCode::NotAllowed);
    EXPECT_EQ(outside.message(),
              "camera: region [200, 10, 10, 10] lies outside the sensor region [0, 0, 160, 120] the camera delivers");

    // A region is left on the device at deactivate; the next activation starts whole again.
    ASSERT_TRUE(cam->setRegion(Roi{13, 7, 50, 31}).ok());
    ASSERT_TRUE(cam->grab(2000ms).ok());
    ASSERT_TRUE(cam->deactivate());
    ASSERT_TRUE(cam->activate());
    auto again = cam->grab(2000ms);
    ASSERT_TRUE(again.ok()) << again.message;
    EXPECT_EQ(again.region, (Roi{0, 0, kWidth, kHeight}));
    EXPECT_EQ(maxDifference(again.image, images_[0]), 0.0);
}

TEST_F(AravisRegions, FreeRunRegionsDropTheFramesOfTheRegionBefore)
{
    startRegionSim();
    auto cam = makeCamera("    trigger: free_run\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    grabRegions(*cam);
}

TEST_F(AravisRegions, ConfiguredRoiBoundsTheRegions)
{
    startRegionSim();
    auto cam = makeCamera("    roi: [16, 10, 96, 64]\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    // Clamped to [16, 20) x [10, 12), then width 8 and height 2.
    EXPECT_EQ(cam->setRegion(Roi{0, 0, 20, 12}).value(), (Roi{16, 10, 8, 2}));
    auto f = cam->grab(2000ms);
    ASSERT_TRUE(f.ok()) << f.message;
    EXPECT_EQ(f.region, (Roi{16, 10, 8, 2}));
    EXPECT_EQ(maxDifference(f.image, images_[0](cv::Rect(16, 10, 8, 2))), 0.0);
    EXPECT_EQ(cam->setRegion(Roi{}).value(), (Roi{16, 10, 96, 64}));
    auto g = cam->grab(2000ms);
    ASSERT_TRUE(g.ok()) << g.message;
    EXPECT_EQ(g.region, (Roi{16, 10, 96, 64}));
}

TEST_F(AravisRegions, CameraWithReadOnlyOffsetXFallsBackToWholeFramesWithOneWarning)
{
    startRegionSim({"--read-only-offset-x"});
    hgtest::LogCapture log("camera");
    auto cam = makeCamera("    trigger: software\n");
    ASSERT_TRUE(cam->configure());
    EXPECT_EQ(cam->getFeature("OffsetX").value(), "0");
    ASSERT_TRUE(cam->activate());
    for (int k = 0; k < 3; ++k) {
        auto region = cam->setRegion(Roi{13, 7, 50, 31});
        ASSERT_TRUE(region.ok()) << region.message();
        EXPECT_EQ(region.value(), (Roi{0, 0, kWidth, kHeight}));
        auto f = cam->grab(2000ms);
        ASSERT_TRUE(f.ok()) << f.message;
        EXPECT_EQ(f.region, (Roi{0, 0, kWidth, kHeight})) << "never a wrong crop";
        EXPECT_EQ(maxDifference(f.image, images_[0]), 0.0);
    }
    EXPECT_EQ(log.count(spdlog::level::warn, "delivering whole frames"), 1) << log.text();
    EXPECT_NE(log.text().find("OffsetX is not writable"), std::string::npos) << log.text();
}

/// Figures for docs/camera.md: bytes per frame and grab times of whole frames
/// and of a 600 x 400 region of a 2448 x 2048 Mono8 sensor. Only the bytes are
/// checked; the times are printed (they depend on the machine and its load).
TEST_F(AravisRegions, BytesAndGrabTimesOfWholeFramesAndARegionAt2448x2048)
{
    const cv::Size sensor(2448, 2048);
    cv::Mat big(sensor, CV_8UC1);
    cv::RNG(11).fill(big, cv::RNG::UNIFORM, 0, 256);
    ASSERT_TRUE(cv::imwrite((dir_ / "big.png").string(), big));
    sim_.start({"--image", (dir_ / "big.png").string(), "--region-increments", "4,2,8,2"});
    auto cam = makeCamera("    trigger: software\n    socket_buffer_bytes: 4194304\n");
    ASSERT_TRUE(cam->configure());
    ASSERT_TRUE(cam->activate());
    using Ms = std::chrono::duration<double, std::milli>;
    auto measure = [&](const Roi& request, const char* name) {
        ASSERT_TRUE(cam->setRegion(request).ok());
        std::vector<double> grabs;
        double changeMs = 0.0, firstMs = 0.0;
        std::size_t bytes = 0;
        for (int k = 0; k < 12; ++k) {
            const auto t0 = Clock::now();
            auto f = grabComplete(*cam);
            const double ms = Ms(Clock::now() - t0).count();
            ASSERT_TRUE(f.ok()) << f.message;
            const Roi& r = f.region;
            EXPECT_EQ(f.payloadBytes, static_cast<std::size_t>(r.width) * r.height);
            EXPECT_EQ(maxDifference(f.image, big(cv::Rect(r.x, r.y, r.width, r.height))), 0.0);
            bytes = f.payloadBytes;
            if (k == 0) {
                changeMs = f.regionChangeMs;
                firstMs = ms;
            } else {
                grabs.push_back(ms);
            }
        }
        std::sort(grabs.begin(), grabs.end());
        std::cout << name << ": " << bytes << " bytes per frame; region change " << changeMs << " ms; first grab "
                  << firstMs << " ms; later grabs median " << grabs[grabs.size() / 2] << " ms (min " << grabs.front()
                  << ", max " << grabs.back() << ")\n";
        RecordProperty(std::string(name) + "_bytes", std::to_string(bytes));
        RecordProperty(std::string(name) + "_grab_median_ms", std::to_string(grabs[grabs.size() / 2]));
    };
    measure(Roi{}, "whole");
    measure(Roi{900, 800, 600, 400}, "region");
    measure(Roi{}, "whole again");
}

TEST_F(AravisGige, RoiTheSensorCannotHoldIsRefused)
{
    startSim();
    auto cam = makeCamera("    roi: [100, 0, 100, 50]\n"); // 100 + 100 > 160 px sensor
    auto s = cam->configure();
    EXPECT_FALSE(s);
    EXPECT_NE(s.message().find("ROI"), std::string::npos) << s.message();
}

} // namespace
