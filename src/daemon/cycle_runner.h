// Runs inspection cycles: takes accepted triggers from the register map,
// drives the CaptureSequencer's actions against the devices and the
// inspection pipeline, commits each record to the result store and only then
// publishes it to the PLC, and sets the lamps. One thread of its own.
#pragma once

#include "daemon_config.h"
#include "devices.h"
#include "hullgauge/calib/fixture_sequence.h"
#include "hullgauge/station/plc_registers.h"
#include "hullgauge/station/sequencer.h"
#include "image_archive.h"
#include "image_writer.h"
#include "inspector.h"
#include "result_store.h"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <vector>

namespace hg::daemon {

/// A live fixture calibration requested on the maintenance socket: the poses
/// to visit, the target the fixture carries, and the station file to write
/// (the old one is kept as a backup; the daemon uses it after a reload).
struct CalibrationJob {
    std::vector<geometry::FixturePose> poses;
    calib::TargetSpec target;
    std::filesystem::path out;
};

class CycleRunner {
  public:
    CycleRunner(station::PlcRegisters& registers, StationDevices& devices, Inspector& inspector, ResultStore& store,
                std::shared_ptr<const station::DaemonConfig> config);
    ~CycleRunner();
    CycleRunner(const CycleRunner&) = delete;
    CycleRunner& operator=(const CycleRunner&) = delete;

    /// Starts the thread: it starts the devices, then serves triggers.
    /// `onDevicesActive` is called once, from that thread, when the devices
    /// first became active (the daemon sends READY=1 there).
    void start(std::function<void()> onDevicesActive);
    /// SIGTERM: a running cycle gets `shutdown_grace_s` to finish, is then
    /// aborted and recorded; the devices are shut down; the thread ends.
    void stop();

    /// A new configuration for the next cycle (SIGHUP); the running cycle keeps its own.
    void setConfig(std::shared_ptr<const station::DaemonConfig> config);
    /// Abort the running cycle or calibration (maintenance socket; the PLC uses COMMAND).
    void abort() { abortRequested_ = true; }

    /// Queues a calibration; it runs between cycles, on the runner thread, when
    /// the station is ready (production is paused meanwhile: PLC STATUS 5,
    /// triggers refused as not ready). False with `why` when one is queued or
    /// running, or the station is faulted or starting.
    bool requestCalibration(CalibrationJob job, std::string& why);
    /// The last calibration: state (queued, running, done, failed), progress
    /// lines, the report or the error, the file written and its backup.
    nlohmann::json calibration() const;

    station::SequencerState state() const;
    /// True while the runner thread turns and no cycle runs longer than `watchdog.max_cycle_s`.
    bool healthy() const;
    /// State, current cycle and counters for the maintenance socket.
    nlohmann::json describe() const;

  private:
    void run();
    void runCycle(const station::TriggerRequest& trigger);
    void recover();
    void runCalibration(CalibrationJob job);
    bool interrupted();
    void setState(std::function<station::SequencerAction()> step, station::SequencerAction& action);

    station::PlcRegisters& registers_;
    StationDevices& devices_;
    Inspector& inspector_;
    ResultStore& store_;

    mutable std::mutex mutex_; // guards config_, sequencer_ reads from other threads, counters
    std::shared_ptr<const station::DaemonConfig> config_;
    station::CaptureSequencer sequencer_;
    std::uint64_t cycles_ = 0;
    std::uint64_t faults_ = 0;
    nlohmann::json lastCycle_ = nullptr;
    std::optional<CalibrationJob> calibrationJob_;
    nlohmann::json calibration_ = nullptr;

    std::thread thread_;
    std::function<void()> onDevicesActive_;
    std::atomic<bool> stopRequested_{false};
    std::atomic<std::int64_t> stopRequestedNs_{0};
    std::atomic<bool> abortRequested_{false};
    std::atomic<std::int64_t> lastLoopNs_{0};
    std::atomic<std::int64_t> cycleStartNs_{0};      ///< 0 when idle
    std::atomic<std::int64_t> calibrationStepNs_{0}; ///< start of the calibration's current step, 0 when none runs
    // Declared last, destroyed first: the images still queued are written while the members
    // their jobs touch (mutex_, lastCycle_) are alive.
    ImageWriter images_;
};

} // namespace hg::daemon
