#include "hmi/hmi_server.h"
#include "hmi/http_util.h"
#include "hmi/parts_routes.h"

#include "hullgauge/calib/station_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/inspect/outcome.h"
#include "hullgauge/report/record_pdf.h"
#include "hullgauge/station/plc_registers.h"
#include "hullgauge/station/sequencer.h"
#include "hullgauge/store/export.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/study/pareto.h"
#include "hullgauge/study/spc.h"

#include <algorithm>
#include <charconv>
#include <cstring>
#include <fstream>
#include <httplib.h>
#include <poll.h>
#include <regex>
#include <sstream>
#include <sys/socket.h>
#include <sys/statvfs.h>
#include <unistd.h>

namespace hg::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// The selection of /api/results and the exports (docs/hmi.md, "JSON API").
store::ResultQuery resultQuery(const httplib::Request& req)
{
    // The filters are `hullgauge export`'s too (docs/export.md): one parser for both.
    store::SelectionFilters filters;
    const auto param = [&req](const char* name) {
        return req.has_param(name) ? std::optional<std::string>(req.get_param_value(name)) : std::nullopt;
    };
    filters.program = param("program");
    filters.serial = param("serial");
    filters.verdict = param("verdict");
    filters.purpose = param("purpose");
    filters.since = param("since");
    filters.until = param("until");
    auto q = store::parseSelection(filters, "");
    q.beforeId = intParam(req, "before", 1, std::numeric_limits<std::int64_t>::max());
    q.limit = static_cast<int>(intParam(req, "limit", 1, 500).value_or(50));
    return q;
}

/// The SPC page's data (docs/hmi.md, "JSON API"; docs/spc.md): the program's
/// PLC-triggered production cycles that ended pass or fail — master, study,
/// maintenance-triggered, aborted and error cycles never count — the newest
/// `limit` of them, oldest first; one landmark's charts, or every landmark's.
json spcSeries(const fs::path& database, const httplib::Request& req)
{
    if (!req.has_param("program")) throw HttpError(400, "program: missing (the part program's number)");
    store::ResultQuery q;
    q.program = static_cast<int>(*intParam(req, "program", 1, 65535));
    q.purpose = "production";
    q.manual = false;
    q.verdicts = {"pass", "fail"};
    q.limit = static_cast<int>(intParam(req, "limit", 2, 5000).value_or(500));
    study::SpcOptions options;
    options.baseline = static_cast<std::size_t>(intParam(req, "baseline", 2, 5000).value_or(25));
    options.rules = study::parseRuleSet(oneOf(req, "rules", {"nelson", "western_electric"}, "nelson"));
    const auto landmark = req.has_param("landmark") ? req.get_param_value("landmark") : std::string();

    auto rows = store::ResultReader(database).select(q);
    std::reverse(rows.begin(), rows.end());
    std::vector<study::StudyRecord> records;
    for (auto& row : rows)
        records.push_back({row.at("id").get<std::int64_t>(), row.value("serial", ""), std::move(row["landmarks"])});
    json ids = json::array();
    json charts = json::array();
    // A cycle without a value for a landmark is a gap in its chart, not the end of it (docs/spc.md, "Gaps").
    for (const auto& series : study::collectSeries(records, study::MissingValues::Gap)) {
        ids.push_back(series.id);
        if (landmark.empty() || series.id == landmark) charts.push_back(study::toJson(study::spcOf(series, options)));
    }
    if (!landmark.empty() && charts.empty())
        throw HttpError(404, "program " + std::to_string(*q.program) + " has no landmark '" + landmark +
                                 "' in its production cycles");
    return {{"program", *q.program}, {"cycles", records.size()}, {"landmark_ids", ids}, {"landmarks", charts}};
}

/// A Pareto counts at most this many cycles (a few MB of landmarks read at once).
constexpr std::int64_t kMaxParetoCycles = 100000;

