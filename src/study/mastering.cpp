// Mastering (docs/mastering.md): the certificate and the correction set.
#include "hullgauge/study/mastering.h"

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"

#include <cmath>
#include <set>

namespace hg::study {

namespace {

MasterCertificate readCertificate(const ConfigNode& root, const std::filesystem::path& file)
{
    if (!root.isMap()) root.fail("expected a map with keys master, certificate, landmarks");
    root.allowOnlyKeys({"master", "certificate", "landmarks"});
    MasterCertificate c;
    c.file = file;
    c.serial = root["master"].asString();
    if (c.serial.empty()) root["master"].fail("the master's serial is empty");
    if (auto n = root.optional("certificate")) c.certificate = n->asString();
    const ConfigNode landmarks = root["landmarks"];
    if (!landmarks.isMap() || landmarks.size() == 0)
        landmarks.fail("expected a map of landmark id -> {value_mm, uncertainty_mm}");
    for (const std::string& id : landmarks.keys()) {
        const ConfigNode n = landmarks[id];
        if (!n.isMap()) n.fail("expected {value_mm, uncertainty_mm}");
        n.allowOnlyKeys({"value_mm", "uncertainty_mm"});
        CertifiedValue v;
        v.valueMm = n["value_mm"].asDoubleIn(-100.0, 100.0);
        v.uncertaintyMm = n["uncertainty_mm"].asDoubleIn(0.0, 10.0);
        v.line = n.line();
        c.landmarks[id] = v;
    }
    return c;
}

} // namespace

MasterCertificate loadMasterCertificate(const std::filesystem::path& file)
{
    return readCertificate(ConfigNode::loadFile(file), file);
}

MasterCertificate parseMasterCertificate(const std::string& text, const std::string& name)
{
    return readCertificate(ConfigNode::parse(text, name), name);
}

std::vector<StudyRecord> uncorrectedRecords(std::vector<StudyRecord> records)
{
    for (StudyRecord& r : records) {
        if (!r.landmarks.is_array()) continue;
        for (nlohmann::json& l : r.landmarks) {
            const auto referral = inspect::referralOf(l, "result " + std::to_string(r.id));
            if (referral) l["deviation_mm"] = referral->rawDeviationMm - referral->thermalMm;
        }
    }
    return records;
}

namespace {

/// One master's point at landmark `id`: its certified value and the mean and
/// spread of its cycles' readings (the type-1 study's x̄ and s).
inspect::MasterPoint pointOf(const MasterCertificate& master, const std::string& id,
                             const std::vector<LandmarkSeries>& series)
{
    const CertifiedValue& certified = master.landmarks.at(id);
    for (const LandmarkSeries& s : series) {
        if (s.id != id) continue;
        if (!s.problem.empty() || s.source != ValueSource::Deviation)
            throw InputError(master.file.string(), "landmarks." + id,
                             "the master's cycles give no sub-voxel deviation for every cycle here" +
                                 (s.problem.empty() ? std::string() : " (" + s.problem + ")"),
                             certified.line);
        const Type1Result t = type1(s.values, 1.0, certified.valueMm, Limits{1});
        return {master.serial, certified.valueMm, certified.uncertaintyMm,
                t.mean,        t.stddev,          static_cast<int>(s.values.size())};
    }
    throw InputError(master.file.string(), "landmarks." + id, "the master's cycles do not have this landmark",
                     certified.line);
}

} // namespace

inspect::CorrectionSet computeCorrections(const std::vector<MasterCertificate>& masters,
                                          const std::vector<std::vector<StudyRecord>>& cycles,
                                          const MasteringTarget& target)
{
    if (masters.empty() || masters.size() > 2 || cycles.size() != masters.size())
        throw ArgumentError("masters: expected one or two masters, each with its cycles, got " +
                            std::to_string(masters.size()) + " masters and " + std::to_string(cycles.size()) +
                            " lists of cycles");
    inspect::CorrectionSet set;
    set.program = target.program;
    set.programVersion = target.programVersion;
    set.material = target.material;
    set.createdUnixMs = target.createdUnixMs;
    set.temperatureC = target.temperatureC;
    set.id = "p" + std::to_string(target.program) +
             (target.programVersion ? "-v" + std::to_string(*target.programVersion) : std::string("-draft")) +
             (target.material.empty() ? std::string() : "-" + target.material) + "-" + target.createdUtc;
    std::vector<std::vector<LandmarkSeries>> series;
    for (const auto& c : cycles) series.push_back(collectSeries(c));
    for (const auto& [id, certified] : masters[0].landmarks) {
        inspect::LandmarkCorrection correction{id, {pointOf(masters[0], id, series[0])}};
        if (masters.size() == 2) {
            if (!masters[1].landmarks.count(id))
                throw InputError(masters[1].file.string(), "landmarks." + id,
                                 "two-point mastering needs this landmark certified on both masters");
            const inspect::MasterPoint second = pointOf(masters[1], id, series[1]);
            const double apart = std::abs(second.certifiedMm - correction.points[0].certifiedMm);
            if (apart <= std::max(second.certifiedUMm, correction.points[0].certifiedUMm))
                throw InputError(masters[1].file.string(), "landmarks." + id,
                                 "the two masters' certified values lie within their U of each other: no gain can "
                                 "be told",
                                 masters[1].landmarks.at(id).line);
            correction.points.push_back(second);
        }
        set.landmarks.push_back(std::move(correction));
    }
    if (masters.size() == 2)
        for (const auto& [id, certified] : masters[1].landmarks)
            if (!masters[0].landmarks.count(id))
                throw InputError(masters[0].file.string(), "landmarks." + id,
                                 "two-point mastering needs this landmark certified on both masters");
    return set;
}

} // namespace hg::study
