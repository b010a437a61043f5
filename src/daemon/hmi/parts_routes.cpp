#include "hmi/parts_routes.h"

#include "hmi/http_util.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"

#include <Eigen/Dense>
#include <fstream>
#include <regex>

namespace hg::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kPart = R"(([A-Za-z0-9][A-Za-z0-9._-]{0,63}))";

json vec(const Eigen::Vector3d& v)
{
    return json::array({v.x(), v.y(), v.z()});
}

std::optional<Eigen::Vector3d> vecOf(const json& body, const char* key)
{
    if (!body.contains(key) || body[key].is_null()) return std::nullopt;
    const auto& v = body[key];
    if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
        throw HttpError(400, std::string(key) + ": expected [x, y, z] (numbers)");
    return Eigen::Vector3d(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
}

int revisionOf(const json& body)
{
    if (!body.contains("revision") || !body["revision"].is_number_integer())
        throw HttpError(400, "revision: missing (the draft revision this change was made on)");
    return body["revision"].get<int>();
}

/// The fields of a landmark change (docs/workbench.md, "HTTP API").
workbench::LandmarkEdit editOf(const json& body)
{
    workbench::LandmarkEdit edit;
    edit.position = vecOf(body, "position");
    edit.normal = vecOf(body, "normal");
    if (body.contains("normal_from_mesh"))
        edit.normalFromMesh = body["normal_from_mesh"].is_boolean() && body["normal_from_mesh"].get<bool>();
    if (body.contains("new_id")) {
        if (!body["new_id"].is_string()) throw HttpError(400, "new_id: not a string");
        edit.newId = body["new_id"].get<std::string>();
    }
    if (body.contains("tolerance_mm") && !body["tolerance_mm"].is_null()) {
        if (!body["tolerance_mm"].is_number()) throw HttpError(400, "tolerance_mm: not a number");
        edit.toleranceMm = body["tolerance_mm"].get<double>();
    }
    if (body.contains("limits_mm") && !body["limits_mm"].is_null()) {
        const auto& l = body["limits_mm"];
        if (!l.is_array() || l.size() != 2 || !l[0].is_number() || !l[1].is_number())
            throw HttpError(400, "limits_mm: expected [lower, upper] (numbers)");
        edit.limitsMm = std::pair{l[0].get<double>(), l[1].get<double>()};
    }
    return edit;
}

json fixtureJson(const geometry::FixtureKinematics& f)
{
    auto axis = [](const Eigen::Vector3d& point, const Eigen::Vector3d& direction) {
        return json{{"point", vec(point)}, {"direction", vec(direction.normalized())}};
    };
    json j{{"type", enumName(f.type)}};
    if (f.type == geometry::FixtureType::Rail) {
        j["rail_axis"] = axis(Eigen::Vector3d::Zero(), f.railAxis);
    } else {
        j["rotation_axis"] = axis(f.rotationAxisPoint, f.rotationAxis);
        j["declination_axis"] = axis(f.declinationAxisPoint, f.declinationAxis);
    }
    return j;
}

std::optional<json> jsonFile(const fs::path& file)
{
    auto text = readFile(file);
    if (!text) return std::nullopt;
    auto j = json::parse(*text, nullptr, false);
    return j.is_discarded() ? std::nullopt : std::optional<json>(std::move(j));
}

/// A refusal of the workspace as its HTTP status: a part that is not there
/// 404; a stale revision, a name taken, a release refused 409; any other bad input 400.
[[noreturn]] void refuse(const InputError& e)
{
    if (dynamic_cast<const workbench::PartNotFound*>(&e)) throw HttpError(404, e.what());
    if (dynamic_cast<const workbench::StaleRevision*>(&e) || dynamic_cast<const workbench::PartExists*>(&e) ||
        dynamic_cast<const workbench::ReleaseRefused*>(&e))
        throw HttpError(409, e.what());
    throw HttpError(400, e.what());
}

/// Runs `work`, turning the workspace's refusals into their HTTP status.
template <class Work> auto refusing(Work work)
{
    try {
        return work();
    } catch (const InputError& e) {
        refuse(e);
    }
}

/// A list row: the part's record without its draft.
json rowJson(const workbench::PartState& s)
{
    json j = workbench::toJson(s);
    j["landmarks"] = s.draft.landmarks.size();
    j["cad"] = s.record.cad;
    j["released_version"] = s.releasedVersion ? json(*s.releasedVersion) : json(nullptr);
    j.erase("draft");
    return j;
}

} // namespace

