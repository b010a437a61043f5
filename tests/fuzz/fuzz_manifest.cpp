// The capture manifest (docs/fuzzing.md): readManifest on the input written as
// manifest.json, as `hullgauge inspect` reads a capture folder.
#include "fuzz_support.h"
#include "hullgauge/vision/manifest.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const auto file = hg::fuzz::writeInput("manifest.json", data, size);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::vision::readManifest(file); });
    return 0;
}
