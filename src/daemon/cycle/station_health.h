// The station's health in the daemon (docs/health.md, "In the daemon"): the
// figures of a cycle in words and as JSON (the maintenance status, the MQTT
// message, the HMI), the journal's lines when a figure crosses its limit and
// when it is back within, and the maintenance action that takes the flat-field
// reference — frames of the empty fixture, grabbed by the cycle runner between
// cycles with production paused as for a calibration (docs/daemon.md,
// "Calibration while production is paused"), built into the reference
// (vision::buildFlatField) and written durably where `health.reference` says.
#pragma once

#include "cycle/devices.h"
#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/station/result_record.h"
#include "hullgauge/vision/health.h"
#include "maintenance_job.h"

#include <array>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

namespace hg::daemon {

/// How one figure is judged and named: its value in the figures, its limit and
/// on which side of it the figure warns (docs/health.md, "Limits").
struct HealthFigureRule {
    vision::HealthFigure figure;
    const char* key;                      ///< its name in JSON and in the store's table
    double vision::HealthFigures::*value; ///< the figure
    double vision::HealthLimits::*limit;  ///< its limit
    bool minimum;                         ///< true: a value below the limit warns; false: above it
    bool magnitude;                       ///< true: |value| above the limit warns, either sign
    const char* what;                     ///< "backlight", "edge width"
    const char* unit;                     ///< the words after the value: "of the reference", "px"
    int digits;                           ///< decimals shown
};
/// One rule per figure, in the enum's order (the PLC's bits, docs/plc.md HEALTH_WARNINGS).
const std::array<HealthFigureRule, 8>& healthFigureRules();

/// The figure in words with its state: "backlight 0.93 of the reference —
/// within limit 0.80", "dust 7 specks beyond the reference's — beyond limit 5",
/// "backlight not measured". The journal and the HMI say it so.
std::string describeFigure(const HealthFigureRule& rule, const vision::HealthFigures& figures,
                           const vision::HealthLimits& limits);

/// The figures as JSON, by the store's column names (null where not measured), with `views` and `probes`.
nlohmann::json healthFiguresJson(const vision::HealthFigures& figures);
/// The warnings' names ("dust", "focus"), in the enum's order.
nlohmann::json healthWarningsJson(const std::vector<vision::HealthFigure>& warnings);
/// Per figure its value, limit, side (`minimum`), `within` (null when not measured) and its sentence.
nlohmann::json healthStatesJson(const vision::HealthFigures& figures, const vision::HealthLimits& limits);
/// The reference as the status shows it: `taken_unix_ms`, `time`, `file`, `sensor`, `level_mean`,
/// `noise`, `dust_specks`; null without one.
nlohmann::json referenceJson(const std::optional<vision::FlatField>& reference, const std::filesystem::path& file);

/// The journal's health lines (category `health`): a warning when a figure
/// crosses its limit, an info line when it is back within. Runner thread only.
class HealthJournal {
  public:
    void report(const station::HealthRecord& health, const vision::HealthLimits& limits);

  private:
    std::set<vision::HealthFigure> beyond_;
};

struct FlatFieldJob {
    int frames = 8; ///< frames averaged (1..64)
};

/// The maintenance action `flat-field` (docs/health.md, "In the daemon").
class FlatFieldAction {
  public:
    /// Queues `job`; a failure saying why when one is queued or running or the station is not ready.
    Status request(FlatFieldJob job, station::SequencerState state);
    bool queued() const { return queue_.queued(); }
    std::optional<FlatFieldJob> take() { return queue_.take(); }
    void requeue(FlatFieldJob job) { queue_.requeue(std::move(job)); }
    void refuse(const std::string& why) { queue_.refuse(why); }

    /// What the grab does with the simulated line's part: `show` names the part
    /// to show while grabbing ("none", the empty fixture) and returns false when
    /// the simulation cannot; `restore` puts the part back. Empty on real
    /// hardware, where the operator empties the fixture.
    struct Simulation {
        std::function<bool()> showEmpty;
        std::function<void()> restore;
    };

    /// What run() came to: the reference taken and written, or why not.
    struct Taken {
        std::optional<vision::FlatField> reference;
        std::filesystem::path file;
        std::string error;
        bool deviceFailed = false; ///< the camera failed: the station is recovered as after a cycle fault
    };

    /// Grabs `job.frames` whole frames where the fixture stands, builds the
    /// reference and writes it durably to `cfg.health.reference`; or why not: a
    /// device failed, the fixture is not empty (the reason buildFlatField
    /// gives), the file cannot be written. `cancelled` is asked between the
    /// frames (an abort). The status says `running` until finish().
    Taken run(const FlatFieldJob& job, StationDevices& devices, const station::DaemonConfig& cfg, Clock& clock,
              const Simulation& simulation, const std::function<bool()>& cancelled);
    /// Ends the job's status (done or failed) once production has resumed and
    /// the reference, if taken, is in use: whoever sees `done` finds the
    /// station ready and judging against it.
    void finish(const Taken& taken);

    /// State (queued, running, done, failed), `frames`, `error`, and once taken `file` and the
    /// reference's figures (referenceJson).
    nlohmann::json status() const { return queue_.status(); }

  private:
    MaintenanceJob<FlatFieldJob> queue_{"a flat-field reference"};
};

} // namespace hg::daemon
