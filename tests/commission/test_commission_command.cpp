// `hullgauge commission` end to end on the simulated line's part (docs/commissioning.md):
// the program is released with its views, its record's digest is the
// SHA-256 of the report as `sha256sum` computes it, a second release is
// version 2 with version 1 kept; --no-release verifies and releases nothing; a missing tolerance and a release multiple
// left out are refused naming the option; a lens too long gives no plan.
#include "hgtest/paths.h"
#include "hullgauge/model/part_program.h"

#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sstream>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

std::string tool()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

fs::path sim(const std::string& name)
{
    return hgtest::sourceDir() / "config" / "sim" / name;
}

std::string commission(const fs::path& out, const std::string& extra)
{
    return tool() + " commission --cad " + sim("stepped-block.stl").string() + " --station " +
           sim("station.yaml").string() + " --out " + out.string() +
           " --seats 2 --seat-shift 0.3 --seat-rotation 0.3 --defects 2 " + extra;
}

std::string readText(const fs::path& file)
{
    std::ifstream in(file);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

TEST(CommissionCommand, ReleasesTheProgramWithItsViewsAndRecordAndKeepsEveryVersion)
{
    hgtest::TempDir dir;
    const fs::path out = dir / "stepped";
    const std::string cmd =
        commission(out, "--program " + sim("stepped-block.yaml").string() + " --released-by tester");
    const hgtest::RunResult first = hgtest::run(cmd);
    ASSERT_EQ(first.status, 0) << first.err;
    const model::PartProgram released = model::loadPartProgram(out / "stepped-block.yaml");
    ASSERT_TRUE(released.release.has_value());
    EXPECT_EQ(released.release->version, 1);
    EXPECT_EQ(released.release->releasedBy, "tester");
    EXPECT_EQ(released.landmarks.size(), 10u);
    EXPECT_TRUE(fs::exists(out / "stepped-block-views.yaml"));
    EXPECT_TRUE(fs::exists(out / "stepped-block.stl"));
    EXPECT_TRUE(fs::exists(out / "plan.json"));
    EXPECT_TRUE(nlohmann::json::parse(readText(out / "verification.json"))["released"].get<bool>());
    // The digest is the report's, as an independent tool computes it.
    const hgtest::RunResult sum = hgtest::run("sha256sum " + (out / "verification.json").string());
    ASSERT_EQ(sum.status, 0);
    EXPECT_EQ(sum.out.substr(0, 64), released.release->verificationSha256);

    const hgtest::RunResult second = hgtest::run(cmd);
    ASSERT_EQ(second.status, 0) << second.err;
    EXPECT_EQ(model::loadPartProgram(out / "stepped-block.yaml").release->version, 2);
    // Each version whole in its folder: program, views, model, verification.
    for (int v : {1, 2}) {
        const fs::path kept = out / "releases" / ("stepped-block.v" + std::to_string(v));
        EXPECT_EQ(model::loadPartProgram(kept / "stepped-block.yaml").release->version, v);
        EXPECT_TRUE(fs::exists(kept / "stepped-block-views.yaml"));
        EXPECT_TRUE(fs::exists(kept / "verification.json"));
    }
}

// --no-release: the verification is written and would release the program
// (exit 0), and nothing is released: no program in force, no kept version.
TEST(CommissionCommand, NoReleaseVerifiesAndReleasesNothing)
{
    hgtest::TempDir dir;
    const fs::path out = dir / "stepped";
    const hgtest::RunResult r =
        hgtest::run(commission(out, "--program " + sim("stepped-block.yaml").string() + " --no-release"));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("not released (--no-release)"), std::string::npos) << r.err;
    EXPECT_TRUE(nlohmann::json::parse(readText(out / "verification.json"))["released"].get<bool>());
    EXPECT_TRUE(fs::exists(out / "plan.json"));
    EXPECT_TRUE(fs::exists(out / "stepped-block.draft.yaml"));
    EXPECT_FALSE(fs::exists(out / "stepped-block.yaml"));
    EXPECT_FALSE(fs::exists(out / "stepped-block-views.yaml"));
    EXPECT_FALSE(fs::exists(out / "releases"));
}

