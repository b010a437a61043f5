// hullgauge simulate --mesh M.stl [--mesh D.stl ...] [--subtract C.stl ...]
//                    --station S.yaml --poses poses.yaml --out DIR
//                    [--noise SIGMA] [--blur SIGMA] [--seed N] [--bit-depth 8|16] [--subsamples N]
//                    [--seat "dx,dy,dz,rx,ry,rz"]
// Renders backlit views of the part (the union of the --mesh solids, each
// minus every --subtract solid) at the fixture poses and writes v0.png,
// v1.png, ... and DIR/manifest.json (docs/contracts.md §3, §5) with K, dist, R, t and
// the fixture pose of every view. One summary line per view on stdout; the
// progress on stderr.
//
// --seat renders the part seated off its nominal place while the manifest
// keeps the nominal cameras, as a real nest does: the inspection has to find
// the seat (docs/alignment.md). The seat is nominal_from_part, the definition
// of the result's `alignment`: a part point X lies at R·X + t, with R the
// rotation rz about z · ry about y · rx about x (degrees, the part's axes)
// about the centre c of the rendered meshes' bounding box, then the shift d:
// R·X + t = R (X − c) + c + d. The manifest records it under "simulation".
#include "command.h"
#include "hullgauge/align/alignment.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/sim/renderer.h"
#include "hullgauge/vision/manifest.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

struct SimulateArgs {
    std::vector<std::string> meshes;
    std::vector<std::string> subtract;
    std::string station;
    std::string poses;
    std::string out;
    double noise = 0.0;
    double blur = 0.0;
    std::uint64_t seed = 0;
    int bitDepth = 8;
    int subsamples = 16;
    std::vector<double> seat; ///< dx, dy, dz (mm), rx, ry, rz (degrees); empty: as drawn
};

/// The --seat transform (nominal_from_part) about the bounding-box centre `c`.
geometry::RigidTransform seatFromArgs(const std::vector<double>& v, const geometry::Vec3& c)
{
    using Eigen::AngleAxisd;
    const geometry::Mat3 R = (AngleAxisd(geometry::degToRad(v[5]), geometry::Vec3::UnitZ()) *
                              AngleAxisd(geometry::degToRad(v[4]), geometry::Vec3::UnitY()) *
                              AngleAxisd(geometry::degToRad(v[3]), geometry::Vec3::UnitX()))
                                 .toRotationMatrix();
    const geometry::Vec3 d(v[0], v[1], v[2]);
    return {R, c + d - R * c};
}

/// The part to render: every --mesh solid minus every --subtract solid.
/// (A ∪ B) − C = (A − C) ∪ (B − C), and the renderer draws the union, so the
/// differences are taken mesh by mesh.
std::vector<model::TriangleMesh> loadPart(const SimulateArgs& args)
{
    std::vector<model::TriangleMesh> cutters;
    for (const auto& file : args.subtract) cutters.push_back(model::loadMesh(file));
    std::vector<model::TriangleMesh> part;
    for (const auto& file : args.meshes) {
        model::TriangleMesh mesh = model::loadMesh(file);
        for (std::size_t i = 0; i < cutters.size(); ++i) {
            mesh = model::difference(mesh, cutters[i]);
            if (mesh.empty()) {
                log::category("sim")->warn("{} minus {} leaves nothing", file, args.subtract[i]);
                break;
            }
        }
        if (!mesh.empty()) part.push_back(std::move(mesh));
    }
    return part;
}

std::string summary(const std::string& id, const std::string& pose, const sim::CoverageStats& s)
{
    std::ostringstream line;
    line << id << ": " << pose << ": object area " << std::fixed << std::setprecision(1) << s.areaPx << " px";
    if (s.boundingBox.empty()) {
        line << ", not in view";
    } else {
        const cv::Rect& b = s.boundingBox;
        line << ", bounding box x " << b.x << ".." << b.x + b.width - 1 << ", y " << b.y << ".." << b.y + b.height - 1;
        if (s.touchesBorder) line << " (cut by the image border)";
    }
    return line.str();
}

