#include "maintenance.h"

#include "cycle/cycle_runner.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/store/audit_log.h"
#include "hullgauge/store/result_store.h"
#include "mastering_run.h"
#include "plant/plc_server.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <grp.h>
#include <map>
#include <spdlog/fmt/fmt.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

namespace hg::daemon {

namespace {

/// `unix:<user>` of the process at the other end of `fd` (SO_PEERCRED), `unix:uid <n>` without a name.
std::string peerName(int fd)
{
    ucred cred{};
    socklen_t size = sizeof cred;
    if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &size) != 0) return "unix:?";
    return store::unixUserName(cred.uid);
}

} // namespace

MaintenanceServer::MaintenanceServer(std::filesystem::path path, const std::string& group, Handler handler,
                                     Clock& clock)
    : path_(std::move(path)), handler_(std::move(handler)), clock_(clock)
{
    auto fail = [&](const std::string& what) {
        std::string why = std::strerror(errno);
        if (fd_ >= 0) close(fd_);
        fd_ = -1;
        throw FaultError("maintenance socket " + path_.string() + ": " + what + ": " + why);
    };
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path_.string().size() >= sizeof addr.sun_path) {
        errno = ENAMETOOLONG;
        fail("path too long");
    }
    std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
    std::error_code ec;
    std::filesystem::create_directories(path_.parent_path(), ec);
    // A socket left by a daemon that was killed: nobody listens on it any more.
    if (std::filesystem::is_socket(path_, ec)) std::filesystem::remove(path_, ec);
    fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd_ < 0) fail("socket");
    // Create it with 0660 directly (no window in which others could connect).
    mode_t old = umask(0117);
    int rc = bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    umask(old);
    if (rc != 0) fail("bind");
    if (!group.empty()) {
        struct group* entry = getgrnam(group.c_str());
        if (!entry) {
            errno = ENOENT;
            fail("unknown group '" + group + "'");
        }
        if (chown(path_.c_str(), static_cast<uid_t>(-1), entry->gr_gid) != 0) fail("chown to group " + group);
    }
    if (listen(fd_, 8) != 0) fail("listen");
    hg::log::category("daemon")->info("maintenance socket {}", path_.string());
}

MaintenanceServer::~MaintenanceServer()
{
    if (fd_ >= 0) {
        close(fd_);
        std::error_code ec;
        std::filesystem::remove(path_, ec);
    }
}

std::vector<pollfd> MaintenanceServer::pollFds() const
{
    std::vector<pollfd> fds{{fd_, POLLIN, 0}};
    for (const auto& c : clients_) fds.push_back({c.fd, POLLIN, 0});
    return fds;
}

void MaintenanceServer::serve(const std::vector<pollfd>& polled)
{
    // The clients polled are the first polled.size() - 1 of clients_, in order.
    std::vector<bool> done(clients_.size(), false);
    for (std::size_t i = 1; i < polled.size() && i - 1 < clients_.size(); ++i)
        if (polled[i].revents & (POLLIN | POLLHUP | POLLERR)) done[i - 1] = readFrom(clients_[i - 1]);
    const auto now = clock_.now();
    for (std::size_t i = clients_.size(); i-- > 0;) {
        if (!done[i] && now - clients_[i].since < kRequestTimeout) continue;
        if (!done[i] && !clients_[i].request.empty()) refuseUnfinished(clients_[i]);
        close(clients_[i].fd);
        clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(i));
    }
    if (!polled.empty() && (polled[0].revents & POLLIN)) acceptAll();
}

void MaintenanceServer::acceptAll()
{
    for (;;) {
        int fd = accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
        if (fd < 0) return;
        if (clients_.size() >= kMaxClients) {
            // The longest-waiting client yields: the newest is the likeliest to send.
            close(clients_.front().fd);
            clients_.erase(clients_.begin());
        }
        clients_.push_back({fd, clock_.now(), {}, peerName(fd)});
    }
}

