#include "hullgauge/inspect/part_map.h"

#include <algorithm>
#include <stdexcept>

#include "hullgauge/common/error.h"

namespace hg::inspect {

LabelOracle cadLabels(std::shared_ptr<const model::Solid> solid)
{
    return [solid = std::move(solid)](const Eigen::AlignedBox3d& box) {
        // The exact classification settles voxels wholly inside or outside
        // (including those touching a face); only boundary voxels need the
        // volume fraction.
        switch (solid->classify(box)) {
        case model::Occupancy::Inside: return true;
        case model::Occupancy::Outside: return false;
        case model::Occupancy::Boundary: break;
        }
        return solid->isObjectVoxel(box);
    };
}

InspectionMap buildInspectionMap(const model::PartProgram& program, int levels)
{
    const model::OctreeSpec& o = program.octree;
    if (o.depth > kMaxDepth)
        throw InputError(program.file.string(), "octree.depth",
                         "the inspection map supports depth up to " + std::to_string(kMaxDepth));
    if (!program.solid) throw InputError(program.file.string(), "mesh", "part program has no CAD solid");
    MapGeometry g;
    g.cubeOrigin = o.cubeOrigin;
    g.cubeSize = o.cubeSize;
    g.depth = o.depth;
    g.adjacencyDepth = o.adjacencyDepth;
    g.coarsestLevel = std::max(0, o.depth - std::max(1, levels) + 1);

    std::vector<MapLandmark> landmarks;
    for (const model::Landmark& l : program.landmarks)
        landmarks.push_back({l.id, l.position, l.normal.normalized(), l.toleranceMm});
    std::vector<MapParameter> parameters;
    for (const model::GeometricParameter& p : program.parameters) {
        MapParameter mp;
        mp.id = p.id;
        mp.kind = p.kind == model::ParameterKind::Distance    ? ParameterKind::Distance
                  : p.kind == model::ParameterKind::Perimeter ? ParameterKind::Perimeter
                                                              : ParameterKind::Area;
        mp.landmarks = p.landmarkIds;
        mp.nominal = p.nominalMm;
        mp.tolerance = p.toleranceMm;
        parameters.push_back(std::move(mp));
    }
    try {
        return InspectionMap::build(program.part, g, std::move(landmarks), std::move(parameters),
                                    cadLabels(program.solid));
    } catch (const std::invalid_argument& e) {
        throw InputError(program.file.string(), "octree", e.what());
    }
}

}  // namespace hg::inspect
