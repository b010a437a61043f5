// The exports of docs/export.md on rows built here in the shape ResultReader::select
// returns (docs/daemon.md, "Results"), each format against its text written out
// by hand from the format's definition: RFC 4180 for CSV, the Q-DAS ASCII
// transfer format's K-field lines for AQDEF.
#include "hullgauge/common/error.h"
#include "hullgauge/store/export.h"

#include <gtest/gtest.h>

#include <sstream>

namespace {

using hg::store::ExportFormat;
using nlohmann::json;

constexpr std::int64_t kT0 = 1'780'000'000'000; // 2026-05-28T20:26:40Z

json row(std::int64_t id, std::int64_t ms, const std::string& serial, json landmarks)
{
    return {{"id", id},
            {"time", ""},
            {"started_unix_ms", ms},
            {"trigger_seq", id},
            {"manual", false},
            {"serial", serial},
            {"program", 5},
            {"part", "bracket"},
            {"verdict", "pass"},
            {"fault_code", 0},
            {"cycle_ms", 900},
            {"landmarks_failed", 0},
            {"landmarks_total", landmarks.size()},
            {"landmarks", std::move(landmarks)},
            {"timing", json::object()},
            {"images", ""},
            {"alignment", nullptr},
            {"simulation", nullptr},
            {"purpose", "production"},
            {"program_version", nullptr},
            {"program_sha256", nullptr}};
}

/// A release's verification digest: 64 hex digits.
const std::string kDigest = "5f0c9d3e4b7a1c2d8e6f0a9b3c5d7e1f2a4b6c8d0e2f4a6b8c0d2e4f6a8b0c2d";

std::string written(ExportFormat format, const std::vector<json>& rows, std::int64_t exported = kT0)
{
    std::ostringstream out;
    hg::store::writeExport(out, format, rows, exported);
    return out.str();
}

TEST(ExportFormat, NamesTypesAndExtensions)
{
    EXPECT_EQ(hg::store::parseExportFormat("aqdef"), ExportFormat::Aqdef);
    EXPECT_EQ(hg::store::parseExportFormat("csv"), ExportFormat::Csv);
    EXPECT_EQ(hg::store::parseExportFormat("json"), ExportFormat::Json);
    for (auto f : {ExportFormat::Aqdef, ExportFormat::Csv, ExportFormat::Json})
        EXPECT_EQ(hg::store::parseExportFormat(hg::enumName(f)), f);
    EXPECT_EQ(hg::store::contentType(ExportFormat::Aqdef), "text/plain; charset=ISO-8859-1");
    EXPECT_EQ(hg::store::contentType(ExportFormat::Csv), "text/csv; charset=utf-8");
    EXPECT_EQ(hg::store::contentType(ExportFormat::Json), "application/json");
    EXPECT_EQ(hg::store::fileExtension(ExportFormat::Aqdef), "dfq");
    EXPECT_EQ(hg::store::fileExtension(ExportFormat::Csv), "csv");
    EXPECT_EQ(hg::store::fileExtension(ExportFormat::Json), "json");
    try {
        hg::store::parseExportFormat("xml");
        FAIL() << "xml accepted";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "format");
        EXPECT_NE(std::string(e.what()).find("'xml'"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("aqdef, csv, json"), std::string::npos) << e.what();
    }
}

TEST(ExportCsv, OneQuotedRowPerLandmarkWithCrlf)
{
    auto fail = row(7, kT0, "A,\"b\"\nc",
                    json::array({{{"id", "a"},
                                  {"status", "ok"},
                                  {"error_mm", 0.0625},
                                  {"tolerance_mm", 0.2},
                                  {"deviation_mm", 0.012},
                                  {"uncertainty_mm", 0.004},
                                  {"decision", "conforms"}},
                                 {{"id", "b"},
                                  {"status", "out_of_tolerance"},
                                  {"error_mm", 0.1875},
                                  {"tolerance_mm", 0.1},
                                  {"limits_mm", {-0.05, 0.15}}},
                                 {{"id", "c"}, {"status", "not_found"}, {"error_mm", 0.0}, {"tolerance_mm", 0.2}}}));
    fail["program"] = 3;
    fail["part"] = "block";
    fail["verdict"] = "fail";
    fail["program_version"] = 2; // judged with release 2 of the program; the aborted cycle with none
    fail["program_sha256"] = kDigest;
    auto aborted = row(8, kT0 + 60'000, "M-1", json::array());
    aborted["program"] = 3;
    aborted["part"] = "block";
    aborted["verdict"] = "aborted";
    aborted["purpose"] = "master";
    aborted["manual"] = true;
    aborted["simulation"] = {{"part", "nominal"}};

    const std::string expected =
        "result_id,time,serial,program,part,purpose,verdict,landmark,status,value_mm,value_source,deviation_mm,"
        "uncertainty_mm,error_mm,lower_mm,upper_mm,decision,excluded,exclusion_reason,program_version,program_"
        "sha256,simulated\r\n"
        "7,2026-05-28T20:26:40.000Z,\"A,\"\"b\"\"\nc\",3,block,production,fail,a,ok,0.012,deviation_mm,0.012,0.004,"
        "0.0625,-0.2,0.2,conforms,false,,2," +
        kDigest +
        ",false\r\n"
        "7,2026-05-28T20:26:40.000Z,\"A,\"\"b\"\"\nc\",3,block,production,fail,b,out_of_tolerance,0.1875,error_mm,,,"
        "0.1875,-0.05,0.15,,false,,2," +
        kDigest +
        ",false\r\n"
        "7,2026-05-28T20:26:40.000Z,\"A,\"\"b\"\"\nc\",3,block,production,fail,c,not_found,,,,,0.0,-0.2,0.2,,false,,"
        "2," +
        kDigest +
        ",false\r\n"
        "8,2026-05-28T20:27:40.000Z,M-1,3,block,master,aborted,,,,,,,,,,,true,\"verdict aborted, purpose master, "
        "simulated, manual trigger\",,,true\r\n";
    EXPECT_EQ(written(ExportFormat::Csv, {fail, aborted}), expected);
}

TEST(ExportJson, TheRowsUnderFormatVersionAndTime)
{
    std::vector<json> rows{
        row(1, kT0, "S-1", json::array({{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0}, {"tolerance_mm", 0.1}}})),
        row(2, kT0 + 1000, "S\xC3\xBC", json::array())};
    rows[1]["program_version"] = 3;
    rows[1]["program_sha256"] = kDigest;
    const auto text = written(ExportFormat::Json, rows, kT0 + 123);
    ASSERT_FALSE(text.empty());
    EXPECT_EQ(text.back(), '\n');
    const auto doc = json::parse(text);
    EXPECT_EQ(doc.size(), 4u);
    EXPECT_EQ(doc["format"], "hullgauge-results");
    EXPECT_EQ(doc["version"], 1);
    EXPECT_EQ(doc["exported"], "2026-05-28T20:26:40.123Z");
    ASSERT_EQ(doc["results"].size(), 2u);
    EXPECT_EQ(doc["results"][0], rows[0]);
    EXPECT_TRUE(doc["results"][0]["program_version"].is_null()); // a draft's result: no release
    EXPECT_EQ(doc["results"][1]["serial"], "S\xC3\xBC");         // UTF-8 kept
    EXPECT_EQ(doc["results"][1]["program_version"], 3);          // the release the part was judged with
    EXPECT_EQ(doc["results"][1]["program_sha256"], kDigest);
}

/// Program 5 (bracket): a production pass, a production fail with landmark b
/// not found, a master cycle; program 6 (cap): an aborted cycle whose only
/// landmark was never inspected.
std::vector<json> aqdefRows()
{
    const json zoneB = {-0.05, 0.15};
    auto r1 =
        row(1, kT0, "P-1",
            json::array(
                {{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0625}, {"tolerance_mm", 0.1}, {"deviation_mm", 0.0123}},
                 {{"id", "b"}, {"status", "ok"}, {"error_mm", 0.0625}, {"tolerance_mm", 0.1}, {"limits_mm", zoneB}}}));
    auto r2 = row(
        2, kT0 + 60'000,
        "Pr\xC3\xBC"
        "f-2",
        json::array(
            {{{"id", "a"},
              {"status", "out_of_tolerance"},
              {"error_mm", 0.1875},
              {"tolerance_mm", 0.1},
              {"deviation_mm", 0.1504}},
             {{"id", "b"}, {"status", "not_found"}, {"error_mm", 0.0}, {"tolerance_mm", 0.1}, {"limits_mm", zoneB}}}));
    r2["verdict"] = "fail";
    auto r3 =
        row(3, kT0 + 120'000, "M",
            json::array(
                {{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0}, {"tolerance_mm", 0.1}, {"deviation_mm", -0.002}},
                 {{"id", "b"}, {"status", "ok"}, {"error_mm", 0.0625}, {"tolerance_mm", 0.1}, {"limits_mm", zoneB}}}));
    r3["purpose"] = "master";
    auto r4 = row(4, kT0 + 180'000, "",
                  json::array({{{"id", "z"}, {"status", "not_inspected"}, {"error_mm", 0.0}, {"tolerance_mm", 0.3}}}));
    r4["program"] = 6;
    r4["part"] = "cap";
    r4["verdict"] = "aborted";
    return {r1, r2, r3, r4};
}

