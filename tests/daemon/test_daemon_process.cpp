// The daemon as a process (with fake devices): the PLC handshake with an
// independent client, faults with their codes, sd_notify through a fake
// NOTIFY_SOCKET, SIGHUP reloads, kill -9 and the result database.
#include "daemon_harness.h"

#include <cstdlib>
#include <cstring>
#include <functional>
#include <gtest/gtest.h>
#include <signal.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace {

using namespace std::chrono_literals;
using hgdaemon::DaemonProcess;

/// The JSON lines of `text`; `complete`: skip a last line still being written.
std::vector<nlohmann::json> jsonLines(const std::string& text, bool complete = false)
{
    std::vector<nlohmann::json> lines;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        if (complete && in.eof()) break; // no newline yet: not a whole line
        lines.push_back(nlohmann::json::parse(line));
    }
    return lines;
}

std::string sql(const std::filesystem::path& db, const std::string& query)
{
    return hgtest::run("sqlite3 " + db.string() + " \"" + query + "\"").out;
}

using hgdaemon::eventually;
using hgdaemon::occurrences;

int heartbeat(int port)
{
    return nlohmann::json::parse(hgdaemon::plcClient(port, "read 109 1").out)[0].get<int>();
}

TEST(DaemonProcess, HundredCyclesAlternatingNominalAndDefective)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s)) << daemon.logText();
    auto r = hgdaemon::plcClient(port, "cycles 100 --bad-every 2 --sim-socket " + (dir / "hg.sock").string());
    ASSERT_EQ(r.status, 0) << r.err << daemon.logText();
    auto lines = jsonLines(r.out);
    ASSERT_EQ(lines.size(), 101u);
    for (std::size_t i = 0; i < 100; ++i) {
        const auto& c = lines[i];
        EXPECT_EQ(c["verdict"], c["expected"]) << c.dump();
        EXPECT_TRUE(c["consistent"].get<bool>()) << c.dump();
        EXPECT_EQ(c["landmarks_total"], 20);
        EXPECT_EQ(c["landmarks_failed"], c["expected"] == "fail" ? 2 : 0);
    }
    // Every result the PLC saw is in the database, with the same verdict.
    auto db = dir / "results.db";
    EXPECT_EQ(sql(db, "SELECT COUNT(*) FROM inspections"), "100\n");
    EXPECT_EQ(sql(db, "SELECT COUNT(*) FROM inspections WHERE verdict='fail' AND serial LIKE 'BAD%'"), "50\n");
    EXPECT_EQ(sql(db, "SELECT COUNT(*) FROM inspections WHERE verdict='pass' AND serial LIKE 'SN%'"), "50\n");
    // Failed parts left their annotated images.
    auto images = sql(db, "SELECT images_dir FROM inspections WHERE verdict='fail' LIMIT 1");
    ASSERT_FALSE(images.empty());
    images.pop_back();
    EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(images) / "view_0.png")) << images;
    EXPECT_EQ(WEXITSTATUS(daemon.signal(SIGTERM)), 0);
    // The images are written after each result is shown; a stop writes what is still queued,
    // so every failed part's folder holds its 3 views, the last one's too.
    auto folders = sql(db, "SELECT images_dir FROM inspections WHERE verdict='fail' ORDER BY id");
    std::istringstream list(folders);
    int complete = 0;
    for (std::string folder; std::getline(list, folder);) {
        bool all = true;
        for (int k = 0; k < 3; ++k)
            all =
                all && std::filesystem::exists(std::filesystem::path(folder) / ("view_" + std::to_string(k) + ".png"));
        complete += all ? 1 : 0;
    }
    EXPECT_EQ(complete, 50) << folders;
}

