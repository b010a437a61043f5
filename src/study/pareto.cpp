// The Pareto of docs/spc.md, "Pareto".
#include "hullgauge/study/pareto.h"

#include "hullgauge/common/error.h"
#include "hullgauge/study/gauge_study.h"

#include <algorithm>

namespace hg::study {

namespace {

/// Bars from counts: most first, ties in key order, each with its cumulative share.
std::vector<ParetoBar> ranked(std::map<std::string, ParetoBar> counted, bool numericKeys)
{
    std::vector<ParetoBar> bars;
    std::size_t total = 0;
    for (auto& [key, bar] : counted) {
        total += bar.count;
        bars.push_back(std::move(bar));
    }
    const auto before = [numericKeys](const ParetoBar& a, const ParetoBar& b) {
        if (a.count != b.count) return a.count > b.count;
        if (numericKeys && a.key.size() != b.key.size()) return a.key.size() < b.key.size();
        return a.key < b.key;
    };
    std::sort(bars.begin(), bars.end(), before);
    std::size_t running = 0;
    for (auto& bar : bars) {
        running += bar.count;
        bar.cumulativeShare = static_cast<double>(running) / static_cast<double>(total);
    }
    return bars;
}

} // namespace

Pareto paretoOf(const std::vector<ParetoRecord>& records)
{
    Pareto p;
    std::map<std::string, ParetoBar> landmarks, faults;
    for (const auto& r : records) {
        ++p.cycles;
        if (r.verdict == "fail") ++p.failedCycles;
        if (r.faultCode != 0) {
            ++p.faultedCycles;
            auto& bar = faults[std::to_string(r.faultCode)];
            bar.key = std::to_string(r.faultCode);
            ++bar.count;
        }
        if (!r.landmarks.is_array()) continue;
        for (const auto& entry : r.landmarks) {
            const std::string where = "result " + std::to_string(r.id) + ".landmarks";
            if (!entry.is_object() || !entry.contains("id") || !entry["id"].is_string())
                throw InputError("", where, "an entry without an id");
            const std::string id = entry["id"].get<std::string>();
            const auto status = statusOf(entry, where + "." + id);
            if (!status || *status == inspect::LandmarkStatus::Ok) continue;
            auto& bar = landmarks[id];
            bar.key = id;
            ++bar.count;
            ++bar.byStatus[std::string(enumName(*status))];
        }
    }
    p.landmarks = ranked(std::move(landmarks), false);
    p.faults = ranked(std::move(faults), true);
    return p;
}

nlohmann::json toJson(const Pareto& p)
{
    auto landmarks = nlohmann::json::array();
    for (const auto& b : p.landmarks)
        landmarks.push_back(
            {{"id", b.key}, {"count", b.count}, {"cumulative_share", b.cumulativeShare}, {"by_status", b.byStatus}});
    auto faults = nlohmann::json::array();
    for (const auto& b : p.faults)
        faults.push_back({{"code", std::stoi(b.key)}, {"count", b.count}, {"cumulative_share", b.cumulativeShare}});
    return {{"cycles", p.cycles},
            {"failed_cycles", p.failedCycles},
            {"faulted_cycles", p.faultedCycles},
            {"landmarks", landmarks},
            {"faults", faults}};
}

} // namespace hg::study
