#include "plant/mqtt_config.h"

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/file_kind.h"

#include <cstdlib>
#include <fstream>
#include <sys/stat.h>

namespace hg::station {
namespace {

namespace fs = std::filesystem;

fs::path existingFile(const ConfigNode& node, const fs::path& base)
{
    const auto text = node.asString();
    if (text.empty()) node.fail("expected a path");
    const fs::path p = fs::path(text).is_absolute() ? fs::path(text) : (base / text).lexically_normal();
    if (auto problem = notARegularFile(p); !problem.empty()) node.fail(problem + ": " + p.string());
    return p;
}

/// A secret (a client key, a password) must be the daemon's alone: a file its
/// group or others may read is refused, naming it (docs/mqtt.md, "Security").
void requirePrivate(const ConfigNode& node, const fs::path& file)
{
    struct stat st {};
    if (::stat(file.c_str(), &st) != 0) node.fail("cannot read " + file.string());
    if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
        char mode[8];
        std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
        node.fail(file.string() + " is open to its group or others (mode " + mode +
                  "): a secret must be readable by the daemon's user only (chmod 600 " + file.string() + ")");
    }
}

std::string readPassword(const ConfigNode& node, const fs::path& file)
{
    requirePrivate(node, file);
    std::ifstream in(file);
    std::string password;
    if (!in || !std::getline(in, password)) node.fail("cannot read the password from " + file.string());
    if (!password.empty() && password.back() == '\r') password.pop_back();
    if (password.empty()) node.fail(file.string() + " holds an empty password");
    return password;
}

/// mqtt://host[:port], mqtts://host[:port]; host a name, an IPv4 address or [IPv6].
void parseUrl(const ConfigNode& node, MqttConfig& mqtt)
{
    mqtt.url = node.asString();
    const std::string expected = "expected mqtt://HOST[:PORT] or mqtts://HOST[:PORT], not '" + mqtt.url + "'";
    std::string rest;
    if (mqtt.url.rfind("mqtt://", 0) == 0) {
        rest = mqtt.url.substr(7);
    } else if (mqtt.url.rfind("mqtts://", 0) == 0) {
        rest = mqtt.url.substr(8);
        mqtt.tls = true;
        mqtt.port = 8883;
    } else {
        node.fail(expected);
    }
    if (!rest.empty() && rest.back() == '/') rest.pop_back();
    std::string port;
    bool portGiven = false;
    if (!rest.empty() && rest.front() == '[') {
        const auto close = rest.find(']');
        if (close == std::string::npos) node.fail(expected);
        mqtt.host = rest.substr(1, close - 1);
        if (close + 1 < rest.size()) {
            if (rest[close + 1] != ':') node.fail(expected);
            port = rest.substr(close + 2);
            portGiven = true;
        }
    } else {
        const auto colon = rest.find(':');
        mqtt.host = rest.substr(0, colon);
        if (colon != std::string::npos) port = rest.substr(colon + 1);
        portGiven = colon != std::string::npos;
    }
    if (mqtt.host.empty() || mqtt.host.find_first_of("/@?# ") != std::string::npos) node.fail(expected);
    if (portGiven) {
        if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
            std::stoi(port) < 1 || std::stoi(port) > 65535)
            node.fail("the port in '" + mqtt.url + "' is not a number 1..65535");
        mqtt.port = std::stoi(port);
    }
}

void parseTls(const ConfigNode& node, const fs::path& base, MqttConfig& mqtt)
{
    node.allowOnlyKeys({"ca_file", "cert_file", "key_file"});
    if (auto n = node.optional("ca_file")) mqtt.caFile = existingFile(*n, base);
    if (auto n = node.optional("cert_file")) mqtt.certFile = existingFile(*n, base);
    if (auto n = node.optional("key_file")) {
        mqtt.keyFile = existingFile(*n, base);
        requirePrivate(*n, mqtt.keyFile);
    }
    if (mqtt.certFile.empty() != mqtt.keyFile.empty())
        node.fail("give cert_file and key_file together (the client's certificate and its key)");
}

