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
    ASSERT_TRUE(cam.centre());
    EXPECT_LT((*cam.centre() - Vec3(0, -300, 0)).norm(), 1e-9);
    EXPECT_FALSE(cam.isTelecentric()); // camera.model defaults to pinhole
}

// A telecentric lens from its data sheet (docs/telecentric.md): a 0.5x lens
// on 5 µm pixels is 100 px per mm of object; the fixture's t puts the part
// origin on the plane of best focus.
const std::string kTelecentric = "camera:\n"
                                 "  model: telecentric\n"
                                 "  image_size: [2000, 1500]\n"
                                 "  magnification: 0.5\n"
                                 "  pixel_pitch_mm: 0.005\n"
                                 "  principal_point: [1000.5, 750.25]\n"
                                 "  dist: [0, 0, 0, 0, 0]\n"
                                 "  depth_of_field_mm: 4\n"
                                 "  telecentric_field_mm: 18\n"
                                 "  working_distance_mm: 110\n"
                                 "fixture:\n"
                                 "  type: rotation_declination\n"
                                 "  camera_from_fixture: {R: [[1, 0, 0], [0, 0, -1], [0, 1, 0]], t: [0, 0, 0]}\n";

TEST(Station, LoadsATelecentricCameraFromItsDataSheet)
{
    hgtest::TempDir dir;
    const Station s = loadStation(hgtest::writeFile(dir / "station.yaml", kTelecentric));
    EXPECT_EQ(s.camera.projection, Projection::Telecentric);
    EXPECT_EQ(s.fixture.cameraProjection, Projection::Telecentric);
    EXPECT_DOUBLE_EQ(s.camera.K(0, 0), 100.0);
    EXPECT_DOUBLE_EQ(s.camera.K(1, 1), 100.0);
    EXPECT_DOUBLE_EQ(s.camera.K(0, 2), 1000.5);
    EXPECT_DOUBLE_EQ(s.camera.K(1, 2), 750.25);
    EXPECT_DOUBLE_EQ(s.camera.workingDistanceMm, 110.0);
    // One figure: the depth of field centred on the focus plane, z in [−2, 2].
    ASSERT_TRUE(s.depthOfFieldMm);
    EXPECT_DOUBLE_EQ(s.depthOfFieldMm->min, -2.0);
    EXPECT_DOUBLE_EQ(s.depthOfFieldMm->max, 2.0);
    ASSERT_TRUE(s.telecentricFieldMm);
    EXPECT_DOUBLE_EQ(*s.telecentricFieldMm, 18.0);
    // X_cam = (x, −z, y): the part point (1.5, 40, 2) at (1000.5 + 150, 750.25 − 200), whatever its y.
    const CameraModel cam = s.cameraAt({0, 0, 0});
    EXPECT_TRUE(cam.isTelecentric());
    const auto p = cam.project({1.5, 40, 2});
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x(), 1150.5, 1e-9);
    EXPECT_NEAR(p->y(), 550.25, 1e-9);
    // A pitch per axis: fx = 0.5 / 0.004, fy = 0.5 / 0.005; K alone states the same.
    const Station aspect = loadStation(hgtest::writeFile(
        dir / "aspect.yaml", replaced(kTelecentric, "pixel_pitch_mm: 0.005", "pixel_pitch_mm: [0.004, 0.005]")));
    EXPECT_DOUBLE_EQ(aspect.camera.K(0, 0), 125.0);
    EXPECT_DOUBLE_EQ(aspect.camera.K(1, 1), 100.0);
    const std::string withK =
        replaced(replaced(replaced(kTelecentric, "  magnification: 0.5\n", ""), "  pixel_pitch_mm: 0.005\n", ""),
                 "  principal_point: [1000.5, 750.25]\n", "  K: [[100, 0, 1000.5], [0, 100, 750.25], [0, 0, 1]]\n");
    EXPECT_EQ(loadStation(hgtest::writeFile(dir / "k.yaml", withK)).camera.K, s.camera.K);
}

TEST(Station, TheDivisionModelIsReadWithItsKappa)
{
    hgtest::TempDir dir;
    const std::string division =
        replaced(kTelecentric, "  dist: [0, 0, 0, 0, 0]\n", "  distortion_model: division\n  kappa: -0.002\n");
    const Station s = loadStation(hgtest::writeFile(dir / "station.yaml", division));
    EXPECT_EQ(s.camera.distortionModel, DistortionModel::Division);
    EXPECT_DOUBLE_EQ(s.camera.kappa, -0.002);
    const std::string both = replaced(division, "  kappa: -0.002\n", "  kappa: -0.002\n  dist: [0.1, 0, 0, 0, 0]\n");
    EXPECT_EQ(loadError(both), "station.yaml:" + std::to_string(hgtest::lineOf(both, "dist:")) +
                                   ": camera.dist: the division model takes kappa, not OpenCV's coefficients");
    const std::string stray = replaced(kTelecentric, "  dist: [0, 0, 0, 0, 0]\n", "  kappa: -0.002\n");
    EXPECT_EQ(loadError(stray), "station.yaml:" + std::to_string(hgtest::lineOf(stray, "kappa:")) +
                                    ": camera.kappa: only the division model (distortion_model: division) has kappa");
}

TEST(Station, TelecentricKeysAreRefusedWhereTheyDoNotBelong)
{
    auto lineOfT = [](const std::string& text, const std::string& key) {
        return "station.yaml:" + std::to_string(hgtest::lineOf(text, key)) + ": ";
    };
    // A pinhole camera has no magnification.
    const std::string pinhole = replaced(kStation, "  dist:", "  magnification: 0.5\n  dist:");
    EXPECT_EQ(loadError(pinhole), lineOfT(pinhole, "magnification") +
                                      "camera.magnification: only a telecentric camera (camera.model: telecentric) "
                                      "has this key");
    const std::string unknown = replaced(kTelecentric, "model: telecentric", "model: fisheye");
    EXPECT_EQ(loadError(unknown),
              lineOfT(unknown, "model:") + "camera.model: unknown camera model 'fisheye' (pinhole or telecentric)");
    const std::string both =
        replaced(kTelecentric, "  dist:", "  K: [[100, 0, 1000.5], [0, 100, 750.25], [0, 0, 1]]\n  dist:");
    EXPECT_EQ(loadError(both), lineOfT(both, "magnification") +
                                   "camera.magnification: give either K or magnification, pixel_pitch_mm and "
                                   "principal_point");
    const std::string noPitch = replaced(kTelecentric, "  pixel_pitch_mm: 0.005\n", "");
    EXPECT_NE(loadError(noPitch).find("pixel_pitch_mm"), std::string::npos) << loadError(noPitch);
    const std::string badDof = replaced(kTelecentric, "depth_of_field_mm: 4", "depth_of_field_mm: [-200, 2]");
    EXPECT_EQ(loadError(badDof), lineOfT(badDof, "depth_of_field_mm") +
                                     "camera.depth_of_field_mm: depth of field must lie beyond the lens's front");
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
