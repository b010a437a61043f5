// The plant link's payloads (docs/mqtt.md, "Topics"): the result message is
// the stored row with the station and the cycle id, nothing of the row
// changed; the state's `online` follows `offline`; the counters carry every
// verdict's count. Its reconnection back-off on a clock the test moves by hand
// (docs/mqtt.md, "Failures"). The broker's side runs in
// tests/integration/mqtt_plant_link.py.
#include "daemon_harness.h"
#include "hgtest/log_capture.h"
#include "hgtest/manual_clock.h"
#include "hgtest/paths.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/store/result_store.h"
#include "hullgauge/store/sqlite.h"
#include "plant/mqtt_config.h"
#include "plant/mqtt_publisher.h"

#include <algorithm>
#include <arpa/inet.h>
#include <csignal>
#include <fcntl.h>
#include <fstream>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sstream>
#include <stdexcept>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;
using hgdaemon::eventually;
using hgdaemon::occurrences;
using hgdaemon::readText;

TEST(MqttPayloads, TheResultIsTheStoredRowWithStationAndCycleId)
{
    store::OutboxEntry entry;
    entry.id = 12;
    entry.cycleId = "0b6f3c9e-5d0a-4f8e-9a43-8d1c2e7f6a10";
    entry.row = {{"id", 12},
                 {"serial", "SN-1"},
                 {"program", 3},
                 {"verdict", "fail"},
                 {"landmarks", {{{"id", "c1"}, {"status", "out_of_tolerance"}}}},
                 {"time", "2026-12-03T08:14:03.250Z"}};
    auto message = resultMessage(entry, "gauge-7");
    EXPECT_EQ(message["station"], "gauge-7");
    EXPECT_EQ(message["cycle_id"], entry.cycleId);
    message.erase("station");
    message.erase("cycle_id");
    EXPECT_EQ(message, entry.row);
}

TEST(MqttPayloads, StateIsOnlineUnlessOfflineAndTheWillHasNoTime)
{
    const auto ready = stateMessage("g", "ready", 1'796'285'643'250);
    EXPECT_EQ(
        ready,
        (nlohmann::json{{"station", "g"}, {"state", "ready"}, {"online", true}, {"time", "2026-12-03T08:14:03.250Z"}}));
    const auto will = stateMessage("g", "offline", 0);
    EXPECT_EQ(will, (nlohmann::json{{"station", "g"}, {"state", "offline"}, {"online", false}}));
}

TEST(MqttPayloads, CountersCarryEveryVerdict)
{
    const auto message = countersMessage("g", store::ResultCounters{9, 5, 2, 1, 1}, 0);
    EXPECT_EQ(message["cycles"], 9);
    EXPECT_EQ(message["passes"], 5);
    EXPECT_EQ(message["fails"], 2);
    EXPECT_EQ(message["aborted"], 1);
    EXPECT_EQ(message["faults"], 1);
    EXPECT_EQ(message["time"], "1970-01-01T00:00:00.000Z");
}

/// A TCP port on 127.0.0.1 that refuses every connection: bound, never
/// listening, and held for the test's life so nothing else takes it.
class RefusingPort {
  public:
    RefusingPort() : fd_(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0))
    {
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t length = sizeof address;
        if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
            ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &length) != 0)
            throw std::runtime_error("cannot bind a port on 127.0.0.1");
        port_ = ntohs(address.sin_port);
    }
    ~RefusingPort() { ::close(fd_); }
    RefusingPort(const RefusingPort&) = delete;
    RefusingPort& operator=(const RefusingPort&) = delete;
    int port() const { return port_; }

  private:
    int fd_;
    int port_ = 0;
};

// docs/mqtt.md, "Failures": a broker that refuses is tried again after
// retry_min_s, the wait doubling at every failure up to retry_max_s. With
// 1 s and 4 s the attempts are due at 0, 1, 3, 7, 11 and 15 s on the
// publisher's clock. The test moves that clock in 100 ms steps and, at each,
// waits until the publisher waits on it again (having seen the new time), so
// the count it reads is the count at that instant: every attempt at its step
// of the back-off, none before.
TEST(MqttPublisher, ARefusedConnectionIsTriedAgainAtTheBackOffStepsAndNotBefore)
{
    hgtest::TempDir dir;
    const auto database = dir / "results.db";
    {
        store::ResultStore created(database);
    }
    RefusingPort broker;
    station::MqttConfig config;
    const auto yaml = "mqtt: {url: 'mqtt://127.0.0.1:" + std::to_string(broker.port()) +
                      "', station_id: gauge-7, retry_min_s: 1, retry_max_s: 4}\n";
    station::parseMqtt(ConfigNode::parse(yaml, (dir / "hullgauged.yaml").string())["mqtt"], dir.path(), config);

    hgtest::ManualClock clock(hgtest::ManualClock::Sleeps::WaitForTheHand);
    MqttPublisher publisher(
        config, database, [] { return std::string("ready"); }, clock);
    const std::vector<std::chrono::milliseconds> due{0ms, 1000ms, 3000ms, 7000ms, 11000ms, 15000ms};
    for (auto at = 0ms; at <= 16000ms; at += 100ms) {
        if (at > 0ms) clock.advance(100ms);
        ASSERT_TRUE(clock.nextWake()) << "the publisher does not wait on its clock at " << at.count() << " ms";
        const auto expected = std::count_if(due.begin(), due.end(), [&](auto d) { return d <= at; });
        ASSERT_EQ(publisher.connectionAttempts(), expected) << "at " << at.count() << " ms";
    }
    const auto status = publisher.status();
    EXPECT_EQ(status["connected"], false);
    EXPECT_NE(status.value("last_error", "").find(config.url), std::string::npos) << status.dump();
}