// The simulated line's program with one more landmark whose tolerance no
// station proves (±0.001 mm on the tall block's top): without --fix the
// program is not released (exit 1) and the landmark is named with the test it
// fails; with --fix the fixes it names for that test are a lens, a tolerance
// (the engineer's) or dropping it, so it is dropped and the rest released.
TEST(CommissionCommand, FixDropsALandmarkWhoseFixIsNotTheCommandsToMake)
{
    hgtest::TempDir dir;
    std::string program = readText(sim("stepped-block.yaml"));
    const std::string mesh = "mesh: stepped-block.stl";
    ASSERT_NE(program.find(mesh), std::string::npos);
    program.replace(program.find(mesh), mesh.size(), "mesh: " + sim("stepped-block.stl").string());
    program.replace(program.find("landmarks:\n"), 11,
                    "landmarks:\n  - {id: too-tight, position: [-10, 0, 30], tolerance_mm: 0.001}\n");
    const fs::path file = hgtest::writeFile(dir / "tight.yaml", program);

    const hgtest::RunResult plain = hgtest::run(commission(dir / "plain", "--program " + file.string()));
    EXPECT_EQ(plain.status, 1) << plain.err;
    EXPECT_NE(plain.err.find("too-tight (capability)"), std::string::npos) << plain.err;
    EXPECT_FALSE(fs::exists(dir / "plain" / "stepped-block.yaml"));

    const hgtest::RunResult fixed = hgtest::run(commission(dir / "fixed", "--program " + file.string() + " --fix"));
    ASSERT_EQ(fixed.status, 0) << fixed.err;
    EXPECT_NE(fixed.err.find("--fix: too-tight: dropped"), std::string::npos) << fixed.err;
    const model::PartProgram released = model::loadPartProgram(dir / "fixed" / "stepped-block.yaml");
    EXPECT_EQ(released.landmarks.size(), 10u);
    EXPECT_EQ(released.findLandmark("too-tight"), nullptr);
}

TEST(CommissionCommand, RefusesWithoutATolerance)
{
    hgtest::TempDir dir;
    const hgtest::RunResult r = hgtest::run(commission(dir / "x", ""));
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--tolerance"), std::string::npos) << r.err;
}

TEST(CommissionCommand, RefusesDefectsWithoutTheReleaseMultiple)
{
    hgtest::TempDir dir;
    const hgtest::RunResult r =
        hgtest::run(tool() + " commission --cad " + sim("stepped-block.stl").string() + " --station " +
                    sim("station.yaml").string() + " --out " + (dir / "x").string() + " --tolerance 0.4 --defects 1,3");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--defects"), std::string::npos) << r.err;
}

TEST(CommissionCommand, ALensTooLongGivesNoPlanNamingTheView)
{
    hgtest::TempDir dir;
    std::string station = readText(sim("station.yaml"));
    const std::string k = "K: [[2500, 0, 640], [0, 2500, 480], [0, 0, 1]]";
    ASSERT_NE(station.find(k), std::string::npos);
    station.replace(station.find(k), k.size(), "K: [[9000, 0, 640], [0, 9000, 480], [0, 0, 1]]");
    const fs::path file = hgtest::writeFile(dir / "station.yaml", station);
    const hgtest::RunResult r =
        hgtest::run(tool() + " commission --cad " + sim("stepped-block.stl").string() + " --station " + file.string() +
                    " --out " + (dir / "x").string() + " --program " + sim("stepped-block.yaml").string());
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("does not hold the whole part in its frame"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "x" / "stepped-block.yaml"));
}

} // namespace
} // namespace hg::cli
