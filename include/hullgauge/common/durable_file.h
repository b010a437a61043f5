// Files that are whole on the disk or not there at all: the bytes are written
// and flushed (fsync) before the caller renames them into place, so a full disk
// or a power cut leaves the old state, never a truncated file (the station
// file update of docs/calibration.md, the parts' archive of docs/daemon.md).
#pragma once

#include <filesystem>
#include <string_view>

namespace hg {

/// Writes `bytes` into `file` (created or truncated) and flushes it to the
/// disk. Throws FaultError naming the file (a full disk shows here).
void writeFileDurably(const std::filesystem::path& file, std::string_view bytes);

/// Flushes a folder's entries (files created or renamed in it) to the disk.
/// Throws FaultError naming the folder.
void syncFolder(const std::filesystem::path& folder);

/// Replaces `file` with `bytes` atomically: written and flushed into a hidden
/// temporary file in the same folder, renamed over `file`, the folder flushed.
/// A reader sees the old file or the new one, never a part; on any error the
/// temporary file is removed and `file` is as it was. Throws FaultError naming
/// the file.
void replaceFileDurably(const std::filesystem::path& file, std::string_view bytes);

/// Run as root, gives `file` to the owner and group of its folder, so a file a root shell creates in
/// the daemon's state folder (an account, the audit trail: docs/audit.md) stays the daemon's. Nothing
/// for anyone else. Throws FaultError naming the file.
void giveToFolderOwner(const std::filesystem::path& file);

} // namespace hg
