// The `mqtt` section of hullgauged.yaml (docs/mqtt.md): a complete section
// loads with its values, the defaults follow the URL's scheme, and every bad
// value is refused naming file, line and key — a secret open to its group or
// to others naming the file and its mode.
#include "daemon_config.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/common/error.h"

#include <cstdlib>
#include <gtest/gtest.h>

namespace hg::station {
namespace {

namespace fs = std::filesystem;

const char* kBase = R"(station: station.yaml
programs:
  1: {part: block.yaml, views: views.yaml}
results: {database: r.db, images: img}
)";

struct Fixture {
    hgtest::TempDir dir;
    Fixture()
    {
        hgtest::writeFile(dir / "station.yaml", hgtest::stationYaml({.sections = "lamps: {backend: sim}\n"}));
        hgtest::writeFile(dir / "block.yaml", "part: block\nmesh: block.stl\n"
                                              "landmarks:\n  - {id: c1, position: [0, 0, 10], tolerance_mm: 0.2}\n");
        hgtest::writeFile(dir / "views.yaml", "- {rotation_deg: 0, declination_deg: 30}\n");
        hgtest::writeFile(dir / "ca.pem", "ca");
        hgtest::writeFile(dir / "client.pem", "cert");
        secret("client.key", "key");
        secret("password", "s3cret\n");
    }
    fs::path secret(const std::string& name, const std::string& text, fs::perms mode = fs::perms::owner_read)
    {
        auto file = hgtest::writeFile(dir / name, text);
        fs::permissions(file, mode);
        return file;
    }
    MqttConfig load(const std::string& section)
    {
        return loadDaemonConfig(hgtest::writeFile(dir / "hullgauged.yaml", std::string(kBase) + section)).mqtt;
    }
    std::string error(const std::string& section)
    {
        try {
            load(section);
        } catch (const InputError& e) {
            return e.what();
        }
        return {};
    }
};

TEST(MqttConfig, LoadsEveryKey)
{
    Fixture f;
    const auto mqtt = f.load("mqtt:\n"
                             "  url: mqtts://broker.plant:8884\n"
                             "  station_id: line-3.gauge_1\n"
                             "  client_id: gauge-1\n"
                             "  qos: 2\n"
                             "  keepalive_s: 15\n"
                             "  tls: {ca_file: ca.pem, cert_file: client.pem, key_file: client.key}\n"
                             "  username: gauge\n"
                             "  password_file: password\n"
                             "  retry_min_s: 0.5\n"
                             "  retry_max_s: 4\n"
                             "  max_inflight: 5\n");
    EXPECT_TRUE(mqtt.enabled);
    EXPECT_TRUE(mqtt.tls);
    EXPECT_EQ(mqtt.host, "broker.plant");
    EXPECT_EQ(mqtt.port, 8884);
    EXPECT_EQ(mqtt.stationId, "line-3.gauge_1");
    EXPECT_EQ(mqtt.clientId, "gauge-1");
    EXPECT_EQ(mqtt.qos, 2);
    EXPECT_EQ(mqtt.keepaliveS, 15);
    EXPECT_EQ(mqtt.caFile, f.dir.path() / "ca.pem");
    EXPECT_EQ(mqtt.certFile, f.dir.path() / "client.pem");
    EXPECT_EQ(mqtt.keyFile, f.dir.path() / "client.key");
    EXPECT_EQ(mqtt.username, "gauge");
    EXPECT_EQ(mqtt.password, "s3cret");
    EXPECT_EQ(mqtt.retryMin, std::chrono::milliseconds(500));
    EXPECT_EQ(mqtt.retryMax, std::chrono::milliseconds(4000));
    EXPECT_EQ(mqtt.maxInflight, 5);
    EXPECT_EQ(mqtt.topic("result"), "hullgauge/line-3.gauge_1/result");
}

TEST(MqttConfig, DefaultsFollowTheScheme)
{
    Fixture f;
    EXPECT_FALSE(f.load("").enabled);
    auto plain = f.load("mqtt: {url: 'mqtt://10.0.0.5', station_id: g1}\n");
    EXPECT_FALSE(plain.tls);
    EXPECT_EQ(plain.host, "10.0.0.5");
    EXPECT_EQ(plain.port, 1883);
    EXPECT_EQ(plain.clientId, "hullgauge-g1");
    EXPECT_EQ(plain.qos, 1);
    EXPECT_EQ(plain.keepaliveS, 30);
    EXPECT_TRUE(plain.username.empty());
    EXPECT_TRUE(plain.password.empty());
    auto secure = f.load("mqtt: {url: 'mqtts://[fd00::7]', station_id: g1}\n");
    EXPECT_TRUE(secure.tls);
    EXPECT_EQ(secure.host, "fd00::7");
    EXPECT_EQ(secure.port, 8883);
    EXPECT_TRUE(secure.caFile.empty()); // the system's CAs
}

TEST(MqttConfig, BadValuesNameFileLineAndKey)
{
    Fixture f;
    struct Case {
        std::string section, expect;
    };
    const Case cases[] = {
        {"mqtt: {url: 'http://h:1883', station_id: g}\n", "hullgauged.yaml:5: mqtt.url: expected mqtt://HOST[:PORT]"},
        {"mqtt: {url: 'mqtt://h:0', station_id: g}\n", "mqtt.url: the port in 'mqtt://h:0' is not a number"},
        {"mqtt: {url: 'mqtt://h:99999', station_id: g}\n", "mqtt.url: the port"},
        {"mqtt: {url: 'mqtt://h:', station_id: g}\n", "mqtt.url: the port"},
        {"mqtt: {url: 'mqtt://', station_id: g}\n", "mqtt.url: expected"},
        {"mqtt: {url: 'mqtt://u@h', station_id: g}\n", "mqtt.url: expected"},
        {"mqtt: {station_id: g}\n", "hullgauged.yaml:5: mqtt: missing required key 'url'"},
        {"mqtt: {url: 'mqtt://h'}\n", "mqtt: missing required key 'station_id'"},
        {"mqtt: {url: 'mqtt://h', station_id: 'a/b'}\n", "mqtt.station_id: expected 1 to 64 of the characters"},
        {"mqtt: {url: 'mqtt://h', station_id: 'a+'}\n", "mqtt.station_id"},
        {"mqtt: {url: 'mqtt://h', station_id: '#'}\n", "mqtt.station_id"},
        {"mqtt: {url: 'mqtt://h', station_id: g, qos: 0}\n", "mqtt.qos: QoS 0 is never acknowledged"},
        {"mqtt: {url: 'mqtt://h', station_id: g, qos: 3}\n", "mqtt.qos"},
        {"mqtt: {url: 'mqtt://h', station_id: g, keepalive_s: 1}\n", "mqtt.keepalive_s"},
        {"mqtt: {url: 'mqtt://h', station_id: g, tls: {ca_file: ca.pem}}\n", "mqtt.tls: tls needs an mqtts:// url"},
        {"mqtt: {url: 'mqtts://h', station_id: g, tls: {cert_file: client.pem}}\n",
         "mqtt.tls: give cert_file and key_file together"},
        {"mqtt: {url: 'mqtts://h', station_id: g, tls: {ca_file: none.pem}}\n", "mqtt.tls.ca_file: no such file"},
        {"mqtt: {url: 'mqtts://h', station_id: g, tls: {cafile: ca.pem}}\n", "cafile"},
        {"mqtt: {url: 'mqtt://h', station_id: g, password_file: password}\n", "a password needs a username"},
        {"mqtt: {url: 'mqtt://h', station_id: g, username: u, password_file: password, password_credential: p}\n",
         "mqtt.password_credential: give password_file or password_credential, not both"},
        {"mqtt: {url: 'mqtt://h', station_id: g, retry_min_s: 5, retry_max_s: 1}\n",
         "mqtt.retry_max_s: must not be below retry_min_s"},
        {"mqtt: {url: 'mqtt://h', station_id: g, max_inflight: 0}\n", "mqtt.max_inflight"},
        {"mqtt: {url: 'mqtt://h', station_id: g, subscribe: ['#']}\n", "subscribe"},
        {"mqtt: mqtt://h\n", "hullgauged.yaml:5: mqtt: expected a map"},
    };
    for (const auto& c : cases) {
        auto message = f.error(c.section);
        EXPECT_NE(message.find(c.expect), std::string::npos) << c.section << " -> " << message;
        EXPECT_NE(message.find("hullgauged.yaml"), std::string::npos) << message;
    }
}

TEST(MqttConfig, SecretsOpenToGroupOrOthersAreRefusedNamingTheFile)
{
    Fixture f;
    const auto key = f.secret("open.key", "key", fs::perms::owner_read | fs::perms::group_read);
    auto message = f.error("mqtt:\n  url: mqtts://h\n  station_id: g\n"
                           "  tls: {cert_file: client.pem, key_file: open.key}\n");
    EXPECT_NE(message.find("hullgauged.yaml:8: mqtt.tls.key_file: " + key.string() +
                           " is open to its group or others (mode 0440)"),
              std::string::npos)
        << message;
    const auto password =
        f.secret("open-password", "pw\n", fs::perms::owner_read | fs::perms::owner_write | fs::perms::others_read);
    message = f.error("mqtt:\n  url: mqtt://h\n  station_id: g\n  username: u\n  password_file: open-password\n");
    EXPECT_NE(message.find("hullgauged.yaml:9: mqtt.password_file: " + password.string() +
                           " is open to its group or others (mode 0604)"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("chmod 600 " + password.string()), std::string::npos) << message;
    f.secret("empty-password", "\n");
    message = f.error("mqtt: {url: 'mqtt://h', station_id: g, username: u, password_file: empty-password}\n");
    EXPECT_NE(message.find("holds an empty password"), std::string::npos) << message;
}

TEST(MqttConfig, PasswordFromASystemdCredential)
{
    Fixture f;
    const char* saved = std::getenv("CREDENTIALS_DIRECTORY");
    const std::string restore = saved ? saved : "";
    ::unsetenv("CREDENTIALS_DIRECTORY");
    const std::string section = "mqtt: {url: 'mqtt://h', station_id: g, username: u, password_credential: mqtt-pw}\n";
    EXPECT_NE(f.error(section).find("mqtt.password_credential: $CREDENTIALS_DIRECTORY is not set"), std::string::npos);
    fs::create_directories(f.dir / "credentials");
    f.secret("credentials/mqtt-pw", "from-systemd\n");
    ::setenv("CREDENTIALS_DIRECTORY", (f.dir / "credentials").c_str(), 1);
    const auto mqtt = f.load(section);
    EXPECT_EQ(mqtt.password, "from-systemd");
    EXPECT_EQ(mqtt.passwordFrom, f.dir.path() / "credentials" / "mqtt-pw");
    if (saved)
        ::setenv("CREDENTIALS_DIRECTORY", restore.c_str(), 1);
    else
        ::unsetenv("CREDENTIALS_DIRECTORY");
}

} // namespace
} // namespace hg::station
