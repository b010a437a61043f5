// `hullgauge calibrate ...` end to end: the program as an operator runs it.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "fixture_rig.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/station.h"
#include "telecentric_rig.h"

namespace {

std::string hullgauge()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

std::string sampleImages()
{
    std::string list;
    for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
        char name[96];
        std::snprintf(name, sizeof name, " /usr/share/doc/opencv-doc/examples/data/left%02d.jpg", i);
        list += name;
    }
    return list;
}

std::string readText(const std::filesystem::path& p)
{
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

const std::string kStation =
    hgtest::stationYaml({.focalPx = 400, .cameraKeys = "  pixel_size_um: [6.0, 6.0]\n", .floorZMm = 2.5});

} // namespace

TEST(CalibrateCli, IntrinsicsWritesTheStationAndKeepsABackup)
{
    hgtest::TempDir dir;
    auto station = hgtest::writeFile(dir / "station.yaml", kStation);
    auto r = hgtest::run(hullgauge() + " calibrate intrinsics --pattern chessboard:9x6:25 --fix-aspect-ratio --images" +
                         sampleImages() + " --out " + station.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("RMS reprojection error"), std::string::npos) << r.out;
    EXPECT_NE(r.err.find("[13/13]"), std::string::npos) << r.err; // progress on stderr
    auto s = hg::geometry::loadStation(station);
    // OpenCV's published result for these images (samples/data/left_intrinsics.yml).
    EXPECT_NEAR(s.camera.K(0, 0), 535.9157, 0.01 * 535.9);
    EXPECT_NEAR(s.camera.K(0, 2), 342.2832, 0.01 * 342.3);
    EXPECT_EQ(s.camera.dist.size(), 5u);
    EXPECT_DOUBLE_EQ(s.floorZMm, 2.5);
    ASSERT_TRUE(s.pixelSizeUm);
    EXPECT_DOUBLE_EQ(s.pixelSizeUm->x(), 6.0);
    int backups = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path()))
        if (e.path().filename().string().rfind("station.yaml.bak-", 0) == 0) {
            ++backups;
            EXPECT_EQ(readText(e.path()), kStation);
        }
    EXPECT_EQ(backups, 1);
}

