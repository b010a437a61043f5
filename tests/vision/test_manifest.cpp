// Capture manifest (docs/contracts.md §3): round trip, the P form against K [R | t]
// computed by hand, and one precise error per malformed field.
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/vision/manifest.h"

#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

namespace hg::vision {
namespace {

using geometry::CameraModel;
using geometry::Intrinsics;
using geometry::RigidTransform;
using geometry::Vec3;

CameraModel someCamera(std::vector<double> dist, double angleDeg)
{
    Intrinsics in;
    in.K << 2400.5, 0.25, 1223.75, 0, 2398.125, 1020.5, 0, 0, 1;
    in.dist = std::move(dist);
    in.imageSize = {2448, 2048};
    RigidTransform pose = RigidTransform::rotation(Vec3(0.2, 1.0, -0.4), angleDeg);
    pose.t = Vec3(3.125, -7.5, 412.0625);
    return CameraModel(in, pose);
}

TEST(Manifest, RoundTripKeepsCamerasPosesAndSegmentation)
{
    hgtest::TempDir tmp;
    CaptureManifest m;
    ManifestView a;
    a.id = "v0";
    a.image = tmp / "set/v0.png";
    a.camera = someCamera({-0.21, 0.093, 0.0011, -0.0007, -0.012}, 33.3);
    a.fixturePose = ManifestFixturePose{geometry::FixtureType::RotationDeclination, {30.0, 20.0, 0.0}};
    ManifestView b;
    b.id = "side";
    b.image = tmp / "set/raw/side.png";
    b.camera = someCamera({}, -71.0);
    b.fixturePose = ManifestFixturePose{geometry::FixtureType::Rail, {0.0, 0.0, 120.5}};
    m.views = {a, b};
    m.segmentation.method = SegmentationMethod::Fixed;
    m.segmentation.threshold = 97.5;
    m.segmentation.objectIsDark = false;

    const auto file = tmp / "set/manifest.json";
    std::filesystem::create_directories(file.parent_path());
    writeManifest(m, file);

    // The file is plain docs/contracts.md §3 JSON with paths relative to the manifest.
    std::ifstream in(file);
    const auto raw = nlohmann::json::parse(in);
    EXPECT_EQ(raw["views"][0]["image"], "v0.png");
    EXPECT_EQ(raw["views"][1]["image"], "raw/side.png");
    EXPECT_EQ(raw["views"][0]["K"][0][2], 1223.75);
    EXPECT_EQ(raw["views"][1]["dist"], nlohmann::json::array({0, 0, 0, 0, 0}));
    EXPECT_EQ(raw["views"][0]["fixture_pose"]["declination_deg"], 20.0);
    EXPECT_EQ(raw["views"][1]["fixture_pose"]["rail_mm"], 120.5);
    EXPECT_EQ(raw["segmentation"]["method"], "fixed");

    const CaptureManifest back = readManifest(file);
    ASSERT_EQ(back.views.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
        const ManifestView& want = m.views[i];
        const ManifestView& got = back.views[i];
        EXPECT_EQ(got.id, want.id);
        EXPECT_EQ(got.image, want.image);
        EXPECT_EQ(got.camera.intrinsics().K, want.camera.intrinsics().K);
        EXPECT_EQ(got.camera.imageSize(), want.camera.imageSize());
        EXPECT_LT((got.camera.cameraFromPart().R - want.camera.cameraFromPart().R).cwiseAbs().maxCoeff(), 1e-15);
        EXPECT_EQ(got.camera.cameraFromPart().t, want.camera.cameraFromPart().t);
        ASSERT_TRUE(got.fixturePose);
        EXPECT_EQ(got.fixturePose->type, want.fixturePose->type);
        EXPECT_EQ(got.fixturePose->pose, want.fixturePose->pose);
    }
    EXPECT_EQ(back.views[0].camera.intrinsics().dist, m.views[0].camera.intrinsics().dist);
    EXPECT_FALSE(back.views[1].camera.intrinsics().hasDistortion());
    EXPECT_EQ(back.segmentation.method, SegmentationMethod::Fixed);
    EXPECT_EQ(back.segmentation.threshold, 97.5);
    EXPECT_FALSE(back.segmentation.objectIsDark);
    ASSERT_NE(back.find("side"), nullptr);
    EXPECT_EQ(back.find("nope"), nullptr);
}

TEST(Manifest, ContractExampleWithProjectionMatrix)
{
    // K, R, t chosen by hand; P = K [R | t] written out (R: 90° about z).
    // K = [[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], R = [[0,-1,0],[1,0,0],[0,0,1]], t = (10, 20, 500):
    // K R = [[0, -1000, 320], [1000, 0, 240], [0, 0, 1]], K t = (10000 + 160000, 20000 + 120000, 500).
    hgtest::TempDir tmp;
    const auto file = hgtest::writeFile(tmp / "manifest.json", R"({
      "views": [
        {"id": "v0", "image": "v0.png",
         "K": [[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], "dist": [0, 0, 0, 0, 0],
         "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [0, 0, 300]},
        {"id": "v1", "image": "/abs/v1.png",
         "P": [[0, -2000, 640, 340000], [2000, 0, 480, 280000], [0, 0, 2, 1000]]}
      ]
    })");
    const CaptureManifest m = readManifest(file);
    ASSERT_EQ(m.views.size(), 2u);
    EXPECT_EQ(m.segmentation.method, SegmentationMethod::Otsu); // defaults
    EXPECT_TRUE(m.segmentation.objectIsDark);
    EXPECT_EQ(m.views[0].image, tmp / "v0.png");
    EXPECT_EQ(m.views[1].image, std::filesystem::path("/abs/v1.png"));
    EXPECT_FALSE(m.views[0].fromProjectionMatrix);
    EXPECT_TRUE(m.views[1].fromProjectionMatrix);

    const CameraModel& cam = m.views[1].camera;
    geometry::Mat3 K, R;
    K << 1000, 0, 320, 0, 1000, 240, 0, 0, 1;
    R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
    EXPECT_LT((cam.intrinsics().K - K).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((cam.cameraFromPart().R - R).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((cam.cameraFromPart().t - Vec3(10, 20, 500)).norm(), 1e-9);
    // Part point (5, -3, 40): camera (13, 25, 540) -> pixel (320 + 1000*13/540, 240 + 1000*25/540).
    auto px = cam.project(Vec3(5, -3, 40));
    ASSERT_TRUE(px);
    EXPECT_NEAR(px->x(), 320 + 13000.0 / 540, 1e-9);
    EXPECT_NEAR(px->y(), 240 + 25000.0 / 540, 1e-9);
}

struct BadCase {
    const char* name;
    std::string json;
    std::string field;
    std::string problem; // a part of the expected message
};

// Names the case in CTest's list instead of dumping its bytes.
void PrintTo(const BadCase& c, std::ostream* os)
{
    *os << c.name;
}

std::string goodView(const std::string& id)
{
    return R"({"id": ")" + id +
           R"(", "image": "x.png", "K": [[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [0, 0, 300]})";
}

std::string views(const std::string& a, const std::string& b = "", const std::string& rest = "")
{
    std::string v = R"({"views": [)" + goodView("a") + ", " + goodView("b") + ", " + a;
    if (!b.empty()) v += ", " + b;
    return v + "]" + rest + "}";
}

const std::string kK = R"("K": [[1000, 0, 320], [0, 1000, 240], [0, 0, 1]])";
const std::string kR = R"("R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]])";
const std::string kT = R"("t": [0, 0, 300])";

class MalformedManifest : public ::testing::TestWithParam<BadCase> {};

TEST_P(MalformedManifest, NamesFileAndField)
{
    const BadCase& c = GetParam();
    hgtest::TempDir tmp;
    const auto file = hgtest::writeFile(tmp / "manifest.json", c.json);
    try {
        readManifest(file);
        FAIL() << "accepted: " << c.json;
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), file.string());
        EXPECT_EQ(e.field(), c.field) << e.what();
        EXPECT_NE(e.problem().find(c.problem), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
        EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": " + c.field, 0), 0u) << e.what();
    }
}

