// The station health monitor's cost per cycle (docs/health.md, "Cost"):
//  - BM_HealthCycle8Views/regions:<0|1>: one cycle of 8 views of a 1280 x 1024
//    8-bit sensor — whole frames, or the 400 x 300 regions around the part a
//    daemon with `camera.regions` delivers — 6 edge probes per view, with a
//    flat-field reference: background samples, one band of the dust survey
//    (the band moves on every iteration, as it does every cycle), the edge
//    profiles. Target: <= 0.2 ms;
//  - BM_FindEdge8Views/regions:<0|1>: the baseline in the same run, findEdge
//    at the same 48 probes, what the inspection already pays per landmark edge;
//  - BM_CapabilityUsed/landmarks:<N>: the capability figure of a cycle
//    (docs/health.md, "Capability"): N landmarks of a program, 8 planned views
//    each, every view's noise term scaled and the views combined again.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

#include "hullgauge/inspect/capability.h"
#include "hullgauge/vision/edge.h"
#include "hullgauge/vision/health.h"

using namespace hg::vision;

namespace {

const cv::Size kSensor{1280, 1024};

// A vignetted backlight with noise σ = 1.5 grey levels.
cv::Mat backlight(std::uint64_t seed)
{
    cv::Mat light(kSensor, CV_32FC1);
    for (int y = 0; y < kSensor.height; ++y)
        for (int x = 0; x < kSensor.width; ++x) {
            const double dx = (x - 640.0) / 820.0, dy = (y - 512.0) / 820.0;
            light.at<float>(y, x) = static_cast<float>(200.0 * (1.0 - 0.3 * (dx * dx + dy * dy)));
        }
    cv::Mat noise(kSensor, CV_32FC1);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.5);
    cv::Mat grey;
    cv::Mat(light + noise).convertTo(grey, CV_8UC1);
    return grey;
}

// The views of one cycle: the part (a disc of radius 110 px, grey 30) at
// another place in each, blurred σ = 1 px, a few specks of dust on the light.
struct Cycle {
    FlatField reference;
    std::vector<EdgeImage> views;
    std::vector<std::vector<EdgeProbe>> probes;
};

Cycle cycleOf(bool regions)
{
    Cycle out;
    std::vector<cv::Mat> empty;
    for (std::uint64_t i = 0; i < 4; ++i) empty.push_back(backlight(100 + i));
    out.reference = buildFlatField(empty, 0);
    for (int v = 0; v < 8; ++v) {
        const cv::Point2d centre(300.0 + 95.0 * v, 300.0 + 60.0 * v);
        cv::Mat light = backlight(static_cast<std::uint64_t>(v)), part(kSensor, CV_8UC1, cv::Scalar(0));
        cv::circle(part, centre * 16.0, 110 * 16, cv::Scalar(255), cv::FILLED, cv::LINE_AA, 4);
        cv::GaussianBlur(part, part, {0, 0}, 1.0);
        cv::Mat frame;
        cv::Mat(light - part.mul(light - 30.0, 1.0 / 255.0)).copyTo(frame);
        for (int s = 0; s < 6; ++s) frame(cv::Rect(100 + 170 * s, 80 + 150 * s, 3, 3)) *= 0.5;
        EdgeImage image;
        image.threshold = 115.0;
        image.sensor = kSensor;
        if (regions) {
            const cv::Rect region =
                cv::Rect(cv::Point(centre) - cv::Point(200, 150), cv::Size(400, 300)) & cv::Rect({0, 0}, kSensor);
            image.grey = frame(region).clone();
            image.origin = region.tl();
        } else {
            image.grey = frame;
        }
        out.views.push_back(image);
        std::vector<EdgeProbe> probes;
        for (int p = 0; p < 6; ++p) {
            const double a = (p + 0.3 * v) * 2.0 * M_PI / 6.0;
            const Eigen::Vector2d normal(std::cos(a), std::sin(a));
            probes.push_back({Eigen::Vector2d(centre.x, centre.y) + 110.0 * normal, normal});
        }
        out.probes.push_back(probes);
    }
    return out;
}

void BM_HealthCycle8Views(benchmark::State& state)
{
    const Cycle cycle = cycleOf(state.range(0) != 0);
    HealthMonitor monitor(cycle.reference);
    HealthFigures f;
    for (auto _ : state) {
        monitor.beginCycle();
        for (std::size_t v = 0; v < cycle.views.size(); ++v) monitor.addView(v, cycle.views[v], cycle.probes[v]);
        f = monitor.endCycle();
        benchmark::DoNotOptimize(f.probes); // an int: Google Benchmark 1.7 under GCC garbles a double here
    }
    state.counters["probes"] = f.probes;
    state.counters["backlight"] = f.backlight;
    state.counters["width_px"] = f.edgeWidthPx;
    state.counters["dust"] = f.dustSpecks;
}
BENCHMARK(BM_HealthCycle8Views)->ArgName("regions")->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_FindEdge8Views(benchmark::State& state)
{
    const Cycle cycle = cycleOf(state.range(0) != 0);
    int found = 0;
    for (auto _ : state) {
        found = 0;
        for (std::size_t v = 0; v < cycle.views.size(); ++v)
            for (const EdgeProbe& p : cycle.probes[v])
                found += findEdge(cycle.views[v], p.pixel, p.normal, 3.0).has_value() ? 1 : 0;
        benchmark::DoNotOptimize(found);
    }
    state.counters["edges"] = found;
}
BENCHMARK(BM_FindEdge8Views)->ArgName("regions")->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// A program's assessment: N capable landmarks decided by the gauge, 8 views
// each with the budget terms of a 0.05 mm/px station (noise 0.4–1.1 µm,
// tilt 0.3 µm, calibration 0.2 µm), a tolerance of ±0.05 mm.
std::vector<hg::inspect::LandmarkCapability> assessmentOf(int landmarks)
{
    std::vector<hg::inspect::LandmarkCapability> out;
    for (int l = 0; l < landmarks; ++l) {
        std::vector<hg::inspect::ViewDeviation> views;
        for (int v = 0; v < 8; ++v)
            views.push_back({"v" + std::to_string(v), 0.0, 4e-4 + 1e-4 * ((l + v) % 8), 20.0, 3e-4, 2e-4});
        hg::inspect::LandmarkCapability c;
        c.id = "l" + std::to_string(l);
        c.zoneMm = 0.1;
        c.views = 8;
        c.capable = true;
        c.prediction = hg::inspect::combine(views, 5e-4);
        c.expectedMm = c.prediction.uncertaintyMm;
        out.push_back(c);
    }
    return out;
}

void BM_CapabilityUsed(benchmark::State& state)
{
    const auto assessment = assessmentOf(static_cast<int>(state.range(0)));
    double used = 0.0;
    for (auto _ : state) {
        used = hg::inspect::capabilityUsed(assessment, 0.05, 0.08);
        benchmark::DoNotOptimize(used);
    }
    state.counters["share_x1000"] = static_cast<int>(1000.0 * used);
}
BENCHMARK(BM_CapabilityUsed)->ArgName("landmarks")->Arg(16)->Arg(64)->Unit(benchmark::kMicrosecond);

} // namespace

BENCHMARK_MAIN();
