// Error types shared by every module; which one a failure is follows
// docs/style.md point 4.
//
// Loading-time problems (a file, a configuration key, a command-line value) are
// InputError: they name the file, the field and, where the format has lines, the
// line, and map to exit status 2 (docs/contracts.md §5). Hardware and runtime faults are
// FaultError (exit status 3). A caller that breaks a public function's documented
// precondition gets an ArgumentError; a loader that passes a value it read on to
// such a function turns that into an InputError naming the field. The capture
// loop never throws across a driver boundary; it returns status values instead
// (status.h).
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

/// A value the function's contract excludes: the caller broke a documented
/// precondition (a render window outside the image, a camera with a
/// non-positive focal length, an aligner without datums). The message names
/// the argument and the value. An std::invalid_argument, so a caller may catch
/// it as one; it is neither bad input (the function does not know the file)
/// nor a fault of the station.
class ArgumentError : public std::invalid_argument {
  public:
    using std::invalid_argument::invalid_argument;
};

/// Exit statuses of every hullgauge program (docs/contracts.md §5).
enum class ExitStatus : int { Ok = 0, PartFails = 1, BadInput = 2, Fault = 3 };

} // namespace hg