PartsRoutes::PartsRoutes(httplib::Server& server, const station::WorkbenchConfig& workbench, ConfigSource config,
                         Access& access, CommandMailbox& mailbox, StaticFiles& files)
    : workbench_(workbench), workspace_(workbench.folder), config_(std::move(config)), access_(access),
      mailbox_(mailbox), files_(files),
      jobs_(std::make_unique<PartJobs>(workbench.cli, workbench.folder, workbench.maxJobs))
{
    routeReads(server);
    routeLandmarks(server);
    routeJobs(server);
    routeVersions(server);
}

json PartsRoutes::partJson(const std::string& part) const
{
    const workbench::PartState s = workspace_.read(part);
    const fs::path folder = workspace_.partFolder(part);
    json j = workbench::toJson(s);
    const auto cfg = config_();
    j["station"] = {{"fixture", fixtureJson(cfg->station.fixture)}, {"floor_z_mm", cfg->station.floorZMm}};
    j["suggestions"] = jsonFile(folder / "suggestions.json").value_or(json(nullptr));
    const auto plan = jsonFile(folder / "plan.json");
    j["plan"] = plan ? json{{"feasible", plan->value("feasible", false)},
                            {"views", plan->value("views", json::array()).size()},
                            {"problems", plan->value("problems", json::array())}}
                     : json(nullptr);
    if (j["verified"].is_object()) j["verified"]["stale"] = j["verified"]["revision"] != s.record.revision;
    const auto job = jobs_->job(part);
    j["job"] = job ? toJson(*job) : json(nullptr);
    return j;
}

Actor PartsRoutes::engineer(const httplib::Request& req, const std::string& action, const std::string& part)
{
    return access_.authorize(req, store::Permission::Programs, action, part);
}

std::string PartsRoutes::auditState(const std::string& part) const
{
    try {
        const json j = workbench::toJson(workspace_.read(part));
        return json{{"revision", j["revision"]},
                    {"draft", j["draft"]},
                    {"plc_program", j["plc_program"]},
                    {"released", j["released"]}}
            .dump(2);
    } catch (const InputError&) {
        return {}; // not there (yet, or any more)
    }
}

template <class Change>
auto PartsRoutes::audited(const Actor& by, const std::string& action, const std::string& part, Change&& change)
{
    const auto before = auditState(part);
    auto result = change();
    access_.record(by, action, part, "done", {}, before, auditState(part));
    return result;
}