bool MaintenanceServer::readFrom(Client& client)
{
    char buf[4096];
    ssize_t n = read(client.fd, buf, sizeof buf);
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return false;
    if (n < 0) return true; // gone before sending a whole line
    if (n == 0) {
        // The client closed its side after its request: the end of the stream ends the line.
        if (client.request.empty()) return true;
        client.request.push_back('\n');
        answer(client);
        return true;
    }
    client.request.append(buf, static_cast<std::size_t>(n));
    const bool complete = client.request.find('\n') != std::string::npos;
    if (!complete && client.request.size() < kMaxRequestBytes) return false;
    answer(client);
    return true;
}

std::string answerMaintenanceRequest(const std::string& request, const MaintenanceServer::Handler& handler,
                                     const std::string& peer)
{
    nlohmann::json answer;
    const auto end = request.find('\n');
    try {
        if (end == std::string::npos) throw InputError("request", "line", "longer than 64 KiB without a newline");
        auto parsed = parseJson(request.substr(0, end), "request");
        if (!parsed.is_object() || !parsed.contains("command"))
            throw InputError("request", "command", "expected one JSON object with a \"command\" on one line");
        // Who asked is what the kernel says, never what the request claims (docs/audit.md).
        parsed.erase("caller");
        if (!peer.empty()) parsed["caller"] = {{"who", peer}, {"source", "socket"}};
        answer = handler(parsed);
    } catch (const std::exception& e) {
        answer = {{"ok", false}, {"error", e.what()}};
    }
    // An error may quote the request's own bytes (a JSON syntax error shows what
    // it read), which need not be UTF-8; the answer is always valid JSON, so such
    // bytes are sent as U+FFFD rather than failing the dump (docs/daemon.md,
    // "Maintenance socket").
    return dumpJson(answer) + "\n";
}

