// The predicted cycle time of planned views (docs/planning.md, "Cycle time"):
// per part the views in the order of least predicted time against the order
// the view pattern analysis chose them in and the order of least travel
// distance. Parts: the simulated line's stepped block on its station
// (config/sim), and the tests' parts (tests/support/hgtest/parts.h; not the
// hole plate, whose hole wall this station cannot inspect) on the
// tests' station (2448 × 2048, f = 4000 px) with two fixtures: the simulated
// drive's defaults (turntable 90 °/s, 360 °/s²; tilt 45 °/s, 180 °/s²; settle
// 0.05 s) and a fast turntable with a slow tilt (360 °/s, 3600 °/s²; 10 °/s,
// 20 °/s²). The benchmark's time is the planning; the counters are the
// cycle times in seconds and the share the ordering saves.
#include "hgtest/parts.h"
#include "hgtest/station.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/planner.h"
#include "hullgauge/plan/program_plan.h"

#include <benchmark/benchmark.h>
#include <functional>

namespace {

using namespace hg;

const std::string kSlowTilt = "  motion:\n"
                              "    rotation: {speed_deg_s: 360, acceleration_deg_s2: 3600}\n"
                              "    declination: {speed_deg_s: 10, acceleration_deg_s2: 20}\n";

geometry::Station testStation(const std::string& fixtureKeys)
{
    return hgtest::station({.imageSize = {2448, 2048}, .focalPx = 4000, .fixtureKeys = fixtureKeys});
}

plan::PlanProblem testProblem(const hgtest::TestPart& part, const geometry::Station& station)
{
    plan::PlanProblem p;
    p.part = part.name;
    p.solid = part.solid.get();
    p.station = &station;
    p.frame = part.geometry.frame();
    for (const auto& l : part.landmarks) {
        plan::PlanLandmark pl;
        static_cast<inspect::MapLandmark&>(pl) = l;
        p.landmarks.push_back(pl);
    }
    return p;
}

void report(benchmark::State& state, const plan::ViewPlan& plan)
{
    const auto& c = plan.cycleTime;
    state.counters["views"] = static_cast<double>(plan.views.size());
    state.counters["ordered_s"] = c.predicted.totalS;
    state.counters["moves_s"] = c.predicted.movesS;
    state.counters["unordered_s"] = c.unorderedS;
    state.counters["least_distance_s"] = c.leastDistanceS;
    state.counters["saved_pct"] = c.unorderedS > 0 ? 100.0 * (1.0 - c.predicted.totalS / c.unorderedS) : 0.0;
    state.counters["saved_vs_distance_pct"] =
        c.leastDistanceS > 0 ? 100.0 * (1.0 - c.predicted.totalS / c.leastDistanceS) : 0.0;
}

void BM_CycleTimeSimulatedLine(benchmark::State& state)
{
    const auto station = geometry::loadStation(HULLGAUGE_SOURCE_DIR "/config/sim/station.yaml");
    const auto program = model::loadPartProgram(HULLGAUGE_SOURCE_DIR "/config/sim/stepped-block.yaml");
    const auto problem = plan::planProblem(program, station);
    plan::ViewPlan result;
    for (auto _ : state) {
        result = plan::planViews(problem);
        benchmark::DoNotOptimize(result);
    }
    report(state, result);
}
BENCHMARK(BM_CycleTimeSimulatedLine)->Unit(benchmark::kMillisecond)->Iterations(1);

void cycleTimeOfTestPart(benchmark::State& state, const std::function<hgtest::TestPart()>& make)
{
    const auto part = make();
    const auto station = testStation(state.range(0) == 0 ? std::string() : kSlowTilt);
    const auto problem = testProblem(part, station);
    plan::ViewPlan result;
    for (auto _ : state) {
        result = plan::planViews(problem);
        benchmark::DoNotOptimize(result);
    }
    report(state, result);
}

// Arg 0: the simulated drive's defaults; 1: fast turntable, slow tilt.
BENCHMARK_CAPTURE(cycleTimeOfTestPart, cube, hgtest::cubePart)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(cycleTimeOfTestPart, u_channel, hgtest::uChannelPart)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(cycleTimeOfTestPart, post, hgtest::postPart)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(cycleTimeOfTestPart, defect_plate, hgtest::defectPlatePart)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

} // namespace

BENCHMARK_MAIN();
