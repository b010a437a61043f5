#include "hullgauge/store/audit_log.h"

#include "hullgauge/common/durable_file.h"
#include "hullgauge/store/export.h"
#include "hullgauge/store/result_reader.h"

#include <array>
#include <pwd.h>
#include <sstream>

namespace hg::store {

namespace {

// Version 1 of the trail (docs/audit.md, "Store"): entries appended, never changed or removed.
constexpr const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS audit (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  at_unix_ms INTEGER NOT NULL,
  who TEXT NOT NULL,
  role TEXT NOT NULL,
  source TEXT NOT NULL,
  action TEXT NOT NULL,
  object TEXT NOT NULL,
  outcome TEXT NOT NULL CHECK (outcome IN ('done', 'refused', 'failed')),
  detail TEXT NOT NULL,
  before_text TEXT NOT NULL,
  after_text TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS audit_time ON audit (at_unix_ms);
CREATE TABLE IF NOT EXISTS watched_files (
  path TEXT PRIMARY KEY,
  sha256 TEXT NOT NULL,
  content TEXT NOT NULL);
CREATE TRIGGER IF NOT EXISTS audit_append_only_update BEFORE UPDATE ON audit
  BEGIN SELECT RAISE(ABORT, 'the audit trail is append-only'); END;
CREATE TRIGGER IF NOT EXISTS audit_append_only_delete BEFORE DELETE ON audit
  BEGIN SELECT RAISE(ABORT, 'the audit trail is append-only'); END;
PRAGMA user_version = 1;
)";

std::int64_t insert(const sqlite::Connection& db, const AuditEntry& e)
{
    auto add = db.prepare("INSERT INTO audit (at_unix_ms, who, role, source, action, object, outcome, detail, "
                          "before_text, after_text) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    add.bind(1, e.atMs).bind(2, e.who).bind(3, e.role).bind(4, e.source).bind(5, e.action).bind(6, e.object);
    add.bind(7, e.outcome).bind(8, e.detail).bind(9, e.before).bind(10, e.after);
    add.step();
    return db.lastInsertRowId();
}

} // namespace

AuditLog::AuditLog(const std::filesystem::path& file, bool readOnly) : file_(file)
{
    const std::string label = "audit trail " + file.string();
    bool fresh = false;
    if (readOnly) {
        db_ = sqlite::open(file, sqlite::Access::Read, label);
    } else {
        std::error_code ec;
        if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
        fresh = !std::filesystem::exists(file, ec);
        db_ = sqlite::open(file, sqlite::Access::Create, label);
        db_.exec("PRAGMA journal_mode=WAL");
        // A recorded change survives a power cut as the result it came with does.
        db_.exec("PRAGMA synchronous=FULL");
    }
    auto version = db_.prepare("PRAGMA user_version");
    const int found = version.step() ? version.integer(0) : 0;
    if (found > 1) throw sqlite::Error(label, "audit schema version " + std::to_string(found) + " is newer than 1");
    if (!readOnly && found < 1) db_.exec(kSchema);
    // Created by a root shell (`hullgauge users`): the daemon's all the same. SQLite gives its WAL the
    // database's owner itself.
    if (!readOnly && fresh) giveToFolderOwner(file);
    if (readOnly && found < 1) throw sqlite::Error(label, "not an audit trail (no audit table)");
}

std::int64_t AuditLog::record(AuditEntry entry)
{
    std::lock_guard lock(mutex_);
    return insert(db_, entry);
}

std::vector<AuditEntry> AuditLog::select(const AuditQuery& q) const
{
    std::string sql = "SELECT id, at_unix_ms, who, role, source, action, object, outcome, detail, before_text, "
                      "after_text FROM audit WHERE 1";
    if (q.sinceMs) sql += " AND at_unix_ms >= :since";
    if (q.untilMs) sql += " AND at_unix_ms < :until";
    if (!q.who.empty()) sql += " AND who = :who";
    // substr, not LIKE: an action's `_` is no wildcard.
    if (!q.actionPrefix.empty()) sql += " AND substr(action, 1, length(:action)) = :action";
    if (!q.outcome.empty()) sql += " AND outcome = :outcome";
    if (q.beforeId) sql += " AND id < :before";
    sql += " ORDER BY id DESC";
    if (q.limit > 0) sql += " LIMIT " + std::to_string(q.limit);
    std::lock_guard lock(mutex_);
    auto s = db_.prepare(sql);
    int i = 0;
    if (q.sinceMs) s.bind(++i, *q.sinceMs);
    if (q.untilMs) s.bind(++i, *q.untilMs);
    if (!q.who.empty()) s.bind(++i, q.who);
    if (!q.actionPrefix.empty()) s.bind(++i, q.actionPrefix);
    if (!q.outcome.empty()) s.bind(++i, q.outcome);
    if (q.beforeId) s.bind(++i, *q.beforeId);
    std::vector<AuditEntry> entries;
    while (s.step())
        entries.push_back({s.int64(0), s.int64(1), s.text(2), s.text(3), s.text(4), s.text(5), s.text(6), s.text(7),
                           s.text(8), s.text(9), s.text(10)});
    return entries;
}

std::optional<AuditLog::Watched> AuditLog::watched(const std::string& path) const
{
    std::lock_guard lock(mutex_);
    auto s = db_.prepare("SELECT sha256, content FROM watched_files WHERE path = ?");
    s.bind(1, path);
    if (!s.step()) return std::nullopt;
    return Watched{s.text(0), s.text(1)};
}

std::int64_t AuditLog::recordFileChange(const std::string& path, const Watched& now, AuditEntry entry)
{
    std::lock_guard lock(mutex_);
    sqlite::Transaction transaction(db_);
    const auto id = insert(db_, entry);
    auto keep = db_.prepare("INSERT INTO watched_files (path, sha256, content) VALUES (?, ?, ?) "
                            "ON CONFLICT (path) DO UPDATE SET sha256 = excluded.sha256, content = excluded.content");
    keep.bind(1, path).bind(2, now.sha256).bind(3, now.content).step();
    transaction.commit();
    return id;
}

std::string unixUserName(unsigned uid)
{
    passwd entry{};
    passwd* found = nullptr;
    std::array<char, 1024> buffer{};
    if (getpwuid_r(uid, &entry, buffer.data(), buffer.size(), &found) == 0 && found)
        return std::string("unix:") + found->pw_name;
    return "unix:uid " + std::to_string(uid);
}

nlohmann::json toJson(const AuditEntry& e)
{
    return {{"id", e.id},           {"at_unix_ms", e.atMs}, {"time", formatUtc(e.atMs)}, {"who", e.who},
            {"role", e.role},       {"source", e.source},   {"action", e.action},        {"object", e.object},
            {"outcome", e.outcome}, {"detail", e.detail},   {"before", e.before},        {"after", e.after}};
}

std::string auditCsv(const std::vector<AuditEntry>& entries)
{
    std::ostringstream out;
    const auto line = [&out](const std::vector<std::string>& cells) {
        for (std::size_t i = 0; i < cells.size(); ++i) out << (i ? "," : "") << csvField(cells[i]);
        out << "\r\n";
    };
    line({"id", "time", "who", "role", "source", "action", "object", "outcome", "detail", "before", "after"});
    for (const auto& e : entries)
        line({std::to_string(e.id), formatUtc(e.atMs), e.who, e.role, e.source, e.action, e.object, e.outcome, e.detail,
              e.before, e.after});
    return out.str();
}

} // namespace hg::store
