// The correction set of docs/mastering.md from the master cycles of a result
// store: the rows are selected here, the computation is the pure one of
// hullgauge/study/mastering.h. One way for both who compute it — `hullgauge
// master` from a store, and the daemon's mastering run from exactly the cycles
// it ran (docs/mastering.md, "The mastering run").
#pragma once

#include "hullgauge/inspect/correction.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/study/mastering.h"

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace hg::store {

/// Which master cycles a set is computed from: the pass/fail cycles of purpose
/// `master` of the program with each master's serial.
struct MasterCycleSelection {
    int program = 0;
    std::optional<std::int64_t> sinceMs, untilMs; ///< the window (started at or after, before)
    std::set<std::int64_t> only;                  ///< when it names any: only these rows
    std::size_t minCycles = 5;                    ///< the fewest per master
    std::string minCyclesOption = "--min-cycles"; ///< what sets it, for the refusal
};

/// The set of `masters` (one: one-point; two: two-point) from their cycles in
/// `store`, for `material`, computed at `createdUnixMs`. InputError naming the
/// master's file when it has fewer cycles than needed, and when the cycles span
/// several versions of the program; the computation's own refusals as
/// study::computeCorrections.
inspect::CorrectionSet masterCorrectionSet(const ResultReader& store,
                                           const std::vector<study::MasterCertificate>& masters,
                                           const MasterCycleSelection& selection, const std::string& material,
                                           std::int64_t createdUnixMs);

/// Each landmark's correction in a set as the tools report it
/// (docs/mastering.md): id, offset_mm, gain, and the first point's spread_mm,
/// uncertainty_mm and cycles.
nlohmann::json landmarkSummary(const inspect::CorrectionSet& set);

} // namespace hg::store