/// The Pareto of what fails (docs/spc.md, "Pareto"): the PLC's production
/// cycles of a period — every verdict, so faults count — optionally of one
/// program; each fault code named.
json paretoSeries(const fs::path& database, const httplib::Request& req)
{
    store::ResultQuery q;
    if (const auto program = intParam(req, "program", 1, 65535)) q.program = static_cast<int>(*program);
    q.purpose = "production";
    q.manual = false;
    if (req.has_param("since")) q.sinceMs = store::parseUtc(req.get_param_value("since"), "since");
    if (req.has_param("until")) q.untilMs = store::parseUtc(req.get_param_value("until"), "until");
    q.newestFirst = false;
    const store::ResultReader reader(database);
    if (const auto cycles = reader.count(q); cycles > kMaxParetoCycles)
        throw HttpError(400, "the period holds " + std::to_string(cycles) + " cycles, a Pareto at most " +
                                 std::to_string(kMaxParetoCycles) + ": narrow it (since/until, program)");
    std::vector<study::ParetoRecord> records;
    for (auto& row : reader.select(q))
        records.push_back({row.at("id").get<std::int64_t>(), row.value("verdict", ""), row.value("fault_code", 0),
                           std::move(row["landmarks"])});
    json answer = study::toJson(study::paretoOf(records));
    for (auto& f : answer["faults"]) {
        const auto code = static_cast<station::FaultCode>(f["code"].get<int>());
        f["name"] = std::string(enumName(code));
        f["sentence"] = station::describe(code);
    }
    answer["program"] = q.program ? json(*q.program) : json(nullptr);
    answer["since"] = q.sinceMs ? json(store::formatUtc(*q.sinceMs)) : json(nullptr);
    answer["until"] = q.untilMs ? json(store::formatUtc(*q.untilMs)) : json(nullptr);
    return answer;
}

/// The window of the health charts when the page names none: the last week.
constexpr std::int64_t kHealthWindowMs = 7LL * 24 * 3600 * 1000;

/// The station's health figures of a window (docs/hmi.md, "JSON API"; docs/health.md, "In the daemon"):
/// the store's rows, oldest first, the newest `limit` of them.
json healthSeries(const fs::path& database, const httplib::Request& req, std::int64_t nowMs)
{
    store::HealthQuery q;
    q.sinceMs =
        req.has_param("since") ? store::parseUtc(req.get_param_value("since"), "since") : nowMs - kHealthWindowMs;
    if (req.has_param("until")) q.untilMs = store::parseUtc(req.get_param_value("until"), "until");
    q.limit = static_cast<int>(intParam(req, "limit", 1, 20000).value_or(5000));
    const auto rows = store::ResultReader(database).health(q);
    return {{"since", store::formatUtc(*q.sinceMs)},
            {"until", q.untilMs ? json(store::formatUtc(*q.untilMs)) : json()},
            {"cycles", rows.size()},
            {"rows", rows}};
}

/// A download holds at most this many cycles; `hullgauge export` has no limit.
constexpr std::int64_t kMaxExportCycles = 20000;

/// The results page's downloads (docs/export.md): the selection of /api/results
/// without its paging, oldest first, in one of the export formats.
void sendExport(const fs::path& database, const httplib::Request& req, httplib::Response& res)
{
    const auto format = store::parseExportFormat(oneOf(req, "format", {"csv", "aqdef", "json"}, "csv"));
    auto q = resultQuery(req);
    q.limit = 0;
    q.newestFirst = false;
    const store::ResultReader reader(database);
    const auto cycles = reader.count(q);
    if (cycles > kMaxExportCycles)
        throw HttpError(400, "the selection holds " + std::to_string(cycles) + " cycles, a download at most " +
                                 std::to_string(kMaxExportCycles) +
                                 ": narrow it (since/until, program) or use hullgauge export");
    // As `hullgauge export --include-simulated` (docs/export.md): the demo's cycles tried in an SPC program.
    store::ExportSettings settings;
    settings.includeSimulated = oneOf(req, "include_simulated", {"true", "false"}, "false") == "true";
    std::ostringstream out;
    store::writeExport(out, format, reader.select(q), settings);
    res.set_header("Cache-Control", "no-store");
    res.set_header("Content-Disposition",
                   "attachment; filename=\"hullgauge-results." + std::string(store::fileExtension(format)) + "\"");
    res.set_content(out.str(), std::string(store::contentType(format)));
}

/// A row of the results list: the stored row without its bulky parts, with the failed landmarks named.
json summary(const json& row)
{
    json failed = json::array();
    // A landmark whose status is missing or unknown is listed as failed, not refused:
    // the list shows every stored row (docs/hmi.md).
    for (const auto& l : row.at("landmarks"))
        if (parseEnum<inspect::LandmarkStatus>(l.value("status", "")) != inspect::LandmarkStatus::Ok)
            failed.push_back(l.value("id", ""));
    json s = row;
    for (const char* bulky : {"landmarks", "timing", "alignment", "simulation"}) s.erase(bulky);
    s["failed_landmarks"] = std::move(failed);
    s["has_images"] = !row.at("images").get<std::string>().empty();
    s.erase("images");
    return s;
}

