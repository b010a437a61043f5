// The web HMI's accounts (docs/audit.md, "Roles"): each person signs in with
// their own name and password (stored as a crypt(3) hash, never in clear) and
// acts with their role's rights — an operator watches, an engineer changes
// part programs and calibrates, an administrator besides manages the accounts
// and the daemon's settings. One YAML file (`http.users_file`) written by the
// daemon for the HMI's administrator and by `hullgauge users`, whole or not at
// all (replaced atomically, mode 0600, under a lock so both never interleave).
#pragma once

#include "hullgauge/common/enum_names.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace hg::store {

/// Ordered: each role holds every right of the roles before it.
enum class Role { Operator, Engineer, Administrator };
constexpr auto nameTable(Role)
{
    using enum Role;
    return std::to_array<EnumName<Role>>(
        {{Operator, "operator"}, {Engineer, "engineer"}, {Administrator, "administrator"}});
}

/// What a request may want to do; each needs a least role (minimumRole).
enum class Permission { Read, Operate, Programs, Calibration, Users, Settings };
constexpr auto nameTable(Permission)
{
    using enum Permission;
    return std::to_array<EnumName<Permission>>({{Read, "read"},
                                                {Operate, "operate"},
                                                {Programs, "programs"},
                                                {Calibration, "calibration"},
                                                {Users, "users"},
                                                {Settings, "settings"}});
}
/// What the right lets one do, in words: "change part programs".
std::string_view describe(Permission permission);
/// Who holds it, in words: "an engineer or administrator".
std::string whoMay(Permission permission);
/// Read: operator; Operate, Programs, Calibration: engineer; Users, Settings: administrator (docs/audit.md).
Role minimumRole(Permission permission);
inline bool allows(Role role, Permission permission)
{
    return role >= minimumRole(permission);
}

struct Account {
    std::string name;
    Role role = Role::Operator;
    std::string passwordHash;
};

/// True when `hash` is a crypt(3) setting this libcrypt can verify (the
/// prefixes `$y$`, `$gy$`, `$7$`, `$6$`, `$5$`, `$2b$`): never a plain password.
bool validPasswordHash(const std::string& hash);
/// Whether `password` hashes to `hash` (crypt_r; compared in constant time).
bool verifyPassword(const std::string& password, const std::string& hash);
/// A yescrypt hash of `password` with a fresh salt from the kernel. Throws InputError
/// (field "password") for a password of fewer than 8 characters.
std::string hashPassword(const std::string& password);
/// Names: 1–32 characters of letters, digits, `.`, `_`, `-`, starting with a letter or digit.
bool validAccountName(const std::string& name);

class AccountsFile {
  public:
    explicit AccountsFile(std::filesystem::path file);

    /// The accounts as the file holds them now (none when it does not exist). Throws InputError naming
    /// file, line and field for a malformed file.
    std::vector<Account> accounts() const;
    std::optional<Account> find(const std::string& name) const;

    /// Each change reads the file, changes it and replaces it under the lock. They throw InputError
    /// naming the problem: an invalid name or hash, a name taken (add) or unknown (the others), the
    /// last administrator removed or made another role.
    void add(const Account& account) const;
    void setRole(const std::string& name, Role role) const;
    void setPasswordHash(const std::string& name, const std::string& hash) const;
    void remove(const std::string& name) const;

    const std::filesystem::path& file() const { return file_; }

  private:
    template <class Change> void change(Change&& edit) const;

    std::filesystem::path file_;
};

} // namespace hg::store
