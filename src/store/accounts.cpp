#include "hullgauge/store/accounts.h"

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <crypt.h>
#include <cstring>
#include <fcntl.h>
#include <memory>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

namespace hg::store {

Role minimumRole(Permission permission)
{
    switch (permission) {
    case Permission::Read:
        return Role::Operator;
    case Permission::Operate:
    case Permission::Programs:
    case Permission::Calibration:
        return Role::Engineer;
    case Permission::Users:
    case Permission::Settings:
        return Role::Administrator;
    }
    return Role::Administrator;
}

std::string_view describe(Permission permission)
{
    switch (permission) {
    case Permission::Read:
        return "read the audit trail";
    case Permission::Operate:
        return "run maintenance actions";
    case Permission::Programs:
        return "change part programs";
    case Permission::Calibration:
        return "calibrate the station";
    case Permission::Users:
        return "manage accounts";
    case Permission::Settings:
        return "change settings";
    }
    return "?";
}

std::string whoMay(Permission permission)
{
    std::vector<std::string> roles;
    for (const auto& [role, name] : nameTable(Role{}))
        if (allows(role, permission)) roles.emplace_back(name);
    // Every role's name begins with a vowel.
    std::string text = "an ";
    for (std::size_t i = 0; i < roles.size(); ++i)
        text += (i == 0 ? "" : i + 1 == roles.size() ? " or " : ", ") + roles[i];
    return text;
}

bool validPasswordHash(const std::string& hash)
{
    static constexpr std::array<const char*, 6> kPrefixes{"$y$", "$gy$", "$7$", "$6$", "$5$", "$2b$"};
    const bool known =
        std::any_of(kPrefixes.begin(), kPrefixes.end(), [&](const char* p) { return hash.rfind(p, 0) == 0; });
    // A whole hash: method, salt and the hashed password ("$6$salt$hash"), not a setting alone;
    // crypt_checksalt says whether this libcrypt supports the method and the setting is well formed.
    // It calls sha256crypt ($5$) legacy; docs/audit.md reads it all the same (the methods weaker still
    // are not among the prefixes).
    const auto fields = std::count(hash.begin(), hash.end(), '$');
    const int check = crypt_checksalt(hash.c_str());
    return known && fields >= 3 && hash.back() != '$' && hash.size() >= 20 &&
           (check == CRYPT_SALT_OK || check == CRYPT_SALT_METHOD_LEGACY);
}

bool verifyPassword(const std::string& password, const std::string& hash)
{
    if (!validPasswordHash(hash)) return false;
    auto data = std::make_unique<crypt_data>();
    const char* out = crypt_r(password.c_str(), hash.c_str(), data.get());
    // A failed crypt_r returns a string starting with '*', never the hash itself.
    if (!out || out[0] == '*') return false;
    const std::size_t n = std::strlen(out);
    if (n != hash.size()) return false;
    unsigned char diff = 0;
    for (std::size_t i = 0; i < n; ++i) diff |= static_cast<unsigned char>(out[i] ^ hash[i]);
    return diff == 0;
}

std::string hashPassword(const std::string& password)
{
    if (password.size() < 8)
        throw InputError("", "password",
                         "a password has at least 8 characters (" + std::to_string(password.size()) + " given)");
    // yescrypt at libxcrypt's default cost; the salt from the kernel's random source (no rbytes given).
    char setting[CRYPT_GENSALT_OUTPUT_SIZE];
    if (!crypt_gensalt_rn("$y$", 0, nullptr, 0, setting, sizeof setting))
        throw FaultError(std::string("crypt_gensalt: ") + std::strerror(errno));
    auto data = std::make_unique<crypt_data>();
    const char* out = crypt_r(password.c_str(), setting, data.get());
    if (!out || out[0] == '*') throw FaultError("crypt: yescrypt failed");
    return out;
}

bool validAccountName(const std::string& name)
{
    if (name.empty() || name.size() > 32 || !std::isalnum(static_cast<unsigned char>(name[0]))) return false;
    return std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
    });
}

