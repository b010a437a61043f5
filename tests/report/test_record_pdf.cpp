// The part record's PDF (src/report/record_pdf.cpp, docs/hmi.md "Part
// record") read back with an independent reader, poppler's pdftotext, pdfinfo
// and pdfimages: the facts, every landmark with its numbers, A4 pages, the view
// embedded as an image; a long table runs onto more pages; a row missing a
// field is refused naming it. `hullgauge record` on a store written with sqlite3.
#include "hullgauge/common/error.h"
#include "hullgauge/report/record_pdf.h"

#include "hgtest/paths.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <fstream>
#include <regex>
#include <sstream>

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

const char* kSha = "3f5a0c1e9b7d2468ace013579bdf2468ace013579bdf2468ace013579bdf2468";

/// A small annotated view: a grey silhouette with a red mark, 64 × 48 px.
std::vector<unsigned char> viewPng()
{
    cv::Mat image(48, 64, CV_8UC3, cv::Scalar(230, 230, 230));
    cv::rectangle(image, {10, 12}, {50, 40}, cv::Scalar(60, 60, 60), cv::FILLED);
    cv::circle(image, {30, 26}, 5, cv::Scalar(0, 0, 255), cv::FILLED);
    std::vector<unsigned char> png;
    EXPECT_TRUE(cv::imencode(".png", image, png));
    return png;
}

/// A failed part: one landmark measured to a deviation, one not found with only its voxel bracket.
json failedRow()
{
    return json::parse(R"({
      "id": 42, "time": "2026-12-02T10:30:05.250Z", "started_unix_ms": 1796207405250, "trigger_seq": 7,
      "manual": false, "serial": "SN-REC-0042", "program": 3, "part": "stepped-block", "verdict": "fail",
      "fault_code": 0, "cycle_ms": 812, "landmarks_failed": 1, "landmarks_total": 2, "purpose": "production",
      "program_version": 4, "program_sha256": ")" +
                       std::string(kSha) + R"(",
      "alignment": {"measured": true, "shift_mm": 0.1375, "shift_uncertainty_mm": 0.0125, "rotation_deg": 0.215,
                    "rotation_uncertainty_deg": 0.02, "residual_px": 0.31, "within_limits": true},
      "landmarks": [
        {"id": "face_top", "status": "ok", "error_min_mm": -0.05, "error_max_mm": 0.05, "error_mm": 0.0,
         "tolerance_mm": 0.2, "deviation_mm": 0.0123, "uncertainty_mm": 0.0046, "decision": "conforms"},
        {"id": "bore_left", "status": "not_found", "error_min_mm": -0.2875, "error_max_mm": 0.3625,
         "limits_mm": [-0.15, 0.25]}
      ]})");
}

