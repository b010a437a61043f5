// The daemon configuration: a complete file loads with its values; every kind
// of bad value is refused naming file, line and key.
#include "daemon_config.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/calib/flat_field.h"
#include "hullgauge/common/error.h"

#include <gtest/gtest.h>

namespace hg::station {
namespace {

const std::string kStation = hgtest::stationYaml({.sections = "lamps: {backend: sim}\n"});

const char* kPart = R"(part: block
mesh: block.stl
landmarks:
  - {id: c1, position: [0, 0, 10], tolerance_mm: 0.2}
)";

const char* kDaemon = R"(station: station.yaml
programs:
  1: {part: block.yaml, views: views.yaml}
  12: {part: block.yaml, views: views.yaml}
plc:
  bind: 127.0.0.1
  port: 1502
  unit_id: 3
  allowed_clients: [127.0.0.1, 10.1.0.0/16]
  heartbeat_period_s: 0.25
results:
  database: data/results.db
  images: /var/tmp/hg-images
  archive_all: true
  retention: {max_count: 50, max_age_days: 2, max_bytes: 1.0e6}
sequencer: {move_timeout_s: 4, grab_timeout_s: 0.5, settle_s: 0.02, retries: 1}
maintenance: {socket: run/hg.sock, group: hullgauge}
watchdog: {max_cycle_s: 30}
)";

using hgtest::replaced;

struct Fixture {
    hgtest::TempDir dir;
    Fixture()
    {
        hgtest::writeFile(dir / "station.yaml", kStation);
        hgtest::writeFile(dir / "block.yaml", kPart);
        hgtest::writeFile(dir / "views.yaml", "- {rotation_deg: 0, declination_deg: 30}\n"
                                              "- {rotation_deg: 90, declination_deg: 30}\n");
    }
    std::string error(const std::string& daemonText)
    {
        auto file = hgtest::writeFile(dir / "hullgauged.yaml", daemonText);
        try {
            loadDaemonConfig(file);
        } catch (const InputError& e) {
            return e.what();
        }
        return {};
    }
};

TEST(DaemonConfig, LoadsAllSections)
{
    Fixture f;
    auto cfg = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml", kDaemon));
    EXPECT_EQ(cfg.stationFile, f.dir.path() / "station.yaml");
    ASSERT_EQ(cfg.programs.size(), 2u);
    EXPECT_EQ(cfg.programs.at(12).views.size(), 2u);
    EXPECT_DOUBLE_EQ(cfg.programs.at(12).views[1].rotationDeg, 90.0);
    EXPECT_EQ(cfg.plc.bindAddress, "127.0.0.1");
    EXPECT_EQ(cfg.plc.port, 1502);
    EXPECT_EQ(cfg.plc.unitId, 3);
    ASSERT_EQ(cfg.plc.allowedClients.size(), 2u);
    EXPECT_TRUE(cfg.plc.allowedClients[1].contains(0x0A01FE07));  // 10.1.254.7
    EXPECT_FALSE(cfg.plc.allowedClients[1].contains(0x0A020001)); // 10.2.0.1
    EXPECT_EQ(cfg.plc.heartbeatPeriod, std::chrono::milliseconds(250));
    EXPECT_EQ(cfg.results.database, f.dir.path() / "data/results.db");
    EXPECT_EQ(cfg.results.imageDir, "/var/tmp/hg-images");
    EXPECT_TRUE(cfg.results.archiveAll);
    EXPECT_EQ(cfg.results.retention.maxCount, 50u);
    EXPECT_EQ(cfg.results.retention.maxAge, std::chrono::hours(48));
    EXPECT_EQ(cfg.results.retention.maxBytes, 1'000'000u);
    EXPECT_EQ(cfg.sequencer.grabTimeout, std::chrono::milliseconds(500));
    EXPECT_EQ(cfg.sequencer.settle, std::chrono::milliseconds(20));
    EXPECT_EQ(cfg.maintenance.socket, f.dir.path() / "run/hg.sock");
    EXPECT_EQ(cfg.maintenance.group, "hullgauge");
    EXPECT_EQ(cfg.watchdog.maxCycle, std::chrono::seconds(30));
}