/// A program the test runs beside it (a broker, a subscriber), its output to `log`, killed at the end.
class Spawned {
  public:
    Spawned(std::vector<std::string> argv, const std::filesystem::path& log)
    {
        pid_ = fork();
        if (pid_ == 0) {
            const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
            dup2(fd, 1);
            dup2(fd, 2);
            std::vector<char*> args;
            for (auto& a : argv) args.push_back(a.data());
            args.push_back(nullptr);
            execvp(args[0], args.data());
            _exit(127);
        }
    }
    ~Spawned()
    {
        kill(pid_, SIGKILL);
        waitpid(pid_, nullptr, 0);
    }
    Spawned(const Spawned&) = delete;
    Spawned& operator=(const Spawned&) = delete;

  private:
    pid_t pid_ = -1;
};

/// Whether 127.0.0.1:`port` accepts a connection now.
bool accepts(int port)
{
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    ::close(fd);
    return ok;
}

// docs/mqtt.md, "Failures": a store that takes no writes (a full disk; here a write lock the test
// holds) ends neither the session nor the results' order: each result goes out once, the client
// does not reconnect, and the acknowledged results are marked published once the store takes
// writes again. Before, every refused mark ended the session, and each reconnection sent the
// waiting results again.
TEST(MqttPublisher, AStoreThatTakesNoWritesKeepsTheSessionAndSendsNothingTwice)
{
    hgtest::TempDir dir;
    const auto database = dir / "results.db";
    {
        store::ResultStore created(database);
        for (int k = 1; k <= 3; ++k) {
            station::InspectionRecord r;
            r.startedUnixMs = 1'700'000'000'000 + k;
            r.triggerSeq = static_cast<std::uint16_t>(k);
            r.serial = "LOCKED-" + std::to_string(k);
            r.program = 1;
            r.verdict = station::Verdict::Pass;
            created.commit(r);
        }
    }
    const int port = hgdaemon::freePort();
    const auto conf = hgtest::writeFile(dir / "mosquitto.conf", "listener " + std::to_string(port) +
                                                                    " 127.0.0.1\nallow_anonymous true\n"
                                                                    "persistence false\nuser root\n");
    Spawned broker({"mosquitto", "-c", conf.string()}, dir / "broker.log");
    ASSERT_TRUE(eventually([&] { return accepts(port); }, 10s)) << readText(dir / "broker.log");
    // Subscribed (SUBACK in the client's debug output) before anything is published.
    const auto received = dir / "received.txt";
    // Line-buffered: the subscriber writes to a file, which stdio would buffer whole.
    Spawned subscriber({"stdbuf", "-oL", "mosquitto_sub", "-d", "-v", "-q", "1", "-h", "127.0.0.1", "-p",
                        std::to_string(port), "-t", "hullgauge/gauge-7/result"},
                       received);
    ASSERT_TRUE(eventually([&] { return readText(received).find("SUBACK") != std::string::npos; }, 10s))
        << readText(received);

    station::MqttConfig config;
    const auto yaml = "mqtt: {url: 'mqtt://127.0.0.1:" + std::to_string(port) +
                      "', station_id: gauge-7, qos: 1, retry_min_s: 0.5, retry_max_s: 1}\n";
    station::parseMqtt(ConfigNode::parse(yaml, (dir / "hullgauged.yaml").string())["mqtt"], dir.path(), config);
    hgtest::LogCapture log("mqtt");
    auto lock = store::sqlite::open(database, store::sqlite::Access::Write, "the test's lock");
    lock.exec("BEGIN EXCLUSIVE");
    MqttPublisher publisher(
        config, database, [] { return std::string("ready"); }, Clock::steady());
    const auto sentOnce = [&] {
        const auto text = readText(received);
        for (int k = 1; k <= 3; ++k)
            if (occurrences(text, "\"LOCKED-" + std::to_string(k) + "\"") != 1) return false;
        return true;
    };
    ASSERT_TRUE(eventually(sentOnce, 20s)) << readText(received);
    ASSERT_TRUE(eventually([&] { return log.text().find("the store takes no writes") != std::string::npos; }, 20s))
        << log.text();
    // Long enough for two more marks refused at the back-off and, before, two reconnections.
    EXPECT_FALSE(eventually([&] { return !sentOnce() || publisher.connectionAttempts() != 1; }, 6s))
        << readText(received) << log.text();

    lock.exec("ROLLBACK");
    const auto marked = [&] {
        auto reader = store::sqlite::open(database, store::sqlite::Access::Read, "the test's reader");
        auto count = reader.prepare("SELECT COUNT(*) FROM inspections WHERE published_unix_ms IS NOT NULL");
        return count.step() && count.int64(0) == 3;
    };
    EXPECT_TRUE(eventually(marked, 20s)) << log.text();
    // The marks are committed before the line saying so is logged: waited for, not assumed.
    EXPECT_TRUE(eventually([&] { return log.text().find("the store takes writes again") != std::string::npos; }, 20s))
        << log.text();
    EXPECT_TRUE(sentOnce()) << readText(received);
    EXPECT_EQ(publisher.connectionAttempts(), 1);
}

