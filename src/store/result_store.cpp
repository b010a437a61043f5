#include "hullgauge/store/result_store.h"

#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"
#include "result_rows.h"
#include "schema.h"

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

namespace hg::store {

std::string newCycleId()
{
    // A random (version 4) UUID: unique across stations and across a store that was replaced,
    // so the plant's receiver can drop the duplicates of a redelivery by it (docs/mqtt.md).
    // std::random_device reads the kernel's random source (getrandom) on Linux.
    std::random_device random;
    std::array<std::uint8_t, 16> b{};
    for (std::size_t i = 0; i < b.size(); i += 4) {
        const auto r = random();
        for (std::size_t k = 0; k < 4; ++k) b[i + k] = static_cast<std::uint8_t>(r >> (8 * k));
    }
    b[6] = static_cast<std::uint8_t>((b[6] & 0x0F) | 0x40);
    b[8] = static_cast<std::uint8_t>((b[8] & 0x3F) | 0x80);
    std::string id;
    static constexpr char kHex[] = "0123456789abcdef";
    for (std::size_t i = 0; i < b.size(); ++i) {
        if (i == 4 || i == 6 || i == 8 || i == 10) id += '-';
        id += kHex[b[i] >> 4];
        id += kHex[b[i] & 0x0F];
    }
    return id;
}

ResultStore::ResultStore(const std::filesystem::path& file) : file_(file)
{
    std::error_code ec;
    if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
    db_ = sqlite::open(file, sqlite::Access::Create, "result store " + file.string());
    db_.exec("PRAGMA journal_mode=WAL");
    db_.exec("PRAGMA synchronous=FULL");
    createOrMigrate(db_);
    hg::log::category("store")->info("result store {} ({} records)", file.string(), count());
}

namespace {

/// A figure as the table `health` keeps it: NULL where it was not measured (NaN).
void bindFigure(sqlite::Statement& s, int index, double value)
{
    if (std::isfinite(value))
        s.bindReal(index, value);
    else
        s.bindNull(index);
}

/// The cycle's health row (docs/health.md, "In the daemon"), beside its inspection `id`.
void insertHealth(const sqlite::Connection& db, std::int64_t id, std::int64_t unixMs,
                  const station::HealthRecord& health)
{
    auto insert = db.prepare("INSERT INTO health (inspection_id, unix_ms, backlight, uniformity, dust_specks, "
                             "edge_width_px, contrast, noise, predicted_sigma_px, edge_bias_px, capability, warnings) "
                             "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    insert.bind(1, id).bind(2, unixMs);
    const auto& f = health.figures;
    int index = 3;
    for (const double v : {f.backlight, f.uniformity, f.dustSpecks, f.edgeWidthPx, f.contrast, f.noise,
                           f.predictedSigmaPx, f.edgeBiasPx, f.capability})
        bindFigure(insert, index++, v);
    nlohmann::json warnings = nlohmann::json::array();
    for (const auto w : health.warnings) warnings.push_back(std::string(enumName(w)));
    insert.bind(12, dumpJson(warnings));
    insert.step();
}

} // namespace

std::int64_t ResultStore::commit(const station::InspectionRecord& r, const std::string& imagesDir)
{
    // The health row goes in the inspection's transaction: one fsync, both or neither.
    std::optional<sqlite::Transaction> transaction;
    if (r.health) transaction.emplace(db_);
    auto insert =
        db_.prepare("INSERT INTO inspections (started_utc, started_unix_ms, trigger_seq, manual, serial, "
                    "program, part, verdict, fault_code, cycle_ms, landmarks_failed, landmarks_total, "
                    "landmarks_json, timing_json, images_dir, alignment_json, simulation_json, purpose, cycle_id, "
                    "program_version, program_sha256, correction_id, temperature_c) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    insert.bind(1, formatUtc(r.startedUnixMs))
        .bind(2, r.startedUnixMs)
        .bind(3, r.triggerSeq)
        .bind(4, r.manual ? 1 : 0)
        .bind(5, r.serial)
        .bind(6, r.program)
        .bind(7, r.part)
        .bind(8, std::string(enumName(r.verdict)))
        .bind(9, static_cast<int>(r.faultCode))
        .bind(10, r.cycleMs)
        .bind(11, static_cast<std::int64_t>(r.landmarksFailed()))
        .bind(12, static_cast<std::int64_t>(r.landmarks.size()))
        .bind(13, dumpJson(r.landmarksJson()))
        .bind(14, dumpJson(station::toJson(r.timings)))
        .bind(15, imagesDir)
        .bind(16, dumpJson(r.alignment))
        .bind(17, dumpJson(r.simulation))
        .bind(18, std::string(enumName(r.purpose)))
        .bind(19, r.cycleId.empty() ? newCycleId() : r.cycleId);
    // The program's release: NULL and '' for a draft (docs/daemon.md, "Result store").
    if (r.programRelease)
        insert.bind(20, r.programRelease->version);
    else
        insert.bindNull(20);
    insert.bind(21, r.programRelease ? r.programRelease->verificationSha256 : std::string());
    insert.bind(22, r.correctionId);
    if (r.temperatureC)
        insert.bindReal(23, *r.temperatureC);
    else
        insert.bindNull(23);
    // Alone, the INSERT in autocommit mode is its own transaction: durable when step() returns;
    // with the health row, durable when the transaction's commit returns.
    insert.step();
    const std::int64_t id = db_.lastInsertRowId();
    if (transaction) {
        insertHealth(db_, id, r.startedUnixMs, *r.health);
        transaction->commit();
    }
    return id;
}

nlohmann::json ResultStore::recent(int limit) const
{
    ResultQuery query;
    query.limit = limit;
    return selectResults(db_, file_.string(), query);
}

std::int64_t ResultStore::count() const
{
    auto query = db_.prepare("SELECT COUNT(*) FROM inspections");
    return query.step() ? query.int64(0) : 0;
}

std::int64_t ResultStore::productionJudged(int program, const std::string& correctionId,
                                           std::optional<std::int64_t> sinceMs) const
{
    // On the index inspections_correction (schema.cpp): the set's rows only, never the whole store.
    auto query = db_.prepare("SELECT COUNT(*) FROM inspections WHERE correction_id = ? AND program = ? AND "
                             "purpose = 'production' AND verdict IN ('pass', 'fail') AND started_unix_ms >= ?");
    query.bind(1, correctionId)
        .bind(2, static_cast<std::int64_t>(program))
        .bind(3, sinceMs.value_or(std::numeric_limits<std::int64_t>::min()));
    return query.step() ? query.int64(0) : 0;
}

} // namespace hg::store
