// hullgauge reconstruct --views M.json --cube X Y Z SIZE --depth D --out hull.ply [--stats S.json]
// Whole-object octree reconstruction with the same volume-source voxel test as
// the inspection (docs/contracts.md §5). The PLY holds one vertex per object octree
// node: its centre and its edge length (`size`, mm) — nodes decided whole at a
// coarse level are not split into finest voxels. S.json: object_voxels (finest
// level), volume_mm3, undecided_voxels, voxel_size_mm, object_nodes,
// footprints_measured, time_ms.
#include <array>
#include <chrono>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>

#include "command.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/inspect/reconstruct.h"
#include "hullgauge/vision/manifest.h"

namespace hg::cli {
namespace {

struct ReconstructArgs {
    std::string views;
    std::vector<double> cube;
    int depth = 7;
    std::string out;
    std::string stats;
    std::string method = "volume";
};

int run(const ReconstructArgs& args)
{
    const Stopwatch watch;
    if (args.cube.size() != 4) throw InputError("", "--cube", "expected X Y Z SIZE");
    if (!(args.cube[3] > 0.0)) throw InputError("", "--cube", "SIZE must be positive");
    const vision::CaptureManifest manifest = vision::readManifest(args.views);
    std::vector<inspect::SilhouetteView> views;
    for (std::size_t i = 0; i < manifest.views.size(); ++i) {
        const cv::Mat frame = vision::readViewImage(manifest, i);
        const vision::ManifestView& mv = manifest.views[i];
        geometry::Intrinsics in = mv.camera.intrinsics();
        const cv::Mat silhouette = vision::segment(frame, manifest.segmentation);
        if (!mv.origin) {
            in.imageSize = frame.size();
            views.push_back({geometry::CameraModel(in, mv.camera.cameraFromPart()),
                             inspect::SilhouetteIndex::fromSilhouette(silhouette)});
            continue;
        }
        // A region image (manifest `origin`): the sensor outside it is unknown to the voxel test.
        inspect::SilhouetteIndex index(in.imageSize);
        index.addRegion(cv::Rect(*mv.origin, frame.size()), silhouette);
        views.push_back({geometry::CameraModel(in, mv.camera.cameraFromPart()), std::move(index)});
    }
    if (views.empty()) throw InputError(args.views, "views", "no views");
    const auto hull = inspect::reconstructHull(
        views, {Eigen::Vector3d(args.cube[0], args.cube[1], args.cube[2]), args.cube[3], args.depth},
        args.method == "centre" ? inspect::VoxelTestMethod::CentrePoint : inspect::VoxelTestMethod::VolumeSource);

    std::ofstream ply(args.out);
    ply << "ply\nformat ascii 1.0\ncomment hullgauge reconstruct: object octree nodes (centre, edge mm)\n"
        << "element vertex " << hull.objectNodes.size() << "\nproperty float x\nproperty float y\nproperty float z\n"
        << "property float size\nend_header\n";
    for (const auto& n : hull.objectNodes) {
        const auto b = hull.box(n);
        const Eigen::Vector3d c = b.center();
        ply << c.x() << ' ' << c.y() << ' ' << c.z() << ' ' << b.sizes().x() << '\n';
    }
    if (!ply) throw FaultError("cannot write " + args.out);
    const double ms = watch.ms();
    const nlohmann::json stats{{"object_voxels", hull.objectVoxels},
                               {"volume_mm3", hull.volumeMm3()},
                               {"undecided_voxels", hull.undecidedVoxels},
                               {"voxel_size_mm", hull.voxelSize()},
                               {"object_nodes", hull.objectNodes.size()},
                               {"footprints_measured", hull.footprintsMeasured},
                               {"views_used", views.size()},
                               {"time_ms", ms}};
    if (!args.stats.empty()) {
        std::ofstream s(args.stats);
        s << stats.dump(2) << '\n';
        if (!s) throw FaultError("cannot write " + args.stats);
    }
    std::cerr << "hullgauge reconstruct: " << hull.objectVoxels << " object voxels, " << hull.volumeMm3() << " mm3\n";
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<ReconstructArgs>();
    auto* cmd = app.add_subcommand("reconstruct", "whole-object octree reconstruction (volume-source voxel test)");
    cmd->add_option("--views", args->views, "capture manifest (JSON)")->required();
    cmd->add_option("--cube", args->cube, "cube low corner X Y Z and edge SIZE, mm")->required()->expected(4);
    cmd->add_option("--depth", args->depth, "octree depth (voxel = SIZE / 2^depth)")
        ->check(CLI::Range(0, 12))
        ->capture_default_str();
    cmd->add_option("--out", args->out, "PLY of the object octree nodes")->required();
    cmd->add_option("--stats", args->stats, "statistics JSON");
    cmd->add_option("--method", args->method, "voxel test: volume or centre")
        ->check(CLI::IsMember({"volume", "centre"}))
        ->capture_default_str();
    return [args] { return run(*args); };
}

HG_REGISTER_COMMAND("reconstruct", factory);

} // namespace
} // namespace hg::cli