int run(const SimulateArgs& args)
{
    const geometry::Station station = geometry::loadStation(args.station);
    const std::vector<geometry::FixturePose> poses = geometry::loadPoses(args.poses, &station.fixture);
    if (poses.empty()) throw InputError(args.poses, "", "no poses: expected a list of fixture poses");

    sim::RenderOptions options;
    options.subScanlines = args.subsamples;
    options.bitDepth = args.bitDepth;
    options.noiseSigma = args.noise;
    options.blurSigmaPx = args.blur;

    const std::vector<model::TriangleMesh> part = loadPart(args);
    std::size_t triangles = 0;
    for (const auto& m : part) triangles += m.triangles.size();
    const sim::SilhouetteRenderer renderer(part);
    Eigen::AlignedBox3d bounds;
    for (const auto& m : part) bounds.extend(m.bounds());
    const geometry::RigidTransform seat =
        args.seat.empty() ? geometry::RigidTransform::identity() : seatFromArgs(args.seat, bounds.center());

    const fs::path outDir = args.out;
    std::error_code ec;
    fs::create_directories(outDir, ec);
    if (ec || !fs::is_directory(outDir)) throw InputError("", "--out", "cannot create folder '" + args.out + "'");

    std::cerr << "hullgauge simulate: " << poses.size() << " views of " << part.size() << " mesh(es), " << triangles
              << " triangles, " << station.camera.imageSize.width << "x" << station.camera.imageSize.height << " px\n";

    vision::CaptureManifest manifest;
    // What the frames are made with: the capability check and the budget
    // read the station's records and image quality from the manifest
    // (docs/inspection.md); the noise no lower than 8-bit quantisation's.
    manifest.calibration = station.calibration;
    const double full = args.bitDepth == 16 ? 65535.0 : 255.0;
    manifest.imageQuality = geometry::ImageQuality{std::max(options.noiseSigma, 1.0 / std::sqrt(12.0)),
                                                   (options.backgroundLevel - options.objectLevel) * full, true};
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const std::string id = "v" + std::to_string(i);
        const geometry::CameraModel camera = station.cameraAt(poses[i]);
        // The part is seen seated; the manifest gets the nominal camera.
        const cv::Mat coverage = renderer.coverage(align::seatedCamera(camera, seat), options);
        // Each view gets its own noise stream, reproducible from --seed.
        sim::RenderOptions viewOptions = options;
        viewOptions.seed = args.seed + i;
        const cv::Mat image = sim::shadeCoverage(coverage, viewOptions);
        const fs::path file = outDir / (id + ".png");
        if (!cv::imwrite(file.string(), image)) throw FaultError("cannot write image " + file.string());

        const sim::CoverageStats stats = sim::measureCoverage(coverage);
        std::cout << summary(id, fmt::format("{}", geometry::PoseOn{poses[i], station.fixture.type}), stats)
                  << std::endl;

        vision::ManifestView view;
        view.id = id;
        view.image = file;
        view.camera = camera;
        view.fixturePose = vision::ManifestFixturePose{station.fixture.type, poses[i]};
        manifest.views.push_back(std::move(view));
    }
    const fs::path manifestFile = outDir / "manifest.json";
    if (args.seat.empty()) {
        vision::writeManifest(manifest, manifestFile);
    } else {
        nlohmann::json j = parseJson(vision::manifestJson(manifest, outDir), manifestFile.string());
        // The manifest's "simulation" extension: the true seat the part was rendered with.
        j["simulation"] = {{"seat", align::seatJson(seat, bounds.center())}};
        std::ofstream f(manifestFile);
        f << j.dump(2) << '\n';
        if (!f) throw FaultError("cannot write " + manifestFile.string());
    }
    std::cerr << "hullgauge simulate: wrote " << manifestFile.string() << '\n';
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<SimulateArgs>();
    auto* cmd = app.add_subcommand("simulate", "render backlit views of a CAD part at fixture poses, with a manifest");
    cmd->add_option("--mesh", args->meshes, "CAD mesh (STL, OBJ, PLY); repeat to render the union of several")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--subtract", args->subtract, "mesh to cut from every --mesh (CSG difference); repeatable")
        ->check(CLI::ExistingFile);
    cmd->add_option("--station", args->station, "station description (YAML)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--poses", args->poses, "fixture poses (YAML list)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--out", args->out, "output folder for v0.png, v1.png, ... and manifest.json")->required();
    cmd->add_option("--noise", args->noise, "sensor noise: Gaussian sigma in grey levels of the output depth")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    cmd->add_option("--blur", args->blur, "optics blur: Gaussian sigma in pixels")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    cmd->add_option("--seed", args->seed, "noise seed (view i uses seed + i)")->capture_default_str();
    cmd->add_option("--bit-depth", args->bitDepth, "8 or 16 bit PNG")
        ->check(CLI::IsMember({8, 16}))
        ->capture_default_str();
    cmd->add_option("--subsamples", args->subsamples, "sub-scanlines per pixel row (vertical anti-aliasing)")
        ->check(CLI::Range(4, 256))
        ->capture_default_str();
    cmd->add_option("--seat", args->seat,
                    "render the part seated off nominal: dx,dy,dz (mm), rx,ry,rz (degrees) about the bounding-box "
                    "centre; the manifest keeps the nominal cameras")
        ->delimiter(',')
        ->expected(6);
    return [args] { return run(*args); };
}

HG_REGISTER_COMMAND("simulate", factory);

} // namespace
} // namespace hg::cli
