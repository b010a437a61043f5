// View planning: time for 16, 64 and 256 landmarks on a stamp-like part
// (target < 1 s for 100), and the greedy view count against the integer
// program's optimum on instances of 5 to 30 landmarks.
#include "hgtest/station.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/plan/planner.h"

#include <benchmark/benchmark.h>
#include <random>

namespace {

using namespace hg;
using Eigen::Vector3d;

geometry::Station station()
{
    return hgtest::station({.imageSize = {2448, 2048}, .focalPx = 4000});
}

// A stamp: handle 10 x 10 x 30 under a 24 x 24 x 8 head with a 6 mm boss on top.
const model::Solid& stamp()
{
    static const model::Solid solid = [] {
        auto m = model::unionOf(model::makeBox(Vector3d(-5, -5, 0), Vector3d(5, 5, 30)),
                                model::makeBox(Vector3d(-12, -12, 30), Vector3d(12, 12, 38)));
        m = model::unionOf(m, model::makeCylinder(Vector3d(0, 0, 38), 6, 4, 48));
        return model::Solid(m);
    }();
    return solid;
}

// Landmarks on the stamp's flat faces (head sides and top, handle sides), seeded.
std::vector<plan::PlanLandmark> landmarks(std::size_t n, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<plan::PlanLandmark> out;
    for (std::size_t i = 0; i < n; ++i) {
        plan::PlanLandmark l;
        l.id = "l" + std::to_string(i);
        l.toleranceMm = 0.5;
        const int face = static_cast<int>(rng() % 6);
        const double a = u(rng), b = u(rng);
        switch (face) {
        case 0:
            l.position = {12, 11 * a, 34 + 3.5 * b};
            l.normal = Vector3d::UnitX();
            break;
        case 1:
            l.position = {-12, 11 * a, 34 + 3.5 * b};
            l.normal = -Vector3d::UnitX();
            break;
        case 2:
            l.position = {11 * a, 12, 34 + 3.5 * b};
            l.normal = Vector3d::UnitY();
            break;
        case 3:
            l.position = {11 * a, -12, 34 + 3.5 * b};
            l.normal = -Vector3d::UnitY();
            break;
        case 4:
            l.position = {5, 4 * a, 15 + 12 * b};
            l.normal = Vector3d::UnitX();
            break;
        default:
            l.position = {4 * a, -5, 15 + 12 * b};
            l.normal = -Vector3d::UnitY();
            break;
        }
        out.push_back(l);
    }
    return out;
}

plan::PlanProblem problem(const geometry::Station& s, std::vector<plan::PlanLandmark> lms)
{
    plan::PlanProblem p;
    p.part = "stamp";
    p.solid = &stamp();
    p.station = &s;
    p.frame = {Vector3d(-64, -64, -64), 128.0, 9}; // ΔV = 0.25 mm
    p.landmarks = std::move(lms);
    return p;
}

void BM_PlanLandmarks(benchmark::State& state)
{
    const auto s = station();
    const auto p = problem(s, landmarks(static_cast<std::size_t>(state.range(0)), 42));
    std::size_t views = 0;
    for (auto _ : state) {
        auto plan = plan::planViews(p);
        views = plan.views.size();
        benchmark::DoNotOptimize(plan);
    }
    state.counters["views"] = static_cast<double>(views);
}
BENCHMARK(BM_PlanLandmarks)->Arg(16)->Arg(64)->Arg(100)->Arg(256)->Unit(benchmark::kMillisecond)->Iterations(1);

// Greedy (5.6.1 plus the final redundancy check) against the GLPK optimum on
// 10 seeded instances per size; counters give the mean counts and how many
// instances the greedy matched the optimum on.
void BM_GreedyVersusOptimum(benchmark::State& state)
{
    const auto s = station();
    double greedy = 0, exact = 0, equal = 0;
    const int instances = 10;
    for (auto _ : state) {
        greedy = exact = equal = 0;
        for (int k = 0; k < instances; ++k) {
            auto p = problem(s, landmarks(static_cast<std::size_t>(state.range(0)), 1000u + static_cast<unsigned>(k)));
            plan::PlanOptions o;
            o.exact = true;
            auto plan = plan::planViews(p, o);
            greedy += static_cast<double>(plan.greedyViews);
            exact += plan.exactViews ? static_cast<double>(*plan.exactViews) : 0.0;
            equal += plan.exactViews && *plan.exactViews == plan.greedyViews ? 1 : 0;
        }
    }
    state.counters["greedy_views"] = greedy / instances;
    state.counters["optimal_views"] = exact / instances;
    state.counters["equal_of_10"] = equal;
}
BENCHMARK(BM_GreedyVersusOptimum)->Arg(5)->Arg(10)->Arg(20)->Arg(30)->Unit(benchmark::kMillisecond)->Iterations(1);

} // namespace

BENCHMARK_MAIN();