/// The fault the operator reads on the line view (docs/hmi.md, "Line view"): the
/// station's own while it is in fault, else the FAULT_CODE the PLC reads with
/// the last result (docs/plc.md, "Fault codes"); sentence and action from the
/// one table of them (station::describe, station::faultAction).
json faultOf(const json& status, int retries)
{
    const json& sequencer = status.contains("sequencer") ? status["sequencer"] : json::object();
    const json& plc = status.contains("plc") ? status["plc"] : json::object();
    const bool inFault = sequencer.contains("fault_code");
    const int code = inFault ? sequencer["fault_code"].get<int>() : plc.value("fault_code", 0);
    const auto fault = static_cast<station::FaultCode>(code);
    // The sequencer's sentence counts the retries its cycle had; the register's, the configured ones.
    const auto sentence = inFault && sequencer.contains("fault") ? sequencer["fault"].get<std::string>()
                                                                 : station::describe(fault, retries);
    return {{"code", code},
            {"name", std::string(enumName(fault))},
            {"sentence", sentence},
            {"action", std::string(station::faultAction(fault))},
            {"source", inFault     ? "station"
                       : code != 0 ? "last_result"
                                   : "none"}};
}

/// The current shift's production (docs/hmi.md, "Line view"): the PLC-triggered
/// production cycles that started since the shift began, by verdict; the yield
/// is pass / (pass + fail), null before the first judged part.
json shiftOf(const station::DaemonConfig& cfg, std::int64_t nowUnixMs, const station::UtcOffset& offset)
{
    const auto window = station::currentShift(cfg.shifts, nowUnixMs, offset);
    const store::ResultReader reader(cfg.results.database);
    store::ResultQuery q;
    q.purpose = "production";
    q.manual = false;
    q.sinceMs = window.startUnixMs;
    json shift{{"name", cfg.shifts[window.index].name},
               {"started_utc", store::formatUtc(window.startUnixMs)},
               {"started_unix_ms", window.startUnixMs},
               {"cycles", reader.count(q)}};
    for (const char* verdict : {"pass", "fail", "aborted", "error"}) {
        q.verdicts = {verdict};
        shift[verdict] = reader.count(q);
    }
    const auto judged = shift["pass"].get<std::int64_t>() + shift["fail"].get<std::int64_t>();
    shift["yield"] = judged ? json(double(shift["pass"].get<std::int64_t>()) / double(judged)) : json();
    return shift;
}

/// The archived part's folder, when it lies inside the configured image folder; never a path the row could
/// name outside it. Empty when the part has none there.
fs::path archiveFolderOf(const json& row, const fs::path& imageRoot)
{
    const auto stored = row.at("images").get<std::string>();
    if (stored.empty()) return {};
    std::error_code ec;
    fs::path folder = fs::weakly_canonical(stored, ec);
    const auto root = fs::weakly_canonical(imageRoot, ec);
    const auto rel = folder.lexically_relative(root);
    if (ec || rel.empty() || *rel.begin() == ".." || *rel.begin() == "." || !fs::is_directory(folder, ec)) return {};
    return folder;
}

/// The annotated pictures of an archived part (view_<k>.png), when its folder
/// lies inside the configured image folder (archiveFolderOf).
std::vector<std::string> imagesOf(const json& row, const fs::path& imageRoot, fs::path& folder)
{
    std::vector<std::string> names;
    folder = archiveFolderOf(row, imageRoot);
    if (folder.empty()) return names;
    std::error_code ec;
    static const std::regex kView(R"(view_[0-9]{1,3}\.png)");
    for (const auto& entry : fs::directory_iterator(folder, ec))
        if (entry.is_regular_file() && std::regex_match(entry.path().filename().string(), kView))
            names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
        return a.size() != b.size() ? a.size() < b.size() : a < b;
    });
    return names;
}

/// The stored row with the id of a request path (digits, matched by the route); 404 when there is none.
std::optional<json> storedResult(const station::DaemonConfig& cfg, const std::string& id)
{
    const store::ResultReader reader(cfg.results.database);
    auto row = reader.byId(std::stoll(id));
    if (!row) throw HttpError(404, "no result " + id);
    return row;
}

/// The file of view `view`'s overlay (`overlay`: view_<k>.json) or plain frame (the file its overlay names:
/// frame_<k>.png or the capture's 8-bit frame; docs/daemon.md, "Archived parts") in the part's folder.
/// 404 when the part has no such file, as an older part without overlays has not.
fs::path overlayFile(const station::DaemonConfig& cfg, const std::string& id, const std::string& view, bool overlay)
{
    const auto row = storedResult(cfg, id);
    const fs::path folder = archiveFolderOf(*row, cfg.results.imageDir);
    const std::string what = overlay ? "overlay of view " + view : "plain frame of view " + view;
    if (folder.empty()) throw HttpError(404, "result " + id + " has no archived images");
    const fs::path file = folder / ("view_" + view + ".json");
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) throw HttpError(404, "result " + id + " has no " + what);
    if (overlay) return file;
    // The overlay names its frame; only a plain file name of the folder is followed.
    const auto text = readFile(file);
    const json parsed = text ? json::parse(*text, nullptr, false) : json();
    const std::string frame = parsed.is_object() && parsed.value("frame", json()).is_string()
                                  ? parsed.at("frame").get<std::string>()
                                  : std::string();
    static const std::regex kFrame(R"([A-Za-z0-9_-]{1,64}\.png)");
    if (!std::regex_match(frame, kFrame) || !fs::is_regular_file(folder / frame, ec))
        throw HttpError(404, "result " + id + " has no " + what);
    return folder / frame;
}

