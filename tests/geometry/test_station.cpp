// Station and poses files: valid files load; every kind of bad value names
// file, line and key.
#include <gtest/gtest.h>

#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"

namespace hg::geometry {
namespace {

// The contract example (docs/contracts.md §2): every optional key given.
const std::string kStation = hgtest::stationYaml({.imageSize = {2448, 2048},
                                                  .focalPx = 2400,
                                                  .cameraKeys = "  dist: [-0.1, 0.05, 0, 0, 0]\n"
                                                                "  pixel_size_um: [3.45, 3.45]\n"
                                                                "  depth_of_field_mm: [250, 350]\n",
                                                  .floorZMm = -2.5,
                                                  .sections = "plc: {port: 1502}\n"});

/// "station.yaml:<line of key>: " + rest.
std::string at(const std::string& key, const std::string& rest)
{
    return "station.yaml:" + std::to_string(hgtest::lineOf(kStation, key)) + ": " + rest;
}

using hgtest::replaced;

// Loads `text` and returns the InputError message (empty if it loaded).
std::string loadError(const std::string& text)
{
    hgtest::TempDir dir;
    auto file = hgtest::writeFile(dir / "station.yaml", text);
    try {
        loadStation(file);
    } catch (const InputError& e) {
        std::string msg = e.what();
        return msg.substr(msg.find("station.yaml"));
    }
    return {};
}

TEST(Station, LoadsTheContractExample)
{
    hgtest::TempDir dir;
    auto s = loadStation(hgtest::writeFile(dir / "station.yaml", kStation));
    EXPECT_EQ(s.camera.imageSize, cv::Size(2448, 2048));
    EXPECT_EQ(s.camera.K(0, 2), 1224);
    ASSERT_EQ(s.camera.dist.size(), 5u);
    ASSERT_TRUE(s.pixelSizeUm);
    ASSERT_TRUE(s.depthOfFieldMm);
    EXPECT_EQ(s.depthOfFieldMm->max, 350);
    EXPECT_EQ(s.fixture.type, FixtureType::RotationDeclination);
    EXPECT_EQ(s.fixture.declinationRangeDeg.max, 60);
    EXPECT_EQ(s.floorZMm, -2.5);
    ASSERT_TRUE(s.document);
    EXPECT_EQ(s.document->raw()["plc"]["port"].as<int>(), 1502); // driver sections kept
    auto cam = s.cameraAt({0, 0, 0});
    EXPECT_LT((cam.centre() - Vec3(0, -300, 0)).norm(), 1e-9);
}

TEST(Station, WrongTypeNamesLineAndKey)
{
    EXPECT_EQ(loadError(replaced(kStation, "[2448, 2048]", "wide")),
              at("image_size:", "camera.image_size: expected a sequence, found 'wide'"));
    EXPECT_EQ(loadError(replaced(kStation, "floor_z_mm: -2.5", "floor_z_mm: low")),
              at("floor_z_mm:", "environment.floor_z_mm: expected a finite number, found 'low'"));
}

TEST(Station, BadValuesAreRefused)
{
    EXPECT_EQ(loadError(replaced(kStation, "dist: [-0.1, 0.05, 0, 0, 0]", "dist: [1, 2, 3]")),
              at("dist:", "camera.dist: expected 4, 5, 8 or 12 OpenCV coefficients, found 3"));
    EXPECT_EQ(loadError(replaced(kStation, "[[1, 0, 0], [0, 0, -1], [0, 1, 0]]", "[[1, 0, 0], [0, 0, 1], [0, 1, 0]]")),
              at("camera_from_fixture:",
                 "fixture.camera_from_fixture.R: not a rotation matrix (must be orthonormal with "
                 "determinant +1)"));
    EXPECT_EQ(loadError(replaced(kStation, "type: rotation_declination", "type: turntable")),
              at("type:", "fixture.type: unknown fixture type 'turntable' (rotation_declination or rail)"));
    EXPECT_EQ(loadError(replaced(kStation, "[0, 60]", "[60, 0]")),
              at("declination_range_deg:", "fixture.declination_range_deg: range [min, max] must have min <= max"));
    EXPECT_EQ(loadError(replaced(kStation, "[2400, 0, 1224], [0, 2400, 1024]", "[-2400, 0, 1224], [0, 2400, 1024]")),
              at("K:", "camera.K: fx and fy must be positive"));
}

TEST(Station, AbsurdMagnitudesAreNamedWhereTheyAre)
{
    // 9.2e18 mm: once accepted, `plan` blamed the part for what was a typo in the station.
    EXPECT_EQ(loadError(replaced(kStation, "t: [0, 0, 300]", "t: [0, 0, 9.2e18]")),
              at("camera_from_fixture:",
                 "fixture.camera_from_fixture.t: values must lie within ±1e5 mm (a station is not that "
                 "large)"));
    EXPECT_EQ(loadError(replaced(kStation, "[0, 2400, 1024]", "[0, 2400, -9.2e18]")),
              at("K:", "camera.K: the principal point (cx, cy) lies more than ten image sizes from the image"));
    EXPECT_EQ(loadError(replaced(kStation, "[[2400, 0, 1224]", "[[1e308, 0, 1224]")),
              at("K:", "camera.K: fx, fy and the skew must be below 1e7 px"));
    EXPECT_EQ(loadError(replaced(kStation, "[-180, 180]", "[-1e308, 180]")),
              at("rotation_range_deg:",
                 "fixture.rotation_range_deg: values must lie within ±1e5 mm or degrees (a station is "
                 "not that large)"));
    EXPECT_EQ(loadError(replaced(kStation, "floor_z_mm: -2.5", "floor_z_mm: 1e300")),
              at("floor_z_mm:", "environment.floor_z_mm: value 1e+300 is outside [-100000, 100000]"));
    // A principal point outside the image but within reach stays legal (decentred optics).
    EXPECT_EQ(loadError(replaced(kStation, "[0, 2400, 1024]", "[0, 2400, 3000]")), "");
}

TEST(Station, MissingAndUnknownKeys)
{
    // A block map is where its first key is: without `type`, camera_from_fixture.
    const std::string untyped = replaced(kStation, "  type: rotation_declination\n", "");
    EXPECT_EQ(loadError(untyped), "station.yaml:" + std::to_string(hgtest::lineOf(untyped, "camera_from_fixture:")) +
                                      ": fixture: missing required key 'type'");
    auto msg = loadError(replaced(kStation, "  rotation_axis:", "  rotaton_axis:"));
    EXPECT_EQ(msg.substr(0, msg.find(" (")), at("rotation_axis:", "fixture.rotaton_axis: unknown key 'rotaton_axis'"));
}

TEST(Station, SyntaxErrorNamesLine)
{
    EXPECT_EQ(loadError("camera:\n  K: [[1, 2\n  image_size: 3\n").substr(0, 15), "station.yaml:3:");
}

TEST(Poses, LoadAndCheckAgainstTheFixture)
{
    hgtest::TempDir dir;
    auto station = loadStation(hgtest::writeFile(dir / "station.yaml", kStation));
    auto ok =
        hgtest::writeFile(dir / "poses.yaml", "- {rotation_deg: 30, declination_deg: 20}\n- {rotation_deg: -90}\n");
    auto poses = loadPoses(ok, &station.fixture);
    ASSERT_EQ(poses.size(), 2u);
    EXPECT_EQ(poses[0], (FixturePose{30, 20, 0}));
    EXPECT_EQ(poses[1], (FixturePose{-90, 0, 0}));

    auto expectError = [&](const std::string& text, const std::string& expected) {
        auto file = hgtest::writeFile(dir / "bad.yaml", text);
        try {
            loadPoses(file, &station.fixture);
            ADD_FAILURE() << "no error for " << text;
        } catch (const InputError& e) {
            std::string m = e.what();
            EXPECT_EQ(m.substr(m.find("bad.yaml")), expected);
        }
    };
    expectError("- {rotation_deg: 30, declination_deg: 75}\n",
                "bad.yaml:1: [0]: pose rotation 30 deg, declination 75 deg is outside the fixture's range");
    expectError("- {rotation_deg: 0}\n- {rail_mm: 10}\n",
                "bad.yaml:2: [1]: the station's fixture turns and tilts: give rotation_deg/declination_deg");
    expectError("- {rotation_deg: ten}\n", "bad.yaml:1: [0].rotation_deg: expected a finite number, found 'ten'");
    expectError("rotation_deg: 10\n", "bad.yaml:1: (document): expected a list of fixture poses");
}

} // namespace
} // namespace hg::geometry
