// Commissioning on 2 cores (docs/commissioning.md): a public CAD mesh of a
// real part (tests/data/cad/mcad-nema17-stepper.stl, a NEMA 17 motor body) on
// a turntable station whose lens fits it — 8 landmarks suggested, the views
// planned, the program verified on the twin with 20 seats and defects of 1, 2
// and 3 × the tolerance added and removed at every landmark. Counters give
// the time of each phase (s) and the cycles run; the baseline in the same run
// is one cycle of the nominal part on the twin.
#include "hullgauge/commission/screen.h"
#include "hullgauge/commission/verification.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/plan/landmark_suggest.h"
#include "hullgauge/plan/program_plan.h"

#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

namespace {

using namespace hg;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const fs::path kMesh = fs::path(HULLGAUGE_SOURCE_DIR) / "tests/data/cad/mcad-nema17-stepper.stl";

// The simulated line's station with a lens that fits the 78 mm part: its
// bounding sphere fills half the frame's height at 400 mm; the floor under it.
constexpr const char* kStation = R"(camera:
  image_size: [1280, 960]
  K: [[2461, 0, 640], [0, 2461, 480], [0, 0, 1]]
  image_quality: {noise_grey: 1.5, contrast_grey: 224.4, blur_sigma_px: 0.6}
fixture:
  type: rotation_declination
  camera_from_fixture: {R: [[1, 0, 0], [0, 0, -1], [0, 1, 0]], t: [0, 0, 400]}
  rotation_axis: [0, 0, 1]
  declination_axis: [1, 0, 0]
  rotation_range_deg: [-180, 180]
  declination_range_deg: [0, 60]
environment:
  floor_z_mm: -26.5
segmentation: {method: otsu, object_is_dark: true}
)";

double seconds(Clock::time_point start)
{
    return std::chrono::duration<double>(Clock::now() - start).count();
}

/// The suggested program (8 landmarks, tolerance 0.1 mm) written beside the mesh's copy.
fs::path suggestedProgram(const geometry::Station& station, const fs::path& dir)
{
    const int depth = plan::finestResolvedDepth(model::loadCadModel(kMesh, 8, 4).solid->mesh(), station, 4);
    const model::CadModel cad = model::loadCadModel(kMesh, depth, 4);
    // As `hullgauge commission` suggests: capable over the nest's play, planned as the draft is.
    plan::SuggestOptions options;
    options.count = 8;
    options.toleranceMm = 0.1;
    options.plan.pareLayers = cad.octree.adjacencyDepth;
    const plan::Suggestion s = plan::suggestLandmarks(plan::suggestProblem(cad, station), options);
    std::ofstream(dir / "p.yaml") << "part: nema17\nmesh: " << kMesh.string() << "\noctree: {depth: " << depth
                                  << ", adjacency_depth: 4}\n"
                                  << plan::landmarksYaml(s, 0.1, {});
    return dir / "p.yaml";
}

struct Prepared {
    model::PartProgram program;
    plan::ProgramPlan planned;
    commission::VerificationProblem problem;
};

void prepare(Prepared& p, const geometry::Station& station)
{
    plan::PlanOptions options;
    options.pareLayers = p.program.octree.adjacencyDepth;
    p.planned = plan::planProgram(p.program, station, options);
    p.problem = commission::verificationProblem(
        p.program, station, p.planned.plan, p.planned.capability.value_or(std::vector<inspect::LandmarkCapability>{}));
}

void BM_Commission(benchmark::State& state)
{
    const geometry::Station station = geometry::parseStation(ConfigNode::parse(kStation, "station.yaml"));
    const fs::path dir = fs::temp_directory_path() / "hullgauge-bench-commission";
    fs::create_directories(dir);
    std::map<std::string, double> phase;
    std::size_t landmarks = 0;
    for (auto _ : state) {
        auto start = Clock::now();
        const fs::path program = suggestedProgram(station, dir);
        phase["suggest"] = seconds(start);
        start = Clock::now();
        Prepared p{model::loadPartProgram(program), {}, {}};
        prepare(p, station);
        phase["plan"] = seconds(start);
        std::map<std::string, Clock::time_point> started;
        const auto progress = [&](const std::string& name, std::size_t done, std::size_t total) {
            if (done == 0) started[name] = Clock::now();
            if (done == total) phase[name] = seconds(started[name]);
            return true;
        };
        commission::VerificationOptions options;
        options.seats = 20;
        const auto report = commission::verifyProgram(p.problem, options, commission::twinFrames(station, 1), progress);
        landmarks = p.program.landmarks.size();
        benchmark::DoNotOptimize(report.released);
    }
    fs::remove_all(dir);
    for (const auto& [name, s] : phase) state.counters[name + "_s"] = s;
    state.counters["landmarks"] = static_cast<double>(landmarks);
    state.counters["cycles"] = static_cast<double>(20 + landmarks * 3 * 2);
}
BENCHMARK(BM_Commission)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_OneTwinCycle(benchmark::State& state)
{
    const geometry::Station station = geometry::parseStation(ConfigNode::parse(kStation, "station.yaml"));
    const fs::path dir = fs::temp_directory_path() / "hullgauge-bench-commission-cycle";
    fs::create_directories(dir);
    Prepared p{model::loadPartProgram(suggestedProgram(station, dir)), {}, {}};
    prepare(p, station);
    commission::VerificationOptions options;
    options.seats = 1;
    options.defectMultiples = {};
    for (auto _ : state) {
        const auto report = commission::verifyProgram(p.problem, options, commission::twinFrames(station, 1));
        benchmark::DoNotOptimize(report.nominalPassed);
    }
    fs::remove_all(dir);
}
BENCHMARK(BM_OneTwinCycle)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