TEST(DaemonProcess, TriggersRefusedWhileBusyOrForUnknownProgramsAreCounted)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    // Every move waits for the file `go`: the station stays busy until the test lets it go on.
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port), {{"HG_FAKE_MOVE_HOLD", (dir / "go").string()}});
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s)) << daemon.logText();
    // Unknown program 9: refused, counted, nothing else changes.
    auto refused = hgdaemon::plcClient(port, "cycles 1 --program 9");
    EXPECT_NE(refused.status, 0);
    EXPECT_NE(refused.err.find("refused"), std::string::npos) << refused.err;
    auto regs = nlohmann::json::parse(hgdaemon::plcClient(port, "read 100 12").out);
    EXPECT_EQ(regs[10], 1); // REJECTED_TRIGGERS
    EXPECT_EQ(regs[11], 2); // LAST_REJECT_REASON unknown program
    EXPECT_EQ(regs[1], 0);  // DONE_SEQ untouched
    // A manual trigger makes the station busy (held at its first move); a PLC trigger meanwhile is refused.
    auto manual = hgdaemon::maintenance(dir / "hg.sock", {{"command", "trigger"}, {"program", 1}, {"serial", "M1"}});
    ASSERT_TRUE(manual["ok"].get<bool>()) << manual.dump();
    auto busy = hgdaemon::plcClient(port, "cycles 1");
    EXPECT_NE(busy.status, 0);
    regs = nlohmann::json::parse(hgdaemon::plcClient(port, "read 100 12").out);
    EXPECT_EQ(regs[10], 2);
    EXPECT_EQ(regs[11], 1); // busy
    // The cycle in progress finishes undisturbed and the station serves the next trigger.
    hgtest::writeFile(dir / "go", "");
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "done", 10s));
    auto next = hgdaemon::plcClient(port, "cycles 1 --bad-every 0");
    EXPECT_EQ(next.status, 0) << next.err;
    EXPECT_EQ(sql(dir / "results.db", "SELECT serial, manual, verdict FROM inspections ORDER BY id"),
              "M1|1|pass\nSN000000|0|pass\n");
}

// Numbers from the socket are read as they are written: a fraction, a float, a
// string or a value outside the documented range is refused naming the key —
// "program": 1.9 once ran program 1, "limit": 1e8 answered every row — and a
// manual serial longer than the PLC's 16 characters (once a 300-character one
// broke the part's image folder) is refused before any cycle starts.
TEST(DaemonProcess, LooseNumbersAndOverlongSerialsAreRefusedNamingTheKey)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    const auto sock = dir / "hg.sock";
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();
    using nlohmann::json;
    const std::pair<json, std::string> refused[] = {
        {{{"command", "trigger"}, {"program", 1.9}}, "program: 1.9 is not a whole number 1..65535"},
        {{{"command", "trigger"}, {"program", "1"}}, "program: \"1\" is not a whole number 1..65535"},
        {{{"command", "trigger"}, {"program", 0}}, "program: 0 is outside 1..65535"},
        {{{"command", "trigger"}}, "program: missing (a whole number 1..65535)"},
        {{{"command", "trigger"}, {"program", 1}, {"serial", 7}}, "serial: 7 is not a string"},
        {{{"command", "trigger"}, {"program", 1}, {"serial", std::string(17, 'S')}},
         "serial: 17 characters; a serial has at most 16 (the PLC's SERIAL registers)"},
        {{{"command", "results"}, {"limit", 0}}, "limit: 0 is outside 1..1000"},
        {{{"command", "results"}, {"limit", -1}}, "limit: -1 is outside 1..1000"},
        {{{"command", "results"}, {"limit", 1e8}}, "limit: 100000000.0 is not a whole number 1..1000"},
        {{{"command", "results"}, {"limit", 18446744073709551615ull}},
         "limit: 18446744073709551615 is outside 1..1000"},
    };
    for (const auto& [request, error] : refused) {
        const json answer = hgdaemon::maintenance(sock, request);
        EXPECT_EQ(answer["ok"], false) << request.dump();
        EXPECT_EQ(answer.value("error", ""), error) << request.dump();
    }
    EXPECT_EQ(sql(dir / "results.db", "SELECT count(*) FROM inspections"), "0\n");
    // Sixteen characters are the PLC's own: taken.
    const json taken =
        hgdaemon::maintenance(sock, {{"command", "trigger"}, {"program", 1}, {"serial", std::string(16, 'S')}});
    ASSERT_TRUE(taken["ok"].get<bool>()) << taken.dump();
    ASSERT_TRUE(hgdaemon::waitForState(sock, "done", 10s));
    EXPECT_EQ(hgdaemon::maintenance(sock, {{"command", "results"}, {"limit", 1000}})["results"].size(), 1u);
}

