// The configuration's files in the audit trail (docs/audit.md, "Files"): each
// time the daemon loads its configuration — at start and at every reload it
// applies — it compares the files it runs with (the configuration itself, the
// station file with its calibration, each part program and its view plan) with
// the text the trail last recorded for them, and records each one that changed
// with its text before and after. A file edited by hand, a calibration written,
// a program released by the tool: whatever wrote it, the trail shows the change
// from the moment the daemon runs with it.
#pragma once

#include "daemon_config.h"
#include "hullgauge/store/audit_log.h"

#include <cstdint>
#include <string>

namespace hg::daemon {

/// Records the files of `config` that differ from what `audit` holds for them (the first time, their
/// whole text); `when` says at what the daemon found them ("start", "reload"). Returns how many were
/// recorded. A file that cannot be read is recorded as such, never an exception.
int recordConfigurationFiles(store::AuditLog& audit, const station::DaemonConfig& config, const std::string& when,
                             std::int64_t wallMs);

} // namespace hg::daemon
