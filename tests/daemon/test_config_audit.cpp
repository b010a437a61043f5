// The configuration's files in the audit trail (docs/audit.md, "Files"): each
// load records the files that are new or changed since the trail last saw
// them, with their text before and after; a file over 1 MiB by its SHA-256
// (computed here by the sha256sum program) and size; a file that cannot be
// read as such.
#include "config_audit.h"
#include "hgtest/paths.h"

#include <gtest/gtest.h>

namespace hg::daemon {
namespace {

constexpr std::int64_t kT0 = 1'780'000'000'000;

struct Files {
    hgtest::TempDir dir;
    station::DaemonConfig config;

    Files()
    {
        config.file = hgtest::writeFile(dir / "hullgauged.yaml", "station: station.yaml\n");
        config.stationFile = hgtest::writeFile(dir / "station.yaml", "camera:\n  focal_mm: 25\n");
        station::PartProgramRef program;
        program.number = 3;
        program.partFile = hgtest::writeFile(dir / "block.yaml", "part: block\n");
        program.viewsFile = hgtest::writeFile(dir / "block.views.json", "{\"views\": []}\n");
        config.programs[3] = program;
    }
};

std::vector<store::AuditEntry> oldestFirst(const store::AuditLog& audit)
{
    auto entries = audit.select({});
    std::reverse(entries.begin(), entries.end());
    return entries;
}

TEST(ConfigAudit, RecordsEachFileOnceAndThenOnlyWhatChanged)
{
    Files f;
    store::AuditLog audit(f.dir / "audit.sqlite");
    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "start", kT0), 4);
    auto entries = oldestFirst(audit);
    ASSERT_EQ(entries.size(), 4u);
    const struct {
        std::string file, text, detail;
    } expected[] = {
        {"hullgauged.yaml", "station: station.yaml\n", "daemon configuration, first recorded; found at start"},
        {"station.yaml", "camera:\n  focal_mm: 25\n", "station file, first recorded; found at start"},
        {"block.yaml", "part: block\n", "part program 3, first recorded; found at start"},
        {"block.views.json", "{\"views\": []}\n", "view plan of program 3, first recorded; found at start"}};
    for (std::size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(entries[i].object, (f.dir / expected[i].file).string());
        EXPECT_EQ(entries[i].action, "file.recorded");
        EXPECT_EQ(entries[i].who, "hullgauged");
        EXPECT_EQ(entries[i].role, "");
        EXPECT_EQ(entries[i].source, "daemon");
        EXPECT_EQ(entries[i].outcome, "done");
        EXPECT_EQ(entries[i].atMs, kT0);
        EXPECT_EQ(entries[i].detail, expected[i].detail);
        EXPECT_EQ(entries[i].before, "");
        EXPECT_EQ(entries[i].after, expected[i].text);
    }

    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "reload", kT0 + 1000), 0);
    EXPECT_EQ(audit.select({}).size(), 4u);

    hgtest::writeFile(f.config.stationFile, "camera:\n  focal_mm: 35\n");
    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "reload", kT0 + 2000), 1);
    entries = oldestFirst(audit);
    ASSERT_EQ(entries.size(), 5u);
    EXPECT_EQ(entries[4].action, "file.changed");
    EXPECT_EQ(entries[4].object, (f.dir / "station.yaml").string());
    EXPECT_EQ(entries[4].detail, "station file, changed; found at reload");
    EXPECT_EQ(entries[4].atMs, kT0 + 2000);
    EXPECT_EQ(entries[4].before, "camera:\n  focal_mm: 25\n");
    EXPECT_EQ(entries[4].after, "camera:\n  focal_mm: 35\n");

    // A new trail (another daemon's) starts again with every file.
    store::AuditLog fresh(f.dir / "other.sqlite");
    EXPECT_EQ(recordConfigurationFiles(fresh, f.config, "start", kT0), 4);
}

TEST(ConfigAudit, AFileOverOneMebibyteIsRecordedByItsDigestAndSize)
{
    Files f;
    constexpr std::size_t kMiB = 1u << 20;
    hgtest::writeFile(f.config.programs[3].viewsFile, std::string(kMiB + 1, 'v'));
    hgtest::writeFile(f.config.programs[3].partFile, std::string(kMiB, 'p')); // at the limit: kept whole
    const auto digest = hgtest::run("sha256sum " + f.config.programs[3].viewsFile.string()).out.substr(0, 64);
    ASSERT_EQ(digest.size(), 64u);
    store::AuditLog audit(f.dir / "audit.sqlite");
    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "start", kT0), 4);
    const auto entries = oldestFirst(audit);
    ASSERT_EQ(entries.size(), 4u);
    EXPECT_EQ(entries[2].after, std::string(kMiB, 'p'));
    EXPECT_EQ(entries[3].after, "(1048577 bytes, SHA-256 " + digest + "; not kept as text)");
    EXPECT_EQ(audit.watched(f.config.programs[3].viewsFile.string())->sha256, digest);

    // One byte changed in the big file: a change, shown by its digests.
    std::string changed(kMiB + 1, 'v');
    changed[10] = 'w';
    hgtest::writeFile(f.config.programs[3].viewsFile, changed);
    const auto digest2 = hgtest::run("sha256sum " + f.config.programs[3].viewsFile.string()).out.substr(0, 64);
    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "reload", kT0), 1);
    const auto last = audit.select({}).front();
    EXPECT_EQ(last.action, "file.changed");
    EXPECT_EQ(last.before, "(1048577 bytes, SHA-256 " + digest + "; not kept as text)");
    EXPECT_EQ(last.after, "(1048577 bytes, SHA-256 " + digest2 + "; not kept as text)");
}

TEST(ConfigAudit, AFileThatCannotBeReadIsRecordedAsSuch)
{
    Files f;
    std::filesystem::remove(f.config.programs[3].viewsFile);
    store::AuditLog audit(f.dir / "audit.sqlite");
    int recorded = -1;
    EXPECT_NO_THROW(recorded = recordConfigurationFiles(audit, f.config, "start", kT0));
    EXPECT_EQ(recorded, 4);
    const auto last = audit.select({}).front();
    EXPECT_EQ(last.object, (f.dir / "block.views.json").string());
    EXPECT_EQ(last.action, "file.recorded");
    EXPECT_EQ(last.after, "(cannot be read)");
    // Still unreadable: nothing new; readable again: its text, as a change.
    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "reload", kT0), 0);
    hgtest::writeFile(f.config.programs[3].viewsFile, "{\"views\": [1]}\n");
    EXPECT_EQ(recordConfigurationFiles(audit, f.config, "reload", kT0), 1);
    const auto back = audit.select({}).front();
    EXPECT_EQ(back.action, "file.changed");
    EXPECT_EQ(back.before, "(cannot be read)");
    EXPECT_EQ(back.after, "{\"views\": [1]}\n");
}

} // namespace
} // namespace hg::daemon
