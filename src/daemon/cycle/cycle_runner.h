// Runs inspection cycles: takes accepted triggers from the register map,
// performs the CaptureSequencer's actions against the devices and the
// inspection pipeline, commits each record to the result store and only then
// publishes it to the PLC, and sets the lamps (the rules of
// hullgauge/station/cycle_rules.h). One thread of its own.
//
// The PLC's commands (docs/plc.md, COMMAND) are taken in one place,
// takeCommands(), before every step of a cycle and every turn between cycles:
// an abort ends the running cycle; a fault reset written during a cycle is
// kept and applied once the cycle has ended (when the station is then in
// fault). Recovery runs when the sequencer's Recover action says, on the
// runner's clock (injected; the tests move it by hand).
#pragma once

#include "cycle/camera_snapshot.h"
#include "cycle/devices.h"
#include "cycle/fixture_calibration.h"
#include "cycle/image_archive.h"
#include "cycle/image_writer.h"
#include "cycle/inspector.h"
#include "cycle/part_temperature.h"
#include "cycle/station_health.h"
#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/worker.h"
#include "hullgauge/station/mastering_due.h"
#include "hullgauge/station/sequencer.h"
#include "hullgauge/store/result_store.h"
#include "plant/plc_registers.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stop_token>

namespace hg::daemon {

class CycleRunner {
  public:
    CycleRunner(PlcRegisters& registers, StationDevices& devices, Inspector& inspector, store::ResultStore& store,
                std::shared_ptr<const station::DaemonConfig> config, Clock& clock = Clock::steady());
    ~CycleRunner();
    CycleRunner(const CycleRunner&) = delete;
    CycleRunner& operator=(const CycleRunner&) = delete;

    /// The simulated line's control (before start()): a new part is seated in
    /// the nest at the start of every cycle, and the record keeps the part
    /// shown and its true seat (docs/daemon.md, "Seating"). Null on real hardware.
    void setSimulation(SimulationControl* simulation) { simulation_ = simulation; }

    /// Starts the thread: it starts the devices, then serves triggers.
    /// `onDevicesActive` is called once, from that thread, when the devices
    /// first became active (the daemon sends READY=1 there).
    void start(std::function<void()> onDevicesActive);
    /// SIGTERM: a running cycle gets `shutdown_grace_s` to finish, is then
    /// aborted and recorded; the devices are shut down; the thread ends.
    void stop();

    /// A new configuration for the next cycle (SIGHUP); the running cycle keeps its own.
    void setConfig(std::shared_ptr<const station::DaemonConfig> config);
    /// The configuration the next cycle runs with (from any thread): the mastering run waits here for its
    /// set to be in force (docs/mastering.md, "The mastering run").
    std::shared_ptr<const station::DaemonConfig> config() const
    {
        std::lock_guard lock(mutex_);
        return config_;
    }
    /// Abort the running cycle or calibration (maintenance socket; the PLC uses
    /// COMMAND); false, and nothing latched, when none runs (docs/plc.md).
    bool abort();

    /// Queues a calibration; it runs between cycles, on the runner thread, when
    /// the station is ready (production is paused meanwhile: PLC STATUS 5,
    /// triggers refused as not ready). A failure saying why when one is queued
    /// or running, or the station is faulted or starting.
    Status requestCalibration(CalibrationJob job);
    /// The last calibration (FixtureCalibration::status).
    nlohmann::json calibration() const { return calibration_.status(); }
    /// Queues a camera snapshot (docs/hmi.md, "Maintenance"): like a
    /// calibration, between cycles with production paused for the grab.
    Status requestSnapshot(SnapshotJob job) { return snapshot_.request(std::move(job), state()); }
    /// The last snapshot: its status and its overlay (CameraSnapshot).
    const CameraSnapshot& snapshot() const { return snapshot_; }
    /// Queues the flat-field reference (docs/health.md, "In the daemon"): like
    /// a calibration, between cycles with production paused for the grabs; the
    /// station's health is judged against it from the next cycle.
    Status requestFlatField(FlatFieldJob job) { return flatField_.request(job, state()); }
    /// The last flat-field action's status (FlatFieldAction::status).
    nlohmann::json flatField() const { return flatField_.status(); }