TEST(DaemonConfig, DefaultsFollowTheContract)
{
    Fixture f;
    auto cfg = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml",
                                                  "station: station.yaml\n"
                                                  "programs: {1: {part: block.yaml, views: views.yaml}}\n"
                                                  "results: {database: r.db, images: img}\n"));
    EXPECT_EQ(cfg.plc.port, 502); // docs/contracts.md §6
    EXPECT_EQ(cfg.plc.unitId, 1); // docs/contracts.md §6
    EXPECT_TRUE(cfg.plc.allowedClients.empty());
    EXPECT_LE(cfg.plc.heartbeatPeriod, std::chrono::milliseconds(1000));
    EXPECT_EQ(cfg.sequencer.retries, 1);
    EXPECT_EQ(cfg.lampsSection, "lamps");
    EXPECT_TRUE(cfg.results.saveFailedImages);
    EXPECT_FALSE(cfg.results.archiveAll);
    EXPECT_EQ(cfg.segmentation.method, vision::SegmentationMethod::Otsu);
    EXPECT_TRUE(cfg.segmentation.objectIsDark);
}

TEST(DaemonConfig, StationSegmentationIsReadAtLoadAndNamedWhenBad)
{
    Fixture f;
    hgtest::writeFile(f.dir / "station.yaml", kStation + "segmentation: {method: fixed, threshold: 40}\n");
    auto cfg = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml", kDaemon));
    EXPECT_EQ(cfg.segmentation.method, vision::SegmentationMethod::Fixed);
    EXPECT_EQ(cfg.segmentation.threshold, 40.0);
    // Named at the section's line (`hullgauged --check` exits 2 with this).
    const std::string text = kStation + "segmentation: {method: fixed}\n";
    hgtest::writeFile(f.dir / "station.yaml", text);
    auto message = f.error(kDaemon);
    const std::string where = "station.yaml:" + std::to_string(hgtest::lineOf(text, "segmentation:")) + ": ";
    EXPECT_NE(message.find(where + "segmentation: threshold: missing"), std::string::npos) << message;
}

TEST(DaemonConfig, BadValuesNameFileLineAndKey)
{
    Fixture f;
    struct Case {
        std::string from, to, expect;
    };
    const Case cases[] = {
        {"port: 1502", "port: 70000", "hullgauged.yaml:7: plc.port"},
        {"unit_id: 3", "unit_id: -1", "plc.unit_id"},
        {"10.1.0.0/16", "10.1.0.0/33", "plc.allowed_clients[1]"},
        {"10.1.0.0/16", "example.com", "plc.allowed_clients[1]"},
        {"bind: 127.0.0.1", "bind: localhost", "plc.bind"},
        {"heartbeat_period_s: 0.25", "heartbeat_period_s: 2", "plc.heartbeat_period_s"},
        {"  12: {part", "  0: {part", "programs.0"},
        {"  12: {part", "  x1: {part", "programs.x1"},
        {"12: {part: block.yaml", "12: {part: missing.yaml", "no such file"},
        {"retries: 1", "retries: 9", "sequencer.retries"},
        {"grab_timeout_s: 0.5", "grab_timeout_s: -1", "sequencer.grab_timeout_s"},
        {"max_cycle_s: 30", "max_cycel_s: 30", "max_cycel_s"},
        {"station: station.yaml", "station: nowhere.yaml", "station"},
        {"archive_all: true", "archive_all: sometimes", "hullgauged.yaml:14: results.archive_all"},
    };
    for (const auto& c : cases) {
        auto message = f.error(replaced(kDaemon, c.from, c.to));
        EXPECT_NE(message.find(c.expect), std::string::npos) << c.to << " -> " << message;
        EXPECT_NE(message.find("hullgauged.yaml"), std::string::npos) << message;
    }
}