/// Sends `bytes` to the maintenance socket as they are (no newline added); `closeWrite` then shuts
/// the client's side. Returns what the daemon answered until it closed (at most 10 s).
std::string rawMaintenance(const std::filesystem::path& socketPath, const std::string& bytes, bool closeWrite)
{
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, socketPath.c_str(), sizeof addr.sun_path - 1);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(fd);
        return "(no connection)";
    }
    timeval tv{10, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    (void)!write(fd, bytes.data(), bytes.size());
    if (closeWrite) shutdown(fd, SHUT_WR);
    std::string answer;
    char buf[4096];
    ssize_t n;
    while ((n = read(fd, buf, sizeof buf)) > 0) answer.append(buf, static_cast<std::size_t>(n));
    close(fd);
    return answer;
}

// docs/daemon.md, "Maintenance socket": a field of the wrong type is refused naming its key (not
// with the JSON library's words); a request the client ends by closing its side is answered; one
// left without its newline is told so when its time is up.
TEST(DaemonProcess, WrongTypesAndUnendedRequestsAreAnsweredNamingWhat)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    const auto sock = dir / "hg.sock";
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();
    using nlohmann::json;
    const std::pair<json, std::string> refused[] = {
        {{{"command", 5}}, "command: 5 is not a string"},
        {{{"command", "sim-part"}, {"name", 7}}, "name: 7 is not a string"},
        {{{"command", "sim-part"}, {"list", "yes"}}, "list: \"yes\" is not true or false"},
        {{{"command", "sim-age"}, {"reset", 1}}, "reset: 1 is not true or false"},
        {{{"command", "snapshot"}, {"grab", 1}}, "snapshot: grab: 1 is not true or false"},
        {{{"command", "calibrate"}, {"poses", 3}}, "poses: 3 is not a string"},
        {{{"command", "calibrate"}, {"poses", "p.yaml"}, {"out", false}}, "out: false is not a string"},
        {{{"command", "flat-field"}, {"take", "yes"}}, "flat-field: take: \"yes\" is not true or false"},
        {{{"command", "flat-field"}, {"take", true}, {"frames", 0}}, "flat-field: frames: 0 is outside 1..64"},
        {{{"command", "flat-field"}, {"take", true}, {"frames", 2.5}},
         "flat-field: frames: 2.5 is not a whole number 1..64"},
    };
    for (const auto& [request, error] : refused) {
        const json answer = hgdaemon::maintenance(sock, request);
        EXPECT_EQ(answer["ok"], false) << request.dump();
        EXPECT_EQ(answer.value("error", ""), error) << request.dump();
    }
    const auto ended = json::parse(rawMaintenance(sock, R"({"command": "status"})", true), nullptr, false);
    ASSERT_TRUE(ended.is_object()) << "no answer to a request ended by closing the client's side";
    EXPECT_EQ(ended["ok"], true) << ended.dump();
    const auto unended = json::parse(rawMaintenance(sock, R"({"command": "status"})", false), nullptr, false);
    ASSERT_TRUE(unended.is_object()) << "no answer to a request left without its newline";
    EXPECT_EQ(unended["ok"], false);
    EXPECT_NE(unended.value("error", "").find("no newline within"), std::string::npos) << unended.dump();
}

