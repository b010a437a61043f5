#include "hullgauge/common/file_kind.h"

#include <system_error>

namespace hg {

std::string notARegularFile(const std::filesystem::path& path)
{
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status target = fs::status(path, ec);
    if (fs::is_regular_file(target)) return {};
    if (target.type() == fs::file_type::not_found) {
        // A link whose target is gone reads as missing through the link: say which.
        const fs::file_status link = fs::symlink_status(path, ec);
        return fs::is_symlink(link) ? "a broken symbolic link (its target does not exist)" : "no such file";
    }
    switch (target.type()) {
    case fs::file_type::directory:
        return "a folder, not a file";
    case fs::file_type::character:
        return "a character device, not a regular file";
    case fs::file_type::block:
        return "a block device, not a regular file";
    case fs::file_type::fifo:
        return "a FIFO (named pipe), not a regular file";
    case fs::file_type::socket:
        return "a socket, not a regular file";
    default:
        break;
    }
    return ec ? "cannot be read: " + ec.message() : "not a regular file";
}

} // namespace hg
