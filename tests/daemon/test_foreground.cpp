// The daemon's foreground mode (docs/daemon.md, "Without systemd"): the
// runtime and state folders made or checked, the user, groups and capability
// of the unit taken when started as root, read back from the kernel
// (/proc/PID/status) and the file system.
#include "daemon_harness.h"

#include <fstream>
#include <gtest/gtest.h>
#include <pwd.h>
#include <regex>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using namespace std::chrono_literals;
using hgdaemon::DaemonProcess;
namespace fs = std::filesystem;

/// The daemon's configuration with its socket in DIR/run and its store in DIR/state.
fs::path writeFolderConfig(const hgtest::TempDir& dir)
{
    // The workspace in the state folder too, as installed (the daemon makes it as its user).
    auto config = hgdaemon::writeConfig(dir, hgdaemon::freePort(), "workbench: {folder: state/parts}\n");
    auto text = hgdaemon::readText(config);
    for (auto [from, to] : {std::pair<std::string, std::string>{"{database: results.db, images: images}",
                                                                "{database: state/results.db, images: state/images}"},
                            {"{socket: hg.sock}", "{socket: run/hg.sock}"}}) {
        auto at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        text.replace(at, from.size(), to);
    }
    return hgtest::writeFile(config, text);
}

/// A field of /proc/PID/status ("Uid", "CapEff"), as written there.
std::string procStatus(pid_t pid, const std::string& field)
{
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(field + ":", 0) == 0)
            return std::regex_replace(line.substr(field.size() + 1), std::regex("\\s+"), " ");
    return "";
}

struct stat statOf(const fs::path& path)
{
    struct stat st {};
    EXPECT_EQ(stat(path.c_str(), &st), 0) << path;
    return st;
}

TEST(Foreground, CreatesItsFoldersAndRunsAsTheUnitsUserWithItsOneCapability)
{
    hgtest::TempDir dir;
    const bool root = geteuid() == 0;
    // Started as root it becomes nobody, who must read the configuration (0644 files).
    fs::permissions(dir.path(), fs::perms(0755));
    const passwd* nobody = getpwnam("nobody");
    ASSERT_TRUE(nobody);
    const uid_t uid = root ? nobody->pw_uid : geteuid();
    const gid_t gid = root ? nobody->pw_gid : getegid();
    DaemonProcess daemon(writeFolderConfig(dir), {}, {"--foreground", "--user", "nobody"});
    ASSERT_TRUE(hgdaemon::waitForState(dir / "run/hg.sock", "ready", 10s)) << daemon.logText();
    for (const char* folder : {"run", "state", "state/parts"}) {
        auto st = statOf(dir / folder);
        EXPECT_EQ(st.st_mode & 07777, 0750u) << folder;
        EXPECT_EQ(st.st_uid, uid) << folder;
        EXPECT_EQ(st.st_gid, gid) << folder;
    }
    // The store is written by that user, through the unit's umask 0027: no access for others.
    EXPECT_EQ(statOf(dir / "state/results.db").st_uid, uid);
    EXPECT_EQ(statOf(dir / "state/results.db").st_mode & 0007, 0u);
    const auto ids = std::to_string(uid);
    EXPECT_EQ(procStatus(daemon.pid(), "Uid"), " " + ids + " " + ids + " " + ids + " " + ids);
    if (root) {
        // CAP_NET_BIND_SERVICE is capability 10: mask 0x400, alone in every set, as the
        // unit's CapabilityBoundingSet= and AmbientCapabilities= leave it.
        const std::string kept = HULLGAUGE_UNIT_NET_BIND_SERVICE ? " 0000000000000400" : " 0000000000000000";
        for (const char* set : {"CapEff", "CapPrm", "CapInh", "CapBnd", "CapAmb"})
            EXPECT_EQ(procStatus(daemon.pid(), set), kept) << set;
        EXPECT_EQ(procStatus(daemon.pid(), "NoNewPrivs"), " 1");
    }
    EXPECT_NE(daemon.logText().find("foreground: user "), std::string::npos) << daemon.logText();
    EXPECT_EQ(WEXITSTATUS(daemon.signal(SIGTERM)), 0) << daemon.logText();
}

TEST(Foreground, AFolderItsUserCannotWriteIsRefusedNamingTheKeyTheFolderAndItsOwner)
{
    if (geteuid() != 0) GTEST_SKIP() << "needs root: started as root, the daemon becomes another user";
    hgtest::TempDir dir;
    fs::permissions(dir.path(), fs::perms(0755));
    auto config = writeFolderConfig(dir);
    fs::create_directory(dir / "state");
    fs::permissions(dir / "state", fs::perms(0755));
    DaemonProcess daemon(config, {}, {"--foreground", "--user", "nobody"});
    const int status = daemon.wait(10s);
    ASSERT_TRUE(WIFEXITED(status)) << daemon.logText();
    EXPECT_EQ(WEXITSTATUS(status), 2);
    const std::string expected = "results.database: folder " + (dir / "state").string() +
                                 " is not writable by user nobody (owner root:root, mode 0755)";
    EXPECT_NE(daemon.logText().find(expected), std::string::npos) << daemon.logText();
    EXPECT_FALSE(fs::exists(dir / "state/results.db"));
}

TEST(Foreground, AUserThatDoesNotExistIsRefusedByName)
{
    if (geteuid() != 0) GTEST_SKIP() << "needs root: only root changes its user";
    hgtest::TempDir dir;
    DaemonProcess daemon(writeFolderConfig(dir), {}, {"--foreground", "--user", "no-such-station-user"});
    const int status = daemon.wait(10s);
    ASSERT_TRUE(WIFEXITED(status)) << daemon.logText();
    EXPECT_EQ(WEXITSTATUS(status), 2);
    EXPECT_NE(daemon.logText().find("--user: user 'no-such-station-user' does not exist"), std::string::npos)
        << daemon.logText();
    EXPECT_FALSE(fs::exists(dir / "run"));
}

} // namespace
