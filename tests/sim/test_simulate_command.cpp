// `hullgauge simulate` end to end: a box on a turntable station, checked
// against the silhouette area worked out by hand, the manifest against the
// station's own cameras, a CSG notch, and bad input (exit 2, one line naming
// file and field).
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/vision/manifest.h"

#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

namespace hg::sim {
namespace {

namespace fs = std::filesystem;

// Camera 300 mm from the turntable centre on the part's -y side, looking
// along +y, image up = part +z: X_cam = (x, -z, y + 300).
const std::string kStation = hgtest::stationYaml();

/// An ASCII STL of the box [lo, hi], written facet by facet (outward normals).
std::string boxStl(double x0, double y0, double z0, double x1, double y1, double z1)
{
    const double c[8][3] = {{x0, y0, z0}, {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0},
                            {x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}};
    // Two counter-clockwise (seen from outside) triangles per face.
    const int faces[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                              {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
    std::ostringstream s;
    s << "solid box\n";
    for (const auto& f : faces) {
        s << " facet normal 0 0 0\n  outer loop\n";
        for (int v : f) s << "   vertex " << c[v][0] << ' ' << c[v][1] << ' ' << c[v][2] << '\n';
        s << "  endloop\n endfacet\n";
    }
    s << "endsolid box\n";
    return s.str();
}

std::string program()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

/// Object area of a backlit image: darkness relative to the background grey
/// level `bg`, in units of the object's darkness, summed.
double darkArea(const cv::Mat& grey, double bg, double obj)
{
    cv::Mat f;
    grey.convertTo(f, CV_64F, -1.0 / (bg - obj), bg / (bg - obj));
    return cv::sum(f)[0];
}

class SimulateCommand : public ::testing::Test {
  protected:
    void SetUp() override
    {
        ASSERT_TRUE(fs::exists(program())) << program() << " is not built";
        hgtest::writeFile(dir / "station.yaml", kStation);
        hgtest::writeFile(dir / "box.stl", boxStl(-20, -10, 0, 20, 10, 30));
    }

    hgtest::RunResult simulate(const std::string& extra)
    {
        return hgtest::run(program() + " simulate --mesh " + (dir / "box.stl").string() + " --station " +
                           (dir / "station.yaml").string() + " " + extra);
    }

    hgtest::TempDir dir;
};

TEST_F(SimulateCommand, RendersViewsAndWritesManifest)
{
    hgtest::writeFile(dir / "poses.yaml", "- {rotation_deg: 0, declination_deg: 0}\n"
                                          "- {rotation_deg: 30, declination_deg: 20}\n"
                                          "- {rotation_deg: 90, declination_deg: 0}\n");
    auto r = simulate("--poses " + (dir / "poses.yaml").string() + " --out " + (dir / "out").string());
    ASSERT_EQ(r.status, 0) << r.err;

    // One summary line per view.
    std::istringstream lines(r.out);
    std::string line;
    int n = 0;
    while (std::getline(lines, line)) {
        EXPECT_EQ(line.rfind("v" + std::to_string(n) + ": rotation ", 0), 0u) << line;
        EXPECT_NE(line.find("object area"), std::string::npos) << line;
        ++n;
    }
    EXPECT_EQ(n, 3);

    // The manifest holds the station's cameras at the poses.
    const auto station = geometry::loadStation(dir / "station.yaml");
    const auto poses = geometry::loadPoses(dir / "poses.yaml", &station.fixture);
    const auto m = vision::readManifest(dir / "out/manifest.json");
    ASSERT_EQ(m.views.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        const auto& v = m.views[i];
        const auto want = station.cameraAt(poses[i]);
        EXPECT_EQ(v.id, "v" + std::to_string(i));
        EXPECT_EQ(v.image, dir / "out" / ("v" + std::to_string(i) + ".png"));
        EXPECT_EQ(v.camera.intrinsics().K, want.intrinsics().K);
        EXPECT_LT((v.camera.cameraFromPart().R - want.cameraFromPart().R).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_LT((v.camera.cameraFromPart().t - want.cameraFromPart().t).norm(), 1e-9);
        ASSERT_TRUE(v.fixturePose);
        EXPECT_EQ(v.fixturePose->pose, poses[i]);
        const cv::Mat img = vision::readViewImage(m, i);
        ASSERT_EQ(img.type(), CV_8UC1);
        EXPECT_EQ(img.size(), cv::Size(640, 480));
    }

    // View 0 by hand: the camera sees the box face y = -10 at depth 290 mm
    // head on (side faces are edge-on or turned away): x in ±20, z in [0, 30]
    // -> 40 * 800/290 by 30 * 800/290 pixels.
    const double expected = (40.0 * 800 / 290) * (30.0 * 800 / 290);
    // Default levels 0.85 and 0.08 of 255 are stored as 217 and 20.
    const cv::Mat v0 = cv::imread((dir / "out/v0.png").string(), cv::IMREAD_UNCHANGED);
    EXPECT_NEAR(darkArea(v0, 217, 20), expected, 1e-3 * expected);
    const auto at = r.out.find("object area ");
    ASSERT_NE(at, std::string::npos);
    // Horizontal edges are sampled by 16 sub-scanlines per row: each of the
    // two (110 px long) may be off by up to 1/32 px.
    EXPECT_NEAR(std::stod(r.out.substr(at + 12)), expected, 2 * (40.0 * 800 / 290) / 32) << r.out;
}

TEST_F(SimulateCommand, SubtractCutsANotch)
{
    // A bar through the top right edge removes x in [10, 20], z in [20, 30]
    // along the whole depth: the front face loses a 10 x 10 mm square,
    // 10 * 800/290 px on a side; the faces inside the notch turn away from
    // the camera, so nothing fills it.
    hgtest::writeFile(dir / "cutter.stl", boxStl(10, -15, 20, 25, 15, 35));
    hgtest::writeFile(dir / "poses.yaml", "- {rotation_deg: 0, declination_deg: 0}\n");
    auto r = simulate("--subtract " + (dir / "cutter.stl").string() + " --poses " + (dir / "poses.yaml").string() +
                      " --out " + (dir / "out").string() + " --bit-depth 16 --noise 20 --seed 3 --blur 0.7");
    ASSERT_EQ(r.status, 0) << r.err;
    const cv::Mat img = cv::imread((dir / "out/v0.png").string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(img.type(), CV_16UC1);
    // Blur keeps the sum and zero-mean noise adds ~0.2 px² of scatter.
    const double s = 800.0 / 290;
    const double expected = (40 * s) * (30 * s) - (10 * s) * (10 * s);
    EXPECT_NEAR(darkArea(img, 0.85 * 65535, 0.08 * 65535), expected, 1e-3 * expected);
}

TEST_F(SimulateCommand, BadPosesFileExitsTwoNamingFileAndField)
{
    const auto poses = hgtest::writeFile(dir / "poses.yaml", "- {rotation_deg: 0, declination_deg: 0}\n"
                                                             "- {rotation_deg: ten, declination_deg: 20}\n");
    auto r = simulate("--poses " + poses.string() + " --out " + (dir / "out").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(poses.string() + ":2:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("rotation_deg"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out/manifest.json"));

    // Out of the fixture's reach.
    hgtest::writeFile(poses, "- {rotation_deg: 0, declination_deg: 75}\n");
    r = simulate("--poses " + poses.string() + " --out " + (dir / "out").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find(poses.string()), std::string::npos) << r.err;
}

TEST_F(SimulateCommand, BadOptionsAndMeshesExitTwo)
{
    const auto poses = hgtest::writeFile(dir / "poses.yaml", "- {rotation_deg: 0, declination_deg: 0}\n");
    auto r = simulate("--poses " + poses.string() + " --out " + (dir / "out").string() + " --bit-depth 12");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--bit-depth"), std::string::npos) << r.err;

    // A box with one facet missing is not a solid.
    std::string open = boxStl(-20, -10, 0, 20, 10, 30);
    const auto cut = open.find(" facet normal");
    open.erase(cut, open.find(" facet normal", cut + 1) - cut);
    const auto broken = hgtest::writeFile(dir / "open.stl", open);
    r = hgtest::run(program() + " simulate --mesh " + broken.string() + " --station " +
                    (dir / "station.yaml").string() + " --poses " + poses.string() + " --out " +
                    (dir / "out").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find(broken.string()), std::string::npos) << r.err;
}

// --seat renders the part seated off nominal: the same pixels as the moved
// solid drawn at nominal, while the manifest keeps the nominal cameras and
// records the seat (docs/inspection.md, "Seated parts").
TEST_F(SimulateCommand, SeatRendersThePartMovedAndKeepsTheNominalCameras)
{
    hgtest::writeFile(dir / "poses.yaml", "- {rotation_deg: 0, declination_deg: 0}\n"
                                          "- {rotation_deg: 30, declination_deg: 20}\n");
    // The box [-20, 20] x [-10, 10] x [0, 30] about its centre c = (0, 0, 15):
    // shifted by d = (2, 0, 3) it is the box [-18, 22] x [-10, 10] x [3, 33];
    // turned 90° about z it is [-10, 10] x [-20, 20] x [0, 30].
    struct Case {
        std::string seat;
        std::string movedStl;
        Eigen::Matrix3d R;
        Eigen::Vector3d t;
        double shiftMm, rotationDeg;
    };
    Eigen::Matrix3d rz90;
    rz90 << 0, -1, 0, 1, 0, 0, 0, 0, 1;
    const std::vector<Case> cases = {
        {"2,0,3,0,0,0", boxStl(-18, -10, 3, 22, 10, 33), Eigen::Matrix3d::Identity(), {2, 0, 3}, std::sqrt(13.0), 0.0},
        {"0,0,0,0,0,90", boxStl(-10, -20, 0, 10, 20, 30), rz90, {0, 0, 0}, 0.0, 90.0},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.seat);
        hgtest::writeFile(dir / "moved.stl", c.movedStl);
        auto seated = simulate("--poses " + (dir / "poses.yaml").string() + " --out " + (dir / "seated").string() +
                               " --seat " + c.seat);
        ASSERT_EQ(seated.status, 0) << seated.err;
        auto moved = hgtest::run(program() + " simulate --mesh " + (dir / "moved.stl").string() + " --station " +
                                 (dir / "station.yaml").string() + " --poses " + (dir / "poses.yaml").string() +
                                 " --out " + (dir / "moved").string());
        ASSERT_EQ(moved.status, 0) << moved.err;
        const auto station = geometry::loadStation(dir / "station.yaml");
        const auto poses = geometry::loadPoses(dir / "poses.yaml", &station.fixture);
        const auto m = vision::readManifest(dir / "seated/manifest.json");
        const auto reference = vision::readManifest(dir / "moved/manifest.json");
        ASSERT_EQ(m.views.size(), 2u);
        for (std::size_t i = 0; i < 2; ++i) {
            // The nominal camera, not the seated one.
            const auto want = station.cameraAt(poses[i]);
            EXPECT_LT((m.views[i].camera.cameraFromPart().R - want.cameraFromPart().R).cwiseAbs().maxCoeff(), 1e-12);
            EXPECT_LT((m.views[i].camera.cameraFromPart().t - want.cameraFromPart().t).norm(), 1e-9);
            // The same pixels as the moved box (rounding may flip a grey level on an edge).
            const cv::Mat a = vision::readViewImage(m, i), b = vision::readViewImage(reference, i);
            EXPECT_LE(cv::norm(a, b, cv::NORM_INF), 1.0);
            EXPECT_LT(cv::norm(a, b, cv::NORM_L1) / static_cast<double>(a.total()), 0.01);
        }
        std::ifstream in(dir / "seated/manifest.json");
        const auto seat = nlohmann::json::parse(in)["simulation"]["seat"];
        for (int r = 0; r < 3; ++r) {
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(seat["R"][r][k].get<double>(), c.R(r, k), 1e-12);
            EXPECT_NEAR(seat["t"][r].get<double>(), c.t(r), 1e-12);
        }
        EXPECT_EQ(seat["centre"], nlohmann::json({0.0, 0.0, 15.0}));
        EXPECT_NEAR(seat["shift_mm"].get<double>(), c.shiftMm, 1e-12);
        EXPECT_NEAR(seat["rotation_deg"].get<double>(), c.rotationDeg, 1e-9);
    }
    // Six numbers or nothing.
    auto bad =
        simulate("--poses " + (dir / "poses.yaml").string() + " --out " + (dir / "bad").string() + " --seat 1,2,3");
    EXPECT_EQ(bad.status, 2) << bad.err;
}

} // namespace
} // namespace hg::sim
