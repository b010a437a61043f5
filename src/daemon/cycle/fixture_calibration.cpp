#include "cycle/fixture_calibration.h"

#include "hullgauge/calib/station_file.h"
#include "hullgauge/common/log.h"

namespace hg::daemon {

Status FixtureCalibration::request(CalibrationJob job, station::SequencerState state)
{
    nlohmann::json status{
        {"poses", job.poses.size()}, {"out", job.out.string()}, {"progress", nlohmann::json::array()}};
    return queue_.request(std::move(job), state, std::move(status));
}

// The station file is written with a backup only when the axes were solved;
// the running configuration is not touched (a reload takes the new calibration).
bool FixtureCalibration::run(const CalibrationJob& job, StationDevices& devices, const station::DaemonConfig& cfg,
                             Clock& clock, const std::function<bool()>& cancelled)
{
    auto log = hg::log::category("calib");
    queue_.update({{"state", "running"}});
    log->info("calibration: {} poses, target {}, writing {}", job.poses.size(), job.target, job.out.string());
    calib::FixtureSequenceIo io;
    io.moveTo = [&](const geometry::FixturePose& pose) {
        stepNs_ = clock.nowNs();
        auto r = devices.moveTo(pose, cfg.sequencer.moveTimeout, false);
        if (!r.ok()) return r;
        clock.sleepUntil(clock.now() + cfg.sequencer.settle, cancelled);
        return Status::success();
    };
    // The target is found on whole frames: the last cycle left the camera on its last view's region.
    if (auto r = devices.setRegion({}); !r.ok()) log->warn("calibration: whole frames asked: {}", r.message());
    io.grab = [&](cv::Mat& image) {
        stepNs_ = clock.nowNs();
        GrabbedFrame frame;
        auto r = devices.grab(cfg.sequencer.grabTimeout, frame);
        image = frame.image;
        return r;
    };
    io.progress = [&](std::size_t, std::size_t, const std::string& line) {
        log->info("calibration {}", line);
        queue_.append("progress", line);
    };
    io.cancelled = cancelled;
    bool written = false;
    try {
        auto result =
            calib::runFixtureSequence(job.poses, job.target, cfg.station.camera, cfg.station.fixture.type, io, "poses");
        calib::StationFileUpdate file(job.out);
        file.setFixtureAxes(result.axes);
        const auto backup = file.commit();
        queue_.update({{"state", "done"},
                       {"report", calib::formatFixtureReport(result.axes)},
                       {"views_used", result.views.size()},
                       {"backup", backup ? backup->string() : std::string()}});
        log->info("calibration written to {}", job.out.string());
        written = true;
    } catch (const std::exception& e) {
        log->error("calibration failed: {}", e.what());
        queue_.update({{"state", "failed"}, {"error", e.what()}});
    }
    stepNs_ = 0;
    return written;
}

} // namespace hg::daemon
