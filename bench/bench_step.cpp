// STEP reading (docs/part-program.md, "A process of its own"): Open CASCADE's
// parse and translation in a child process, as the programs read a STEP
// part, against the same read in this process, for two parts of
// tests/fuzz/corpus/step (the box with a through bore, the stepped block).
// The difference is what the process of its own costs: the fork and the
// part's BRep text read back.
#include "hullgauge/model/step_io.h"

#include <benchmark/benchmark.h>

#include <array>
#include <filesystem>

namespace {

std::filesystem::path part(std::int64_t index)
{
    static const std::array<const char*, 2> kParts = {"box-with-bore.step", "stepped-block.step"};
    return std::filesystem::path(HULLGAUGE_SOURCE_DIR) / "tests/fuzz/corpus/step" /
           kParts.at(static_cast<std::size_t>(index));
}

void BM_StepReadInThisProcess(benchmark::State& state)
{
    const auto file = part(state.range(0));
    for (auto _ : state) {
        const auto model = hg::model::StepModel::readInThisProcess(file);
        benchmark::DoNotOptimize(model.summary().faces);
    }
}
BENCHMARK(BM_StepReadInThisProcess)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_StepReadInAProcessOfItsOwn(benchmark::State& state)
{
    const auto file = part(state.range(0));
    for (auto _ : state) {
        const auto model = hg::model::StepModel::read(file);
        benchmark::DoNotOptimize(model.summary().faces);
    }
}
BENCHMARK(BM_StepReadInAProcessOfItsOwn)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
