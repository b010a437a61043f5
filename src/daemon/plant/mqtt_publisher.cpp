#include "plant/mqtt_publisher.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <map>
#include <mosquitto.h>
#include <optional>

namespace hg::daemon {

using store::OutboxEntry;
using store::ResultCounters;
using store::ResultOutbox;

namespace {

using nlohmann::json;

/// Results read from the outbox at a time (bounded memory: at most this many rows and `max_inflight` sent).
constexpr int kBatch = 50;
/// The wait for the broker's socket in one turn of the loop: also how soon a new result is seen.
constexpr int kLoopMs = 20;

std::shared_ptr<spdlog::logger> logger()
{
    return hg::log::category("mqtt");
}

/// What went wrong, in words: libmosquitto's error, with the system's reason when it is one.
std::string describeError(int rc)
{
    if (rc == MOSQ_ERR_ERRNO) return std::strerror(errno);
    if (rc == MOSQ_ERR_TLS)
        return std::string(mosquitto_strerror(rc)) +
               " (the broker's certificate not signed by tls.ca_file or not naming the URL's host, or the client "
               "certificate refused: the OpenSSL error above says which)";
    return mosquitto_strerror(rc);
}

} // namespace

json resultMessage(const OutboxEntry& entry, const std::string& stationId)
{
    // The stored row as every reader gives it, and what identifies it at the plant.
    json message = entry.row;
    message["station"] = stationId;
    message["cycle_id"] = entry.cycleId;
    return message;
}

json stateMessage(const std::string& stationId, const std::string& state, std::int64_t unixMs)
{
    json message{{"station", stationId}, {"state", state}, {"online", state != "offline"}};
    if (unixMs > 0) message["time"] = store::formatUtc(unixMs);
    return message;
}

json countersMessage(const std::string& stationId, const ResultCounters& c, std::int64_t unixMs)
{
    return {{"station", stationId}, {"time", store::formatUtc(unixMs)},
            {"cycles", c.cycles},   {"passes", c.passes},
            {"fails", c.fails},     {"aborted", c.aborted},
            {"faults", c.faults}};
}

json healthMessage(const json& health, const std::string& stationId)
{
    json message = health;
    message["station"] = stationId;
    return message;
}

namespace {

/// One connection to the broker: a libmosquitto client made for it and
/// destroyed with it, so nothing of a lost connection is sent again by the
/// library; the outbox sends again what was not acknowledged, in order.
/// Everything runs on the publisher's thread (libmosquitto's callbacks too:
/// mosquitto_loop calls them).
struct Session {
    const station::MqttConfig& config;
    const Clock& clock; ///< the publisher's: the time stamps and the goodbye's bound
    mosquitto* client = nullptr;
    bool connected = false;
    std::string failure;                        ///< why the session ended, when it did
    std::map<int, std::int64_t> inflight;       ///< message id -> result id, sent and not acknowledged
    std::vector<std::int64_t> acknowledged;     ///< result ids acknowledged, not yet marked in the store
    std::deque<OutboxEntry> batch;              ///< read from the outbox, not yet sent
    std::int64_t lastQueued = 0;                ///< the newest result id sent
    std::string lastState;                      ///< the state last published
    std::optional<ResultCounters> lastCounters; ///< the counters last published