/// The station's name on a part record (docs/hmi.md, "Part record"): the plant
/// link's station id when there is one, the name the plant knows it by, else the host name.
std::string stationName(const station::DaemonConfig& cfg)
{
    if (cfg.mqtt.enabled && !cfg.mqtt.stationId.empty()) return cfg.mqtt.stationId;
    char host[256] = {};
    return ::gethostname(host, sizeof host - 1) == 0 ? std::string(host) : std::string();
}

/// The part record of a stored result as a PDF download (docs/hmi.md, "Part record"): its row and archived views.
void sendRecordPdf(const station::DaemonConfig& cfg, const std::string& id, std::int64_t nowMs, httplib::Response& res)
{
    const auto row = storedResult(cfg, id);
    fs::path folder;
    std::vector<report::RecordView> views;
    for (const auto& name : imagesOf(*row, cfg.results.imageDir, folder)) {
        auto bytes = readFile(folder / name);
        if (!bytes) throw HttpError(500, "result " + id + ": cannot read its image " + name);
        views.push_back({name, std::vector<unsigned char>(bytes->begin(), bytes->end())});
    }
    std::ostringstream pdf;
    report::writeRecordPdf(pdf, *row, views, {stationName(cfg), nowMs});
    res.set_header("Cache-Control", "no-store");
    res.set_header("Content-Disposition", "attachment; filename=\"" + report::recordFileName(*row) + "\"");
    res.set_content(pdf.str(), "application/pdf");
}

/// The station's calibrations, newest first (calib::calibrationHistory): the
/// station file's records and each backup's, with the file's name.
json calibrationHistory(const fs::path& stationFile)
{
    json history = json::array();
    for (const auto& c : calib::calibrationHistory(stationFile, 50)) {
        json entry{{"file", c.file.filename().string()}, {"camera", c.camera}, {"fixture", c.fixture}};
        if (!c.error.empty()) entry["error"] = c.error;
        history.push_back(std::move(entry));
    }
    return history;
}

/// A request the gate passed, as cpp-httplib reads it: its bytes from memory,
/// the answer to the client's socket under the write timeout.
class GatedStream : public httplib::Stream {
  public:
    explicit GatedStream(const GatedRequest& request) : r_(request) {}
    bool is_readable() const override { return pos_ < r_.bytes.size(); }
    bool is_writable() const override
    {
        pollfd p{r_.fd, POLLOUT, 0};
        return ::poll(&p, 1, 5000) == 1 && (p.revents & POLLOUT);
    }
    ssize_t read(char* ptr, size_t size) override
    {
        const std::size_t n = std::min(size, r_.bytes.size() - pos_);
        std::memcpy(ptr, r_.bytes.data() + pos_, n);
        pos_ += n;
        return static_cast<ssize_t>(n);
    }
    ssize_t write(const char* ptr, size_t size) override
    {
        std::size_t sent = 0;
        while (sent < size) {
            if (!is_writable()) return -1; // the client stopped reading for the write timeout (5 s)
            const ssize_t n = ::send(r_.fd, ptr + sent, size - sent, MSG_NOSIGNAL);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) return -1;
            sent += static_cast<std::size_t>(n);
        }
        return static_cast<ssize_t>(size);
    }
    void get_remote_ip_and_port(std::string& ip, int& port) const override
    {
        ip = r_.peerIp;
        port = r_.peerPort;
    }
    void get_local_ip_and_port(std::string& ip, int& port) const override
    {
        ip.clear();
        port = 0;
    }
    socket_t socket() const override { return r_.fd; }

  private:
    const GatedRequest& r_;
    std::size_t pos_ = 0;
};

/// The name an engineer signs in with (`name`, optional): who released what
/// on the workbench (docs/workbench.md). Printable, at most 64 bytes.
} // namespace

/// cpp-httplib's server answering requests the gate read (GateListener): its
/// routing and handlers as they are, its own accept loop never run.
class GatedHttpServer : public httplib::Server {
  public:
    void answer(const GatedRequest& request)
    {
        GatedStream stream(request);
        bool closed = false;
        (void)process_request(stream, true, closed, [](httplib::Request&) {});
    }
};

