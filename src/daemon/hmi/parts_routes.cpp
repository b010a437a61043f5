#include "hmi/parts_routes.h"

#include "hmi/http_util.h"
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
    if (body.contains("normal_from_mesh")) edit.normalFromMesh = body["normal_from_mesh"].is_boolean() &&
                                                                 body["normal_from_mesh"].get<bool>();
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

json landmarkJson(const workbench::DraftLandmark& l)
{
    json j{{"id", l.id},
           {"position", vec(l.position)},
           {"normal", vec(l.normal)},
           {"normal_given", l.normalGiven},
           {"on", enumName(l.on)}};
    j["tolerance_mm"] = l.toleranceMm ? json(*l.toleranceMm) : json(nullptr);
    j["limits_mm"] = l.limitsMm ? json::array({l.limitsMm->first, l.limitsMm->second}) : json(nullptr);
    return j;
}

json recordJson(const workbench::PartState& s)
{
    const auto& r = s.record;
    json j{{"name", r.part},
           {"revision", r.revision},
           {"changed_by", r.changedBy},
           {"changed_at", r.changedAt},
           {"change", r.change},
           {"cad", r.cad},
           {"landmarks", s.draft.landmarks.size()}};
    j["plc_program"] = r.plcProgram ? json(*r.plcProgram) : json(nullptr);
    j["released_version"] = s.releasedVersion ? json(*s.releasedVersion) : json(nullptr);
    return j;
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

/// Each planned view's camera in the part frame (docs/workbench.md): the
/// plan's K, R, t (camera from part) turned into the centre, the rotation
/// camera → part and the working distance to the part's centre.
json viewsJson(const json& plan, const Eigen::Vector3d& partCentre)
{
    json views = json::array();
    std::size_t index = 1;
    for (const auto& v : plan.value("views", json::array())) {
        Eigen::Matrix3d r;
        Eigen::Vector3d t;
        for (int i = 0; i < 3; ++i) {
            t[i] = v.at("t").at(i).get<double>();
            for (int k = 0; k < 3; ++k) r(i, k) = v.at("R").at(i).at(k).get<double>();
        }
        const Eigen::Matrix3d toPart = r.transpose();
        const Eigen::Vector3d centre = -toPart * t;
        json rotation = json::array();
        for (int i = 0; i < 3; ++i) rotation.push_back({toPart(i, 0), toPart(i, 1), toPart(i, 2)});
        const auto& k = v.at("K");
        views.push_back({{"index", index++},
                         {"id", v.value("id", "")},
                         {"pose", v.at("pose")},
                         {"landmarks", v.value("landmarks", json::array())},
                         {"camera",
                          {{"centre", vec(centre)},
                           {"rotation", rotation},
                           {"fx", k[0][0]},
                           {"fy", k[1][1]},
                           {"cx", k[0][2]},
                           {"cy", k[1][2]},
                           {"width", v.at("image_size")[0]},
                           {"height", v.at("image_size")[1]},
                           {"working_distance_mm", (r * partCentre + t).z()}}}});
    }
    return views;
}

/// A refusal of the workspace as its HTTP status: a stale revision 409, a
/// part that is not there 404, any other bad input 400.
[[noreturn]] void refuse(const InputError& e)
{
    if (dynamic_cast<const workbench::StaleRevision*>(&e)) throw HttpError(409, e.what());
    if (e.field() == "part") throw HttpError(404, e.what());
    throw HttpError(400, e.what());
}

} // namespace