INSTANTIATE_TEST_SUITE_P(
    Fields, MalformedManifest,
    ::testing::Values(
        BadCase{"KWrongShape",
                views(R"({"id": "c", "image": "c.png", "K": [[1000, 0], [0, 1000], [0, 0]], )" + kR + ", " + kT + "}"),
                "views[2].K", "expected 3 rows of 3 numbers"},
        BadCase{"KNotUpperTriangular",
                views(R"({"id": "c", "image": "c.png", "K": [[1000, 0, 320], [5, 1000, 240], [0, 0, 1]], )" + kR +
                      ", " + kT + "}"),
                "views[2].K", "upper triangular"},
        BadCase{"KNegativeFocal",
                views(R"({"id": "c", "image": "c.png", "K": [[-1000, 0, 320], [0, 1000, 240], [0, 0, 1]], )" + kR +
                      ", " + kT + "}"),
                "views[2].K", "positive"},
        BadCase{"KHoldsString",
                views(R"({"id": "c", "image": "c.png", "K": [[1000, 0, 320], [0, "f", 240], [0, 0, 1]], )" + kR + ", " +
                      kT + "}"),
                "views[2].K", "expected 3 rows of 3 numbers"},
        BadCase{"RNotRotation",
                views(R"({"id": "c", "image": "c.png", )" + kK + R"(, "R": [[1, 0, 0], [0, 1, 0], [0, 0, -1]], )" + kT +
                      "}"),
                "views[2].R", "not a rotation"},
        BadCase{"TWrongLength", views(R"({"id": "c", "image": "c.png", )" + kK + ", " + kR + R"(, "t": [0, 300]})"),
                "views[2].t", "expected 3 numbers"},
        BadCase{"MissingR", views(R"({"id": "c", "image": "c.png", )" + kK + ", " + kT + "}"), "views[2].R", "missing"},
        BadCase{"MissingImage", views(R"({"id": "c", )" + kK + ", " + kR + ", " + kT + "}"), "views[2].image",
                "missing"},
        BadCase{"ImageNotString", views(R"({"id": "c", "image": 7, )" + kK + ", " + kR + ", " + kT + "}"),
                "views[2].image", "expected a string"},
        BadCase{"MissingId", views(R"({"image": "c.png", )" + kK + ", " + kR + ", " + kT + "}"), "views[2].id",
                "missing"},
        BadCase{"DuplicateId", views(goodView("a")), "views[2].id", "duplicate id 'a'"},
        BadCase{"DistCount",
                views(R"({"id": "c", "image": "c.png", )" + kK + ", " + kR + ", " + kT + R"(, "dist": [0, 0, 0]})"),
                "views[2].dist", "expected 4, 5, 8 or 12"},
        BadCase{"PWrongShape", views(R"({"id": "c", "image": "c.png", "P": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]})"),
                "views[2].P", "expected 3 rows of 4 numbers"},
        BadCase{"PSingular", views(R"({"id": "c", "image": "c.png", "P": [[1, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 1]]})"),
                "views[2].P", "singular"},
        BadCase{"PAndK",
                views(R"({"id": "c", "image": "c.png", "P": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1]], )" + kK + "}"),
                "views[2].K", "either P or K"},
        BadCase{"ImageSize",
                views(R"({"id": "c", "image": "c.png", "image_size": [640], )" + kK + ", " + kR + ", " + kT + "}"),
                "views[2].image_size", "[width, height]"},
        BadCase{"FixturePose",
                views(R"({"id": "c", "image": "c.png", "fixture_pose": {"rotation_deg": "ten"}, )" + kK + ", " + kR +
                      ", " + kT + "}"),
                "views[2].fixture_pose.rotation_deg", "expected a number"},
        BadCase{"ViewNotObject", views("[1, 2]"), "views[2]", "expected an object"},
        BadCase{"MethodUnknown", views(goodView("c"), "", R"(, "segmentation": {"method": "canny"})"),
                "segmentation.method", "expected otsu, fixed or mask"},
        BadCase{"FixedNeedsThreshold", views(goodView("c"), "", R"(, "segmentation": {"method": "fixed"})"),
                "segmentation.threshold", "missing"},
        BadCase{"ThresholdRange", views(goodView("c"), "", R"(, "segmentation": {"method": "fixed", "threshold": -4})"),
                "segmentation.threshold", "within [0, 65535]"},
        BadCase{"ObjectIsDarkType", views(goodView("c"), "", R"(, "segmentation": {"object_is_dark": "yes"})"),
                "segmentation.object_is_dark", "expected true or false"},
        BadCase{"ViewsNotArray", R"({"views": {"id": "a"}})", "views", "expected an array"},
        BadCase{"ViewsEmpty", R"({"views": []})", "views", "at least one view"},
        BadCase{"ViewsMissing", R"({"segmentation": {"method": "otsu"}})", "views", "missing"},
        BadCase{"TAbsurd", views(R"({"id": "c", "image": "c.png", )" + kK + ", " + kR + R"(, "t": [1e308, 0, 300]})"),
                "views[2].t", "within ±1e5 mm"},
        BadCase{"CxAbsurd",
                views(R"({"id": "c", "image": "c.png", "K": [[1000, 0, -9.2e18], [0, 1000, 240], [0, 0, 1]], )" + kR +
                      ", " + kT + "}"),
                "views[2].K", "within ±1e7 px"},
        BadCase{"OriginNotPair",
                views(R"({"id": "c", "image": "c.png", "image_size": [640, 480], "origin": [3], )" + kK + ", " + kR +
                      ", " + kT + "}"),
                "views[2].origin", "expected [x, y]"},
        BadCase{"OriginFractional",
                views(R"({"id": "c", "image": "c.png", "image_size": [640, 480], "origin": [3.5, 0], )" + kK + ", " +
                      kR + ", " + kT + "}"),
                "views[2].origin", "whole non-negative pixels, found 3.5"},
        BadCase{"OriginNegative",
                views(R"({"id": "c", "image": "c.png", "image_size": [640, 480], "origin": [0, -8], )" + kK + ", " +
                      kR + ", " + kT + "}"),
                "views[2].origin", "whole non-negative pixels, found -8"},
        BadCase{"OriginWithoutSensorSize",
                views(R"({"id": "c", "image": "c.png", "origin": [10, 20], )" + kK + ", " + kR + ", " + kT + "}"),
                "views[2].origin", "needs image_size"},
        BadCase{"OriginOffTheSensor",
                views(R"({"id": "c", "image": "c.png", "image_size": [640, 480], "origin": [640, 0], )" + kK + ", " +
                      kR + ", " + kT + "}"),
                "views[2].origin", "[640, 0] lies outside the 640x480 sensor"}),
    [](const ::testing::TestParamInfo<BadCase>& param) { return std::string(param.param.name); });