// A request begun and not ended by a newline within the time allowed is told so, not just closed.
void MaintenanceServer::refuseUnfinished(const Client& client)
{
    const std::string text =
        dumpJson({{"ok", false},
                  {"error", fmt::format("request: no newline within {} ms (a request is one JSON line ending in a "
                                        "newline, or the client closes its side after it)",
                                        kRequestTimeout.count())}}) +
        "\n";
    [[maybe_unused]] auto n = send(client.fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

void MaintenanceServer::answer(const Client& client)
{
    const std::string text = answerMaintenanceRequest(client.request, handler_, client.peer);
    // The answer is small (a status or a page of results); a client that does
    // not read it gets one second before it is dropped.
    timeval tv{1, 0};
    setsockopt(client.fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    int flags = fcntl(client.fd, F_GETFL);
    fcntl(client.fd, F_SETFL, flags & ~O_NONBLOCK);
    std::size_t sent = 0;
    while (sent < text.size()) {
        ssize_t n = write(client.fd, text.data() + sent, text.size() - sent);
        if (n <= 0) break;
        sent += static_cast<std::size_t>(n);
    }
}

} // namespace hg::daemon

namespace hg::daemon {
namespace {

using nlohmann::json;

// The PLC's counters (docs/plc.md), from the same snapshot as the other registers.
json plcCounters(std::span<const std::uint16_t> regs)
{
    const auto n = station::readCounters(regs);
    return {{"triggers", n.triggers},
            {"passes", n.passes},
            {"fails", n.fails},
            {"faults", n.faults},
            {"missed_triggers", n.missed}};
}

// The correction sets the running configuration names and the last mastering run (docs/mastering.md,
// "In the daemon" and "The mastering run").
json masteringStatus(const station::DaemonConfig& cfg, const MasteringRun* run)
{
    json sets = json::object();
    for (const auto& [number, ref] : cfg.programs)
        if (!ref.correctionId.empty()) sets[std::to_string(number)] = ref.correctionId;
    return {{"folder", cfg.mastering.folder.empty() ? json() : json(cfg.mastering.folder.string())},
            {"sets", sets},
            {"run", run ? run->status() : json()}};
}

json status(const MaintenanceContext& c, const json&)
{
    const auto regs = c.registers.snapshot();
    const auto counters = c.plc.counters();
    return {{"ok", true},
            {"pid", getpid()},
            {"config", c.config->file.string()},
            {"sequencer", c.runner.describe()},
            {"plc",
             {{"port", c.plc.port()},
              {"status", regs[station::reg::Status]},
              {"ack_seq", regs[station::reg::AckSeq]},
              {"done_seq", regs[station::reg::DoneSeq]},
              {"result", regs[station::reg::Result]},
              {"fault_code", regs[station::reg::FaultCode]},
              {"heartbeat", regs[station::reg::Heartbeat]},
              {"rejected_triggers", regs[station::reg::RejectedTriggers]},
              {"acq_done_seq", regs[station::reg::AcqDoneSeq]},
              {"result_seq", regs[station::reg::ResultSeq]},
              {"active_program", regs[station::reg::ActiveProgram]},
              {"program_state",
               std::string(enumName(static_cast<station::ProgramState>(regs[station::reg::ProgramState])))},
              {"master_due", regs[station::reg::MasterDue]},
              {"master_grace_left", regs[station::reg::MasterGraceLeft]},
              {"health_warnings", regs[station::reg::HealthWarnings]},
              {"counters", plcCounters(regs)},
              {"clients", counters.clients},
              {"requests", counters.requests},
              {"exceptions", counters.exceptions},
              {"accepted_connections", counters.acceptedConnections},
              {"refused_connections", counters.refusedConnections},
              {"dropped_connections", counters.droppedConnections},
              {"idle_closed", counters.idleClosed},
              {"yielded", counters.yielded}}},
            {"results", {{"database", c.store.file().string()}, {"records", c.store.count()}}},
            {"http", c.hmiPort ? json{{"address", c.config->http.bindAddress}, {"port", c.hmiPort}} : json()},
            {"mqtt", c.mqttStatus ? c.mqttStatus() : json()},
            {"lamps", c.devices.lampStatus()},
            {"calibration", c.runner.calibration()},
            {"health", c.runner.health()},
            {"purpose", std::string(enumName(c.registers.purpose()))},
            {"program", c.runner.program()},
            {"mastering", masteringStatus(*c.config, c.mastering)},
            {"simulated_part", c.simulation ? c.simulation->part() : std::string()},
            {"simulated_optics", c.simulation ? c.simulation->optics() : json()}};
}

/// A whole-number field of a request within [lo, hi], `fallback` when it is
/// absent (docs/daemon.md, "Maintenance socket"): a fraction (1.9), a string, a
/// float written as 1e8 or a number out of range is refused naming the key,
/// never rounded, truncated or clamped into a different request.
Result<std::int64_t> wholeNumber(const json& request, const char* key, std::int64_t lo, std::int64_t hi,
                                 std::optional<std::int64_t> fallback)
{
    if (!request.contains(key)) {
        if (fallback) return *fallback;
        return Status::failure(StatusCode::NotAllowed, fmt::format("{}: missing (a whole number {}..{})", key, lo, hi));
    }
    const json& v = request[key];
    if (!v.is_number_integer())
        return Status::failure(StatusCode::NotAllowed,
                               fmt::format("{}: {} is not a whole number {}..{}", key, v.dump(), lo, hi));
    // Unsigned past int64's range stays out of range rather than wrapping negative.
    const bool huge = v.is_number_unsigned() && v.get<std::uint64_t>() > std::uint64_t(hi);
    const std::int64_t n = huge ? hi : v.get<std::int64_t>();
    if (huge || n < lo || n > hi)
        return Status::failure(StatusCode::NotAllowed, fmt::format("{}: {} is outside {}..{}", key, v.dump(), lo, hi));
    return n;
}

/// A text field of a request, `fallback` when absent; any other type is refused naming the key.
Result<std::string> textField(const json& request, const char* key, std::string fallback = {})
{
    if (!request.contains(key)) return fallback;
    const json& v = request[key];
    if (!v.is_string())
        return Status::failure(StatusCode::NotAllowed, fmt::format("{}: {} is not a string", key, v.dump()));
    return v.get<std::string>();
}

/// A true/false field of a request, false when absent; any other type is refused naming the key.
Result<bool> flagField(const json& request, const char* key)
{
    if (!request.contains(key)) return false;
    const json& v = request[key];
    if (!v.is_boolean())
        return Status::failure(StatusCode::NotAllowed, fmt::format("{}: {} is not true or false", key, v.dump()));
    return v.get<bool>();
}

json refusal(const Status& status)
{
    return {{"ok", false}, {"error", status.message()}};
}

json results(const MaintenanceContext& c, const json& request)
{
    const auto limit = wholeNumber(request, "limit", 1, 1000, 10);
    if (!limit) return refusal(limit.status());
    return {{"ok", true}, {"results", c.store.recent(static_cast<int>(limit.value()))}};
}

/// Why `serial` cannot be a manual cycle's serial; empty when it can. A manual serial fits the PLC's
/// SERIAL registers too: it names the part's record and its image folder, which a 300-character serial
/// once broke; a NUL is padding there, never part of a serial.
std::string serialProblem(const std::string& serial)
{
    if (serial.size() > station::kSerialChars)
        return fmt::format("serial: {} characters; a serial has at most {} (the PLC's SERIAL registers)", serial.size(),
                           station::kSerialChars);
    for (std::size_t i = 0; i < serial.size(); ++i)
        if (const auto byte = static_cast<unsigned char>(serial[i]); byte == 0 || !station::validSerialByte(byte))
            return fmt::format("serial: byte {} is 0x{:02x}; a serial is printable ASCII", i + 1, byte);
    return {};
}

json trigger(const MaintenanceContext& c, const json& request)
{
    const auto program = wholeNumber(request, "program", 1, 65535, std::nullopt);
    if (!program) return refusal(program.status());
    const auto named = textField(request, "serial");
    if (!named) return refusal(named.status());
    if (const auto problem = serialProblem(named.value()); !problem.empty()) return {{"ok", false}, {"error", problem}};
    const auto reason = c.registers.triggerManually(static_cast<std::uint16_t>(program.value()), named.value());
    if (reason == station::RejectReason::None) return {{"ok", true}};
    return {{"ok", false}, {"error", "trigger refused: " + triggerRefusal(reason)}};
}

// The purpose of the cycles triggered from now on (docs/study.md); the PLC's
// CYCLE_PURPOSE register is the same value, so the last writer wins. Without
// "purpose" the current one is answered.
json purpose(const MaintenanceContext& c, const json& request)
{
    if (request.contains("purpose")) {
        const auto& wanted = request["purpose"];
        const auto parsed =
            wanted.is_string() ? parseEnum<station::CyclePurpose>(wanted.get<std::string>()) : std::nullopt;
        if (!parsed)
            return {{"ok", false},
                    {"error", "purpose: " + wanted.dump() + " is not \"" +
                                  enumNameList<station::CyclePurpose>("\", \"", "\" or \"") + "\""}};
        c.registers.setPurpose(*parsed);
        hg::log::category("daemon")->info("cycle purpose {} (maintenance socket)", enumName(*parsed));
    }
    return {{"ok", true}, {"purpose", std::string(enumName(c.registers.purpose()))}};
}

json abortCycle(const MaintenanceContext& c, const json&)
{
    // An abort applies to the running cycle only (docs/plc.md).
    return {{"ok", true}, {"aborted", c.runner.abort()}};
}

/// The refusal of another maintenance job while the mastering run owns the station; null when none runs.
json refusedWhileMastering(const MaintenanceContext& c, const std::string& what)
{
    if (!c.mastering || !c.mastering->running()) return nullptr;
    return {{"ok", false}, {"error", what + ": a mastering run is running (cancel it with the command master)"}};
}

// The live fixture calibration (docs/calibration.md), run by the cycle runner
// between cycles. Bad input is answered at once.
json calibrate(const MaintenanceContext& c, const json& request)
{
    if (auto refused = refusedWhileMastering(c, "calibrate"); !refused.is_null()) return refused;
    const auto& config = *c.config;
    CalibrationJob job;
    const auto pattern = textField(request, "pattern");
    const auto poses = textField(request, "poses");
    const auto out = textField(request, "out", config.stationFile.string());
    if (!pattern) return refusal(pattern.status());
    if (!poses) return refusal(poses.status());
    if (!out) return refusal(out.status());
    try {
        job.target = calib::TargetSpec::parse(pattern.value(), "pattern");
        if (poses.value().empty()) return {{"ok", false}, {"error", "poses: the poses YAML file is required"}};
        job.poses = geometry::loadPoses(poses.value(), &config.station.fixture);
    } catch (const std::exception& e) {
        return {{"ok", false}, {"error", e.what()}};
    }
    if (config.station.fixture.type != geometry::FixtureType::RotationDeclination)
        return {{"ok", false}, {"error", "calibrate solves rotation/declination fixtures"}};
    job.out = out.value();
    if (const Status queued = c.runner.requestCalibration(std::move(job)); !queued.ok())
        return {{"ok", false}, {"error", queued.message()}};
    return {{"ok", true}, {"calibration", c.runner.calibration()}};
}

json calibration(const MaintenanceContext& c, const json&)
{
    return {{"ok", true}, {"calibration", c.runner.calibration()}};
}

// A camera frame on demand (docs/hmi.md, "Maintenance"): `rotation_deg` and
// `declination_deg` (or `rail_mm`) move the fixture there first; without them
// it stays put. The answer is the queued job's status; `snapshot` without
// `grab` only reads the last one.
json snapshot(const MaintenanceContext& c, const json& request)
{
    const auto grab = flagField(request, "grab");
    if (!grab) return refusal(grab.status().prefixed("snapshot: "));
    if (!grab.value()) return {{"ok", true}, {"snapshot", c.runner.snapshot().status()}};
    if (auto refused = refusedWhileMastering(c, "snapshot"); !refused.is_null()) return refused;
    SnapshotJob job;
    const auto& fixture = c.config->station.fixture;
    const bool rail = fixture.type == geometry::FixtureType::Rail;
    const std::vector<std::string> keys =
        rail ? std::vector<std::string>{"rail_mm"} : std::vector<std::string>{"rotation_deg", "declination_deg"};
    for (const auto& key : keys) {
        if (!request.contains(key)) continue;
        if (!request[key].is_number()) return {{"ok", false}, {"error", "snapshot: " + key + " is not a number"}};
        if (!job.pose) job.pose = geometry::FixturePose{};
        const double v = request[key].get<double>();
        (key == "rail_mm"        ? job.pose->railMm
         : key == "rotation_deg" ? job.pose->rotationDeg
                                 : job.pose->declinationDeg) = v;
    }
    if (job.pose && !fixture.reachable(*job.pose))
        return {{"ok", false},
                {"error", fmt::format("snapshot: {} is outside the fixture's ranges",
                                      geometry::PoseOn{*job.pose, fixture.type})}};
    if (const Status queued = c.runner.requestSnapshot(std::move(job)); !queued.ok())
        return {{"ok", false}, {"error", "snapshot: " + queued.message()}};
    return {{"ok", true}, {"snapshot", c.runner.snapshot().status()}};
}

// The flat-field reference (docs/health.md, "In the daemon"): `take` queues it
// (`frames` 1..64, default 8), grabbed by the runner between cycles; without
// `take` the last one's status is answered.
json flatField(const MaintenanceContext& c, const json& request)
{
    const auto take = flagField(request, "take");
    if (!take) return refusal(take.status().prefixed("flat-field: "));
    if (!take.value()) return {{"ok", true}, {"flat_field", c.runner.flatField()}};
    if (auto refused = refusedWhileMastering(c, "flat-field"); !refused.is_null()) return refused;
    const auto frames = wholeNumber(request, "frames", 1, 64, 8);
    if (!frames) return refusal(frames.status().prefixed("flat-field: "));
    if (const Status queued = c.runner.requestFlatField({static_cast<int>(frames.value())}); !queued.ok())
        return {{"ok", false}, {"error", "flat-field: " + queued.message()}};
    return {{"ok", true}, {"flat_field", c.runner.flatField()}};
}

/// Why no mastering run may start now (a cycle running, the station not ready, a calibration, snapshot or
/// flat-field reference queued or running); empty when it may (docs/mastering.md, "The mastering run").
std::string stationBusy(const MaintenanceContext& c)
{
    const auto state = c.runner.state();
    if (state != station::SequencerState::Ready && state != station::SequencerState::Done)
        return fmt::format("the station is {} (a cycle runs, or it is not ready): run the master once the line has "
                           "stopped and the station is ready",
                           enumName(state));
    const std::pair<const char*, json> jobs[] = {{"a calibration", c.runner.calibration()},
                                                 {"a camera snapshot", c.runner.snapshot().status()},
                                                 {"a flat-field reference", c.runner.flatField()}};
    for (const auto& [what, job] : jobs) {
        const auto jobState = job.is_object() ? job.value("state", std::string()) : std::string();
        if (jobState == "queued" || jobState == "running") return std::string(what) + " is " + jobState;
    }
    return {};
}

/// The run a `master` request asks for; a refusal naming the field otherwise.
Result<MasteringRequest> masteringRequest(const json& request)
{
    MasteringRequest r;
    const auto program = wholeNumber(request, "program", 1, 65535, std::nullopt);
    if (!program) return program.status().prefixed("master: ");
    const auto cycles = wholeNumber(request, "run", 2, 10000, std::nullopt);
    if (!cycles) return cycles.status().prefixed("master: ");
    const auto timeout = wholeNumber(request, "timeout_s", 1, 86400, 120);
    if (!timeout) return timeout.status().prefixed("master: ");
    const auto text = textField(request, "certificate");
    const auto name = textField(request, "certificate_file", "certificate");
    if (!text) return text.status().prefixed("master: ");
    if (!name) return name.status().prefixed("master: ");
    if (text.value().empty())
        return Status::failure(StatusCode::NotAllowed, "master: certificate: the master's certificate (YAML) is "
                                                       "required");
    if (request.contains("material")) {
        const auto material = textField(request, "material");
        if (!material) return material.status().prefixed("master: ");
        r.material = material.value();
    }
    try {
        r.master = study::parseMasterCertificate(text.value(), name.value());
    } catch (const std::exception& e) {
        return Status::failure(StatusCode::NotAllowed, std::string("master: ") + e.what());
    }
    if (const auto problem = serialProblem(r.master.serial); !problem.empty())
        return Status::failure(StatusCode::NotAllowed, "master: " + name.value() + ": the master's " + problem);
    r.program = static_cast<std::uint16_t>(program.value());
    r.cycles = static_cast<std::size_t>(cycles.value());
    r.timeout = std::chrono::seconds(timeout.value());
    const json caller = request.value("caller", json::object());
    r.who = caller.value("who", "unix:?");
    r.role = caller.value("role", "");
    r.source = caller.value("source", "socket");
    return r;
}

// The mastering run (docs/mastering.md, "The mastering run"): `run` N starts it, `cancel` ends it at
// its next wait; without either the last run's status is answered.
json master(const MaintenanceContext& c, const json& request)
{
    if (!c.mastering) return {{"ok", false}, {"error", "master: the mastering run is not offered here"}};
    const auto cancel = flagField(request, "cancel");
    if (!cancel) return refusal(cancel.status().prefixed("master: "));
    if (cancel.value()) {
        const auto by = request.value("caller", json::object()).value("who", std::string("unix:?"));
        const bool cancelled = c.mastering->cancel(by);
        return {{"ok", true}, {"cancelled", cancelled}, {"run", c.mastering->status()}};
    }
    if (!request.contains("run")) return {{"ok", true}, {"run", c.mastering->status()}};
    const auto wanted = masteringRequest(request);
    if (!wanted) return refusal(wanted.status());
    // A run already running is refused as such (start says so), not as the cycle it keeps busy.
    if (const auto busy = c.mastering->running() ? std::string() : stationBusy(c); !busy.empty())
        return {{"ok", false}, {"error", "master: " + busy}};
    if (const Status started = c.mastering->start(wanted.value()); !started.ok())
        return refusal(started.prefixed("master: "));
    return {{"ok", true}, {"run", c.mastering->status()}};
}

json simPart(const MaintenanceContext& c, const json& request)
{
    auto parts = c.simulation ? c.simulation->parts() : std::vector<std::string>{};
    if (parts.empty()) return {{"ok", false}, {"error", "the camera is not simulated"}};
    const auto list = flagField(request, "list");
    if (!list) return refusal(list.status());
    if (list.value()) return {{"ok", true}, {"parts", parts}, {"current", c.simulation->part()}};
    const auto named = textField(request, "name");
    if (!named) return refusal(named.status());
    const auto& name = named.value();
    if (!c.simulation->selectPart(name))
        return {{"ok", false}, {"error", "unknown simulated part '" + name + "' (see sim-part --list)"}};
    return {{"ok", true}, {"current", name}};
}

// The simulated camera's optics as they have aged (docs/camera.md, "Aging");
// `"reset": true` sets them back as configured, the cycle count at 0.
json simAge(const MaintenanceContext& c, const json& request)
{
    if (!c.simulation || c.simulation->optics().is_null())
        return {{"ok", false}, {"error", "the camera is not simulated"}};
    const auto reset = flagField(request, "reset");
    if (!reset) return refusal(reset.status());
    if (reset.value()) c.simulation->resetAging();
    return {{"ok", true}, {"optics", c.simulation->optics()}};
}

// As SIGHUP (docs/daemon.md, "Reload"): answered at once, applied when read and checked.
json reload(const MaintenanceContext& c, const json&)
{
    if (!c.requestReload) return {{"ok", false}, {"error", "reload is not offered here"}};
    c.requestReload();
    return {{"ok", true}, {"reloading", true}};
}

using Command = json (*)(const MaintenanceContext&, const json&);
const std::map<std::string, Command, std::less<>> kCommands{
    {"status", status},       {"results", results},         {"trigger", trigger},  {"abort", abortCycle},
    {"calibrate", calibrate}, {"calibration", calibration}, {"sim-part", simPart}, {"purpose", purpose},
    {"snapshot", snapshot},   {"reload", reload},           {"sim-age", simAge},   {"flat-field", flatField},
    {"master", master},
};

} // namespace

namespace {

/// The value a recorded command changes, read before and after it (empty: the command changes nothing here).
std::string changedValue(const MaintenanceContext& c, const std::string& command, const json& request)
{
    if (command == "purpose" && request.contains("purpose")) return std::string(enumName(c.registers.purpose()));
    if (command == "sim-part" && request.contains("name") && c.simulation) return "part: " + c.simulation->part();
    if (command == "sim-age" && request.value("reset", json()) == json(true) && c.simulation) {
        const json optics = c.simulation->optics();
        if (optics.is_null()) return {};
        return fmt::format("aging: {} cycles, {} steps", optics.value("cycles", 0), optics.value("aging_steps", 0));
    }
    return {};
}

// The changes among the commands go into the audit trail with who asked (docs/audit.md): a new cycle
// purpose, another simulated part, the simulated optics' aging reset, a calibration queued (its station
// file is recorded when the daemon loads it), a flat-field reference taken, a reload asked for. Questions
// (status, results, calibration, flat-field without `take`) and operations (trigger, abort, snapshot) are
// not changes.
void recordChange(const MaintenanceContext& c, const std::string& command, const json& request,
                  const std::string& before, const json& answer)
{
    static const std::map<std::string, std::string> kActions{
        {"purpose", "setting.purpose"},   {"sim-part", "setting.sim-part"},         {"sim-age", "setting.sim-age"},
        {"calibrate", "calibration.run"}, {"flat-field", "calibration.flat-field"}, {"reload", "setting.reload"},
        {"master", "mastering.run"}};
    const auto action = kActions.find(command);
    if (!c.audit || action == kActions.end()) return;
    if (command == "flat-field" && !(request.contains("take") && request["take"] == true)) return;
    const bool masterCancel = command == "master" && request.value("cancel", json()) == json(true);
    if (command == "master" && !request.contains("run") && !masterCancel) return;
    if ((command == "purpose" || command == "sim-part" || command == "sim-age") && before.empty()) return;
    // The caller is set by the socket server or the HMI, never by the client (answerMaintenanceRequest).
    const json caller = request.value("caller", json::object());
    store::AuditEntry entry;
    entry.who = caller.value("who", "unix:?");
    entry.role = caller.value("role", "");
    entry.source = caller.value("source", "socket");
    entry.action = masterCancel ? "mastering.cancel" : action->second;
    entry.object = command == "calibrate" && answer.contains("calibration") && answer["calibration"].is_object()
                       ? answer["calibration"].value("out", std::string())
                   : command == "flat-field" ? c.config->health.reference.string()
                                             : command;
    const bool ok = answer.value("ok", false);
    entry.outcome = ok ? "done" : "failed";
    entry.detail = ok ? std::string() : answer.value("error", std::string());
    // The request's own words, whatever their type (a refused request may carry a number there).
    const auto words = [&request](const char* key) {
        return request.contains(key) && request[key].is_string() ? request[key].get<std::string>()
                                                                 : request.value(key, json()).dump();
    };
    if (command == "calibrate")
        entry.detail = "pattern " + words("pattern") + ", poses " + words("poses") + (ok ? "" : ": " + entry.detail);
    if (command == "flat-field")
        entry.detail = "frames " + (request.contains("frames") ? words("frames") : std::string("8")) +
                       (ok ? "" : ": " + entry.detail);
    if (command == "master") {
        entry.object = "program " + words("program");
        if (!masterCancel)
            entry.detail = words("run") + " master cycles" +
                           (ok ? " of " + answer["run"].value("master", std::string()) : ": " + entry.detail);
        else if (answer.value("cancelled", false) == false)
            entry.detail = "no mastering run was running";
    }
    entry.before = before;
    entry.after = before.empty() ? std::string() : changedValue(c, command, request);
    c.audit(std::move(entry));
}

} // namespace

MaintenanceServer::Handler maintenanceCommands(MaintenanceContext context)
{
    return [context](const json& request) -> json {
        const auto named = textField(request, "command");
        if (!named) return refusal(named.status());
        const auto& command = named.value();
        const auto it = kCommands.find(command);
        if (it == kCommands.end()) return {{"ok", false}, {"error", "unknown command '" + command + "'"}};
        const auto before = changedValue(context, command, request);
        auto answer = it->second(context, request);
        recordChange(context, command, request, before, answer);
        return answer;
    };
}

} // namespace hg::daemon
