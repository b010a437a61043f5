#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/calib/station_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"

using namespace hg::calib;

namespace {

// A station with a comment, camera and lamp sections and a limited turntable:
// what a rewrite must keep.
const std::string kStation =
    "# station of line 3\n" + hgtest::stationYaml({.focalPx = 500,
                                                   .cameraKeys = "  pixel_size_um: [3.45, 3.45]\n"
                                                                 "  driver: {backend: sim}\n",
                                                   .distanceMm = 400,
                                                   .rotationRangeDeg = {-170, 170},
                                                   .floorZMm = -5.5,
                                                   .sections = "lamps: {backend: sim, green: G, amber: A, red: R}\n"});

std::string readText(const std::filesystem::path& p)
{
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

IntrinsicsResult sampleResult()
{
    IntrinsicsResult r;
    r.intrinsics.K << 812.5, 0, 330.25, 0, 811.0, 241.5, 0, 0, 1;
    r.intrinsics.dist = {-0.2, 0.05, 0.001, -0.002, 0.01};
    r.intrinsics.imageSize = cv::Size(640, 480);
    r.rmsPx = 0.21;
    r.viewNames = {"a", "b", "c"};
    r.stdDev = {0.5, 0.5, 0.3, 0.3, 0.001, 0.002, 0.0001, 0.0001, 0.003};
    return r;
}

} // namespace

TEST(StationFile, IntrinsicsRewriteKeepsOtherKeysAndMakesABackup)
{
    hgtest::TempDir dir;
    auto file = hgtest::writeFile(dir / "station.yaml", kStation);
    StationFileUpdate update(file);
    update.setIntrinsics(sampleResult(), "chessboard:9x6:25");
    auto backup = update.commit();

    ASSERT_TRUE(backup.has_value());
    EXPECT_EQ(readText(*backup), kStation); // the old file, comment and all
    auto station = hg::geometry::loadStation(file);
    EXPECT_DOUBLE_EQ(station.camera.K(0, 0), 812.5);
    EXPECT_DOUBLE_EQ(station.camera.K(1, 2), 241.5);
    ASSERT_EQ(station.camera.dist.size(), 5u);
    EXPECT_DOUBLE_EQ(station.camera.dist[3], -0.002);
    // Everything else is as it was.
    ASSERT_TRUE(station.pixelSizeUm.has_value());
    EXPECT_DOUBLE_EQ(station.pixelSizeUm->x(), 3.45);
    EXPECT_DOUBLE_EQ(station.floorZMm, -5.5);
    EXPECT_DOUBLE_EQ(station.fixture.rotationRangeDeg.min, -170.0);
    EXPECT_DOUBLE_EQ(station.fixture.cameraFromFixture.t.z(), 400.0);
    auto root = hg::ConfigNode::loadFile(file);
    EXPECT_EQ(root["camera"]["driver"]["backend"].asString(), "sim");
    EXPECT_EQ(root["lamps"]["red"].asString(), "R");
    EXPECT_DOUBLE_EQ(root["camera"]["calibration"]["rms_px"].asDouble(), 0.21);
    EXPECT_EQ(root["camera"]["calibration"]["method"].asString(), "chessboard:9x6:25");
    // Key order is kept: camera, fixture, environment, lamps.
    EXPECT_EQ(root.keys(), (std::vector<std::string>{"camera", "fixture", "environment", "lamps"}));
    // No temporary file is left behind.
    int files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
    EXPECT_EQ(files, 2);
}

TEST(StationFile, SecondRewriteKeepsBothBackups)
{
    hgtest::TempDir dir;
    auto file = hgtest::writeFile(dir / "s.yaml", kStation);
    auto first = StationFileUpdate(file);
    first.setIntrinsics(sampleResult(), "m1");
    auto b1 = first.commit();
    auto second = StationFileUpdate(file);
    auto r = sampleResult();
    r.rmsPx = 0.3;
    second.setIntrinsics(r, "m2");
    auto b2 = second.commit();
    ASSERT_TRUE(b1 && b2);
    EXPECT_NE(*b1, *b2);
    EXPECT_EQ(readText(*b1), kStation);
    EXPECT_NE(readText(*b2).find("m1"), std::string::npos);
}

TEST(StationFile, NewFileHasNoBackup)
{
    hgtest::TempDir dir;
    StationFileUpdate update(dir / "new.yaml");
    update.setIntrinsics(sampleResult(), "chessboard:9x6:25");
    EXPECT_FALSE(update.commit().has_value());
    auto root = hg::ConfigNode::loadFile(dir / "new.yaml");
    EXPECT_EQ(root["camera"]["image_size"].asDoubles(2), (std::vector<double>{640, 480}));
}

TEST(StationFile, BrokenExistingFileIsBadInputAndStaysUntouched)
{
    hgtest::TempDir dir;
    auto file = hgtest::writeFile(dir / "bad.yaml", "camera: [unclosed\n");
    EXPECT_THROW(StationFileUpdate{file}, hg::InputError);
    EXPECT_EQ(readText(file), "camera: [unclosed\n");
}

TEST(StationFile, HistoryListsTheFileThenItsBackupsNewestFirst)
{
    hgtest::TempDir dir;
    auto file = hgtest::writeFile(dir / "s.yaml", kStation);
    auto first = StationFileUpdate(file);
    first.setIntrinsics(sampleResult(), "m1");
    ASSERT_TRUE(first.commit());
    auto second = StationFileUpdate(file);
    auto r = sampleResult();
    r.rmsPx = 0.3;
    second.setIntrinsics(r, "m2");
    ASSERT_TRUE(second.commit());
    // An old backup that no longer parses is listed with its error, not skipped or fatal.
    hgtest::writeFile(dir / "s.yaml.bak-20000101T000000Z", "camera: [unclosed\n");
    // Another station's backups in the same folder are not this one's history.
    hgtest::writeFile(dir / "other.yaml.bak-20991231T235959Z", kStation);

    const auto history = calibrationHistory(file, 10);
    ASSERT_EQ(history.size(), 4u);
    EXPECT_EQ(history[0].file, file);
    EXPECT_EQ(history[0].camera.at("method"), "m2");
    EXPECT_DOUBLE_EQ(history[0].camera.at("rms_px").get<double>(), 0.3);
    EXPECT_EQ(history[0].camera.at("views"), 3);
    EXPECT_DOUBLE_EQ(history[0].camera.at("std_dev").at("fx").get<double>(), 0.5);
    EXPECT_EQ(history[1].camera.at("method"), "m1"); // what the second calibration replaced
    EXPECT_TRUE(history[2].camera.is_null());        // the original file: no calibration yet
    EXPECT_TRUE(history[2].error.empty());
    EXPECT_EQ(history[3].file.filename(), "s.yaml.bak-20000101T000000Z");
    EXPECT_FALSE(history[3].error.empty());

    EXPECT_EQ(calibrationHistory(file, 2).size(), 2u);
    EXPECT_TRUE(calibrationHistory(file, 0).empty());
}

TEST(StationFile, HistoryOrdersBackupsOfOneSecondByTheirNumber)
{
    hgtest::TempDir dir;
    auto file = hgtest::writeFile(dir / "s.yaml", kStation);
    for (int i : {0, 2, 10}) {
        const std::string suffix = i == 0 ? "" : "-" + std::to_string(i);
        hgtest::writeFile(dir / ("s.yaml.bak-20261203T080000Z" + suffix), kStation);
    }
    const auto history = calibrationHistory(file, 10);
    ASSERT_EQ(history.size(), 4u);
    EXPECT_EQ(history[1].file.filename(), "s.yaml.bak-20261203T080000Z-10");
    EXPECT_EQ(history[2].file.filename(), "s.yaml.bak-20261203T080000Z-2");
    EXPECT_EQ(history[3].file.filename(), "s.yaml.bak-20261203T080000Z");
}

TEST(StationFile, TelecentricCameraIsWrittenInOneOfItsTwoForms)
{
    TelecentricCalibration r;
    r.intrinsics.K << 100.0, 0, 651.25, 0, 100.2, 498.5, 0, 0, 1;
    r.intrinsics.dist = {-2.5e-4, 4e-7, 0, 0, 0};
    r.intrinsics.imageSize = cv::Size(1280, 1024);
    r.rmsPx = 0.03;
    r.viewNames.assign(12, "v");
    r.stdDev = {0.001, 0.001, 0.15, 0.17, 1e-6, 1e-8, 0, 0, 0};
    r.tiltSpreadDeg = 60.0;
    hgtest::TempDir dir;
    const auto file = hgtest::writeFile(dir / "station.yaml", kStation);

    // With the pitch: magnification = fx·pitch = 0.55, the vertical pitch
    // magnification / fy = 0.55 / 100.2 mm; K goes.
    StationFileUpdate withPitch(file);
    withPitch.setTelecentricIntrinsics(r, "chessboard:15x12:0.45", 0.0055);
    (void)withPitch.commit();
    YAML::Node cam = YAML::LoadFile(file.string())["camera"];
    EXPECT_EQ(cam["model"].as<std::string>(), "telecentric");
    EXPECT_NEAR(cam["magnification"].as<double>(), 0.55, 1e-12);
    EXPECT_NEAR(cam["pixel_pitch_mm"][0].as<double>(), 0.0055, 1e-15);
    EXPECT_NEAR(cam["pixel_pitch_mm"][1].as<double>(), 0.55 / 100.2, 1e-15);
    EXPECT_DOUBLE_EQ(cam["principal_point"][0].as<double>(), 651.25);
    EXPECT_DOUBLE_EQ(cam["principal_point"][1].as<double>(), 498.5);
    EXPECT_FALSE(cam["K"]);
    EXPECT_DOUBLE_EQ(cam["dist"][0].as<double>(), -2.5e-4);
    EXPECT_DOUBLE_EQ(cam["calibration"]["std_dev"]["cy"].as<double>(), 0.17);
    EXPECT_EQ(cam["calibration"]["model"].as<std::string>(), "telecentric");
    EXPECT_EQ(cam["pixel_size_um"][0].as<double>(), 3.45); // other keys kept
    // The station loader reads it back as the camera that was calibrated.
    auto read = hg::geometry::parseCameraSection(hg::ConfigNode::loadFile(file)["camera"]);
    EXPECT_EQ(read.projection, hg::geometry::Projection::Telecentric);
    EXPECT_LT((read.K - r.intrinsics.K).norm(), 1e-9);

    // Without it: K in px/mm, and the pitch form goes.
    StationFileUpdate withoutPitch(file);
    withoutPitch.setTelecentricIntrinsics(r, "chessboard:15x12:0.45", std::nullopt);
    (void)withoutPitch.commit();
    cam = YAML::LoadFile(file.string())["camera"];
    EXPECT_DOUBLE_EQ(cam["K"][1][1].as<double>(), 100.2);
    EXPECT_DOUBLE_EQ(cam["K"][0][2].as<double>(), 651.25);
    for (const char* key : {"magnification", "pixel_pitch_mm", "principal_point"}) EXPECT_FALSE(cam[key]) << key;
    read = hg::geometry::parseCameraSection(hg::ConfigNode::loadFile(file)["camera"]);
    EXPECT_EQ(read.projection, hg::geometry::Projection::Telecentric);
    EXPECT_LT((read.K - r.intrinsics.K).norm(), 1e-12);
}
