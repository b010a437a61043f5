// The plant link's payloads (docs/mqtt.md, "Topics"): the result message is
// the stored row with the station and the cycle id, nothing of the row
// changed; the state's `online` follows `offline`; the counters carry every
// verdict's count. The broker's side runs in tests/integration/mqtt_plant_link.py.
#include "plant/mqtt_publisher.h"

#include <gtest/gtest.h>

namespace hg::daemon {
namespace {

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

} // namespace
} // namespace hg::daemon