// docs/health.md, "In the daemon": the `health` section, its defaults (vision::HealthLimits),
// every bad value named with file, line and key, and the reference file beside the station file.
TEST(DaemonConfig, TheHealthSectionItsDefaultsAndItsRefusals)
{
    Fixture f;
    auto defaults = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml", kDaemon));
    EXPECT_TRUE(defaults.health.enabled);
    EXPECT_EQ(defaults.health.reference, f.dir.path() / "flat-field.json");
    EXPECT_FALSE(defaults.health.referenceRead);
    EXPECT_EQ(defaults.health.limits.minBacklight, 0.80);
    EXPECT_EQ(defaults.health.limits.maxNoise, 0.02);
    EXPECT_EQ(defaults.health.limits.maxEdgeBiasPx, 0.25);
    EXPECT_EQ(defaults.health.limits.maxCapability, 0.9);

    const std::string text = kDaemon + std::string("health:\n"
                                                   "  enabled: false\n"
                                                   "  reference: refs/ff.json\n"
                                                   "  limits: {min_backlight: 0.7, max_uniformity: 0.2, "
                                                   "max_dust_specks: 12, max_edge_width_px: 2.5, min_contrast: 0.3, "
                                                   "max_noise: 0.03, max_edge_bias_px: 0.4, max_capability: 0.75}\n");
    auto cfg = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml", text));
    EXPECT_FALSE(cfg.health.enabled);
    EXPECT_EQ(cfg.health.reference, f.dir.path() / "refs/ff.json");
    const auto& l = cfg.health.limits;
    EXPECT_EQ(l.minBacklight, 0.7);
    EXPECT_EQ(l.maxUniformity, 0.2);
    EXPECT_EQ(l.maxDustSpecks, 12.0);
    EXPECT_EQ(l.maxEdgeWidthPx, 2.5);
    EXPECT_EQ(l.minContrast, 0.3);
    EXPECT_EQ(l.maxNoise, 0.03);
    EXPECT_EQ(l.maxEdgeBiasPx, 0.4);
    EXPECT_EQ(l.maxCapability, 0.75);

    const int line = hgtest::lineOf(text, "  limits:");
    struct Case {
        std::string from, to, expect;
    };
    const Case cases[] = {
        {"min_backlight: 0.7", "min_backlight: 1.5",
         "hullgauged.yaml:" + std::to_string(line) + ": health.limits.min_backlight"},
        {"max_noise: 0.03", "max_noise: loud", "health.limits.max_noise"},
        {"max_edge_bias_px: 0.4", "max_edge_bias_px: -0.4", "health.limits.max_edge_bias_px"},
        {"max_capability: 0.75", "max_capability: 0", "health.limits.max_capability"},
        {"max_edge_width_px: 2.5", "max_edge_width_px: 0", "health.limits.max_edge_width_px"},
        {"max_dust_specks: 12", "max_dust: 12", "max_dust"},
        {"enabled: false", "enabled: perhaps", "health.enabled"},
        {"  reference: refs/ff.json", "  referense: refs/ff.json", "referense"},
    };
    for (const auto& c : cases) {
        auto message = f.error(replaced(text, c.from, c.to));
        EXPECT_NE(message.find(c.expect), std::string::npos) << c.to << " -> " << message;
        EXPECT_NE(message.find("hullgauged.yaml"), std::string::npos) << message;
    }

    // A reference there is read; one of another sensor than the station's camera (640 x 480) is refused.
    const std::vector<cv::Mat> frames(2, cv::Mat(480, 640, CV_8UC1, cv::Scalar(230)));
    calib::writeFlatField(f.dir / "flat-field.json", vision::buildFlatField(frames, 1'800'000'000'000));
    auto read = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml", kDaemon));
    ASSERT_TRUE(read.health.referenceRead);
    EXPECT_EQ(read.health.referenceRead->takenUnixMs, 1'800'000'000'000);
    EXPECT_EQ(read.health.referenceSha256.size(), 64u);
    const std::vector<cv::Mat> small(2, cv::Mat(240, 320, CV_8UC1, cv::Scalar(230)));
    calib::writeFlatField(f.dir / "flat-field.json", vision::buildFlatField(small, 1'800'000'000'000));
    auto message = f.error(kDaemon);
    EXPECT_NE(message.find("flat-field.json"), std::string::npos) << message;
    EXPECT_NE(message.find("320 x 240"), std::string::npos) << message;
    EXPECT_NE(message.find("640 x 480"), std::string::npos) << message;
    // A file that is no reference at all is refused naming it.
    hgtest::writeFile(f.dir / "flat-field.json", "not a reference\n");
    message = f.error(kDaemon);
    EXPECT_NE(message.find("flat-field.json"), std::string::npos) << message;
}

