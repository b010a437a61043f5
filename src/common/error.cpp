#include "hullgauge/common/error.h"

namespace hg {
namespace {

// One line: "file:line: field: problem" — the form compilers use, so editors
// and grep understand it.
std::string format(const std::string& file, const std::string& field, const std::string& problem,
                   std::optional<int> line)
{
    std::string s;
    if (!file.empty()) {
        s += file;
        if (line) s += ":" + std::to_string(*line);
        s += ": ";
    }
    if (!field.empty()) s += field + ": ";
    s += problem;
    return s;
}

}  // namespace

InputError::InputError(std::string file, std::string field, std::string problem, std::optional<int> line)
    : std::runtime_error(format(file, field, problem, line)),
      file_(std::move(file)), field_(std::move(field)), problem_(std::move(problem)), line_(line)
{
}

}  // namespace hg
