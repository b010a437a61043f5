// Whole-object reconstruction against Open3D (benchmark (d), docs/inspection.md):
// `reconstruct` (octree, volume-source test, 50 % rule) and Open3D's
// VoxelGrid::CarveSilhouette on a dense grid, at equal resolution and with the
// same 16 views of the block (bench_scene.h). Both report wall time and the
// voxels disagreeing with the true solid (a voxel is truly object when >= 50 %
// of it lies inside the block). Open3D keeps a voxel when any of its 8
// corners projects onto a silhouette pixel (bilinear), so it errs outward.
#include <benchmark/benchmark.h>

#include <open3d/camera/PinholeCameraParameters.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/VoxelGrid.h>

#include "bench_scene.h"
#include "hullgauge/inspect/reconstruct.h"

using namespace hg::inspect;
using namespace hgbench;

namespace {

struct Open3dView {
    open3d::geometry::Image mask;
    open3d::camera::PinholeCameraParameters camera;
};

std::vector<Open3dView> open3dViews(const std::vector<CapturedView>& frames)
{
    std::vector<Open3dView> out;
    for (const auto& f : frames) {
        const cv::Mat sil = hg::vision::segment(f.frame, {});
        Open3dView v;
        v.mask.Prepare(sil.cols, sil.rows, 1, 4); // FloatValueAt needs a float image
        for (int r = 0; r < sil.rows; ++r)
            for (int c = 0; c < sil.cols; ++c)
                *v.mask.PointerAt<float>(c, r) = sil.at<std::uint8_t>(r, c) ? 1.0f : 0.0f;
        const Eigen::Matrix3d K = f.camera.intrinsics().K;
        v.camera.intrinsic_.SetIntrinsics(sil.cols, sil.rows, K(0, 0), K(1, 1), K(0, 2), K(1, 2));
        Eigen::Matrix4d e = Eigen::Matrix4d::Identity();
        e.block<3, 3>(0, 0) = f.camera.cameraFromPart().R;
        e.block<3, 1>(0, 3) = f.camera.cameraFromPart().t;
        v.camera.extrinsic_ = e;
        out.push_back(std::move(v));
    }
    return out;
}

void BM_Open3dCarveSilhouette(benchmark::State& state)
{
    const int depth = static_cast<int>(state.range(0));
    static const auto frames = carvingViews({1224, 1024});
    static const auto views = open3dViews(frames);
    const double dv = kCubeSize / (1 << depth);
    // Voxel (0,0,0) of a fresh grid must sit at the cube's corner, or the
    // comparison is off.
    const auto fresh = open3d::geometry::VoxelGrid::CreateDense(kCubeOrigin, Eigen::Vector3d(1, 1, 1), dv, kCubeSize,
                                                                kCubeSize, kCubeSize);
    const Eigen::Vector3d c0 = fresh->GetVoxelCenterCoordinate(Eigen::Vector3i(0, 0, 0));
    if ((c0 - (kCubeOrigin + Eigen::Vector3d::Constant(dv / 2))).norm() > 1e-9) {
        const std::string msg = "Open3D dense grid is not aligned with the part cube: voxel 0 centre at " +
                                std::to_string(c0.x()) + " " + std::to_string(c0.y()) + " " + std::to_string(c0.z());
        state.SkipWithError(msg.c_str());
        return;
    }
    std::shared_ptr<open3d::geometry::VoxelGrid> grid;
    for (auto _ : state) {
        grid = open3d::geometry::VoxelGrid::CreateDense(kCubeOrigin, Eigen::Vector3d(1, 1, 1), dv, kCubeSize, kCubeSize,
                                                        kCubeSize);
        for (const auto& v : views) grid->CarveSilhouette(v.mask, v.camera, false);
        benchmark::DoNotOptimize(grid->voxels_.size());
    }
    DenseGrid kept(depth);
    for (const auto& [index, voxel] : grid->voxels_) {
        const Eigen::Vector3i& g = voxel.grid_index_;
        if ((g.array() >= 0).all() && (g.array() < kept.n).all()) kept.set(g);
    }
    const Disagreement d = compareWithTruth(kept);
    state.counters["views"] = static_cast<double>(views.size());
    state.counters["volume_mm3"] = static_cast<double>(d.object) * dv * dv * dv;
    state.counters["wrong_extra"] = static_cast<double>(d.extra);
    state.counters["wrong_missing"] = static_cast<double>(d.missing);
}
BENCHMARK(BM_Open3dCarveSilhouette)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
