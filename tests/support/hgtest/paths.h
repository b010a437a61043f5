// Where tests find the source tree, the built programs and a scratch folder.
#pragma once

#include <filesystem>
#include <string>

namespace hgtest {

/// The checkout (HULLGAUGE_SOURCE_DIR, set by CTest).
std::filesystem::path sourceDir();
/// The build folder (HULLGAUGE_BINARY_DIR); programs are in binaryDir()/"bin".
std::filesystem::path binaryDir();

/// A fresh folder under the system temp dir, removed when the object dies.
class TempDir {
  public:
    TempDir();
    ~TempDir();
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::filesystem::path& path() const { return path_; }
    std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

  private:
    std::filesystem::path path_;
};

/// Writes `text` to `path` (creating parent folders) and returns the path.
std::filesystem::path writeFile(const std::filesystem::path& path, const std::string& text);

/// Result of running a program: exit status and what it printed.
struct RunResult {
    int status = -1;
    std::string out;
    std::string err;
};

/// Runs `command` through /bin/sh with stdout and stderr captured.
RunResult run(const std::string& command);

} // namespace hgtest