TEST(DaemonProcess, CyclePurposeFromThePlcOrTheSocketIsLatchedAtTheTriggerAndStored)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port));
    const auto sock = dir / "hg.sock";
    ASSERT_TRUE(hgdaemon::waitForState(sock, "ready", 10s)) << daemon.logText();
    EXPECT_EQ(hgdaemon::maintenance(sock, {{"command", "status"}})["purpose"], "production");

    // The PLC tags the next cycles master (CYCLE_PURPOSE = 1); a value past 2 answers exception 03.
    EXPECT_EQ(nlohmann::json::parse(hgdaemon::plcClient(port, "write 11 1").out)["exception"], 0);
    EXPECT_EQ(nlohmann::json::parse(hgdaemon::plcClient(port, "write 11 3").out)["exception"], 3);
    EXPECT_EQ(nlohmann::json::parse(hgdaemon::plcClient(port, "read 11 1").out)[0], 1);
    EXPECT_EQ(hgdaemon::maintenance(sock, {{"command", "purpose"}})["purpose"], "master");
    ASSERT_EQ(hgdaemon::plcClient(port, "cycles 1 --bad-every 0").status, 0);

    // The socket writes the same register: the last writer wins, for the PLC's triggers too.
    auto set = hgdaemon::maintenance(sock, {{"command", "purpose"}, {"purpose", "study"}});
    ASSERT_TRUE(set["ok"].get<bool>()) << set.dump();
    EXPECT_EQ(nlohmann::json::parse(hgdaemon::plcClient(port, "read 11 1").out)[0], 2);
    ASSERT_EQ(hgdaemon::plcClient(port, "cycles 1 --bad-every 0").status, 0);
    auto bad = hgdaemon::maintenance(sock, {{"command", "purpose"}, {"purpose", "golden"}});
    EXPECT_FALSE(bad["ok"].get<bool>());
    EXPECT_NE(bad["error"].get<std::string>().find("\"golden\" is not"), std::string::npos) << bad.dump();
    EXPECT_FALSE(hgdaemon::maintenance(sock, {{"command", "purpose"}, {"purpose", 1}})["ok"].get<bool>());
    EXPECT_EQ(hgdaemon::maintenance(sock, {{"command", "status"}})["purpose"], "study");
    // A manual trigger carries it as well; back to production for the last one.
    ASSERT_TRUE(hgdaemon::maintenance(sock, {{"command", "trigger"}, {"program", 1}, {"serial", "M1"}})["ok"]);
    ASSERT_TRUE(hgdaemon::waitForState(sock, "done", 10s));
    ASSERT_TRUE(hgdaemon::maintenance(sock, {{"command", "purpose"}, {"purpose", "production"}})["ok"]);
    ASSERT_EQ(hgdaemon::plcClient(port, "cycles 1 --bad-every 0").status, 0);

    EXPECT_EQ(sql(dir / "results.db", "SELECT manual, purpose FROM inspections ORDER BY id"),
              "0|master\n0|study\n1|study\n0|production\n");
    const auto recent = hgdaemon::maintenance(sock, {{"command", "results"}, {"limit", 4}})["results"];
    ASSERT_EQ(recent.size(), 4u);
    EXPECT_EQ(recent[0]["purpose"], "production");
    EXPECT_EQ(recent[3]["purpose"], "master");
    EXPECT_EQ(hgdaemon::maintenance(sock, {{"command", "status"}})["sequencer"]["last_cycle"]["purpose"], "production");
}

struct FaultCase {
    const char* variable;
    const char* value;
    int faultCode;
};

void PrintTo(const FaultCase& c, std::ostream* os)
{
    *os << c.variable << "=" << c.value << " (fault " << c.faultCode << ")";
}

class DaemonFaults : public ::testing::TestWithParam<FaultCase> {};