TEST(Manifest, SyntaxErrorNamesTheLine)
{
    hgtest::TempDir tmp;
    const auto file = hgtest::writeFile(tmp / "manifest.json", "{\n  \"views\": [\n    {\"id\": \"a\",, }\n  ]\n}\n");
    try {
        readManifest(file);
        FAIL() << "accepted a syntax error";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), file.string());
        ASSERT_TRUE(e.line());
        EXPECT_EQ(*e.line(), 3);
        EXPECT_NE(e.problem().find("syntax error"), std::string::npos) << e.what();
    }
}

TEST(Manifest, MissingFileIsBadInput)
{
    hgtest::TempDir tmp;
    EXPECT_THROW(readManifest(tmp / "absent.json"), InputError);
}

TEST(Manifest, ARegionImageIsReadWhereItLiesAndRefusedWhereItLeavesTheSensor)
{
    // docs/contracts.md §3: `origin` places a region image on the sensor of
    // image_size; a 64x48 region at [576, 432] ends on the 640x480 sensor's
    // last pixel, one pixel further it leaves it.
    hgtest::TempDir tmp;
    cv::Mat region(48, 64, CV_8UC1, cv::Scalar(200));
    ASSERT_TRUE(cv::imwrite((tmp / "region.png").string(), region));
    const auto view = [](const std::string& id, const std::string& origin) {
        return R"({"id": ")" + id + R"(", "image": "region.png", "image_size": [640, 480], "origin": )" + origin +
               ", " + kK + ", " + kR + ", " + kT + "}";
    };
    const auto file = hgtest::writeFile(tmp / "manifest.json", R"({"views": [)" + view("in", "[576, 432]") + ", " +
                                                                   view("out", "[577, 432]") + "]}");
    const CaptureManifest m = readManifest(file);
    ASSERT_TRUE(m.views[0].origin);
    EXPECT_EQ(*m.views[0].origin, cv::Point(576, 432));
    EXPECT_EQ(readViewImage(m, 0).size(), cv::Size(64, 48));
    try {
        (void)readViewImage(m, 1);
        FAIL() << "a region leaving the sensor was read";
    } catch (const InputError& e) {
        EXPECT_NE(e.problem().find("64x48 at origin [577, 432]: it leaves the 640x480 sensor"), std::string::npos)
            << e.what();
    }
}

