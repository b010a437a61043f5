#include "foreground.h"

#include "hullgauge/common/error.h"

#include <cerrno>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <grp.h>
#include <linux/capability.h>
#include <pwd.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

// Set by src/daemon/CMakeLists.txt from HULLGAUGE_PLC_PORT, the same setting
// that writes the unit's AmbientCapabilities= (systemd/CMakeLists.txt).
#ifndef HULLGAUGE_UNIT_NET_BIND_SERVICE
#error "HULLGAUGE_UNIT_NET_BIND_SERVICE must be defined (0 or 1) by the build"
#endif

namespace hg::daemon {
namespace {

namespace fs = std::filesystem;

struct Account {
    std::string name;
    uid_t uid = 0;
    gid_t gid = 0;
};

Account lookUp(const std::string& user)
{
    errno = 0;
    const passwd* pw = getpwnam(user.c_str());
    if (!pw) {
        throw InputError("", "--user",
                         fmt::format("user '{}' does not exist (the package's postinst creates hullgauge; "
                                     "systemd-sysusers hullgauge.conf makes it again)",
                                     user));
    }
    return {user, pw->pw_uid, pw->pw_gid};
}

[[noreturn]] void osFailed(const std::string& what)
{
    throw FaultError(fmt::format("foreground: {}: {}", what, std::strerror(errno)));
}

std::string ownerAndMode(const fs::path& folder)
{
    struct stat st {};
    if (stat(folder.c_str(), &st) != 0) return "not readable";
    const passwd* pw = getpwuid(st.st_uid);
    const group* gr = getgrgid(st.st_gid);
    return fmt::format("owner {}:{}, mode {:04o}", pw ? pw->pw_name : std::to_string(st.st_uid),
                       gr ? gr->gr_name : std::to_string(st.st_gid), st.st_mode & 07777);
}

/// Creates a missing folder as the unit's RuntimeDirectory=/StateDirectory= do
/// (mode 0750, its last component owned by `owner`); an existing one is left as
/// it is, so a folder the configuration shares with others (say /tmp) is never
/// taken over. Returns whether it was created.
bool makeFolder(const ServiceFolder& folder, const Account* owner)
{
    std::error_code ec;
    if (fs::exists(folder.path, ec)) {
        if (!fs::is_directory(folder.path, ec))
            throw InputError("", folder.key, fmt::format("{} exists and is not a folder", folder.path.string()));
        return false;
    }
    fs::create_directories(folder.path.parent_path(), ec);
    if (ec || mkdir(folder.path.c_str(), 0750) != 0)
        osFailed(fmt::format("cannot create {} (the folder of {})", folder.path.string(), folder.key));
    if (chmod(folder.path.c_str(), 0750) != 0) osFailed("chmod 0750 " + folder.path.string());
    if (owner && chown(folder.path.c_str(), owner->uid, owner->gid) != 0)
        osFailed(fmt::format("chown {} {}", owner->name, folder.path.string()));
    return true;
}

int lastCapability()
{
    std::ifstream in("/proc/sys/kernel/cap_last_cap");
    int last = CAP_LAST_CAP;
    in >> last;
    return last;
}

/// Becomes `account` with its groups, keeping `keep` (a capability mask of the
/// first 32) as the unit's CapabilityBoundingSet= and AmbientCapabilities= do,
/// and NoNewPrivileges=.
void becomeAccount(const Account& account, std::uint32_t keep)
{
    for (int cap = 0; cap <= lastCapability(); ++cap) {
        if (cap < 32 && (keep & (1u << cap))) continue;
        if (prctl(PR_CAPBSET_DROP, cap, 0, 0, 0) != 0) osFailed(fmt::format("dropping capability {}", cap));
    }
    if (prctl(PR_SET_KEEPCAPS, 1, 0, 0, 0) != 0) osFailed("keeping capabilities across the user change");
    if (initgroups(account.name.c_str(), account.gid) != 0) osFailed("the groups of user " + account.name);
    if (setresgid(account.gid, account.gid, account.gid) != 0) osFailed("the group of user " + account.name);
    if (setresuid(account.uid, account.uid, account.uid) != 0) osFailed("becoming user " + account.name);
    __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
    __user_cap_data_struct data[2]{{keep, keep, keep}, {0, 0, 0}};
    if (syscall(SYS_capset, &header, data) != 0) osFailed("setting the capabilities kept");
    for (int cap = 0; cap < 32; ++cap) {
        if ((keep & (1u << cap)) && prctl(PR_CAP_AMBIENT, PR_CAP_AMBIENT_RAISE, cap, 0, 0) != 0)
            osFailed(fmt::format("raising ambient capability {}", cap));
    }
    if (prctl(PR_SET_KEEPCAPS, 0, 0, 0, 0) != 0 || prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0)
        osFailed("no new privileges");
    // The change must be for good: root is out of reach from here on.
    if (setuid(0) == 0) throw FaultError("foreground: user " + account.name + " could become root again");
}

std::string whoAmI()
{
    const passwd* pw = getpwuid(geteuid());
    return pw ? pw->pw_name : std::to_string(geteuid());
}

} // namespace

std::vector<ServiceFolder> serviceFolders(const station::DaemonConfig& config)
{
    return {{config.maintenance.socket.parent_path(), "maintenance.socket", "RuntimeDirectory=hullgauge"},
            {config.results.database.parent_path(), "results.database", "StateDirectory=hullgauge"}};
}

std::string enterForeground(const station::DaemonConfig& config, const std::string& user)
{
    umask(0027); // the unit's UMask=
    const bool root = geteuid() == 0;
    std::optional<Account> account;
    if (root) account = lookUp(user);
    const auto folders = serviceFolders(config);
    std::vector<std::string> made;
    for (const auto& folder : folders)
        made.push_back(fmt::format("{} {}", folder.path.string(),
                                   makeFolder(folder, account ? &*account : nullptr) ? "created" : "there"));
    const std::uint32_t keep = HULLGAUGE_UNIT_NET_BIND_SERVICE ? (1u << CAP_NET_BIND_SERVICE) : 0u;
    if (account) becomeAccount(*account, keep);
    // Checked as the user the daemon now is, whoever made the folder.
    for (const auto& folder : folders) {
        if (access(folder.path.c_str(), W_OK | X_OK) != 0)
            throw InputError("", folder.key,
                             fmt::format("folder {} is not writable by user {} ({}): give it to that user, as "
                                         "the unit's {} would, or name another folder",
                                         folder.path.string(), whoAmI(), ownerAndMode(folder.path), folder.unit));
    }
    return fmt::format("foreground: user {}{}; {}, {}", whoAmI(),
                       account ? (keep ? " (capability CAP_NET_BIND_SERVICE only)" : " (no capability)") : "", made[0],
                       made[1]);
}

} // namespace hg::daemon