namespace {

std::vector<Account> parse(const ConfigNode& root)
{
    std::vector<Account> accounts;
    if (root.isNull()) return accounts;
    root.allowOnlyKeys({"users"});
    const auto users = root.optional("users");
    if (!users) return accounts;
    for (const auto& item : users->items()) {
        item.allowOnlyKeys({"name", "role", "password_hash"});
        Account a{item["name"].asString(), item["role"].asEnum<Role>("role"), item["password_hash"].asString()};
        if (!validAccountName(a.name))
            item["name"].fail("'" + a.name + "' is not an account name (1-32 letters, digits, '.', '_', '-')");
        if (!validPasswordHash(a.passwordHash))
            item["password_hash"].fail("not a crypt(3) hash ($y$..., $6$...): set it with `hullgauge users passwd`");
        for (const auto& other : accounts)
            if (other.name == a.name) item["name"].fail("account '" + a.name + "' given twice");
        accounts.push_back(std::move(a));
    }
    return accounts;
}

std::string emit(const std::vector<Account>& accounts)
{
    YAML::Emitter out;
    out << YAML::Comment("hullgauge HMI accounts (docs/audit.md): written by the daemon and `hullgauge users`");
    out << YAML::BeginMap << YAML::Key << "users" << YAML::Value << YAML::BeginSeq;
    for (const auto& a : accounts)
        out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << a.name << YAML::Key << "role" << YAML::Value
            << std::string(enumName(a.role)) << YAML::Key << "password_hash" << YAML::Value << YAML::SingleQuoted
            << a.passwordHash << YAML::EndMap;
    out << YAML::EndSeq << YAML::EndMap;
    return std::string(out.c_str()) + "\n";
}

std::vector<Account>::iterator named(std::vector<Account>& accounts, const std::string& name)
{
    auto it = std::find_if(accounts.begin(), accounts.end(), [&](const Account& a) { return a.name == name; });
    if (it == accounts.end()) throw InputError("", "name", "no account '" + name + "'");
    return it;
}

bool anyAdministrator(const std::vector<Account>& accounts)
{
    return std::any_of(accounts.begin(), accounts.end(),
                       [](const Account& a) { return a.role == Role::Administrator; });
}

/// A change that would leave no administrator where there was one is refused, even of the only account:
/// without one nobody can manage the accounts (docs/audit.md). A file written by hand without any
/// administrator can still be changed.
void keepAnAdministrator(const std::vector<Account>& before, const std::vector<Account>& after, const std::string& name)
{
    if (anyAdministrator(before) && !anyAdministrator(after))
        throw InputError("", "name",
                         "'" + name + "' is the last administrator: make another account administrator first");
}

} // namespace

AccountsFile::AccountsFile(std::filesystem::path file) : file_(std::move(file))
{
}

std::vector<Account> AccountsFile::accounts() const
{
    std::error_code ec;
    if (!std::filesystem::exists(file_, ec)) return {};
    return parse(ConfigNode::loadFile(file_));
}

std::optional<Account> AccountsFile::find(const std::string& name) const
{
    for (auto& a : accounts())
        if (a.name == name) return a;
    return std::nullopt;
}

// Read, change and replace under an exclusive lock on `<file>.lock`, so the daemon and the tool never
// lose each other's change; the file itself is replaced whole (replaceFileDurably) with mode 0600.
template <class Change> void AccountsFile::change(Change&& edit) const
{
    std::error_code ec;
    if (file_.has_parent_path()) std::filesystem::create_directories(file_.parent_path(), ec);
    const auto lockPath = file_.string() + ".lock";
    const int fd = ::open(lockPath.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0) throw FaultError("accounts " + lockPath + ": " + std::strerror(errno));
    struct Unlock {
        int fd;
        ~Unlock() { ::close(fd); }
    } unlock{fd};
    if (::flock(fd, LOCK_EX) != 0) throw FaultError("accounts " + lockPath + ": lock: " + std::strerror(errno));
    auto list = accounts();
    edit(list);
    const mode_t old = ::umask(0077);
    try {
        replaceFileDurably(file_, emit(list));
    } catch (...) {
        ::umask(old);
        throw;
    }
    ::umask(old);
    giveToFolderOwner(file_);
    giveToFolderOwner(lockPath);
}

void AccountsFile::add(const Account& account) const
{
    if (!validAccountName(account.name))
        throw InputError("", "name",
                         "'" + account.name + "' is not an account name (1-32 letters, digits, '.', '_', '-')");
    if (!validPasswordHash(account.passwordHash)) throw InputError("", "password_hash", "not a crypt(3) hash");
    change([&](std::vector<Account>& list) {
        for (const auto& a : list)
            if (a.name == account.name) throw InputError("", "name", "account '" + account.name + "' exists");
        list.push_back(account);
    });
}

void AccountsFile::setRole(const std::string& name, Role role) const
{
    change([&](std::vector<Account>& list) {
        const auto before = list;
        named(list, name)->role = role;
        keepAnAdministrator(before, list, name);
    });
}

void AccountsFile::setPasswordHash(const std::string& name, const std::string& hash) const
{
    if (!validPasswordHash(hash)) throw InputError("", "password_hash", "not a crypt(3) hash");
    change([&](std::vector<Account>& list) { named(list, name)->passwordHash = hash; });
}

void AccountsFile::remove(const std::string& name) const
{
    change([&](std::vector<Account>& list) {
        const auto before = list;
        list.erase(named(list, name));
        keepAnAdministrator(before, list, name);
    });
}

} // namespace hg::store
