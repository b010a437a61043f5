// What a path names when a file was expected: every loader says why a path is
// no file it can read — missing, a folder, a device node such as /dev/zero, a
// FIFO — instead of one "no such file" for all of them, and refuses the
// special files before a byte is read (a FIFO would block the reader, a device
// node would feed it without end; docs/style.md point 4).
#pragma once

#include <filesystem>
#include <string>

namespace hg {

/// Empty when `path` is a regular file (after following symbolic links);
/// otherwise the problem in words: "no such file", "a folder, not a file",
/// "a character device, not a regular file", "a FIFO (named pipe), not a
/// regular file", "a broken symbolic link" …
std::string notARegularFile(const std::filesystem::path& path);

} // namespace hg
