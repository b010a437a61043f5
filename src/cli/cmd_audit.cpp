// hullgauge audit [--since T] [--until T] [--who W] [--action PREFIX]
// [--outcome O] [--format text|csv|json] [--out F]: the audit trail
// (docs/audit.md) read read-only, beside the running daemon, as a table for
// the terminal or exported as CSV or JSON — the same selection and columns as
// the web HMI's audit page and its download.
#include "command.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "hullgauge/store/audit_log.h"
#include "hullgauge/store/result_reader.h"

#include <iostream>
#include <memory>
#include <sstream>

namespace hg::cli {
namespace {

struct AuditOptions {
    std::string audit = "/var/lib/hullgauge/audit.sqlite";
    std::string since, until, who, action, outcome, out;
    std::string format = "text";
};

/// One line per entry; before and after are in the CSV and JSON, the terminal shows that they exist.
std::string table(const std::vector<store::AuditEntry>& entries)
{
    std::ostringstream out;
    for (auto it = entries.rbegin(); it != entries.rend(); ++it) {
        const auto& e = *it;
        out << store::formatUtc(e.atMs) << "  " << e.who << (e.role.empty() ? "" : " (" + e.role + ")") << "  "
            << e.source << "  " << e.action << "  " << e.object << "  " << e.outcome;
        if (!e.detail.empty()) out << "  " << e.detail;
        if (!e.before.empty() || !e.after.empty()) out << "  [before/after: --format csv or json]";
        out << '\n';
    }
    return out.str();
}

/// The trail named by --audit, read-only. It is the user's file: one that is missing or no audit trail is
/// bad input naming it (exit status 2, docs/contracts.md §5), as the result store of `hullgauge export`.
store::AuditLog openTrail(const std::string& file)
{
    if (auto problem = notARegularFile(file); !problem.empty())
        throw InputError(file, "--audit", "no audit trail at " + file + ": " + problem);
    try {
        return store::AuditLog(file, true);
    } catch (const store::sqlite::Error& e) {
        throw InputError(file, "--audit", e.reason());
    }
}

int run(const AuditOptions& o)
{
    store::AuditQuery q;
    if (!o.since.empty()) q.sinceMs = store::parseUtc(o.since, "--since");
    if (!o.until.empty()) q.untilMs = store::parseUtc(o.until, "--until");
    q.who = o.who;
    q.actionPrefix = o.action;
    q.outcome = o.outcome;
    const auto audit = openTrail(o.audit);
    const auto entries = audit.select(q);
    std::string text;
    if (o.format == "csv") {
        text = store::auditCsv(entries);
    } else if (o.format == "json") {
        nlohmann::json rows = nlohmann::json::array();
        for (const auto& e : entries) rows.push_back(store::toJson(e));
        text = nlohmann::json{{"entries", rows}}.dump(2) + "\n";
    } else {
        text = table(entries);
    }
    if (o.out.empty())
        std::cout << text;
    else
        replaceFileDurably(o.out, text);
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<AuditOptions>();
    auto* sub = app.add_subcommand("audit", "the audit trail: who changed which program, file, calibration, "
                                            "setting or account, and every refused attempt (docs/audit.md)");
    sub->add_option("--audit", o->audit, "the audit trail (results.audit; read read-only)")->capture_default_str();
    sub->add_option("--since", o->since, "entries at or after this UTC time (YYYY-MM-DD[THH:MM[:SS]][Z])");
    sub->add_option("--until", o->until, "entries before this UTC time");
    sub->add_option("--who", o->who, "entries of this person (an account, unix:<user>, hullgauged)");
    sub->add_option("--action", o->action, "entries whose action begins so (program., user., file.changed, ...)");
    sub->add_option("--outcome", o->outcome, "done, refused or failed")
        ->check(CLI::IsMember({"done", "refused", "failed"}));
    sub->add_option("--format", o->format, "text (oldest first), csv or json (newest first)")
        ->check(CLI::IsMember({"text", "csv", "json"}))
        ->capture_default_str();
    sub->add_option("--out", o->out, "write to this file (replaced whole) instead of standard output");
    return [=]() { return run(*o); };
}

} // namespace

HG_REGISTER_COMMAND("audit", factory);

} // namespace hg::cli
