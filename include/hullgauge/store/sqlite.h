// The one SQLite wrapper of the result store (docs/daemon.md, "Result store"):
// a connection and a prepared statement that release themselves, the binds,
// steps and column reads the store's queries use, and the one function that
// opens a database, with the flags and busy timeout of each of its users — the
// daemon's writer, the plant link's outbox (docs/mqtt.md, "Outbox") and the
// read-only readers of the tool and the web HMI (docs/export.md, docs/hmi.md).
// Every failure is an sqlite::Error naming the database.
#pragma once

#include "hullgauge/common/error.h"

#include <cstdint>
#include <filesystem>
#include <string>

struct sqlite3;
struct sqlite3_stmt;

namespace hg::store::sqlite {

/// What SQLite refused: a FaultError "<label>: <reason>", with SQLite's reason alone for callers that
/// report it otherwise (a reader's file is the user's input, docs/export.md).
class Error : public FaultError {
  public:
    Error(const std::string& label, std::string reason);
    const std::string& reason() const noexcept { return reason_; }

  private:
    std::string reason_;
};

/// How a connection uses the database; each opens with its own flags.
enum class Access {
    /// Read-write, the file created when missing; serialized (SQLITE_OPEN_FULLMUTEX), so one
    /// connection serves every thread of the daemon (the cycle's commit, `ctl status`, `ctl results`).
    Create,
    /// Read-write on a database that exists, for one thread (the plant link's publisher).
    Write,
    /// Read-only (URI mode=ro): never writes, not even a migration, so it runs beside the daemon.
    Read,
};

class Statement;

/// An open database, closed when the connection goes. Move-only.
class Connection {
  public:
    Connection() = default;
    ~Connection();
    Connection(Connection&& other) noexcept;
    Connection& operator=(Connection&& other) noexcept;
    Connection(const Connection&) = delete;
    Connection& operator=(const Connection&) = delete;

    /// Runs SQL text that returns no rows (the schema, pragmas); throws Error.
    void exec(const std::string& sql) const;
    /// Prepares one statement; throws Error.
    Statement prepare(const std::string& sql) const;
    /// The row id of this connection's last INSERT.
    std::int64_t lastInsertRowId() const;
    /// Names the database in every error: "result store <file>".
    const std::string& label() const { return label_; }
    /// Throws Error with SQLite's message for this connection's last failure.
    [[noreturn]] void fail() const;

  private:
    friend Connection open(const std::filesystem::path& file, Access access, std::string label);
    friend class Statement;
    friend class Transaction;
    sqlite3* db_ = nullptr;
    std::string label_;
};

/// Opens `file` for `access`, waiting up to 2 s for a lock another connection holds (the daemon's
/// commit, a reader, the sqlite3 program: each holds it for one short statement). Throws Error.
Connection open(const std::filesystem::path& file, Access access, std::string label);

/// A prepared statement of one connection, finalized when it goes. Parameters count from 1,
/// columns from 0, as in SQLite. Move-only; not to outlive its connection.
class Statement {
  public:
    ~Statement();
    Statement(Statement&& other) noexcept;
    Statement& operator=(Statement&& other) = delete;
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;

    Statement& bind(int index, std::int64_t value);
    Statement& bind(int index, const std::string& text);
    Statement& bindNull(int index);
    Statement& bindReal(int index, double value);
    /// The next row: true while there is one, false when the statement is done; throws Error.
    bool step();
    /// Back to before the first step, the bindings kept, for the next run with new ones.
    void reset();

    int integer(int column) const;
    std::int64_t int64(int column) const;
    double real(int column) const;
    /// The column's text; "" for NULL.
    std::string text(int column) const;
    bool isNull(int column) const;

  private:
    friend class Connection;
    Statement(const Connection& db, sqlite3_stmt* stmt) : db_(&db), stmt_(stmt) {}
    const Connection* db_;
    sqlite3_stmt* stmt_;
};

/// BEGIN IMMEDIATE at construction; rolled back unless commit() was reached.
class Transaction {
  public:
    explicit Transaction(const Connection& db);
    ~Transaction();
    Transaction(const Transaction&) = delete;
    Transaction& operator=(const Transaction&) = delete;
    void commit();

  private:
    const Connection& db_;
    bool open_ = true;
};

} // namespace hg::store::sqlite