HmiServer::HmiServer(std::shared_ptr<const station::DaemonConfig> config, CommandMailbox& mailbox, Clock& clock,
                     SnapshotSource snapshots, station::UtcOffset utcOffset, std::shared_ptr<store::AuditLog> audit)
    : config_(std::move(config)), mailbox_(mailbox), clock_(clock), snapshots_(std::move(snapshots)),
      utcOffset_(utcOffset ? std::move(utcOffset) : station::UtcOffset(station::localUtcOffset)),
      limiter_(config_->http.requestsPerSecond, config_->http.burst, clock),
      audit_(audit ? std::move(audit) : std::make_shared<store::AuditLog>(station::auditFile(*config_))),
      access_(std::make_unique<Access>([this] { return this->config(); }, audit_, clock)),
      server_(std::make_unique<GatedHttpServer>())
{
    const auto& http = config_->http;
    // The gate holds each request to its own limit (the CAD upload to workbench.max_upload_bytes).
    server_->set_payload_max_length(std::max(http.maxRequestBytes, config_->workbench.maxUploadBytes));
    // Every answer closes its connection: a line view polling four times a
    // second would otherwise keep a thread, and `threads` screens starve every other.
    server_->set_keep_alive_max_count(1);
    server_->set_socket_options([this](int fd) {
        int one = 1;
        setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        listenFd_ = fd;
    });
    server_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        return guard(req, res) ? httplib::Server::HandlerResponse::Unhandled
                               : httplib::Server::HandlerResponse::Handled;
    });
    server_->set_post_routing_handler([](const httplib::Request&, httplib::Response& res) {
        res.set_header("X-Content-Type-Options", "nosniff");
        res.set_header("X-Frame-Options", "DENY");
        res.set_header("Referrer-Policy", "no-referrer");
        res.set_header("Content-Security-Policy",
                       "default-src 'self'; img-src 'self' data:; frame-ancestors 'none'; form-action 'self'");
    });
    server_->set_error_handler([](const httplib::Request&, httplib::Response& res) {
        // cpp-httplib's own refusals (413 too large, 414 URI too long, 400 malformed, 404) get a JSON body too.
        if (res.body.empty()) sendError(res, res.status, "HTTP " + std::to_string(res.status));
    });
    routePages();
    routeApi();
    access_->route(*server_);
    routeMaintenance();
    if (config_->workbench.enabled())
        parts_ = std::make_unique<PartsRoutes>(
            *server_, config_->workbench, [this] { return this->config(); }, *access_, mailbox_, files_);
    port_ = http.port == 0 ? server_->bind_to_any_port(http.bindAddress)
                           : (server_->bind_to_port(http.bindAddress, http.port) ? http.port : -1);
    if (port_ < 0) throw FaultError("web HMI: cannot listen on " + http.bindAddress + ":" + std::to_string(http.port));
    // cpp-httplib listens with a backlog of 5; many screens connecting at once need more.
    if (listenFd_ >= 0) ::listen(listenFd_, 1024);
    // The gate reads every request whole, under one deadline; `threads` only answer (docs/hmi.md, "Bounded").
    pool_ = std::make_unique<httplib::ThreadPool>(static_cast<std::size_t>(http.threads));
    GateListener::Options gate;
    gate.limits.maxBodyBytes = http.maxRequestBytes;
    if (config_->workbench.enabled()) {
        gate.limits.uploadTarget = "/api/parts";
        gate.limits.maxUploadBytes = config_->workbench.maxUploadBytes;
    }
    gate.limits.allowedHosts = station::allowedHostsFor(http);
    gate.requestTimeout = http.requestTimeout;
    gate.maxPending = http.maxPendingRequests;
    gate_ = std::make_unique<GateListener>(
        listenFd_, gate,
        [this](GatedRequest request) {
            pool_->enqueue([this, request = std::move(request)] {
                server_->answer(request);
                ::close(request.fd);
            });
        },
        clock_);
    hg::log::category("hmi")->info("web HMI on http://{}:{}/", http.bindAddress, port_);
}

HmiServer::~HmiServer()
{
    stop();
}

void HmiServer::stop()
{
    // The gate first (no new request is handed on), then the answers in flight, then the socket.
    if (gate_) gate_->stop();
    if (pool_) pool_->shutdown();
    pool_.reset();
    parts_.reset(); // the workbench's jobs end with the daemon
    if (listenFd_ >= 0) ::close(listenFd_);
    listenFd_ = -1;
}

void HmiServer::setConfig(std::shared_ptr<const station::DaemonConfig> config)
{
    std::lock_guard lock(configMutex_);
    config_ = std::move(config);
}

std::shared_ptr<const station::DaemonConfig> HmiServer::config() const
{
    std::lock_guard lock(configMutex_);
    return config_;
}