void PartsRoutes::routeReads(httplib::Server& server)
{
    const std::string parts = std::string("/api/parts/") + kPart;
    server.Get("/api/parts", api([this](const httplib::Request&, httplib::Response& res) {
                   json rows = json::array();
                   for (const auto& s : workspace_.list()) {
                       json row = rowJson(s);
                       const auto job = jobs_->job(s.record.part);
                       row["job"] = job ? toJson(*job) : json(nullptr);
                       rows.push_back(std::move(row));
                   }
                   sendJson(res, {{"parts", rows}});
               }));
    server.Get(parts, api([this](const httplib::Request& req, httplib::Response& res) {
                   sendJson(res, refusing([&] { return partJson(req.matches[1].str()); }));
               }));
    server.Get(parts + "/model\\.stl", api([this](const httplib::Request& req, httplib::Response& res) {
                   const bool lod = req.has_param("lod") && req.get_param_value("lod") == "1";
                   const auto mesh = refusing([&] { return workspace_.displayMeshFile(req.matches[1].str(), lod); });
                   files_.serve(req, res, mesh);
               }));
    server.Get(parts + "/verification", api([this](const httplib::Request& req, httplib::Response& res) {
                   const auto folder = refusing([&] { return workspace_.partFolder(req.matches[1].str()); });
                   const auto report = jsonFile(folder / "verification.json");
                   if (!report) throw HttpError(404, "part " + req.matches[1].str() + " has not been commissioned");
                   sendJson(res, *report);
               }));
    server.Get(parts + "/views", api([this](const httplib::Request& req, httplib::Response& res) {
                   const auto station = config_()->stationFile;
                   sendJson(res, refusing([&] { return workspace_.views(req.matches[1].str(), station); }));
               }));
    server.Get(parts + "/views/([0-9]{1,3})\\.png", api([this](const httplib::Request& req, httplib::Response& res) {
                   const std::string part = req.matches[1].str(), k = req.matches[2].str();
                   const fs::path folder = refusing([&] { return workspace_.partFolder(part); });
                   const fs::path png = folder / "display" / ("view_" + k + ".png");
                   std::error_code ec;
                   const auto planned = fs::last_write_time(folder / "plan.json", ec);
                   if (ec) throw HttpError(404, "part " + part + " has no plan: plan or commission it");
                   // Rendered by a process of its own at nice 10, kept until the next plan.
                   if (!fs::exists(png) || fs::last_write_time(png, ec) < planned)
                       runPart({"view", part, k, "--out", png.string(), "--station", config_()->stationFile.string()},
                               std::chrono::seconds(120));
                   files_.serve(req, res, png);
               }));
    server.Get(parts + "/job", api([this](const httplib::Request& req, httplib::Response& res) {
                   const auto job = jobs_->job(req.matches[1].str());
                   sendJson(res, job ? toJson(*job) : json(nullptr));
               }));
    server.Get(parts + "/versions", api([this](const httplib::Request& req, httplib::Response& res) {
                   json versions = json::array();
                   for (const auto& v : refusing([&] { return workspace_.versions(req.matches[1].str()); }))
                       versions.push_back(workbench::toJson(v));
                   sendJson(res, {{"versions", versions}});
               }));
    server.Get(parts + "/diff", api([this](const httplib::Request& req, httplib::Response& res) {
                   static const std::regex kVersion(R"(draft|[0-9]{1,6})");
                   const auto from = req.get_param_value("from"), to = req.get_param_value("to");
                   if (!std::regex_match(from, kVersion) || !std::regex_match(to, kVersion))
                       throw HttpError(400, "from, to: a version number or 'draft'");
                   sendJson(res, refusing([&] { return workspace_.diff(req.matches[1].str(), from, to); }));
               }));
}

std::string PartsRoutes::runPart(const std::vector<std::string>& args, std::chrono::seconds deadline) const
{
    const auto outcome = runPartCommand(workbench_.cli, workbench_.folder, args, deadline);
    if (outcome.timedOut)
        throw HttpError(503, "hullgauge part " + args.at(0) + " did not finish within " +
                                 std::to_string(deadline.count()) + " s");
    if (outcome.exitStatus != 0) {
        std::string words = outcome.err;
        while (!words.empty() && (words.back() == '\n' || words.back() == ' ')) words.pop_back();
        if (words.size() > 4000) words = words.substr(words.size() - 4000);
        throw HttpError(outcome.exitStatus == 2 ? 400 : 500,
                        words.empty() ? "hullgauge part " + args.at(0) + " failed" : words);
    }
    return outcome.out;
}