    Session(const station::MqttConfig& cfg, const Clock& c) : config(cfg), clock(c) {}
    ~Session()
    {
        if (client) mosquitto_destroy(client);
    }
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    bool start();
    bool publish(const std::string& topic, const json& payload, bool retain, int* mid = nullptr);
};

bool Session::start()
{
    client = mosquitto_new(config.clientId.c_str(), true, this);
    if (!client) {
        failure = "cannot create the MQTT client: " + std::string(std::strerror(errno));
        return false;
    }
    mosquitto_int_option(client, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
    mosquitto_connect_callback_set(client, [](mosquitto*, void* self, int rc) {
        auto& s = *static_cast<Session*>(self);
        if (rc == 0)
            s.connected = true;
        else
            s.failure = std::string("the broker refused the connection: ") + mosquitto_connack_string(rc);
    });
    mosquitto_publish_callback_set(client, [](mosquitto*, void* self, int mid) {
        auto& s = *static_cast<Session*>(self);
        if (auto it = s.inflight.find(mid); it != s.inflight.end()) {
            s.acknowledged.push_back(it->second);
            s.inflight.erase(it);
        }
    });
    mosquitto_log_callback_set(client, [](mosquitto*, void*, int level, const char* text) {
        if (level & (MOSQ_LOG_ERR | MOSQ_LOG_WARNING)) logger()->warn("libmosquitto: {}", text);
    });
    // The state's last will: the broker tells the plant when the station vanishes (docs/mqtt.md).
    const auto will = dumpJson(stateMessage(config.stationId, "offline", 0));
    int rc = mosquitto_will_set(client, config.topic("state").c_str(), static_cast<int>(will.size()), will.data(),
                                config.qos, true);
    if (rc == MOSQ_ERR_SUCCESS && !config.username.empty())
        rc = mosquitto_username_pw_set(client, config.username.c_str(),
                                       config.password.empty() ? nullptr : config.password.c_str());
    if (rc == MOSQ_ERR_SUCCESS && config.tls) {
        const auto path = [](const std::filesystem::path& p) { return p.empty() ? nullptr : p.c_str(); };
        // Without ca_file the system's CAs; a key is never asked for a passphrase (it has none).
        rc = mosquitto_tls_set(client, path(config.caFile), config.caFile.empty() ? "/etc/ssl/certs" : nullptr,
                               path(config.certFile), path(config.keyFile), [](char*, int, int, void*) { return 0; });
        if (rc != MOSQ_ERR_SUCCESS) {
            failure = "TLS settings refused: " + describeError(rc);
            return false;
        }
    }
    if (rc == MOSQ_ERR_SUCCESS)
        rc = mosquitto_connect_async(client, config.host.c_str(), config.port, config.keepaliveS);
    if (rc != MOSQ_ERR_SUCCESS) {
        failure = "cannot connect to " + config.url + ": " + describeError(rc);
        return false;
    }
    return true;
}

bool Session::publish(const std::string& topic, const json& payload, bool retain, int* mid)
{
    const auto text = dumpJson(payload);
    const int rc =
        mosquitto_publish(client, mid, topic.c_str(), static_cast<int>(text.size()), text.data(), config.qos, retain);
    if (rc != MOSQ_ERR_SUCCESS) failure = "publishing on " + topic + " failed: " + describeError(rc);
    return rc == MOSQ_ERR_SUCCESS;
}

/// The acknowledged results marked published; kept for the next turn when the store is busy.
void markAcknowledged(ResultOutbox& outbox, Session& session)
{
    if (session.acknowledged.empty()) return;
    outbox.markPublished(session.acknowledged, session.clock.wallMs());
    session.acknowledged.clear();
}

/// Marks acknowledged results published, backed off while the store refuses writes (a full
/// disk, docs/mqtt.md "Failures"): the session goes on, nothing is sent again, the marks wait
/// in memory and the journal says so when it starts and when it ends.
class PublishedMarks {
  public:
    PublishedMarks(const Clock& clock, std::chrono::milliseconds first, std::chrono::milliseconds most)
        : clock_(clock), first_(first), most_(most), wait_(first)
    {
    }
    void mark(ResultOutbox& outbox, Session& session)
    {
        if (session.acknowledged.empty() || (failing_ && clock_.now() < nextTry_)) return;
        const auto count = session.acknowledged.size();
        try {
            markAcknowledged(outbox, session);
        } catch (const FaultError& e) {
            if (!failing_)
                logger()->warn("plant link: the store takes no writes ({}); acknowledged results are marked "
                               "published when it does (nothing is sent again)",
                               e.what());
            failing_ = true;
            nextTry_ = clock_.now() + wait_;
            wait_ = std::min(wait_ * 2, most_);
            return;
        }
        if (failing_) logger()->info("plant link: the store takes writes again; {} results marked published", count);
        failing_ = false;
        wait_ = first_;
    }

  private:
    const Clock& clock_;
    const std::chrono::milliseconds first_, most_;
    std::chrono::milliseconds wait_;
    Clock::time_point nextTry_{};
    bool failing_ = false;
};

/// The station's state and counters, when they changed since last published (retained: a
/// subscriber that comes later gets the latest at once).
bool publishLatest(Session& session, const std::string& state, const ResultCounters& counters)
{
    const auto& cfg = session.config;
    if (state != session.lastState) {
        if (!session.publish(cfg.topic("state"), stateMessage(cfg.stationId, state, session.clock.wallMs()), true))
            return false;
        session.lastState = state;
    }
    if (session.lastCounters != counters) {
        if (!session.publish(cfg.topic("counters"), countersMessage(cfg.stationId, counters, session.clock.wallMs()),
                             true))
            return false;
        session.lastCounters = counters;
    }
    return true;
}

/// Sends waiting results, oldest first, while fewer than max_inflight are unacknowledged.
bool sendWaiting(Session& session, ResultOutbox& outbox)
{
    const auto& cfg = session.config;
    while (static_cast<int>(session.inflight.size()) < cfg.maxInflight) {
        if (session.batch.empty()) {
            for (auto& entry : outbox.pending(session.lastQueued, kBatch)) session.batch.push_back(std::move(entry));
            if (session.batch.empty()) return true;
        }
        auto& entry = session.batch.front();
        int mid = 0;
        if (!entry.row.is_null()) {
            if (!session.publish(cfg.topic("result"), resultMessage(entry, cfg.stationId), false, &mid)) return false;
            session.inflight.emplace(mid, entry.id);
        }
        session.lastQueued = entry.id;
        session.batch.pop_front();
    }
    return true;
}

/// A clean stop: the state `offline` (the will is not sent after a clean disconnect), acknowledged
/// within a second or given up, then the disconnect.
void sayGoodbye(Session& session, ResultOutbox& outbox)
{
    const auto& cfg = session.config;
    int mid = 0;
    if (session.publish(cfg.topic("state"), stateMessage(cfg.stationId, "offline", session.clock.wallMs()), true,
                        &mid)) {
        session.inflight.emplace(mid, 0);
        const auto until = session.clock.now() + std::chrono::seconds(1);
        while (session.inflight.count(mid) && session.clock.now() < until)
            if (mosquitto_loop(session.client, kLoopMs, 1) != MOSQ_ERR_SUCCESS) break;
    }
    std::erase(session.acknowledged, 0);
    markAcknowledged(outbox, session);
    mosquitto_disconnect(session.client);
    mosquitto_loop(session.client, kLoopMs, 1);
}

} // namespace

MqttPublisher::MqttPublisher(station::MqttConfig config, std::filesystem::path database, StateSource state,
                             Clock& clock)
    : config_(std::move(config)), database_(std::move(database)), state_(std::move(state)), clock_(clock),
      retry_(config_.retryMin)
{
    mosquitto_lib_init();
    worker_.start([this](std::stop_token stop) { run(stop); }, wakeOn(mutex_, wake_));
}

MqttPublisher::~MqttPublisher()
{
    stop();
    mosquitto_lib_cleanup();
}

void MqttPublisher::stop()
{
    worker_.stop();
}

json MqttPublisher::status() const
{
    std::lock_guard lock(statusMutex_);
    json j{{"url", config_.url},
           {"station_id", config_.stationId},
           {"connected", connected_},
           {"pending", pending_.load()}};
    if (!lastError_.empty()) j["last_error"] = lastError_;
    return j;
}

void MqttPublisher::publishHealth(json health)
{
    std::lock_guard lock(healthMutex_);
    health_ = std::move(health);
}

std::optional<json> MqttPublisher::takeHealth()
{
    std::lock_guard lock(healthMutex_);
    std::optional<json> health;
    health.swap(health_);
    return health;
}

// A health message the broker did not take goes out with the next session, unless a newer one came.
void MqttPublisher::keepHealth(json health)
{
    std::lock_guard lock(healthMutex_);
    if (!health_) health_ = std::move(health);
}

void MqttPublisher::setStatus(bool connected, const std::string& error)
{
    std::lock_guard lock(statusMutex_);
    connected_ = connected;
    if (!error.empty()) lastError_ = error;
}

void MqttPublisher::run(std::stop_token stop)
{
    logger()->info("plant link to {} as '{}' (client id '{}', QoS {}): publishing on hullgauge/{}/#", config_.url,
                   config_.stationId, config_.clientId, config_.qos, config_.stationId);
    std::unique_ptr<ResultOutbox> outbox;
    while (!stop.stop_requested()) {
        try {
            if (!outbox) outbox = std::make_unique<ResultOutbox>(database_);
            serve(*outbox, stop);
        } catch (const std::exception& e) {
            // A store that cannot be read now may be readable at the next attempt; the cycles go on.
            logger()->error("plant link: {}", e.what());
            setStatus(false, e.what());
            outbox.reset();
        }
        waitBeforeRetry(outbox.get(), stop);
    }
}

void MqttPublisher::waitBeforeRetry(ResultOutbox* outbox, std::stop_token stop)
{
    std::unique_lock lock(mutex_);
    if (stop.stop_requested()) return;
    logger()->info("plant link: next attempt in {:.1f} s", retry_.count() / 1000.0);
    // On the publisher's clock (a test moves it by hand), in slices, so `ctl status` sees the
    // results that wait pile up while the broker is away.
    const auto until = clock_.now() + retry_;
    while (!stop.stop_requested() && clock_.now() < until) {
        clock_.waitUntil(lock, wake_, std::min(until, clock_.now() + std::chrono::milliseconds(500)),
                         [&] { return stop.stop_requested(); });
        try {
            if (outbox) pending_ = outbox->pendingCount();
        } catch (const FaultError&) {
            // Counted again at the next slice or attempt.
        }
    }
    retry_ = std::min(retry_ * 2, config_.retryMax);
}

// One session, from the connection attempt to its loss or the daemon's stop.
void MqttPublisher::serve(ResultOutbox& outbox, std::stop_token stop)
{
    Session session(config_, clock_);
    // Counted once in full, then only the new results (the ids above the last one counted).
    counters_ += outbox.countAfter(counted_, counted_);
    pending_ = outbox.pendingCount();
    const auto answerBy = clock_.now() + std::chrono::seconds(std::max(10, config_.keepaliveS));
    bool connected = false;
    auto countedPendingAt = clock_.now();
    PublishedMarks marks(clock_, config_.retryMin, config_.retryMax);
    ++attempts_;
    bool ok = session.start();
    while (ok && !stop.stop_requested()) {
        const int rc = mosquitto_loop(session.client, kLoopMs, 1);
        if (!session.failure.empty()) break;
        if (rc != MOSQ_ERR_SUCCESS) {
            session.failure = (connected ? "connection to " : "cannot connect to ") + config_.url +
                              (connected ? " lost: " : ": ") + describeError(rc);
            break;
        }
        if (!session.connected) {
            if (clock_.now() > answerBy)
                session.failure = "no answer from " + config_.url + " within " +
                                  std::to_string(std::max(10, config_.keepaliveS)) + " s (a TLS or proxy problem?)";
            ok = session.failure.empty();
            continue;
        }
        if (!connected) {
            connected = true;
            retry_ = config_.retryMin;
            setStatus(true, {});
            logger()->info("connected to {}; {} results waiting in the outbox", config_.url, pending_.load());
        }
        marks.mark(outbox, session);
        counters_ += outbox.countAfter(counted_, counted_);
        ok = publishLatest(session, state_(), counters_) && sendWaiting(session, outbox);
        // The station's health: retained, the newest only (docs/mqtt.md, topic `health`).
        if (auto health = ok ? takeHealth() : std::nullopt) {
            ok = session.publish(config_.topic("health"), healthMessage(*health, config_.stationId), true);
            if (!ok) keepHealth(std::move(*health));
        }
        // For `ctl status`: counted twice a second, not at every turn (a long backlog costs a scan).
        if (clock_.now() - countedPendingAt > std::chrono::milliseconds(500)) {
            pending_ = outbox.pendingCount();
            countedPendingAt = clock_.now();
        }
    }
    if (session.connected && session.failure.empty()) sayGoodbye(session, outbox);
    try {
        markAcknowledged(outbox, session);
    } catch (const FaultError& e) {
        logger()->warn("plant link: {} (those results are sent again)", e.what());
    }
    if (!session.failure.empty()) {
        logger()->error("plant link: {}", session.failure);
        setStatus(false, session.failure);
    } else {
        setStatus(false, {});
    }
}

} // namespace hg::daemon