TEST_P(DaemonFaults, DeviceFaultIsReportedWithItsCodeAndTheDaemonKeepsServing)
{
    auto c = GetParam();
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port), {{c.variable, c.value}});
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s)) << daemon.logText();
    auto r = hgdaemon::plcClient(port, "cycles 1 --bad-every 0");
    ASSERT_EQ(r.status, 0) << r.err;
    auto cycle = jsonLines(r.out).at(0);
    EXPECT_EQ(cycle["verdict"], "error");
    EXPECT_EQ(cycle["fault_code"], c.faultCode);
    EXPECT_TRUE(cycle["consistent"].get<bool>());
    EXPECT_EQ(sql(dir / "results.db", "SELECT verdict, fault_code FROM inspections"),
              "error|" + std::to_string(c.faultCode) + "\n");
    // Still serving: the heartbeat moves (heartbeat_period_s 0.2) and the register map answers.
    const int a = heartbeat(port);
    EXPECT_TRUE(eventually([&] { return heartbeat(port) - a >= 2; }));
}

INSTANTIATE_TEST_SUITE_P(Codes, DaemonFaults,
                         ::testing::Values(FaultCase{"HG_FAKE_MOVE_FAIL", "timeout", 20},
                                           FaultCase{"HG_FAKE_MOVE_FAIL", "fault", 21},
                                           FaultCase{"HG_FAKE_GRAB_FAIL", "timeout", 10},
                                           FaultCase{"HG_FAKE_GRAB_FAIL", "bad", 11}),
                         // The test's name says the fault and its code, never the case's bytes.
                         [](const ::testing::TestParamInfo<FaultCase>& param) {
                             const std::string device =
                                 std::string(param.param.variable).find("MOVE") != std::string::npos ? "move" : "grab";
                             return device + "_" + param.param.value + "_" + std::to_string(param.param.faultCode);
                         });

TEST(DaemonProcess, AbortCommandFromThePlcEndsTheCycleAsAborted)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    // The first move of the cycle waits for the file `go`: the abort lands mid-cycle.
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port, {}, 8), {{"HG_FAKE_MOVE_HOLD", (dir / "go").string()}});
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s));
    auto manual = hgdaemon::maintenance(dir / "hg.sock", {{"command", "trigger"}, {"program", 1}});
    ASSERT_TRUE(manual["ok"].get<bool>());
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "moving", 10s));
    auto abort = hgtest::run("mbpoll -m tcp -p " + std::to_string(port) + " -a 1 -t 4 -r 10 -0 -1 127.0.0.1 1");
    EXPECT_EQ(abort.status, 0) << abort.out << abort.err;
    hgtest::writeFile(dir / "go", "");
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "done", 5s));
    EXPECT_EQ(sql(dir / "results.db", "SELECT verdict, fault_code FROM inspections"), "aborted|40\n");
}