// Before routing: methods, the rate limit and the cross-site rules of docs/hmi.md ("Security").
bool HmiServer::guard(const httplib::Request& req, httplib::Response& res)
{
    if (req.method != "GET" && req.method != "HEAD" && req.method != "POST") {
        sendError(res, 405, "method " + req.method + " not allowed");
        return false;
    }
    if (!limiter_.allow(req.remote_addr)) {
        res.set_header("Retry-After", "1");
        sendError(res, 429, "too many requests from " + req.remote_addr);
        return false;
    }
    if (req.method != "POST") return true;
    // A state change comes from our own pages only: JSON (no HTML form can send it
    // cross-site without a preflight we never grant) from our own origin.
    // The one exception, a CAD upload (docs/workbench.md), carries its file's bytes and still needs
    // the session's CSRF token: a custom header no other site can send without a preflight.
    const bool upload =
        req.path == "/api/parts" && req.get_header_value("Content-Type").rfind("application/octet-stream", 0) == 0;
    if (!upload && req.get_header_value("Content-Type").rfind(kJson, 0) != 0) {
        sendError(res, 415, "a POST carries application/json");
        return false;
    }
    const auto origin = req.get_header_value("Origin");
    if (!origin.empty() && origin != "http://" + req.get_header_value("Host")) {
        sendError(res, 403, "cross-origin request refused (Origin " + origin + ")");
        return false;
    }
    const auto site = req.get_header_value("Sec-Fetch-Site");
    if (!site.empty() && site != "same-origin" && site != "none") {
        sendError(res, 403, "cross-site request refused (Sec-Fetch-Site " + site + ")");
        return false;
    }
    return true;
}

void HmiServer::routePages()
{
    // The pages: one HTML file each, their scripts and styles beside them.
    static const std::map<std::string, std::string> kPages{{"/", "line.html"},
                                                           {"/results", "results.html"},
                                                           {"/result", "result.html"},
                                                           {"/spc", "spc.html"},
                                                           {"/maintenance", "maintenance.html"},
                                                           {"/parts", "parts.html"},
                                                           {"/record", "record.html"},
                                                           {"/audit", "audit.html"},
                                                           {"/users", "users.html"}};
    for (const auto& [path, file] : kPages)
        server_->Get(path, [this, file = file](const httplib::Request& req, httplib::Response& res) {
            files_.serve(req, res, config()->http.assets / file);
        });
    server_->Get(R"(/assets/([a-z0-9][a-z0-9_-]*\.(?:js|css|svg|png)))",
                 [this](const httplib::Request& req, httplib::Response& res) {
                     files_.serve(req, res, config()->http.assets / req.matches[1].str());
                 });
    // Chart.js from Debian's libjs-chart.js (UMD build: window.Chart), never from a CDN.
    server_->Get("/lib/chart.js", [this](const httplib::Request& req, httplib::Response& res) {
        files_.serve(req, res, config()->http.javascript / "chart.js" / "chart.min.js");
    });
    // three.js from Debian's libjs-three (the UMD build, window.THREE, and the examples' non-module scripts that
    // add to it) for the workbench's 3D view (docs/workbench.md).
    static const std::map<std::string, std::string> kThree{
        {"/lib/three/three.min.js", "three/build/three.min.js"},
        {"/lib/three/OrbitControls.js", "three/examples/js/controls/OrbitControls.js"},
        {"/lib/three/STLLoader.js", "three/examples/js/loaders/STLLoader.js"}};
    for (const auto& [path, file] : kThree)
        server_->Get(path, [this, file = file](const httplib::Request& req, httplib::Response& res) {
            files_.serve(req, res, config()->http.javascript / file);
        });
}

