#include "hullgauge/station/result_record.h"

#include <algorithm>
#include <limits>

namespace hg::station {

std::string_view toString(Verdict v)
{
    switch (v) {
    case Verdict::Pass:
        return "pass";
    case Verdict::Fail:
        return "fail";
    case Verdict::Aborted:
        return "aborted";
    case Verdict::Error:
        return "error";
    }
    return "error";
}

std::size_t InspectionRecord::landmarksFailed() const
{
    return static_cast<std::size_t>(std::count_if(landmarks.begin(), landmarks.end(), [](auto& l) { return !l.ok(); }));
}

nlohmann::json InspectionRecord::landmarksJson() const
{
    auto list = nlohmann::json::array();
    for (const auto& l : landmarks)
        list.push_back({{"id", l.id},
                        {"status", l.status},
                        {"error_min_mm", l.errorMinMm},
                        {"error_max_mm", l.errorMaxMm},
                        {"error_mm", l.errorMm},
                        {"tolerance_mm", l.toleranceMm}});
    return list;
}

PublishedResult InspectionRecord::toPublished(PlcStatus statusAfter) const
{
    constexpr auto kMax = std::numeric_limits<std::uint16_t>::max();
    PublishedResult r;
    r.seq = triggerSeq;
    r.manual = manual;
    r.statusAfter = statusAfter;
    r.faultCode = static_cast<std::uint16_t>(faultCode);
    switch (verdict) {
    case Verdict::Pass:
        r.result = PlcResult::Pass;
        break;
    case Verdict::Fail:
        r.result = PlcResult::Fail;
        break;
    case Verdict::Aborted:
    case Verdict::Error:
        r.result = PlcResult::Aborted;
        break;
    }
    r.landmarksFailed = static_cast<std::uint16_t>(std::min<std::size_t>(landmarksFailed(), kMax));
    r.landmarksTotal = static_cast<std::uint16_t>(std::min<std::size_t>(landmarks.size(), kMax));
    r.cycleMs = cycleMs;
    r.landmarkOk.reserve(landmarks.size());
    for (const auto& l : landmarks) r.landmarkOk.push_back(l.ok());
    return r;
}

} // namespace hg::station
