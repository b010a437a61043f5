#include "hullgauge/inspect/part_map.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "hullgauge/common/error.h"

static_assert(hg::inspect::kMaxDepth == hg::model::kMaxOctreeDepth,
              "a program's octree.depth is checked at loading against the map's deepest level");

namespace hg::inspect {

namespace {

/// Directions tried for a line of sight through a void voxel, in addition to
/// the tangent directions of the nearest surface: the 13 lattice directions
/// (axes, face and body diagonals: slots, channels and holes are mostly
/// machined along them) and 64 spread over the half sphere (a Fibonacci
/// lattice; a line runs both ways). An enclosed voxel tries them all, so
/// their number is the cost of a cavity in the map build.
const std::vector<Eigen::Vector3d>& lineDirections()
{
    static const std::vector<Eigen::Vector3d> dirs = [] {
        std::vector<Eigen::Vector3d> d;
        for (int x = -1; x <= 1; ++x)
            for (int y = -1; y <= 1; ++y)
                for (int z = -1; z <= 1; ++z) {
                    const Eigen::Vector3d v(x, y, z);
                    // One of each opposite pair: first non-zero coordinate positive.
                    if (v.isZero() || (x < 0) || (x == 0 && y < 0) || (x == 0 && y == 0 && z < 0)) continue;
                    d.push_back(v.normalized());
                }
        constexpr int n = 64;
        const double golden = M_PI * (3.0 - std::sqrt(5.0));
        for (int i = 0; i < n; ++i) {
            const double z = (i + 0.5) / n; // upper half sphere
            const double r = std::sqrt(1.0 - z * z);
            d.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
        }
        return d;
    }();
    return dirs;
}

/// True when some straight line through the voxel's centre misses the part:
/// then a view along it can see background through the voxel (weak convexity,
/// chapter 2). Directions in the tangent plane of the nearest surface come
/// first: they are the grazing lines of sight, the only clear ones next to a
/// face inside a channel or a hole.
bool someLineMisses(const model::Solid& solid, const Eigen::AlignedBox3d& bounds, const Eigen::AlignedBox3d& box)
{
    const Eigen::Vector3d c = box.center();
    const double reach = 2.0 * (bounds.diagonal().norm() + (c - bounds.center()).norm()) + 1.0;
    auto clear = [&](const Eigen::Vector3d& d) { return !solid.segmentHits(c - reach * d, c + reach * d); };

    const Eigen::Vector3d n = solid.closestPoint(c).normal;
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    for (int a = 0; a < 3; ++a) {
        const Eigen::Vector3d axis = Eigen::Vector3d::Unit(a);
        const Eigen::Vector3d t = axis - axis.dot(n) * n;
        if (t.norm() > 1e-9 && clear(t.normalized())) return true;
    }
    constexpr int azimuths = 12;
    for (int k = 0; k < azimuths; ++k) {
        const double phi = M_PI * k / azimuths;
        if (clear(std::cos(phi) * u + std::sin(phi) * v)) return true;
    }
    return std::any_of(lineDirections().begin(), lineDirections().end(), clear);
}

} // namespace

ExpectationOracle cadLabels(std::shared_ptr<const model::Solid> solid)
{
    const Eigen::AlignedBox3d bounds = solid->mesh().bounds();
    return [solid = std::move(solid), bounds](const Eigen::AlignedBox3d& box) {
        VoxelExpectation e;
        // The exact classification settles voxels wholly inside or outside
        // (including those touching a face); only boundary voxels need the
        // volume fraction.
        switch (solid->classify(box)) {
        case model::Occupancy::Inside:
            e.object = true;
            return e;
        case model::Occupancy::Outside:
            break;
        case model::Occupancy::Boundary: {
            const double f = solid->insideFraction(box).estimate;
            e.object = solid->isObjectVoxel(box);
            e.dontCare = std::abs(f - 0.5) < kDontCareBand;
            break;
        }
        }
        if (!e.object && !e.dontCare) e.hidden = !someLineMisses(*solid, bounds, box);
        return e;
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

    std::vector<MapLandmark> landmarks = mapLandmarks(program);
    std::vector<MapParameter> parameters;
    for (const model::GeometricParameter& p : program.parameters) {
        MapParameter mp;
        mp.id = p.id;
        mp.kind = p.kind;
        mp.landmarks = p.landmarkIds;
        mp.nominal = p.nominalMm;
        mp.tolerance = p.toleranceMm;
        parameters.push_back(std::move(mp));
    }
    try {
        return InspectionMap::build(program.part, g, std::move(landmarks), std::move(parameters),
                                    cadLabels(program.solid));
    } catch (const ArgumentError& e) {
        // The geometry and landmarks came from the part program: its fault, named there (docs/style.md point 4).
        throw InputError(program.file.string(), "octree", e.what());
    }
}

InspectionOptions inspectionOptions(const model::InspectionSettings& settings)
{
    InspectionOptions options;
    options.level = settings.level;
    options.adjacency = settings.adjacency;
    options.earlyExit = settings.earlyExit;
    options.method = settings.centrePointTest ? VoxelTestMethod::CentrePoint : VoxelTestMethod::VolumeSource;
    options.requireResolution = settings.requireResolution;
    options.decisionRule = settings.simpleDecision ? DecisionRule::Simple : DecisionRule::Guarded;
    return options;
}

std::shared_ptr<const align::Aligner> makeAligner(const model::PartProgram& program)
{
    if (program.alignment.method == model::AlignmentMethod::None) return nullptr;
    try {
        return std::make_shared<const align::Aligner>(program.solid, program.landmarks, program.alignment);
    } catch (const ArgumentError& e) {
        throw InputError(program.file.string(), "alignment", e.what());
    }
}

std::shared_ptr<const DeviationGauge> makeDeviationGauge(const model::PartProgram& program,
                                                         const geometry::CalibrationUncertainty& calibration)
{
    return program.inspection.deviation ? std::make_shared<const DeviationGauge>(program.solid, calibration) : nullptr;
}

std::vector<MapLandmark> mapLandmarks(const model::PartProgram& program)
{
    std::vector<MapLandmark> landmarks;
    for (const model::Landmark& l : program.landmarks)
        landmarks.push_back({l.id, l.position, l.normal.normalized(), l.toleranceMm, l.limitsMm});
    return landmarks;
}

double inspectionVoxelMm(const model::PartProgram& program)
{
    const int level = program.inspection.level < 0 ? program.octree.depth : program.inspection.level;
    return program.octree.cubeSize / static_cast<double>(std::uint64_t{1} << level);
}

InspectionMap buildInspectionMap(const model::PartProgram& program, const InspectionOptions& options)
{
    const int depth = program.octree.depth;
    const int level = options.level < 0 ? depth : options.level;
    return buildInspectionMap(program, std::max(1, depth - level + 1));
}

} // namespace hg::inspect
