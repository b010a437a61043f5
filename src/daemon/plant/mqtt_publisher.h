// The plant link (docs/mqtt.md): every committed result, the station's state
// and its counters published to an MQTT broker with libmosquitto, on a thread
// of its own, off the inspection path. The result store is the outbox: the
// publisher reads the results not yet acknowledged from the store, oldest
// first and in batches, through its own SQLite connection, keeps a bounded
// number in flight, and marks each one published when the broker acknowledges
// it (PUBACK). Whatever the broker does, the cycles never wait for it; results
// wait on disk, in order, and go out when it is back, also after a restart.
//
// Publish only: the client subscribes to nothing and takes no commands.
#pragma once

#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/worker.h"
#include "hullgauge/store/result_outbox.h"

#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace hg::daemon {

/// The payloads (docs/mqtt.md, "Topics"; docs/schemas/mqtt-*.schema.json).
nlohmann::json resultMessage(const store::OutboxEntry& entry, const std::string& stationId);
nlohmann::json stateMessage(const std::string& stationId, const std::string& state, std::int64_t unixMs);
nlohmann::json countersMessage(const std::string& stationId, const store::ResultCounters& counters,
                               std::int64_t unixMs);
/// A cycle's health as the cycle runner reports it, with the station (docs/mqtt.md, topic `health`).
nlohmann::json healthMessage(const nlohmann::json& health, const std::string& stationId);

class MqttPublisher {
  public:
    /// The station's state as the PLC's STATUS sees it ("ready", "moving", ...);
    /// called from the publisher's thread.
    using StateSource = std::function<std::string()>;

    /// Starts the thread. `database` is the result store the daemon opened;
    /// `clock` times the reconnection back-off, the timeouts and the time stamps.
    MqttPublisher(station::MqttConfig config, std::filesystem::path database, StateSource state,
                  Clock& clock = Clock::steady());
    ~MqttPublisher();
    MqttPublisher(const MqttPublisher&) = delete;
    MqttPublisher& operator=(const MqttPublisher&) = delete;

    /// Publishes the state `offline`, disconnects and ends the thread (unacknowledged results stay in the outbox).
    void stop();
    /// For `ctl status`: connected, results waiting, the last error.
    nlohmann::json status() const;
    /// A cycle's health (docs/mqtt.md, topic `health`), sent retained with the
    /// configured QoS as soon as the broker is connected; while it is not, only
    /// the newest waits (the figures' history is in the store). Thread-safe.
    void publishHealth(nlohmann::json health);
    /// Connection attempts since the start: one at once, then one after every
    /// back-off (docs/mqtt.md, "Failures").
    std::int64_t connectionAttempts() const { return attempts_.load(); }

  private:
    void run(std::stop_token stop);
    void serve(store::ResultOutbox& outbox, std::stop_token stop);
    void waitBeforeRetry(store::ResultOutbox* outbox, std::stop_token stop);
    void setStatus(bool connected, const std::string& error);
    std::optional<nlohmann::json> takeHealth();
    void keepHealth(nlohmann::json health);

    const station::MqttConfig config_;
    const std::filesystem::path database_;
    StateSource state_;
    Clock& clock_;

    std::mutex mutex_; // the waits between attempts, which the stop ends
    std::condition_variable wake_;
    std::chrono::milliseconds retry_; ///< the next wait before a connection attempt (publisher thread)
    store::ResultCounters counters_;  ///< the store's counts (publisher thread) ...
    std::int64_t counted_ = 0;        ///< ... of the results up to this id

    mutable std::mutex statusMutex_;
    bool connected_ = false;
    std::string lastError_;
    std::atomic<std::int64_t> pending_{0};
    std::atomic<std::int64_t> attempts_{0};

    std::mutex healthMutex_;
    std::optional<nlohmann::json> health_; ///< the newest health not yet sent

    Worker worker_; ///< run(); last, so it ends before what it uses
};

} // namespace hg::daemon
