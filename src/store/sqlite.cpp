#include "hullgauge/store/sqlite.h"

#include <chrono>
#include <sqlite3.h>
#include <utility>

namespace hg::store::sqlite {
namespace {

/// Every lock on the store is one short statement (a commit, a mark, a read): waiting this long
/// for one is never a cycle's delay, and a lock held longer is a fault worth reporting.
constexpr std::chrono::milliseconds kBusyTimeout{2000};

struct OpenFlags {
    int flags;
    bool readOnlyUri; ///< opened as "file:<absolute path>?mode=ro"
};

OpenFlags flagsFor(Access access)
{
    switch (access) {
    case Access::Create:
        return {SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, false};
    case Access::Write:
        return {SQLITE_OPEN_READWRITE, false};
    case Access::Read:
        break;
    }
    return {SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, true};
}

} // namespace

Error::Error(const std::string& label, std::string reason)
    : FaultError(label + ": " + reason), reason_(std::move(reason))
{
}

Connection open(const std::filesystem::path& file, Access access, std::string label)
{
    Connection db;
    db.label_ = std::move(label);
    const auto how = flagsFor(access);
    const auto name = how.readOnlyUri ? "file:" + std::filesystem::absolute(file).string() + "?mode=ro" : file.string();
    // A failed open may still return a handle: the connection's destructor closes it.
    if (sqlite3_open_v2(name.c_str(), &db.db_, how.flags, nullptr) != SQLITE_OK)
        throw Error(db.label_, db.db_ ? sqlite3_errmsg(db.db_) : "out of memory");
    sqlite3_busy_timeout(db.db_, static_cast<int>(kBusyTimeout.count()));
    return db;
}

Connection::~Connection()
{
    if (db_) sqlite3_close(db_);
}

Connection::Connection(Connection&& other) noexcept
    : db_(std::exchange(other.db_, nullptr)), label_(std::move(other.label_))
{
}

Connection& Connection::operator=(Connection&& other) noexcept
{
    if (this != &other) {
        if (db_) sqlite3_close(db_);
        db_ = std::exchange(other.db_, nullptr);
        label_ = std::move(other.label_);
    }
    return *this;
}

void Connection::exec(const std::string& sql) const
{
    char* message = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
        std::string why = message ? message : sqlite3_errmsg(db_);
        sqlite3_free(message);
        throw Error(label_, std::move(why));
    }
}

Statement Connection::prepare(const std::string& sql) const
{
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK) fail();
    return Statement(*this, stmt);
}

std::int64_t Connection::lastInsertRowId() const
{
    return sqlite3_last_insert_rowid(db_);
}

void Connection::fail() const
{
    throw Error(label_, db_ ? sqlite3_errmsg(db_) : "not open");
}

Statement::~Statement()
{
    sqlite3_finalize(stmt_);
}

Statement::Statement(Statement&& other) noexcept : db_(other.db_), stmt_(std::exchange(other.stmt_, nullptr))
{
}

Statement& Statement::bind(int index, std::int64_t value)
{
    sqlite3_bind_int64(stmt_, index, value);
    return *this;
}

Statement& Statement::bindReal(int index, double value)
{
    sqlite3_bind_double(stmt_, index, value);
    return *this;
}

Statement& Statement::bind(int index, const std::string& text)
{
    sqlite3_bind_text(stmt_, index, text.c_str(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
    return *this;
}

Statement& Statement::bindNull(int index)
{
    sqlite3_bind_null(stmt_, index);
    return *this;
}

bool Statement::step()
{
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc != SQLITE_DONE) db_->fail();
    return false;
}

void Statement::reset()
{
    // The error of a failed step was thrown by step(); reset() repeats it, nothing new.
    sqlite3_reset(stmt_);
}

int Statement::integer(int column) const
{
    return sqlite3_column_int(stmt_, column);
}

std::int64_t Statement::int64(int column) const
{
    return sqlite3_column_int64(stmt_, column);
}

double Statement::real(int column) const
{
    return sqlite3_column_double(stmt_, column);
}

std::string Statement::text(int column) const
{
    const auto* p = sqlite3_column_text(stmt_, column);
    return p ? reinterpret_cast<const char*>(p) : "";
}

bool Statement::isNull(int column) const
{
    return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

Transaction::Transaction(const Connection& db) : db_(db)
{
    db_.exec("BEGIN IMMEDIATE");
}

Transaction::~Transaction()
{
    // Unwinding from a failed statement: nothing of the transaction stays.
    if (open_) sqlite3_exec(db_.db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::commit()
{
    db_.exec("COMMIT");
    open_ = false;
}

} // namespace hg::store::sqlite
