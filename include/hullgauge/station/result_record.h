// One inspection as the station records it (result store row) and reports it
// (PLC registers): the daemon builds a record when a cycle ends, commits it to
// the result store, and only then publishes it to the PLC.
#pragma once

#include "hullgauge/common/clock.h"
#include "hullgauge/common/enum_names.h"
#include "hullgauge/inspect/correction.h"
#include "hullgauge/inspect/outcome.h"
#include "hullgauge/station/plc_registers.h"
#include "hullgauge/station/sequencer.h"
#include "hullgauge/vision/health.h"

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace hg::station {

/// A landmark's outcome, as in the inspection result JSON (docs/contracts.md §4).
struct LandmarkOutcome {
    std::string id;
    inspect::LandmarkStatus status = inspect::LandmarkStatus::NotInspected;
    double errorMinMm = 0.0;
    double errorMaxMm = 0.0;
    double errorMm = 0.0;
    double toleranceMm = 0.0;
    /// With the part program's inspection.deviation (docs/inspection.md): the
    /// signed sub-voxel deviation, its expanded uncertainty and the decision.
    std::optional<double> deviationMm{};
    std::optional<double> uncertaintyMm{};
    std::optional<inspect::Decision> decision{};
    /// The part program's asymmetric limits [lower, upper], when it gives them.
    std::optional<std::pair<double, double>> limitsMm{};
    /// The raw deviation, the temperature's share and the master's correction
    /// behind `deviationMm` (docs/mastering.md, "In the result").
    std::optional<inspect::AppliedReferral> referral{};
    bool ok() const { return status == inspect::LandmarkStatus::Ok; }
};

/// The steps of a cycle whose time the result reports; their names are the
/// keys of its `timing_ms` (docs/daemon.md, "Maintenance socket"). Prepare runs
/// on the pipeline's worker, mostly while the fixture moves, so the steps
/// overlap and do not add up to the cycle.
enum class CycleStep {
    Move,
    Settle,
    Grab,
    Region,
    Prepare,
    Traversal,
    Processing,
    WaitForVerdict,
    CorrectPoses,
    Commit,
    Publish,
    LastFrameToPublish,
};
constexpr auto nameTable(CycleStep)
{
    using enum CycleStep;
    return std::to_array<EnumName<CycleStep>>({{Move, "move"},
                                               {Settle, "settle"},
                                               {Grab, "grab"},
                                               {Region, "region"},
                                               {Prepare, "prepare"},
                                               {Traversal, "traversal"},
                                               {Processing, "processing"},
                                               {WaitForVerdict, "wait_for_verdict"},
                                               {CorrectPoses, "correct_poses"},
                                               {Commit, "commit"},
                                               {Publish, "publish"},
                                               {LastFrameToPublish, "last_frame_to_publish"}});
}

/// A cycle's time per step; a step the cycle did not report has no entry.
using CycleTimings = std::map<CycleStep, Milliseconds>;
/// {"commit": 1.5, "grab": 20.25, ...}: each step's milliseconds under its name
/// (the result's `timing_ms`; the only place it is written).
nlohmann::json toJson(const CycleTimings& timings);

/// A landmark's outcome as the result store and the HMI read it: id, status, the voxel bracket, the deviation
/// with U and decision where measured, the zone (docs/daemon.md, "Result store").
nlohmann::json toJson(const LandmarkOutcome& landmark);

/// The release of a part program a part was judged with (docs/commissioning.md,
/// "Release"): its version and the SHA-256 of the verification report it was
/// released on. A draft program has none.
struct ProgramRelease {
    int version = 0;
    std::string verificationSha256; ///< 64 lower-case hex digits
    bool operator==(const ProgramRelease&) const = default;
};

/// The station's health as one cycle's views showed it (docs/health.md, "In
/// the daemon"): the figures and those beyond the configured limits. The
/// result store keeps it in its table `health`, the PLC reads the warnings in
/// HEALTH_WARNINGS.
struct HealthRecord {
    vision::HealthFigures figures;
    std::vector<vision::HealthFigure> warnings; ///< in the enum's order (vision::healthWarnings)
};

enum class Verdict { Pass, Fail, Aborted, Error };
constexpr auto nameTable(Verdict)
{
    using enum Verdict;
    return std::to_array<EnumName<Verdict>>({{Pass, "pass"}, {Fail, "fail"}, {Aborted, "aborted"}, {Error, "error"}});
}

struct InspectionRecord {
    std::int64_t startedUnixMs = 0; ///< wall clock at trigger acceptance (ms since 1970, UTC)
    std::uint16_t triggerSeq = 0;
    bool manual = false; ///< triggered from the maintenance socket
    std::string serial;
    std::uint16_t program = 0;
    std::string part; ///< the part program's `part` name
    /// The release of the part program the part was judged with; absent for a
    /// draft program, and when no program judged the part (docs/daemon.md, "Result store").
    std::optional<ProgramRelease> programRelease;
    /// What the cycle was for (CYCLE_PURPOSE at the trigger, docs/study.md).
    CyclePurpose purpose = CyclePurpose::Production;
    Verdict verdict = Verdict::Error;
    FaultCode faultCode = FaultCode::None;
    std::uint32_t cycleMs = 0; ///< trigger accepted -> verdict
    std::vector<LandmarkOutcome> landmarks;
    /// The correction set the deviations were corrected with (docs/mastering.md); empty: none.
    std::string correctionId;
    /// The part's temperature at the trigger (°C), when the station reads one (docs/mastering.md).
    std::optional<double> temperatureC;
    /// Cycle-time breakdown (move, settle, grab, processing, ...).
    CycleTimings timings;
    /// The measured seat: the result's `alignment` object (docs/alignment.md,
    /// docs/contracts.md §4); null when the cycle measured none.
    nlohmann::json alignment = nullptr;
    /// The simulated line only (docs/daemon.md, "Seating"): the part shown and
    /// its true seat, {"part": name, "seat": {...}}; null on real hardware.
    nlohmann::json simulation = nullptr;
    /// The station's health the cycle's views showed; absent when none was
    /// examined (health off, a cycle that ended before its views were prepared).
    std::optional<HealthRecord> health;
    /// The result's id at the plant (a random UUID, docs/mqtt.md); empty: the
    /// store gives one at the commit.
    std::string cycleId;

    std::size_t landmarksFailed() const;
    /// The landmark errors as stored in the result database.
    nlohmann::json landmarksJson() const;
    /// RESULT, FAULT_CODE, counts, CYCLE_MS, the seat (from `alignment`:
    /// shift_mm, rotation_deg), LANDMARK_OK_BITS and, when the cycle examined
    /// the station's health, HEALTH_WARNINGS for the PLC.
    PublishedResult toPublished(PlcStatus statusAfter) const;
};

} // namespace hg::station
