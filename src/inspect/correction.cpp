// The mastering correction and the temperature referral (docs/mastering.md).
#include "hullgauge/inspect/correction.h"

#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"

#include <cmath>
#include <fstream>
#include <sstream>

namespace hg::inspect {

double MasterPoint::meanSigmaMm() const
{
    return cycles > 0 ? spreadMm / std::sqrt(static_cast<double>(cycles)) : 0.0;
}

double LandmarkCorrection::gain() const
{
    if (points.size() < 2) return 1.0;
    return (points[1].certifiedMm - points[0].certifiedMm) / (points[1].measuredMm - points[0].measuredMm);
}

double LandmarkCorrection::offsetMm() const
{
    return points.empty() ? 0.0 : points[0].certifiedMm - gain() * points[0].measuredMm;
}

double LandmarkCorrection::correct(double readingMm) const
{
    return offsetMm() + gain() * readingMm;
}

// docs/mastering.md, "Uncertainty": the corrected value c₁ + g·(r − m₁) with
// g = (c₂ − c₁)/(m₂ − m₁) has the sensitivities 1 − t and t to the certified
// values and −g·(1 − t), −g·t to the readings' means, t = (r − m₁)/(m₂ − m₁);
// one point is t = 0, g = 1.
double LandmarkCorrection::uncertaintyAt(double readingMm) const
{
    if (points.empty()) return 0.0;
    const double g = gain();
    const MasterPoint& p1 = points[0];
    auto share = [g](const MasterPoint& p) {
        const double uc = p.certifiedUMm / 2.0, um = p.meanSigmaMm();
        return uc * uc + g * g * um * um;
    };
    double variance = share(p1);
    if (points.size() >= 2) {
        const double t = (readingMm - p1.measuredMm) / (points[1].measuredMm - p1.measuredMm);
        variance = (1.0 - t) * (1.0 - t) * share(p1) + t * t * share(points[1]);
    }
    return 2.0 * std::sqrt(variance);
}

MasteringMethod CorrectionSet::method() const
{
    for (const LandmarkCorrection& l : landmarks)
        if (l.points.size() >= 2) return MasteringMethod::TwoPoint;
    return MasteringMethod::OnePoint;
}

const LandmarkCorrection* CorrectionSet::find(const std::string& landmarkId) const
{
    for (const LandmarkCorrection& l : landmarks)
        if (l.id == landmarkId) return &l;
    return nullptr;
}

nlohmann::json toJson(const CorrectionSet& set)
{
    using nlohmann::json;
    json lms = json::array();
    for (const LandmarkCorrection& l : set.landmarks) {
        json points = json::array();
        for (const MasterPoint& p : l.points)
            points.push_back({{"master", p.master},
                              {"certified_mm", p.certifiedMm},
                              {"certified_uncertainty_mm", p.certifiedUMm},
                              {"measured_mm", p.measuredMm},
                              {"spread_mm", p.spreadMm},
                              {"cycles", p.cycles}});
        lms.push_back({{"id", l.id}, {"offset_mm", l.offsetMm()}, {"gain", l.gain()}, {"points", points}});
    }
    return {{"id", set.id},
            {"program", set.program},
            {"program_version", set.programVersion ? json(*set.programVersion) : json(nullptr)},
            {"material", set.material},
            {"created_unix_ms", set.createdUnixMs},
            {"temperature_c", set.temperatureC ? json(*set.temperatureC) : json(nullptr)},
            {"method", enumName(set.method())},
            {"landmarks", lms}};
}

namespace {

/// A field of a correction set's JSON, or InputError naming it.
const nlohmann::json& field(const nlohmann::json& j, const std::string& key, const std::string& name,
                            const std::string& at)
{
    if (!j.is_object() || !j.contains(key)) throw InputError(name, at + key, "missing");
    return j.at(key);
}

double number(const nlohmann::json& j, const std::string& key, const std::string& name, const std::string& at)
{
    const nlohmann::json& v = field(j, key, name, at);
    if (!v.is_number() || !std::isfinite(v.get<double>())) throw InputError(name, at + key, "expected a number");
    return v.get<double>();
}

MasterPoint pointFromJson(const nlohmann::json& p, const std::string& name, const std::string& at)
{
    MasterPoint point;
    const nlohmann::json& master = field(p, "master", name, at);
    if (!master.is_string()) throw InputError(name, at + "master", "expected a string");
    point.master = master.get<std::string>();
    point.certifiedMm = number(p, "certified_mm", name, at);
    point.certifiedUMm = number(p, "certified_uncertainty_mm", name, at);
    point.measuredMm = number(p, "measured_mm", name, at);
    point.spreadMm = number(p, "spread_mm", name, at);
    point.cycles = static_cast<int>(number(p, "cycles", name, at));
    if (point.certifiedUMm < 0 || point.spreadMm < 0 || point.cycles < 1)
        throw InputError(name, at + "points", "negative uncertainty or spread, or fewer than 1 cycle");
    return point;
}

LandmarkCorrection landmarkFromJson(const nlohmann::json& l, const std::string& name, const std::string& at)
{
    LandmarkCorrection c;
    const nlohmann::json& id = field(l, "id", name, at);
    if (!id.is_string() || id.get<std::string>().empty()) throw InputError(name, at + "id", "expected a landmark id");
    c.id = id.get<std::string>();
    const nlohmann::json& points = field(l, "points", name, at);
    if (!points.is_array() || points.empty() || points.size() > 2)
        throw InputError(name, at + "points", "expected one or two master points");
    for (std::size_t k = 0; k < points.size(); ++k)
        c.points.push_back(pointFromJson(points[k], name, at + "points[" + std::to_string(k) + "]."));
    if (c.points.size() == 2 && c.points[0].measuredMm == c.points[1].measuredMm)
        throw InputError(name, at + "points", "two masters read alike: no gain through them");
    return c;
}

} // namespace

CorrectionSet correctionSetFromJson(const nlohmann::json& j, const std::string& name)
{
    CorrectionSet set;
    const nlohmann::json& id = field(j, "id", name, "");
    if (!id.is_string() || id.get<std::string>().empty()) throw InputError(name, "id", "expected a non-empty string");
    set.id = id.get<std::string>();
    set.program = static_cast<int>(number(j, "program", name, ""));
    const nlohmann::json& version = field(j, "program_version", name, "");
    if (!version.is_null()) set.programVersion = static_cast<int>(number(j, "program_version", name, ""));
    const nlohmann::json& material = field(j, "material", name, "");
    if (!material.is_string()) throw InputError(name, "material", "expected a string");
    set.material = material.get<std::string>();
    set.createdUnixMs = static_cast<std::int64_t>(number(j, "created_unix_ms", name, ""));
    if (j.contains("temperature_c") && !j["temperature_c"].is_null())
        set.temperatureC = number(j, "temperature_c", name, "");
    const nlohmann::json& lms = field(j, "landmarks", name, "");
    if (!lms.is_array()) throw InputError(name, "landmarks", "expected an array");
    for (std::size_t k = 0; k < lms.size(); ++k)
        set.landmarks.push_back(landmarkFromJson(lms[k], name, "landmarks[" + std::to_string(k) + "]."));
    return set;
}

void saveCorrectionSet(const CorrectionSet& set, const std::filesystem::path& file)
{
    replaceFileDurably(file, toJson(set).dump(2) + "\n");
}

CorrectionSet loadCorrectionSet(const std::filesystem::path& file)
{
    std::ifstream in(file);
    if (!in) throw InputError(file.string(), "", "cannot be read");
    std::ostringstream text;
    text << in.rdbuf();
    return correctionSetFromJson(parseJson(text.str(), file.string()), file.string());
}

double thermalOffsetMm(double expansionPerK, double temperatureC, const geometry::Vec3& position,
                       const geometry::Vec3& normal, const geometry::Vec3& centre)
{
    // ISO 1: dimensions are those at 20 °C. A free part grows uniformly about
    // the point it is held by, so a surface point moves by α·ΔT·(p − c).
    return expansionPerK * (temperatureC - 20.0) * (position - centre).dot(normal.normalized());
}

void addReferral(nlohmann::json& landmark, const AppliedReferral& a)
{
    landmark["raw_deviation_mm"] = a.rawDeviationMm;
    landmark["raw_uncertainty_mm"] = a.rawUncertaintyMm;
    landmark["thermal_mm"] = a.thermalMm;
    landmark["thermal_uncertainty_mm"] = a.thermalUncertaintyMm;
    landmark["correction"] = a.correctionId.empty() ? nlohmann::json(nullptr)
                                                    : nlohmann::json{{"id", a.correctionId},
                                                                     {"offset_mm", a.correctionOffsetMm},
                                                                     {"gain", a.correctionGain},
                                                                     {"uncertainty_mm", a.correctionUncertaintyMm}};
}

std::optional<AppliedReferral> referralOf(const nlohmann::json& l, const std::string& name)
{
    if (!l.is_object() || !l.contains("raw_deviation_mm")) return std::nullopt;
    AppliedReferral a;
    a.rawDeviationMm = number(l, "raw_deviation_mm", name, "");
    a.rawUncertaintyMm = number(l, "raw_uncertainty_mm", name, "");
    a.thermalMm = number(l, "thermal_mm", name, "");
    if (l.contains("thermal_uncertainty_mm")) a.thermalUncertaintyMm = number(l, "thermal_uncertainty_mm", name, "");
    const nlohmann::json& c = field(l, "correction", name, "");
    if (!c.is_null()) {
        const nlohmann::json& id = field(c, "id", name, "correction.");
        if (!id.is_string()) throw InputError(name, "correction.id", "expected a string");
        a.correctionId = id.get<std::string>();
        a.correctionOffsetMm = number(c, "offset_mm", name, "correction.");
        a.correctionGain = number(c, "gain", name, "correction.");
        a.correctionUncertaintyMm = number(c, "uncertainty_mm", name, "correction.");
    }
    return a;
}

} // namespace hg::inspect
