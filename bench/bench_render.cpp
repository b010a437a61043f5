// Silhouette renderer speed: a 2448 x 2048 view (5 MP GigE camera) of a
// ~10k-triangle part, as the simulated camera renders it for every frame of
// the simulated line. Target: well under a second on one core.
#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/sim/renderer.h"

#include <benchmark/benchmark.h>

namespace {

using hg::geometry::CameraModel;
using hg::geometry::Intrinsics;
using hg::geometry::RigidTransform;
using hg::geometry::Vec3;

CameraModel stationCamera(bool distorted)
{
    // 12 mm lens on 3.45 µm pixels, part 300 mm away.
    Intrinsics in;
    in.K << 3478.0, 0, 1223.5, 0, 3478.0, 1023.5, 0, 0, 1;
    if (distorted) in.dist = {-0.12, 0.08, 0.0005, -0.0003, -0.01};
    in.imageSize = {2448, 2048};
    RigidTransform pose = RigidTransform::rotation(Vec3(1.0, 0.4, 0.2), 35.0);
    pose.t = Vec3(2.0, -3.0, 300.0);
    return CameraModel(in, pose);
}

/// A part of ~10k triangles: a 9.8k-triangle sphere (100 x 50) on a box base.
hg::sim::SilhouetteRenderer part()
{
    return hg::sim::SilhouetteRenderer({hg::model::makeSphere(Vec3(0, 0, 20), 40.0, 100, 50),
                                        hg::model::makeBox(Vec3(-50, -30, -20), Vec3(50, 30, 0))});
}

void BM_Coverage(benchmark::State& state)
{
    const auto renderer = part();
    const CameraModel camera = stationCamera(state.range(0) != 0);
    hg::sim::RenderOptions options;
    options.subScanlines = static_cast<int>(state.range(1));
    for (auto _ : state) benchmark::DoNotOptimize(renderer.coverage(camera, options));
    state.SetLabel(state.range(0) != 0 ? "distorted" : "pinhole");
}
BENCHMARK(BM_Coverage)->Args({0, 16})->Args({0, 4})->Args({1, 16})->Unit(benchmark::kMillisecond);

void BM_RenderWithBlurAndNoise(benchmark::State& state)
{
    const auto renderer = part();
    const CameraModel camera = stationCamera(false);
    hg::sim::RenderOptions options;
    options.blurSigmaPx = 0.8;
    options.noiseSigma = 2.0;
    for (auto _ : state) benchmark::DoNotOptimize(renderer.render(camera, options));
}
BENCHMARK(BM_RenderWithBlurAndNoise)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
