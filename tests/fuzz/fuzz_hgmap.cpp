// The inspection map reader (docs/fuzzing.md): InspectionMap::deserialise on the
// bytes, as InspectionMap::load does with a .hgmap file's. Each input is read
// twice: as it is, and sealed — magic, payload size and checksum
// rewritten to match the payload (tests/support/hgtest/hgmap_file.h) — since a mutated payload almost never keeps
// its checksum and would stop at the corruption check before the records.
#include "fuzz_support.h"
#include "hgtest/hgmap_file.h"
#include "hullgauge/inspect/inspection_map.h"

#include <cstring>
#include <vector>

namespace {

// The header (docs/inspection.md, "File"): magic (8), version (4), reserved (4), payload size (8), checksum (8).
constexpr std::size_t kHeader = 32;

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    (void)hg::fuzz::workFolder(); // silences the log
    std::vector<std::uint8_t> bytes(data, data + size);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::inspect::InspectionMap::deserialise(bytes, "input.hgmap"); });
    if (size < kHeader) return 0;
    std::uint32_t version = 0;
    std::memcpy(&version, data + 8, 4);
    bytes = hgtest::sealMap({data + kHeader, data + size}, version);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::inspect::InspectionMap::deserialise(bytes, "input.hgmap"); });
    return 0;
}