PartsRoutes::PartsRoutes(httplib::Server& server, const station::WorkbenchConfig& workbench, ConfigSource config,
                         SignedIn signedIn, CommandMailbox& mailbox)
    : workbench_(workbench), workspace_(workbench.folder), config_(std::move(config)), signedIn_(std::move(signedIn)),
      mailbox_(mailbox), jobs_(std::make_unique<PartJobs>(workbench.cli, workbench.folder, workbench.maxJobs))
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
    json j = recordJson(s);
    j["cad"] = {{"file", s.record.cad},
                {"kind", s.cadKind},
                {"triangles", s.triangles},
                {"bounds_mm", {vec(s.boundsMin), vec(s.boundsMax)}},
                {"sha256", s.cadSha256}};
    json landmarks = json::array();
    for (const auto& l : s.draft.landmarks) landmarks.push_back(landmarkJson(l));
    j["draft"] = {{"octree", {{"depth", s.draft.depth}, {"adjacency_depth", s.draft.adjacencyDepth}}},
                  {"tolerance_mm", s.draft.defaultToleranceMm},
                  {"landmarks", landmarks}};
    const auto cfg = config_();
    j["station"] = {{"fixture", fixtureJson(cfg->station.fixture)}, {"floor_z_mm", cfg->station.floorZMm}};
    j["suggestions"] = jsonFile(folder / "suggestions.json").value_or(json(nullptr));
    const auto plan = jsonFile(folder / "plan.json");
    j["plan"] = plan ? json{{"feasible", plan->value("feasible", false)},
                            {"views", plan->value("views", json::array()).size()},
                            {"problems", plan->value("problems", json::array())}}
                     : json(nullptr);
    if (const auto& v = s.record.verified)
        j["verified"] = {{"revision", v->revision},
                         {"released", v->released},
                         {"stale", v->revision != s.record.revision},
                         {"verification_sha256", v->verificationSha256}};
    else
        j["verified"] = nullptr;
    const auto versions = workspace_.versions(part);
    j["released"] = nullptr;
    for (const auto& v : versions)
        if (v.inForce)
            j["released"] = {{"version", v.version},
                             {"plc_program", s.record.plcProgram ? json(*s.record.plcProgram) : json(nullptr)},
                             {"released_by", v.releasedBy},
                             {"released_at", v.releasedAt}};
    const auto job = jobs_->job(part);
    j["job"] = job ? toJson(*job) : json(nullptr);
    return j;
}

void PartsRoutes::routeReads(httplib::Server& server)
{
    server.Get("/api/parts", api([this](const httplib::Request&, httplib::Response& res) {
                   json parts = json::array();
                   for (const auto& s : workspace_.list()) {
                       json p = recordJson(s);
                       const auto job = jobs_->job(s.record.part);
                       p["job"] = job ? toJson(*job) : json(nullptr);
                       parts.push_back(std::move(p));
                   }
                   sendJson(res, {{"parts", parts}});
               }));
    server.Get(std::string("/api/parts/") + kPart, api([this](const httplib::Request& req, httplib::Response& res) {
                   try {
                       sendJson(res, partJson(req.matches[1].str()));
                   } catch (const InputError& e) {
                       refuse(e);
                   }
               }));
    server.Get(std::string("/api/parts/") + kPart + "/model\\.stl",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   try {
                       const bool lod = req.has_param("lod") && req.get_param_value("lod") == "1";
                       res.set_header("Cache-Control", "no-cache");
                       res.set_content(workspace_.displayMesh(req.matches[1].str(), lod), "model/stl");
                   } catch (const InputError& e) {
                       refuse(e);
                   }
               }));
    server.Get(std::string("/api/parts/") + kPart + "/verification",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   try {
                       const auto file = workspace_.partFolder(req.matches[1].str()) / "verification.json";
                       const auto report = jsonFile(file);
                       if (!report) throw HttpError(404, "part " + req.matches[1].str() + " has not been commissioned");
                       sendJson(res, *report);
                   } catch (const InputError& e) {
                       refuse(e);
                   }
               }));
    server.Get(std::string("/api/parts/") + kPart + "/views",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   try {
                       const std::string part = req.matches[1].str();
                       const auto s = workspace_.read(part);
                       const auto plan = jsonFile(workspace_.partFolder(part) / "plan.json");
                       if (!plan) throw HttpError(404, "part " + part + " has no plan: plan or commission it");
                       sendJson(res, {{"views", viewsJson(*plan, (s.boundsMin + s.boundsMax) / 2.0)}});
                   } catch (const InputError& e) {
                       refuse(e);
                   }
               }));
    server.Get(std::string("/api/parts/") + kPart + "/views/([0-9]{1,3})\\.png",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   try {
                       const std::string part = req.matches[1].str(), k = req.matches[2].str();
                       const fs::path folder = workspace_.partFolder(part);
                       const fs::path png = folder / "display" / ("view_" + k + ".png");
                       std::error_code ec;
                       const auto planned = fs::last_write_time(folder / "plan.json", ec);
                       if (ec) throw HttpError(404, "part " + part + " has no plan: plan or commission it");
                       if (!fs::exists(png) || fs::last_write_time(png, ec) < planned)
                           runPart({"view", part, k, "--out", png.string()}, std::chrono::seconds(120));
                       sendFile(res, png);
                   } catch (const InputError& e) {
                       refuse(e);
                   }
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
        if (const auto nl = words.rfind('\n'); nl != std::string::npos && words.size() > 4000)
            words = words.substr(nl + 1);
        throw HttpError(outcome.exitStatus == 2 || outcome.exitStatus == 1 ? 409 : 500,
                        words.empty() ? "hullgauge part " + args.at(0) + " failed" : words);
    }
    return outcome.out;
}

