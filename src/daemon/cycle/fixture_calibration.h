// The live fixture calibration requested on the maintenance socket
// (docs/daemon.md, "Calibration while production is paused"): the queued job,
// its progress for `ctl calibration`, and the sequence itself
// (calib::runFixtureSequence) through the station's devices. The cycle runner
// decides when it runs (between cycles) and moves the sequencer and the PLC's
// STATUS around it.
#pragma once

#include "cycle/devices.h"
#include "daemon_config.h"
#include "hullgauge/calib/fixture_sequence.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/station/sequencer.h"
#include "maintenance_job.h"

#include <atomic>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::daemon {

/// The poses to visit, the target the fixture carries, and the station file
/// to write (the old one is kept as a backup; the daemon uses it after a reload).
struct CalibrationJob {
    std::vector<geometry::FixturePose> poses;
    calib::TargetSpec target;
    std::filesystem::path out;
};

class FixtureCalibration {
  public:
    /// Queues `job`. A failure saying why when one is queued or running, or
    /// the station (in `state`) is faulted, starting or in maintenance.
    Status request(CalibrationJob job, station::SequencerState state);
    bool queued() const { return queue_.queued(); }
    /// Takes the queued job (none when none is queued).
    std::optional<CalibrationJob> take() { return queue_.take(); }
    /// Puts a taken job back (a trigger was accepted first: its cycle runs first).
    void requeue(CalibrationJob job) { queue_.requeue(std::move(job)); }
    /// Ends a taken job as failed before it started.
    void refuse(const std::string& why) { queue_.refuse(why); }

    /// Runs `job` with `cfg`'s timeouts and settle time: move, settle, grab
    /// per pose, then solve and write the station file. True when it was written.
    bool run(const CalibrationJob& job, StationDevices& devices, const station::DaemonConfig& cfg, Clock& clock,
             const std::function<bool()>& cancelled);

    /// State (queued, running, done, failed), progress lines, the report or
    /// the error, the file written and its backup.
    nlohmann::json status() const { return queue_.status(); }
    /// When the running step (move, settle, grab) began on the runner's clock, 0 when none runs.
    std::int64_t stepStartNs() const { return stepNs_.load(); }

  private:
    MaintenanceJob<CalibrationJob> queue_{"a calibration"};
    std::atomic<std::int64_t> stepNs_{0};
};

} // namespace hg::daemon