TEST(CalibrateCli, BadPatternIsExitTwoAndLeavesTheFile)
{
    hgtest::TempDir dir;
    auto station = hgtest::writeFile(dir / "station.yaml", kStation);
    auto r = hgtest::run(hullgauge() + " calibrate intrinsics --pattern chessboard:9x6 --images" + sampleImages() +
                         " --out " + station.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--pattern"), std::string::npos) << r.err;
    EXPECT_EQ(readText(station), kStation);
}

TEST(CalibrateCli, RailPrintsTheTablesAndNamesBadKeys)
{
    hgtest::TempDir dir;
    // f/Δp = 1000 both ways, centre (320, 240), rail offset 0: a point v mm off
    // the axis is seen 1000 v / d pixels from the centre.
    std::ostringstream y;
    y << "horizontal:\n";
    for (double h : {-20.0, 20.0}) {
        y << "  - displacement_mm: " << h << "\n    samples:\n";
        for (double d : {200.0, 250.0, 400.0})
            y << "      - {range_mm: " << d << ", pixel: [" << 320 + 1000 * h / d << ", 240]}\n";
    }
    y << "vertical:\n";
    for (double w : {-10.0, 30.0}) {
        y << "  - displacement_mm: " << w << "\n    samples:\n";
        for (double d : {200.0, 250.0, 400.0})
            y << "      - {range_mm: " << d << ", pixel: [320, " << 240 + 1000 * w / d << "]}\n";
    }
    auto obs = hgtest::writeFile(dir / "rail.yaml", y.str());
    auto r = hgtest::run(hullgauge() + " calibrate rail --observations " + obs.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("Table 4.3"), std::string::npos);
    EXPECT_NE(r.out.find("Table 4.6"), std::string::npos);
    EXPECT_NE(r.out.find("(320.000, 240.000)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("1000.0"), std::string::npos) << r.out;

    auto bad = hgtest::writeFile(dir / "bad.yaml", "horizontal: []\nvertical: []\nextra: 1\n");
    r = hgtest::run(hullgauge() + " calibrate rail --observations " + bad.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("bad.yaml:3: extra"), std::string::npos) << r.err;
}

TEST(CalibrateCli, FixtureFromCornerObservationsWritesTheAxes)
{
    calibtest::Rig rig(0.0, 0.0);
    hgtest::TempDir dir;
    std::ostringstream st;
    st.precision(12);
    const auto& K = rig.camera.K;
    st << "camera:\n  image_size: [2048, 1536]\n  K: [[" << K(0, 0) << ", 0, " << K(0, 2) << "], [0, " << K(1, 1)
       << ", " << K(1, 2)
       << "], [0, 0, 1]]\n  dist: [-0.05, 0.02, 0, 0, 0]\nlamps: {backend: sim, green: G, amber: A, red: R}\n";
    auto station = hgtest::writeFile(dir / "station.yaml", st.str());
    std::ostringstream obs;
    obs.precision(10);
    obs << "pattern: " << fmt::format("{}", rig.board) << "\nviews:\n";
    for (const auto& v : rig.views(21)) {
        obs << "  - rotation_deg: " << v.pose.rotationDeg << "\n    declination_deg: " << v.pose.declinationDeg
            << "\n    corners: [";
        for (std::size_t i = 0; i < v.target.imagePoints.size(); ++i)
            obs << (i ? ", " : "") << "[" << v.target.imagePoints[i].x << ", " << v.target.imagePoints[i].y << "]";
        obs << "]\n";
    }
    auto obsFile = hgtest::writeFile(dir / "fixture.yaml", obs.str());
    auto r = hgtest::run(hullgauge() + " calibrate fixture --station " + station.string() + " --observations " +
                         obsFile.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("distance between axes"), std::string::npos) << r.out;
    auto root = hg::ConfigNode::loadFile(station);
    EXPECT_EQ(root["lamps"]["green"].asString(), "G"); // untouched
    auto R = root["fixture"]["camera_from_fixture"]["R"].asMatrix3();
    auto t = root["fixture"]["camera_from_fixture"]["t"].asVector3();
    EXPECT_LT(hg::geometry::rotationAngleDeg(R, rig.cameraFromFixture.R), 0.05);
    EXPECT_LT((t - rig.cameraFromFixture.t).norm(), 0.1);
    EXPECT_LT((root["fixture"]["declination_axis"].asVector3() - hg::geometry::Vec3::UnitX()).norm(), 1e-3);
    EXPECT_NEAR(root["fixture"]["calibration"]["axes_distance_mm"].asDouble(), 0.0, 0.1);

    // A view with a corner missing and no ids is refused with the key.
    auto broken =
        hgtest::writeFile(dir / "broken.yaml", "pattern: chessboard:3x3:10\nviews:\n"
                                               "  - {rotation_deg: 0, declination_deg: 0, corners: [[1, 2]]}\n");
    r = hgtest::run(hullgauge() + " calibrate fixture --station " + station.string() + " --observations " +
                    broken.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("broken.yaml:3: views[0].corners: expected all 9 corners"), std::string::npos) << r.err;
}

TEST(CalibrateCli, TelecentricIntrinsicsWriteACameraTheStationLoads)
{
    // Twelve tilts of the independent renderer's chessboard written as the
    // camera's images; the data sheet's pitch of 5.5 µm gives the
    // magnification 100 px/mm · 0.0055 mm = 0.55 (docs/telecentric-calibration.md).
    using namespace telecentrictest;
    hgtest::TempDir dir;
    auto station = hgtest::writeFile(dir / "station.yaml", kStation);
    const auto lens = trueLens();
    const auto poses = twelveTilts();
    std::string images;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const auto image = dir / ("tilt" + std::to_string(i) + ".png");
        ASSERT_TRUE(cv::imwrite(image.string(), renderView(lens, poses[i], 1000 + i)));
        images += " " + image.string();
    }
    auto r = hgtest::run(hullgauge() + " calibrate intrinsics --model telecentric --pattern " + kPattern +
                         " --pixel-pitch-mm 0.0055 --images" + images + " --out " + station.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("fixed by convention"), std::string::npos) << r.out;
    const auto s = hg::geometry::loadStation(station);
    EXPECT_EQ(s.camera.projection, hg::geometry::Projection::Telecentric);
    EXPECT_NEAR(s.camera.K(0, 0) / lens.fx, 1.0, 5e-4);
    EXPECT_NEAR(s.camera.K(1, 1) / lens.fy, 1.0, 5e-4);
    EXPECT_NEAR(s.camera.K(0, 2), lens.cx, 0.3);
    EXPECT_NEAR(s.camera.K(1, 2), lens.cy, 0.3);
    const auto cam = hg::ConfigNode::loadFile(station)["camera"];
    EXPECT_NEAR(cam["magnification"].asDouble(), 0.55, 0.55 * 5e-4);

    // A pinhole calibration has no pitch to take.
    r = hgtest::run(hullgauge() + " calibrate intrinsics --pattern " + kPattern + " --pixel-pitch-mm 0.0055 --images" +
                    images + " --out " + station.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--pixel-pitch-mm"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("only with --model telecentric"), std::string::npos) << r.err;
}
