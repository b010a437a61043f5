// Part program loader (docs/contracts.md §1); every field is validated through
// ConfigNode so errors name file, line and key path.
#include "hullgauge/model/part_program.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <spdlog/fmt/fmt.h>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/step_io.h"

namespace hg::model {
namespace {

// The angular deflection of a STEP part's tessellation: about 6°, so small
// curved faces (fillets, small bores) get facets even where the chord error
// alone would allow few.
constexpr double kStepAngularDeflectionRad = 0.1;

std::string str(const Eigen::Vector3d& p)
{
    return fmt::format("({:.4f}, {:.4f}, {:.4f})", p.x(), p.y(), p.z());
}

OctreeSpec parseOctree(const ConfigNode& node, const Eigen::AlignedBox3d& bounds)
{
    node.allowOnlyKeys({"cube_origin", "cube_size", "depth", "adjacency_depth"});
    OctreeSpec spec;
    spec.depth = static_cast<int>(node["depth"].asIntIn(1, kMaxOctreeDepth));
    spec.adjacencyDepth = static_cast<int>(node["adjacency_depth"].asIntIn(1, 1 << 20));
    const auto origin = node.optional("cube_origin");
    const auto size = node.optional("cube_size");
    if (origin && !size) origin->fail("cube_origin needs cube_size as well");
    const double cells = std::ldexp(1.0, spec.depth);
    const auto derived = boundingCube(bounds, spec.depth, spec.adjacencyDepth);
    if (!size) {
        if (!derived)
            node["depth"].fail(fmt::format("depth {} gives {} voxels per edge, too few for a default cube with {} "
                                           "layers of type-four voxels around the part; raise depth or give cube_size",
                                           spec.depth, cells, spec.adjacencyDepth));
        spec = *derived;
        return spec;
    }
    spec.cubeSize = size->asPositive();
    // Without an origin the cube is centred on the part's bounding box.
    spec.cubeOrigin =
        origin ? origin->asVector3() : Eigen::Vector3d(bounds.center() - Eigen::Vector3d::Constant(spec.cubeSize / 2));
    const Eigen::AlignedBox3d cube(spec.cubeOrigin, spec.cubeOrigin + Eigen::Vector3d::Constant(spec.cubeSize));
    const ConfigNode& where = origin ? *origin : *size;
    if (!cube.contains(bounds))
        where.fail(fmt::format("the part (bounding box {} to {}) does not fit in the cube {} to {}", str(bounds.min()),
                               str(bounds.max()), str(cube.min()), str(cube.max())));
    const double margin = std::min((bounds.min() - cube.min()).minCoeff(), (cube.max() - bounds.max()).minCoeff());
    if (margin < spec.adjacencyDepth * spec.voxelSize())
        log::category("model")->warn("{}: the cube leaves only {:.4g} mm around the part, less than adjacency_depth "
                                     "({}) voxels of {:.4g} mm; type-four voxels near the cube wall are cut off",
                                     where.file(), margin, spec.adjacencyDepth, spec.voxelSize());
    return spec;
}

// A fixture pose of a best view or a view for the seat: {rotation_deg[,
// declination_deg]} or {rail_mm}; `list` names the poses' list in the error
// when they mix the two kinds.
geometry::FixturePose parsePose(const ConfigNode& node, std::optional<geometry::FixtureType>& kind,
                                const std::string& list = "best views")
{
    if (!node.isMap()) node.fail("expected a pose such as {rotation_deg: 0, declination_deg: 30} or {rail_mm: 120}");
    node.allowOnlyKeys({"rotation_deg", "declination_deg", "rail_mm"});
    geometry::FixturePose pose;
    geometry::FixtureType type;
    if (node.has("rail_mm")) {
        if (node.has("rotation_deg") || node.has("declination_deg"))
            node.fail("a pose gives either rail_mm or rotation_deg/declination_deg, not both");
        pose.railMm = node["rail_mm"].asDouble();
        type = geometry::FixtureType::Rail;
    } else {
        pose.rotationDeg = node["rotation_deg"].asDoubleIn(-360.0, 360.0);
        if (auto d = node.optional("declination_deg")) pose.declinationDeg = d->asDoubleIn(-180.0, 180.0);
        type = geometry::FixtureType::RotationDeclination;
    }
    if (kind && *kind != type) node.fail(list + " mix rail poses and rotation/declination poses");
    kind = type;
    return pose;
}

std::vector<BestViewGroup> parseBestViews(const ConfigNode& node, std::optional<geometry::FixtureType>& kind)
{
    std::vector<BestViewGroup> groups;
    for (const ConfigNode& entry : node.items()) {
        // AND over entries; an entry is one pose or {any_of: [poses]} (OR).
        BestViewGroup group;
        if (entry.isMap() && entry.has("any_of")) {
            entry.allowOnlyKeys({"any_of"});
            const ConfigNode list = entry["any_of"];
            for (const ConfigNode& pose : list.items()) group.push_back(parsePose(pose, kind));
            if (group.empty()) list.fail("any_of needs at least one pose");
        } else {
            group.push_back(parsePose(entry, kind));
        }
        groups.push_back(std::move(group));
    }
    return groups;
}

/// `tolerance_mm` (the zone ±t) or `limits_mm: [lower, upper]` (docs/part-program.md), one of them.
void parseTolerance(const ConfigNode& node, Landmark& lm)
{
    const auto limits = node.optional("limits_mm");
    if (limits && node.has("tolerance_mm"))
        limits->fail("give either tolerance_mm or limits_mm, not both (limits_mm replaces the symmetric zone)");
    if (!limits) {
        lm.toleranceMm = node["tolerance_mm"].asPositive();
        return;
    }
    const auto v = limits->asDoubles(2);
    if (std::abs(v[0]) > 1e3 || std::abs(v[1]) > 1e3) limits->fail("limits must lie within ±1000 mm");
    if (!(v[0] < v[1])) limits->fail("expected [lower, upper] with lower < upper (mm, outward positive)");
    lm.limitsMm = std::make_pair(v[0], v[1]);
    lm.toleranceMm = 0.5 * (v[1] - v[0]);
}

/// The surface at a landmark: the nearest point, its distance and the outward normal.
struct SurfaceAt {
    Eigen::Vector3d point;
    double distance = 0.0;
    Eigen::Vector3d normal;
};

/// A STEP part's exact B-rep (docs/part-program.md, "STEP parts"), else the
/// mesh; on an edge or a corner (within the surface tolerance) both take the
/// mean of the faces that meet there (the mesh: angle-weighted).
SurfaceAt surfaceAt(const Eigen::Vector3d& position, const Solid& solid, const StepModel* brep, double radius)
{
    if (brep) {
        const BRepPoint exact = brep->closestPoint(position, radius);
        return {exact.point, exact.distance, exact.normal};
    }
    const SurfacePoint nearest = solid.closestPoint(position);
    return {nearest.point, nearest.distance, solid.surfaceNormal(nearest.point, radius)};
}

Landmark parseLandmark(const ConfigNode& node, const Solid& solid, const StepModel* brep, double surfaceTolerance,
                       std::optional<geometry::FixtureType>& kind)
{
    node.allowOnlyKeys({"id", "position", "normal", "tolerance_mm", "limits_mm", "best_views"});
    Landmark lm;
    const ConfigNode idNode = node["id"];
    lm.id = idNode.asString();
    if (lm.id.empty()) idNode.fail("landmark id is empty");
    const ConfigNode posNode = node["position"];
    lm.position = posNode.asVector3();
    // Far past any part: the closest-point query would overflow (a coordinate of 1e308).
    if (lm.position.cwiseAbs().maxCoeff() > 1e5)
        posNode.fail("values must lie within ±1e5 mm (a part is not that large)");
    parseTolerance(node, lm);

    // On the surface (within the documented tolerance).
    const SurfaceAt nearest = surfaceAt(lm.position, solid, brep, surfaceTolerance);
    lm.distanceToSurfaceMm = nearest.distance;
    if (nearest.distance > surfaceTolerance)
        posNode.fail(fmt::format("landmark '{}' is {:.3f} mm from the surface (nearest point {}; allowed {:.3g} mm)",
                                 lm.id, nearest.distance, str(nearest.point), surfaceTolerance));
    // A STEP part's landmark lies on the exact surface: the tessellation is
    // only the map's approximation of it.
    if (brep) lm.position = nearest.point;
    lm.onBRep = brep != nullptr;
    const Eigen::Vector3d surfaceNormal = nearest.normal;
    if (auto n = node.optional("normal")) {
        const Eigen::Vector3d given = n->asVector3();
        if (!(given.norm() > 1e-12)) n->fail("normal has zero length");
        lm.normal = given.normalized();
        if (lm.normal.dot(surfaceNormal) <= 0.0)
            n->fail(fmt::format("normal {} of landmark '{}' points into the part (the surface normal there is {})",
                                str(lm.normal), lm.id, str(surfaceNormal)));
    } else {
        lm.normal = surfaceNormal;
        lm.normalFromMesh = true;
    }
    if (auto bv = node.optional("best_views")) lm.bestViews = parseBestViews(*bv, kind);
    return lm;
}

GeometricParameter parseParameter(const ConfigNode& node, const std::map<std::string, std::size_t>& landmarkIndex)
{
    node.allowOnlyKeys({"id", "kind", "landmarks", "nominal_mm", "tolerance_mm"});
    GeometricParameter p;
    const ConfigNode idNode = node["id"];
    p.id = idNode.asString();
    if (p.id.empty()) idNode.fail("parameter id is empty");
    p.kind = node["kind"].asEnum<ParameterKind>("kind");
    const ConfigNode list = node["landmarks"];
    for (const ConfigNode& item : list.items()) {
        const std::string id = item.asString();
        auto it = landmarkIndex.find(id);
        if (it == landmarkIndex.end()) item.fail("unknown landmark '" + id + "'");
        p.landmarkIds.push_back(id);
        p.landmarkIndices.push_back(it->second);
    }
    if (p.kind == ParameterKind::Distance && p.landmarkIds.size() != 2)
        list.fail(fmt::format("a distance needs exactly 2 landmarks, found {}", p.landmarkIds.size()));
    if (p.kind != ParameterKind::Distance && p.landmarkIds.size() < 3)
        list.fail(fmt::format("a {} needs at least 3 landmarks (a closed polygon), found {}", enumName(p.kind),
                              p.landmarkIds.size()));
    std::set<std::string> unique(p.landmarkIds.begin(), p.landmarkIds.end());
    if (unique.size() != p.landmarkIds.size()) list.fail("a landmark is listed twice");
    p.nominalMm = node["nominal_mm"].asDoubleIn(0.0, 1e12);
    p.toleranceMm = node["tolerance_mm"].asPositive();
    return p;
}

// The `inspection` section, checked against the octree.
InspectionSettings parseInspection(const ConfigNode& node, const OctreeSpec& octree)
{
    node.allowOnlyKeys(
        {"level", "adjacency", "method", "resolution_check", "early_exit", "deviation", "decision_rule"});
    InspectionSettings s;
    if (auto n = node.optional("level")) s.level = static_cast<int>(n->asIntIn(1, octree.depth));
    if (auto n = node.optional("adjacency")) s.adjacency = static_cast<int>(n->asIntIn(1, octree.adjacencyDepth));
    if (auto n = node.optional("method")) {
        const std::string method = n->asString();
        if (method != "volume" && method != "centre")
            n->fail("unknown method '" + method + "' (expected volume or centre)");
        s.centrePointTest = method == "centre";
    }
    if (auto n = node.optional("resolution_check")) s.requireResolution = n->asBool();
    if (auto n = node.optional("early_exit")) s.earlyExit = n->asBool();
    if (auto n = node.optional("deviation")) s.deviation = n->asBool();
    if (auto n = node.optional("decision_rule"))
        s.simpleDecision = n->asEnum<DecisionRule>("decision rule") == DecisionRule::Simple;
    return s;
}

// The `alignment` section (docs/part-program.md, docs/alignment.md): the
// datums must name landmarks, so it is read after them.
AlignmentSettings parseAlignment(const ConfigNode& node, const std::map<std::string, std::size_t>& landmarkIndex)
{
    if (!node.isMap())
        node.fail("expected a map with keys method, datums, max_shift_mm, max_rotation_deg, correct_poses_after, "
                  "seat_views");
    node.allowOnlyKeys({"method", "datums", "max_shift_mm", "max_rotation_deg", "correct_poses_after", "seat_views"});
    AlignmentSettings s;
    if (auto n = node.optional("method")) s.method = n->asEnum<AlignmentMethod>("method");
    const auto datums = node.optional("datums");
    if (datums && s.method != AlignmentMethod::Datums)
        datums->fail("datums are read by method datums only (method is " + std::string(enumName(s.method)) + ")");
    if (s.method == AlignmentMethod::Datums) {
        if (!datums) node.fail("method datums needs datums: [landmark id, ...] (in priority order)");
        for (const ConfigNode& item : datums->items()) {
            const std::string id = item.asString();
            if (!landmarkIndex.count(id)) item.fail("unknown landmark '" + id + "'");
            if (std::find(s.datums.begin(), s.datums.end(), id) != s.datums.end())
                item.fail("datum '" + id + "' is listed twice");
            s.datums.push_back(id);
        }
        if (s.datums.empty()) datums->fail("method datums needs at least one datum");
    }
    if (auto n = node.optional("max_shift_mm")) s.maxShiftMm = n->asPositive();
    if (auto n = node.optional("max_rotation_deg")) {
        // Beyond 10° the part is not seated at all: no fixture has that much play.
        s.maxRotationDeg = n->asPositive();
        if (s.maxRotationDeg > 10.0)
            n->fail("value " + formatNumber(s.maxRotationDeg) + " is outside (0, 10] (degrees)");
    }
    // A view count: 0 never corrects; a plan has at most a few dozen views.
    if (auto n = node.optional("correct_poses_after")) s.correctPosesAfter = static_cast<int>(n->asIntIn(0, 64));
    if (auto n = node.optional("seat_views")) {
        if (s.method == AlignmentMethod::None) n->fail("views for the seat are read only when the part is aligned");
        std::optional<geometry::FixtureType> kind;
        for (const ConfigNode& item : n->items()) {
            const geometry::FixturePose pose = parsePose(item, kind, "views for the seat");
            if (std::find(s.seatViews.begin(), s.seatViews.end(), pose) != s.seatViews.end())
                item.fail("this pose is listed twice");
            s.seatViews.push_back(pose);
        }
        if (s.seatViews.empty()) n->fail("expected at least one pose, or no seat_views");
        if (s.seatViews.size() > 64) n->fail("at most 64 views for the seat");
    }
    return s;
}

/// A STEP part's tessellation for the octree `octree`: chord error ΔV/20
/// (PartProgram::tessellationDeflectionMm, docs/part-program.md "STEP parts").
TriangleMesh tessellateFor(StepModel& brep, const OctreeSpec& octree)
{
    return brep.tessellate(octree.voxelSize() / 20.0, kStepAngularDeflectionRad);
}

/// `mesh_repair: repair | strict` and `mesh_gap_mm` (docs/part-program.md, "Meshes as they come").
MeshRepairOptions parseMeshRepair(const ConfigNode& root)
{
    MeshRepairOptions options;
    if (auto n = root.optional("mesh_repair")) options.mode = n->asEnum<MeshRepairMode>("mode");
    // A gap wider than a millimetre is a hole in the CAD model, not rounding in its export.
    if (auto n = root.optional("mesh_gap_mm")) options.gapToleranceMm = n->asDoubleIn(0.0, 1.0);
    return options;
}

/// `mesh_solid` (docs/part-program.md, "STEP parts"): a solid of a STEP file
/// by name; a mesh file has no named solids to choose from.
std::string parseMeshSolid(const std::optional<ConfigNode>& node, const std::filesystem::path& meshFile)
{
    if (!node) return {};
    const std::string name = node->asString();
    if (name.empty()) node->fail("solid name is empty");
    if (!isStepFile(meshFile))
        node->fail(fmt::format("{} is a mesh (STL, OBJ, PLY or OFF): one surface without named solids; mesh_solid "
                               "chooses a solid of a STEP file (.step, .stp)",
                               meshFile.filename().string()));
    return name;
}

/// The model file's own error, reported at the key it concerns: a solid's
/// name at `mesh_solid`, everything else at `mesh`.
[[noreturn]] void failAt(const InputError& e, const ConfigNode& meshNode, const std::optional<ConfigNode>& solidNode)
{
    if (e.field() == "mesh_solid" && solidNode) solidNode->fail(e.what());
    meshNode.fail(e.what());
}

/// The CAD model and the octree around it. A STEP part is read first, the
/// octree placed around its exact bounding box, and then tessellated with the
/// chord error ΔV/20 (docs/part-program.md, "STEP parts"); a mesh is read as it is.
void loadModel(const ConfigNode& meshNode, const std::optional<ConfigNode>& solidNode, const ConfigNode& octreeNode,
               PartProgram& program)
{
    TriangleMesh mesh;
    std::shared_ptr<StepModel> brep;
    try {
        if (isStepFile(program.meshFile))
            brep = std::make_shared<StepModel>(StepModel::read(program.meshFile, program.meshSolid));
        else {
            ImportedMesh imported = importMesh(program.meshFile, program.meshRepair);
            mesh = std::move(imported.mesh);
            program.meshRepairReport = imported.repair;
        }
    } catch (const InputError& e) {
        failAt(e, meshNode, solidNode);
    }
    program.octree = parseOctree(octreeNode, brep ? brep->summary().bounds : mesh.bounds());
    if (brep) {
        try {
            mesh = tessellateFor(*brep, program.octree);
        } catch (const InputError& e) {
            meshNode.fail(e.what());
        }
        program.brep = brep;
    }
    program.solid = std::make_shared<const Solid>(std::move(mesh));
}

/// loadCadModel's STEP file: a name no solid or several carry is the `--solid` option's error.
std::shared_ptr<StepModel> readCadStep(const std::filesystem::path& file, const std::string& solid)
{
    try {
        return std::make_shared<StepModel>(StepModel::read(file, solid));
    } catch (const InputError& e) {
        if (e.field() != "mesh_solid") throw;
        throw InputError(e.file(), "--solid", e.problem());
    }
}

} // namespace

double OctreeSpec::voxelSize() const
{
    return cubeSize / std::ldexp(1.0, depth);
}

double PartProgram::surfaceToleranceMm() const
{
    return std::max(0.01, octree.voxelSize() / 4.0);
}

const Landmark* PartProgram::findLandmark(const std::string& id) const
{
    auto it = std::find_if(landmarks.begin(), landmarks.end(), [&](const Landmark& l) { return l.id == id; });
    return it == landmarks.end() ? nullptr : &*it;
}

std::optional<OctreeSpec> boundingCube(const Eigen::AlignedBox3d& bounds, int depth, int adjacencyDepth)
{
    const double cells = std::ldexp(1.0, depth);
    const double margin = adjacencyDepth + 1.0;
    if (cells <= 2.0 * margin) return std::nullopt;
    const double extent = (bounds.max() - bounds.min()).maxCoeff();
    OctreeSpec spec;
    spec.depth = depth;
    spec.adjacencyDepth = adjacencyDepth;
    spec.cubeFromMesh = true;
    spec.cubeSize = extent / (1.0 - 2.0 * margin / cells);
    spec.cubeOrigin = bounds.center() - Eigen::Vector3d::Constant(spec.cubeSize / 2.0);
    return spec;
}

CadModel loadCadModel(const std::filesystem::path& file, int depth, int adjacencyDepth, const std::string& solid)
{
    CadModel model;
    model.file = file;
    TriangleMesh mesh;
    std::shared_ptr<StepModel> brep;
    if (isStepFile(file))
        brep = readCadStep(file, solid);
    else if (!solid.empty())
        throw InputError(file.string(), "--solid",
                         "a mesh (STL, OBJ, PLY or OFF) is one surface without named solids; --solid chooses a "
                         "solid of a STEP file (.step, .stp)");
    else
        mesh = loadMesh(file);
    const auto cube = boundingCube(brep ? brep->summary().bounds : mesh.bounds(), depth, adjacencyDepth);
    if (!cube)
        throw InputError(file.string(), "octree.depth",
                         fmt::format("depth {} is too small for a default cube with {} layers of type-four voxels "
                                     "around the part; raise the depth",
                                     depth, adjacencyDepth));
    model.octree = *cube;
    if (brep) {
        mesh = tessellateFor(*brep, model.octree);
        model.brep = brep;
    }
    model.solid = std::make_shared<const Solid>(std::move(mesh));
    return model;
}

namespace {

// docs/commissioning.md, "Release": the record commissioning writes.
ReleaseRecord parseRelease(const ConfigNode& node)
{
    node.allowOnlyKeys({"version", "verification_sha256", "released_by", "released_at", "rolled_back_from"});
    ReleaseRecord r;
    r.version = static_cast<int>(node["version"].asIntIn(1, 1000000));
    r.verificationSha256 = node["verification_sha256"].asString();
    const bool hex = r.verificationSha256.size() == 64 &&
                     r.verificationSha256.find_first_not_of("0123456789abcdef") == std::string::npos;
    if (!hex) node["verification_sha256"].fail("expected 64 lower-case hex digits (SHA-256)");
    r.releasedBy = node["released_by"].asString();
    if (r.releasedBy.empty()) node["released_by"].fail("who released the program is empty");
    r.releasedAt = node["released_at"].asString();
    if (r.releasedAt.empty()) node["released_at"].fail("when the program was released is empty");
    if (auto n = node.optional("rolled_back_from")) {
        r.rolledBackFrom = static_cast<int>(n->asIntIn(1, 1000000));
        if (*r.rolledBackFrom >= r.version)
            n->fail("version " + std::to_string(r.version) + " can only roll back to an earlier version, not " +
                    std::to_string(*r.rolledBackFrom));
    }
    return r;
}

// docs/part-program.md, "Material"; docs/mastering.md, "Temperature".
Material parseMaterial(const ConfigNode& node, const Solid& solid)
{
    node.allowOnlyKeys({"name", "expansion_per_k", "expansion_centre"});
    Material m;
    m.name = node["name"].asString();
    const bool plain = !m.name.empty() && m.name.find_first_of("/\\ \t") == std::string::npos;
    if (!plain) node["name"].fail("expected a material name without spaces or slashes (it names correction sets)");
    if (auto n = node.optional("expansion_per_k")) m.expansionPerK = n->asDoubleIn(0.0, 1e-3);
    const auto bounds = solid.mesh().bounds();
    m.expansionCentre = 0.5 * (bounds.min() + bounds.max());
    if (auto n = node.optional("expansion_centre")) m.expansionCentre = n->asVector3();
    return m;
}

} // namespace

PartProgram loadPartProgram(const std::filesystem::path& file)
{
    const ConfigNode root = ConfigNode::loadFile(file);
    if (!root.isMap()) root.fail("expected a map with keys part, mesh, octree, landmarks");
    root.allowOnlyKeys({"part", "mesh", "mesh_solid", "mesh_repair", "mesh_gap_mm", "octree", "landmarks", "parameters",
                        "inspection", "alignment", "decision_rule", "release", "material"});

    PartProgram program;
    program.file = file;
    const ConfigNode partNode = root["part"];
    program.part = partNode.asString();
    if (program.part.empty()) partNode.fail("part name is empty");

    const ConfigNode meshNode = root["mesh"];
    const std::string meshText = meshNode.asString();
    if (meshText.empty()) meshNode.fail("mesh path is empty");
    program.meshFile =
        std::filesystem::path(meshText).is_absolute() ? std::filesystem::path(meshText) : file.parent_path() / meshText;
    program.meshRepair = parseMeshRepair(root);
    const std::optional<ConfigNode> solidNode = root.optional("mesh_solid");
    program.meshSolid = parseMeshSolid(solidNode, program.meshFile);
    loadModel(meshNode, solidNode, root["octree"], program);

    const double surfaceTolerance = program.surfaceToleranceMm();
    const ConfigNode landmarks = root["landmarks"];
    std::map<std::string, std::size_t> index;
    for (const ConfigNode& node : landmarks.items()) {
        Landmark lm =
            parseLandmark(node, *program.solid, program.brep.get(), surfaceTolerance, program.bestViewFixture);
        if (index.count(lm.id)) node["id"].fail("duplicate landmark id '" + lm.id + "'");
        index[lm.id] = program.landmarks.size();
        program.landmarks.push_back(std::move(lm));
    }
    if (program.landmarks.empty()) landmarks.fail("a part program needs at least one landmark");

    if (auto params = root.optional("parameters")) {
        std::set<std::string> ids;
        for (const ConfigNode& node : params->items()) {
            GeometricParameter p = parseParameter(node, index);
            if (!ids.insert(p.id).second) node["id"].fail("duplicate parameter id '" + p.id + "'");
            program.parameters.push_back(std::move(p));
        }
    }
    if (auto n = root.optional("inspection")) program.inspection = parseInspection(*n, program.octree);
    // docs/contracts.md §8 writes the rule at the top level; inspection.decision_rule says the same.
    if (auto n = root.optional("decision_rule")) {
        const auto rule = n->asEnum<DecisionRule>("decision rule");
        const auto inner = root.optional("inspection") ? root["inspection"].optional("decision_rule") : std::nullopt;
        if (inner && inner->asEnum<DecisionRule>("decision rule") != rule)
            n->fail("decision_rule disagrees with inspection.decision_rule (give it once)");
        program.inspection.simpleDecision = rule == DecisionRule::Simple;
    }
    if (auto n = root.optional("alignment")) program.alignment = parseAlignment(*n, index);
    if (auto n = root.optional("release")) program.release = parseRelease(*n);
    if (auto n = root.optional("material")) program.material = parseMaterial(*n, *program.solid);
    return program;
}

} // namespace hg::model
