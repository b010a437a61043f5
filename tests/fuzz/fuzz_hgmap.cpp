// The inspection map reader (docs/fuzzing.md): InspectionMap::deserialise on the
// bytes, as InspectionMap::load does with a .hgmap file's. Each input is read
// twice: as it is, and sealed — the header's payload size and checksum
// rewritten to match the payload — since a mutated payload almost never keeps
// its checksum and would stop at the corruption check before the records.
#include "fuzz_support.h"
#include "hullgauge/inspect/inspection_map.h"

#include <cstring>
#include <vector>

namespace {

// The header (src/inspect/inspection_map.cpp): magic (8), version (4), reserved (4), payload size (8), checksum (8).
constexpr std::size_t kHeader = 32;

/// The map's checksum: FNV-1a over 64-bit little-endian words, the tail byte-wise.
std::uint64_t checksum(const std::uint8_t* data, std::size_t n)
{
    std::uint64_t h = 14695981039346656037ull;
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        std::uint64_t w;
        std::memcpy(&w, data + i, 8);
        h = (h ^ w) * 1099511628211ull;
    }
    for (; i < n; ++i) h = (h ^ data[i]) * 1099511628211ull;
    return h;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    (void)hg::fuzz::workFolder(); // silences the log
    std::vector<std::uint8_t> bytes(data, data + size);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::inspect::InspectionMap::deserialise(bytes, "input.hgmap"); });
    if (size < kHeader) return 0;
    const std::uint64_t payload = size - kHeader, sum = checksum(bytes.data() + kHeader, payload);
    std::memcpy(bytes.data() + 16, &payload, 8);
    std::memcpy(bytes.data() + 24, &sum, 8);
    hg::fuzz::expectDocumentedErrors([&] { (void)hg::inspect::InspectionMap::deserialise(bytes, "input.hgmap"); });
    return 0;
}
