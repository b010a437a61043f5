// Files replaced whole or not at all (include/hullgauge/common/durable_file.h).
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"

#include <gtest/gtest.h>
#include <hgtest/paths.h>

#include <fstream>
#include <sstream>

namespace {

std::string contents(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

std::vector<std::string> namesIn(const std::filesystem::path& folder)
{
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(folder)) names.push_back(e.path().filename().string());
    return names;
}

TEST(DurableFile, ReplaceWritesTheNewBytesAndLeavesNoTemporaryFile)
{
    hgtest::TempDir dir;
    const auto file = dir / "out.dfq";
    hg::replaceFileDurably(file, std::string("K0100 0\r\n\0x", 11));
    EXPECT_EQ(contents(file), std::string("K0100 0\r\n\0x", 11));
    hg::replaceFileDurably(file, "second");
    EXPECT_EQ(contents(file), "second");
    EXPECT_EQ(namesIn(dir.path()), (std::vector<std::string>{"out.dfq"}));
}

TEST(DurableFile, ReplaceIntoAMissingFolderFailsAndWritesNothing)
{
    hgtest::TempDir dir;
    const auto file = dir / "none" / "out.csv";
    try {
        hg::replaceFileDurably(file, "x");
        FAIL() << "wrote into a missing folder";
    } catch (const hg::FaultError& e) {
        EXPECT_NE(std::string(e.what()).find("out.csv"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(dir / "none"));
    // Renaming over a folder fails: the folder stays and the temporary file goes.
    std::filesystem::create_directory(dir / "taken");
    EXPECT_THROW(hg::replaceFileDurably(dir / "taken", "x"), hg::FaultError);
    EXPECT_TRUE(std::filesystem::is_directory(dir / "taken"));
    EXPECT_EQ(namesIn(dir.path()), (std::vector<std::string>{"taken"}));
}

} // namespace
