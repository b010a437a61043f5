// The STEP reader (docs/fuzzing.md): StepModel::readInThisProcess (what
// StepModel::read runs in its child process) on the input written to
// `input.step`, then what the part program loader does with a STEP part
// before it builds the solid (loadModel, src/model/part_program.cpp): the
// default cube around the summary's bounds and the tessellation at that
// cube's ΔV/20 (PartProgram::tessellationDeflectionMm).
#include "fuzz_support.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/step_io.h"

namespace {

// Depth 6 rather than the simulated line's 8: a curved face's triangles
// multiply with every level, and at depth 8 the sphere seed takes 3 s under
// the sanitizers (0.7 s at depth 6); the reader and the tessellator take the
// same paths either way.
constexpr int kDepth = 6;
constexpr int kAdjacencyDepth = 4;
constexpr double kAngularDeflectionRad = 0.1; // kStepAngularDeflectionRad of part_program.cpp

void loadStep(const std::filesystem::path& file)
{
    hg::model::StepModel model = hg::model::StepModel::readInThisProcess(file);
    const auto cube = hg::model::boundingCube(model.summary().bounds, kDepth, kAdjacencyDepth);
    (void)model.tessellate(cube->voxelSize() / 20.0, kAngularDeflectionRad);
}

} // namespace

// Memory Open CASCADE allocates and never frees is not the harness's finding:
// its STEP controller's tables built on the first read, and the content of
// every entity of a type it does not know (Interface_UndefinedContent, on
// each such input; docs/fuzzing.md, "Open CASCADE"). Its libraries are built
// without frame pointers, so such a leak's stack ends in them and is
// suppressed by module; a leak of memory our code allocates names our frames.
extern "C" const char* __lsan_default_suppressions()
{
    return "leak:libTKernel.so\n"
           "leak:libTKXSBase.so\n"
           "leak:libTKSTEP\n";
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const auto file = hg::fuzz::writeInput("input.step", data, size);
    hg::fuzz::expectDocumentedErrors([&] { loadStep(file); });
    return 0;
}