void PartsRoutes::routeLandmarks(httplib::Server& server)
{
    const std::string parts = std::string("/api/parts/") + kPart;
    server.Post("/api/parts", api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = engineer(req, "program.add", req.get_param_value("name"));
                    if (!req.has_param("file")) throw HttpError(400, "file: missing (the CAD file's name)");
                    workbench::AddOptions options;
                    if (req.has_param("name")) options.name = req.get_param_value("name");
                    if (const auto depth = intParam(req, "depth", 1, 15)) options.depth = static_cast<int>(*depth);
                    if (req.has_param("tolerance")) {
                        const auto t = req.get_param_value("tolerance");
                        char* end = nullptr;
                        options.toleranceMm = std::strtod(t.c_str(), &end);
                        if (t.empty() || *end != '\0' || !(options.toleranceMm > 0.0))
                            throw HttpError(400, "tolerance: '" + t + "' is not a number > 0 (mm)");
                    }
                    const auto state = refusing([&] {
                        return workspace_.addUpload(req.get_param_value("file"), req.body, options, {session.name});
                    });
                    access_.record(session, "program.add", state.record.part, "done",
                                   "CAD file " + req.get_param_value("file"), {}, auditState(state.record.part));
                    hg::log::category("workbench")->info("part {} added by {}", state.record.part, session.name);
                    sendJson(res, partJson(state.record.part), 201);
                }));
    const auto placedAnswer = [this](const std::string& part, const workbench::Placed& placed) {
        json answer = partJson(part);
        answer["placed"] = workbench::toJson(placed);
        return answer;
    };
    server.Post(parts + "/landmarks", api([this, placedAnswer](const httplib::Request& req, httplib::Response& res) {
                    const std::string part = req.matches[1].str();
                    const auto session = engineer(req, "program.landmark.add", part);
                    const auto body = jsonBody(req, "{\"revision\": N, \"position\": [x, y, z], ...}");
                    if (!body.contains("position")) throw HttpError(400, "position: missing");
                    std::optional<std::string> id;
                    if (body.contains("id") && !body["id"].is_null()) {
                        if (!body["id"].is_string()) throw HttpError(400, "id: not a string");
                        id = body["id"].get<std::string>();
                    }
                    const auto placed = audited(session, "program.landmark.add", part, [&] {
                        return refusing([&] {
                            return workspace_.addLandmark(part, revisionOf(body), id, editOf(body), {session.name});
                        });
                    });
                    sendJson(res, placedAnswer(part, placed));
                }));
    server.Post(parts + "/landmarks/([^/]{1,64})",
                api([this, placedAnswer](const httplib::Request& req, httplib::Response& res) {
                    const std::string part = req.matches[1].str();
                    const auto session = engineer(req, "program.landmark.change", part);
                    const auto body = jsonBody(req, "{\"revision\": N, ...}");
                    const auto placed = audited(session, "program.landmark.change", part, [&] {
                        return refusing([&] {
                            return workspace_.changeLandmark(part, revisionOf(body), req.matches[2].str(), editOf(body),
                                                             {session.name});
                        });
                    });
                    sendJson(res, placedAnswer(part, placed));
                }));
    server.Post(
        parts + "/landmarks/([^/]{1,64})/remove", api([this](const httplib::Request& req, httplib::Response& res) {
            const std::string part = req.matches[1].str();
            const auto session = engineer(req, "program.landmark.remove", part);
            const auto body = jsonBody(req, "{\"revision\": N}");
            audited(session, "program.landmark.remove", part, [&] {
                return refusing([&] {
                    return workspace_.removeLandmark(part, revisionOf(body), req.matches[2].str(), {session.name});
                });
            });
            sendJson(res, partJson(part));
        }));
}