void parseSecrets(const ConfigNode& node, const fs::path& base, MqttConfig& mqtt)
{
    if (auto n = node.optional("username")) mqtt.username = n->asString();
    if (node.has("password_file") && node.has("password_credential"))
        node["password_credential"].fail("give password_file or password_credential, not both");
    if (auto n = node.optional("password_file")) {
        mqtt.passwordFrom = existingFile(*n, base);
        mqtt.password = readPassword(*n, mqtt.passwordFrom);
    }
    // systemd's LoadCredential= puts the file in $CREDENTIALS_DIRECTORY, the unit's own.
    if (auto n = node.optional("password_credential")) {
        const char* dir = std::getenv("CREDENTIALS_DIRECTORY");
        if (!dir) n->fail("$CREDENTIALS_DIRECTORY is not set (the unit's LoadCredential= provides it)");
        mqtt.passwordFrom = fs::path(dir) / n->asString();
        mqtt.password = readPassword(*n, mqtt.passwordFrom);
    }
    if (!mqtt.password.empty() && mqtt.username.empty())
        node.fail("a password needs a username (MQTT sends no password without one)");
}

} // namespace

void parseMqtt(const ConfigNode& node, const fs::path& base, MqttConfig& mqtt)
{
    if (!node.isMap()) node.fail("expected a map: {url: mqtt://HOST:PORT, station_id: NAME, ...}");
    node.allowOnlyKeys({"url", "station_id", "client_id", "qos", "keepalive_s", "tls", "username", "password_file",
                        "password_credential", "retry_min_s", "retry_max_s", "max_inflight"});
    mqtt = MqttConfig{};
    mqtt.enabled = true;
    parseUrl(node["url"], mqtt);
    auto station = node["station_id"];
    mqtt.stationId = station.asString();
    // The id is one topic level: no separators or wildcards, nothing a receiver must escape.
    if (mqtt.stationId.empty() || mqtt.stationId.size() > 64 ||
        mqtt.stationId.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_.") !=
            std::string::npos)
        station.fail("expected 1 to 64 of the characters A-Z a-z 0-9 - _ . (one topic level), not '" + mqtt.stationId +
                     "'");
    mqtt.clientId = "hullgauge-" + mqtt.stationId;
    if (auto n = node.optional("client_id")) {
        mqtt.clientId = n->asString();
        if (mqtt.clientId.empty() || mqtt.clientId.size() > 128) n->fail("expected 1 to 128 characters");
    }
    if (auto n = node.optional("qos")) {
        mqtt.qos = static_cast<int>(n->asIntIn(0, 2));
        // QoS 0 has no acknowledgement: the outbox could never know a result arrived.
        if (mqtt.qos == 0) n->fail("QoS 0 is never acknowledged, so results could be lost: use 1 (or 2)");
    }
    if (auto n = node.optional("keepalive_s")) mqtt.keepaliveS = static_cast<int>(n->asIntIn(5, 3600));
    if (auto n = node.optional("tls")) {
        if (!mqtt.tls) n->fail("tls needs an mqtts:// url");
        parseTls(*n, base, mqtt);
    }
    parseSecrets(node, base, mqtt);
    const auto ms = [](const ConfigNode& n, double lo, double hi) {
        return std::chrono::milliseconds(static_cast<long long>(n.asDoubleIn(lo, hi) * 1000.0 + 0.5));
    };
    if (auto n = node.optional("retry_min_s")) mqtt.retryMin = ms(*n, 0.1, 60.0);
    if (auto n = node.optional("retry_max_s")) mqtt.retryMax = ms(*n, 0.1, 3600.0);
    if (mqtt.retryMax < mqtt.retryMin) {
        if (!node.has("retry_max_s")) node["retry_min_s"].fail("must not exceed retry_max_s (default 30)");
        node["retry_max_s"].fail("must not be below retry_min_s");
    }
    if (auto n = node.optional("max_inflight")) mqtt.maxInflight = static_cast<int>(n->asIntIn(1, 1000));
}

} // namespace hg::station
