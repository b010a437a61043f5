// A .hgmap file written from the format of docs/inspection.md ("File"),
// independently of InspectionMap::serialise: the tests read hand-made maps
// through it, and the .hgmap fuzz harness seals mutated payloads with it so
// that they get past the corruption check to the records.
#pragma once

#include <cstdint>
#include <vector>

namespace hgtest {

/// A .hgmap file around `payload`: magic, format `version`, the payload's size
/// and checksum (FNV-1a over 64-bit little-endian words, the tail byte by byte).
inline std::vector<std::uint8_t> sealMap(const std::vector<std::uint8_t>& payload, std::uint32_t version)
{
    std::uint64_t h = 14695981039346656037ull;
    std::size_t n = 0;
    for (; n + 8 <= payload.size(); n += 8) {
        std::uint64_t w = 0;
        for (int b = 0; b < 8; ++b) w |= std::uint64_t{payload[n + b]} << (8 * b);
        h = (h ^ w) * 1099511628211ull;
    }
    for (; n < payload.size(); ++n) h = (h ^ payload[n]) * 1099511628211ull;
    std::vector<std::uint8_t> file;
    auto raw = [&file](const void* v, std::size_t size) {
        const auto* b = static_cast<const std::uint8_t*>(v);
        file.insert(file.end(), b, b + size);
    };
    const std::uint32_t reserved = 0;
    const std::uint64_t size = payload.size();
    raw("HGMAP\r\n\x1a", 8);
    raw(&version, 4);
    raw(&reserved, 4);
    raw(&size, 8);
    raw(&h, 8);
    file.insert(file.end(), payload.begin(), payload.end());
    return file;
}

} // namespace hgtest
