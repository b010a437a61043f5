// The inspection pipeline: view k is prepared while the fixture moves to view
// k+1, finish() runs only the traversal. First the ViewPipeline with a
// stand-in preparation whose steps the test releases one by one (no sleeps),
// then the daemon's engine inspector on the simulated line's part program with
// rendered frames, against the defects the variant meshes were built with.
#include "cycle/engine_inspector.h"
#include "cycle/view_pipeline.h"
#include "daemon_config.h"
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/sim/renderer.h"

#include <atomic>
#include <chrono>
#include <future>
#include <gtest/gtest.h>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <set>
#include <thread>

namespace {

using hg::daemon::ViewPipeline;
using hg::inspect::CapturedView;
using hg::inspect::SilhouetteView;
using namespace std::chrono_literals;

hg::geometry::CameraModel smallCamera()
{
    hg::geometry::Intrinsics in;
    in.K << 80, 0, 32, 0, 80, 24, 0, 0, 1;
    in.imageSize = {64, 48};
    return hg::geometry::CameraModel(
        in, hg::geometry::RigidTransform{Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 300)});
}

CapturedView view(int k)
{
    return {"v" + std::to_string(k), smallCamera(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(200))};
}

// A stand-in preparation counting the calls.
ViewPipeline::PrepareFn countingPreparation(std::atomic<int>& calls)
{
    return [&calls](const CapturedView& v) {
        ++calls;
        return SilhouetteView{v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
    };
}

/// A preparation each view of which starts, and then waits until the test lets it finish.
struct SteppedPreparation {
    explicit SteppedPreparation(int views) : started(views), finish(views)
    {
        for (auto& f : finish) released.push_back(f.get_future().share());
    }
    ViewPipeline::PrepareFn fn()
    {
        return [this](const CapturedView& v) {
            const auto k = static_cast<std::size_t>(std::stoi(v.id.substr(1)));
            started[k].set_value();
            released[k].wait();
            return SilhouetteView{v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
        };
    }
    std::vector<std::promise<void>> started;
    std::vector<std::promise<void>> finish;
    std::vector<std::shared_future<void>> released;
};

TEST(ViewPipeline, PreparesEachViewWhileTheFixtureMovesToTheNext)
{
    // The cycle runner submits view k and moves the fixture on: the worker must take
    // view k by itself (nobody waits for it) and be done with it before view k+1 is in.
    constexpr int kViews = 5;
    SteppedPreparation preparation(kViews);
    std::vector<std::future<void>> started;
    for (auto& p : preparation.started) started.push_back(p.get_future());
    ViewPipeline pipeline(2);
    pipeline.begin(preparation.fn());
    for (int k = 0; k < kViews; ++k) {
        pipeline.submit(view(k));
        ASSERT_EQ(started[k].wait_for(10s), std::future_status::ready) << "view " << k << " was not taken up";
        EXPECT_EQ(pipeline.queued(), 0u);
        preparation.finish[k].set_value(); // the preparation ends during the move
    }
    auto prepared = pipeline.wait();

    ASSERT_TRUE(prepared.error.empty()) << prepared.error;
    ASSERT_EQ(prepared.views.size(), static_cast<std::size_t>(kViews));
    ASSERT_EQ(prepared.timings.size(), static_cast<std::size_t>(kViews));
    double sumMs = 0;
    for (int k = 0; k < kViews; ++k) {
        EXPECT_EQ(prepared.ids[k], "v" + std::to_string(k)) << "views come back in submission order";
        const auto& t = prepared.timings[k];
        EXPECT_LE(t.submitted, t.started);
        EXPECT_LE(t.started, t.finished);
        sumMs += std::chrono::duration<double, std::milli>(t.finished - t.started).count();
    }
    // prepareTime is the worker's time: each view's start to finish, summed.
    EXPECT_NEAR(prepared.prepareTime.count(), sumMs, 1e-3 + 1e-6 * sumMs);
}

TEST(ViewPipeline, NamesTheViewThatCouldNotBePrepared)
{
    ViewPipeline pipeline;
    pipeline.begin([](const CapturedView& v) -> SilhouetteView {
        if (v.id == "v1") throw std::runtime_error("lost 3 lines");
        return {v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
    });
    for (int k = 0; k < 3; ++k) pipeline.submit(view(k));
    auto prepared = pipeline.wait();
    EXPECT_EQ(prepared.error, "view 'v1': lost 3 lines");
    EXPECT_EQ(prepared.ids, (std::vector<std::string>{"v0", "v2"}));

    // The next cycle starts clean.
    std::atomic<int> calls{0};
    pipeline.begin(countingPreparation(calls));
    pipeline.submit(view(7));
    prepared = pipeline.wait();
    EXPECT_TRUE(prepared.error.empty());
    EXPECT_EQ(prepared.ids, std::vector<std::string>{"v7"});
}

TEST(ViewPipeline, TheFirstViewsAreHandedOutWhenPreparedAndStayForTheVerdict)
{
    // The cycle runner asks for the first two views (to measure the seat) while
    // the third is still in preparation: it gets them as soon as they are done,
    // and wait() still returns all three.
    SteppedPreparation preparation(3);
    std::vector<std::future<void>> started;
    for (auto& p : preparation.started) started.push_back(p.get_future());
    ViewPipeline pipeline(4);
    pipeline.begin(preparation.fn());
    EXPECT_FALSE(pipeline.firstPrepared(1)) << "nothing submitted yet";
    for (int k = 0; k < 3; ++k) pipeline.submit(view(k));
    auto first = std::async(std::launch::async, [&] { return pipeline.firstPrepared(2); });
    preparation.finish[0].set_value();
    ASSERT_EQ(started[1].wait_for(10s), std::future_status::ready);
    EXPECT_EQ(first.wait_for(0s), std::future_status::timeout) << "view 1 is still in preparation";
    preparation.finish[1].set_value();
    ASSERT_EQ(first.wait_for(10s), std::future_status::ready);
    const auto views = first.get();
    ASSERT_TRUE(views);
    ASSERT_EQ(views->size(), 2u);
    EXPECT_EQ((*views)[0].index.frameSize(), cv::Size()) << "handed out without the silhouette index";
    EXPECT_EQ((*views)[1].camera.intrinsics().imageSize, cv::Size(64, 48));
    preparation.finish[2].set_value();
    const auto prepared = pipeline.wait();
    ASSERT_TRUE(prepared.error.empty()) << prepared.error;
    EXPECT_EQ(prepared.ids, (std::vector<std::string>{"v0", "v1", "v2"}));
    EXPECT_EQ(prepared.views[0].index.frameSize(), cv::Size(64, 48)) << "the index stays with the cycle";
}

TEST(ViewPipeline, AFirstViewThatFailedHandsOutNothing)
{
    ViewPipeline pipeline;
    pipeline.begin([](const CapturedView& v) -> SilhouetteView {
        if (v.id == "v0") throw std::runtime_error("lost 3 lines");
        return {v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
    });
    for (int k = 0; k < 2; ++k) pipeline.submit(view(k));
    EXPECT_FALSE(pipeline.firstPrepared(2));
    EXPECT_EQ(pipeline.wait().error, "view 'v0': lost 3 lines");
}

TEST(ViewPipeline, CancelDropsQueuedViewsAndTheNextCycleSeesOnlyItsOwn)
{
    std::promise<void> release;
    std::shared_future<void> released = release.get_future().share();
    std::atomic<int> calls{0};
    ViewPipeline pipeline(4);
    pipeline.begin([&](const CapturedView& v) {
        ++calls;
        released.wait(); // the first view holds the worker until the test lets go
        return SilhouetteView{v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
    });
    for (int k = 0; k < 4; ++k) pipeline.submit(view(k));
    // cancel() must wait for the view in preparation: let it go from another thread once
    // cancel() has dropped the queue (the worker holds at most view 0, so only cancel() empties it).
    auto releaser = std::async(std::launch::async, [&] {
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        while (pipeline.queued() != 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
        release.set_value();
    });
    pipeline.cancel();
    releaser.get();
    EXPECT_LE(calls.load(), 1) << "queued views were prepared after cancel()";

    std::atomic<int> fresh{0};
    pipeline.begin(countingPreparation(fresh));
    pipeline.submit(view(9));
    auto prepared = pipeline.wait();
    EXPECT_EQ(prepared.ids, std::vector<std::string>{"v9"});
    EXPECT_EQ(fresh.load(), 1);
    EXPECT_LE(calls.load(), 1);
}

// The station's health (docs/health.md, "In the daemon"): each view is
// examined after it is marked prepared, so the verdict's wait() returns while
// the last view's examination still runs; waitExamined() waits for it. The
// examination gets the prepared view's camera and grey levels, in submission order.
TEST(ViewPipeline, EachViewIsExaminedAfterItIsPreparedAndTheVerdictDoesNotWaitForIt)
{
    std::atomic<int> calls{0};
    std::promise<void> lastStarted, releaseLast;
    auto lastReleased = releaseLast.get_future().share();
    std::mutex mutex;
    std::vector<std::size_t> examined;
    std::vector<int> greyWidths;
    ViewPipeline pipeline(2);
    pipeline.begin(
        [&calls](const CapturedView& v) {
            ++calls;
            SilhouetteView s{v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
            s.grey = v.frame;
            return s;
        },
        [&](std::size_t index, const SilhouetteView& v) {
            if (index == 2) {
                lastStarted.set_value();
                lastReleased.wait();
            }
            std::lock_guard lock(mutex);
            examined.push_back(index);
            greyWidths.push_back(v.grey.cols);
        });
    for (int k = 0; k < 3; ++k) pipeline.submit(view(k));
    lastStarted.get_future().wait();
    // The last view's examination holds: the verdict's wait is free all the same.
    auto prepared = pipeline.wait();
    EXPECT_EQ(prepared.views.size(), 3u);
    EXPECT_TRUE(prepared.error.empty());
    {
        std::lock_guard lock(mutex);
        EXPECT_EQ(examined, (std::vector<std::size_t>{0, 1}));
    }
    auto examinedAll = std::async(std::launch::async, [&] { pipeline.waitExamined(); });
    EXPECT_EQ(examinedAll.wait_for(50ms), std::future_status::timeout) << "waitExamined waits for the last view";
    releaseLast.set_value();
    examinedAll.get();
    std::lock_guard lock(mutex);
    EXPECT_EQ(examined, (std::vector<std::size_t>{0, 1, 2}));
    EXPECT_EQ(greyWidths, (std::vector<int>{64, 64, 64}));
    EXPECT_EQ(calls, 3);
}

// An examination that throws is logged and dropped: the cycle's verdict is not its business.
TEST(ViewPipeline, AnExaminationThatThrowsLeavesTheCycleAsItWas)
{
    std::atomic<int> calls{0};
    ViewPipeline pipeline(2);
    pipeline.begin(countingPreparation(calls),
                   [](std::size_t, const SilhouetteView&) { throw hg::ArgumentError("scripted examination failure"); });
    pipeline.submit(view(0));
    pipeline.submit(view(1));
    const auto prepared = pipeline.wait();
    pipeline.waitExamined();
    EXPECT_EQ(prepared.views.size(), 2u);
    EXPECT_TRUE(prepared.error.empty());
}

TEST(ViewPipeline, QueueIsBounded)
{
    std::promise<void> release;
    std::shared_future<void> released = release.get_future().share();
    std::atomic<int> started{0};
    ViewPipeline pipeline(2);
    pipeline.begin([&](const CapturedView& v) {
        ++started;
        released.wait();
        return SilhouetteView{v.camera, hg::inspect::SilhouetteIndex(v.frame.size())};
    });
    pipeline.submit(view(0));
    // Wait (under a deadline) for the worker to hold view 0, so the queue holds exactly what follows.
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (started.load() == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
    ASSERT_EQ(started.load(), 1);
    pipeline.submit(view(1));
    pipeline.submit(view(2)); // the queue is full now (capacity 2)
    EXPECT_EQ(pipeline.queued(), 2u);
    std::atomic<bool> fourthIn{false};
    auto fourth = std::async(std::launch::async, [&] {
        pipeline.submit(view(3));
        fourthIn = true;
    });
    // While the worker holds view 0 nothing can make room: the fourth submit() stays blocked
    // however long it is given (a bounded look, not a synchronisation).
    EXPECT_EQ(fourth.wait_for(60ms), std::future_status::timeout) << "submit() did not wait for room";
    EXPECT_FALSE(fourthIn.load());
    EXPECT_EQ(pipeline.queued(), 2u);
    release.set_value();
    fourth.get();
    EXPECT_TRUE(fourthIn.load());
    auto prepared = pipeline.wait();
    EXPECT_EQ(prepared.ids, (std::vector<std::string>{"v0", "v1", "v2", "v3"}));
}

// The daemon's engine inspector on the simulated line (config/sim): the part
// program's landmarks and the defect variants built to move exactly two of them.
class EnginePipeline : public ::testing::Test {
  protected:
    static void SetUpTestSuite()
    {
        config_ = new hg::station::DaemonConfig(
            hg::station::loadDaemonConfig(hgtest::sourceDir() / "config" / "sim" / "hullgauged.yaml"));
    }
    static void TearDownTestSuite()
    {
        delete config_;
        config_ = nullptr;
    }

    // The frames the simulated camera would grab of `part` (config/sim/station.yaml's grey levels).
    static std::vector<cv::Mat> frames(const std::string& part)
    {
        std::filesystem::path mesh;
        for (const auto& [name, file] : config_->simulatedParts)
            if (name == part) mesh = file;
        hg::sim::SilhouetteRenderer renderer({hg::model::loadMesh(mesh)});
        hg::sim::RenderOptions options;
        options.backgroundLevel = 0.92;
        options.objectLevel = 0.04;
        options.blurSigmaPx = 0.6;
        options.noiseSigma = 1.5;
        options.seed = 7;
        std::vector<cv::Mat> out;
        for (const auto& pose : config_->programs.at(1).views)
            out.push_back(renderer.render(config_->station.cameraAt(pose), options));
        return out;
    }

    /// Each image at its origin on the sensor (whole frames: (0, 0)).
    static hg::daemon::InspectionOutcome inspect(hg::daemon::Inspector& inspector, const std::vector<cv::Mat>& images,
                                                 const std::vector<cv::Point>& origins = {})
    {
        const hg::Status begun = inspector.begin(config_->programs.at(1));
        EXPECT_TRUE(begun.ok()) << begun.message();
        const auto& poses = config_->programs.at(1).views;
        for (std::size_t k = 0; k < images.size(); ++k)
            inspector.addView(k, poses[k], images[k], k < origins.size() ? origins[k] : cv::Point());
        return inspector.finish();
    }

    static std::set<std::string> failing(const hg::daemon::InspectionOutcome& outcome)
    {
        std::set<std::string> ids;
        for (const auto& l : outcome.landmarks)
            if (hg::enumName(l.status) != "ok") ids.insert(l.id);
        return ids;
    }

    static hg::station::DaemonConfig* config_;
};

hg::station::DaemonConfig* EnginePipeline::config_ = nullptr;

TEST_F(EnginePipeline, VerdictsOfNominalAndDefectiveParts)
{
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    auto nominal = inspect(*inspector, frames("nominal"));
    ASSERT_TRUE(nominal.ok) << nominal.error;
    EXPECT_TRUE(nominal.pass);
    EXPECT_EQ(nominal.landmarks.size(), 10u);
    EXPECT_TRUE(failing(nominal).empty());
    EXPECT_TRUE(nominal.evidence) << "a passed part can be archived too (results.archive_all)";
    EXPECT_GT(nominal.prepareTime.count(), 0.0);
    EXPECT_GT(nominal.traversalTime.count(), 0.0);

    // Same inspector, next cycle: the map is reused, the worker starts clean.
    auto low = inspect(*inspector, frames("face-low"));
    ASSERT_TRUE(low.ok) << low.error;
    EXPECT_FALSE(low.pass);
    EXPECT_EQ(failing(low), (std::set<std::string>{"step-top", "step-top-back"}));
    // The failed part's images are built after the verdict, from the frames the cycle kept.
    ASSERT_TRUE(low.evidence);
    auto views = low.evidence();
    ASSERT_EQ(views.size(), config_->programs.at(1).views.size()) << "a failed part keeps every frame";
    for (const auto& v : views) {
        EXPECT_EQ(v.image.size(), cv::Size(1280, 960));
        ASSERT_EQ(v.silhouette.size(), v.image.size());
        // The stepped block fills part of the frame, never all of it.
        const double partShare = cv::countNonZero(v.silhouette) / static_cast<double>(v.image.total());
        EXPECT_GT(partShare, 0.01);
        EXPECT_LT(partShare, 0.9);
    }
    std::set<std::string> drawnFailing;
    for (const auto& mark : views[0].landmarks)
        if (hg::enumName(mark.status) != "ok") drawnFailing.insert(mark.id);
    EXPECT_EQ(drawnFailing, (std::set<std::string>{"step-top", "step-top-back"}));
}

TEST_F(EnginePipeline, AFrameLeavingTheSensorIsAnOutcomeErrorNamingTheView)
{
    // A 640x480 frame is a region of the 1280x960 sensor (docs/inspection.md,
    // "Frames that are regions"); placed at (800, 600) it leaves the sensor.
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    auto images = frames("nominal");
    images[1] = images[1](cv::Rect(640, 480, 640, 480)).clone();
    auto outcome = inspect(*inspector, images, {{0, 0}, {800, 600}});
    EXPECT_FALSE(outcome.ok);
    EXPECT_NE(outcome.error.find("view 'v1'"), std::string::npos) << outcome.error;
    EXPECT_NE(outcome.error.find("640x480 at sensor (800, 600) does not lie on the camera's 1280x960 sensor"),
              std::string::npos)
        << outcome.error;

    // An aborted cycle leaves nothing behind for the next one.
    ASSERT_TRUE(inspector->begin(config_->programs.at(1)).ok());
    inspector->addView(0, config_->programs.at(1).views[0], images[0], {});
    inspector->cancel();
    auto again = inspect(*inspector, frames("nominal"));
    ASSERT_TRUE(again.ok) << again.error;
    EXPECT_TRUE(again.pass);
}

} // namespace
