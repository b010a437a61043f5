// hullgauge users list|add|passwd|role|remove: the web HMI's accounts
// (docs/audit.md, "Accounts") from the line PC's shell — how the first
// administrator is made, and how one gets in again when every administrator's
// password is lost. Passwords are read from the terminal (twice, not shown) or
// from a file given by name (`--password-file`, `-` for standard input), never
// from the command line. Every change goes into the audit trail as
// `unix:<user>` before it is made: a change that cannot be recorded is not made.
#include "command.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/store/accounts.h"
#include "hullgauge/store/audit_log.h"

#include <fstream>
#include <iostream>
#include <memory>
#include <termios.h>
#include <unistd.h>

namespace hg::cli {
namespace {

struct UsersOptions {
    std::string action;
    std::string name;
    std::string role;
    std::string passwordFile;
    // The installed station's (config/installed/*/hullgauged.yaml: beside `results.database`).
    std::string file = "/var/lib/hullgauge/users.yaml";
    std::string audit = "/var/lib/hullgauge/audit.sqlite";
};

std::string readLine(std::istream& in, const std::string& what)
{
    std::string line;
    if (!std::getline(in, line)) throw InputError(what, "password", "no password to read");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
}

/// One line from the terminal with echo off (restored on every path).
std::string askHidden(const std::string& prompt)
{
    termios old{};
    tcgetattr(STDIN_FILENO, &old);
    termios quiet = old;
    quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
    tcsetattr(STDIN_FILENO, TCSAFLUSH, &quiet);
    std::cerr << prompt << std::flush;
    std::string line;
    const bool got = static_cast<bool>(std::getline(std::cin, line));
    tcsetattr(STDIN_FILENO, TCSAFLUSH, &old);
    std::cerr << '\n';
    if (!got) throw InputError("terminal", "password", "no password typed");
    return line;
}

std::string password(const UsersOptions& o)
{
    if (o.passwordFile == "-") return readLine(std::cin, "standard input");
    if (!o.passwordFile.empty()) {
        std::ifstream in(o.passwordFile);
        if (!in) throw InputError(o.passwordFile, "--password-file", "cannot be read");
        return readLine(in, o.passwordFile);
    }
    if (!isatty(STDIN_FILENO))
        throw InputError("", "--password-file", "standard input is no terminal: give --password-file FILE (or -)");
    const auto first = askHidden("Password for " + o.name + ": ");
    if (askHidden("Again: ") != first) throw InputError("terminal", "password", "the two passwords differ");
    return first;
}

store::Role roleNamed(const std::string& text)
{
    const auto role = parseEnum<store::Role>(text);
    if (!role) throw InputError("", "--role", "'" + text + "' is not " + enumNameList<store::Role>(", ", " or "));
    return *role;
}

int list(const store::AccountsFile& file)
{
    for (const auto& a : file.accounts()) std::cout << a.name << '\t' << enumName(a.role) << '\n';
    return 0;
}

int change(const UsersOptions& o)
{
    const store::AccountsFile file(o.file);
    // The trail first: a change it cannot record is not made.
    store::AuditLog audit(o.audit);
    store::AuditEntry entry{0,
                            Clock::steady().wallMs(),
                            store::unixUserName(geteuid()),
                            "",
                            "tool",
                            "user." + o.action,
                            o.name,
                            "done",
                            {},
                            {},
                            {}};
    const auto before = file.find(o.name);
    if (o.action == "add") {
        const auto role = roleNamed(o.role);
        file.add({o.name, role, store::hashPassword(password(o))});
        entry.after = "role: " + std::string(enumName(role));
    } else if (!before) {
        throw InputError(o.file, "NAME", "no account '" + o.name + "'");
    } else if (o.action == "role") {
        const auto role = roleNamed(o.role);
        file.setRole(o.name, role);
        entry.before = "role: " + std::string(enumName(before->role));
        entry.after = "role: " + std::string(enumName(role));
    } else if (o.action == "passwd") {
        file.setPasswordHash(o.name, store::hashPassword(password(o)));
        entry.action = "user.password";
        entry.detail = "password set with hullgauge users";
    } else {
        file.remove(o.name);
        entry.before = "role: " + std::string(enumName(before->role));
    }
    audit.record(entry);
    std::cerr << "hullgauge users: " << o.action << " " << o.name << " done (" << o.file << ")\n";
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<UsersOptions>();
    auto* sub = app.add_subcommand("users", "the web HMI's accounts and roles: list, add, passwd, role, remove "
                                            "(docs/audit.md); every change in the audit trail");
    sub->add_option("ACTION", o->action, "list, add, passwd, role or remove")
        ->required()
        ->check(CLI::IsMember({"list", "add", "passwd", "role", "remove"}));
    sub->add_option("NAME", o->name, "the account (1-32 letters, digits, '.', '_', '-')");
    sub->add_option("--role", o->role, "operator, engineer or administrator (add, role)");
    sub->add_option("--password-file", o->passwordFile,
                    "read the password from this file's first line ('-': standard input); else it is asked for");
    sub->add_option("--file", o->file, "the accounts file (http.users_file)")->capture_default_str();
    sub->add_option("--audit", o->audit, "the audit trail (results.audit)")->capture_default_str();
    return [=]() {
        if (o->action == "list") return list(store::AccountsFile(o->file));
        if (o->name.empty()) throw InputError("", "NAME", "the account to " + o->action + " is missing");
        if ((o->action == "add" || o->action == "role") && o->role.empty())
            throw InputError("", "--role", "missing: operator, engineer or administrator");
        return change(*o);
    };
}

} // namespace

HG_REGISTER_COMMAND("users", factory);

} // namespace hg::cli