TEST(ExportAqdef, KFieldLinesOfPartsCharacteristicsAndValues)
{
    // Written out from the field definitions (docs/export.md): K0100 the number
    // of characteristics; per part K1001/K1002; per characteristic K2001 ...
    // K2142; per value K0001 value, K0002 attribute (0 valid, 129 excluded, 255
    // no value), K0004 dd.mm.yyyy/hh:mm:ss, K0014 part ident, K0015 reason for
    // test (0 production, 10 special), K0009 the value's text: its method (a value
    // from the deviation or from the bracket in one characteristic) and why its cycle is excluded.
    const std::string expected = "K0100 3\r\n"
                                 "K1001/1 5\r\n"
                                 "K1002/1 bracket\r\n"
                                 "K2001/1 a\r\n"
                                 "K2002/1 a: deviation along the outward normal; each value's method in K0009\r\n"
                                 "K2004/1 0\r\n"
                                 "K2101/1 0\r\n"
                                 "K2110/1 -0.1\r\n"
                                 "K2111/1 0.1\r\n"
                                 "K2142/1 mm\r\n"
                                 "K2001/2 b\r\n"
                                 "K2002/2 b: deviation along the outward normal; each value's method in K0009\r\n"
                                 "K2004/2 0\r\n"
                                 "K2101/2 0\r\n"
                                 "K2110/2 -0.05\r\n"
                                 "K2111/2 0.15\r\n"
                                 "K2142/2 mm\r\n"
                                 "K0001/1 0.0123\r\n"
                                 "K0002/1 0\r\n"
                                 "K0004/1 28.05.2026/20:26:40\r\n"
                                 "K0014/1 P-1\r\n"
                                 "K0015/1 0\r\n"
                                 "K0009/1 method deviation_mm (sub-voxel)\r\n"
                                 "K0001/2 0.0625\r\n"
                                 "K0002/2 0\r\n"
                                 "K0004/2 28.05.2026/20:26:40\r\n"
                                 "K0014/2 P-1\r\n"
                                 "K0015/2 0\r\n"
                                 "K0009/2 method error_mm (middle of the voxel bracket)\r\n"
                                 "K0001/1 0.1504\r\n"
                                 "K0002/1 0\r\n"
                                 "K0004/1 28.05.2026/20:27:40\r\n"
                                 "K0014/1 Pr\xFC"
                                 "f-2\r\n"
                                 "K0015/1 0\r\n"
                                 "K0009/1 method deviation_mm (sub-voxel)\r\n"
                                 "K0001/2 0\r\n"
                                 "K0002/2 255\r\n"
                                 "K0004/2 28.05.2026/20:27:40\r\n"
                                 "K0014/2 Pr\xFC"
                                 "f-2\r\n"
                                 "K0015/2 0\r\n"
                                 "K0001/1 -0.002\r\n"
                                 "K0002/1 129\r\n"
                                 "K0004/1 28.05.2026/20:28:40\r\n"
                                 "K0014/1 M\r\n"
                                 "K0015/1 10\r\n"
                                 "K0009/1 method deviation_mm (sub-voxel); excluded: purpose master\r\n"
                                 "K0001/2 0.0625\r\n"
                                 "K0002/2 129\r\n"
                                 "K0004/2 28.05.2026/20:28:40\r\n"
                                 "K0014/2 M\r\n"
                                 "K0015/2 10\r\n"
                                 "K0009/2 method error_mm (middle of the voxel bracket); excluded: purpose master\r\n"
                                 "K1001/2 6\r\n"
                                 "K1002/2 cap\r\n"
                                 "K2001/3 z\r\n"
                                 "K2002/3 z: deviation along the outward normal; each value's method in K0009\r\n"
                                 "K2004/3 0\r\n"
                                 "K2101/3 0\r\n"
                                 "K2110/3 -0.3\r\n"
                                 "K2111/3 0.3\r\n"
                                 "K2142/3 mm\r\n"
                                 "K0001/3 0\r\n"
                                 "K0002/3 255\r\n"
                                 "K0004/3 28.05.2026/20:29:40\r\n"
                                 "K0015/3 0\r\n"
                                 "K0009/3 excluded: verdict aborted\r\n";
    EXPECT_EQ(written(ExportFormat::Aqdef, aqdefRows()), expected);
}