TEST(Manifest, ReadsViewImagesAsGreyOfTheirDepth)
{
    hgtest::TempDir tmp;
    cv::Mat deep(48, 64, CV_16UC1, cv::Scalar(40000));
    deep(cv::Rect(10, 10, 20, 20)).setTo(1200);
    ASSERT_TRUE(cv::imwrite((tmp / "deep.png").string(), deep));
    cv::Mat colour(48, 64, CV_8UC3, cv::Scalar(200, 200, 200));
    ASSERT_TRUE(cv::imwrite((tmp / "colour.png").string(), colour));
    const auto file = hgtest::writeFile(tmp / "manifest.json", R"({"views": [
        {"id": "d", "image": "deep.png", "image_size": [64, 48], )" +
                                                                   kK + ", " + kR + ", " + kT + R"(},
        {"id": "c", "image": "colour.png", )" + kK + ", " + kR + ", " +
                                                                   kT + R"(},
        {"id": "s", "image": "deep.png", "image_size": [640, 480], )" +
                                                                   kK + ", " + kR + ", " + kT + R"(},
        {"id": "m", "image": "missing.png", )" + kK + ", " + kR + ", " +
                                                                   kT + R"(}]})");
    const CaptureManifest m = readManifest(file);

    cv::Mat d = readViewImage(m, 0);
    ASSERT_EQ(d.type(), CV_16UC1);
    EXPECT_EQ(cv::norm(d, deep, cv::NORM_INF), 0.0);
    cv::Mat c = readViewImage(m, 1);
    ASSERT_EQ(c.type(), CV_8UC1);
    EXPECT_EQ(c.at<std::uint8_t>(5, 5), 200);

    for (std::size_t bad : {2u, 3u}) {
        try {
            readViewImage(m, bad);
            FAIL() << "view " << bad << " accepted";
        } catch (const InputError& e) {
            EXPECT_EQ(e.field(), "views[" + std::to_string(bad) + "].image") << e.what();
        }
    }
}

