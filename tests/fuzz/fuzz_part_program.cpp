// The part program loader (docs/fuzzing.md): loadPartProgram on the input
// written as part.yaml next to the simulated line's mesh, which a seed's
// `mesh: stepped-block.stl` names, so the fuzzer reaches past the mesh into the
// octree, landmarks, parameters, inspection and alignment sections.
#include "fuzz_support.h"
#include "hullgauge/model/part_program.h"

#include <filesystem>

#ifndef HULLGAUGE_SOURCE_DIR
#error "HULLGAUGE_SOURCE_DIR names the repository (tests/fuzz/CMakeLists.txt)"
#endif

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    std::filesystem::copy_file(std::filesystem::path(HULLGAUGE_SOURCE_DIR) / "config/sim/stepped-block.stl",
                               hg::fuzz::workFolder() / "stepped-block.stl",
                               std::filesystem::copy_options::overwrite_existing);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const auto file = hg::fuzz::writeInput("part.yaml", data, size);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::model::loadPartProgram(file); });
    return 0;
}
