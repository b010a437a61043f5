// hullgauge study type1|type3 --store DB [...]: the gauge studies of
// docs/study.md on the cycles of the result store (docs/daemon.md,
// "Results"), read read-only. The store is read here; the studies themselves
// are pure (hullgauge/study/gauge_study.h).
#include "command.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/study/gauge_study.h"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <spdlog/fmt/fmt.h>
#include <sstream>

namespace hg::cli {
namespace {

using nlohmann::json;

enum class Kind { Type1, Type3 };

struct StudyOptions {
    std::string store;
    int program = 0;
    std::string serial;
    std::string since, until;
    std::string purpose;
    std::string reference;
    std::size_t minCycles = 25;
    std::vector<std::string> landmarks; ///< only these (docs/contracts.md §8 `--landmark ID`); empty: all
    bool json = false;
    std::string out;
};

/// The series of the landmarks --landmark names (all without it); an id no
/// selected cycle has is bad input naming it.
std::vector<study::LandmarkSeries> chosenSeries(std::vector<study::LandmarkSeries> series, const StudyOptions& o)
{
    if (o.landmarks.empty()) return series;
    for (const auto& id : o.landmarks)
        if (std::none_of(series.begin(), series.end(), [&](const auto& s) { return s.id == id; }))
            throw InputError("", "--landmark", "no landmark '" + id + "' in the selected cycles");
    std::erase_if(series, [&](const auto& s) {
        return std::find(o.landmarks.begin(), o.landmarks.end(), s.id) == o.landmarks.end();
    });
    return series;
}

/// Which cycles the study takes: pass/fail cycles (never aborted or error)
/// of one purpose (or any), optionally one program, one serial, a time window.
struct Selection {
    std::string purpose;
    std::optional<int> program;
    std::string serial;
    std::string since, until; ///< as given
    std::optional<std::int64_t> sinceMs, untilMs;
};

/// The selected cycles in the order they were stored; the programs they span.
std::vector<study::StudyRecord> readRecords(const store::ResultReader& store, const Selection& sel,
                                            std::set<int>& programs)
{
    store::ResultQuery q;
    q.verdicts = {"pass", "fail"};
    if (sel.purpose != "any") q.purpose = sel.purpose;
    q.program = sel.program;
    q.serial = sel.serial;
    q.sinceMs = sel.sinceMs;
    q.untilMs = sel.untilMs;
    q.newestFirst = false;
    std::vector<study::StudyRecord> records;
    for (auto& row : store.select(q)) {
        programs.insert(row["program"].get<int>());
        records.push_back(
            {row["id"].get<std::int64_t>(), row["serial"].get<std::string>(), std::move(row["landmarks"])});
    }
    return records;
}

std::string describe(const Selection& sel)
{
    std::string s = "pass/fail cycles with purpose " + sel.purpose;
    if (sel.program) s += ", program " + std::to_string(*sel.program);
    if (!sel.serial.empty()) s += ", serial '" + sel.serial + "'";
    if (sel.sinceMs) s += ", started at or after " + sel.since;
    if (sel.untilMs) s += ", started before " + sel.until;
    return s;
}

/// The selection's cycles: one program, at least one cycle.
std::vector<study::StudyRecord> selectCycles(const StudyOptions& o, Selection& sel)
{
    const store::ResultReader store(o.store);
    std::set<int> programs;
    auto records = readRecords(store, sel, programs);
    if (records.empty()) throw InputError("", "--store", o.store + " holds no " + describe(sel));
    if (programs.size() > 1) {
        std::string list;
        for (int p : programs) list += (list.empty() ? "" : ", ") + std::to_string(p);
        throw InputError("", "--program", "the selected cycles span programs " + list + ": choose one");
    }
    sel.program = *programs.begin();
    return records;
}

/// The reference file of a type-1 study: landmark id → x_ref in mm (docs/study.md).
std::map<std::string, double> loadReference(const std::string& file, const std::vector<study::LandmarkSeries>& series)
{
    std::map<std::string, double> out;
    if (file.empty()) return out;
    const auto root = ConfigNode::loadFile(file);
    if (!root.isMap()) throw InputError(file, "", "expected a mapping of landmark id to reference value in mm");
    for (const auto& id : root.keys()) {
        const bool known = std::any_of(series.begin(), series.end(), [&](auto& s) { return s.id == id; });
        if (!known) throw InputError(file, id, "no such landmark in the selected cycles", root[id].line());
        out[id] = root[id].asDouble();
    }
    return out;
}

json sourceJson(const study::LandmarkSeries& s)
{
    json j{{"id", s.id}, {"values", std::string(enumName(s.source))}, {"zone_mm", {s.zone.lower, s.zone.upper}}};
    if (s.source == study::ValueSource::BracketMiddle) j["note"] = "bracket middle: resolution one voxel";
    return j;
}

json runType1(const std::vector<study::StudyRecord>& records, const StudyOptions& o)
{
    const auto series = chosenSeries(study::collectSeries(records), o);
    const auto reference = loadReference(o.reference, series);
    study::Limits limits;
    limits.minType1Values = o.minCycles;
    auto landmarks = json::array();
    for (const auto& s : series) {
        auto j = sourceJson(s);
        if (!s.problem.empty()) {
            j.update({{"n", s.values.size()}, {"evaluated", false}, {"not_evaluated", s.problem}});
        } else {
            const auto it = reference.find(s.id);
            const auto r = study::type1(s.values, s.zone.width(), it == reference.end() ? 0.0 : it->second, limits);
            j.update(toJson(r));
            if (r.evaluated && r.stddev == 0.0 && s.source == study::ValueSource::BracketMiddle)
                j["note"] = j["note"].get<std::string>() +
                            "; s = 0: every value in the same bracket, the spread is below the resolution";
            // A value known to one voxel cannot show the gauge capable, whatever its spread
            // (VDA 5 asks a resolution of 5 % of T; docs/study.md).
            if (r.evaluated && s.source == study::ValueSource::BracketMiddle) {
                j["capable"] = false;
                j["note"] = j["note"].get<std::string>() + "; not capable on the bracket middle";
            }
        }
        landmarks.push_back(std::move(j));
    }
    return landmarks;
}

json runType3(const std::vector<study::StudyRecord>& records, const StudyOptions& o)
{
    study::checkType3Layout(records);
    auto landmarks = json::array();
    for (const auto& s : chosenSeries(study::collectSeries(records), o)) {
        auto j = sourceJson(s);
        if (!s.problem.empty())
            j.update({{"evaluated", false}, {"not_evaluated", s.problem}});
        else
            j.update(toJson(study::type3(study::groupByPart(s), s.zone.width())));
        landmarks.push_back(std::move(j));
    }
    return landmarks;
}

std::string cell(const json& v, int precision = 4)
{
    if (v.is_number()) return formatNumber(v.get<double>(), precision);
    if (v.is_string()) return v.get<std::string>() == "inf" ? "∞" : (v.get<std::string>() == "-inf" ? "−∞" : "?");
    return "—";
}

void printNotes(std::ostream& os, const json& landmarks)
{
    for (const auto& l : landmarks) {
        if (l.contains("not_evaluated"))
            os << "  " << l["id"].get<std::string>() << ": not evaluated — " << l["not_evaluated"].get<std::string>()
               << "\n";
        if (l.contains("note"))
            os << "  " << l["id"].get<std::string>() << ": " << l["note"].get<std::string>() << "\n";
    }
}

std::string textReport(Kind kind, const json& report)
{
    std::ostringstream os;
    const auto& sel = report["selection"];
    os << (kind == Kind::Type1 ? "type-1 study" : "type-3 study (gauge R&R, ANOVA without operators)") << ": "
       << sel["cycles"] << " cycles of program " << sel["program"] << ", purpose " << sel["purpose"].get<std::string>()
       << ", from " << report["store"].get<std::string>() << "\n";
    if (kind == Kind::Type1 && sel["serials"].get<int>() > 1)
        os << "  (" << sel["serials"] << " serials: a type-1 study measures one master part; --serial chooses it)\n";
    if (kind == Kind::Type1) {
        os << fmt::format("{:<16} {:>4} {:>7} {:>10} {:>10} {:>9} {:>10} {:>7} {:>7}  {}\n", "landmark", "n", "T mm",
                          "mean mm", "s mm", "ref mm", "bias mm", "Cg", "Cgk", "capable");
        for (const auto& l : report["landmarks"])
            os << fmt::format("{:<16} {:>4} {:>7} {:>10} {:>10} {:>9} {:>10} {:>7} {:>7}  {}\n",
                              l["id"].get<std::string>(), l.value("n", 0), cell(l.value("tolerance_mm", json()), 3),
                              cell(l.value("mean_mm", json())), cell(l.value("stddev_mm", json())),
                              cell(l.value("reference_mm", json())), cell(l.value("bias_mm", json())),
                              cell(l.value("cg", json()), 3), cell(l.value("cgk", json()), 3),
                              l.value("evaluated", false) ? (l["capable"].get<bool>() ? "yes" : "no") : "—");
    } else {
        os << fmt::format("{:<16} {:>5} {:>6} {:>10} {:>10} {:>10} {:>7} {:>7} {:>4}  {}\n", "landmark", "parts",
                          "trials", "EV mm", "PV mm", "TV mm", "%GRR", "%tol", "ndc", "acceptance");
        for (const auto& l : report["landmarks"])
            os << fmt::format("{:<16} {:>5} {:>6} {:>10} {:>10} {:>10} {:>7} {:>7} {:>4}  {}\n",
                              l["id"].get<std::string>(), l.value("parts", 0), l.value("trials", 0),
                              cell(l.value("ev_mm", json())), cell(l.value("pv_mm", json())),
                              cell(l.value("tv_mm", json())), cell(l.value("percent_grr", json()), 3),
                              cell(l.value("percent_tolerance", json()), 3), cell(l.value("ndc", json())),
                              l.value("acceptance", std::string("—")));
    }
    printNotes(os, report["landmarks"]);
    return os.str();
}

std::size_t serialCount(const std::vector<study::StudyRecord>& records)
{
    std::set<std::string> serials;
    for (const auto& r : records) serials.insert(r.serial);
    return serials.size();
}

int run(Kind kind, const StudyOptions& o)
{
    Selection sel{o.purpose.empty() ? (kind == Kind::Type1 ? "master" : "study") : o.purpose,
                  {},
                  o.serial,
                  o.since,
                  o.until,
                  {},
                  {}};
    if (o.program) sel.program = o.program;
    if (!o.since.empty()) sel.sinceMs = store::parseUtc(o.since, "--since");
    if (!o.until.empty()) sel.untilMs = store::parseUtc(o.until, "--until");
    const auto records = selectCycles(o, sel);
    if (kind == Kind::Type1 && records.size() < o.minCycles)
        throw InputError("", "--min-cycles",
                         std::to_string(records.size()) + " " + describe(sel) + " in " + o.store +
                             ", a type-1 study needs " + std::to_string(o.minCycles) +
                             " (VDA 5: at least 25; --min-cycles lowers it)");
    json report{{"study", kind == Kind::Type1 ? "type1" : "type3"},
                {"store", o.store},
                {"selection",
                 {{"purpose", sel.purpose},
                  {"program", *sel.program},
                  {"serial", sel.serial},
                  {"cycles", records.size()},
                  {"serials", serialCount(records)},
                  {"first_id", records.front().id},
                  {"last_id", records.back().id}}},
                {"landmarks", kind == Kind::Type1 ? runType1(records, o) : runType3(records, o)}};
    const auto text = o.json ? report.dump(2) + "\n" : textReport(kind, report);
    hg::log::category("study")->debug("{}: {} cycles of program {}", report["study"].get<std::string>(), records.size(),
                                      *sel.program);
    if (o.out.empty())
        std::cout << text;
    else
        writeFileDurably(o.out, text);
    return 0;
}

CLI::App* addStudy(CLI::App& parent, const char* name, const char* what, StudyOptions& o)
{
    auto* sub = parent.add_subcommand(name, what);
    sub->add_option("--store", o.store, "the result store (SQLite, read read-only)")->required();
    sub->add_option("--program", o.program, "part program number (default: the one the cycles have)")
        ->check(CLI::Range(1, 65535));
    sub->add_option("--serial", o.serial, "only the cycles of this serial");
    sub->add_option("--since", o.since, "only cycles started at or after this UTC time (YYYY-MM-DD[THH:MM[:SS]])");
    sub->add_option("--until", o.until, "only cycles started before this UTC time");
    sub->add_option("--purpose", o.purpose, "cycles tagged master, study or production, or any")
        ->check(CLI::IsMember({"production", "master", "study", "any"}));
    sub->add_option("--landmark", o.landmarks, "only this landmark (repeatable; default: every landmark)");
    sub->add_flag("--json", o.json, "print JSON (docs/study.md)");
    sub->add_option("--out", o.out, "write the report to this file instead of standard output");
    return sub;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<StudyOptions>();
    auto* studyCmd = app.add_subcommand("study", "gauge studies on the result store: type-1 (Cg, Cgk) and type-3 "
                                                 "(gauge R&R) per landmark (docs/study.md)");
    studyCmd->require_subcommand(1);
    auto* type1 =
        addStudy(*studyCmd, "type1",
                 "type-1 study (VDA 5): one master part measured again and again; default purpose master", *o);
    type1->add_option("--reference", o->reference, "YAML: landmark id → the master's reference value in mm");
    type1->add_option("--min-cycles", o->minCycles, "fewest cycles the study takes (default 25)")
        ->check(CLI::Range(2, 1000000));
    addStudy(*studyCmd, "type3", "type-3 study (AIAG MSA, ANOVA): parts × 2–3 trials; default purpose study", *o);
    return [=]() { return run(type1->parsed() ? Kind::Type1 : Kind::Type3, *o); };
}

} // namespace

HG_REGISTER_COMMAND("study", factory);

} // namespace hg::cli
