// The flat-field reference's file (docs/health.md, "Reference file"): a
// round trip keeps every figure to the bit; a malformed file is refused
// naming the file and the field.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>

#include "hgtest/paths.h"
#include "hullgauge/calib/flat_field.h"
#include "hullgauge/common/error.h"

using namespace hg::calib;
using hg::vision::FlatField;

namespace {

// A reference built from frames of a 96 x 70 sensor (cells of 32 px: 3 x 3
// blocks, the last row and column partial) with one dark speck.
FlatField sampleReference()
{
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0.0, 1.2);
    std::vector<cv::Mat> frames;
    for (int i = 0; i < 3; ++i) {
        cv::Mat f(70, 96, CV_8UC1);
        for (int y = 0; y < f.rows; ++y)
            for (int x = 0; x < f.cols; ++x)
                f.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(180.0 - 0.3 * x + 0.2 * y + noise(rng));
        f(cv::Rect(40, 20, 2, 2)) *= 0.5;
        frames.push_back(f);
    }
    return hg::vision::buildFlatField(frames, 1'790'123'456'789);
}

std::string readText(const std::filesystem::path& p)
{
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// The refusal of `text` as a reference file: the message, or "accepted".
std::string refusal(const hgtest::TempDir& dir, const std::string& text)
{
    const auto file = hgtest::writeFile(dir / "flat_field.json", text);
    try {
        readFlatField(file);
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.file(), file.string());
        return e.field() + ": " + e.problem();
    }
    return "accepted";
}

// A valid document with `key` replaced by `value` (JSON text), or removed when `value` is empty.
std::string with(const std::string& key, const std::string& value)
{
    std::string doc = R"({"format": "hullgauge flat field", "version": 1, "sensor": [64, 40], "cell": 32,)"
                      R"( "blocks": [2, 2], "level": [0.7, 0.71, 0.69, 0.7], "noise": 0.005,)"
                      R"( "dust_specks": [[10.5, 20.0]], "taken_unix_ms": 1790000000000})";
    const std::string quoted = "\"" + key + "\": ";
    const auto at = doc.find(quoted);
    // The field's value runs to the next top-level comma or the closing brace.
    std::size_t end = at + quoted.size();
    for (int depth = 0; end < doc.size(); ++end) {
        if (doc[end] == '[') ++depth;
        if (doc[end] == ']') --depth;
        if (depth == 0 && (doc[end] == ',' || doc[end] == '}')) break;
    }
    if (value.empty()) return doc.erase(at, end - at + (doc[end] == ',' ? 2 : 0));
    return doc.replace(at + quoted.size(), end - at - quoted.size(), value);
}

} // namespace

TEST(FlatFieldFile, RoundTripKeepsEveryFigure)
{
    const FlatField ref = sampleReference();
    ASSERT_EQ(ref.level.size(), cv::Size(3, 3));
    ASSERT_EQ(ref.dustSpecks, 1);
    hgtest::TempDir dir;
    const auto file = dir / "flat_field.json";
    writeFlatField(file, ref);
    const FlatField back = readFlatField(file);
    EXPECT_EQ(back.sensor, ref.sensor);
    EXPECT_EQ(back.cell, ref.cell);
    EXPECT_EQ(back.level.type(), CV_32FC1);
    ASSERT_EQ(back.level.size(), ref.level.size());
    EXPECT_EQ(cv::countNonZero(back.level != ref.level), 0); // to the bit
    EXPECT_EQ(back.noise, ref.noise);
    EXPECT_EQ(back.dustSpecks, 1);
    ASSERT_EQ(back.dustAt.size(), 1u);
    EXPECT_EQ(back.dustAt[0], ref.dustAt[0]);
    EXPECT_EQ(back.takenUnixMs, 1'790'123'456'789);
    // The documented layout (docs/health.md): the blocks' rows one after the other.
    const std::string text = readText(file);
    EXPECT_EQ(text.rfind("{\n \"format\": \"hullgauge flat field\",\n \"version\": 1,", 0), 0u) << text.substr(0, 80);
    EXPECT_NE(text.find("\"blocks\": [\n  3,\n  3\n ]"), std::string::npos) << text.substr(0, 200);
    // Rewritten in place: replaced whole.
    FlatField other = ref;
    other.noise = 0.25;
    writeFlatField(file, other);
    EXPECT_EQ(readFlatField(file).noise, 0.25);
}