// A unix datagram socket standing in for systemd's notify socket.
class FakeNotifySocket {
  public:
    explicit FakeNotifySocket(const std::filesystem::path& path) : path_(path)
    {
        fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
        EXPECT_EQ(bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
        timeval tv{0, 50'000};
        setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    ~FakeNotifySocket() { close(fd_); }
    struct Message {
        std::chrono::steady_clock::time_point at;
        std::string text;
    };
    /// Collects messages until `until` returns true or `timeout`.
    void collect(
        std::chrono::milliseconds timeout, const std::function<bool()>& until = [] { return false; })
    {
        auto deadline = std::chrono::steady_clock::now() + timeout;
        char buf[4096];
        while (std::chrono::steady_clock::now() < deadline && !until()) {
            ssize_t n = recv(fd_, buf, sizeof buf, 0);
            if (n > 0)
                messages.push_back({std::chrono::steady_clock::now(), std::string(buf, static_cast<std::size_t>(n))});
        }
    }
    bool seen(const std::string& field) const
    {
        for (auto& m : messages)
            if (("\n" + m.text + "\n").find("\n" + field + "\n") != std::string::npos) return true;
        return false;
    }
    std::vector<std::chrono::steady_clock::time_point> times(const std::string& field) const
    {
        std::vector<std::chrono::steady_clock::time_point> t;
        for (auto& m : messages)
            if (("\n" + m.text + "\n").find("\n" + field + "\n") != std::string::npos) t.push_back(m.at);
        return t;
    }
    std::vector<Message> messages;

  private:
    std::filesystem::path path_;
    int fd_ = -1;
};

TEST(DaemonProcess, NotifyProtocolReadyWatchdogStopping)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    FakeNotifySocket notify(dir / "notify.sock");
    DaemonProcess daemon(
        hgdaemon::writeConfig(dir, port),
        {{"NOTIFY_SOCKET", (dir / "notify.sock").string()}, {"WATCHDOG_USEC", "400000"}, {"WATCHDOG_PID", "$PID"}});
    notify.collect(10s, [&] { return notify.seen("READY=1"); });
    ASSERT_TRUE(notify.seen("READY=1")) << daemon.logText();
    notify.messages.clear();
    notify.collect(2s);
    // WATCHDOG_USEC = 0.4 s: the daemon pings every half interval, 0.2 s.
    auto pings = notify.times("WATCHDOG=1");
    EXPECT_GE(pings.size(), 7u);
    EXPECT_LE(pings.size(), 12u);
    for (std::size_t i = 1; i < pings.size(); ++i) EXPECT_LT(pings[i] - pings[i - 1], 400ms) << "gap before ping " << i;
    kill(daemon.pid(), SIGTERM);
    notify.collect(5s, [&] { return notify.seen("STOPPING=1"); });
    EXPECT_TRUE(notify.seen("STOPPING=1"));
    EXPECT_EQ(WEXITSTATUS(daemon.wait(10s)), 0);
}

TEST(DaemonProcess, NoReadyWhileDevicesDoNotStart)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    FakeNotifySocket notify(dir / "notify.sock");
    DaemonProcess daemon(hgdaemon::writeConfig(dir, port),
                         {{"NOTIFY_SOCKET", (dir / "notify.sock").string()}, {"HG_FAKE_START_FAIL", "1"}});
    // The devices failed to start: the sequencer is in fault (the daemon retries every 2 s).
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "fault", 10s)) << daemon.logText();
    auto regs = nlohmann::json::parse(hgdaemon::plcClient(port, "read 102 3").out);
    EXPECT_EQ(regs[0], 3); // STATUS fault
    // Everything the daemon sent up to its fault status (the main loop sends it within a turn).
    notify.collect(5s, [&] { return notify.seen("STATUS=fault"); });
    ASSERT_TRUE(notify.seen("STATUS=fault"));
    EXPECT_FALSE(notify.seen("READY=1"));
    auto refused = hgdaemon::plcClient(port, "cycles 1");
    EXPECT_NE(refused.status, 0);
}

TEST(DaemonProcess, SighupWithABadConfigurationKeepsTheRunningOne)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    auto config = hgdaemon::writeConfig(dir, port);
    DaemonProcess daemon(config);
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s));
    auto good = hgtest::run("cat " + config.string()).out;

    // Bad: a typo in a key. The daemon logs why and keeps program 1.
    hgtest::writeFile(config, good + "watchdog: {max_cycel_s: 3}\n");
    daemon.signal(SIGHUP);
    EXPECT_TRUE(eventually([&] { return daemon.logText().find("reload refused") != std::string::npos; }))
        << daemon.logText();
    EXPECT_NE(daemon.logText().find("max_cycel_s"), std::string::npos);
    EXPECT_EQ(hgdaemon::plcClient(port, "cycles 1 --bad-every 0").status, 0);

    // Good: program 2 added; it is accepted after the reload.
    EXPECT_NE(hgdaemon::plcClient(port, "cycles 1 --program 2").status, 0);
    std::string withTwo = good;
    withTwo.replace(withTwo.find("plc:"), 0, "  2: {part: part.yaml, views: views.yaml}\n");
    hgtest::writeFile(config, withTwo);
    daemon.signal(SIGHUP);
    ASSERT_TRUE(eventually([&] { return daemon.logText().find("configuration reloaded") != std::string::npos; }))
        << daemon.logText();
    auto r = hgdaemon::plcClient(port, "cycles 1 --program 2 --bad-every 0");
    EXPECT_EQ(r.status, 0) << r.err << daemon.logText();
}