void PartsRoutes::routeJobs(httplib::Server& server)
{
    const std::string parts = std::string("/api/parts/") + kPart;
    for (const std::string kind : {"suggest", "plan", "commission"})
        server.Post(parts + "/" + kind, api([this, kind](const httplib::Request& req, httplib::Response& res) {
                        const std::string part = req.matches[1].str();
                        const auto session = engineer(req, "program." + kind, part);
                        const auto body = jsonBody(req, "{...}");
                        refusing([&] { return workspace_.partFolder(part); });
                        std::vector<std::string> args{"--station", config_()->stationFile.string()};
                        if (kind == "commission") {
                            args.emplace_back("--progress");
                            if (body.contains("seats")) {
                                if (!body["seats"].is_number_integer() || body["seats"].get<int>() < 1 ||
                                    body["seats"].get<int>() > 200)
                                    throw HttpError(400, "seats: a whole number 1..200");
                                args.insert(args.end(), {"--seats", std::to_string(body["seats"].get<int>())});
                            }
                            // The nest's play the twin seats the part within (docs/commissioning.md).
                            for (const auto& [key, option] : {std::pair{"seat_shift_mm", "--seat-shift"},
                                                              std::pair{"seat_rotation_deg", "--seat-rotation"}}) {
                                if (!body.contains(key)) continue;
                                const json& v = body[key];
                                if (!v.is_number() || !(v.get<double>() > 0.0) || v.get<double>() > 10.0)
                                    throw HttpError(400, std::string(key) + ": a number in (0, 10]");
                                args.insert(args.end(), {option, formatNumber(v.get<double>())});
                            }
                        }
                        if (auto started = jobs_->start(part, kind, args, session.name); !started)
                            throw HttpError(409, started.message());
                        access_.record(session, "program." + kind, part, "done", kind + " started");
                        sendJson(res, toJson(*jobs_->job(part)), 202);
                    }));
    server.Post(parts + "/job/cancel", api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = engineer(req, "program.job.cancel", req.matches[1].str());
                    if (!jobs_->cancel(req.matches[1].str()))
                        throw HttpError(409, "part " + req.matches[1].str() + " has no job running");
                    access_.record(session, "program.job.cancel", req.matches[1].str(), "done");
                    sendJson(res, toJson(*jobs_->job(req.matches[1].str())));
                }));
}

// A release or rollback changes what the daemon runs: it reads its programs
// again (as on SIGHUP) and runs the version in force from its next cycle.
json PartsRoutes::reloaded(const std::string& part)
{
    const auto reload = mailbox_.call({{"command", "reload"}}, std::chrono::milliseconds(2000));
    json answer = partJson(part);
    answer["reload"] = reload ? *reload : json{{"ok", false}, {"error", "the daemon did not answer in time"}};
    return answer;
}

void PartsRoutes::routeVersions(httplib::Server& server)
{
    const std::string parts = std::string("/api/parts/") + kPart;
    server.Post(parts + "/release", api([this](const httplib::Request& req, httplib::Response& res) {
                    const std::string part = req.matches[1].str();
                    const auto session = engineer(req, "program.release", part);
                    const auto body = jsonBody(req, "{\"revision\": N, \"plc_program\": P}");
                    std::optional<int> number;
                    if (body.contains("plc_program") && !body["plc_program"].is_null()) {
                        if (!body["plc_program"].is_number_integer() || body["plc_program"].get<int>() < 1 ||
                            body["plc_program"].get<int>() > 65535)
                            throw HttpError(400, "plc_program: a whole number 1..65535 (the PLC's PART_PROGRAM)");
                        number = body["plc_program"].get<int>();
                    }
                    if (jobs_->running(part)) throw HttpError(409, "part " + part + " has a job running");
                    const auto cfg = config_();
                    std::vector<int> taken;
                    for (const auto& [n, ref] : cfg->programs)
                        if (ref.workbenchPart != part) taken.push_back(n);
                    const auto version = audited(session, "program.release", part, [&] {
                        return refusing([&] {
                            return workspace_.release(part, revisionOf(body), cfg->stationFile, number, taken,
                                                      {session.name});
                        });
                    });
                    hg::log::category("workbench")
                        ->info("part {} version {} released by {}", part, version.version, session.name);
                    sendJson(res, reloaded(part));
                }));
    server.Post(parts + "/rollback", api([this](const httplib::Request& req, httplib::Response& res) {
                    const std::string part = req.matches[1].str();
                    const auto session = engineer(req, "program.rollback", part);
                    const auto body = jsonBody(req, "{\"version\": V}");
                    if (!body.contains("version") || !body["version"].is_number_integer())
                        throw HttpError(400, "version: the version to make the one in force again");
                    if (jobs_->running(part)) throw HttpError(409, "part " + part + " has a job running");
                    const auto version = audited(session, "program.rollback", part, [&] {
                        return refusing(
                            [&] { return workspace_.rollback(part, body["version"].get<int>(), {session.name}); });
                    });
                    hg::log::category("workbench")
                        ->info("part {} rolled back to version {} as version {} by {}", part,
                               body["version"].get<int>(), version.version, session.name);
                    sendJson(res, reloaded(part));
                }));
}

} // namespace hg::daemon
