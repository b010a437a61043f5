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

/// Compact text of `value` for anything hullgauge writes (HTTP answers, result
/// rows, MQTT payloads). A string that is not valid UTF-8 (a landmark name typed
/// in Latin-1 in a part program, a URL parameter echoed in an error) has each
/// ill-formed byte replaced by U+FFFD instead of throwing: the answer or the
/// record is still written, and shows where the text was wrong.
std::string dumpJson(const nlohmann::json& value);

} // namespace hg