    /// The station's health for the maintenance status (docs/health.md, "In the
    /// daemon"): `enabled`, the last examined cycle's `figures`, `warnings`,
    /// `states` (each figure against its limit, in words) and `time`, the
    /// `limits`, the `reference` in use (null without one), its file, and the
    /// last `flat_field` action.
    nlohmann::json health() const;
    /// True while the last examined cycle showed a figure beyond its limit: the
    /// lamps ask for attention (docs/lamps.md, docs/health.md).
    bool healthAttention() const { return healthAttention_.load(); }
    /// Called from the runner's thread with each examined cycle's health once
    /// its result is published (the plant link's topic `health`, docs/mqtt.md).
    /// Before start().
    void setHealthSink(std::function<void(const nlohmann::json&)> sink) { healthSink_ = std::move(sink); }

    station::SequencerState state() const;
    /// True while the runner thread turns and no cycle runs longer than `watchdog.max_cycle_s`.
    bool healthy() const;
    /// State, current cycle and counters for the maintenance socket.
    nlohmann::json describe() const;
    /// The part program the inspection last loaded for a changeover or a cycle:
    /// number, part, version, verification_sha256 (null for a draft) and material ('' when the
    /// program names none); null
    /// before the first (docs/daemon.md, "Maintenance socket").
    nlohmann::json program() const;

  private:
    struct Cycle;

    void run(std::stop_token stop);
    void startDevices();
    void serveBetweenCycles();
    void takeCommands();
    station::SequencerAction feed(station::SequencerEvent event);
    station::SequencerAction transition(const std::function<station::SequencerAction()>& step);
    void schedule(const station::SequencerAction& action);
    void showState();
    void showLamps(LampPattern pattern);
    void refreshLamps();
    void recover();
    void prepareProgram(std::uint16_t number);
    void noteLoaded(const station::PartProgramRef& ref);
    void masteringConfigured(const station::DaemonConfig& cfg);
    void masteringStarted(const station::PartProgramRef& ref);
    void masteringLoaded(const station::PartProgramRef& ref, std::optional<int> version);
    void masteringJudged(const station::InspectionRecord& record);
    void applyCorrectionSet(std::uint16_t number, const station::PartProgramRef& ref);
    station::MasteringHistory judgedWith(const station::PartProgramRef& ref) const;
    void signalMastering();
    nlohmann::json masteringJson() const;
    void runCalibration(CalibrationJob job);
    void runSnapshot(SnapshotJob job);
    void runFlatField(FlatFieldJob job);
    FlatFieldAction::Simulation emptyFixture();
    void healthConfigured(const station::DaemonConfig& cfg);
    void watchHealth();
    void reportHealth(const Cycle& cycle);
    bool runMaintenance(const std::function<bool(const station::DaemonConfig&)>& work);

    void runCycle(const station::TriggerRequest& trigger);
    station::SequencerAction beginCycle(Cycle& cycle);
    std::optional<station::SequencerAction> interruption(Cycle& cycle);
    station::SequencerAction perform(Cycle& cycle, const station::SequencerAction& action);
    station::SequencerAction move(Cycle& cycle, const station::SequencerAction& action);
    void correctPoses(Cycle& cycle);
    station::SequencerAction settle(Cycle& cycle, const station::SequencerAction& action);
    void askRegion(Cycle& cycle, std::size_t view);
    station::SequencerAction grab(Cycle& cycle, const station::SequencerAction& action);
    station::SequencerAction finishInspection(Cycle& cycle);
    void endCycle(Cycle& cycle, bool stopMotion);
    void recordOutcome(Cycle& cycle);
    nlohmann::json poseCorrectionJson(const Cycle& cycle) const;
    void commitAndPublish(Cycle& cycle);
    void report(Cycle& cycle);
    void archivePart(Cycle& cycle);
    bool archiveHasRoom(Cycle& cycle);
    ImageArchive archiveOf(const Cycle& cycle) const;
    void commitRecord(Cycle& cycle);