TEST(FlatFieldFile, RefusesMalformedFilesNamingTheField)
{
    hgtest::TempDir dir;
    EXPECT_EQ(refusal(dir, with("cell", "32")), "accepted");
    EXPECT_EQ(refusal(dir, with("format", "\"a flat field\"")),
              "format: expected \"hullgauge flat field\", found \"a flat field\"");
    EXPECT_EQ(refusal(dir, with("version", "2")), "version: 2 is not known (this build reads 1)");
    EXPECT_EQ(refusal(dir, with("sensor", "")), "sensor: missing");
    EXPECT_EQ(refusal(dir, with("sensor", "[64]")), "sensor: expected [width, height], found [64]");
    EXPECT_EQ(refusal(dir, with("sensor", "[64, -40]")), "sensor[1]: -40 is outside [1, 1000000]");
    EXPECT_EQ(refusal(dir, with("cell", "0")), "cell: 0 is outside [1, 40]");
    EXPECT_EQ(refusal(dir, with("blocks", "[2, 3]")),
              "blocks: [2, 3] does not fit the sensor [64, 40] in cells of 32 px: expected [2, 2]");
    EXPECT_EQ(refusal(dir, with("level", "[0.7, 0.7, 0.7]")),
              "level: expected 4 numbers (the blocks' rows one after the other), found 3");
    EXPECT_EQ(refusal(dir, with("level", "[0.7, 0.7, 0, 0.7]")), "level[2]: 0 is outside [1e-06, 1.0]");
    EXPECT_EQ(refusal(dir, with("level", "[0.7, \"bright\", 0.7, 0.7]")),
              "level[1]: expected a number, found \"bright\"");
    EXPECT_EQ(refusal(dir, with("noise", "-0.1")), "noise: -0.1 is outside [0.0, 1.0]");
    EXPECT_EQ(refusal(dir, with("dust_specks", "[[10, 20], [64, 3]]")), "dust_specks[1][0]: 64 is outside [0.0, 63.0]");
    EXPECT_EQ(refusal(dir, with("dust_specks", "[[10, 20, 1]]")), "dust_specks[0]: expected [x, y] in sensor pixels");
    EXPECT_EQ(refusal(dir, with("taken_unix_ms", "1.5")), "taken_unix_ms: expected a whole number, found 1.5");
    EXPECT_EQ(refusal(dir, "[1, 2]"), ": expected a JSON object");

    // Broken JSON: the parser's refusal names the file and the line.
    const auto broken =
        hgtest::writeFile(dir / "broken.json", "{\"format\": \"hullgauge flat field\",\n \"version\": 1,\n");
    try {
        readFlatField(broken);
        FAIL() << "accepted broken JSON";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.file(), broken.string());
        EXPECT_TRUE(e.line().has_value());
    }
    try {
        readFlatField(dir / "none.json");
        FAIL() << "read a file that is not there";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.file(), (dir / "none.json").string());
        EXPECT_EQ(e.problem(), "cannot open file");
    }
}

TEST(FlatFieldFile, WriteRefusesAnEmptyReferenceAndReportsAFolderThatIsNotThere)
{
    hgtest::TempDir dir;
    EXPECT_THROW(writeFlatField(dir / "a.json", FlatField{}), hg::ArgumentError);
    EXPECT_FALSE(std::filesystem::exists(dir / "a.json"));
    try {
        writeFlatField(dir / "missing" / "a.json", sampleReference());
        FAIL() << "wrote into a folder that is not there";
    } catch (const hg::FaultError& e) {
        EXPECT_NE(std::string(e.what()).find("missing"), std::string::npos) << e.what();
    }
}
