// The Pareto of what fails (docs/spc.md, "Pareto"): over a selection of
// cycles, how often each landmark failed (by its status) and how often each
// fault code ended a cycle, most frequent first, with the cumulative share —
// the few causes behind most rejects. Pure computation on stored records;
// the web HMI reads the store and names the fault codes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace hg::study {

/// One cycle as the result store holds it.
struct ParetoRecord {
    std::int64_t id = 0;      ///< the row id, for messages
    std::string verdict;      ///< pass, fail, aborted, error
    int faultCode = 0;        ///< 0: none
    nlohmann::json landmarks; ///< the record's `landmarks_json` (array of objects)
};

/// One bar: a landmark id or a fault code, its count, and the share of all
/// counts of its chart up to and including it.
struct ParetoBar {
    std::string key;
    std::size_t count = 0;
    double cumulativeShare = 0.0;
    std::map<std::string, std::size_t> byStatus; ///< landmarks: the count per failing status
};

struct Pareto {
    std::size_t cycles = 0;
    std::size_t failedCycles = 0;     ///< verdict fail
    std::size_t faultedCycles = 0;    ///< a fault code other than 0
    std::vector<ParetoBar> landmarks; ///< failed landmark readings, most first (ties by id)
    std::vector<ParetoBar> faults;    ///< fault codes (as decimal text), most first (ties by code)
};

/// Counts every landmark entry whose status is not `ok` and every non-zero
/// fault code. Throws hg::InputError naming the record and field when an
/// entry has no id or its status is no landmark status.
Pareto paretoOf(const std::vector<ParetoRecord>& records);

/// {cycles, failed_cycles, faulted_cycles, landmarks: [{id, count,
/// cumulative_share, by_status}], faults: [{code, count, cumulative_share}]}.
nlohmann::json toJson(const Pareto& p);

} // namespace hg::study
