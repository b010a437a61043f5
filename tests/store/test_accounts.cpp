// The HMI's accounts (docs/audit.md, "Roles" and "Accounts"): the rights of
// each role, the file's refusals naming file, line and field, the changes and
// their refusals, the password hashes (checked against hashes made by openssl
// and by Python's crypt), the file's mode and the lock that keeps two writers
// from losing each other's change.
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/store/accounts.h"

#include <gtest/gtest.h>

#include <functional>
#include <sys/stat.h>
#include <thread>

namespace hg::store {
namespace {

// `openssl passwd -6 -salt saltsalt 'correct horse'` and `openssl passwd -5 -salt saltsalt 'correct horse'`.
const std::string kSha512 =
    "$6$saltsalt$hRM5XZ86KXEw9UOmjigeVqFgULtFB2sgpC9lXQDfMib3Zgw7mEiUvBJI2EplzfAqxL5Vvwp2scFtv/uamSo5z0";
const std::string kSha256 = "$5$saltsalt$myjXcpMpE2Ofk7fj9hqyNYSn6lmWG4Mqnjx.KIRRr4/";

std::string usersYaml(const std::vector<std::string>& entries)
{
    std::string text = "users:\n";
    for (const auto& e : entries) text += e;
    return text;
}

std::string account(const std::string& name, const std::string& role, const std::string& hash = kSha512)
{
    return "  - name: " + name + "\n    role: " + role + "\n    password_hash: '" + hash + "'\n";
}

/// The InputError `accounts()` throws for `text`, which must throw one.
InputError parseError(const hgtest::TempDir& dir, const std::string& text)
{
    const auto file = hgtest::writeFile(dir / "users.yaml", text);
    try {
        AccountsFile(file).accounts();
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << "accepted:\n" << text;
    return InputError("", "", "");
}

TEST(Roles, EachRightNeedsTheRoleTheDocumentsName)
{
    // docs/audit.md, the table of rights.
    EXPECT_EQ(minimumRole(Permission::Read), Role::Operator);
    EXPECT_EQ(minimumRole(Permission::Operate), Role::Engineer);
    EXPECT_EQ(minimumRole(Permission::Programs), Role::Engineer);
    EXPECT_EQ(minimumRole(Permission::Calibration), Role::Engineer);
    EXPECT_EQ(minimumRole(Permission::Users), Role::Administrator);
    EXPECT_EQ(minimumRole(Permission::Settings), Role::Administrator);
    // Each role holds every right of the roles before it.
    EXPECT_TRUE(allows(Role::Administrator, Permission::Read));
    EXPECT_TRUE(allows(Role::Administrator, Permission::Programs));
    EXPECT_TRUE(allows(Role::Engineer, Permission::Read));
    EXPECT_FALSE(allows(Role::Engineer, Permission::Users));
    EXPECT_FALSE(allows(Role::Operator, Permission::Operate));
    EXPECT_FALSE(allows(Role::Operator, Permission::Settings));

    EXPECT_EQ(whoMay(Permission::Read), "an operator, engineer or administrator");
    EXPECT_EQ(whoMay(Permission::Programs), "an engineer or administrator"); // the docs' example answer
    EXPECT_EQ(whoMay(Permission::Operate), "an engineer or administrator");
    EXPECT_EQ(whoMay(Permission::Calibration), "an engineer or administrator");
    EXPECT_EQ(whoMay(Permission::Users), "an administrator");
    EXPECT_EQ(whoMay(Permission::Settings), "an administrator");

    // "operator 'olga' may not change part programs" (docs/audit.md); the others say what the table allows.
    EXPECT_EQ(describe(Permission::Programs), "change part programs");
    EXPECT_NE(describe(Permission::Read).find("audit trail"), std::string_view::npos);
    EXPECT_NE(describe(Permission::Operate).find("maintenance"), std::string_view::npos);
    EXPECT_NE(describe(Permission::Calibration).find("calibrate"), std::string_view::npos);
    EXPECT_NE(describe(Permission::Users).find("accounts"), std::string_view::npos);
    EXPECT_NE(describe(Permission::Settings).find("settings"), std::string_view::npos);
}

TEST(Accounts, ReadsTheDocumentedFile)
{
    hgtest::TempDir dir;
    const auto file = hgtest::writeFile(
        dir / "users.yaml", usersYaml({account("anna", "administrator"), account("olga.k_2-b", "operator", kSha256)}));
    const auto accounts = AccountsFile(file).accounts();
    ASSERT_EQ(accounts.size(), 2u);
    EXPECT_EQ(accounts[0].name, "anna");
    EXPECT_EQ(accounts[0].role, Role::Administrator);
    EXPECT_EQ(accounts[0].passwordHash, kSha512);
    EXPECT_EQ(accounts[1].name, "olga.k_2-b");
    EXPECT_EQ(accounts[1].role, Role::Operator);
    EXPECT_EQ(AccountsFile(file).find("olga.k_2-b")->passwordHash, kSha256);
    EXPECT_FALSE(AccountsFile(file).find("olga"));
    // No file: no accounts.
    EXPECT_TRUE(AccountsFile(dir / "none.yaml").accounts().empty());
}

TEST(Accounts, AFileThatDoesNotReadIsRefusedNamingLineAndField)
{
    hgtest::TempDir dir;
    const auto file = (dir / "users.yaml").string();
    struct Case {
        std::string text;
        int line;
        std::string field;
        std::string problem;
    } cases[] = {
        {usersYaml({account("anna", "administrator"),
                    "  - name: olga\n    role: operator\n    pasword_hash: '" + kSha512 + "'\n"}),
         7, "users[1].pasword_hash", "unknown key 'pasword_hash'"},
        {usersYaml({account("anna", "administrator"), account("olga", "boss")}), 6, "users[1].role",
         "unknown role 'boss' (expected operator, engineer or administrator)"},
        {usersYaml({account("anna", "administrator", "hunter22secret")}), 4, "users[0].password_hash",
         "not a crypt(3) hash"},
        {usersYaml({account("anna", "administrator"), account("olga", "operator"), account("anna", "operator")}), 8,
         "users[2].name", "account 'anna' given twice"},
        {usersYaml({account("-anna", "administrator")}), 2, "users[0].name", "'-anna' is not an account name"},
        {usersYaml({account("anna smith", "administrator")}), 2, "users[0].name", "is not an account name"},
    };
    for (const auto& c : cases) {
        const auto e = parseError(dir, c.text);
        EXPECT_EQ(e.file(), file);
        EXPECT_EQ(e.line(), c.line) << c.text;
        EXPECT_EQ(e.field(), c.field) << c.text;
        EXPECT_NE(e.problem().find(c.problem), std::string::npos) << e.what();
        const std::string where = file + ":" + std::to_string(c.line) + ": " + c.field + ": ";
        EXPECT_EQ(std::string(e.what()).rfind(where, 0), 0u) << e.what();
    }
}

TEST(Accounts, ChangesAndTheirRefusals)
{
    hgtest::TempDir dir;
    const AccountsFile file(dir / "state" / "users.yaml");
    file.add({"anna", Role::Administrator, kSha512});
    file.add({"olga", Role::Operator, kSha256});
    file.setRole("olga", Role::Engineer);
    file.setPasswordHash("olga", kSha512);
    auto olga = file.find("olga");
    ASSERT_TRUE(olga);
    EXPECT_EQ(olga->role, Role::Engineer);
    EXPECT_EQ(olga->passwordHash, kSha512);
    // What another reader finds in the file: the documented layout.
    const auto reread = AccountsFile(file.file()).accounts();
    ASSERT_EQ(reread.size(), 2u);
    EXPECT_EQ(reread[0].name, "anna");
    EXPECT_EQ(reread[1].name, "olga");

    const auto refused = [](auto&& change, const std::string& field, const std::string& problem) {
        try {
            change();
            ADD_FAILURE() << "not refused: " << problem;
        } catch (const InputError& e) {
            EXPECT_EQ(e.field(), field) << e.what();
            EXPECT_EQ(e.problem(), problem);
        }
    };
    refused([&] { file.add({"olga", Role::Operator, kSha256}); }, "name", "account 'olga' exists");
    refused(
        [&] {
            file.add({"", Role::Operator, kSha256});
        },
        "name", "'' is not an account name (1-32 letters, digits, '.', '_', '-')");
    refused(
        [&] {
            file.add({std::string(33, 'a'), Role::Operator, kSha256});
        },
        "name", "'" + std::string(33, 'a') + "' is not an account name (1-32 letters, digits, '.', '_', '-')");
    refused([&] { file.add({"pia", Role::Operator, "secret-password"}); }, "password_hash", "not a crypt(3) hash");
    refused([&] { file.setPasswordHash("olga", "$6$"); }, "password_hash", "not a crypt(3) hash");
    refused([&] { file.setRole("pia", Role::Engineer); }, "name", "no account 'pia'");
    refused([&] { file.setPasswordHash("pia", kSha512); }, "name", "no account 'pia'");
    refused([&] { file.remove("pia"); }, "name", "no account 'pia'");
    const std::string last = "'anna' is the last administrator: make another account administrator first";
    refused([&] { file.setRole("anna", Role::Engineer); }, "name", last);
    refused([&] { file.remove("anna"); }, "name", last);
    // Nothing refused changed the file.
    EXPECT_EQ(file.accounts().size(), 2u);
    EXPECT_EQ(file.find("anna")->role, Role::Administrator);

    // With a second administrator the first may go.
    file.setRole("olga", Role::Administrator);
    file.setRole("anna", Role::Operator);
    file.remove("anna");
    ASSERT_EQ(file.accounts().size(), 1u);
    EXPECT_EQ(file.accounts()[0].name, "olga");
    // Not even as the only account: then nobody could manage the accounts.
    refused([&] { file.remove("olga"); }, "name",
            "'olga' is the last administrator: make another account administrator first");
    EXPECT_EQ(file.accounts().size(), 1u);
}

TEST(Accounts, AFileWithoutAnAdministratorCanStillBeChanged)
{
    // Written by hand with operators only: nothing to keep, so nothing is refused for it.
    hgtest::TempDir dir;
    const AccountsFile file(
        hgtest::writeFile(dir / "users.yaml", usersYaml({account("olga", "operator"), account("pia", "operator")})));
    file.setRole("olga", Role::Engineer);
    file.remove("pia");
    file.remove("olga");
    EXPECT_TRUE(file.accounts().empty());
}

TEST(Accounts, TheFileIsReadableByItsOwnerOnly)
{
    hgtest::TempDir dir;
    const AccountsFile file(dir / "users.yaml");
    hgtest::writeFile(file.file(), usersYaml({account("anna", "administrator")}));
    ::chmod(file.file().c_str(), 0644);
    file.add({"olga", Role::Operator, kSha256});
    struct stat st {};
    ASSERT_EQ(::stat(file.file().c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 07777, 0600u);
}

TEST(Passwords, AYescryptHashWithAFreshSaltThatCryptAccepts)
{
    const auto first = hashPassword("correct horse");
    const auto second = hashPassword("correct horse");
    EXPECT_EQ(first.rfind("$y$", 0), 0u) << first;
    EXPECT_NE(first, second) << "the same salt twice";
    // "$y$<params>$<salt>$<hash>": the salts differ, not only the hashes.
    const auto salt = [](const std::string& h) { return h.substr(0, h.rfind('$')); };
    EXPECT_NE(salt(first), salt(second));
    EXPECT_TRUE(validPasswordHash(first));
    EXPECT_TRUE(verifyPassword("correct horse", first));
    EXPECT_TRUE(verifyPassword("correct horse", second));
    EXPECT_FALSE(verifyPassword("correct hors", first));
    EXPECT_FALSE(verifyPassword("correct horse ", first));
    // Python's crypt module (libxcrypt's crypt(3)) agrees.
    const auto python = hgtest::run("/usr/bin/python3 -W ignore -c \"import crypt, sys; "
                                    "print(crypt.crypt('correct horse', sys.argv[1]) == sys.argv[1])\" '" +
                                    first + "'");
    EXPECT_EQ(python.out, "True\n") << python.err;

    try {
        hashPassword("1234567");
        FAIL() << "a 7-character password hashed";
    } catch (const InputError& e) {
        EXPECT_EQ(e.field(), "password");
        EXPECT_EQ(e.problem(), "a password has at least 8 characters (7 given)");
    }
    EXPECT_TRUE(verifyPassword("12345678", hashPassword("12345678")));
}

TEST(Passwords, HashesOfOtherMethodsAreVerifiedAndPlainTextNever)
{
    EXPECT_TRUE(verifyPassword("correct horse", kSha512));
    EXPECT_TRUE(verifyPassword("correct horse", kSha256));
    EXPECT_FALSE(verifyPassword("correct horsE", kSha512));
    EXPECT_FALSE(validPasswordHash("correct horse"));
    EXPECT_FALSE(validPasswordHash("$6$saltsalt$"));                       // a setting, no hash
    EXPECT_FALSE(validPasswordHash("$1$saltsalt$abcdefghijklmnopqrstuv")); // MD5: not read
    // A stored plain "password" is never compared as one.
    EXPECT_FALSE(verifyPassword("hunter22secret", "hunter22secret"));
}

TEST(Accounts, TwoWritersAtOnceLoseNothing)
{
    hgtest::TempDir dir;
    const auto path = dir / "users.yaml";
    std::string errors[2];
    const auto adds = [&](const std::string& prefix, std::string& error) {
        const AccountsFile file(path); // each writer with its own object, as the daemon and the tool
        try {
            for (int i = 0; i < 20; ++i) file.add({prefix + std::to_string(i), Role::Operator, kSha512});
        } catch (const std::exception& e) {
            error = e.what();
        }
    };
    {
        std::jthread a(adds, "a", std::ref(errors[0]));
        std::jthread b(adds, "b", std::ref(errors[1]));
    } // both joined
    EXPECT_EQ(errors[0], "");
    EXPECT_EQ(errors[1], "");
    const auto accounts = AccountsFile(path).accounts();
    EXPECT_EQ(accounts.size(), 40u);
    for (const char* prefix : {"a", "b"})
        for (int i = 0; i < 20; ++i) EXPECT_TRUE(AccountsFile(path).find(prefix + std::to_string(i))) << prefix << i;
}

} // namespace
} // namespace hg::store