std::string contents(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

fs::path writePdf(const hgtest::TempDir& dir, const json& row, const std::vector<hg::report::RecordView>& views)
{
    std::ostringstream pdf;
    hg::report::writeRecordPdf(pdf, row, views, {"gauge-7", 1796207500000});
    const auto file = dir / "record.pdf";
    std::ofstream(file, std::ios::binary) << pdf.str();
    return file;
}

/// What a poppler tool prints for `file`; the test fails when it does not run.
std::string poppler(const std::string& tool, const fs::path& file)
{
    const auto r = hgtest::run(tool + " '" + file.string() + "' -");
    EXPECT_EQ(r.status, 0) << tool << ": " << r.err;
    return r.out;
}

int pages(const std::string& info)
{
    const auto at = info.find("Pages:");
    return at == std::string::npos ? 0 : std::stoi(info.substr(at + 6));
}

TEST(RecordPdf, HoldsTheFactsEveryLandmarkAndTheView)
{
    hgtest::TempDir dir;
    const auto file = writePdf(dir, failedRow(), {{"view_1.png", viewPng()}});
    ASSERT_EQ(contents(file).rfind("%PDF-", 0), 0u);
    const auto text = poppler("pdftotext -layout", file);
    for (const char* expected :
         {"SN-REC-0042", "FAIL", "version 4", kSha, "stepped-block", "gauge-7", "2026-12-02T10:30:05.250Z", "812 ms",
          // the measured landmark: its deviation, U, zone and decision
          "face_top", "0.0123", "0.0046", "±0.2000", "conforms",
          // the one not found: its bracket and limits, no deviation
          "bore_left", "not found", "[-0.2875, 0.3625]", "[-0.1500, 0.2500]",
          // the seat
          "0.1375", "0.215", "view_1.png"})
        EXPECT_NE(text.find(expected), std::string::npos) << "'" << expected << "' missing from:\n" << text;
    // The bracket of a landmark with a deviation stays out (docs/hmi.md, "Part record").
    EXPECT_EQ(text.find("[-0.0500, 0.0500]"), std::string::npos) << text;

    const auto info = hgtest::run("pdfinfo '" + file.string() + "'");
    ASSERT_EQ(info.status, 0) << info.err;
    EXPECT_GE(pages(info.out), 1) << info.out;
    EXPECT_TRUE(std::regex_search(info.out, std::regex(R"(Page size:\s+595\.276 x 841\.89 pts \(A4\))"))) << info.out;

    // pdfimages -list: page num type width height ...; the view is one 64 × 48 image.
    const auto images = hgtest::run("pdfimages -list '" + file.string() + "'");
    ASSERT_EQ(images.status, 0) << images.err;
    std::istringstream lines(images.out);
    std::string line;
    int views = 0;
    while (std::getline(lines, line)) {
        std::istringstream cells(line);
        std::string page, num, type, width, height;
        cells >> page >> num >> type >> width >> height;
        if (type == "image" && width == "64" && height == "48") ++views;
    }
    EXPECT_EQ(views, 1) << images.out;
}

TEST(RecordPdf, ALandmarkTheBracketCouldNotPlaceIsReadByItsBracketAndAContradictionIsNamed)
{
    // docs/hmi.md, "Landmark rows": a not-found corner whose sub-voxel gauge still reported −0.2260 mm
    // against a bracket of |error| in [0.9756, 1.0976] (width 0.1220): 0.2260 < 0.9756 − 0.1220, a fault
    // of the inspection. The row shows the bracket and names the fault, never the deviation as a reading;
    // an overflow 0.01 mm below its open bracket's lower end is no contradiction.
    hgtest::TempDir dir;
    auto row = failedRow();
    row["landmarks"].push_back({{"id", "tall_corner"},
                                {"status", "not_found"},
                                {"error_min_mm", 0.9756},
                                {"error_max_mm", 1.0976},
                                {"tolerance_mm", 0.4},
                                {"deviation_mm", -0.2260},
                                {"uncertainty_mm", 0.0496}});
    row["landmarks"].push_back({{"id", "tall_side"},
                                {"status", "overflow"},
                                {"error_min_mm", 1.0976},
                                {"error_max_mm", 1.2195},
                                {"tolerance_mm", 0.4},
                                {"deviation_mm", 1.0876},
                                {"uncertainty_mm", 0.05}});
    const auto text = poppler("pdftotext -layout", writePdf(dir, row, {}));
    const auto line = [&](const std::string& id) {
        const auto at = text.find(id);
        return at == std::string::npos ? std::string() : text.substr(at, text.find('\n', at) - at);
    };
    const auto corner = line("tall_corner");
    EXPECT_NE(corner.find("[0.9756, 1.0976]"), std::string::npos) << corner;
    EXPECT_NE(corner.find("inspection fault"), std::string::npos) << corner;
    EXPECT_EQ(corner.find("0.2260"), std::string::npos) << corner;
    const auto side = line("tall_side");
    EXPECT_NE(side.find("[1.0976, 1.2195]"), std::string::npos) << side;
    EXPECT_EQ(side.find("inspection fault"), std::string::npos) << side;
    EXPECT_EQ(side.find("1.0876"), std::string::npos) << side;
}

TEST(RecordPdf, ADraftAndNoViewsSaySo)
{
    hgtest::TempDir dir;
    auto row = failedRow();
    row["program_version"] = nullptr;
    row["program_sha256"] = nullptr;
    row["verdict"] = "pass";
    const auto text = poppler("pdftotext -layout", writePdf(dir, row, {}));
    EXPECT_NE(text.find("draft"), std::string::npos) << text;
    EXPECT_NE(text.find("PASS"), std::string::npos) << text;
    EXPECT_NE(text.find("No images archived"), std::string::npos) << text;
}

TEST(RecordPdf, SixtyLandmarksRunOntoMorePages)
{
    hgtest::TempDir dir;
    auto row = failedRow();
    row["landmarks"] = json::array();
    for (int i = 0; i < 60; ++i) {
        char id[16];
        std::snprintf(id, sizeof id, "lm_%02d", i);
        row["landmarks"].push_back({{"id", id},
                                    {"status", "ok"},
                                    {"tolerance_mm", 0.2},
                                    {"deviation_mm", 0.001 * i},
                                    {"uncertainty_mm", 0.004},
                                    {"decision", "conforms"}});
    }
    const auto file = writePdf(dir, row, {{"view_1.png", viewPng()}});
    const auto info = hgtest::run("pdfinfo '" + file.string() + "'");
    // The table alone takes more than the first page; the view a page of its own.
    EXPECT_GE(pages(info.out), 3) << info.out;
    const auto text = poppler("pdftotext -layout", file);
    for (int i = 0; i < 60; ++i) {
        char id[16];
        std::snprintf(id, sizeof id, "lm_%02d", i);
        EXPECT_NE(text.find(id), std::string::npos) << id << " missing";
    }
    EXPECT_NE(text.find("Landmarks (continued)"), std::string::npos);
    // The running header on every page: the serial once per page.
    std::size_t serials = 0;
    for (auto at = text.find("Serial SN-REC-0042"); at != std::string::npos;
         at = text.find("Serial SN-REC-0042", at + 1))
        ++serials;
    EXPECT_EQ(static_cast<int>(serials), pages(info.out));
}

/// The field the refusal names, and that nothing was written.
std::string refusedField(const json& row, const std::vector<hg::report::RecordView>& views = {})
{
    std::ostringstream out;
    try {
        hg::report::writeRecordPdf(out, row, views);
    } catch (const hg::InputError& e) {
        EXPECT_TRUE(out.str().empty()) << e.what();
        return e.field().empty() ? e.file() : e.field();
    }
    ADD_FAILURE() << "not refused: " << row.dump();
    return "";
}

TEST(RecordPdf, RefusesARowMissingAFieldNamingIt)
{
    auto row = failedRow();
    row.erase("verdict");
    EXPECT_EQ(refusedField(row), "verdict");
    row = failedRow();
    row.erase("serial");
    EXPECT_EQ(refusedField(row), "serial");
    row = failedRow();
    row.erase("id");
    EXPECT_EQ(refusedField(row), "id");
    row = failedRow();
    row["landmarks"][1].erase("status");
    EXPECT_EQ(refusedField(row), "landmarks[1].status");
    row = failedRow();
    row["landmarks"][0].erase("tolerance_mm");
    EXPECT_EQ(refusedField(row), "landmarks[0].tolerance_mm");
    row = failedRow();
    row["landmarks"] = "none";
    EXPECT_EQ(refusedField(row), "landmarks");
    EXPECT_EQ(refusedField(json::array()), "row");
    std::vector<unsigned char> notPng{'G', 'I', 'F', '8', '9', 'a', 0, 0, 0, 0};
    EXPECT_EQ(refusedField(failedRow(), {{"view_2.png", notPng}}), "view_2.png");
    auto cut = viewPng();
    cut.resize(cut.size() / 2);
    EXPECT_EQ(refusedField(failedRow(), {{"view_3.png", cut}}), "view_3.png");
}

TEST(RecordPdf, FileNameCarriesIdAndSerial)
{
    auto row = failedRow();
    EXPECT_EQ(hg::report::recordFileName(row), "hullgauge-record-42-SN-REC-0042.pdf");
    row["serial"] = "A/B \"7\"";
    EXPECT_EQ(hg::report::recordFileName(row), "hullgauge-record-42-A_B__7_.pdf");
    row["serial"] = "";
    EXPECT_EQ(hg::report::recordFileName(row), "hullgauge-record-42.pdf");
}

TEST(RecordPdf, WordsForStatusesAndDecisions)
{
    EXPECT_EQ(hg::report::statusWords("out_of_tolerance"), "out of tolerance");
    EXPECT_EQ(hg::report::statusWords("not_observable"), "not observable");
    EXPECT_EQ(hg::report::decisionWords("nonconforms"), "does not conform");
}

// ---- hullgauge record ----------------------------------------------------------------------------------------

std::string hullgauge()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

/// One stored cycle (id 1) in the daemon's layout, archived in `images`/<folder> with one view.
fs::path makeStore(const hgtest::TempDir& dir)
{
    const auto folder = dir / "images" / "1796207405250_SN-CLI-9";
    fs::create_directories(folder);
    const auto png = viewPng();
    std::ofstream(folder / "view_1.png", std::ios::binary)
        .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    const std::string landmarks = failedRow()["landmarks"].dump();
    const std::string sql =
        "CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT, started_unix_ms INTEGER, "
        "serial TEXT, program INTEGER, part TEXT, verdict TEXT, landmarks_json TEXT, images_dir TEXT);\n"
        "INSERT INTO inspections (started_utc, started_unix_ms, serial, program, part, verdict, landmarks_json, "
        "images_dir) VALUES ('2026-12-02T10:30:05.250Z', 1796207405250, 'SN-CLI-9', 3, 'stepped-block', 'fail', '" +
        landmarks + "', '" + folder.string() + "');\n";
    const auto script = hgtest::writeFile(dir / "rows.sql", sql);
    const auto db = dir / "results.db";
    EXPECT_EQ(hgtest::run("sqlite3 " + db.string() + " < " + script.string()).status, 0);
    return db;
}

TEST(RecordCli, WritesThePdfOfAStoredResult)
{
    hgtest::TempDir dir;
    const auto db = makeStore(dir);
    const auto out = dir / "part.pdf";
    const auto r = hgtest::run(hullgauge() + " record 1 --out " + out.string() + " --results " + db.string() +
                               " --images " + (dir / "images").string() + " --station line-3");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto text = poppler("pdftotext -layout", out);
    for (const char* expected : {"SN-CLI-9", "FAIL", "draft", "face_top", "bore_left", "line-3", "view_1.png"})
        EXPECT_NE(text.find(expected), std::string::npos) << "'" << expected << "' missing from:\n" << text;
}

TEST(RecordCli, RefusesAnUnknownId)
{
    hgtest::TempDir dir;
    const auto db = makeStore(dir);
    const auto out = dir / "part.pdf";
    auto r = hgtest::run(hullgauge() + " record 99 --out " + out.string() + " --results " + db.string());
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("no result 99"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    r = hgtest::run(hullgauge() + " record 1 --out " + out.string() + " --results " + (dir / "none.db").string());
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

} // namespace
