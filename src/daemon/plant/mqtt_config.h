// The `mqtt` section of hullgauged.yaml: the plant link (docs/mqtt.md). The
// broker's address, the station's id in the topics, the client's identity
// and its secrets. Every key is listed in docs/config-reference.md.
//
// Secrets are read when the configuration loads (at start, `--check` and
// SIGHUP), so a bad one is refused before the daemon runs: a password file or
// a client key readable by its group or by others is refused naming the file.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>

namespace hg {
class ConfigNode;
}

namespace hg::station {

struct MqttConfig {
    bool enabled = false; ///< the `mqtt` section is present
    std::string url;      ///< as written: mqtt://host[:port] or mqtts://host[:port]
    bool tls = false;     ///< mqtts://
    std::string host;
    int port = 1883; ///< 1883 for mqtt://, 8883 for mqtts:// unless the URL names one
    /// The station's name in the topics hullgauge/<station_id>/...: letters,
    /// digits, '-', '_' and '.'.
    std::string stationId;
    std::string clientId; ///< default hullgauge-<station_id>
    int qos = 1;          ///< 1 or 2: a result counts as published once the broker acknowledged it
    int keepaliveS = 30;
    /// TLS (mqtts:// only): the CA that signed the broker's certificate (empty:
    /// the system's CAs in /etc/ssl/certs) and the client's own certificate and
    /// key when the broker asks for one.
    std::filesystem::path caFile;
    std::filesystem::path certFile;
    std::filesystem::path keyFile;
    std::string username;
    std::string password;               ///< read from password_file or password_credential
    std::filesystem::path passwordFrom; ///< where the password was read (for messages)
    /// Reconnection after a refused or lost connection: the first wait, doubled
    /// up to the largest.
    std::chrono::milliseconds retryMin{1000};
    std::chrono::milliseconds retryMax{30000};
    /// Results sent and not yet acknowledged, at most.
    int maxInflight = 20;

    std::string topic(const std::string& leaf) const { return "hullgauge/" + stationId + "/" + leaf; }
    bool operator==(const MqttConfig&) const = default;
};

/// Parses the `mqtt` section; relative paths are relative to `base` (the
/// configuration file's folder). Throws hg::InputError naming file, line and key.
void parseMqtt(const ConfigNode& node, const std::filesystem::path& base, MqttConfig& mqtt);

} // namespace hg::station
