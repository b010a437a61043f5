// hullgauge check-part --part P.yaml [--station S.yaml --views V.yaml] [--json]:
// validates a part program (docs/contracts.md §1) and prints what the
// inspection map will be built from; with a station and the poses of its
// views, the uncertainty each landmark is expected to be measured with there
// (the capability check, docs/inspection.md, "Capability").
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <spdlog/fmt/fmt.h>

#include "command.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/program_inspector.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/step_io.h"

namespace hg::cli {
namespace {

using geometry::toJson;

struct CheckArgs {
    std::string part;
    std::string station;
    std::string views;
    bool json = false;
};

/// The expected U per landmark at the station's views, as the daemon judges
/// the program there when it loads it (inspect::assessProgram); nullopt
/// without --station. Printed, not enforced: the check names what the
/// daemon would refuse (docs/inspection.md, "Capability").
std::optional<std::vector<inspect::LandmarkCapability>> capabilityAt(const model::PartProgram& program,
                                                                     const CheckArgs& args)
{
    if (args.station.empty()) return std::nullopt;
    const geometry::Station station = geometry::loadStation(args.station);
    std::vector<geometry::CameraModel> cameras;
    for (const geometry::FixturePose& pose : geometry::loadPoses(args.views, &station.fixture))
        cameras.push_back(station.cameraAt(pose));
    return inspect::assessProgram(program, station.calibration, cameras, station.imageQuality);
}

/// "tolerance ±0.05 mm" or "limits [-0.02, 0.08] mm".
std::string zoneText(const model::Landmark& lm)
{
    if (lm.limitsMm) return fmt::format("limits [{:.4g}, {:.4g}] mm", lm.limitsMm->first, lm.limitsMm->second);
    return fmt::format("tolerance {:.4g} mm", lm.toleranceMm);
}

/// A STEP part (docs/part-program.md, "STEP parts"): what was read from the
/// exact B-rep and how it was tessellated.
nlohmann::json stepJson(const model::StepModel& brep)
{
    const model::StepSummary& s = brep.summary();
    const model::StepTessellation& t = brep.tessellation();
    nlohmann::json tree = nlohmann::json::array();
    for (const model::StepSolid& solid : s.tree)
        tree.push_back({{"name", solid.name},
                        {"instance", solid.instance},
                        {"solids", solid.solids},
                        {"volume_mm3", solid.volumeMm3},
                        {"chosen", solid.chosen}});
    return {{"solids", s.solids},
            {"mesh_solid", s.chosen.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.chosen)},
            {"tree", tree},
            {"faces", s.faces},
            {"volume_mm3", s.volumeMm3},
            {"bounds_min", toJson(s.bounds.min())},
            {"bounds_max", toJson(s.bounds.max())},
            {"linear_deflection_mm", t.linearDeflectionMm},
            {"angular_deflection_rad", t.angularDeflectionRad},
            {"triangles", t.triangles}};
}

/// The file's solids by name, the chosen one marked (docs/part-program.md, "STEP parts").
std::string treeText(const model::StepSummary& s)
{
    std::string text = fmt::format("solids      {} in the file's product tree{}\n", s.tree.size(),
                                   s.chosen.empty() ? " (all in the part)" : "");
    for (const model::StepSolid& solid : s.tree)
        text += fmt::format("  {}: {}{}volume {:.6g} mm³{}\n", model::describe(solid),
                            solid.solids == 1 ? "" : std::to_string(solid.solids) + " bodies, ",
                            solid.solids == 1 ? "" : "their union's ", solid.volumeMm3,
                            solid.chosen ? " (chosen: mesh_solid)" : "");
    return text;
}

std::string stepText(const model::StepModel& brep)
{
    const model::StepSummary& s = brep.summary();
    const model::StepTessellation& t = brep.tessellation();
    const Eigen::Vector3d& lo = s.bounds.min();
    const Eigen::Vector3d& hi = s.bounds.max();
    const std::string what = !s.chosen.empty() ? fmt::format("solid '{}' of {} (mesh_solid)", s.chosen, s.solids)
                                               : fmt::format("{} solid{}{}", s.solids, s.solids == 1 ? "" : "s",
                                                             s.solids > 1 ? " (their union)" : "");
    return fmt::format("step        {}, {} faces, volume {:.6g} mm³ (exact), bounds ({:.4f}, {:.4f}, "
                       "{:.4f}) to ({:.4f}, {:.4f}, {:.4f}) mm\n"
                       "tessellated deflection {:.4g} mm, {:.3g} rad: {} triangles\n",
                       what, s.faces, s.volumeMm3, lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z(), t.linearDeflectionMm,
                       t.angularDeflectionRad, t.triangles) +
           treeText(s);
}

/// What the mesh file needed to be read as a solid (docs/part-program.md,
/// "Meshes as they come"); every count zero for a clean mesh.
nlohmann::json repairJson(const model::PartProgram& program)
{
    const model::MeshRepairReport& r = program.meshRepairReport;
    return {{"mode", enumName(program.meshRepair.mode)},
            {"gap_tolerance_mm", program.meshRepair.gapToleranceMm},
            {"repaired", !r.clean()},
            {"duplicate_faces", r.duplicateFaces},
            {"opposed_faces", r.opposedFaces},
            {"degenerate_faces", r.degenerateFaces},
            {"merged_vertices", r.mergedVertices},
            {"closed_edges", r.closedEdges},
            {"reoriented_faces", r.reorientedFaces},
            {"flipped_shells", r.flippedShells},
            {"self_intersections", r.selfIntersections},
            {"retriangulated_faces", r.retriangulatedFaces},
            {"autorefined_pairs", r.autorefinedPairs},
            {"volume_as_read_mm3", r.volumeAsReadMm3},
            {"volume_mm3", r.volumeMm3},
            {"repairs", r.items()}};
}

std::string repairText(const model::PartProgram& program)
{
    const model::MeshRepairReport& r = program.meshRepairReport;
    if (r.clean()) return "repaired    nothing (the mesh needed no repair)\n";
    std::string text = fmt::format("repaired    {} kind{} of defect (mesh_repair: {}):\n", r.items().size(),
                                   r.items().size() == 1 ? "" : "s", enumName(program.meshRepair.mode));
    for (const std::string& item : r.items()) text += "  " + item + "\n";
    return text;
}

int run(const CheckArgs& args)
{
    const std::string& partFile = args.part;
    const bool json = args.json;
    const model::PartProgram program = model::loadPartProgram(partFile);
    const auto capability = capabilityAt(program, args);
    const model::TriangleMesh& mesh = program.solid->mesh();
    const model::MeshCheck check = model::checkMesh(mesh);
    const auto& oct = program.octree;
    const auto bounds = mesh.bounds();

    if (json) {
        nlohmann::json out;
        out["part"] = program.part;
        out["mesh"] = {{"file", program.meshFile.string()},
                       {"vertices", mesh.vertices.size()},
                       {"triangles", mesh.triangles.size()},
                       {"volume_mm3", mesh.signedVolume()},
                       {"area_mm2", mesh.area()},
                       {"closed", check.ok()},
                       {"bounds_min", toJson(bounds.min())},
                       {"bounds_max", toJson(bounds.max())}};
        if (program.brep)
            out["step"] = stepJson(*program.brep);
        else
            out["mesh_repair"] = repairJson(program);
        out["octree"] = {{"cube_origin", toJson(oct.cubeOrigin)},
                         {"cube_size", oct.cubeSize},
                         {"cube_from_mesh", oct.cubeFromMesh},
                         {"depth", oct.depth},
                         {"adjacency_depth", oct.adjacencyDepth},
                         {"voxel_size_mm", oct.voxelSize()},
                         {"max_measurable_error_mm", oct.maxMeasurableErrorMm()}};
        out["surface_tolerance_mm"] = program.surfaceToleranceMm();
        out["landmarks"] = nlohmann::json::array();
        for (const auto& lm : program.landmarks) {
            out["landmarks"].push_back(
                {{"id", lm.id},
                 {"position", toJson(lm.position)},
                 {"normal", toJson(lm.normal)},
                 {"normal_from_mesh", lm.normalFromMesh},
                 {"on_brep", lm.onBRep},
                 {"distance_to_surface_mm", lm.distanceToSurfaceMm},
                 {"tolerance_mm", lm.toleranceMm},
                 {"limits_mm",
                  lm.limitsMm ? nlohmann::json{lm.limitsMm->first, lm.limitsMm->second} : nlohmann::json(nullptr)},
                 {"best_view_groups", lm.bestViews.size()}});
        }
        if (capability) {
            out["capability"] = nlohmann::json::array();
            for (const auto& c : *capability) out["capability"].push_back(inspect::toJson(c));
        }
        out["parameters"] = nlohmann::json::array();
        for (const auto& p : program.parameters)
            out["parameters"].push_back({{"id", p.id},
                                         {"kind", enumName(p.kind)},
                                         {"landmarks", p.landmarkIds},
                                         {"nominal_mm", p.nominalMm},
                                         {"tolerance_mm", p.toleranceMm}});
        std::cout << out.dump(2) << '\n';
        return 0;
    }

    std::cout << fmt::format("part        {}\n", program.part);
    std::cout << fmt::format("mesh        {}: {} triangles, {} vertices, closed 2-manifold, outward\n",
                             program.meshFile.string(), mesh.triangles.size(), mesh.vertices.size());
    std::cout << (program.brep ? stepText(*program.brep) : repairText(program));
    std::cout << fmt::format("volume      {:.6g} mm³, area {:.6g} mm²\n", mesh.signedVolume(), mesh.area());
    std::cout << fmt::format("bounds      ({:.4f}, {:.4f}, {:.4f}) to ({:.4f}, {:.4f}, {:.4f}) mm\n", bounds.min().x(),
                             bounds.min().y(), bounds.min().z(), bounds.max().x(), bounds.max().y(), bounds.max().z());
    std::cout << fmt::format("cube        origin ({:.4f}, {:.4f}, {:.4f}) size {:.6g} mm{}\n", oct.cubeOrigin.x(),
                             oct.cubeOrigin.y(), oct.cubeOrigin.z(), oct.cubeSize,
                             oct.cubeFromMesh ? (program.brep ? " (from the B-rep)" : " (from the mesh)") : "");
    std::cout << fmt::format("octree      depth {}, ΔV = {:.6g} mm (MAD), {} adjacency layers = {:.6g} mm measurable\n",
                             oct.depth, oct.voxelSize(), oct.adjacencyDepth, oct.maxMeasurableErrorMm());
    std::cout << fmt::format("landmarks   {} (on the surface within {:.3g} mm)\n", program.landmarks.size(),
                             program.surfaceToleranceMm());
    for (const auto& lm : program.landmarks)
        std::cout << fmt::format("  {:<16} at ({:.4f}, {:.4f}, {:.4f}) off {:.2e} mm, normal ({:.4f}, {:.4f}, {:.4f})"
                                 "{}, {}, {} best-view group{}\n",
                                 lm.id, lm.position.x(), lm.position.y(), lm.position.z(), lm.distanceToSurfaceMm,
                                 lm.normal.x(), lm.normal.y(), lm.normal.z(),
                                 lm.normalFromMesh ? (lm.onBRep ? " (B-rep)" : " (mesh)") : "", zoneText(lm),
                                 lm.bestViews.size(), lm.bestViews.size() == 1 ? "" : "s");
    std::cout << fmt::format("parameters  {}\n", program.parameters.size());
    for (const auto& p : program.parameters)
        std::cout << fmt::format("  {:<16} {} of {} landmarks, nominal {:.6g} ± {:.4g}\n", p.id, enumName(p.kind),
                                 p.landmarkIds.size(), p.nominalMm, p.toleranceMm);
    if (capability) {
        std::cout << fmt::format("capability  expected uncertainty (k = 2) at the {} views of {}:\n",
                                 geometry::loadPoses(args.views).size(), args.views);
        for (const auto& c : *capability) std::cout << "  " << inspect::describe(c) << '\n';
    }
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto* sub = app.add_subcommand("check-part", "validate a part program and summarise its mesh, cube and landmarks");
    auto args = std::make_shared<CheckArgs>();
    sub->add_option("--part", args->part, "part program YAML (docs/contracts.md §1)")->required();
    auto* station = sub->add_option("--station", args->station,
                                    "station file: also the expected uncertainty per landmark at --views");
    auto* views = sub->add_option("--views", args->views, "the view plan's poses file (with --station)");
    station->needs(views);
    views->needs(station);
    sub->add_flag("--json", args->json, "print the summary as JSON");
    return [args] { return run(*args); };
}

} // namespace

HG_REGISTER_COMMAND("check-part", factory);

} // namespace hg::cli
