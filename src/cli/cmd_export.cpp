// hullgauge export --store DB --format aqdef|csv|json --out FILE [...]: the
// quality-data export of the result store (docs/export.md), read read-only,
// oldest cycle first. The file is replaced whole or not at all: every input is
// checked and the export formatted in memory before anything is written.
#include "command.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/export.h"
#include "hullgauge/store/result_reader.h"

#include <filesystem>
#include <memory>
#include <sstream>

namespace hg::cli {
namespace {

struct ExportOptions {
    std::string store;
    std::string format;
    store::SelectionFilters filters; ///< the web HMI's download filters (docs/hmi.md), same names and refusals
    store::ExportSettings settings;
    std::string out;
};

store::ExportFormat formatOf(const std::string& text)
{
    try {
        return store::parseExportFormat(text);
    } catch (const InputError& e) {
        throw InputError("", "--format", e.problem());
    }
}

/// The cycles the export takes, oldest first (docs/export.md, "Selection").
store::ResultQuery queryOf(const ExportOptions& o)
{
    auto q = store::parseSelection(o.filters, "--");
    q.newestFirst = false;
    return q;
}

int run(const ExportOptions& o)
{
    const auto format = formatOf(o.format);
    const auto query = queryOf(o);
    const auto folder = std::filesystem::path(o.out).parent_path();
    std::error_code ec;
    if (!folder.empty() && !std::filesystem::is_directory(folder, ec))
        throw InputError("", "--out", "no folder " + folder.string() + " to write " + o.out + " in");
    const store::ResultReader reader(o.store);
    const auto rows = reader.select(query);
    std::ostringstream text;
    store::writeExport(text, format, rows, o.settings);
    replaceFileDurably(o.out, text.str());
    hg::log::category("store")->info("export: {} cycles of {} as {} to {}", rows.size(), o.store, enumName(format),
                                     o.out);
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<ExportOptions>();
    auto* sub = app.add_subcommand("export", "quality-data export of the result store: AQDEF (Q-DAS .dfq), CSV or "
                                             "JSON, oldest cycle first (docs/export.md)");
    sub->add_option("--store", o->store, "the result store (SQLite, read read-only)")->required();
    sub->add_option("--format", o->format, "aqdef, csv or json")->required();
    sub->add_option("--out", o->out, "the file to write (replaced whole, or left as it was on any error)")->required();
    // The filters as text, checked by the parser the HMI's download uses (store::parseSelection).
    const auto filter = [&](const char* name, std::optional<std::string>& field, const char* help) {
        sub->add_option_function<std::string>(
            name, [&field](const std::string& v) { field = v; }, help);
    };
    auto& f = o->filters;
    filter("--program", f.program, "only the cycles of this part program 1..65535 (default: every program)");
    filter("--serial", f.serial, "only cycles whose serial contains this text (at most 64 characters)");
    filter("--verdict", f.verdict, "only cycles that ended pass, fail, aborted or error (default: any)");
    filter("--purpose", f.purpose, "only cycles tagged production, master or study (default: any)");
    filter("--since", f.since, "only cycles started at or after this UTC time (YYYY-MM-DD[THH:MM[:SS]])");
    filter("--until", f.until, "only cycles started before this UTC time");
    sub->add_flag("--include-simulated", o->settings.includeSimulated,
                  "count the simulated line's cycles as measurements (marked in the file; default: excluded)");
    return [=]() { return run(*o); };
}

} // namespace

HG_REGISTER_COMMAND("export", factory);

} // namespace hg::cli