/// The lines of `text` whose key is one of `keys`.
std::vector<std::string> linesOf(const std::string& text, const std::vector<std::string>& keys)
{
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line, '\n');) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        for (const auto& k : keys)
            if (line.rfind(k, 0) == 0) out.push_back(line);
    }
    return out;
}

TEST(ExportAqdef, OneCharacteristicPerLandmarkAndZoneWhateverTheMethodOfItsValues)
{
    // Landmark a: ±0.1 with a deviation, ±0.1 on the bracket only, then ±0.2 with a deviation.
    const auto entry = [](double tol, std::optional<double> deviation) {
        json e{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0625}, {"tolerance_mm", tol}};
        if (deviation) e["deviation_mm"] = *deviation;
        return json::array({e});
    };
    const std::string longSerial(45, 'x');
    const std::vector<json> rows{row(10, kT0, "S\n1\xE6\xB8\xA9", entry(0.1, 0.01)),
                                 row(11, kT0 + 1000, "T", entry(0.1, std::nullopt)),
                                 row(12, kT0 + 2000, longSerial, entry(0.2, 0.02))};
    const auto text = written(ExportFormat::Aqdef, rows);
    // ±0.1 holds the deviation of cycle 10 and the bracket middle of cycle 11; the edited zone ±0.2 is another.
    EXPECT_EQ(linesOf(text, {"K0100", "K2001", "K2110", "K2111"}),
              (std::vector<std::string>{"K0100 2", "K2001/1 a~1", "K2110/1 -0.1", "K2111/1 0.1", "K2001/2 a~2",
                                        "K2110/2 -0.2", "K2111/2 0.2"}));
    EXPECT_EQ(linesOf(text, {"K0001", "K0002", "K0009"}),
              (std::vector<std::string>{"K0001/1 0.01", "K0002/1 0", "K0009/1 method deviation_mm (sub-voxel)",
                                        "K0001/2 0", "K0002/2 255", "K0001/1 0.0625", "K0002/1 0",
                                        "K0009/1 method error_mm (middle of the voxel bracket)", "K0001/2 0",
                                        "K0002/2 255", "K0001/1 0", "K0002/1 255", "K0001/2 0.02", "K0002/2 0",
                                        "K0009/2 method deviation_mm (sub-voxel)"}));
    // A line break in a serial would end the K-field line: a space; a character
    // outside ISO 8859-1 is '?'; K0014 holds 40 characters.
    const auto idents = linesOf(text, {"K0014/1"});
    ASSERT_EQ(idents.size(), 3u);
    EXPECT_EQ(idents[0], "K0014/1 S 1?");
    EXPECT_EQ(idents[2], "K0014/1 " + std::string(40, 'x'));
}

