#include "daemon_config.h"

#include "hmi/hmi_auth.h"
#include "hullgauge/calib/flat_field.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/inspect/correction.h"
#include "hullgauge/workbench/workspace.h"

#include <algorithm>
#include <arpa/inet.h>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <ifaddrs.h>
#include <limits>
#include <unistd.h>

namespace hg::station {
namespace {

namespace fs = std::filesystem;

std::chrono::milliseconds seconds(const ConfigNode& node, double lo, double hi)
{
    return std::chrono::milliseconds(std::llround(node.asDoubleIn(lo, hi) * 1000.0));
}

fs::path resolve(const ConfigNode& node, const fs::path& base)
{
    auto text = node.asString();
    if (text.empty()) node.fail("expected a path");
    fs::path p(text);
    return p.is_absolute() ? p : (base / p).lexically_normal();
}

fs::path existingFile(const ConfigNode& node, const fs::path& base)
{
    auto p = resolve(node, base);
    if (auto problem = notARegularFile(p); !problem.empty()) node.fail(problem + ": " + p.string());
    return p;
}

void parsePlc(const ConfigNode& node, PlcConfig& plc)
{
    node.allowOnlyKeys({"bind", "port", "unit_id", "allowed_clients", "max_clients", "frame_timeout_s",
                        "idle_timeout_s", "yield_after_s", "heartbeat_period_s"});
    if (auto n = node.optional("bind")) {
        plc.bindAddress = n->asString();
        in_addr tmp{};
        if (inet_pton(AF_INET, plc.bindAddress.c_str(), &tmp) != 1)
            n->fail("expected an IPv4 address such as 0.0.0.0 or 127.0.0.1");
    }
    if (auto n = node.optional("port")) plc.port = static_cast<int>(n->asIntIn(1, 65535));
    if (auto n = node.optional("unit_id")) plc.unitId = static_cast<int>(n->asIntIn(0, 255));
    if (auto n = node.optional("allowed_clients")) {
        if (!n->isSequence()) n->fail("expected a list of IPv4 addresses or networks (a.b.c.d or a.b.c.d/n)");
        for (const auto& item : n->items()) {
            auto net = parseIpv4Network(item.asString());
            if (!net) item.fail("expected an IPv4 address or network (a.b.c.d or a.b.c.d/n)");
            plc.allowedClients.push_back(*net);
        }
    }
    if (auto n = node.optional("max_clients")) plc.maxClients = static_cast<int>(n->asIntIn(1, 64));
    if (auto n = node.optional("frame_timeout_s")) plc.frameTimeout = seconds(*n, 0.01, 10.0);
    if (auto n = node.optional("idle_timeout_s")) plc.idleTimeout = seconds(*n, 1.0, 86400.0);
    if (auto n = node.optional("yield_after_s")) plc.yieldAfter = seconds(*n, 0.1, 3600.0);
    // docs/contracts.md §6: HEARTBEAT increments at least once a second.
    if (auto n = node.optional("heartbeat_period_s")) plc.heartbeatPeriod = seconds(*n, 0.05, 1.0);
}

void parseResults(const ConfigNode& node, const fs::path& base, ResultsConfig& results)
{
    node.allowOnlyKeys({"database", "images", "save_failed_images", "archive_all", "retention", "audit"});
    results.database = resolve(node["database"], base);
    if (auto n = node.optional("audit")) results.audit = resolve(*n, base);
    results.imageDir = resolve(node["images"], base);
    if (auto n = node.optional("save_failed_images")) results.saveFailedImages = n->asBool();
    if (auto n = node.optional("archive_all")) results.archiveAll = n->asBool();
    if (auto r = node.optional("retention")) {
        r->allowOnlyKeys({"max_count", "max_age_days", "max_bytes", "keep_failed", "min_free_mb"});
        if (auto n = r->optional("keep_failed"))
            results.retention.keepFailed = static_cast<std::size_t>(n->asIntIn(0, 100'000));
        if (auto n = r->optional("max_count"))
            results.retention.maxCount = static_cast<std::size_t>(n->asIntIn(0, 100'000'000));
        if (auto n = r->optional("max_age_days"))
            results.retention.maxAge = std::chrono::hours(std::llround(n->asDoubleIn(0.0, 36500.0) * 24.0));
        if (auto n = r->optional("max_bytes"))
            results.retention.maxBytes = static_cast<std::uint64_t>(n->asDoubleIn(0.0, 1e15));
        if (auto n = r->optional("min_free_mb"))
            results.retention.minFreeBytes = static_cast<std::uint64_t>(n->asDoubleIn(0.0, 1e9) * 1024.0 * 1024.0);
    }
}

/// A maintenance password hash from $CREDENTIALS_DIRECTORY/<name> (systemd's
/// LoadCredential=, docs/hmi.md "Security"): only the daemon reads it there.
std::string credentialHash(const ConfigNode& node)
{
    const char* dir = std::getenv("CREDENTIALS_DIRECTORY");
    if (!dir) node.fail("$CREDENTIALS_DIRECTORY is not set (the unit's LoadCredential= provides it)");
    const auto file = fs::path(dir) / node.asString();
    std::ifstream in(file);
    std::string hash;
    if (!in || !std::getline(in, hash)) node.fail("cannot read the credential " + file.string());
    return hash;
}

void parseHmi(const ConfigNode& node, const fs::path& base, HmiConfig& http)
{
    node.allowOnlyKeys({"bind", "port", "assets", "javascript", "password_hash", "password_hash_credential",
                        "max_request_bytes", "requests_per_s", "burst", "threads", "session_idle_s", "allowed_hosts",
                        "request_timeout_s", "max_pending_requests", "users_file"});
    http.enabled = true;
    if (auto n = node.optional("users_file")) http.usersFile = resolve(*n, base);
    if (auto n = node.optional("bind")) {
        http.bindAddress = n->asString();
        in_addr tmp{};
        if (inet_pton(AF_INET, http.bindAddress.c_str(), &tmp) != 1)
            n->fail("expected an IPv4 address such as 127.0.0.1 (read-only pages for everyone who reaches it)");
    }
    if (auto n = node.optional("port")) http.port = static_cast<int>(n->asIntIn(0, 65535));
    if (auto n = node.optional("assets")) http.assets = resolve(*n, base);
    if (auto n = node.optional("javascript")) http.javascript = resolve(*n, base);
    if (node.has("password_hash") && node.has("password_hash_credential"))
        node["password_hash_credential"].fail("give password_hash or password_hash_credential, not both");
    if (auto n = node.optional("password_hash")) http.passwordHash = n->asString();
    if (auto n = node.optional("password_hash_credential")) http.passwordHash = credentialHash(*n);
    if (!http.passwordHash.empty() && !hg::daemon::validPasswordHash(http.passwordHash))
        node.fail("the maintenance password hash is not a crypt(3) hash ($y$..., $6$..., $5$...): make one with "
                  "`mkpasswd -m yescrypt` or `openssl passwd -6`");
    if (auto n = node.optional("max_request_bytes"))
        http.maxRequestBytes = static_cast<std::size_t>(n->asIntIn(1024, 16 << 20));
    if (auto n = node.optional("requests_per_s")) http.requestsPerSecond = n->asDoubleIn(1.0, 100000.0);
    if (auto n = node.optional("burst")) http.burst = static_cast<int>(n->asIntIn(1, 100000));
    if (auto n = node.optional("threads")) http.threads = static_cast<int>(n->asIntIn(1, 64));
    if (auto n = node.optional("session_idle_s"))
        http.sessionIdle = std::chrono::seconds(n->asIntIn(60, 7 * 24 * 3600));
    if (auto n = node.optional("request_timeout_s")) http.requestTimeout = seconds(*n, 0.5, 60.0);
    if (auto n = node.optional("max_pending_requests"))
        http.maxPendingRequests = static_cast<std::size_t>(n->asIntIn(4, 4096));
    if (auto n = node.optional("allowed_hosts")) {
        for (const ConfigNode& item : n->items()) {
            std::string name = item.asString();
            std::transform(name.begin(), name.end(), name.begin(),
                           [](unsigned char c) { return char(std::tolower(c)); });
            if (name.empty() || name.find_first_of(" /") != std::string::npos || name.find("://") != std::string::npos)
                item.fail("expected a host name or address without scheme or port, such as line-7.plant.example");
            http.allowedHosts.push_back(std::move(name));
        }
    }
}

void parseSequencer(const ConfigNode& node, SequencerConfig& seq)
{
    node.allowOnlyKeys({"move_timeout_s", "grab_timeout_s", "settle_s", "retries", "shutdown_grace_s"});
    if (auto n = node.optional("move_timeout_s")) seq.moveTimeout = seconds(*n, 0.01, 600.0);
    if (auto n = node.optional("grab_timeout_s")) seq.grabTimeout = seconds(*n, 0.01, 60.0);
    if (auto n = node.optional("settle_s")) seq.settle = seconds(*n, 0.0, 10.0);
    if (auto n = node.optional("retries")) seq.retries = static_cast<int>(n->asIntIn(0, 5));
    if (auto n = node.optional("shutdown_grace_s")) seq.shutdownGrace = seconds(*n, 0.0, 60.0);
}

PartProgramRef parseProgram(const std::string& key, const ConfigNode& node, const fs::path& base,
                            const geometry::Station& station)
{
    PartProgramRef ref;
    long long number = -1;
    try {
        std::size_t used = 0;
        number = std::stoll(key, &used);
        if (used != key.size()) number = -1;
    } catch (const std::exception&) {
        number = -1;
    }
    // 0 is PART_PROGRAM's "none"; the register holds 16 bits.
    if (number < 1 || number > 65535) node.fail("part program numbers are integers 1..65535, not '" + key + "'");
    ref.number = static_cast<std::uint16_t>(number);
    node.allowOnlyKeys({"part", "views", "force"});
    ref.partFile = existingFile(node["part"], base);
    ref.partSha256 = sha256OfFile(ref.partFile);
    {
        // The part program's own loader checks it in full when the program is loaded;
        // here it must at least be a YAML map that names its part and landmarks.
        auto part = ConfigNode::loadFile(ref.partFile);
        if (!part.isMap()) part.fail("a part program is a YAML map (docs/contracts.md §1)");
        (void)part["part"].asString();
        if (!part["landmarks"].isSequence() || part["landmarks"].size() == 0)
            part["landmarks"].fail("expected a non-empty list of landmarks");
    }
    ref.viewsFile = existingFile(node["views"], base);
    ref.views = geometry::loadPoses(ref.viewsFile, &station.fixture);
    if (ref.views.empty()) throw InputError(ref.viewsFile.string(), "views", "a view plan needs at least one pose");
    if (auto f = node.optional("force")) ref.force = f->asBool();
    return ref;
}

void parseWorkbench(const ConfigNode& node, const fs::path& base, WorkbenchConfig& workbench, WorkspaceUse workspace)
{
    node.allowOnlyKeys({"folder", "cli", "max_upload_bytes", "max_jobs"});
    workbench.folder = resolve(node["folder"], base);
    if (auto n = node.optional("cli")) workbench.cli = existingFile(*n, base);
    if (auto n = node.optional("max_upload_bytes"))
        workbench.maxUploadBytes = static_cast<std::size_t>(n->asIntIn(1024, std::int64_t{1} << 30));
    if (auto n = node.optional("max_jobs")) workbench.maxJobs = static_cast<int>(n->asIntIn(1, 4));
    if (workspace == WorkspaceUse::LeaveBe) return;
    std::error_code ec;
    fs::create_directories(workbench.folder, ec);
    if (ec || !fs::is_directory(workbench.folder))
        node["folder"].fail("cannot create the workspace " + workbench.folder.string() + ": " + ec.message());
}

/// The released parts of the workspace as programs (docs/workbench.md,
/// "Released parts on the station"); a number the `programs:` table holds too is refused naming both.
void addWorkbenchPrograms(const ConfigNode& node, DaemonConfig& cfg)
{
    const workbench::Workspace workspace(cfg.workbench.folder);
    for (const auto& part : workspace.list()) {
        if (!part.record.plcProgram || !part.releasedVersion) continue;
        const auto number = static_cast<std::uint16_t>(*part.record.plcProgram);
        const fs::path folder = workspace.partFolder(part.record.part);
        if (auto it = cfg.programs.find(number); it != cfg.programs.end())
            node.fail("the workspace's part '" + part.record.part + "' is released as program " +
                      std::to_string(number) + ", which is " +
                      (it->second.workbenchPart.empty() ? it->second.partFile.string()
                                                        : "the workspace's part '" + it->second.workbenchPart + "'") +
                      " too");
        PartProgramRef ref;
        ref.number = number;
        ref.workbenchPart = part.record.part;
        ref.partFile = folder / (part.record.part + ".yaml");
        ref.partSha256 = sha256OfFile(ref.partFile);
        ref.viewsFile = folder / (part.record.part + "-views.yaml");
        ref.views = geometry::loadPoses(ref.viewsFile, &cfg.station.fixture);
        ref.simulatedNominal = folder / part.record.cad;
        cfg.programs.emplace(number, std::move(ref));
    }
}

} // namespace

bool Ipv4Network::contains(std::uint32_t hostOrderAddress) const
{
    if (prefix == 0) return true;
    std::uint32_t mask = prefix == 32 ? 0xFFFFFFFFu : ~((1u << (32 - prefix)) - 1u);
    return (hostOrderAddress & mask) == (address & mask);
}

std::optional<Ipv4Network> parseIpv4Network(const std::string& text)
{
    Ipv4Network net;
    auto slash = text.find('/');
    auto addressText = text.substr(0, slash);
    in_addr a{};
    if (inet_pton(AF_INET, addressText.c_str(), &a) != 1) return std::nullopt;
    net.address = ntohl(a.s_addr);
    if (slash != std::string::npos) {
        auto prefixText = text.substr(slash + 1);
        if (prefixText.empty() || prefixText.size() > 2 ||
            prefixText.find_first_not_of("0123456789") != std::string::npos)
            return std::nullopt;
        net.prefix = std::stoi(prefixText);
        if (net.prefix > 32) return std::nullopt;
    }
    return net;
}

namespace {

// `simulation.seating`: the play of the simulated nest (docs/daemon.md, "Seating").
DaemonConfig::Seating parseSeating(const ConfigNode& node)
{
    if (!node.isMap()) node.fail("expected {shift_mm: N, rotation_deg: N, seed: N}");
    node.allowOnlyKeys({"shift_mm", "rotation_deg", "seed"});
    DaemonConfig::Seating s;
    // Beyond a few millimetres or degrees the part is not in the nest at all.
    s.shiftMm = node["shift_mm"].asDoubleIn(0.0, 10.0);
    s.rotationDeg = node["rotation_deg"].asDoubleIn(0.0, 10.0);
    if (auto seed = node.optional("seed")) s.seed = static_cast<std::uint64_t>(seed->asIntIn(0, 1LL << 62));
    return s;
}

// `mastering`: the correction set of each program, when its folder holds one
// (docs/mastering.md, "In the daemon"). A file that is not a correction set,
// or is another program's, is refused here as any bad file of the
// configuration is; a set for another version or material of the right
// program is not bad input but an outdated one, found where the program is
// loaded (engine_inspector.cpp).
// `mastering.due`: when the master must be measured again (docs/mastering.md,
// "Re-mastering due"); a cause left out is off, the switches default on.
MasteringDuePolicy parseMasteringDue(const ConfigNode& node)
{
    if (!node.isMap())
        node.fail("expected a map of max_age_h, max_parts, on_calibration_change, "
                  "on_program_change, grace_cycles");
    node.allowOnlyKeys({"max_age_h", "max_parts", "on_calibration_change", "on_program_change", "grace_cycles"});
    MasteringDuePolicy policy;
    // A year bounds the age: a longer one is a typo of the unit, not a mastering interval.
    if (auto h = node.optional("max_age_h"))
        policy.maxAge = std::chrono::milliseconds(std::llround(h->asDoubleIn(0.001, 24.0 * 366) * 3'600'000.0));
    if (auto n = node.optional("max_parts")) policy.maxParts = static_cast<std::uint64_t>(n->asIntIn(1, 1LL << 40));
    if (auto b = node.optional("on_calibration_change")) policy.onCalibrationChange = b->asBool();
    if (auto b = node.optional("on_program_change")) policy.onProgramChange = b->asBool();
    if (auto n = node.optional("grace_cycles"))
        policy.graceCycles = static_cast<std::uint64_t>(n->asIntIn(0, 1'000'000));
    return policy;
}

void parseMastering(const ConfigNode& node, const fs::path& base, DaemonConfig& cfg)
{
    node.allowOnlyKeys({"folder", "due"});
    if (auto due = node.optional("due")) cfg.mastering.due = parseMasteringDue(*due);
    cfg.mastering.folder = resolve(node["folder"], base);
    if (!fs::is_directory(cfg.mastering.folder)) node["folder"].fail("not a folder: " + cfg.mastering.folder.string());
    for (auto& [number, ref] : cfg.programs) {
        const fs::path file = cfg.mastering.folder / ("program-" + std::to_string(number) + ".json");
        if (!fs::exists(file)) continue;
        const inspect::CorrectionSet set = inspect::loadCorrectionSet(file);
        if (set.program != number)
            throw InputError(file.string(), "program",
                             "the correction set of program " + std::to_string(set.program) +
                                 ", in the file of program " + std::to_string(number));
        ref.correctionFile = file;
        ref.correctionSha256 = sha256OfFile(file);
        ref.correctionId = set.id;
        ref.correctionCreatedUnixMs = set.createdUnixMs;
        ref.correctionProgramVersion = set.programVersion;
        ref.correctionTemperatureC = set.temperatureC;
    }
}

// `health` (docs/health.md, "In the daemon"): the limits of the figures and
// the flat-field reference. A reference file that is there must be one, of
// this station's sensor; a missing one is no error — the station is watched
// without it until the maintenance action `flat-field` takes it.
void parseHealth(const ConfigNode& node, DaemonConfig& cfg)
{
    if (!node.isMap()) node.fail("expected a map of enabled, reference, limits");
    node.allowOnlyKeys({"enabled", "reference", "limits"});
    auto& health = cfg.health;
    if (auto n = node.optional("enabled")) health.enabled = n->asBool();
    if (auto n = node.optional("reference")) health.reference = resolve(*n, cfg.file.parent_path());
    if (auto limits = node.optional("limits")) {
        if (!limits->isMap())
            limits->fail("expected a map of min_backlight, max_uniformity, max_dust_specks, max_edge_width_px, "
                         "min_contrast, max_noise, max_edge_bias_px, max_capability");
        limits->allowOnlyKeys({"min_backlight", "max_uniformity", "max_dust_specks", "max_edge_width_px",
                               "min_contrast", "max_noise", "max_edge_bias_px", "max_capability"});
        auto& l = health.limits;
        if (auto n = limits->optional("min_backlight")) l.minBacklight = n->asDoubleIn(0.0, 1.0);
        if (auto n = limits->optional("max_uniformity")) l.maxUniformity = n->asDoubleIn(0.0, 1.0);
        if (auto n = limits->optional("max_dust_specks")) l.maxDustSpecks = n->asDoubleIn(0.0, 1e6);
        if (auto n = limits->optional("max_edge_width_px")) l.maxEdgeWidthPx = n->asDoubleIn(0.1, 100.0);
        if (auto n = limits->optional("min_contrast")) l.minContrast = n->asDoubleIn(0.0, 1.0);
        if (auto n = limits->optional("max_noise")) l.maxNoise = n->asDoubleIn(0.0, 1.0);
        if (auto n = limits->optional("max_edge_bias_px")) l.maxEdgeBiasPx = n->asDoubleIn(0.01, 10.0);
        if (auto n = limits->optional("max_capability")) l.maxCapability = n->asDoubleIn(0.1, 10.0);
    }
}

/// The reference file the configuration names, read when it is there (InputError naming it when it is
/// not a flat-field reference or covers another sensor than the station's camera).
void readHealthReference(DaemonConfig& cfg)
{
    auto& health = cfg.health;
    if (health.reference.empty()) health.reference = cfg.stationFile.parent_path() / "flat-field.json";
    if (!health.enabled || !fs::exists(health.reference)) return;
    vision::FlatField reference = calib::readFlatField(health.reference);
    const cv::Size sensor = cfg.station.camera.imageSize;
    if (reference.sensor != sensor)
        throw InputError(health.reference.string(), "sensor",
                         "the reference covers " + std::to_string(reference.sensor.width) + " x " +
                             std::to_string(reference.sensor.height) + " px, the station's camera " +
                             std::to_string(sensor.width) + " x " + std::to_string(sensor.height) +
                             ": take the reference again (hullgauge ctl flat-field)");
    health.referenceSha256 = sha256OfFile(health.reference);
    health.referenceRead = std::move(reference);
}

// `temperature`: the part's temperature input (docs/mastering.md, "Temperature").
// The sensor file need not exist yet (a script may write it after the start);
// a folder that does not is a typo. Its step of re-mastering belongs to the
// rules of `mastering.due`, without which nothing is ever due.
void parseTemperature(const ConfigNode& node, const fs::path& base, DaemonConfig& cfg)
{
    if (!node.isMap()) node.fail("expected a map of source, file, scale, sigma_c, max_age_s, mastering_step_c");
    node.allowOnlyKeys({"source", "file", "scale", "sigma_c", "max_age_s", "mastering_step_c"});
    TemperatureConfig t;
    t.source = node["source"].asEnum<TemperatureSource>("temperature source");
    if (t.source == TemperatureSource::File) {
        t.file = resolve(node["file"], base);
        if (!fs::is_directory(t.file.parent_path()))
            node["file"].fail("its folder does not exist: " + t.file.parent_path().string());
        if (auto n = node.optional("scale")) t.scale = n->asDoubleIn(1e-6, 1e3);
        if (auto n = node.optional("max_age_s")) t.maxAge = seconds(*n, 0.1, 86400.0);
    } else {
        for (const char* key : {"file", "scale", "max_age_s"})
            if (auto n = node.optional(key)) n->fail("only with source: file (the PLC writes PART_TEMPERATURE)");
    }
    if (auto n = node.optional("sigma_c")) t.sigmaC = n->asDoubleIn(0.0, 10.0);
    if (auto n = node.optional("mastering_step_c")) {
        if (!cfg.mastering.due)
            n->fail("re-mastering due is off: it needs mastering.due (docs/mastering.md, \"Re-mastering due\")");
        cfg.mastering.due->maxTemperatureStepC = n->asDoubleIn(0.01, 100.0);
    }
    cfg.temperature = std::move(t);
}

} // namespace

DaemonConfig loadDaemonConfig(const std::filesystem::path& file, WorkspaceUse workspace)
{
    auto root = ConfigNode::loadFile(file);
    if (!root.isMap()) root.fail("expected a map of sections (station, programs, plc, results, ...)");
    root.allowOnlyKeys({"station", "lamps_section", "programs", "plc", "results", "sequencer", "maintenance", "http",
                        "mqtt", "watchdog", "simulation", "workbench", "shifts", "mastering", "temperature", "health"});
    DaemonConfig cfg;
    cfg.file = fs::absolute(file).lexically_normal();
    const auto base = cfg.file.parent_path();

    cfg.stationFile = existingFile(root["station"], base);
    cfg.station = geometry::loadStation(cfg.stationFile);
    cfg.segmentation = vision::stationSegmentation(cfg.station);
    if (cfg.station.document)
        if (auto n = (*cfg.station.document)["camera"].optional("regions")) cfg.cameraRegions = n->asBool();
    if (auto n = root.optional("lamps_section")) {
        cfg.lampsSection = n->asString();
        if (cfg.station.document && !cfg.station.document->has(cfg.lampsSection))
            n->fail("the station file " + cfg.stationFile.string() + " has no section '" + cfg.lampsSection + "'");
    }

    auto programs = root["programs"];
    if (!programs.isMap() || programs.keys().empty())
        programs.fail("expected a map of part program numbers to {part: FILE, views: FILE}");
    for (const auto& key : programs.keys()) {
        auto ref = parseProgram(key, programs[key], base, cfg.station);
        if (cfg.programs.contains(ref.number)) programs[key].fail("part program number given twice");
        cfg.programs.emplace(ref.number, std::move(ref));
    }

    if (auto n = root.optional("plc")) parsePlc(*n, cfg.plc);
    parseResults(root["results"], base, cfg.results);
    if (auto n = root.optional("sequencer")) parseSequencer(*n, cfg.sequencer);
    if (auto n = root.optional("maintenance")) {
        n->allowOnlyKeys({"socket", "group"});
        if (auto s = n->optional("socket")) {
            cfg.maintenance.socket = resolve(*s, base);
            // sockaddr_un::sun_path holds 108 bytes including the terminating NUL.
            if (cfg.maintenance.socket.string().size() > 107) s->fail("socket path longer than 107 bytes");
        }
        if (auto g = n->optional("group")) cfg.maintenance.group = g->asString();
    }
    if (auto n = root.optional("http")) parseHmi(*n, base, cfg.http);
    if (auto n = root.optional("workbench")) {
        parseWorkbench(*n, base, cfg.workbench, workspace);
        if (workspace == WorkspaceUse::Open) addWorkbenchPrograms(*n, cfg);
    }
    if (auto n = root.optional("mqtt")) parseMqtt(*n, base, cfg.mqtt);
    if (auto n = root.optional("watchdog")) {
        n->allowOnlyKeys({"max_cycle_s"});
        if (auto m = n->optional("max_cycle_s")) cfg.watchdog.maxCycle = seconds(*m, 1.0, 3600.0);
    }
    if (auto n = root.optional("shifts")) cfg.shifts = parseShifts(*n);
    // After `programs` and `workbench`: every program may have its set.
    if (auto n = root.optional("mastering")) parseMastering(*n, base, cfg);
    // After `mastering`: its step joins the rules of `mastering.due`.
    if (auto n = root.optional("temperature")) parseTemperature(*n, base, cfg);
    if (auto n = root.optional("health")) parseHealth(*n, cfg);
    readHealthReference(cfg);
    if (auto n = root.optional("simulation")) {
        n->allowOnlyKeys({"parts", "seating"});
        auto parts = (*n)["parts"];
        if (!parts.isMap()) parts.fail("expected a map of part names to mesh files (nominal and defect variants)");
        for (const auto& name : parts.keys()) {
            // `sim-part none` shows the empty fixture (docs/camera.md, "The empty fixture").
            if (name == drivers::kEmptyFixture)
                parts[name].fail("'none' names the empty fixture (sim-part none): give the part another name");
            cfg.simulatedParts.emplace_back(name, existingFile(parts[name], base));
        }
        if (parts.keys().empty() || !parts.has("nominal")) parts.fail("the simulated parts must include 'nominal'");
        if (auto s = n->optional("seating")) cfg.simulatedSeating = parseSeating(*s);
    }
    return cfg;
}

// The names a browser on the line reaches the station by. Bound to one
// address, that address and the loopback names; bound to all of them, also
// the PC's host name and every address of its interfaces, so the default
// serves the plant network and still refuses a name that is none of the
// station's (DNS rebinding, docs/hmi.md "Bounded").
fs::path auditFile(const DaemonConfig& config)
{
    return config.results.audit.empty() ? config.results.database.parent_path() / "audit.sqlite" : config.results.audit;
}

fs::path usersFile(const DaemonConfig& config)
{
    return config.http.usersFile.empty() ? config.results.database.parent_path() / "users.yaml" : config.http.usersFile;
}

std::vector<std::string> allowedHostsFor(const HmiConfig& http)
{
    if (!http.allowedHosts.empty()) return http.allowedHosts;
    std::vector<std::string> names{"localhost", "127.0.0.1", "::1"};
    const auto add = [&](std::string name) {
        std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        if (!name.empty() && std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    };
    add(http.bindAddress);
    if (http.bindAddress != "0.0.0.0") return names;
    char host[256] = {};
    if (::gethostname(host, sizeof host - 1) == 0) add(host);
    ifaddrs* list = nullptr;
    if (::getifaddrs(&list) != 0) return names;
    for (const ifaddrs* i = list; i; i = i->ifa_next) {
        if (!i->ifa_addr || (i->ifa_addr->sa_family != AF_INET && i->ifa_addr->sa_family != AF_INET6)) continue;
        char text[INET6_ADDRSTRLEN] = {};
        const void* addr =
            i->ifa_addr->sa_family == AF_INET
                ? static_cast<const void*>(&reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr)
                : static_cast<const void*>(&reinterpret_cast<const sockaddr_in6*>(i->ifa_addr)->sin6_addr);
        if (::inet_ntop(i->ifa_addr->sa_family, addr, text, sizeof text)) add(text);
    }
    ::freeifaddrs(list);
    return names;
}

} // namespace hg::station

fmt::format_context::iterator fmt::formatter<hg::station::Ipv4Network>::format(const hg::station::Ipv4Network& network,
                                                                               fmt::format_context& ctx) const
{
    in_addr a{htonl(network.address)};
    char buf[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &a, buf, sizeof buf);
    return fmt::format_to(ctx.out(), "{}/{}", buf, network.prefix);
}
