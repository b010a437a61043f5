// `hullgauge users` run as a program (docs/audit.md, "From the line PC's
// shell"): accounts added with a password from a file and from standard
// input, listed, given another role and password, removed; the refusals with
// exit status 2 naming what was wrong and nothing changed; every change in the
// audit trail as `unix:<the user running the test>` (`id -un`) from `tool`.
// Passwords are checked with Python's crypt module.
#include "hgtest/paths.h"
#include "hullgauge/store/accounts.h"
#include "hullgauge/store/audit_log.h"

#include <gtest/gtest.h>

namespace {

struct Station {
    hgtest::TempDir dir;
    std::filesystem::path users = dir / "state" / "users.yaml";
    std::filesystem::path audit = dir / "state" / "audit.sqlite";

    /// `hullgauge users ARGS --file … --audit …` with `input` on its standard input (a file, never a terminal).
    hgtest::RunResult run(const std::string& args, const std::string& input = "") const
    {
        const auto in = hgtest::writeFile(dir / "stdin.txt", input);
        return hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " users " + args + " --file " +
                           users.string() + " --audit " + audit.string() + " < " + in.string());
    }
    std::string list() const { return run("list").out; }
    std::string hashOf(const std::string& name) const
    {
        const auto account = hg::store::AccountsFile(users).find(name);
        return account ? account->passwordHash : std::string();
    }
};

/// Whether crypt(3), called by Python, finds `password` in `hash`.
bool cryptAccepts(const std::string& password, const std::string& hash)
{
    const auto r = hgtest::run("/usr/bin/python3 -W ignore -c \"import crypt, sys; "
                               "print(crypt.crypt(sys.argv[1], sys.argv[2]) == sys.argv[2])\" '" +
                               password + "' '" + hash + "'");
    EXPECT_EQ(r.status, 0) << r.err;
    return r.out == "True\n";
}

std::string unixUser()
{
    const auto r = hgtest::run("id -un");
    return "unix:" + r.out.substr(0, r.out.find('\n'));
}

void expectRefused(const hgtest::RunResult& r, const std::string& message)
{
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
}

TEST(UsersCli, AddsListsChangesAndRemovesAccountsEachInTheTrail)
{
    Station s;
    const auto passwordFile = hgtest::writeFile(s.dir / "anna.txt", "anna-password\nsecond line ignored\n");
    auto r = s.run("add anna --role administrator --password-file " + passwordFile.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "hullgauge users: add anna done (" + s.users.string() + ")\n");
    r = s.run("add olga --role operator --password-file -", "olga-password\n");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(s.list(), "anna\tadministrator\nolga\toperator\n");
    EXPECT_EQ(s.hashOf("anna").rfind("$y$", 0), 0u);
    EXPECT_TRUE(cryptAccepts("anna-password", s.hashOf("anna")));
    EXPECT_TRUE(cryptAccepts("olga-password", s.hashOf("olga")));
    EXPECT_FALSE(cryptAccepts("anna-password", s.hashOf("olga")));

    ASSERT_EQ(s.run("role olga --role engineer").status, 0);
    EXPECT_EQ(s.list(), "anna\tadministrator\nolga\tengineer\n");
    ASSERT_EQ(s.run("passwd olga --password-file -", "olga-new-password\n").status, 0);
    EXPECT_TRUE(cryptAccepts("olga-new-password", s.hashOf("olga")));
    EXPECT_FALSE(cryptAccepts("olga-password", s.hashOf("olga")));
    ASSERT_EQ(s.run("remove olga").status, 0);
    EXPECT_EQ(s.list(), "anna\tadministrator\n");

    const hg::store::AuditLog trail(s.audit, true);
    auto entries = trail.select({});
    std::reverse(entries.begin(), entries.end());
    const struct {
        std::string action, object, before, after;
    } expected[] = {{"user.add", "anna", "", "role: administrator"},
                    {"user.add", "olga", "", "role: operator"},
                    {"user.role", "olga", "role: operator", "role: engineer"},
                    {"user.password", "olga", "", ""},
                    {"user.remove", "olga", "role: engineer", ""}};
    ASSERT_EQ(entries.size(), 5u);
    for (std::size_t i = 0; i < entries.size(); ++i) {
        EXPECT_EQ(entries[i].who, unixUser());
        EXPECT_EQ(entries[i].role, "");
        EXPECT_EQ(entries[i].source, "tool");
        EXPECT_EQ(entries[i].outcome, "done");
        EXPECT_EQ(entries[i].action, expected[i].action);
        EXPECT_EQ(entries[i].object, expected[i].object);
        EXPECT_EQ(entries[i].before, expected[i].before);
        EXPECT_EQ(entries[i].after, expected[i].after);
    }
    // No password, nor its hash, is anywhere in the trail.
    for (const auto& e : entries)
        for (const auto* text : {&e.detail, &e.before, &e.after})
            EXPECT_EQ(text->find("password:"), std::string::npos) << *text;
    EXPECT_EQ(hgtest::run("cat " + s.audit.string() + "* | grep -c olga-new-password").out, "0\n");
}

TEST(UsersCli, RefusesBadRequestsNamingWhatWasWrongAndChangesNothing)
{
    Station s;
    const auto passwordFile = hgtest::writeFile(s.dir / "pw.txt", "long-enough\n");
    ASSERT_EQ(s.run("add anna --role administrator --password-file " + passwordFile.string()).status, 0);
    const auto pw = " --password-file " + passwordFile.string();
    expectRefused(s.run("add pia --role boss" + pw), "--role: 'boss' is not operator, engineer or administrator");
    expectRefused(s.run("add pia" + pw), "--role: missing");
    expectRefused(s.run("role pia --role engineer"), "no account 'pia'");
    expectRefused(s.run("passwd pia" + pw), "no account 'pia'");
    expectRefused(s.run("remove pia"), "no account 'pia'");
    expectRefused(s.run("add pia --role operator"), "standard input is no terminal: give --password-file FILE (or -)");
    expectRefused(s.run("add pia --role operator --password-file -", "short\n"),
                  "a password has at least 8 characters (5 given)");
    expectRefused(s.run("add pia --role operator --password-file " + (s.dir / "none.txt").string()),
                  (s.dir / "none.txt").string() + ": --password-file: cannot be read");
    expectRefused(s.run("add anna --role operator" + pw), "account 'anna' exists");
    expectRefused(s.run("add 'p ia' --role operator" + pw), "'p ia' is not an account name");
    expectRefused(s.run("remove anna"), "'anna' is the last administrator: make another account administrator first");
    expectRefused(s.run("role anna --role operator"), "'anna' is the last administrator");
    expectRefused(s.run("remove"), "NAME: the account to remove is missing");
    expectRefused(s.run("rename anna"), "rename");

    EXPECT_EQ(s.list(), "anna\tadministrator\n");
    // Only the one change made is in the trail.
    const hg::store::AuditLog trail(s.audit, true);
    const auto entries = trail.select({});
    ASSERT_EQ(entries.size(), 1u);
    EXPECT_EQ(entries[0].action, "user.add");
}

} // namespace
