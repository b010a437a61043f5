// The one way hullgauge reads JSON it did not write itself (capture
// manifests, maintenance requests, answers to `hullgauge ctl`): strict, so that
// bad input is named rather than half-understood (docs/style.md point 4).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace hg {

/// Parses `text`. A syntax error, a number past the range of a double
/// (`1e400`), a duplicate key in one object (`{"command": "status",
/// "command": "abort"}` — nlohmann would keep the last silently) or nesting
/// deeper than 64 levels throws hg::InputError naming `name`, the key path
/// and the line.
nlohmann::json parseJson(const std::string& text, const std::string& name);

} // namespace hg
