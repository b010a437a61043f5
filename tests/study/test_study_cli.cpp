// `hullgauge study type1|type3` on result stores written here with sqlite3:
// the selection (purpose, verdict, program, serial, time), the values taken,
// the refusals (exit 2 naming what was wrong) and the figures, worked out by
// hand for the data sets below (tests/study/test_gauge_study.cpp has the same
// arithmetic).
#include "hgtest/paths.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

namespace {

std::string hullgauge()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

/// The columns `study` reads, as the daemon's schema 3 has them (docs/daemon.md, "Results").
constexpr const char* kTable =
    "CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_unix_ms INTEGER "
    "NOT NULL, serial TEXT NOT NULL, program INTEGER NOT NULL, verdict TEXT NOT NULL, "
    "landmarks_json TEXT NOT NULL, purpose TEXT NOT NULL DEFAULT 'production');\n";

struct Row {
    std::string serial;
    std::string purpose = "master";
    double a = 0.0;    ///< landmark a's deviation_mm
    double b = 0.0625; ///< landmark b's error_mm (no deviation)
    std::string verdict = "pass";
    int program = 1;
    std::int64_t ms = 1'780'000'000'000; // 2026-05-28T20:26:40Z
};

std::string insert(const Row& r)
{
    nlohmann::json landmarks = nlohmann::json::array(
        {{{"id", "a"}, {"status", "ok"}, {"error_mm", 0.0}, {"tolerance_mm", 0.4}, {"deviation_mm", r.a}},
         {{"id", "b"}, {"status", "ok"}, {"error_mm", r.b}, {"tolerance_mm", 0.4}}});
    std::ostringstream sql;
    sql << "INSERT INTO inspections (started_unix_ms, serial, program, verdict, landmarks_json, purpose) VALUES ("
        << r.ms << ", '" << r.serial << "', " << r.program << ", '" << r.verdict << "', '" << landmarks.dump() << "', '"
        << r.purpose << "');\n";
    return sql.str();
}

std::filesystem::path makeStore(const hgtest::TempDir& dir, const std::vector<Row>& rows, const char* table = kTable)
{
    std::string sql = table;
    for (const auto& r : rows) sql += insert(r);
    const auto script = hgtest::writeFile(dir / "rows.sql", sql);
    const auto db = dir / "results.db";
    EXPECT_EQ(hgtest::run("sqlite3 " + db.string() + " < " + script.string()).status, 0);
    return db;
}

/// 25 master cycles, landmark a at 12 × 0.01, 12 × 0.03, 1 × 0.02 (x̄ 0.02, s = sqrt(24·0.0001 / 24)
/// = 0.01), landmark b always 0.0625 (s = 0); production and aborted cycles around them.
std::vector<Row> masterRows()
{
    std::vector<Row> rows;
    for (int i = 0; i < 25; ++i) rows.push_back({"MASTER", "master", i < 12 ? 0.01 : (i < 24 ? 0.03 : 0.02)});
    rows.push_back({"P-1", "production", 0.3});
    rows.push_back({"MASTER", "master", 0.3, 0.0625, "aborted"});
    rows.push_back({"MASTER", "master", -0.3, 0.0625, "error"});
    return rows;
}

TEST(StudyCli, Type1TakesTheMasterCyclesAndComputesCgCgk)
{
    hgtest::TempDir dir;
    const auto db = makeStore(dir, masterRows());
    auto r = hgtest::run(hullgauge() + " study type1 --store " + db.string() + " --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["selection"]["cycles"], 25); // not the production, aborted or error cycles
    EXPECT_EQ(j["selection"]["purpose"], "master");
    EXPECT_EQ(j["selection"]["program"], 1);
    const auto& a = j["landmarks"][0];
    EXPECT_EQ(a["id"], "a");
    EXPECT_EQ(a["values"], "deviation_mm");
    // T = 0.8: Cg = 0.16 / (6·0.01) = 2.6667; Cgk = (0.08 − 0.02) / (3·0.01) = 2.0.
    EXPECT_NEAR(a["mean_mm"].get<double>(), 0.02, 1e-12);
    EXPECT_NEAR(a["stddev_mm"].get<double>(), 0.01, 1e-12);
    EXPECT_NEAR(a["cg"].get<double>(), 2.666667, 1e-6);
    EXPECT_NEAR(a["cgk"].get<double>(), 2.0, 1e-9);
    EXPECT_EQ(a["capable"], true);
    const auto& b = j["landmarks"][1];
    EXPECT_EQ(b["values"], "error_mm");
    EXPECT_EQ(b["note"], "bracket middle: resolution one voxel; s = 0: every value in the same bracket, the spread "
                         "is below the resolution; not capable on the bracket middle");
    EXPECT_EQ(b["capable"], false); // known to a voxel: never capable, whatever its spread
    // --landmark chooses (docs/contracts.md §8); an id the cycles lack is bad input naming it.
    const auto onlyA = hgtest::run(hullgauge() + " study type1 --store " + db.string() + " --json --landmark a");
    ASSERT_EQ(onlyA.status, 0) << onlyA.err;
    const auto ja = nlohmann::json::parse(onlyA.out)["landmarks"];
    ASSERT_EQ(ja.size(), 1u);
    EXPECT_EQ(ja[0]["id"], "a");
    const auto unknown = hgtest::run(hullgauge() + " study type1 --store " + db.string() + " --landmark nose");
    EXPECT_EQ(unknown.status, 2);
    EXPECT_NE(unknown.err.find("no landmark 'nose'"), std::string::npos) << unknown.err;
    EXPECT_EQ(b["stddev_mm"], 0.0);
    EXPECT_EQ(b["cg"], "inf"); // s = 0
    EXPECT_EQ(b["cgk"], "inf");

    // x_ref 0.005 from a reference file: Cgk = (0.08 − 0.015) / 0.03 = 2.1667. Text and --out.
    const auto ref = hgtest::writeFile(dir / "ref.yaml", "a: 0.005\n");
    const auto out = dir / "type1.txt";
    r = hgtest::run(hullgauge() + " study type1 --store " + db.string() + " --reference " + ref.string() + " --out " +
                    out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    std::ifstream in(out);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_NE(text.str().find("type-1 study: 25 cycles of program 1, purpose master"), std::string::npos) << text.str();
    EXPECT_NE(text.str().find("2.17"), std::string::npos) << text.str();
    EXPECT_NE(text.str().find("b: bracket middle: resolution one voxel"), std::string::npos) << text.str();
}

TEST(StudyCli, Type1RefusesTooFewCyclesUnlessLoweredAndNamesBadInput)
{
    hgtest::TempDir dir;
    auto rows = masterRows();
    rows[24].ms += 3'600'000; // the last master cycle an hour later
    const auto db = makeStore(dir, rows);
    const std::string store = " --store " + db.string();
    auto r = hgtest::run(hullgauge() + " study type1" + store + " --until 2026-05-28T21:00");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("24 pass/fail cycles with purpose master"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("needs 25"), std::string::npos) << r.err;
    r = hgtest::run(hullgauge() + " study type1" + store + " --until 2026-05-28T21:00 --min-cycles 24 --json");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["selection"]["cycles"], 24);
    r = hgtest::run(hullgauge() + " study type1" + store + " --since 2026-05-28T21:00 --min-cycles 2");
    EXPECT_EQ(r.status, 2); // one cycle left: no spread to compute
    r = hgtest::run(hullgauge() + " study type1" + store + " --since 2026-02-30");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--since: '2026-02-30' is not a UTC time"), std::string::npos) << r.err;
    const auto ref = hgtest::writeFile(dir / "ref.yaml", "a: 0.005\nzz: 0.1\n");
    r = hgtest::run(hullgauge() + " study type1" + store + " --reference " + ref.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("zz: no such landmark"), std::string::npos) << r.err;
    r = hgtest::run(hullgauge() + " study type1 --store " + (dir / "none.db").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("no database at"), std::string::npos) << r.err;
}

TEST(StudyCli, CyclesOfSeveralProgramsNeedAProgram)
{
    hgtest::TempDir dir;
    auto rows = masterRows();
    rows[3].program = 2;
    const auto db = makeStore(dir, rows);
    auto r = hgtest::run(hullgauge() + " study type1 --store " + db.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("span programs 1, 2"), std::string::npos) << r.err;
    r = hgtest::run(hullgauge() + " study type1 --store " + db.string() + " --program 1 --min-cycles 24 --json");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["selection"]["cycles"], 24);
}

TEST(StudyCli, Type3OnTheStudyCycles)
{
    hgtest::TempDir dir;
    // A 0.10 0.12, B 0.20 0.18, C 0.30 0.31 (interleaved as parts come round): MS_parts 0.0192167,
    // MS_error 0.00015, %GRR 12.4461, of T = 0.8 9.18559, ndc 11 (hand-computed, test_gauge_study.cpp).
    std::vector<Row> rows{{"A", "study", 0.10}, {"B", "study", 0.20}, {"C", "study", 0.30}, {"X", "master", 0.5},
                          {"A", "study", 0.12}, {"B", "study", 0.18}, {"C", "study", 0.31}};
    const auto db = makeStore(dir, rows);
    auto r = hgtest::run(hullgauge() + " study type3 --store " + db.string() + " --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto a = nlohmann::json::parse(r.out)["landmarks"][0];
    EXPECT_EQ(a["parts"], 3);
    EXPECT_EQ(a["trials"], 2);
    EXPECT_NEAR(a["ms_parts"].get<double>(), 0.01921667, 1e-8);
    EXPECT_NEAR(a["ms_error"].get<double>(), 0.00015, 1e-10);
    EXPECT_NEAR(a["percent_grr"].get<double>(), 12.4461, 1e-4);
    EXPECT_NEAR(a["percent_tolerance"].get<double>(), 9.18559, 1e-5);
    EXPECT_EQ(a["ndc"], 11);
    EXPECT_EQ(a["acceptance"], "conditional");
    r = hgtest::run(hullgauge() + " study type3 --store " + db.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("conditional"), std::string::npos) << r.out;

    // A third trial of A only: unbalanced, refused naming every part's count.
    rows.push_back({"A", "study", 0.11});
    hgtest::TempDir other;
    const auto db2 = makeStore(other, rows);
    r = hgtest::run(hullgauge() + " study type3 --store " + db2.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("part 'B' has 2 trials, part 'A' 3"), std::string::npos) << r.err;
}

TEST(StudyCli, AStoreBeforeCyclePurposesHoldsProductionCyclesOnly)
{
    hgtest::TempDir dir;
    std::string table = kTable;
    table.replace(table.find(", purpose TEXT NOT NULL DEFAULT 'production'"),
                  std::string(", purpose TEXT NOT NULL DEFAULT 'production'").size(), "");
    std::vector<Row> rows = masterRows();
    rows.resize(25);
    std::string sql = table;
    for (const auto& row : rows) {
        auto line = insert(row);
        line.replace(line.find(", purpose"), std::string(", purpose").size(), "");
        line.replace(line.rfind(", 'master'"), std::string(", 'master'").size(), "");
        sql += line;
    }
    const auto db = dir / "v2.db";
    ASSERT_EQ(hgtest::run("sqlite3 " + db.string() + " < " + hgtest::writeFile(dir / "v2.sql", sql).string()).status,
              0);
    auto r = hgtest::run(hullgauge() + " study type1 --store " + db.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("holds no pass/fail cycles with purpose master"), std::string::npos) << r.err;
    r = hgtest::run(hullgauge() + " study type1 --store " + db.string() + " --purpose production --json");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["selection"]["cycles"], 25);
}

} // namespace