void PartsRoutes::routeLandmarks(httplib::Server& server)
{
    server.Post("/api/parts", api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = signedIn_(req);
                    if (!req.has_param("file")) throw HttpError(400, "file: missing (the CAD file's name)");
                    workbench::AddOptions options;
                    if (req.has_param("name")) options.name = req.get_param_value("name");
                    if (auto t = req.get_param_value("tolerance"); !t.empty()) {
                        try {
                            options.toleranceMm = std::stod(t);
                        } catch (const std::exception&) {
                            throw HttpError(400, "tolerance: '" + t + "' is not a number");
                        }
                    }
                    const auto state =
                        workspace_.addUpload(req.get_param_value("file"), req.body, options, {session.name});
                    hg::log::category("workbench")->info("part {} added by {}", state.record.part, session.name);
                    sendJson(res, partJson(state.record.part), 201);
                }));
    server.Post(std::string("/api/parts/") + kPart + "/landmarks",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = signedIn_(req);
                    const auto body = jsonBody(req, "{\"revision\": N, \"position\": [x, y, z], ...}");
                    if (!body.contains("position")) throw HttpError(400, "position: missing");
                    std::optional<std::string> id;
                    if (body.contains("id") && body["id"].is_string()) id = body["id"].get<std::string>();
                    try {
                        const std::string part = req.matches[1].str();
                        const auto placed =
                            workspace_.addLandmark(part, revisionOf(body), id, editOf(body), {session.name});
                        json answer = partJson(part);
                        answer["placed"] = {{"id", placed.landmark.id},
                                            {"on", enumName(placed.landmark.on)},
                                            {"moved_mm", placed.movedMm}};
                        sendJson(res, answer);
                    } catch (const InputError& e) {
                        refuse(e);
                    }
                }));
    server.Post(std::string("/api/parts/") + kPart + "/landmarks/([^/]{1,64})",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = signedIn_(req);
                    const auto body = jsonBody(req, "{\"revision\": N, ...}");
                    try {
                        const std::string part = req.matches[1].str();
                        const auto placed = workspace_.changeLandmark(part, revisionOf(body), req.matches[2].str(),
                                                                      editOf(body), {session.name});
                        json answer = partJson(part);
                        answer["placed"] = {{"id", placed.landmark.id},
                                            {"on", enumName(placed.landmark.on)},
                                            {"moved_mm", placed.movedMm}};
                        sendJson(res, answer);
                    } catch (const InputError& e) {
                        refuse(e);
                    }
                }));
    server.Post(std::string("/api/parts/") + kPart + "/landmarks/([^/]{1,64})/remove",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = signedIn_(req);
                    const auto body = jsonBody(req, "{\"revision\": N}");
                    try {
                        const std::string part = req.matches[1].str();
                        workspace_.removeLandmark(part, revisionOf(body), req.matches[2].str(), {session.name});
                        sendJson(res, partJson(part));
                    } catch (const InputError& e) {
                        refuse(e);
                    }
                }));
}

void PartsRoutes::routeJobs(httplib::Server& server)
{
    static const std::map<std::string, std::string> kJobs{
        {"suggest", "suggest"}, {"plan", "plan"}, {"commission", "commission"}};
    for (const auto& [route, kind] : kJobs)
        server.Post(std::string("/api/parts/") + kPart + "/" + route,
                    api([this, kind = kind](const httplib::Request& req, httplib::Response& res) {
                        const auto session = signedIn_(req);
                        const auto body = jsonBody(req, "{...}");
                        const std::string part = req.matches[1].str();
                        try {
                            (void)workspace_.partFolder(part);
                        } catch (const InputError& e) {
                            refuse(e);
                        }
                        std::vector<std::string> args;
                        if (kind == "commission" && body.contains("seats")) {
                            if (!body["seats"].is_number_integer() || body["seats"].get<int>() < 1 ||
                                body["seats"].get<int>() > 200)
                                throw HttpError(400, "seats: a whole number 1..200");
                            args = {"--seats", std::to_string(body["seats"].get<int>())};
                        }
                        if (auto started = jobs_->start(part, kind, args, session.name); !started)
                            throw HttpError(409, started.message());
                        sendJson(res, toJson(*jobs_->job(part)), 202);
                    }));
    server.Get(std::string("/api/parts/") + kPart + "/job",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   const auto job = jobs_->job(req.matches[1].str());
                   sendJson(res, job ? toJson(*job) : json(nullptr));
               }));
    server.Post(std::string("/api/parts/") + kPart + "/job/cancel",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    (void)signedIn_(req);
                    if (!jobs_->cancel(req.matches[1].str()))
                        throw HttpError(409, "part " + req.matches[1].str() + " has no job running");
                    sendJson(res, toJson(*jobs_->job(req.matches[1].str())));
                }));
}

