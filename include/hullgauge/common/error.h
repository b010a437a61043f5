// Error types shared by every module.
//
// Loading-time problems (a file, a configuration key, a command-line value) are
// InputError: they name the file, the field and, where the format has lines, the
// line, and map to exit status 2 (docs/contracts.md §5). Hardware and runtime faults are
// FaultError (exit status 3). The capture loop never throws across a driver
// boundary; it returns status values instead (docs/style.md point 4).
#pragma once

#include <optional>
#include <stdexcept>
#include <string>

namespace hg {

class InputError : public std::runtime_error {
  public:
    /// @param file   the file that was wrong (may be empty for command-line values)
    /// @param field  the key path ("landmarks[3].position") or record ("facet 12")
    /// @param line   1-based line in the file, when the format has lines
    InputError(std::string file, std::string field, std::string problem, std::optional<int> line = std::nullopt);

    const std::string& file() const noexcept { return file_; }
    const std::string& field() const noexcept { return field_; }
    const std::string& problem() const noexcept { return problem_; }
    std::optional<int> line() const noexcept { return line_; }

  private:
    std::string file_;
    std::string field_;
    std::string problem_;
    std::optional<int> line_;
};

/// A runtime or hardware fault (exit status 3).
class FaultError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Exit statuses of every hullgauge program (docs/contracts.md §5).
enum class ExitStatus : int { Ok = 0, PartFails = 1, BadInput = 2, Fault = 3 };

} // namespace hg