// A reload reads the part programs on a worker of its own (docs/daemon.md, "Reload"): while the
// test holds it, the watchdog is pinged, the maintenance socket and the PLC answer; then it applies.
TEST(DaemonProcess, AReloadInProgressLeavesTheMainLoopServing)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    const auto hold = dir / "hold-the-check";
    FakeNotifySocket notify(dir / "notify.sock");
    auto config = hgdaemon::writeConfig(dir, port);
    DaemonProcess daemon(config, {{"NOTIFY_SOCKET", (dir / "notify.sock").string()},
                                  {"WATCHDOG_USEC", "400000"},
                                  {"WATCHDOG_PID", "$PID"},
                                  {"HG_FAKE_CHECK_HOLD", hold.string()}});
    notify.collect(10s, [&] { return notify.seen("READY=1"); });
    ASSERT_TRUE(notify.seen("READY=1")) << daemon.logText();

    std::string withTwo = hgtest::run("cat " + config.string()).out;
    withTwo.replace(withTwo.find("plc:"), 0, "  2: {part: part.yaml, views: views.yaml}\n");
    hgtest::writeFile(config, withTwo);
    hgtest::writeFile(hold, "held\n");
    notify.messages.clear();
    daemon.signal(SIGHUP);
    notify.collect(10s, [&] { return notify.seen("RELOADING=1"); });
    ASSERT_TRUE(notify.seen("RELOADING=1")) << daemon.logText();
    // Held for three seconds, checked from the outside: the loop's answers and its pings.
    const auto heldUntil = std::chrono::steady_clock::now() + 3s;
    int answers = 0;
    while (std::chrono::steady_clock::now() < heldUntil) {
        auto status = hgdaemon::maintenance(dir / "hg.sock", {{"command", "status"}});
        if (status.is_object() && status.value("ok", false)) ++answers;
        notify.collect(200ms);
    }
    EXPECT_GE(answers, 3) << "the maintenance socket answered during the reload";
    EXPECT_EQ(hgdaemon::plcClient(port, "read 109 1").status, 0) << "the PLC answered during the reload";
    EXPECT_EQ(daemon.logText().find("configuration reloaded"), std::string::npos) << "the check is still held";
    EXPECT_FALSE(notify.seen("READY=1")) << "READY comes once the reload is applied";
    auto pings = notify.times("WATCHDOG=1");
    ASSERT_GE(pings.size(), 2u) << daemon.logText();
    for (std::size_t i = 1; i < pings.size(); ++i) EXPECT_LE(pings[i] - pings[i - 1], 2s) << "gap before ping " << i;

    std::filesystem::remove(hold);
    ASSERT_TRUE(eventually([&] { return daemon.logText().find("configuration reloaded") != std::string::npos; }))
        << daemon.logText();
    notify.collect(10s, [&] { return notify.seen("READY=1"); });
    EXPECT_TRUE(notify.seen("READY=1"));
    auto r = hgdaemon::plcClient(port, "cycles 1 --program 2 --bad-every 0");
    EXPECT_EQ(r.status, 0) << r.err << daemon.logText();
}

