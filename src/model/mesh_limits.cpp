#include "mesh_limits.h"

#include <charconv>
#include <fstream>
#include <optional>
#include <vector>

#include <spdlog/fmt/fmt.h>

#include "hullgauge/common/error.h"
#include "ply_check.h"

namespace hg::model::detail {
namespace {

void refuseCount(const std::string& name, std::uint64_t announced, const char* what, const MeshRepairOptions& limits)
{
    throw InputError(name, "mesh",
                     fmt::format("the file announces {} {}, more than the {} a part's mesh may have (mesh size limit, "
                                 "docs/part-program.md)",
                                 announced, what, limits.maxTriangles));
}

/// A binary STL's facet count (bytes 80–83); nothing for an ASCII one.
std::optional<std::uint64_t> stlAnnouncedFacets(const std::filesystem::path& file, std::uintmax_t size)
{
    if (size < 84) return std::nullopt;
    std::ifstream in(file, std::ios::binary);
    std::string head(84, '\0');
    in.read(head.data(), 84);
    const auto first = head.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && head.compare(first, 5, "solid") == 0) return std::nullopt;
    std::uint64_t announced = 0;
    for (int i = 3; i >= 0; --i) announced = (announced << 8) | static_cast<unsigned char>(head[80 + i]);
    return announced;
}

/// The words of an OFF header up to its counts, comments (`#` to the end of
/// the line) left out, each with its line.
struct OffWord {
    std::string text;
    int line = 0;
};

std::vector<OffWord> offHeaderWords(std::istream& in, std::size_t wanted)
{
    std::vector<OffWord> words;
    std::string line;
    for (int number = 1; words.size() < wanted && number <= 64 && std::getline(in, line); ++number) {
        line = line.substr(0, line.find('#'));
        std::size_t at = 0;
        while (words.size() < wanted) {
            const auto begin = line.find_first_not_of(" \t\r", at);
            if (begin == std::string::npos) break;
            const auto end = line.find_first_of(" \t\r", begin);
            words.push_back({line.substr(begin, end - begin), number});
            at = end;
        }
    }
    return words;
}

/// OFF: `[ST][C][N][4][n]OFF [BINARY]`, then the vertex, face and edge counts.
/// Every vertex takes at least 6 bytes ("0 0 0\n") and every face 8
/// ("3 0 1 2\n"), in either encoding, so counts the file cannot hold are
/// refused with the header's line before the reader reserves for them.
void checkOffHeader(const std::filesystem::path& file, std::uintmax_t size, const MeshRepairOptions& limits)
{
    std::ifstream in(file, std::ios::binary);
    std::vector<OffWord> words = offHeaderWords(in, 5);
    if (words.empty() || words[0].text.size() < 3 || words[0].text.substr(words[0].text.size() - 3) != "OFF")
        return; // no OFF file: the reader says so
    std::size_t next = 1;
    if (next < words.size() && words[next].text == "BINARY") ++next;
    const std::string name = file.string();
    std::uint64_t counts[2] = {0, 0};
    for (int k = 0; k < 2; ++k, ++next) {
        const OffWord* w = next < words.size() ? &words[next] : nullptr;
        const std::string text = w ? w->text : "";
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), counts[k]);
        if (!w || end != text.data() + text.size() || error != std::errc())
            throw InputError(name, "header",
                             fmt::format("the {} count '{}' is not a whole number", k == 0 ? "vertex" : "face", text),
                             w ? std::optional<int>(w->line) : std::nullopt);
    }
    const int line = words[next - 1].line;
    if (counts[1] > limits.maxTriangles) refuseCount(name, counts[1], "faces", limits);
    // 3 × as many vertices as triangles is a soup's most; a count past it holds no more triangles.
    if (counts[0] > 3 * limits.maxTriangles) refuseCount(name, counts[0], "vertices", limits);
    if (6 * counts[0] + 8 * counts[1] > size + 1)
        throw InputError(name, "header",
                         fmt::format("{} vertices and {} faces take at least {} bytes; the file has {}", counts[0],
                                     counts[1], 6 * counts[0] + 8 * counts[1] - 1, size),
                         line);
}

} // namespace

void checkAnnouncedSize(const std::filesystem::path& file, const std::string& ext, std::uintmax_t size,
                        const MeshRepairOptions& limits)
{
    const std::string name = file.string();
    if (size > limits.maxFileBytes)
        throw InputError(name, "mesh",
                         fmt::format("the file's {:.1f} MiB are more than the {:.0f} MiB a mesh file may have (mesh "
                                     "size limit, docs/part-program.md)",
                                     double(size) / (1 << 20), double(limits.maxFileBytes) / (1 << 20)));
    if (ext == ".stl") {
        if (auto n = stlAnnouncedFacets(file, size); n && *n > limits.maxTriangles)
            refuseCount(name, *n, "facets", limits);
    } else if (ext == ".ply") {
        if (auto n = plyAnnouncedFaces(file); n && *n > limits.maxTriangles) refuseCount(name, *n, "faces", limits);
    } else if (ext == ".off") {
        checkOffHeader(file, size, limits);
    }
}

} // namespace hg::model::detail
