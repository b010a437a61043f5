// A mesh file's announced size checked against the limits before a reader
// sizes anything by it (docs/part-program.md, "Mesh size limits"): the counts
// a binary STL, a PLY or an OFF header gives, the file's bytes for every
// format. An OFF header of 60 bytes announcing 50 million faces once made the
// reader reserve 1.25 GB.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "hullgauge/model/mesh_repair.h"

namespace hg::model::detail {

/// Throws InputError naming the limit, or the header line whose counts the
/// file's size cannot hold. `ext` is the lower-case extension with its dot.
void checkAnnouncedSize(const std::filesystem::path& file, const std::string& ext, std::uintmax_t size,
                        const MeshRepairOptions& limits);

} // namespace hg::model::detail
