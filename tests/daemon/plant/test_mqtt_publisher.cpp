// The plant link's payloads (docs/mqtt.md, "Topics"): the result message is
// the stored row with the station and the cycle id, nothing of the row
// changed; the state's `online` follows `offline`; the counters carry every
// verdict's count. Its reconnection back-off on a clock the test moves by hand
// (docs/mqtt.md, "Failures"). The broker's side runs in
// tests/integration/mqtt_plant_link.py.
#include "hgtest/manual_clock.h"
#include "hgtest/paths.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/store/result_store.h"
#include "plant/mqtt_config.h"
#include "plant/mqtt_publisher.h"

#include <algorithm>
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <stdexcept>
#include <sys/socket.h>
#include <unistd.h>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;

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

} // namespace
} // namespace hg::daemon
