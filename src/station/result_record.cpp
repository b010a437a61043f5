#include "hullgauge/station/result_record.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hg::station {

std::size_t InspectionRecord::landmarksFailed() const
{
    return static_cast<std::size_t>(std::count_if(landmarks.begin(), landmarks.end(), [](auto& l) { return !l.ok(); }));
}

nlohmann::json toJson(const LandmarkOutcome& l)
{
    nlohmann::json j{{"id", l.id},
                     {"status", enumName(l.status)},
                     {"error_min_mm", l.errorMinMm},
                     {"error_max_mm", l.errorMaxMm},
                     {"error_mm", l.errorMm},
                     {"tolerance_mm", l.toleranceMm}};
    if (l.deviationMm) j["deviation_mm"] = *l.deviationMm;
    if (l.uncertaintyMm) j["uncertainty_mm"] = *l.uncertaintyMm;
    if (l.decision) j["decision"] = enumName(*l.decision);
    if (l.limitsMm) j["limits_mm"] = {l.limitsMm->first, l.limitsMm->second};
    if (l.referral) inspect::addReferral(j, *l.referral);
    return j;
}

nlohmann::json InspectionRecord::landmarksJson() const
{
    auto list = nlohmann::json::array();
    for (const auto& l : landmarks) list.push_back(toJson(l));
    return list;
}

nlohmann::json toJson(const CycleTimings& timings)
{
    auto j = nlohmann::json::object();
    for (const auto& [step, time] : timings) j[std::string(enumName(step))] = time.count();
    return j;
}

namespace {

/// `value` × `scale` rounded into a register: 0 for no value, 65535 beyond.
std::uint16_t saturating(const nlohmann::json& value, double scale)
{
    if (!value.is_number()) return 0;
    const double v = std::round(value.get<double>() * scale);
    if (!(v > 0.0)) return 0;
    return v >= 65535.0 ? std::uint16_t{65535} : static_cast<std::uint16_t>(v);
}

} // namespace

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
    if (alignment.is_object()) {
        r.seatShiftUm = saturating(alignment.value("shift_mm", nlohmann::json()), 1000.0);
        r.seatRotationMdeg = saturating(alignment.value("rotation_deg", nlohmann::json()), 1000.0);
    }
    r.landmarkOk.reserve(landmarks.size());
    for (const auto& l : landmarks) r.landmarkOk.push_back(l.ok());
    if (health) r.healthWarnings = vision::healthWarningBits(health->warnings);
    return r;
}

} // namespace hg::station
