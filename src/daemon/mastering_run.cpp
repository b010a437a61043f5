#include "mastering_run.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/master_cycles.h"

#include <fstream>
#include <spdlog/fmt/fmt.h>
#include <sstream>

namespace hg::daemon {

using nlohmann::json;
using namespace std::chrono_literals;

namespace {

std::string fileText(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) return {};
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

std::filesystem::path setFile(const station::DaemonConfig& config, std::uint16_t program)
{
    return config.mastering.folder / ("program-" + std::to_string(program) + ".json");
}

} // namespace

std::string triggerRefusal(station::RejectReason reason)
{
    using enum station::RejectReason;
    switch (reason) {
    case None:
        return {};
    case Busy:
        return "busy";
    case UnknownProgram:
        return "unknown part program";
    case NotReady:
        return "not ready (fault or starting)";
    case MasteringDue:
        return "re-mastering is due and its grace is used up: run the master (purpose master), then reload its "
               "correction set";
    }
    return "refused";
}

json correctionSummary(const inspect::CorrectionSet& set, const std::string& file)
{
    const json landmarks = store::landmarkSummary(set);
    return {{"id", set.id}, {"file", file}, {"method", enumName(set.method())}, {"landmarks", landmarks}};
}

MasteringRun::MasteringRun(MasteringStation station, Clock& clock) : station_(std::move(station)), clock_(clock)
{
}

MasteringRun::~MasteringRun()
{
    cancel("the daemon stopping");
    worker_.stop();
}

Status MasteringRun::start(MasteringRequest request)
{
    if (running_.load()) {
        const json s = status();
        return Status::failure(StatusCode::NotAllowed,
                               fmt::format("a mastering run is already running (master cycle {} of {} of program {})",
                                           s.value("cycle", 0), s.value("cycles", 0), s.value("program", 0)));
    }
    const auto config = station_.config();
    if (config->mastering.folder.empty())
        return Status::failure(StatusCode::NotAllowed,
                               "the daemon has no mastering.folder to keep the set in (docs/mastering.md, \"In the "
                               "daemon\")");
    if (!config->programs.contains(request.program))
        return Status::failure(StatusCode::NotAllowed,
                               "program: " + std::to_string(request.program) + " is not a configured part program");
    worker_.stop(); // the last run's thread, ended
    const auto purpose = std::string(enumName(station_.purpose()));
    {
        std::lock_guard lock(mutex_);
        cancelledBy_.clear();
        status_ = {{"state", "running"},
                   {"step", "cycles"},
                   {"program", request.program},
                   {"master", request.master.serial},
                   {"certificate", request.master.certificate},
                   {"cycles", request.cycles},
                   {"cycle", 0},
                   {"results", json::array()},
                   {"progress", json::array()},
                   {"purpose_before", purpose},
                   {"previous_set", config->programs.at(request.program).correctionId},
                   {"by", request.who},
                   {"started", store::formatUtc(clock_.wallMs())}};
    }
    cancel_ = false;
    running_ = true;
    worker_.start([this, request = std::move(request)](std::stop_token stop) { run(stop, request); });
    return Status::success();
}

bool MasteringRun::cancel(const std::string& by)
{
    if (!running_.load()) return false;
    {
        std::lock_guard lock(mutex_);
        cancelledBy_ = by;
    }
    cancel_ = true;
    return true;
}

bool MasteringRun::running() const
{
    return running_.load();
}

json MasteringRun::status() const
{
    std::lock_guard lock(mutex_);
    return status_;
}

void MasteringRun::update(const json& fields)
{
    std::lock_guard lock(mutex_);
    status_.update(fields);
}

// The run: the cycles (the purpose put back whatever happens), the set from
// exactly them in the mastering folder, the reload that puts it in force; the
// end recorded in the audit trail with the set before and after.
void MasteringRun::run(std::stop_token stop, const MasteringRequest& request)
{
    const auto config = station_.config();
    const auto file = setFile(*config, request.program);
    const std::string before = fileText(file);
    std::string error;
    try {
        const auto ids = runCycles(stop, request, *config);
        update({{"step", "computing"}});
        const auto set = computeSet(request, *config, ids);
        inspect::saveCorrectionSet(set, file);
        update({{"step", "reloading"}, {"set", correctionSummary(set, file.string())}});
        station_.reload();
        awaitInForce(stop, request, set);
        hg::log::category("study")->info("mastering of program {}: set {} in force", request.program, set.id);
        update({{"state", "done"}, {"step", "in force"}});
    } catch (const std::exception& e) {
        error = e.what();
        hg::log::category("study")->error("mastering of program {}: {}", request.program, error);
        update({{"state", "failed"}, {"error", error}});
    }
    recordEnd(request, file, before, error);
    running_ = false;
}

std::set<std::int64_t> MasteringRun::runCycles(std::stop_token stop, const MasteringRequest& request,
                                               const station::DaemonConfig& config)
{
    const store::ResultReader store(config.results.database);
    store::ResultQuery newest;
    newest.limit = 1;
    const auto last = store.select(newest);
    std::int64_t afterId = last.empty() ? 0 : last[0]["id"].get<std::int64_t>();
    const auto before = station_.purpose();
    std::set<std::int64_t> ids;
    station_.setPurpose(station::CyclePurpose::Master);
    try {
        for (std::size_t k = 1; k <= request.cycles; ++k) {
            afterId = runCycle(stop, request, config, k, afterId);
            ids.insert(afterId);
        }
    } catch (...) {
        station_.setPurpose(before);
        throw;
    }
    station_.setPurpose(before);
    return ids;
}

// One master cycle: the trigger (a station busy with another cycle is asked
// again until the timeout, any other refusal ends the run), then its stored
// row — the next manual row of purpose master with the master's serial.
std::int64_t MasteringRun::runCycle(std::stop_token stop, const MasteringRequest& request,
                                    const station::DaemonConfig& config, std::size_t k, std::int64_t afterId)
{
    const auto& serial = request.master.serial;
    update({{"cycle", k}});
    waitFor(stop, request, "the station to take the master's trigger", [&] {
        const auto reason = station_.trigger(request.program, serial);
        if (reason == station::RejectReason::None) return true;
        if (reason != station::RejectReason::Busy) throw FaultError("trigger refused: " + triggerRefusal(reason));
        return false;
    });
    const store::ResultReader store(config.results.database);
    store::ResultQuery q;
    q.program = request.program;
    q.serial = serial;
    q.purpose = "master";
    q.manual = true;
    q.afterId = afterId;
    q.newestFirst = false;
    q.limit = 1;
    json row;
    waitFor(stop, request, fmt::format("the result of master cycle {} of {}", k, request.cycles), [&] {
        auto rows = store.select(q);
        if (rows.empty()) return false;
        row = std::move(rows[0]);
        return true;
    });
    const auto id = row["id"].get<std::int64_t>();
    const auto verdict = row["verdict"].get<std::string>();
    const auto line = fmt::format("master cycle {} of {}: {} (result {})", k, request.cycles, verdict, id);
    {
        std::lock_guard lock(mutex_);
        status_["results"].push_back(id);
        status_["progress"].push_back(line);
    }
    if (verdict != "pass" && verdict != "fail")
        throw FaultError(fmt::format("master cycle {} of {} (result {}) ended {} with fault code {}: run the master "
                                     "again once the station is ready",
                                     k, request.cycles, id, verdict, row.value("fault_code", 0)));
    return id;
}

// The set from exactly the run's rows, for the material asked for or the one the program names.
inspect::CorrectionSet MasteringRun::computeSet(const MasteringRequest& request, const station::DaemonConfig& config,
                                                const std::set<std::int64_t>& ids)
{
    std::string material;
    if (request.material) {
        material = *request.material;
    } else {
        const auto loaded = station_.material(request.program);
        if (!loaded)
            throw FaultError("the material of program " + std::to_string(request.program) +
                             " is not known (the program is not the one loaded): give the material");
        material = *loaded;
    }
    store::MasterCycleSelection selection;
    selection.program = request.program;
    selection.only = ids;
    selection.minCycles = request.cycles;
    selection.minCyclesOption = "the run's cycles";
    return store::masterCorrectionSet(store::ResultReader(config.results.database), {request.master}, selection,
                                      material, clock_.wallMs());
}

// In force once a reloaded configuration names it (a refused reload keeps the running one: its journal says why).
void MasteringRun::awaitInForce(std::stop_token stop, const MasteringRequest& request,
                                const inspect::CorrectionSet& set)
{
    waitFor(stop, request, "the daemon to take correction set " + set.id + " (a refused reload is in its journal)",
            [&] {
                const auto config = station_.config();
                const auto it = config->programs.find(request.program);
                return it != config->programs.end() && it->second.correctionId == set.id;
            });
}

// Polls `done` every 100 ms on the clock until it holds; the request's
// timeout, a cancel and the daemon stopping end the wait as a failure naming `what`.
void MasteringRun::waitFor(std::stop_token stop, const MasteringRequest& request, const std::string& what,
                           const std::function<bool()>& done)
{
    const auto deadline = clock_.now() + std::chrono::duration_cast<Clock::duration>(request.timeout);
    const auto stopped = [&] { return cancel_.load() || stop.stop_requested(); };
    while (!done()) {
        if (stopped()) {
            std::lock_guard lock(mutex_);
            throw FaultError("cancelled by " + (cancelledBy_.empty() ? std::string("the daemon") : cancelledBy_) +
                             " waiting for " + what);
        }
        if (clock_.now() >= deadline)
            throw FaultError(fmt::format("{} not within {} s (timeout_s)", what,
                                         formatNumber(std::chrono::duration<double>(request.timeout).count(), 0)));
        clock_.sleepUntil(std::min(clock_.now() + Clock::duration(100ms), deadline), stopped);
    }
}

// The run's end in the audit trail (docs/audit.md, `mastering.set`): the program's set file as it was
// before the run and as it is after it (unchanged when the run ended before the set was written).
void MasteringRun::recordEnd(const MasteringRequest& request, const std::filesystem::path& file,
                             const std::string& before, const std::string& error)
{
    if (!station_.audit) return;
    store::AuditEntry entry;
    entry.who = request.who;
    entry.role = request.role;
    entry.source = request.source;
    entry.action = "mastering.set";
    entry.object = file.string();
    entry.outcome = error.empty() ? "done" : "failed";
    const json s = status();
    entry.detail =
        fmt::format("{} master cycles of {} (results {}){}", s.value("results", json::array()).size(),
                    request.master.serial, s.value("results", json::array()).dump(), error.empty() ? "" : ": " + error);
    entry.before = before;
    entry.after = fileText(file);
    station_.audit(std::move(entry));
}

} // namespace hg::daemon
