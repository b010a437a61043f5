// The gauge studies of docs/study.md: formulas and acceptance limits there.
#include "hullgauge/study/gauge_study.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "sample_statistics.h"

#include <algorithm>
#include <cmath>

namespace hg::study {

namespace {

std::string cycleName(const StudyRecord& r)
{
    return "cycle " + std::to_string(r.id);
}

/// The record's entry for landmark `id`, or null when it lists none.
const nlohmann::json* findLandmark(const StudyRecord& record, const std::string& id)
{
    for (const auto& l : record.landmarks)
        if (l.is_object() && l.value("id", std::string()) == id) return &l;
    return nullptr;
}

/// The landmark ids of every record, in the order they first appear.
std::vector<std::string> landmarkIds(const std::vector<StudyRecord>& records)
{
    std::vector<std::string> ids;
    for (const auto& r : records) {
        if (!r.landmarks.is_array())
            throw InputError("", cycleName(r) + ".landmarks_json", "expected a JSON array of landmarks");
        for (const auto& l : r.landmarks) {
            if (!l.is_object() || !l.contains("id") || !l["id"].is_string())
                throw InputError("", cycleName(r) + ".landmarks_json", "a landmark without a string \"id\"");
            const auto id = l["id"].get<std::string>();
            if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
        }
    }
    return ids;
}

bool isNumber(const nlohmann::json& entry, const char* key)
{
    return entry.contains(key) && entry[key].is_number();
}

/// The enumerator `entry[key]` names, nullopt when the entry has no `key`; any
/// other value is bad input naming the field.
template <class E>
std::optional<E> enumOf(const nlohmann::json& entry, const char* key, const std::string& field, const char* what)
{
    if (!entry.contains(key)) return std::nullopt;
    const auto& value = entry[key];
    if (value.is_string())
        if (const auto e = parseEnum<E>(value.get<std::string>())) return e;
    throw InputError("", field + "." + key,
                     "unknown " + std::string(what) + " " + value.dump() + " (expected " +
                         enumNameList<E>(", ", " or ") + ")");
}

} // namespace

std::optional<inspect::LandmarkStatus> statusOf(const nlohmann::json& entry, const std::string& field)
{
    return enumOf<inspect::LandmarkStatus>(entry, "status", field, "landmark status");
}

std::optional<inspect::Decision> decisionOf(const nlohmann::json& entry, const std::string& field)
{
    return enumOf<inspect::Decision>(entry, "decision", field, "decision");
}

// limits_mm when the landmark has it, else ±tolerance_mm (docs/study.md).
Zone zoneOf(const nlohmann::json& entry, const std::string& field)
{
    if (entry.contains("limits_mm") && !entry["limits_mm"].is_null()) {
        const auto& limits = entry["limits_mm"];
        if (!limits.is_array() || limits.size() != 2 || !limits[0].is_number() || !limits[1].is_number())
            throw InputError("", field + ".limits_mm", "expected [lower, upper] in mm");
        return {limits[0].get<double>(), limits[1].get<double>()};
    }
    if (!isNumber(entry, "tolerance_mm")) throw InputError("", field, "neither limits_mm nor tolerance_mm");
    const double t = entry["tolerance_mm"].get<double>();
    return {-t, t};
}

namespace {

/// A landmark's series over all records, or its problem.
LandmarkSeries seriesOf(const std::string& id, const std::vector<StudyRecord>& records, MissingValues missing)
{
    LandmarkSeries series{id, {}, ValueSource::Deviation, {}, {}, {}, {}, {}};
    std::vector<const nlohmann::json*> entries;
    for (std::size_t cycle = 0; cycle < records.size(); ++cycle) {
        const auto& record = records[cycle];
        const auto* entry = findLandmark(record, id);
        const auto field = cycleName(record) + ".landmarks." + id;
        const auto status = entry ? statusOf(*entry, field) : std::nullopt;
        const bool noValue =
            !entry || status == inspect::LandmarkStatus::NotFound || status == inspect::LandmarkStatus::NotObservable;
        if (noValue && missing == MissingValues::Gap) {
            series.gaps.push_back({cycle, record.serial, entry ? std::string(enumName(*status)) : "absent"});
            continue;
        }
        if (!entry) {
            series.problem = cycleName(record) + " has no result for it";
            return series;
        }
        if (noValue) {
            series.problem = cycleName(record) + " reports it " + std::string(enumName(*status));
            return series;
        }
        const Zone zone = zoneOf(*entry, field);
        if (entries.empty()) series.zone = zone;
        if (zone != series.zone) {
            series.problem = "its tolerance zone changed within the selection (" + cycleName(record) + ": [" +
                             formatNumber(zone.lower) + ", " + formatNumber(zone.upper) + "] mm)";
            return series;
        }
        if (!isNumber(*entry, "deviation_mm")) series.source = ValueSource::BracketMiddle;
        if (!isNumber(*entry, "error_mm"))
            throw InputError("", cycleName(record) + ".landmarks." + id + ".error_mm", "expected a number");
        entries.push_back(entry);
        series.serials.push_back(record.serial);
        series.cycles.push_back(cycle);
    }
    const char* key = series.source == ValueSource::Deviation ? "deviation_mm" : "error_mm";
    for (const auto* entry : entries) series.values.push_back((*entry)[key].get<double>());
    return series;
}

/// a / b for b ≥ 0 where b = 0 gives ±∞ by the sign of a (0 for a = 0).
double ratio(double a, double b)
{
    if (b > 0.0) return a / b;
    return a > 0.0 ? kUnbounded : (a < 0.0 ? -kUnbounded : 0.0);
}

nlohmann::json number(double v)
{
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    return v;
}

template <class T> nlohmann::json optionalJson(const std::optional<T>& v)
{
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

} // namespace

std::vector<LandmarkSeries> collectSeries(const std::vector<StudyRecord>& records, MissingValues missing)
{
    std::vector<LandmarkSeries> out;
    for (const auto& id : landmarkIds(records)) out.push_back(seriesOf(id, records, missing));
    return out;
}

Type1Result type1(const std::vector<double>& values, double tolerance, double reference, const Limits& limits)
{
    Type1Result r;
    r.n = values.size();
    r.tolerance = tolerance;
    r.reference = reference;
    if (r.n >= 1) {
        r.mean = mean(values);
        r.bias = r.mean - reference;
    }
    if (r.n >= 2) r.stddev = sampleStddev(values, r.mean);
    if (r.n < limits.minType1Values) {
        r.notEvaluated = std::to_string(r.n) + " values, fewer than the " + std::to_string(limits.minType1Values) +
                         " a type-1 study needs";
        return r;
    }
    if (!(tolerance > 0.0)) {
        r.notEvaluated = "tolerance zone of width " + formatNumber(tolerance) + " mm";
        return r;
    }
    // Cg = 0.2·T / 6s, Cgk = (0.1·T − |x̄ − x_ref|) / 3s (VDA 5, Bosch booklet 10).
    r.cg = ratio(limits.type1Share * tolerance, 6.0 * r.stddev);
    r.cgk = ratio(limits.type1Share / 2.0 * tolerance - std::abs(r.bias), 3.0 * r.stddev);
    r.capable = r.cg >= limits.cgMin && r.cgk >= limits.cgkMin;
    r.evaluated = true;
    return r;
}

Acceptance grrAcceptance(double percent, const Limits& limits)
{
    if (percent <= limits.grrAcceptable) return Acceptance::Acceptable;
    if (percent <= limits.grrConditional) return Acceptance::Conditional;
    return Acceptance::NotAcceptable;
}

namespace {

/// "'A' 3, 'B' 2": every part's number of trials.
std::string countsOf(const PartTrials& byPart)
{
    std::string s;
    for (const auto& [serial, values] : byPart)
        s += (s.empty() ? "'" : ", '") + serial + "' " + std::to_string(values.size());
    return s;
}

void checkLayout(const PartTrials& byPart)
{
    if (byPart.size() < 2)
        throw InputError("", "type3",
                         std::to_string(byPart.size()) + " part(s) (" + countsOf(byPart) +
                             "): a gauge R&R needs at least 2 parts (10 recommended)");
    const auto r = byPart.front().second.size();
    for (const auto& [serial, values] : byPart)
        if (values.size() != r)
            throw InputError("", "type3",
                             "unbalanced: part '" + serial + "' has " + std::to_string(values.size()) +
                                 " trials, part '" + byPart.front().first + "' " + std::to_string(r) +
                                 " (trials per part: " + countsOf(byPart) + ")");
    if (r < 2)
        throw InputError("", "type3",
                         "1 trial per part (" + countsOf(byPart) + "): a gauge R&R needs 2 or 3 trials of every part");
}

/// One-way ANOVA of p parts × r trials: the sums and mean squares.
void analyseVariance(const PartTrials& byPart, Type3Result& r)
{
    const auto p = static_cast<double>(r.parts), n = static_cast<double>(r.trials);
    std::vector<double> all;
    for (const auto& part : byPart) all.insert(all.end(), part.second.begin(), part.second.end());
    r.grandMean = mean(all);
    for (const auto& part : byPart) {
        const double m = mean(part.second);
        r.ssParts += n * (m - r.grandMean) * (m - r.grandMean);
        for (double x : part.second) r.ssError += (x - m) * (x - m);
    }
    r.msParts = r.ssParts / (p - 1.0);
    r.msError = r.ssError / (p * (n - 1.0));
}

} // namespace

Type3Result type3(const PartTrials& byPart, double tolerance, const Limits& limits)
{
    checkLayout(byPart);
    Type3Result r;
    r.parts = byPart.size();
    r.trials = byPart.front().second.size();
    r.tolerance = tolerance;
    analyseVariance(byPart, r);
    // AIAG MSA 4th ed., ANOVA method with one appraiser: GRR is the repeatability alone.
    r.ev = std::sqrt(r.msError);
    r.pv = std::sqrt(std::max(0.0, (r.msParts - r.msError) / static_cast<double>(r.trials)));
    r.grr = r.ev;
    r.tv = std::sqrt(r.grr * r.grr + r.pv * r.pv);
    if (r.tv > 0.0) r.percentGrr = 100.0 * r.grr / r.tv;
    if (tolerance > 0.0) r.percentTolerance = 100.0 * 6.0 * r.grr / tolerance;
    if (r.grr > 0.0) r.ndc = static_cast<long>(std::floor(1.41 * r.pv / r.grr));
    if (r.percentGrr) r.acceptanceVariation = grrAcceptance(*r.percentGrr, limits);
    if (r.percentTolerance) r.acceptanceTolerance = grrAcceptance(*r.percentTolerance, limits);
    // The worse of both; a gauge that repeats exactly (GRR = 0) is acceptable.
    r.acceptance = Acceptance::Acceptable;
    for (const auto& a : {r.acceptanceVariation, r.acceptanceTolerance})
        if (a) r.acceptance = std::max(r.acceptance, *a);
    return r;
}

PartTrials groupByPart(const LandmarkSeries& series)
{
    PartTrials out;
    for (std::size_t i = 0; i < series.values.size(); ++i) {
        auto it = std::find_if(out.begin(), out.end(), [&](auto& p) { return p.first == series.serials[i]; });
        if (it == out.end()) it = out.insert(out.end(), {series.serials[i], {}});
        it->second.push_back(series.values[i]);
    }
    return out;
}

void checkType3Layout(const std::vector<StudyRecord>& records)
{
    PartTrials byPart;
    for (const auto& record : records) {
        if (record.serial.empty())
            throw InputError("", cycleName(record),
                             "no serial: the parts of a type-3 study are told apart by their serials");
        auto it = std::find_if(byPart.begin(), byPart.end(), [&](auto& p) { return p.first == record.serial; });
        if (it == byPart.end()) it = byPart.insert(byPart.end(), {record.serial, {}});
        it->second.push_back(0.0);
    }
    checkLayout(byPart);
}

nlohmann::json toJson(const Type1Result& r)
{
    nlohmann::json j{{"n", r.n},          {"evaluated", r.evaluated}, {"tolerance_mm", r.tolerance},
                     {"mean_mm", r.mean}, {"stddev_mm", r.stddev},    {"reference_mm", r.reference},
                     {"bias_mm", r.bias}};
    if (!r.evaluated) {
        j["not_evaluated"] = r.notEvaluated;
        return j;
    }
    j["cg"] = number(r.cg);
    j["cgk"] = number(r.cgk);
    j["capable"] = r.capable;
    return j;
}

nlohmann::json toJson(const Type3Result& r)
{
    auto acceptance = [](const std::optional<Acceptance>& a) {
        return a ? nlohmann::json(std::string(enumName(*a))) : nlohmann::json(nullptr);
    };
    return {{"parts", r.parts},
            {"trials", r.trials},
            {"tolerance_mm", r.tolerance},
            {"grand_mean_mm", r.grandMean},
            {"ss_parts", r.ssParts},
            {"ss_error", r.ssError},
            {"ms_parts", r.msParts},
            {"ms_error", r.msError},
            {"ev_mm", r.ev},
            {"pv_mm", r.pv},
            {"grr_mm", r.grr},
            {"tv_mm", r.tv},
            {"percent_grr", optionalJson(r.percentGrr)},
            {"percent_tolerance", optionalJson(r.percentTolerance)},
            {"ndc", optionalJson(r.ndc)},
            {"acceptance_variation", acceptance(r.acceptanceVariation)},
            {"acceptance_tolerance", acceptance(r.acceptanceTolerance)},
            {"acceptance", std::string(enumName(r.acceptance))}};
}

} // namespace hg::study
