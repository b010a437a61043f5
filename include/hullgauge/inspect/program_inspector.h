// A part program made into a configured inspector at a station: the one way
// the daemon (each program it loads, and `hullgauged --check`), `hullgauge
// inspect --part` and commissioning's verification on the twin configure the
// inspection of a program, and the capability check `hullgauge check-part
// --station` prints, so that all of them judge a program alike: the map and
// the options of its `inspection` section (docs/inspection.md, "Which
// settings apply"), the aligner of its `alignment` section and the views the
// seat is measured on (docs/alignment.md), the deviation gauge at the
// station's calibration (docs/inspection.md, "Uncertainty budget"), and the
// capability check at the views the caller has (docs/inspection.md,
// "Capability": a landmark the station cannot prove refuses the program
// unless forced, and forced it is never ok).
//
// Pure computation on values: no I/O; what was forced is returned for the
// caller to report its own way (the journal, stderr, the verification report).
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/inspect/inspection_map.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/model/part_program.h"

namespace hg::inspect {

/// The capability check at the views the caller has: the daemon the
/// program's planned views, `inspect` the views of its manifest,
/// commissioning the planned views over the nest's play
/// (docs/commissioning.md, "The prediction over the play").
struct CapabilityCheck {
    /// Every landmark's expected U at those views (assessProgram, or the
    /// assessment over the play).
    std::vector<LandmarkCapability> assessment;
    /// Inspect the landmarks the station cannot prove anyway — then never ok,
    /// at best uncertain — instead of refusing the program.
    bool force = false;
    /// How the user forces them, named in the refusal: "--force",
    /// "programs.1.force: true".
    std::string forceWith;
};

/// What of the station an inspection is configured with.
struct InspectionStation {
    /// The station's calibration records (the station file's, or those a
    /// capture manifest carries): the calibration term of the deviation's budget.
    geometry::CalibrationUncertainty calibration;
    /// None: no capability check (the caller has no views).
    std::optional<CapabilityCheck> capability;
};

/// A program's inspection short of its map: what the daemon validates for
/// every program at start, `--check` and reload without building maps.
struct InspectionSetup {
    /// The program's `inspection` section, the masked landmarks left out and
    /// the forced ones unproven (never ok).
    InspectionOptions options;
    std::shared_ptr<const align::Aligner> aligner; ///< null with `alignment.method: none`
    std::shared_ptr<const DeviationGauge> gauge;   ///< null without `inspection.deviation`
    /// The first views, whose seat corrects the poses of the rest:
    /// `alignment.correct_poses_after`, 0 without alignment.
    std::size_t seatViews = 0;
    /// The landmarks the station cannot prove that are inspected anyway.
    std::vector<LandmarkCapability> forced;
};

/// A configured inspector: the setup, the map of inspections at the
/// options' level, and the inspector over it (which keeps a reference to
/// the map: both stay where they are when this is moved).
struct ProgramInspector {
    InspectionSetup setup;
    std::unique_ptr<const InspectionMap> map;
    std::unique_ptr<Inspector> inspector;
};

/// The capability check of a program's landmarks at these cameras: ΔV at
/// its inspection level, its deviation gauge (none without
/// `inspection.deviation`) at the station's calibration, and the image
/// quality the edge noise is predicted from.
std::vector<LandmarkCapability> assessProgram(const model::PartProgram& program,
                                              const geometry::CalibrationUncertainty& calibration,
                                              const std::vector<geometry::CameraModel>& cameras,
                                              const geometry::ImageQuality& quality);

/// The landmarks the check finds the station cannot prove, the masked ones
/// left out (they are not inspected). Unless `check.force`, throws
/// hg::InputError(file, "landmarks") naming each with its numbers and how to
/// force them.
std::vector<LandmarkCapability> unprovenLandmarks(const CapabilityCheck& check, const std::vector<std::string>& masked,
                                                  const std::string& file);

/// The options of an `inspection` section with the masked landmarks left
/// out and those the check cannot prove unproven (unprovenLandmarks; `file`
/// names the program or map in the refusal). Alone only for a map without
/// its program (`inspect --map`): no aligner, no gauge, no seat views.
InspectionSetup setUpInspection(const model::InspectionSettings& settings,
                                const std::optional<CapabilityCheck>& capability,
                                const std::vector<std::string>& masked, const std::string& file);

/// The options, aligner, gauge and seat views of `program` at `station`;
/// `masked`: landmarks left out of the inspection (`inspect --mask`). Throws
/// hg::InputError naming the program for a datum that is not a landmark, or
/// for landmarks the station cannot prove (unprovenLandmarks).
InspectionSetup setUpInspection(const model::PartProgram& program, const InspectionStation& station,
                                const std::vector<std::string>& masked = {});

/// setUpInspection, then the map and the inspector over it. Throws
/// hg::InputError as setUpInspection and buildInspectionMap do, and
/// hg::ArgumentError when the options do not fit the map (Inspector).
ProgramInspector makeProgramInspector(const model::PartProgram& program, const InspectionStation& station,
                                      const std::vector<std::string>& masked = {});

} // namespace hg::inspect
