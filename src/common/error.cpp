#include "hullgauge/common/error.h"

namespace hg {
namespace {

// One line: "file:line: field: problem" — the form compilers use, so editors
// and grep understand it.
std::string format(const std::string& file, const std::string& field, const std::string& problem,
                   std::optional<int> line)
{
    // Appended piece by piece: GCC 12 reports a false -Wrestrict on
    // `s += ":" + std::to_string(n)` at -O2.
    std::string s;
    if (!file.empty()) {
        s.append(file);
        if (line) s.append(":").append(std::to_string(*line));
        s.append(": ");
    }
    if (!field.empty()) s.append(field).append(": ");
    s.append(problem);
    return s;
}

} // namespace

InputError::InputError(std::string file, std::string field, std::string problem, std::optional<int> line)
    : std::runtime_error(format(file, field, problem, line)), file_(std::move(file)), field_(std::move(field)),
      problem_(std::move(problem)), line_(line)
{
}

} // namespace hg