void HmiServer::routeApi()
{
    server_->Get("/api/status",
                 api([this](const httplib::Request&, httplib::Response& res) { sendJson(res, status()); }));
    server_->Get("/api/results", api([this](const httplib::Request& req, httplib::Response& res) {
                     const auto q = resultQuery(req);
                     const store::ResultReader reader(config()->results.database);
                     json rows = json::array();
                     for (const auto& row : reader.select(q)) rows.push_back(summary(row));
                     json body{{"results", rows}};
                     if (static_cast<int>(rows.size()) == q.limit) body["next_before"] = rows.back().at("id");
                     sendJson(res, body);
                 }));
    server_->Get(R"(/api/results/([0-9]{1,18}))", api([this](const httplib::Request& req, httplib::Response& res) {
                     const auto cfg = config();
                     auto row = storedResult(*cfg, req.matches[1].str());
                     fs::path folder;
                     (*row)["image_files"] = imagesOf(*row, cfg->results.imageDir, folder);
                     row->erase("images");
                     (*row)["station"] = stationName(*cfg);
                     sendJson(res, *row);
                 }));
    server_->Get(R"(/api/results/([0-9]{1,18})/record\.pdf)",
                 api([this](const httplib::Request& req, httplib::Response& res) {
                     sendRecordPdf(*config(), req.matches[1].str(), clock_.wallMs(), res);
                 }));
    server_->Get(R"(/api/results/([0-9]{1,18})/images/(view_[0-9]{1,3}\.png))",
                 api([this](const httplib::Request& req, httplib::Response& res) {
                     const auto cfg = config();
                     const auto row = storedResult(*cfg, req.matches[1].str());
                     fs::path folder;
                     const auto names = imagesOf(*row, cfg->results.imageDir, folder);
                     const auto name = req.matches[2].str();
                     if (std::find(names.begin(), names.end(), name) == names.end())
                         throw HttpError(404, "result " + req.matches[1].str() + " has no image " + name);
                     files_.serve(req, res, folder / name);
                 }));
    // The reject view's plain frame and overlay (docs/hmi.md, "Reject views").
    server_->Get(R"(/api/results/([0-9]{1,18})/images/frame_([0-9]{1,3})\.png)",
                 api([this](const httplib::Request& req, httplib::Response& res) {
                     files_.serve(req, res, overlayFile(*config(), req.matches[1].str(), req.matches[2].str(), false));
                 }));
    server_->Get(R"(/api/results/([0-9]{1,18})/views/([0-9]{1,3})\.json)",
                 api([this](const httplib::Request& req, httplib::Response& res) {
                     files_.serve(req, res, overlayFile(*config(), req.matches[1].str(), req.matches[2].str(), true));
                 }));
    server_->Get("/api/spc", api([this](const httplib::Request& req, httplib::Response& res) {
                     sendJson(res, spcSeries(config()->results.database, req));
                 }));
    server_->Get("/api/pareto", api([this](const httplib::Request& req, httplib::Response& res) {
                     sendJson(res, paretoSeries(config()->results.database, req));
                 }));
    // The maintenance page's health charts: the stored figures and the station's health now (its status).
    server_->Get("/api/health", api([this](const httplib::Request& req, httplib::Response& res) {
                     json answer = healthSeries(config()->results.database, req, clock_.wallMs());
                     const json now = status();
                     answer["now"] = now.contains("health") ? now["health"] : json();
                     sendJson(res, answer);
                 }));
    server_->Get("/api/export", api([this](const httplib::Request& req, httplib::Response& res) {
                     sendExport(config()->results.database, req, res);
                 }));
    server_->Get("/api/programs", api([this](const httplib::Request&, httplib::Response& res) {
                     json programs = json::array();
                     const auto cfg = config();
                     for (const auto& [number, ref] : cfg->programs) {
                         json views = json::array();
                         for (const auto& v : ref.views)
                             views.push_back(geometry::toJson(v, cfg->station.fixture.type));
                         programs.push_back({{"number", number},
                                             {"part", ref.partFile.string()},
                                             {"views_file", ref.viewsFile.string()},
                                             {"views", views},
                                             {"force", ref.force}});
                     }
                     sendJson(res, {{"programs", programs}});
                 }));
    server_->Get("/api/calibration", api([this](const httplib::Request&, httplib::Response& res) {
                     auto answer = mailbox_.call({{"command", "calibration"}}, std::chrono::milliseconds(2000));
                     if (!answer) throw HttpError(503, "the daemon did not answer in time");
                     // The history is read here, on the web thread, not by the main loop.
                     (*answer)["history"] = calibrationHistory(config()->stationFile);
                     sendJson(res, *answer);
                 }));
    server_->Get("/api/snapshot", api([this](const httplib::Request&, httplib::Response& res) {
                     auto answer = mailbox_.call({{"command", "snapshot"}}, std::chrono::milliseconds(2000));
                     if (!answer) throw HttpError(503, "the daemon did not answer in time");
                     sendJson(res, *answer);
                 }));
    server_->Get("/api/snapshot.png", api([this](const httplib::Request&, httplib::Response& res) {
                     const auto png = snapshots_ ? snapshots_() : nullptr;
                     if (!png) throw HttpError(404, "no camera snapshot yet");
                     res.set_header("Cache-Control", "no-store");
                     res.set_content(reinterpret_cast<const char*>(png->data()), png->size(), "image/png");
                 }));
}

