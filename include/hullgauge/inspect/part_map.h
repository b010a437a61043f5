// Building the octree inspection map of a part program (3.5.1): geometry from
// the program's octree section, labels from the CAD solid (object when >= 50 %
// of a voxel lies inside: Solid::isObjectVoxel).
#pragma once

#include <memory>

#include "hullgauge/inspect/inspection_map.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/model/part_program.h"

namespace hg::inspect {

/// Expected voxel labels of a CAD solid: object when >= 50 % inside; don't
/// care when the inside fraction is within kDontCareBand of 50 %; hidden when
/// void but no straight line through the voxel's centre misses the solid
/// (tried: 15 tangent directions of the nearest surface, the 13 lattice
/// directions and 64 spread over the sphere), so no view can carve it (3.3.8).
ExpectationOracle cadLabels(std::shared_ptr<const model::Solid> solid);

/// `levels` inspection levels are prepared: depth - levels + 1 .. depth
/// (clamped to level 0). Throws hg::InputError naming the part program when
/// its octree cannot be represented (depth above kMaxDepth).
InspectionMap buildInspectionMap(const model::PartProgram& program, int levels = 3);

/// The options a part program's `inspection` section sets (docs/part-program.md).
InspectionOptions inspectionOptions(const model::InspectionSettings& settings);

/// The aligner of a part program's `alignment` section; null for `method: none`.
/// Throws hg::InputError naming the program when a datum is not a landmark.
std::shared_ptr<const align::Aligner> makeAligner(const model::PartProgram& program);
/// The deviation gauge of a program with `inspection.deviation`; null
/// without. `calibration`: the station's calibration records (the station
/// file's, or those a capture manifest carries).
std::shared_ptr<const DeviationGauge> makeDeviationGauge(const model::PartProgram& program,
                                                         const geometry::CalibrationUncertainty& calibration = {});

/// The program's landmarks as the map holds them.
std::vector<MapLandmark> mapLandmarks(const model::PartProgram& program);
/// ΔV at the program's inspection level (`inspection.level`, else the depth).
double inspectionVoxelMm(const model::PartProgram& program);

/// The map of inspections at `options.level` (-1: the depth): only the levels
/// from there to the depth. The daemon and `hullgauge inspect --part` both
/// build their map so, so both inspect the same map.
InspectionMap buildInspectionMap(const model::PartProgram& program, const InspectionOptions& options);

} // namespace hg::inspect