void PartsRoutes::routeVersions(httplib::Server& server)
{
    server.Get(std::string("/api/parts/") + kPart + "/versions",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   sendJson(res, parseJson(runPart({"versions", req.matches[1].str(), "--json"},
                                                   std::chrono::seconds(30)),
                                           "hullgauge part versions"));
               }));
    server.Get(std::string("/api/parts/") + kPart + "/diff",
               api([this](const httplib::Request& req, httplib::Response& res) {
                   static const std::regex kVersion(R"(draft|[0-9]{1,6})");
                   const auto from = req.get_param_value("from"), to = req.get_param_value("to");
                   if (!std::regex_match(from, kVersion) || !std::regex_match(to, kVersion))
                       throw HttpError(400, "from, to: a version number or 'draft'");
                   sendJson(res, parseJson(runPart({"diff", req.matches[1].str(), from, to, "--json"},
                                                   std::chrono::seconds(60)),
                                           "hullgauge part diff"));
               }));
    server.Post(std::string("/api/parts/") + kPart + "/release",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = signedIn_(req);
                    const auto body = jsonBody(req, "{\"revision\": N, \"plc_program\": P}");
                    const std::string part = req.matches[1].str();
                    if (!body.contains("plc_program") || !body["plc_program"].is_number_integer() ||
                        body["plc_program"].get<int>() < 1 || body["plc_program"].get<int>() > 65535)
                        throw HttpError(400, "plc_program: a whole number 1..65535 (the PLC's PART_PROGRAM)");
                    const int number = body["plc_program"].get<int>();
                    const auto cfg = config_();
                    if (auto it = cfg->programs.find(static_cast<std::uint16_t>(number));
                        it != cfg->programs.end() && it->second.workbenchPart != part)
                        throw HttpError(409, "program " + std::to_string(number) + " is " +
                                                 (it->second.workbenchPart.empty()
                                                      ? it->second.partFile.string()
                                                      : "the workspace's part '" + it->second.workbenchPart + "'") +
                                                 " on this station: choose another number");
                    if (jobs_->running(part)) throw HttpError(409, "part " + part + " has a job running");
                    runPart({"release", part, "--plc-program", std::to_string(number), "--by", session.name,
                             "--revision", std::to_string(revisionOf(body))},
                            std::chrono::seconds(120));
                    hg::log::category("workbench")->info("part {} released as program {} by {}", part, number,
                                                         session.name);
                    // The daemon reads its programs again (as on SIGHUP): the version runs from the next cycle.
                    const auto reload = mailbox_.call({{"command", "reload"}}, std::chrono::milliseconds(2000));
                    json answer = partJson(part);
                    answer["reload"] = reload ? *reload : json{{"ok", false}, {"error", "the daemon did not answer"}};
                    sendJson(res, answer);
                }));
    server.Post(std::string("/api/parts/") + kPart + "/rollback",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto session = signedIn_(req);
                    const auto body = jsonBody(req, "{\"version\": V}");
                    if (!body.contains("version") || !body["version"].is_number_integer())
                        throw HttpError(400, "version: the version to make the one in force again");
                    const std::string part = req.matches[1].str();
                    runPart({"rollback", part, std::to_string(body["version"].get<int>()), "--by", session.name},
                            std::chrono::seconds(60));
                    const auto reload = mailbox_.call({{"command", "reload"}}, std::chrono::milliseconds(2000));
                    json answer = partJson(part);
                    answer["reload"] = reload ? *reload : json{{"ok", false}, {"error", "the daemon did not answer"}};
                    sendJson(res, answer);
                }));
}

} // namespace hg::daemon