TEST(DaemonConfig, ViewPlanIsCheckedAgainstTheFixture)
{
    Fixture f;
    hgtest::writeFile(f.dir / "views.yaml", "- {rotation_deg: 0, declination_deg: 75}\n"); // range is [0, 60]
    auto message = f.error(kDaemon);
    EXPECT_NE(message.find("views.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find("declination"), std::string::npos) << message;
}

TEST(DaemonConfig, SimulatedPartsNeedNominalAndExistingMeshes)
{
    Fixture f;
    hgtest::writeFile(f.dir / "nominal.stl", "solid n\nendsolid n\n");
    auto cfg = loadDaemonConfig(
        hgtest::writeFile(f.dir / "hullgauged.yaml",
                          std::string(kDaemon) + "simulation: {parts: {nominal: nominal.stl, dented: nominal.stl}}\n"));
    ASSERT_EQ(cfg.simulatedParts.size(), 2u);
    EXPECT_EQ(cfg.simulatedParts[1].first, "dented");
    EXPECT_EQ(cfg.simulatedParts[0].second, f.dir.path() / "nominal.stl");
    auto noNominal = f.error(std::string(kDaemon) + "simulation: {parts: {dented: nominal.stl}}\n");
    EXPECT_NE(noNominal.find("simulation.parts"), std::string::npos) << noNominal;
    EXPECT_NE(noNominal.find("nominal"), std::string::npos) << noNominal;
    auto missing = f.error(std::string(kDaemon) + "simulation: {parts: {nominal: gone.stl}}\n");
    EXPECT_NE(missing.find("simulation.parts.nominal"), std::string::npos) << missing;
    // `none` is the empty fixture's name (docs/camera.md, "The empty fixture").
    auto none = f.error(std::string(kDaemon) + "simulation: {parts: {nominal: nominal.stl, none: nominal.stl}}\n");
    EXPECT_NE(none.find("simulation.parts.none: 'none' names the empty fixture"), std::string::npos) << none;
}

TEST(DaemonConfig, SimulatedSeatingIsOptionalAndBounded)
{
    Fixture f;
    hgtest::writeFile(f.dir / "nominal.stl", "solid n\nendsolid n\n");
    const std::string parts = "simulation:\n  parts: {nominal: nominal.stl}\n";
    auto exact = loadDaemonConfig(hgtest::writeFile(f.dir / "hullgauged.yaml", std::string(kDaemon) + parts));
    EXPECT_FALSE(exact.simulatedSeating); // absent: seated exactly as drawn
    auto cfg = loadDaemonConfig(
        hgtest::writeFile(f.dir / "hullgauged.yaml",
                          std::string(kDaemon) + parts + "  seating: {shift_mm: 0.3, rotation_deg: 0.25, seed: 7}\n"));
    ASSERT_TRUE(cfg.simulatedSeating);
    EXPECT_DOUBLE_EQ(cfg.simulatedSeating->shiftMm, 0.3);
    EXPECT_DOUBLE_EQ(cfg.simulatedSeating->rotationDeg, 0.25);
    EXPECT_EQ(cfg.simulatedSeating->seed, 7u);
    auto unseeded = loadDaemonConfig(hgtest::writeFile(
        f.dir / "hullgauged.yaml", std::string(kDaemon) + parts + "  seating: {shift_mm: 0, rotation_deg: 1}\n"));
    EXPECT_EQ(unseeded.simulatedSeating->seed, 1u);

    for (const auto& [seating, expected] : std::vector<std::pair<std::string, std::string>>{
             {"{shift_mm: -0.1, rotation_deg: 0.3}", "simulation.seating.shift_mm: value -0.1 is outside [0, 10]"},
             {"{shift_mm: 0.3, rotation_deg: 11}", "simulation.seating.rotation_deg: value 11 is outside [0, 10]"},
             {"{shift_mm: 0.3}", "missing required key 'rotation_deg'"},
             {"{shift_mm: 0.3, rotation_deg: 0.3, play: 1}", "simulation.seating.play: unknown key"},
             {"0.3", "simulation.seating: expected {shift_mm"},
         }) {
        auto message = f.error(std::string(kDaemon) + parts + "  seating: " + seating + "\n");
        EXPECT_NE(message.find(expected), std::string::npos) << seating << ": " << message;
    }
}

TEST(DaemonConfig, Ipv4Networks)
{
    auto n = parseIpv4Network("192.168.10.0/24");
    ASSERT_TRUE(n);
    EXPECT_TRUE(n->contains(0xC0A80A63));  // 192.168.10.99
    EXPECT_FALSE(n->contains(0xC0A80B01)); // 192.168.11.1
    EXPECT_EQ(fmt::format("{}", *n), "192.168.10.0/24");
    auto any = parseIpv4Network("0.0.0.0/0");
    ASSERT_TRUE(any);
    EXPECT_TRUE(any->contains(0x01020304));
    EXPECT_FALSE(parseIpv4Network("1.2.3"));
    EXPECT_FALSE(parseIpv4Network("1.2.3.4/"));
    EXPECT_FALSE(parseIpv4Network("1.2.3.4/-1"));
}

} // namespace
} // namespace hg::station