// The PLC's allow-list needs a restart (docs/daemon.md): a reload that changes
// it says so, also when one address replaces another and the count stays.
TEST(DaemonProcess, SighupReplacingAnAllowedClientSaysItNeedsARestart)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    auto config = hgdaemon::writeConfig(dir, port);
    auto text = hgtest::run("cat " + config.string()).out;
    const std::string plcEnd = "heartbeat_period_s: 0.2}";
    text.replace(text.find(plcEnd), plcEnd.size(), "heartbeat_period_s: 0.2, allowed_clients: [127.0.0.1, 10.0.0.1]}");
    hgtest::writeFile(config, text);
    DaemonProcess daemon(config);
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s)) << daemon.logText();
    const std::string restart = "reload: 'plc' changed";

    // The same networks in another order: nothing to restart for.
    text.replace(text.find("[127.0.0.1, 10.0.0.1]"), std::string("[127.0.0.1, 10.0.0.1]").size(),
                 "[10.0.0.1, 127.0.0.1]");
    hgtest::writeFile(config, text);
    daemon.signal(SIGHUP);
    ASSERT_TRUE(eventually([&] { return occurrences(daemon.logText(), "configuration reloaded") == 1; }))
        << daemon.logText();
    EXPECT_EQ(occurrences(daemon.logText(), restart), 0u) << daemon.logText();

    text.replace(text.find("10.0.0.1"), std::string("10.0.0.1").size(), "10.0.0.2");
    hgtest::writeFile(config, text);
    daemon.signal(SIGHUP);
    ASSERT_TRUE(eventually([&] { return occurrences(daemon.logText(), "configuration reloaded") == 2; }))
        << daemon.logText();
    EXPECT_EQ(occurrences(daemon.logText(), restart), 1u) << daemon.logText();
}

TEST(DaemonProcess, KillNineMidCycleLosesNoReportedResult)
{
    hgtest::TempDir dir;
    int port = hgdaemon::freePort();
    auto config = hgdaemon::writeConfig(dir, port);
    std::vector<int> reported;
    {
        DaemonProcess daemon(config, {{"HG_FAKE_MOVE_MS", "20"}});
        ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s));
        // A PLC runs cycles in the background; kill -9 lands in the middle of one.
        auto out = dir / "plc.out";
        auto tool = hgtest::sourceDir() / "tools" / "plc-client";
        auto cmd = "/usr/bin/python3 " + tool.string() + " --port " + std::to_string(port) +
                   " cycles 1000 --bad-every 3 --sim-socket " + (dir / "hg.sock").string() + " > " + out.string() +
                   " 2>/dev/null &";
        (void)!std::system(cmd.c_str());
        // Kill it once the PLC has seen a few results (a line per result).
        auto results = [&] {
            int n = 0;
            for (const auto& line : jsonLines(hgtest::run("cat " + out.string()).out, true)) n += line.contains("seq");
            return n;
        };
        ASSERT_TRUE(eventually([&] { return results() > 5; }, 30s)) << daemon.logText();
        daemon.signal(SIGKILL);
        // Every result the PLC reported until the kill (a line it prints later names a result it had seen too).
        for (const auto& line : jsonLines(hgtest::run("cat " + out.string()).out, true))
            if (line.contains("seq")) reported.push_back(line["seq"].get<int>());
    }
    ASSERT_GT(reported.size(), 5u);
    auto db = dir / "results.db";
    EXPECT_EQ(sql(db, "PRAGMA integrity_check"), "ok\n");
    // After a restart the daemon opens the same database and keeps adding to it.
    DaemonProcess again(config);
    ASSERT_TRUE(hgdaemon::waitForState(dir / "hg.sock", "ready", 10s)) << again.logText();
    for (int seq : reported)
        EXPECT_EQ(sql(db, "SELECT COUNT(*) FROM inspections WHERE trigger_seq=" + std::to_string(seq)), "1\n")
            << "reported seq " << seq << " missing";
    EXPECT_EQ(hgdaemon::plcClient(port, "cycles 2").status, 0);
}

} // namespace
