// `hullgauge ctl` against a running daemon (docs/contracts.md §7): socket selection,
// status, sim-part, trigger, results, and the exit status when no daemon runs.
#include "daemon_harness.h"
#include "hullgauge/calib/flat_field.h"
#include "hullgauge/store/audit_log.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <regex>
#include <thread>

namespace {

using namespace std::chrono_literals;

std::string ctl(const std::string& args, const std::string& env = {})
{
    return env + " " + (hgtest::binaryDir() / "bin" / "hullgauge").string() + " ctl " + args;
}

TEST(Ctl, DrivesTheDaemonThroughItsMaintenanceSocket)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    hgdaemon::DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    auto sock = (dir / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();

    auto status = hgtest::run(ctl("--socket " + sock + " status"));
    ASSERT_EQ(status.status, 0) << status.err;
    EXPECT_NE(status.out.find("state:        ready"), std::string::npos) << status.out;
    EXPECT_NE(status.out.find("port " + std::to_string(port)), std::string::npos) << status.out;

    // $HULLGAUGE_SOCKET when --socket is absent.
    auto list = hgtest::run(ctl("sim-part --list", "HULLGAUGE_SOCKET=" + sock));
    ASSERT_EQ(list.status, 0) << list.err;
    EXPECT_EQ(list.out, "nominal  (current)\ndented\n");
    // --socket wins over the environment.
    EXPECT_EQ(hgtest::run(ctl("--socket " + sock + " sim-part dented", "HULLGAUGE_SOCKET=/nonexistent")).status, 0);
    auto unknown = hgtest::run(ctl("--socket " + sock + " sim-part bent"));
    EXPECT_EQ(unknown.status, 3);
    EXPECT_NE(unknown.err.find("unknown simulated part 'bent'"), std::string::npos) << unknown.err;

    ASSERT_EQ(hgtest::run(ctl("--socket " + sock + " trigger --program 1 --serial BENCH-7")).status, 0);
    ASSERT_TRUE(hgdaemon::waitForState(sock, "done", 10s));
    auto results = hgtest::run(ctl("--socket " + sock + " --json results -n 1"));
    ASSERT_EQ(results.status, 0) << results.err;
    auto rows = nlohmann::json::parse(results.out);
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(rows[0]["serial"], "BENCH-7");
    EXPECT_EQ(rows[0]["verdict"], "fail"); // the dented part
    EXPECT_EQ(rows[0]["landmarks_failed"], 2);
    // The purpose of the next cycles: printed, set, shown by status and stored with the results.
    EXPECT_EQ(hgtest::run(ctl("--socket " + sock + " purpose")).out, "purpose: production\n");
    auto master = hgtest::run(ctl("--socket " + sock + " purpose master"));
    ASSERT_EQ(master.status, 0) << master.err;
    EXPECT_EQ(master.out, "purpose: master\n");
    EXPECT_NE(hgtest::run(ctl("--socket " + sock + " status")).out.find("purpose:      master"), std::string::npos);
    EXPECT_EQ(hgtest::run(ctl("--socket " + sock + " purpose golden")).status, 2);
    ASSERT_EQ(hgtest::run(ctl("--socket " + sock + " trigger --program 1 --serial MASTER-1")).status, 0);
    ASSERT_TRUE(hgdaemon::waitForState(sock, "done", 10s));
    auto tagged = hgtest::run(ctl("--socket " + sock + " results -n 1"));
    EXPECT_NE(tagged.out.find("'MASTER-1'"), std::string::npos) << tagged.out;
    EXPECT_NE(tagged.out.find("  master\n"), std::string::npos) << tagged.out;
    // A trigger for an unknown program is refused with the reason.
    auto refused = hgtest::run(ctl("--socket " + sock + " trigger --program 5"));
    EXPECT_EQ(refused.status, 3);
    EXPECT_NE(refused.err.find("unknown part program"), std::string::npos) << refused.err;
}

// The simulated camera's aging (docs/camera.md, "Aging"): every cycle's new part counts (the fake
// station's optics take a step every 2 cycles); `sim-age --reset` makes them new.
TEST(Ctl, ShowsAndResetsTheSimulatedCamerasAging)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    hgdaemon::DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    auto sock = (dir / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();
    for (const char* serial : {"AGE-1", "AGE-2", "AGE-3"}) {
        ASSERT_EQ(hgtest::run(ctl("--socket " + sock + " trigger --program 1 --serial " + serial)).status, 0);
        ASSERT_TRUE(hgdaemon::waitForState(sock, "done", 10s));
    }
    auto aged = hgtest::run(ctl("--socket " + sock + " sim-age"));
    ASSERT_EQ(aged.status, 0) << aged.err;
    EXPECT_EQ(aged.out, "simulated optics: back light 0.85, vignetting 0, blur 0.5 px, halo 0 px, 1 dust specks (1 "
                        "aging steps in 3 cycles)\n");
    EXPECT_NE(hgtest::run(ctl("--socket " + sock + " status")).out.find("sim optics:   back light 0.85"),
              std::string::npos);
    auto json = nlohmann::json::parse(hgtest::run(ctl("--socket " + sock + " --json sim-age")).out);
    EXPECT_EQ(json["cycles"], 3);
    auto reset = hgtest::run(ctl("--socket " + sock + " sim-age --reset"));
    ASSERT_EQ(reset.status, 0) << reset.err;
    EXPECT_NE(reset.out.find("(0 aging steps in 0 cycles)"), std::string::npos) << reset.out;
    // The reset is a change, in the audit trail beside the result store (docs/audit.md); asking is not.
    hg::store::AuditQuery query;
    query.actionPrefix = "setting.sim-age";
    const auto entries = hg::store::AuditLog(dir / "audit.sqlite", true).select(query);
    ASSERT_EQ(entries.size(), 1u);
    EXPECT_EQ(entries[0].before, "aging: 3 cycles, 1 steps");
    EXPECT_EQ(entries[0].after, "aging: 0 cycles, 0 steps");
    EXPECT_EQ(entries[0].outcome, "done");
    EXPECT_EQ(entries[0].source, "socket");
}

// The release of the program a result was judged with (docs/daemon.md): in the
// results, the last cycle and the PLC's active program once it is loaded.
TEST(Ctl, ShowsTheReleaseOfTheProgramTheResultsWereJudgedWith)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    hgdaemon::DaemonProcess daemon(hgdaemon::writeConfig(dir, port), {{"HG_FAKE_RELEASE", "3"}});
    auto sock = (dir / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();
    // The PLC's cycle selects program 1 (PART_PROGRAM in its trigger block).
    auto plc = hgdaemon::plcClient(port, "cycles 1 --bad-every 0");
    ASSERT_EQ(plc.status, 0) << plc.err << daemon.logText();

    auto results = hgtest::run(ctl("--socket " + sock + " results -n 1"));
    ASSERT_EQ(results.status, 0) << results.err;
    EXPECT_NE(results.out.find("  program 1 version 3  "), std::string::npos) << results.out;
    auto rows = nlohmann::json::parse(hgtest::run(ctl("--socket " + sock + " --json results -n 1")).out);
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(rows[0]["program_version"], 3);
    EXPECT_EQ(rows[0]["program_sha256"], std::string(64, 'a'));

    auto status = hgtest::run(ctl("--socket " + sock + " status"));
    ASSERT_EQ(status.status, 0) << status.err;
    EXPECT_NE(status.out.find("plc program:  1 ready, version 3, "), std::string::npos) << status.out;
    EXPECT_NE(status.out.find("', program 1 version 3, "), std::string::npos) << status.out;
    auto answer = nlohmann::json::parse(hgtest::run(ctl("--socket " + sock + " --json status")).out);
    EXPECT_EQ(answer["program"]["number"], 1);
    EXPECT_EQ(answer["program"]["version"], 3);
    EXPECT_EQ(answer["program"]["verification_sha256"], std::string(64, 'a'));
}

// ctl's options go before or after the subcommand alike, and hullgauge's --log after it too.
TEST(Ctl, TakesItsOptionsBeforeOrAfterTheSubcommand)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    hgdaemon::DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    auto sock = (dir / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();

    for (const auto* args :
         {"--json --socket SOCK status", "status --json --socket SOCK", "--socket SOCK status --json",
          "--json status --socket SOCK", "status --socket SOCK --json --log warn"}) {
        auto line = std::regex_replace(args, std::regex("SOCK"), sock);
        auto r = hgtest::run(ctl(line));
        ASSERT_EQ(r.status, 0) << line << ": " << r.err;
        auto answer = nlohmann::json::parse(r.out, nullptr, false);
        ASSERT_TRUE(answer.is_object()) << line << ": " << r.out;
        EXPECT_EQ(answer["plc"]["port"], port) << line;
    }
    // A subcommand's own options stay its own, in any order with ctl's.
    auto rows = hgtest::run(ctl("results -n 3 --json --socket " + sock));
    ASSERT_EQ(rows.status, 0) << rows.err;
    EXPECT_TRUE(nlohmann::json::parse(rows.out).is_array()) << rows.out;
    // An option nobody has is still refused, naming it.
    auto unknown = hgtest::run(ctl("status --jsn --socket " + sock));
    EXPECT_EQ(unknown.status, 2);
    EXPECT_NE(unknown.err.find("--jsn"), std::string::npos) << unknown.err;
}

// `ctl status` prints where the web HMI answers (docs/hmi.md); without an `http` section, no such line.
TEST(Ctl, StatusPrintsTheAddressOfTheWebHmi)
{
    hgtest::TempDir dir;
    const auto assets = (hgtest::sourceDir() / "share" / "hmi").string();
    hgdaemon::DaemonProcess daemon(hgdaemon::writeConfig(
        dir, hgdaemon::freePort(), "http:\n  bind: 127.0.0.1\n  port: 0\n  assets: " + assets + "\n"));
    auto sock = (dir / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();

    auto status = hgtest::run(ctl("status --socket " + sock));
    ASSERT_EQ(status.status, 0) << status.err;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(status.out, m, std::regex("\nweb HMI: +http://127\\.0\\.0\\.1:([0-9]+)/\n")))
        << status.out;
    // The port the kernel chose, where the HMI's JSON API answers.
    httplib::Client client("127.0.0.1", std::stoi(m[1].str()));
    auto page = client.Get("/api/status");
    ASSERT_TRUE(page) << "nothing answers on " << m[1].str();
    EXPECT_EQ(page->status, 200) << page->body;

    hgtest::TempDir plain;
    hgdaemon::DaemonProcess without(hgdaemon::writeConfig(plain, hgdaemon::freePort()));
    auto plainSock = (plain / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(plainSock, "ready", 10s)) << without.logText();
    auto none = hgtest::run(ctl("status --socket " + plainSock));
    ASSERT_EQ(none.status, 0) << none.err;
    EXPECT_EQ(none.out.find("web HMI"), std::string::npos) << none.out;
}

// docs/health.md, "The flat-field reference": `ctl flat-field` queues it and follows it to its end,
// printing the reference; the file is written beside the station file with the frames' level
// (the fake camera's 200 of 255), `ctl status` names it, and the audit trail records who took it.
TEST(Ctl, TakesTheFlatFieldReferenceAndStatusShowsIt)
{
    hgtest::TempDir dir;
    hgdaemon::DaemonProcess daemon(hgdaemon::writeConfig(dir, hgdaemon::freePort()));
    auto sock = (dir / "hg.sock").string();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();
    auto before = hgtest::run(ctl("--socket " + sock + " status"));
    EXPECT_NE(before.out.find("health:       no cycle examined yet; no flat-field reference"), std::string::npos)
        << before.out;

    auto taken = hgtest::run(ctl("--socket " + sock + " flat-field --frames 3"));
    ASSERT_EQ(taken.status, 0) << taken.err << daemon.logText();
    EXPECT_NE(taken.err.find("flat-field reference queued"), std::string::npos) << taken.err;
    EXPECT_NE(taken.out.find("from 3 frames: mean level 0.784 of full scale"), std::string::npos) << taken.out;
    const auto file = dir / "flat-field.json";
    EXPECT_NE(taken.out.find("written: " + file.string()), std::string::npos) << taken.out;
    const auto reference = hg::calib::readFlatField(file);
    EXPECT_EQ(reference.sensor, cv::Size(64, 48));
    double darkest = 0, brightest = 0;
    cv::minMaxLoc(reference.level, &darkest, &brightest);
    EXPECT_NEAR(darkest, 200.0 / 255.0, 1e-6);
    EXPECT_NEAR(brightest, 200.0 / 255.0, 1e-6);
    EXPECT_NE(hgtest::run(ctl("--socket " + sock + " status")).out.find("; reference taken "), std::string::npos);

    hg::store::AuditLog audit(dir / "audit.sqlite");
    bool recorded = false;
    for (const auto& e : audit.select({}))
        if (e.action == "calibration.flat-field") {
            recorded = true;
            EXPECT_EQ(e.object, file.string());
            EXPECT_EQ(e.outcome, "done");
            EXPECT_EQ(e.source, "socket");
            EXPECT_EQ(e.detail, "frames 3");
            EXPECT_EQ(e.who.rfind("unix:", 0), 0u) << e.who;
        }
    EXPECT_TRUE(recorded);
    // Out of range: refused by ctl's own check before anything is asked of the daemon.
    EXPECT_EQ(hgtest::run(ctl("--socket " + sock + " flat-field --frames 65")).status, 2);
}

TEST(Ctl, NoDaemonIsAFaultNamingTheSocket)
{
    auto r = hgtest::run(ctl("--socket /nonexistent/hg.sock status"));
    EXPECT_EQ(r.status, 3);
    EXPECT_NE(r.err.find("/nonexistent/hg.sock"), std::string::npos) << r.err;
}

} // namespace