// A header claiming 65535 x 65535 pixels (16 GiB of frame) is refused from
// its IHDR chunk, before any decoder allocates or prints a line of its own.
TEST(Manifest, ImageClaimingTooManyPixelsIsRefusedBeforeDecoding)
{
    hgtest::TempDir tmp;
    const unsigned char header[] = {0x89, 'P', 'N', 'G',  '\r', '\n', 0x1A, '\n', 0,    0, 0, 13, 'I', 'H', 'D',
                                    'R',  0,   0,   0xFF, 0xFF, 0,    0,    0xFF, 0xFF, 8, 0, 0,  0,   0};
    hgtest::writeFile(tmp / "huge.png", std::string(reinterpret_cast<const char*>(header), sizeof header));
    const auto file = hgtest::writeFile(tmp / "manifest.json", R"({"views": [{"id": "h", "image": "huge.png", )" + kK +
                                                                   ", " + kR + ", " + kT + "}]}");
    const CaptureManifest m = readManifest(file);
    try {
        readViewImage(m, 0);
        FAIL() << "a 65535x65535 image was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), file.string());
        EXPECT_EQ(e.field(), "views[0].image");
        EXPECT_NE(e.problem().find("65535x65535"), std::string::npos) << e.what();
    }
}

// The strict reader's refusals reach the manifest's reader: file, key and line named.
TEST(Manifest, DuplicateKeyAndNumberPastDoubleAreBadInput)
{
    hgtest::TempDir tmp;
    for (const std::string& text : {std::string(R"({"views": [)") + R"({"id": "a", "id": "b"}]})",
                                    std::string(R"({"views": [{"id": "a", "t": [1e400, 0, 0]}]})")}) {
        const auto file = hgtest::writeFile(tmp / "manifest.json", text);
        try {
            readManifest(file);
            FAIL() << "accepted: " << text;
        } catch (const InputError& e) {
            EXPECT_EQ(e.file(), file.string());
            EXPECT_NE(std::string(e.what()).find(text.find("1e400") == std::string::npos ? "id" : "t"),
                      std::string::npos)
                << e.what();
        }
    }
}

} // namespace
} // namespace hg::vision