// The maintenance actions (docs/hmi.md, "Maintenance"): the maintenance socket's commands a signed-in
// engineer may send, each under the right it needs (docs/audit.md); the command table records the
// changes among them with the person who asked.
void HmiServer::routeMaintenance()
{
    server_->Post(
        "/api/maintenance", api([this](const httplib::Request& req, httplib::Response& res) {
            auto body = json::parse(req.body, nullptr, false);
            if (!body.is_object() || !body.contains("command") || !body["command"].is_string())
                throw HttpError(400, "expected {\"command\": \"...\", ...}");
            using store::Permission;
            static const std::map<std::string, std::pair<Permission, const char*>> kOffered{
                {"trigger", {Permission::Operate, "maintenance.trigger"}},
                {"abort", {Permission::Operate, "maintenance.abort"}},
                {"snapshot", {Permission::Operate, "maintenance.snapshot"}},
                {"sim-part", {Permission::Operate, "setting.sim-part"}},
                {"purpose", {Permission::Operate, "setting.purpose"}},
                {"calibrate", {Permission::Calibration, "calibration.run"}},
                {"flat-field", {Permission::Calibration, "calibration.flat-field"}},
                {"master", {Permission::Calibration, "mastering.run"}},
                {"reload", {Permission::Settings, "setting.reload"}}};
            const auto command = body["command"].get<std::string>();
            const auto offered = kOffered.find(command);
            if (offered == kOffered.end()) throw HttpError(400, "command '" + command + "' is not offered");
            const auto [permission, action] = offered->second;
            const auto actor = access_->authorize(req, permission, action, command);
            // The HMI's calibration writes the station's own file, nowhere else.
            if (command == "calibrate" && body.contains("out"))
                throw HttpError(400, "out: the HMI's calibration writes the station file the daemon runs with");
            body["caller"] = {{"who", actor.name}, {"role", enumName(actor.role)}, {"source", actor.source}};
            hg::log::category("hmi")->info("maintenance '{}' from {} by '{}'", command, req.remote_addr, actor.name);
            auto answer = mailbox_.call(std::move(body), std::chrono::milliseconds(2000));
            if (!answer) throw HttpError(503, "the daemon did not answer in time");
            sendJson(res, *answer, answer->value("ok", false) ? 200 : 409);
        }));
}

// The line view's data: the daemon's status (at most ten asks a second of the
// main loop however many pages poll), the newest result, the disk, the fault in
// words, the PLC status's name and the current shift's counts (docs/hmi.md).
json HmiServer::status()
{
    std::lock_guard lock(cacheMutex_);
    const auto now = clock_.now();
    if (statusCache_.is_null() || now - statusAt_ > std::chrono::milliseconds(100)) {
        auto answer = mailbox_.call({{"command", "status"}}, std::chrono::milliseconds(2000));
        if (!answer) throw HttpError(503, "the daemon did not answer in time");
        const auto cfg = config();
        const store::ResultReader reader(cfg->results.database);
        store::ResultQuery newest;
        newest.limit = 1;
        const auto rows = reader.select(newest);
        (*answer)["last_result"] = rows.empty() ? json() : summary(rows.front());
        (*answer)["disk"] = disk(*cfg);
        (*answer)["fault"] = faultOf(*answer, cfg->sequencer.retries);
        const auto wallMs =
            std::chrono::duration_cast<std::chrono::milliseconds>(clock_.wallNow().time_since_epoch()).count();
        (*answer)["shift"] = shiftOf(*cfg, wallMs, utcOffset_);
        if (answer->contains("plc") && (*answer)["plc"].contains("status"))
            (*answer)["plc"]["status_name"] =
                std::string(enumName(static_cast<station::PlcStatus>((*answer)["plc"]["status"].get<int>())));
        answer->erase("pid");
        answer->erase("config");
        statusCache_ = std::move(*answer);
        statusAt_ = now;
    }
    return statusCache_;
}

// How full the archive and its disk are (docs/hmi.md); walked at most every 10 s.
json HmiServer::disk(const station::DaemonConfig& cfg)
{
    const auto now = clock_.now();
    if (!diskCache_.is_null() && now - diskAt_ < std::chrono::seconds(10)) return diskCache_;
    std::uint64_t bytes = 0, folders = 0;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(cfg.results.imageDir, ec); !ec && it != fs::end(it);
         it.increment(ec)) {
        if (it.depth() == 0 && it->is_directory(ec)) ++folders;
        if (it->is_regular_file(ec)) bytes += it->file_size(ec);
    }
    struct statvfs fsStats {};
    json d{{"archive_bytes", bytes},
           {"archive_folders", folders},
           {"max_bytes", cfg.results.retention.maxBytes},
           {"max_count", cfg.results.retention.maxCount}};
    if (statvfs(cfg.results.imageDir.c_str(), &fsStats) == 0) {
        d["filesystem_bytes"] = static_cast<std::uint64_t>(fsStats.f_blocks) * fsStats.f_frsize;
        d["filesystem_free_bytes"] = static_cast<std::uint64_t>(fsStats.f_bavail) * fsStats.f_frsize;
    }
    diskCache_ = d;
    diskAt_ = now;
    return d;
}

} // namespace hg::daemon
