// hullgauged with fake devices and a fake inspection, for the daemon's
// integration tests: the real main loop, PLC server, sequencer, result store,
// sd_notify and maintenance socket, with hardware whose behaviour the test
// sets through the environment:
//   HG_FAKE_MOVE_MS        time a move takes (default 2)
//   HG_FAKE_MOVE_HOLD      a path: every move waits until that file exists
//                          (the test holds the station busy as long as it needs)
//   HG_FAKE_MOVE_FAIL      "timeout" | "fault" : every move fails so
//   HG_FAKE_GRAB_FAIL      "timeout" | "bad"   : every grab fails so
//   HG_FAKE_START_FAIL     "1": the devices never start
//   HG_FAKE_CHECK_HOLD     a path: while that file exists, every program check
//                          (start, --check, reload) waits (a reload the test holds)
//   HG_FAKE_RELEASE        a version number: the program is released as that
//                          version (verification digest 64 × 'a'); else a draft
// The fake camera has two simulated parts (`hullgauge ctl sim-part`):
// "nominal" grabs bright frames, "dented" dark ones, and optics that count
// every new part as a cycle of their aging, a step every 2 (`ctl sim-age`);
// the fake inspection
// reports 20 landmarks and fails landmarks 3 and 17 (out_of_tolerance) when a
// frame is dark.
#include "daemon.h"

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <thread>

namespace {

using namespace hg::daemon;
using hg::Status;
using hg::StatusCode;
using hg::inspect::LandmarkStatus;

std::string env(const char* name)
{
    const char* v = std::getenv(name);
    return v ? v : "";
}

class FakeDevices : public StationDevices, public SimulationControl {
  public:
    Status start() override
    {
        if (env("HG_FAKE_START_FAIL") == "1") return Status::failure(StatusCode::Error, "fake: devices do not start");
        return Status::success();
    }
    void shutdown() override {}
    Status moveTo(const hg::geometry::FixturePose&, std::chrono::milliseconds timeout, bool) override
    {
        auto mode = env("HG_FAKE_MOVE_FAIL");
        if (mode == "timeout") {
            std::this_thread::sleep_for(timeout);
            return Status::failure(StatusCode::Timeout, "fake: not in position");
        }
        if (mode == "fault") return Status::failure(StatusCode::Fault, "fake: drive fault 7");
        if (auto hold = env("HG_FAKE_MOVE_HOLD"); !hold.empty())
            while (!std::filesystem::exists(hold)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        auto ms = env("HG_FAKE_MOVE_MS");
        std::this_thread::sleep_for(std::chrono::milliseconds(ms.empty() ? 2 : std::stoi(ms)));
        return Status::success();
    }
    void stopMotion() override {}
    Status setRegion(const cv::Rect&) override { return Status::success(); }
    Status grab(std::chrono::milliseconds timeout, GrabbedFrame& frame) override
    {
        auto mode = env("HG_FAKE_GRAB_FAIL");
        if (mode == "timeout") {
            std::this_thread::sleep_for(timeout);
            return Status::failure(StatusCode::Timeout, "fake: no frame");
        }
        if (mode == "bad") return Status::failure(StatusCode::BadFrame, "fake: 12 packets missing");
        frame.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(dented_ ? 100 : 200));
        return Status::success();
    }
    Status recover() override { return start(); }
    void showLamps(LampPattern) override {}
    std::vector<std::string> parts() const override { return {"nominal", "dented"}; }
    std::string part() const override { return dented_ ? "dented" : "nominal"; }
    bool selectPart(const std::string& name) override
    {
        if (name != "nominal" && name != "dented") return false;
        dented_ = name == "dented";
        return true;
    }

    void newPart() override { ++cycles_; }
    nlohmann::json optics() const override
    {
        const int cycles = cycles_;
        return {{"cycles", cycles},         {"aging_steps", cycles / 2}, {"background_level", 0.85},
                {"vignetting", 0.0},        {"blur_sigma_px", 0.5},      {"halo_px", 0.0},
                {"dust_specks", cycles / 2}};
    }
    void resetAging() override { cycles_ = 0; }

  private:
    std::atomic<bool> dented_{false};
    std::atomic<int> cycles_{0};
};

/// The release HG_FAKE_RELEASE names; none (a draft) without it.
std::optional<hg::station::ProgramRelease> fakeRelease()
{
    const auto version = env("HG_FAKE_RELEASE");
    if (version.empty()) return std::nullopt;
    return hg::station::ProgramRelease{std::stoi(version), std::string(64, 'a')};
}

class FakeInspector : public Inspector {
  public:
    hg::Status begin(const hg::station::PartProgramRef&) override
    {
        frames_.clear();
        return hg::Status::success();
    }
    std::optional<LoadedProgramInfo> loaded(std::uint16_t number) const override
    {
        return LoadedProgramInfo{number, "fake-block", fakeRelease()};
    }
    void addView(std::size_t, const hg::geometry::FixturePose&, cv::Mat image, cv::Point) override
    {
        frames_.push_back(image);
    }
    InspectionOutcome finish() override
    {
        InspectionOutcome out;
        out.ok = !frames_.empty();
        out.part = "fake-block";
        out.release = fakeRelease();
        bool dark = false;
        for (const auto& f : frames_) dark = dark || cv::mean(f)[0] < 150;
        out.pass = !dark;
        for (int i = 0; i < 20; ++i) {
            bool bad = dark && (i == 3 || i == 17);
            out.landmarks.push_back({"L" + std::to_string(i), bad ? LandmarkStatus::OutOfTolerance : LandmarkStatus::Ok,
                                     bad ? 0.5 : 0.0, bad ? 0.625 : 0.125, bad ? 0.5625 : 0.0625, 0.2});
        }
        if (dark)
            for (const auto& f : frames_) {
                ViewEvidence v{f, cv::Mat(f.size(), CV_8UC1, cv::Scalar(0)), {}};
                v.silhouette(cv::Rect(16, 12, 32, 24)).setTo(255);
                v.landmarks.push_back({cv::Point2d(16, 12), "L3", LandmarkStatus::OutOfTolerance});
                out.views.push_back(v);
            }
        return out;
    }
    void cancel() override { frames_.clear(); }

  private:
    std::vector<cv::Mat> frames_;
};

} // namespace

int main(int argc, char** argv)
{
    return runDaemon(
        argc, argv,
        [](const hg::station::DaemonConfig&, hg::Clock&) {
            auto devices = std::make_unique<FakeDevices>();
            SimulationControl* simulation = devices.get();
            return StationHardware{std::move(devices), simulation};
        },
        [](const hg::station::DaemonConfig&) { return std::make_unique<FakeInspector>(); },
        [](const hg::station::PartProgramRef&, const hg::geometry::Station&) {
            if (auto hold = env("HG_FAKE_CHECK_HOLD"); !hold.empty())
                while (std::filesystem::exists(hold)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        });
}
