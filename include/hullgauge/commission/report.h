// The verification report (docs/commissioning.md, "The report"): JSON for
// machines (the HMI, the release's digest) and Markdown for the engineer.
#pragma once

#include "hullgauge/commission/verification.h"

#include <nlohmann/json.hpp>
#include <string>

namespace hg::commission {

/// docs/commissioning.md, "verification.json".
nlohmann::json toJson(const VerificationReport& report);

/// The engineer's report: the verdict, per landmark observability, predicted
/// and measured U, the smallest defect caught and the false rejects; per view
/// the landmarks it sees and its frame margin; every finding with its fix.
std::string toMarkdown(const VerificationReport& report);

} // namespace hg::commission