// docs/mqtt.md, topic `health`: each cycle's health goes to
// hullgauge/<station>/health with the station added, retained, with the
// configured QoS. While the broker is away only the newest waits (the history
// is the store's): started after two messages, the broker gets the second
// alone, a subscriber that comes later gets it as the retained message, and a
// message published while connected follows at once.
TEST(MqttPublisher, TheHealthGoesOutRetainedTheNewestWhenTheBrokerComesBack)
{
    hgtest::TempDir dir;
    const auto database = dir / "results.db";
    {
        store::ResultStore created(database);
    }
    const int port = hgdaemon::freePort();
    station::MqttConfig config;
    const auto yaml = "mqtt: {url: 'mqtt://127.0.0.1:" + std::to_string(port) +
                      "', station_id: gauge-7, qos: 1, retry_min_s: 0.2, retry_max_s: 0.5}\n";
    station::parseMqtt(ConfigNode::parse(yaml, (dir / "hullgauged.yaml").string())["mqtt"], dir.path(), config);
    MqttPublisher publisher(
        config, database, [] { return std::string("ready"); }, Clock::steady());
    const auto health = [](const char* serial, const char* warning) {
        return nlohmann::json{{"serial", serial},
                              {"figures", {{"backlight", 0.5}, {"dust_specks", nullptr}}},
                              {"warnings", nlohmann::json::array({warning})}};
    };
    publisher.publishHealth(health("OLDER", "backlight"));
    publisher.publishHealth(health("NEWEST", "dust"));

    const auto conf = hgtest::writeFile(dir / "mosquitto.conf", "listener " + std::to_string(port) +
                                                                    " 127.0.0.1\nallow_anonymous true\n"
                                                                    "persistence false\nuser root\n");
    Spawned broker({"mosquitto", "-c", conf.string()}, dir / "broker.log");
    ASSERT_TRUE(eventually([&] { return accepts(port); }, 10s)) << readText(dir / "broker.log");
    ASSERT_TRUE(eventually([&] { return publisher.status().value("connected", false); }, 20s))
        << publisher.status().dump();
    // The retained message, read by a subscriber that came after it was sent: -v prints the topic first.
    const auto retained = dir / "retained.txt";
    const auto received = [](const std::filesystem::path& file, const std::string& serial) {
        return readText(file).find("\"serial\":\"" + serial + "\"") != std::string::npos;
    };
    {
        Spawned subscriber({"stdbuf", "-oL", "mosquitto_sub", "-d", "-v", "-q", "1", "-h", "127.0.0.1", "-p",
                            std::to_string(port), "-t", "hullgauge/gauge-7/health"},
                           retained);
        ASSERT_TRUE(eventually([&] { return received(retained, "NEWEST"); }, 20s)) << readText(retained);
        publisher.publishHealth(health("WHILE-CONNECTED", "focus"));
        ASSERT_TRUE(eventually([&] { return received(retained, "WHILE-CONNECTED"); }, 20s)) << readText(retained);
    }
    const auto text = readText(retained);
    EXPECT_EQ(text.find("OLDER"), std::string::npos) << text;
    const auto line = text.substr(text.find("hullgauge/gauge-7/health {"));
    const auto message = nlohmann::json::parse(line.substr(line.find('{'), line.find('\n') - line.find('{')));
    EXPECT_EQ(message["station"], "gauge-7");
    EXPECT_EQ(message["serial"], "NEWEST");
    EXPECT_EQ(message["warnings"], nlohmann::json::array({"dust"}));
    EXPECT_TRUE(message["figures"]["dust_specks"].is_null());
    // Retained: the broker flagged the first as such to the late subscriber (mosquitto_sub -d: "r1").
    EXPECT_NE(text.find("r1, m"), std::string::npos) << text;
}

} // namespace
} // namespace hg::daemon
