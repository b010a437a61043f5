// `hullgauge ctl` against a running daemon (docs/contracts.md §7): socket selection,
// status, sim-part, trigger, results, and the exit status when no daemon runs.
#include "daemon_harness.h"

#include <gtest/gtest.h>
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

TEST(Ctl, NoDaemonIsAFaultNamingTheSocket)
{
    auto r = hgtest::run(ctl("--socket /nonexistent/hg.sock status"));
    EXPECT_EQ(r.status, 3);
    EXPECT_NE(r.err.find("/nonexistent/hg.sock"), std::string::npos) << r.err;
}

} // namespace
