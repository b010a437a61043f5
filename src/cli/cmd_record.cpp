// hullgauge record ID --out FILE.pdf [--results DB] [--images DIR] [--station NAME]:
// the part record of one stored result as the PDF the web HMI offers
// (docs/hmi.md, "Part record"), read from the result store read-only and the
// part's archive folder. The file is replaced whole or not at all: the PDF is
// made in memory before anything is written.
#include "command.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/report/record_pdf.h"
#include "hullgauge/store/result_reader.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <unistd.h>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

struct RecordOptions {
    std::int64_t id = 0;
    std::string out;
    // The installed station's (config/installed/*/hullgauged.yaml, `results`).
    std::string results = "/var/lib/hullgauge/results.db";
    std::string images = "/var/lib/hullgauge/images";
    std::string station;
};

/// The part's archive folder: where the row says when it lies inside `root`,
/// else the folder of that name in `root` (a store and archive copied off the
/// station together). Empty when the part was not archived or is gone.
fs::path archiveFolder(const nlohmann::json& row, const fs::path& root)
{
    const auto stored = row.value("images", std::string());
    if (stored.empty()) return {};
    std::error_code ec;
    const auto folder = fs::weakly_canonical(stored, ec);
    const auto rel = folder.lexically_relative(fs::weakly_canonical(root, ec));
    if (!ec && !rel.empty() && *rel.begin() != ".." && fs::is_directory(folder, ec)) return folder;
    const auto moved = root / fs::path(stored).filename();
    return fs::is_directory(moved, ec) ? moved : fs::path();
}

/// The annotated views of the folder (view_<k>.png) in the order of k, as the web HMI lists them.
std::vector<report::RecordView> viewsIn(const fs::path& folder)
{
    std::vector<report::RecordView> views;
    if (folder.empty()) return views;
    static const std::regex kView(R"(view_[0-9]{1,3}\.png)");
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
        const auto name = entry.path().filename().string();
        if (!entry.is_regular_file() || !std::regex_match(name, kView)) continue;
        std::ifstream in(entry.path(), std::ios::binary);
        std::ostringstream bytes;
        if (!in || !(bytes << in.rdbuf())) throw FaultError("cannot read " + entry.path().string());
        const auto text = bytes.str();
        views.push_back({name, std::vector<unsigned char>(text.begin(), text.end())});
    }
    std::sort(views.begin(), views.end(), [](const report::RecordView& a, const report::RecordView& b) {
        return a.name.size() != b.name.size() ? a.name.size() < b.name.size() : a.name < b.name;
    });
    return views;
}

/// The station's name in the running header: --station, else the machine's host name.
std::string stationName(const std::string& given)
{
    if (!given.empty()) return given;
    char host[256] = {};
    return ::gethostname(host, sizeof host - 1) == 0 ? std::string(host) : std::string();
}

int run(const RecordOptions& o)
{
    const auto folder = fs::path(o.out).parent_path();
    std::error_code ec;
    if (!folder.empty() && !fs::is_directory(folder, ec))
        throw InputError("", "--out", "no folder " + folder.string() + " to write " + o.out + " in");
    const store::ResultReader reader(o.results);
    const auto row = reader.byId(o.id);
    if (!row) throw InputError(o.results, "ID", "no result " + std::to_string(o.id) + " in the result store");
    const auto views = viewsIn(archiveFolder(*row, o.images));
    report::RecordOptions options;
    options.station = stationName(o.station);
    options.generatedUnixMs =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count();
    std::ostringstream pdf;
    try {
        report::writeRecordPdf(pdf, *row, views, options);
    } catch (const InputError& e) {
        // A damaged row or view of the store: name the store with what was wrong.
        throw InputError(e.file().empty() ? o.results : e.file(), e.field(), e.problem());
    }
    replaceFileDurably(o.out, pdf.str());
    hg::log::category("store")->info("record: result {} ({} views) to {}", o.id, views.size(), o.out);
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<RecordOptions>();
    auto* sub = app.add_subcommand("record", "the part record of one stored result as an A4 PDF: verdict, program "
                                             "release, every landmark and the annotated views (docs/hmi.md)");
    sub->add_option("ID", o->id, "the result's id (the web HMI's /result?id=ID)")
        ->required()
        ->check(CLI::PositiveNumber);
    sub->add_option("--out", o->out, "the PDF to write (replaced whole, or left as it was on any error)")->required();
    sub->add_option("--results", o->results, "the result store (SQLite, read read-only)")->capture_default_str();
    sub->add_option("--images", o->images, "the image archive holding the part's folder")->capture_default_str();
    sub->add_option("--station", o->station, "the station's name in the record's header (default: the host name)");
    return [=]() { return run(*o); };
}

} // namespace

HG_REGISTER_COMMAND("record", factory);

} // namespace hg::cli
