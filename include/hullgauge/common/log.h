// Category logging (docs/style.md point 5): one spdlog logger per category
// ("camera", "fixture", "plc", "seq", "inspect", "model", "sim", "calib", ...),
// each with its own level, set at run time from HULLGAUGE_LOG
// ("info" or "warn,camera=trace,plc=debug"). Per-frame messages use trace.
#pragma once

#include <memory>
#include <string_view>

#include <spdlog/spdlog.h>

namespace hg::log {

/// The logger of a category, created on first use with the configured level.
std::shared_ptr<spdlog::logger> category(std::string_view name);

/// Apply a level specification such as "info" or "warn,camera=trace".
/// Unknown level names throw hg::InputError naming the specification.
void configure(std::string_view spec);

/// Send every category to the systemd journal instead of stderr.
void useJournal();

} // namespace hg::log
