// hullgauge inspect --part P.yaml|--map M.hgmap --views M.json [--out R.json]
// Goal-driven inspection of one captured part (docs/contracts.md §4, §5;
// docs/inspection.md). With --part the part's seat is measured first
// (docs/alignment.md); a map carries no CAD mesh, so --map inspects the part
// as drawn. Exit 0 when the part passes, 1 when it fails, 2 for bad input (a
// bad manifest, a missing image or one of the wrong size names the view), 3
// for a fault — a part seated beyond the program's alignment limits is one
// (the result, with its `alignment` object, is still written).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>

#include "command.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/inspect/program_inspector.h"
#include "hullgauge/vision/manifest.h"

namespace hg::cli {
namespace {

struct InspectArgs {
    std::string part;
    std::string map;
    std::string views;
    std::string out;
    int level = -1;
    int adjacency = -1;
    std::vector<std::string> mask;
    bool earlyExit = false;
    std::string method;
    bool noResolutionCheck = false;
    std::string alignment; ///< none | silhouette | datums; empty: the program's method
    bool force = false;    ///< inspect landmarks the capability check refuses (never ok then)
};

// The part program's `inspection` section (defaults with --map), each option
// given replacing its key (docs/inspection.md, "Which settings apply").
model::InspectionSettings withFlags(model::InspectionSettings s, const InspectArgs& args)
{
    if (args.level >= 0) s.level = args.level;
    if (args.adjacency >= 0) s.adjacency = args.adjacency;
    if (args.earlyExit) s.earlyExit = true;
    if (!args.method.empty()) s.centrePointTest = args.method == "centre";
    if (args.noResolutionCheck) s.requireResolution = false;
    return s;
}

// The part program's `alignment` section with --alignment replacing its method.
// Datums come from the program only: --alignment datums needs them there.
model::AlignmentSettings withFlag(model::AlignmentSettings s, const InspectArgs& args)
{
    if (args.alignment == "none") s.method = model::AlignmentMethod::None;
    if (args.alignment == "silhouette") s.method = model::AlignmentMethod::Silhouette;
    if (args.alignment == "datums") {
        if (s.datums.empty())
            throw InputError(args.part, "alignment.datums", "--alignment datums needs the program's datums");
        s.method = model::AlignmentMethod::Datums;
    }
    return s;
}

// The seating fault's line on stderr: what was measured against which limit.
std::string seatingFaultMessage(const std::optional<align::AlignmentResult>& measured,
                                const model::AlignmentSettings& limits)
{
    if (!measured) return "the part is not seated; nothing inspected, re-seat the part";
    const align::AlignmentResult& a = *measured;
    if (!a.measured) return a.message + "; nothing inspected, re-seat the part";
    return "the part is not seated: shift " + formatNumber(a.shiftMm, 4) + " mm (limit " +
           formatNumber(limits.maxShiftMm) + " mm), rotation " + formatNumber(a.rotationDeg, 4) + "° (limit " +
           formatNumber(limits.maxRotationDeg) + "°); nothing inspected, re-seat the part";
}

// The manifest's cameras, as the capability check judges the views it holds.
std::vector<geometry::CameraModel> manifestCameras(const vision::CaptureManifest& manifest)
{
    std::vector<geometry::CameraModel> cameras;
    for (const vision::ManifestView& v : manifest.views) cameras.push_back(v.camera);
    return cameras;
}

// The capability check at the manifest's views (docs/inspection.md,
// "Capability"): a landmark whose tolerance zone is narrower than 4 U is
// refused (exit 2) unless --force, which inspects it as never ok.
inspect::CapabilityCheck capabilityCheck(std::vector<inspect::LandmarkCapability> assessment, const InspectArgs& args)
{
    return {std::move(assessment), args.force, "--force"};
}

std::vector<inspect::CapturedView> readViews(const vision::CaptureManifest& manifest, const InspectArgs& args)
{
    std::vector<inspect::CapturedView> views;
    for (std::size_t i = 0; i < manifest.views.size(); ++i) {
        const vision::ManifestView& mv = manifest.views[i];
        cv::Mat frame = vision::readViewImage(manifest, i);
        // A region image (manifest `origin`) keeps the sensor's camera; a whole image sizes it.
        geometry::Intrinsics in = mv.camera.intrinsics();
        if (!mv.origin) in.imageSize = frame.size();
        views.push_back({mv.id, geometry::CameraModel(in, mv.camera.cameraFromPart()), std::move(frame),
                         mv.origin.value_or(cv::Point(0, 0))});
    }
    if (views.empty()) throw InputError(args.views, "views", "no views");
    return views;
}

// The inspector: with --part the one the daemon configures for the program
// (inspect::makeProgramInspector), the flags replacing their keys; with
// --map the map as built, the flags over the defaults, no seat and no gauge
// (a map carries no CAD solid: its landmarks are judged on the voxel bracket).
inspect::ProgramInspector configure(const vision::CaptureManifest& manifest, const InspectArgs& args,
                                    model::AlignmentSettings& alignment)
{
    const geometry::ImageQuality quality = manifest.imageQuality.value_or(geometry::ImageQuality{});
    if (!args.part.empty()) {
        model::PartProgram program = model::loadPartProgram(args.part);
        program.alignment = alignment = withFlag(program.alignment, args);
        program.inspection = withFlags(program.inspection, args);
        // The budget's calibration term is the station's, which the manifest carries (docs/inspection.md).
        auto assessment = inspect::assessProgram(program, manifest.calibration, manifestCameras(manifest), quality);
        return inspect::makeProgramInspector(
            program, {manifest.calibration, capabilityCheck(std::move(assessment), args)}, args.mask);
    }
    inspect::ProgramInspector p;
    p.map = std::make_unique<const inspect::InspectionMap>(inspect::InspectionMap::load(args.map));
    const model::InspectionSettings settings = withFlags({}, args);
    const int level = settings.level < 0 ? p.map->geometry().depth : settings.level;
    auto assessment = inspect::assessCapability(p.map->landmarks(), p.map->frame().voxelSize(level), nullptr,
                                                manifestCameras(manifest), quality);
    p.setup = inspect::setUpInspection(settings, capabilityCheck(std::move(assessment), args), args.mask, args.map);
    p.inspector = std::make_unique<inspect::Inspector>(*p.map, p.setup.options);
    return p;
}

int run(const InspectArgs& args)
{
    const Stopwatch watch;
    const vision::CaptureManifest manifest = vision::readManifest(args.views);
    const std::vector<inspect::CapturedView> views = readViews(manifest, args);
    model::AlignmentSettings alignment;
    inspect::ProgramInspector p;
    try {
        p = configure(manifest, args, alignment);
    } catch (const ArgumentError& e) {
        // Options the map cannot serve came from these files and flags: bad input (docs/style.md point 4).
        throw InputError(args.map.empty() ? args.part : args.map, "inspection options", e.what());
    }
    if (!p.setup.forced.empty())
        std::cerr << "hullgauge inspect: --force: inspecting landmarks this station cannot prove (never ok): "
                  << inspect::describe(p.setup.forced) << "\n";
    inspect::InspectionResult result;
    try {
        result = p.inspector->inspect(views, manifest.segmentation);
    } catch (const ArgumentError& e) {
        throw InputError(args.views, "views", e.what());
    }
    result.totalTime = watch.elapsed();

    const std::string text = inspect::toJson(result).dump(2) + "\n";
    if (args.out.empty()) {
        std::cout << text;
    } else {
        std::ofstream f(args.out);
        f << text;
        if (!f) throw FaultError("cannot write " + args.out);
    }
    if (result.seatingFault) {
        std::cerr << "hullgauge inspect: " << result.part
                  << ": seating fault: " << seatingFaultMessage(result.alignment, alignment) << "\n";
        return static_cast<int>(ExitStatus::Fault);
    }
    int failed = 0;
    for (const auto& l : result.landmarks)
        if (l.status != inspect::LandmarkStatus::Ok) ++failed;
    std::cerr << "hullgauge inspect: " << result.part << ": " << (result.pass ? "pass" : "fail") << " ("
              << result.landmarks.size() - static_cast<std::size_t>(failed) << "/" << result.landmarks.size()
              << " landmarks ok, " << result.voxelsReconstructed << " voxels reconstructed)\n";
    return result.pass ? 0 : static_cast<int>(ExitStatus::PartFails);
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<InspectArgs>();
    auto* cmd = app.add_subcommand("inspect", "goal-driven inspection of one captured part");
    auto* part = cmd->add_option("--part", args->part, "part program (YAML)");
    auto* map = cmd->add_option("--map", args->map, "inspection map built by 'hullgauge build-map'");
    part->excludes(map);
    map->excludes(part);
    cmd->add_option("--views", args->views, "capture manifest (JSON, docs/contracts.md §3)")->required();
    cmd->add_option("--out", args->out, "result JSON (default: stdout)");
    // Each option replaces the part program's `inspection` key of the same meaning.
    cmd->add_option("--level", args->level, "octree level to inspect at (default: inspection.level, else the depth)");
    cmd->add_option("--adjacency", args->adjacency, "type-four layers to search (default: inspection.adjacency)");
    cmd->add_option("--mask", args->mask, "landmark ids to leave out")->delimiter(',');
    cmd->add_flag("--early-exit", args->earlyExit, "stop at the first landmark that is not ok");
    cmd->add_option("--method", args->method,
                    "voxel test: volume (volume source) or centre (centre point); default: inspection.method")
        ->check(CLI::IsMember({"volume", "centre"}));
    cmd->add_flag("--no-resolution-check", args->noResolutionCheck,
                  "do not require a view that resolves ΔV (eq. 4.4.4-19) per landmark");
    cmd->add_flag(
        "--force", args->force,
        "inspect landmarks whose tolerance zone is narrower than 4 U at these views (they are then never ok)");
    cmd->add_option("--alignment", args->alignment,
                    "how the seat is measured: none, silhouette or datums; default: alignment.method (--part only)")
        ->check(CLI::IsMember({"none", "silhouette", "datums"}));
    return [args] {
        if (args->part.empty() == args->map.empty())
            throw InputError("", "--part/--map", "give exactly one of --part and --map");
        if (!args->alignment.empty() && args->part.empty())
            throw InputError("", "--alignment", "--alignment needs --part: a map has no CAD mesh to align");
        return run(*args);
    };
}

HG_REGISTER_COMMAND("inspect", factory);

} // namespace
} // namespace hg::cli
