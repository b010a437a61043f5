// `hullgauge ctl`: talks to the running daemon through its maintenance socket
// (docs/contracts.md §7): --socket PATH, else $HULLGAUGE_SOCKET, else the installed
// default. One JSON request per connection, one JSON answer (docs/daemon.md).
#include "command.h"
#include "daemon_socket.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"

#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

namespace hg::cli {
namespace {

struct CtlOptions {
    std::string socket;
    int limit = 10;
    int program = 1;
    std::string serial;
    bool list = false;
    std::string part;
    bool json = false;
    std::string pattern;
    std::string poses;
    std::string out;
    std::string purpose;
    bool noWait = false;
    double waitS = 900.0;
    int frames = 8;
    bool reset = false;
};

/// " version N" of a part program's release (docs/commissioning.md, "Release"); empty without one.
std::string versionText(const nlohmann::json& version)
{
    return version.is_number_integer() ? " version " + version.dump() : std::string();
}

/// The release of the program the daemon loaded, when it is the PLC's active one and
/// ready: ", version N" or ", draft" (docs/daemon.md, "Maintenance socket").
std::string loadedVersion(const nlohmann::json& s, const nlohmann::json& plc)
{
    const auto program = s.value("program", nlohmann::json());
    if (!program.is_object() || program.value("number", -1) != plc.value("active_program", -2) ||
        plc.value("program_state", std::string()) != "ready")
        return {};
    const auto version = versionText(program.value("version", nlohmann::json()));
    return version.empty() ? ", draft" : "," + version;
}

/// The station's health (docs/health.md, "In the daemon"): the warnings of the last examined cycle and the
/// reference it was judged against.
void printHealth(const nlohmann::json& h)
{
    std::cout << "health:       ";
    if (!h.value("enabled", false)) {
        std::cout << "not watched\n";
        return;
    }
    std::string text;
    if (h["figures"].is_null())
        text = "no cycle examined yet";
    else if (h["warnings"].empty())
        text = "every figure within its limit";
    else
        for (const auto& state : h["states"])
            if (state.value("within", true) == false)
                text += (text.empty() ? "" : "; ") + state["sentence"].get<std::string>();
    const auto& reference = h["reference"];
    std::cout << text
              << (reference.is_object() ? "; reference taken " + reference.value("time", std::string())
                                        : std::string("; no flat-field reference (hullgauge ctl flat-field)"))
              << "\n";
}

/// The last mastering run (docs/mastering.md, "The mastering run"): its state, the cycle it is at, its set or error.
void printMasteringRun(const nlohmann::json& r)
{
    const auto state = r.value("state", std::string());
    std::cout << "mastering:    " << state << ", program " << r.value("program", 0) << ", master "
              << r.value("master", std::string());
    if (state == "running")
        std::cout << ", " << r.value("step", std::string()) << ": master cycle " << r.value("cycle", 0) << " of "
                  << r.value("cycles", 0);
    if (r.value("set", nlohmann::json()).is_object())
        std::cout << ", set " << r["set"].value("id", std::string()) << (state == "done" ? " in force" : "");
    if (r.contains("error")) std::cout << " — " << r["error"].get<std::string>();
    std::cout << "\n";
}

/// The simulated camera's optics as they have aged (docs/camera.md, "Aging"), on one line.
std::string opticsLine(const nlohmann::json& o)
{
    return "back light " + formatNumber(o.value("background_level", 0.0), 4) + ", vignetting " +
           formatNumber(o.value("vignetting", 0.0), 3) + ", blur " + formatNumber(o.value("blur_sigma_px", 0.0), 3) +
           " px, halo " + formatNumber(o.value("halo_px", 0.0), 3) + " px, " +
           std::to_string(o.value("dust_specks", 0)) + " dust specks (" + std::to_string(o.value("aging_steps", 0)) +
           " aging steps in " + std::to_string(o.value("cycles", 0)) + " cycles)";
}

void printStatus(const nlohmann::json& s)
{
    const auto& seq = s["sequencer"];
    const auto& plc = s["plc"];
    std::cout << "state:        " << seq["state"].get<std::string>();
    if (seq.contains("view")) std::cout << " (view " << seq["view"].get<int>() + 1 << " of " << seq["views"] << ")";
    if (seq.contains("fault")) std::cout << " — fault " << seq["fault_code"] << ": " << seq["fault"].get<std::string>();
    std::cout << "\nconfig:       " << s["config"].get<std::string>() << "\n"
              << "plc:          port " << plc["port"] << ", " << plc["clients"] << " clients, status " << plc["status"]
              << ", ack " << plc["ack_seq"] << ", done " << plc["done_seq"] << ", result " << plc["result"]
              << ", fault code " << plc["fault_code"] << ", rejected " << plc["rejected_triggers"] << "\n"
              << "cycles:       " << seq["cycles"] << " (" << seq["faults"] << " with errors)\n"
              << "results:      " << s["results"]["records"] << " in " << s["results"]["database"].get<std::string>()
              << "\n";
    // The PLC's handshake extensions (docs/plc.md): the changeover and the counters.
    if (plc.contains("counters")) {
        const auto& n = plc["counters"];
        std::cout << "plc program:  " << plc["active_program"] << " " << plc["program_state"].get<std::string>()
                  << loadedVersion(s, plc) << ", result seq " << plc["result_seq"] << ", acquired "
                  << plc["acq_done_seq"] << "\n"
                  << "plc counters: triggers " << n["triggers"] << ", pass " << n["passes"] << ", fail " << n["fails"]
                  << ", faults " << n["faults"] << ", missed " << n["missed_triggers"] << "\n";
    }
    if (s.contains("purpose")) std::cout << "purpose:      " << s["purpose"].get<std::string>() << "\n";
    if (s.contains("mqtt") && s["mqtt"].is_object()) {
        // The plant link (docs/mqtt.md): where it publishes, and what waits for the broker.
        const auto& m = s["mqtt"];
        std::cout << "plant link:   " << m.value("url", std::string("?")) << " as "
                  << m.value("station_id", std::string("?"))
                  << (m.value("connected", false) ? ", connected, " : ", not connected, ") << m.value("pending", 0)
                  << " results waiting";
        if (m.contains("last_error")) std::cout << " (last error: " << m["last_error"].get<std::string>() << ")";
        std::cout << "\n";
    }
    // The web HMI's address when the daemon serves it (docs/hmi.md).
    if (s.contains("http") && s["http"].is_object())
        std::cout << "web HMI:      http://" << s["http"].value("address", std::string("?")) << ":"
                  << s["http"].value("port", 0) << "/\n";
    if (!s["simulated_part"].get<std::string>().empty())
        std::cout << "sim part:     " << s["simulated_part"].get<std::string>() << "\n";
    if (s.contains("simulated_optics") && s["simulated_optics"].is_object())
        std::cout << "sim optics:   " << opticsLine(s["simulated_optics"]) << "\n";
    if (s.contains("lamps") && s["lamps"].is_object()) {
        // Commanded state per lamp (off, on, blinking), and the backend.
        const auto& l = s["lamps"];
        std::cout << "lamps:        ";
        for (const char* name : {"green", "amber", "red"})
            if (l.contains(name) && l[name].is_string()) std::cout << name << " " << l[name].get<std::string>() << ", ";
        std::cout << "backend " << l.value("backend", std::string("?")) << "\n";
    }
    if (s.contains("calibration") && s["calibration"].is_object()) {
        const auto& c = s["calibration"];
        std::cout << "calibration:  " << c.value("state", std::string()) << ", "
                  << (c.contains("progress") ? c["progress"].size() : 0) << "/" << c.value("poses", 0) << " poses";
        if (c.contains("error")) std::cout << " — " << c["error"].get<std::string>();
        std::cout << "\n";
    }
    if (s.contains("health") && s["health"].is_object()) printHealth(s["health"]);
    if (s.contains("mastering") && s["mastering"].is_object() &&
        s["mastering"].value("run", nlohmann::json()).is_object())
        printMasteringRun(s["mastering"]["run"]);
    if (!seq["last_cycle"].is_null()) {
        const auto& c = seq["last_cycle"];
        std::cout << "last cycle:   " << c["verdict"].get<std::string>() << ", serial '"
                  << c["serial"].get<std::string>() << "', program " << c["program"]
                  << versionText(c.value("program_version", nlohmann::json())) << ", " << c["cycle_ms"]
                  << " ms, landmarks failed " << c["landmarks_failed"] << "/" << c["landmarks_total"] << "\n";
        // The measured seat (docs/alignment.md) and, on the simulated line, the true one.
        const auto seat = [](const nlohmann::json& a) {
            return formatNumber(a.value("shift_mm", 0.0), 3) + " mm, " + formatNumber(a.value("rotation_deg", 0.0), 3) +
                   "°";
        };
        if (c.contains("alignment") && c["alignment"].is_object())
            std::cout << "last seat:    " << seat(c["alignment"]) << " ("
                      << c["alignment"].value("method", std::string("?")) << ")\n";
        if (c.contains("simulation") && c["simulation"].contains("seat"))
            std::cout << "true seat:    " << seat(c["simulation"]["seat"]) << " (simulated)\n";
    }
}

/// Queues the calibration and follows its progress lines until it ends:
/// exit 0 when the axes were solved and written, 3 when it failed.
int runCalibrate(const std::string& path, const CtlOptions& o)
{
    nlohmann::json req{
        {"command", "calibrate"}, {"pattern", o.pattern}, {"poses", std::filesystem::absolute(o.poses).string()}};
    if (!o.out.empty()) req["out"] = std::filesystem::absolute(o.out).string();
    daemonRequest(path, req);
    std::cerr << "calibration queued" << std::endl;
    if (o.noWait) return 0;
    std::size_t shown = 0;
    const auto c = followJob(path, {{"command", "calibration"}}, "calibration", "calibration", o.waitS,
                             [&](const nlohmann::json& job) {
                                 const auto& lines = job["progress"];
                                 for (; shown < lines.size(); ++shown)
                                     std::cerr << lines[shown].get<std::string>() << std::endl;
                             });
    std::cout << c.value("report", std::string());
    std::cout << "written: " << c.value("out", std::string());
    if (!c.value("backup", std::string()).empty()) std::cout << " (backup " << c["backup"].get<std::string>() << ")";
    std::cout << "\nthe daemon uses it after a reload (systemctl reload hullgauged)\n";
    return 0;
}

/// Queues the flat-field reference and follows it until it ends (docs/health.md, "In the daemon"):
/// exit 0 when it was taken and written, 3 when it failed (the daemon's reason).
int runFlatField(const std::string& path, const CtlOptions& o)
{
    daemonRequest(path, {{"command", "flat-field"}, {"take", true}, {"frames", o.frames}});
    std::cerr << "flat-field reference queued: empty the fixture; production pauses for the grabs" << std::endl;
    if (o.noWait) return 0;
    const auto f = followJob(path, {{"command", "flat-field"}}, "flat_field", "flat-field", o.waitS, {});
    const auto& r = f["reference"];
    std::cout << "flat-field reference taken " << r.value("time", std::string()) << " from " << f.value("frames", 0)
              << " frames: mean level " << formatNumber(r.value("level_mean", 0.0), 3) << " of full scale, noise "
              << formatNumber(r.value("noise", 0.0), 4) << ", " << r.value("dust_specks", 0)
              << " dark specks\nwritten: " << f.value("file", std::string())
              << "\nthe station's health is judged against it from the next cycle\n";
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto opts = std::make_shared<CtlOptions>();
    auto* ctl =
        app.add_subcommand("ctl", "talk to the running daemon (status, results, trigger, abort, sim-part, sim-age, "
                                  "purpose, calibrate, flat-field)");
    ctl->add_option("--socket", opts->socket,
                    "maintenance socket (default $HULLGAUGE_SOCKET, else " + std::string(kDefaultSocket) + ")");
    ctl->add_flag("--json", opts->json, "print the daemon's answer as JSON");
    ctl->require_subcommand(1);
    // ctl's options (and hullgauge's --log) are accepted after the subcommand too, `ctl status --json` as
    // `ctl --json status` (docs/daemon.md, "Maintenance socket"): every subcommand below inherits this.
    ctl->fallthrough();
    auto* status = ctl->add_subcommand("status", "print the daemon state");
    auto* results = ctl->add_subcommand("results", "print the most recent results");
    results->add_option("-n,--limit", opts->limit, "how many (1..1000)")->check(CLI::Range(1, 1000));
    auto* trigger = ctl->add_subcommand("trigger", "start an inspection (same rules as a PLC trigger)");
    trigger->add_option("--program", opts->program, "part program number")->check(CLI::Range(1, 65535));
    trigger->add_option("--serial", opts->serial, "part serial number");
    auto* abort = ctl->add_subcommand("abort", "abort the running cycle");
    auto* simPart = ctl->add_subcommand("sim-part", "switch the simulated part under test");
    simPart->add_flag("--list", opts->list, "list the parts the simulated line offers");
    simPart->add_option("name", opts->part, "nominal, a variant name, or none (the empty fixture)");
    auto* simAge = ctl->add_subcommand("sim-age", "print the simulated camera's aged optics (docs/camera.md, Aging)");
    simAge->add_flag("--reset", opts->reset, "set the optics back as configured, the cycle count at 0");
    auto* purpose = ctl->add_subcommand(
        "purpose", "print or set the purpose of the next cycles: production, master or study (docs/study.md)");
    purpose->add_option("purpose", opts->purpose, "production | master | study (none: print the current one)")
        ->check(CLI::IsMember({"production", "master", "study"}));
    auto* calibrate = ctl->add_subcommand(
        "calibrate", "run the live fixture calibration through the daemon's devices while production is paused; "
                     "writes the station file (with a backup), used after a reload");
    calibrate->add_option("--pattern", opts->pattern, "target carried by the fixture, e.g. chessboard:8x5:10")
        ->required();
    calibrate->add_option("--poses", opts->poses, "poses YAML: the {rotation_deg, declination_deg} to visit")
        ->required()
        ->check(CLI::ExistingFile);
    calibrate->add_option("--out", opts->out, "station YAML to write (default: the daemon's station file)");
    calibrate->add_flag("--no-wait", opts->noWait, "return once the daemon has queued it");
    calibrate->add_option("--wait-timeout", opts->waitS, "seconds to follow the progress")
        ->check(CLI::Range(1.0, 86400.0));
    auto* flatField = ctl->add_subcommand(
        "flat-field", "take the flat-field reference of the empty fixture while production is paused; the station's "
                      "health is judged against it from the next cycle (docs/health.md)");
    flatField->add_option("--frames", opts->frames, "frames averaged (1..64)")->check(CLI::Range(1, 64));
    flatField->add_flag("--no-wait", opts->noWait, "return once the daemon has queued it");
    flatField->add_option("--wait-timeout", opts->waitS, "seconds to wait for it")->check(CLI::Range(1.0, 86400.0));

    return [=]() -> int {
        auto path = daemonSocketPath(opts->socket);
        nlohmann::json answer;
        if (status->parsed()) {
            answer = daemonRequest(path, {{"command", "status"}});
            if (opts->json)
                std::cout << answer.dump(2) << "\n";
            else
                printStatus(answer);
        } else if (results->parsed()) {
            answer = daemonRequest(path, {{"command", "results"}, {"limit", opts->limit}});
            if (opts->json) {
                std::cout << answer["results"].dump(2) << "\n";
            } else {
                for (const auto& r : answer["results"])
                    std::cout << r["id"] << "  " << r["time"].get<std::string>() << "  "
                              << r["verdict"].get<std::string>() << "  serial '" << r["serial"].get<std::string>()
                              << "'  program " << r["program"]
                              << versionText(r.value("program_version", nlohmann::json())) << "  " << r["cycle_ms"]
                              << " ms  failed " << r["landmarks_failed"] << "/" << r["landmarks_total"] << "  fault "
                              << r["fault_code"] << "  " << r.value("purpose", std::string("production")) << "\n";
            }
        } else if (trigger->parsed()) {
            daemonRequest(path, {{"command", "trigger"}, {"program", opts->program}, {"serial", opts->serial}});
            std::cout << "triggered program " << opts->program << "\n";
        } else if (abort->parsed()) {
            daemonRequest(path, {{"command", "abort"}});
            std::cout << "abort requested\n";
        } else if (purpose->parsed()) {
            nlohmann::json req{{"command", "purpose"}};
            if (!opts->purpose.empty()) req["purpose"] = opts->purpose;
            answer = daemonRequest(path, req);
            std::cout << "purpose: " << answer["purpose"].get<std::string>() << "\n";
        } else if (calibrate->parsed()) {
            return runCalibrate(path, *opts);
        } else if (flatField->parsed()) {
            return runFlatField(path, *opts);
        } else if (simAge->parsed()) {
            nlohmann::json req{{"command", "sim-age"}};
            if (opts->reset) req["reset"] = true;
            answer = daemonRequest(path, req);
            if (opts->json)
                std::cout << answer["optics"].dump(2) << "\n";
            else
                std::cout << "simulated optics: " << opticsLine(answer["optics"]) << "\n";
        } else if (simPart->parsed()) {
            if (opts->list) {
                answer = daemonRequest(path, {{"command", "sim-part"}, {"list", true}});
                for (const auto& p : answer["parts"])
                    std::cout << p.get<std::string>() << (p == answer["current"] ? "  (current)" : "") << "\n";
            } else {
                if (opts->part.empty()) throw InputError("", "sim-part", "give a part name or --list");
                answer = daemonRequest(path, {{"command", "sim-part"}, {"name", opts->part}});
                std::cout << "simulated part: " << answer["current"].get<std::string>() << "\n";
            }
        }
        return 0;
    };
}

} // namespace

HG_REGISTER_COMMAND("ctl", factory);

} // namespace hg::cli
