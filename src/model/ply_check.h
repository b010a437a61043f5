// PLY files checked before CGAL's reader reads them: the header and every
// item of the body (docs/part-program.md, "Mesh"; docs/fuzzing.md).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>

namespace hg::model::detail {

/// Throws InputError naming the header line or the element's item where a PLY
/// file is one CGAL's reader would crash on, hang on or size a list by a
/// number it never read; a file that is not PLY at all is left to the reader.
void checkPly(const std::filesystem::path& file, std::uintmax_t size);

/// The count of the header's `face` element; nothing for a file that is no
/// PLY or declares no faces.
std::optional<std::uintmax_t> plyAnnouncedFaces(const std::filesystem::path& file);

} // namespace hg::model::detail
