// Inspection benchmarks (Google Benchmark; tools/bench prints the table):
//  - BM_InspectGoalDriven/64 landmarks x 8 views of 2448x2048 frames, ROI
//    segmentation included (target <= 5 ms on one core);
//  - BM_DenseVoxelTest: the same voxel test applied to voxels of the whole
//    cube; its counter `full_cube_s` extrapolates dense carving at ΔV to all
//    8^depth voxels, for the goal-driven/dense ratio;
//  - BM_ReconstructOctree: whole-object octree reconstruction (hullgauge
//    reconstruct) at depth 7;
//  - BM_VoxelTestAccuracy/<method>: mean |error_mm − true offset| over the
//    landmarks of a face raised by 0.2 mm, volume source against centre point.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "hullgauge/inspect/inspector.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/inspect/reconstruct.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/model/solid.h"
#include "hullgauge/sim/renderer.h"

using namespace hg::inspect;

namespace {

constexpr double kTop = 20.0;

hg::geometry::CameraModel lookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward, cv::Size size)
{
    const Eigen::Vector3d down(0, 0, -1);
    Eigen::Matrix3d R;
    R.row(0) = down.cross(forward).transpose();
    R.row(1) = down.transpose();
    R.row(2) = forward.transpose();
    hg::geometry::Intrinsics in;
    in.K << 3500, 0, (size.width - 1) / 2.0, 0, 3500, (size.height - 1) / 2.0, 0, 0, 1;
    in.imageSize = size;
    return {in, {R, -R * centre}};
}

/// A 40 x 40 x 20 mm block; `n` x `n` landmarks on its top face; views in the
/// face's tangent plane (grazing) from `views` directions around it.
struct Scene {
    InspectionMap map;
    std::vector<CapturedView> frames;

    Scene(int n, int views, cv::Size size, double raise, int depth = 9)
    {
        auto solid = std::make_shared<const hg::model::Solid>(hg::model::makeBox({0, 0, 0}, {40, 40, kTop}));
        MapGeometry g;
        g.cubeOrigin = Eigen::Vector3d(-12, -12, -22);
        g.cubeSize = 64.0;
        g.depth = depth;  // ΔV = 0.125 mm at depth 9
        g.adjacencyDepth = 4;
        g.coarsestLevel = depth;
        std::vector<MapLandmark> lms;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                lms.push_back({"l" + std::to_string(i * n + j),
                               Eigen::Vector3d(5.0 + 30.0 * i / std::max(1, n - 1), 5.0 + 30.0 * j / std::max(1, n - 1), kTop),
                               Eigen::Vector3d::UnitZ(), 0.3});
        map = InspectionMap::build("block", g, lms, {}, cadLabels(solid));
        hg::sim::SilhouetteRenderer r({hg::model::makeBox({0, 0, 0}, {40, 40, kTop + raise})});
        for (int v = 0; v < views; ++v) {
            const double a = 2 * M_PI * v / views;
            const Eigen::Vector3d dir(std::cos(a), std::sin(a), 0);
            const auto cam = lookAt(Eigen::Vector3d(20, 20, kTop) + 400 * dir, -dir, size);
            frames.push_back({"v" + std::to_string(v), cam, r.render(cam)});
        }
    }
};

void BM_InspectGoalDriven(benchmark::State& state)
{
    static const Scene scene(8, 8, {2448, 2048}, 0.0);
    const Inspector inspector(scene.map);
    const hg::vision::SegmentationSettings seg;
    InspectionResult r;
    for (auto _ : state) {
        r = inspector.inspect(scene.frames, seg);
        benchmark::DoNotOptimize(r.pass);
    }
    state.counters["landmarks"] = static_cast<double>(r.landmarks.size());
    state.counters["views"] = static_cast<double>(scene.frames.size());
    state.counters["voxel_tests"] = static_cast<double>(r.voxelsReconstructed);
    state.counters["pass"] = r.pass ? 1 : 0;
}
BENCHMARK(BM_InspectGoalDriven)->Unit(benchmark::kMillisecond);

void BM_DenseVoxelTest(benchmark::State& state)
{
    static const Scene scene(2, 8, {2448, 2048}, 0.0);
    std::vector<SilhouetteView> views;
    for (const auto& f : scene.frames)
        views.push_back({f.camera, SilhouetteIndex::fromSilhouette(hg::vision::segment(f.frame, {}))});
    const VoxelTester tester(&views);
    const int depth = 9;
    const double dv = 64.0 / (1 << depth);
    // Voxels along a diagonal band through the part (a mix of object and void).
    std::uint64_t i = 0;
    for (auto _ : state) {
        const double u = static_cast<double>(i++ % 4096) / 4096.0;
        const Eigen::Vector3d lo = Eigen::Vector3d(-12, -12, -22) + u * Eigen::Vector3d(64 - dv, 64 - dv, 64 - dv);
        benchmark::DoNotOptimize(tester.classify(Box3(lo, lo + Eigen::Vector3d::Constant(dv))));
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["full_cube_voxels"] = std::pow(8.0, depth);
    // time per voxel test × 8^depth: seconds to carve every voxel of the cube.
    state.counters["full_cube_s"] = benchmark::Counter(
        1.0 / std::pow(8.0, depth), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_DenseVoxelTest);

void BM_ReconstructOctree(benchmark::State& state)
{
    static const Scene scene(1, 8, {1224, 1024}, 0.0);
    std::vector<SilhouetteView> views;
    for (const auto& f : scene.frames)
        views.push_back({f.camera, SilhouetteIndex::fromSilhouette(hg::vision::segment(f.frame, {}))});
    HullReconstruction h;
    for (auto _ : state) {
        h = reconstructHull(views, Eigen::Vector3d(-12, -12, -22), 64.0, 7);
        benchmark::DoNotOptimize(h.objectVoxels);
    }
    state.counters["volume_mm3"] = h.volumeMm3();
    state.counters["footprints"] = static_cast<double>(h.footprintsMeasured);
}
BENCHMARK(BM_ReconstructOctree)->Unit(benchmark::kMillisecond);

void BM_VoxelTestAccuracy(benchmark::State& state)
{
    const auto method = state.range(0) == 0 ? VoxelTestMethod::VolumeSource : VoxelTestMethod::CentrePoint;
    static const Scene scene(5, 4, {1224, 1024}, 0.2);
    InspectionOptions o;
    o.method = method;
    const Inspector inspector(scene.map, o);
    InspectionResult r;
    for (auto _ : state) r = inspector.inspect(scene.frames, {});
    double err = 0.0;
    for (const auto& l : r.landmarks) err += l.measured ? std::abs(l.errorMm - 0.2) : 1.0;
    state.SetLabel(method == VoxelTestMethod::VolumeSource ? "volume_source" : "centre_point");
    state.counters["mean_abs_error_mm"] = err / static_cast<double>(r.landmarks.size());
}
BENCHMARK(BM_VoxelTestAccuracy)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
