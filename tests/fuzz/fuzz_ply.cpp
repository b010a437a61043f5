// The mesh loader on PLY files (docs/fuzzing.md): loadMesh as `hullgauge
// check-part` and the part program loader call it, on the input written to a file.
#include "fuzz_support.h"
#include "hullgauge/model/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const auto file = hg::fuzz::writeInput("input.ply", data, size);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::model::loadMesh(file); });
    return 0;
}