// `hullgauge master`'s options (docs/mastering.md, "The command"): the store
// and the file are needed without --run, --run measures one master and takes
// no window, --socket and --timeout go with --run; with --run and no daemon
// behind the socket, a fault naming it.
TEST(MasterCli, TheOptionsWithAndWithoutRunAreRefusedNamingWhatIsWrong)
{
    hgtest::TempDir dir;
    const auto one = hgtest::writeFile(dir / "m1.yaml", "master: M-1\ncertificate: r1\nlandmarks:\n"
                                                        "  a: {value_mm: 0.01, uncertainty_mm: 0.002}\n");
    const auto two = hgtest::writeFile(dir / "m2.yaml", "master: M-2\ncertificate: r2\nlandmarks:\n"
                                                        "  a: {value_mm: 0.05, uncertainty_mm: 0.002}\n");
    const std::string master = hullgauge() + " master --program 1 --master " + one.string();
    const std::string socket = " --socket " + (dir / "none.sock").string();
    struct Case {
        std::string args;
        int status;
        std::string says;
    };
    for (const Case& c : {Case{" --out " + (dir / "set.json").string(), 2, "--store: required without --run"},
                          Case{" --store " + (dir / "r.db").string(), 2, "--out: required without --run"},
                          Case{" --master " + two.string() + " --run 5" + socket, 2, "--run: runs one master's cycles"},
                          Case{" --run 5 --since 2026-05-28" + socket, 2, "--since excludes --run"},
                          Case{" --run 1" + socket, 2, "--run: Value 1 not in range"},
                          Case{socket + " --store x.db --out y.json", 2, "--socket requires --run"},
                          Case{" --run 5" + socket, 3, "cannot reach the daemon at " + (dir / "none.sock").string()}}) {
        const auto r = hgtest::run(master + c.args);
        EXPECT_EQ(r.status, c.status) << c.args << ": " << r.err;
        EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << ": " << r.err;
    }
}