    PlcRegisters& registers_;
    StationDevices& devices_;
    SimulationControl* simulation_ = nullptr;
    Inspector& inspector_;
    store::ResultStore& store_;
    Clock& clock_;
    FixtureCalibration calibration_;
    CameraSnapshot snapshot_;
    FlatFieldAction flatField_;

    mutable std::mutex mutex_; // guards config_, sequencer_ reads from other threads, counters, lastCycle_, program_,
                               // healthWatch_ and lastHealth_
    std::shared_ptr<const station::DaemonConfig> config_;
    station::CaptureSequencer sequencer_;
    std::uint64_t cycles_ = 0;
    std::uint64_t faults_ = 0;
    nlohmann::json lastCycle_ = nullptr;
    nlohmann::json program_ = nullptr; ///< program()
    /// Re-mastering due per program once loaded (docs/mastering.md, "Re-mastering due"):
    /// the rules, the set and program file they were last told of, and what was last signalled.
    struct ProgramMastering {
        station::MasteringDue due;
        std::optional<int> version;
        std::string partSha256;
        std::string setSha256;
        station::MasterDueState shown{};
    };
    std::optional<station::MasteringDuePolicy> duePolicy_;
    std::string calibrationIdentity_; ///< the station's calibration as the configuration names it
    std::map<std::uint16_t, ProgramMastering> mastering_;
    /// The station's health as it is watched (docs/health.md, "In the daemon"): from
    /// the configuration, or the reference the flat-field action just took; the
    /// monitor is replaced before the next cycle when `changed`.
    struct HealthWatch {
        bool configured = false;
        bool enabled = false;
        std::optional<vision::FlatField> reference;
        std::filesystem::path file;
        std::string sha256; ///< of the file the reference came from ('' none)
        bool changed = true;
    } healthWatch_;
    /// The last examined cycle's health, its start time and the limits it was judged by.
    std::optional<station::HealthRecord> lastHealth_;
    std::int64_t lastHealthUnixMs_ = 0;
    vision::HealthLimits lastHealthLimits_;
    /// Written by the last failed part's image job when it is done (ms; < 0 until then).
    std::shared_ptr<std::atomic<double>> lastImagesMs_;

    // Runner thread only.
    bool resetRequested_ = false;                ///< COMMAND = 2 not applied yet
    std::optional<Clock::time_point> recoverAt_; ///< when the sequencer's Recover is due
    bool archiveHadRoom_ = true;                 ///< the last part found min_free_mb free (logged on change)
    HealthJournal healthJournal_;
    std::function<void(const nlohmann::json&)> healthSink_;
    PartTemperature temperature_{clock_}; ///< the part's temperature at each trigger
    /// The lamps between cycles (docs/lamps.md): the verdict and fault of the part in the
    /// nest (until a production trigger is refused), the pattern last commanded, and
    /// REJECTED_TRIGGERS as last looked at.
    station::Verdict shownVerdict_ = station::Verdict::Error;
    station::FaultCode shownFault_ = station::FaultCode::None;
    std::optional<LampPattern> lamps_;
    std::uint16_t refusalsSeen_ = 0;

    std::stop_token stop_; ///< the worker's (runner thread only): SIGTERM's stop()
    std::function<void()> onDevicesActive_;
    std::atomic<std::int64_t> stopRequestedNs_{0};
    std::atomic<bool> abortRequested_{false};
    std::atomic<std::int64_t> lastLoopNs_{0};
    std::atomic<std::int64_t> cycleStartNs_{0}; ///< 0 when idle
    std::atomic<bool> healthAttention_{false};
    ImageWriter images_;
    Worker worker_; ///< run(); last, so it ends before what it uses
};

} // namespace hg::daemon