TEST(ExportAqdef, TheSimulatedLineIsExcludedUnlessIncludedAndThenMarked)
{
    auto sim =
        row(20, kT0, "SIM-1",
            json::array(
                {{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0}, {"tolerance_mm", 0.1}, {"deviation_mm", 0.003}}}));
    sim["simulation"] = {{"part", "nominal"}};
    EXPECT_EQ(
        linesOf(written(ExportFormat::Aqdef, {sim}), {"K0002", "K0009"}),
        (std::vector<std::string>{"K0002/1 129", "K0009/1 method deviation_mm (sub-voxel); excluded: simulated"}));
    std::ostringstream out;
    hg::store::writeExport(out, ExportFormat::Aqdef, {sim}, kT0, {.includeSimulated = true});
    EXPECT_EQ(linesOf(out.str(), {"K0002", "K0009"}),
              (std::vector<std::string>{
                  "K0002/1 0", "K0009/1 method deviation_mm (sub-voxel); simulated, included (--include-simulated)"}));
    // Another reason still excludes it.
    sim["purpose"] = "master";
    std::ostringstream master;
    hg::store::writeExport(master, ExportFormat::Aqdef, {sim}, kT0, {.includeSimulated = true});
    EXPECT_EQ(linesOf(master.str(), {"K0002"}), (std::vector<std::string>{"K0002/1 129"}));
}

TEST(ExportAqdef, MalformedLandmarksAreBadInputNamingTheResult)
{
    auto bad = row(42, kT0, "S", json::array({{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0}}}));
    try {
        written(ExportFormat::Aqdef, {bad});
        FAIL() << "a landmark without a tolerance zone accepted";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "result 42.landmarks.a");
    }
    bad["landmarks"] = json::array({{{"status", "ok"}}});
    EXPECT_THROW(written(ExportFormat::Csv, {bad}), hg::InputError);
}

TEST(ExportCsv, AStoredStatusThatIsNoStatusIsBadInputNamingIt)
{
    const auto bad =
        row(42, kT0, "S", json::array({{{"id", "a"}, {"status", "fine"}, {"error_mm", 0.0}, {"tolerance_mm", 0.1}}}));
    try {
        written(ExportFormat::Csv, {bad});
        FAIL() << "a landmark status 'fine' accepted";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "result 42.landmarks.a.status");
    }
}

TEST(ExportAqdef, NoRowsIsAFileWithoutCharacteristics)
{
    EXPECT_EQ(written(ExportFormat::Aqdef, {}), "K0100 0\r\n");
}

} // namespace
