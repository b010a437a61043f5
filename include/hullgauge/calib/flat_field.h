// The flat-field reference on disk (docs/health.md, "Reference file"): what
// calibration saw of the empty fixture's backlight (vision::buildFlatField),
// read by the station health monitor (vision/health.h). A small JSON
// document, written durably: a power cut leaves the old reference or the
// new one, never a part of it.
#pragma once

#include "hullgauge/vision/health.h"

#include <filesystem>

namespace hg::calib {

/// Writes `reference` into `file`, replacing it atomically
/// (common/durable_file.h). Throws hg::ArgumentError when the reference is
/// empty or its levels are not ceil(sensor / cell) blocks of CV_32FC1, and
/// hg::FaultError naming the file when it cannot be written.
void writeFlatField(const std::filesystem::path& file, const vision::FlatField& reference);

/// Reads a reference writeFlatField wrote. Throws hg::InputError naming the
/// file and the field (and the line where the JSON is broken) when the file
/// cannot be read, is not the format, or a field is missing or out of range.
vision::FlatField readFlatField(const std::filesystem::path& file);

} // namespace hg::calib
