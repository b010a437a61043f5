// A part program made into a configured inspector at a station
// (include/hullgauge/inspect/program_inspector.h).
#include "hullgauge/inspect/program_inspector.h"

#include <algorithm>

#include "hullgauge/common/error.h"
#include "hullgauge/inspect/part_map.h"

namespace hg::inspect {

std::vector<LandmarkCapability> assessProgram(const model::PartProgram& program,
                                              const geometry::CalibrationUncertainty& calibration,
                                              const std::vector<geometry::CameraModel>& cameras,
                                              const geometry::ImageQuality& quality)
{
    const auto gauge = makeDeviationGauge(program, calibration);
    return assessCapability(mapLandmarks(program), inspectionVoxelMm(program), gauge.get(), cameras, quality);
}

// A tolerance zone narrower than 4 U refuses the program before production,
// unless forced; a forced landmark is never ok (docs/inspection.md,
// "Capability"). A masked landmark is not inspected, so it decides nothing.
std::vector<LandmarkCapability> unprovenLandmarks(const CapabilityCheck& check, const std::vector<std::string>& masked,
                                                  const std::string& file)
{
    std::vector<LandmarkCapability> unproven;
    for (const LandmarkCapability& c : check.assessment)
        if (!c.capable && std::find(masked.begin(), masked.end(), c.id) == masked.end()) unproven.push_back(c);
    if (unproven.empty() || check.force) return unproven;
    std::string problem = describe(unproven);
    if (!check.forceWith.empty())
        problem += " (" + check.forceWith + " inspects " + (unproven.size() == 1 ? "it" : "them") +
                   " anyway, never ok: at best uncertain)";
    throw InputError(file, "landmarks", problem);
}

InspectionSetup setUpInspection(const model::InspectionSettings& settings,
                                const std::optional<CapabilityCheck>& capability,
                                const std::vector<std::string>& masked, const std::string& file)
{
    InspectionSetup setup;
    setup.options = inspectionOptions(settings);
    setup.options.maskedLandmarks = masked;
    if (capability) setup.forced = unprovenLandmarks(*capability, masked, file);
    for (const LandmarkCapability& c : setup.forced) setup.options.unprovenLandmarks.push_back(c.id);
    return setup;
}

InspectionSetup setUpInspection(const model::PartProgram& program, const InspectionStation& station,
                                const std::vector<std::string>& masked)
{
    InspectionSetup setup = setUpInspection(program.inspection, station.capability, masked, program.file.string());
    // Deviations referred to 20 °C when a temperature comes with the cycle (docs/mastering.md).
    if (program.material) {
        setup.options.expansionPerK = program.material->expansionPerK;
        setup.options.expansionCentre = program.material->expansionCentre;
    }
    setup.aligner = makeAligner(program);
    setup.gauge = makeDeviationGauge(program, station.calibration);
    // The seat of the first views corrects the poses of the rest (docs/alignment.md,
    // "Poses corrected for the seat"); without alignment every view is taken as planned.
    if (program.alignment.method != model::AlignmentMethod::None)
        setup.seatViews = static_cast<std::size_t>(program.alignment.correctPosesAfter);
    return setup;
}

ProgramInspector makeProgramInspector(const model::PartProgram& program, const InspectionStation& station,
                                      const std::vector<std::string>& masked)
{
    ProgramInspector p;
    p.setup = setUpInspection(program, station, masked);
    // The levels from the options' level to the depth, so the daemon and
    // `hullgauge inspect --part` inspect the same map (buildInspectionMap).
    p.map = std::make_unique<const InspectionMap>(buildInspectionMap(program, p.setup.options));
    p.inspector = std::make_unique<Inspector>(*p.map, p.setup.options, p.setup.aligner, p.setup.gauge);
    return p;
}

} // namespace hg::inspect
