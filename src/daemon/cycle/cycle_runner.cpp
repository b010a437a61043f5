#include "cycle/cycle_runner.h"

#include "cycle/image_archive.h"
#include "hullgauge/align/alignment.h"
#include "hullgauge/align/pose_correction.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/common/log.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/station/cycle_rules.h"
#include "hullgauge/store/result_reader.h"

#include <cmath>

namespace hg::daemon {
namespace {

using station::SequencerAction;
using station::SequencerEvent;
using station::SequencerState;
using Kind = SequencerAction::Kind;

std::int64_t ns(std::chrono::milliseconds d)
{
    return std::chrono::nanoseconds(d).count();
}

/// A program's release as the status shows it with a cycle (docs/daemon.md): null for a draft.
void putRelease(nlohmann::json& j, const std::optional<station::ProgramRelease>& release)
{
    j["program_version"] = release ? nlohmann::json(release->version) : nlohmann::json();
    j["program_sha256"] = release ? nlohmann::json(release->verificationSha256) : nlohmann::json();
}

/// The station's calibration as re-mastering due compares it (docs/mastering.md,
/// "Re-mastering due"): every calibration writes its date into the station file
/// (docs/calibration.md), so a new date is a new calibration.
std::string calibrationIdentity(const station::DaemonConfig& cfg)
{
    std::string identity;
    for (const char* section : {"camera", "fixture"}) {
        std::string date = "none";
        if (cfg.station.document)
            if (auto s = cfg.station.document->optional(section); s && s->isMap())
                if (auto c = s->optional("calibration"); c && c->isMap())
                    if (auto d = c->optional("date")) date = d->asString();
        identity += std::string(identity.empty() ? "" : ", ") + section + " " + date;
    }
    return identity;
}

/// A cycle's health as the plant link publishes it (docs/mqtt.md, topic `health`; the station is added there).
nlohmann::json healthMessage(const station::InspectionRecord& record, const nlohmann::json& reference)
{
    const auto& health = *record.health;
    return {{"time", store::formatUtc(record.startedUnixMs)},
            {"cycle_id", record.cycleId},
            {"serial", record.serial},
            {"program", record.program},
            {"purpose", std::string(enumName(record.purpose))},
            {"figures", healthFiguresJson(health.figures)},
            {"warnings", healthWarningsJson(health.warnings)},
            {"warning_bits", vision::healthWarningBits(health.warnings)},
            {"reference", reference.is_null() ? reference
                                              : nlohmann::json{{"taken_unix_ms", reference["taken_unix_ms"]},
                                                               {"time", reference["time"]}}}};
}

/// What the station asks of the operator (docs/lamps.md): re-mastering due of the
/// active program, as MASTER_DUE tells the PLC (docs/mastering.md, "Due in the daemon"),
/// or a health figure beyond its limit, as HEALTH_WARNINGS does (docs/health.md).
station::Attention attentionOf(const std::array<std::uint16_t, station::reg::Count>& regs)
{
    const auto due = static_cast<station::MasterDue>(regs[station::reg::MasterDue]);
    return {.wanted = due != station::MasterDue::No || regs[station::reg::HealthWarnings] != 0,
            .productionRefused = due == station::MasterDue::ProductionRefused};
}

station::MasterDueState dueState(const station::MasteringDue& due)
{
    using station::MasterDue;
    if (!due.due()) return {MasterDue::No, due.graceLeft()};
    return {due.admits(station::CyclePurpose::Production) ? MasterDue::Due : MasterDue::ProductionRefused,
            due.graceLeft()};
}

} // namespace

/// One cycle's working state, from the trigger to the published record.
struct CycleRunner::Cycle {
    std::shared_ptr<const station::DaemonConfig> cfg; ///< the configuration the cycle keeps to its end
    const station::PartProgramRef* program = nullptr;
    /// The poses commanded: the plan's, those after the first seatViews() corrected for the seat they measured.
    std::vector<geometry::FixturePose> poses;
    bool posesChecked = false;      ///< the correction was decided (done, or why not)
    nlohmann::json poseCorrection;  ///< what it did, for the record (null: not tried)
    std::vector<bool> rangeLimited; ///< per view: a range of the fixture stopped its correction short
    station::InspectionRecord record;
    Clock::time_point started;
    std::optional<Clock::time_point> lastFrameAt; ///< when the last good frame was in (the latency)
    Milliseconds move{}, settle{}, grab{}, finish{}, commit{}, publish{};
    /// The camera's time applying the views' regions (within grab), and the bytes it sent.
    Milliseconds region{};
    std::size_t payloadBytes = 0;
    std::optional<Milliseconds> lastFrameToPublish; ///< none when no frame came in
    InspectionOutcome outcome;
    bool interruptFed = false; ///< the abort or the shutdown was fed to the sequencer
    bool saveImages = false;
    bool archiveFull = false; ///< images not kept for want of free space: the writer makes room
    std::string imagesDir;
};

CycleRunner::CycleRunner(PlcRegisters& registers, StationDevices& devices, Inspector& inspector,
                         store::ResultStore& store, std::shared_ptr<const station::DaemonConfig> config, Clock& clock)
    : registers_(registers), devices_(devices), inspector_(inspector), store_(store), clock_(clock),
      config_(std::move(config)), sequencer_(config_->sequencer.retries)
{
    masteringConfigured(*config_);
    healthConfigured(*config_);
}

CycleRunner::~CycleRunner()
{
    stop();
}

void CycleRunner::start(std::function<void()> onDevicesActive)
{
    onDevicesActive_ = std::move(onDevicesActive);
    lastLoopNs_ = clock_.nowNs();
    worker_.start([this](std::stop_token stop) { run(stop); });
}

void CycleRunner::stop()
{
    if (!worker_.running()) return;
    // Before the stop turns, so that the runner never sees the stop without its time.
    stopRequestedNs_ = clock_.nowNs();
    worker_.stop();
}

void CycleRunner::setConfig(std::shared_ptr<const station::DaemonConfig> config)
{
    std::lock_guard lock(mutex_);
    config_ = std::move(config);
    masteringConfigured(*config_);
    healthConfigured(*config_);
}

station::SequencerState CycleRunner::state() const
{
    std::lock_guard lock(mutex_);
    return sequencer_.state();
}

bool CycleRunner::healthy() const
{
    std::shared_ptr<const station::DaemonConfig> cfg;
    {
        std::lock_guard lock(mutex_);
        cfg = config_;
    }
    const auto now = clock_.nowNs();
    const auto cycleStart = cycleStartNs_.load();
    if (cycleStart != 0 && now - cycleStart > ns(cfg->watchdog.maxCycle)) return false;
    // A calibration step (move, settle, grab) is bounded by its timeouts.
    if (auto step = calibration_.stepStartNs(); step != 0) {
        const auto& s = cfg->sequencer;
        return now - step <= ns(s.moveTimeout + s.settle + s.grabTimeout + std::chrono::seconds(5));
    }
    // Outside a cycle the thread turns at least every 200 ms; inside one each step is bounded by its timeout.
    return cycleStart != 0 || now - lastLoopNs_.load() <= ns(std::chrono::seconds(5));
}

nlohmann::json CycleRunner::describe() const
{
    std::lock_guard lock(mutex_);
    // Between the sequencer's end of cycle and the published result (commit, PLC registers) the
    // operator sees "processing": "done" promises a result that is already stored.
    auto shown = sequencer_.state();
    if (cycleStartNs_.load() != 0 && !station::isBusy(shown)) shown = SequencerState::Processing;
    auto last = lastCycle_;
    if (lastImagesMs_ && lastImagesMs_->load() >= 0) last["timing_ms"]["images"] = lastImagesMs_->load();
    nlohmann::json j{
        {"state", std::string(enumName(shown))}, {"cycles", cycles_}, {"faults", faults_}, {"last_cycle", last}};
    j["mastering"] = masteringJson();
    if (station::isBusy(sequencer_.state())) {
        j["view"] = sequencer_.view();
        j["views"] = sequencer_.viewCount();
    }
    if (sequencer_.state() == SequencerState::Fault) {
        j["fault_code"] = static_cast<int>(sequencer_.faultCode());
        j["fault"] = station::describe(sequencer_.faultCode(), sequencer_.retries());
    }
    return j;
}

Status CycleRunner::requestCalibration(CalibrationJob job)
{
    return calibration_.request(std::move(job), state());
}

// ---- the sequencer, the commands, the lamps ---------------------------------

SequencerAction CycleRunner::transition(const std::function<SequencerAction()>& step)
{
    auto log = hg::log::category("seq");
    std::lock_guard lock(mutex_);
    const auto before = sequencer_.state();
    const auto refusedBefore = sequencer_.refusedTransition();
    auto action = step();
    if (sequencer_.state() != before) log->debug("{} -> {}", enumName(before), enumName(sequencer_.state()));
    if (auto refused = sequencer_.refusedTransition(); refused != refusedBefore)
        log->error("the sequencer refused {} -> {}: internal fault", enumName(refused.first), enumName(refused.second));
    return action;
}

SequencerAction CycleRunner::feed(SequencerEvent event)
{
    return transition([&] { return sequencer_.onEvent(event); });
}

bool CycleRunner::abort()
{
    // Checked as PlcRegisters checks the PLC's abort: one sent while idle would abort the next part.
    if (!registers_.running()) {
        hg::log::category("seq")->info("abort dropped: no cycle or calibration runs");
        return false;
    }
    abortRequested_ = true;
    return true;
}

// The one place the PLC's commands are taken: an abort acts on the running
// cycle; a fault reset waits for the station to be between cycles.
void CycleRunner::takeCommands()
{
    const auto commands = registers_.takeCommands();
    if (commands.abort) abortRequested_ = true;
    if (commands.resetFault) resetRequested_ = true;
}

void CycleRunner::schedule(const SequencerAction& action)
{
    if (action.kind == Kind::Recover) recoverAt_ = clock_.now() + action.delay;
}

void CycleRunner::showState()
{
    const auto s = state();
    showLamps(station::lampPattern(s, shownVerdict_, shownFault_, attentionOf(registers_.snapshot())));
    registers_.setStatus(station::plcStatus(s));
}

void CycleRunner::showLamps(LampPattern pattern)
{
    devices_.showLamps(pattern);
    lamps_ = pattern;
}

// Between cycles the lamps follow what the station asks for (docs/lamps.md):
// a due that the time or a reload brings, and a production trigger refused
// since the last result, which ends the showing of that part's verdict (the
// part in the nest is another one, and the operator must see why it waits).
void CycleRunner::refreshLamps()
{
    const auto regs = registers_.snapshot();
    if (regs[station::reg::RejectedTriggers] != refusalsSeen_) {
        refusalsSeen_ = regs[station::reg::RejectedTriggers];
        if (regs[station::reg::LastRejectReason] == static_cast<std::uint16_t>(station::RejectReason::MasteringDue)) {
            shownVerdict_ = station::Verdict::Error;
            shownFault_ = station::FaultCode::None;
        }
    }
    const auto pattern = station::lampPattern(state(), shownVerdict_, shownFault_, attentionOf(regs));
    if (pattern != lamps_) showLamps(pattern);
}

// ---- between cycles ---------------------------------------------------------

void CycleRunner::run(std::stop_token stop)
{
    stop_ = stop;
    watchHealth();
    startDevices();
    while (!stop_.stop_requested()) serveBetweenCycles();
    showLamps(LampPattern::Off);
    devices_.shutdown();
    hg::log::category("seq")->info("devices shut down");
}

void CycleRunner::startDevices()
{
    auto log = hg::log::category("seq");
    auto started = devices_.start();
    if (!started.ok()) {
        log->error("devices failed to start: {}", started.message());
        schedule(feed(SequencerEvent::DevicesFailed));
        showState();
        return;
    }
    feed(SequencerEvent::DevicesActive);
    showState();
    log->info("devices active; ready");
    if (auto ready = std::exchange(onDevicesActive_, nullptr)) ready();
}

void CycleRunner::serveBetweenCycles()
{
    lastLoopNs_ = clock_.nowNs();
    takeCommands();
    {
        // The age runs on between events: looked at every turn (at least every 200 ms).
        std::lock_guard lock(mutex_);
        if (!mastering_.empty()) signalMastering();
    }
    refreshLamps();
    // An abort outside a cycle has nothing to abort (a queued calibration clears it when it starts).
    if (!calibration_.queued()) abortRequested_ = false;
    auto recoverIfDue = [this] {
        if (!recoverAt_ || clock_.now() < *recoverAt_) return;
        recoverAt_.reset();
        recover();
    };
    recoverIfDue();
    // A fault reset (also one written during the cycle that just ended) retries at once.
    if (std::exchange(resetRequested_, false)) {
        schedule(feed(SequencerEvent::FaultReset));
        recoverIfDue();
    }
    const bool maintenanceQueued = calibration_.queued() || snapshot_.queued() || flatField_.queued();
    auto wait = std::chrono::milliseconds(maintenanceQueued ? 0 : 200);
    if (recoverAt_)
        wait = std::clamp(std::chrono::duration_cast<std::chrono::milliseconds>(*recoverAt_ - clock_.now()),
                          std::chrono::milliseconds(0), wait);
    // Triggers first: a queued calibration or snapshot starts only when none is
    // pending, and a changeover written meanwhile is prepared after the cycle (docs/plc.md).
    if (auto trigger = registers_.waitTrigger(wait)) return runCycle(*trigger);
    if (auto program = registers_.takeChangeover()) return prepareProgram(*program);
    if (!maintenanceQueued) return;
    if (auto shot = snapshot_.take()) {
        if (state() == SequencerState::Fault)
            return snapshot_.refuse("the station went into fault before the snapshot was grabbed");
        return runSnapshot(std::move(*shot));
    }
    if (auto job = flatField_.take()) {
        if (state() == SequencerState::Fault)
            return flatField_.refuse("the station went into fault before the frames were grabbed");
        return runFlatField(*job);
    }
    auto job = calibration_.take();
    if (!job) return;
    if (state() == SequencerState::Fault)
        return calibration_.refuse("the station went into fault before the calibration started");
    runCalibration(std::move(*job));
}

// The recipe changeover (docs/plc.md): between cycles, so it never delays or
// disturbs one; a trigger accepted meanwhile starts when the program is loaded.
void CycleRunner::prepareProgram(std::uint16_t number)
{
    std::shared_ptr<const station::DaemonConfig> cfg;
    {
        std::lock_guard lock(mutex_);
        cfg = config_;
    }
    auto log = hg::log::category("seq");
    const auto it = cfg->programs.find(number);
    std::string error;
    station::ProgramState state = station::ProgramState::Ready;
    if (it == cfg->programs.end()) {
        // Between a reload's new configuration and its program list: the list's recheck follows.
        state = station::ProgramState::UnknownProgram;
        error = "not configured";
    } else if (const Status loaded = inspector_.prepare(it->second); !loaded.ok()) {
        state = station::ProgramState::LoadFailed;
        error = loaded.message();
    }
    registers_.programPrepared(number, state);
    if (state == station::ProgramState::Ready) {
        noteLoaded(it->second);
        log->info("part program {} ready", number);
    } else {
        log->error("part program {}: {}: {}", number, enumName(state),
                   error.empty() ? "the part program could not be loaded" : error);
    }
}

// What `ctl status` shows of the program the inspection serves (docs/daemon.md).
void CycleRunner::noteLoaded(const station::PartProgramRef& ref)
{
    const auto info = inspector_.loaded(ref.number);
    nlohmann::json program = nullptr;
    if (info) {
        program = {{"number", info->number}, {"part", info->part}, {"material", info->material}};
        program["version"] = info->release ? nlohmann::json(info->release->version) : nlohmann::json();
        program["verification_sha256"] =
            info->release ? nlohmann::json(info->release->verificationSha256) : nlohmann::json();
    }
    std::lock_guard lock(mutex_);
    program_ = std::move(program);
    if (info) masteringLoaded(ref, info->release ? std::optional<int>(info->release->version) : std::nullopt);
}

// ---- re-mastering due (docs/mastering.md, "Re-mastering due") -----------------
// Under mutex_: the configuration (reload), the program loads and the judged
// cycles feed one MasteringDue per program, and signalMastering() shows the
// outcome on the PLC registers, where a refused production trigger is rejected.

void CycleRunner::masteringConfigured(const station::DaemonConfig& cfg)
{
    calibrationIdentity_ = calibrationIdentity(cfg);
    // New rules start every count again, from the program's next load.
    if (cfg.mastering.due != duePolicy_) mastering_.clear();
    duePolicy_ = cfg.mastering.due;
    for (auto it = mastering_.begin(); it != mastering_.end();) {
        const auto ref = cfg.programs.find(it->first);
        if (ref == cfg.programs.end()) {
            it = mastering_.erase(it);
            continue;
        }
        it->second.due.calibrationIs(calibrationIdentity_);
        // A new set for the same program file applies now; with a new release it waits
        // for the load that says which version the program is.
        if (ref->second.partSha256 == it->second.partSha256 && ref->second.correctionSha256 != it->second.setSha256)
            applyCorrectionSet(it->first, ref->second);
        ++it;
    }
    if (duePolicy_)
        for (const auto& [number, ref] : cfg.programs) masteringStarted(ref);
    signalMastering();
}

// Every configured program has its rules from the start, so a restart refuses
// production from the first trigger when the store's counts say so. The
// program's release is known once it is loaded; until then it is taken to be
// the one its set was mastered on (docs/mastering.md, "Due in the daemon").
void CycleRunner::masteringStarted(const station::PartProgramRef& ref)
{
    const auto version = ref.correctionId.empty() ? std::nullopt : ref.correctionProgramVersion;
    auto [it, added] = mastering_.try_emplace(
        ref.number, ProgramMastering{station::MasteringDue(*duePolicy_, clock_, calibrationIdentity_),
                                     version,
                                     ref.partSha256,
                                     std::string(),
                                     {}});
    if (!added) return;
    it->second.due.programIs(version);
    applyCorrectionSet(ref.number, ref);
}

void CycleRunner::masteringLoaded(const station::PartProgramRef& ref, std::optional<int> version)
{
    if (!duePolicy_) return;
    masteringStarted(ref);
    auto& pm = mastering_.at(ref.number);
    pm.version = version;
    pm.partSha256 = ref.partSha256;
    pm.due.programIs(version);
    if (ref.correctionSha256 != pm.setSha256) applyCorrectionSet(ref.number, ref);
    signalMastering();
}

// The set the configuration names for the program comes into force, measured
// on the station as it is calibrated now; none: the program is not mastered.
void CycleRunner::applyCorrectionSet(std::uint16_t number, const station::PartProgramRef& ref)
{
    auto& pm = mastering_.at(number);
    if (ref.correctionId.empty()) {
        pm.due = station::MasteringDue(*duePolicy_, clock_, calibrationIdentity_);
        pm.due.programIs(pm.version);
    } else {
        pm.due.mastered({ref.correctionId, ref.correctionCreatedUnixMs, ref.correctionProgramVersion,
                         calibrationIdentity_, ref.correctionTemperatureC},
                        judgedWith(ref));
    }
    pm.setSha256 = ref.correctionSha256;
}

// The counts are the result store's (docs/mastering.md, "Due in the daemon"):
// the production parts judged with the set before it came into force here
// (none for a new set; after a restart, those of the daemon before).
station::MasteringHistory CycleRunner::judgedWith(const station::PartProgramRef& ref) const
{
    station::MasteringHistory history;
    try {
        history.parts = static_cast<std::uint64_t>(store_.productionJudged(ref.number, ref.correctionId));
        if (duePolicy_->maxAge)
            history.partsPastAge = static_cast<std::uint64_t>(store_.productionJudged(
                ref.number, ref.correctionId, ref.correctionCreatedUnixMs + duePolicy_->maxAge->count()));
    } catch (const std::exception& e) {
        hg::log::category("inspect")->error("part program {}: the parts judged with correction set {} could not be "
                                            "counted ({}): its part count and grace start again",
                                            ref.number, ref.correctionId, e.what());
        return {};
    }
    if (history.parts > 0)
        hg::log::category("inspect")->info("part program {}: {} production parts judged with correction set {} so far",
                                           ref.number, history.parts, ref.correctionId);
    return history;
}

// A pass or a fail is a judged part; an aborted or faulted cycle is not.
void CycleRunner::masteringJudged(const station::InspectionRecord& record)
{
    if (record.verdict != station::Verdict::Pass && record.verdict != station::Verdict::Fail) return;
    std::lock_guard lock(mutex_);
    const auto it = mastering_.find(record.program);
    if (it == mastering_.end()) return;
    it->second.due.judged(record.purpose);
    if (record.temperatureC) it->second.due.temperatureIs(*record.temperatureC);
    signalMastering();
}

// The registers get every program's state; the journal says when one becomes
// due, when its production is refused and when a new set clears it.
void CycleRunner::signalMastering()
{
    auto log = hg::log::category("inspect");
    std::map<std::uint16_t, station::MasterDueState> states;
    for (auto& [number, pm] : mastering_) {
        const auto now = dueState(pm.due);
        states[number] = now;
        if (now.due == pm.shown.due) {
            pm.shown = now;
            continue;
        }
        const auto cause = enumName(pm.due.cause());
        if (now.due == station::MasterDue::No)
            log->info("part program {}: re-mastering no longer due: correction set in force", number);
        else if (now.due == station::MasterDue::Due)
            log->warn("part program {}: re-mastering due ({}): production judged for {} more cycles", number, cause,
                      now.graceLeft);
        else
            log->warn("part program {}: re-mastering due ({}): production triggers refused until the master is "
                      "measured and its correction set reloaded; master and study cycles run",
                      number, cause);
        pm.shown = now;
    }
    registers_.setMasterDue(std::move(states));
}

nlohmann::json CycleRunner::masteringJson() const
{
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [number, pm] : mastering_) {
        const auto state = dueState(pm.due);
        j[std::to_string(number)] = {{"due", pm.due.due()},
                                     {"cause", std::string(enumName(pm.due.cause()))},
                                     {"production_refused", state.due == station::MasterDue::ProductionRefused},
                                     {"grace_left", state.graceLeft}};
    }
    return j;
}

nlohmann::json CycleRunner::program() const
{
    std::lock_guard lock(mutex_);
    return program_;
}

void CycleRunner::recover()
{
    auto log = hg::log::category("seq");
    auto r = devices_.recover();
    if (!r.ok()) {
        log->warn("recovery failed: {}", r.message());
        schedule(feed(SequencerEvent::RecoveryFailed));
        return;
    }
    feed(SequencerEvent::Recovered);
    showState();
    log->info("recovered; ready");
    if (auto ready = std::exchange(onDevicesActive_, nullptr)) ready();
}

// Work on the devices between cycles (a calibration, a snapshot): STATUS 5
// refuses triggers, the amber lamp shows the station busy, the sequencer sits
// in its maintenance state `calibrating`. False when a trigger was accepted in
// the meantime (its cycle runs first; the caller queues the work again).
bool CycleRunner::runMaintenance(const std::function<bool(const station::DaemonConfig&)>& work)
{
    if (!registers_.enterMaintenance()) return false;
    feed(SequencerEvent::CalibrationStart);
    showLamps(LampPattern::Busy);
    abortRequested_ = false;
    std::shared_ptr<const station::DaemonConfig> cfg;
    {
        std::lock_guard lock(mutex_);
        cfg = config_;
    }
    const bool done = work(*cfg);
    abortRequested_ = false;
    feed(SequencerEvent::CalibrationEnd);
    showState();
    if (done) return true;
    // A failed step may have left the drive faulted or the camera stopped: bring
    // the station back the way a cycle fault does before production resumes.
    if (auto r = devices_.recover(); !r.ok()) {
        schedule(feed(SequencerEvent::DevicesFailed));
        showState();
    }
    return true;
}

// The live fixture calibration (docs/calibration.md).
void CycleRunner::runCalibration(CalibrationJob job)
{
    const bool ran = runMaintenance([&](const station::DaemonConfig& cfg) {
        return calibration_.run(job, devices_, cfg, clock_,
                                [this] { return abortRequested_.load() || stop_.stop_requested(); });
    });
    if (!ran) calibration_.requeue(std::move(job));
}

// A camera frame on demand with its silhouette (docs/hmi.md, "Maintenance").
void CycleRunner::runSnapshot(SnapshotJob job)
{
    const bool ran =
        runMaintenance([&](const station::DaemonConfig& cfg) { return snapshot_.run(job, devices_, cfg, clock_); });
    if (!ran) snapshot_.requeue(std::move(job));
}

// ---- the station's health (docs/health.md, "In the daemon") ------------------

// Under mutex_: a configuration whose reference file or switch differs from
// what is watched replaces the monitor before the next cycle; the same file
// (a reload after the flat-field action wrote it) keeps the one in use.
void CycleRunner::healthConfigured(const station::DaemonConfig& cfg)
{
    auto& w = healthWatch_;
    const auto& h = cfg.health;
    if (w.configured && w.enabled == h.enabled && w.file == h.reference && w.sha256 == h.referenceSha256) return;
    w.configured = true;
    w.enabled = h.enabled;
    w.file = h.reference;
    w.sha256 = h.referenceSha256;
    w.reference = h.referenceRead;
    w.changed = true;
}

// Runner thread, between cycles: the inspection examines the next cycle's views with a monitor of the
// reference in use (a new monitor: the dust survey starts again against the reference's own specks).
void CycleRunner::watchHealth()
{
    bool enabled = false;
    std::optional<vision::FlatField> reference;
    std::filesystem::path file;
    {
        std::lock_guard lock(mutex_);
        if (!healthWatch_.changed) return;
        healthWatch_.changed = false;
        enabled = healthWatch_.enabled;
        reference = healthWatch_.reference;
        file = healthWatch_.file;
    }
    auto log = hg::log::category("health");
    if (!enabled) {
        inspector_.watchHealth(nullptr);
        healthAttention_ = false;
        log->info("station health not watched (health.enabled: false)");
        return;
    }
    inspector_.watchHealth(std::make_unique<vision::HealthMonitor>(reference.value_or(vision::FlatField{})));
    if (reference)
        log->info("station health watched against the flat-field reference {} taken {}", file.string(),
                  store::formatUtc(reference->takenUnixMs));
    else
        log->info("station health watched without a flat-field reference ({} does not exist): the backlight, its "
                  "uniformity and dust are not measured until one is taken (hullgauge ctl flat-field)",
                  file.string());
}

// After the result is published: the journal, the lamps' attention, the status and the plant link.
void CycleRunner::reportHealth(const Cycle& cycle)
{
    const auto& record = cycle.record;
    if (!record.health) return;
    const auto& limits = cycle.cfg->health.limits;
    healthJournal_.report(*record.health, limits);
    healthAttention_ = !record.health->warnings.empty();
    nlohmann::json reference;
    {
        std::lock_guard lock(mutex_);
        lastHealth_ = record.health;
        lastHealthUnixMs_ = record.startedUnixMs;
        lastHealthLimits_ = limits;
        reference = referenceJson(healthWatch_.reference, healthWatch_.file);
    }
    if (healthSink_) healthSink_(healthMessage(record, reference));
}

nlohmann::json CycleRunner::health() const
{
    std::lock_guard lock(mutex_);
    const auto& limits = lastHealth_ ? lastHealthLimits_ : config_->health.limits;
    nlohmann::json limitsJson;
    for (const auto& rule : healthFigureRules()) limitsJson[rule.key] = limits.*rule.limit;
    nlohmann::json j{{"enabled", healthWatch_.enabled},
                     {"limits", limitsJson},
                     {"reference", referenceJson(healthWatch_.reference, healthWatch_.file)},
                     {"reference_file", healthWatch_.file.string()},
                     {"flat_field", flatField_.status()}};
    if (!lastHealth_) {
        j["figures"] = nullptr;
        j["warnings"] = nlohmann::json::array();
        j["states"] = nullptr;
        j["time"] = nullptr;
        return j;
    }
    j["figures"] = healthFiguresJson(lastHealth_->figures);
    j["warnings"] = healthWarningsJson(lastHealth_->warnings);
    j["states"] = healthStatesJson(lastHealth_->figures, limits);
    j["time"] = store::formatUtc(lastHealthUnixMs_);
    return j;
}

// The simulated line empties its nest for the flat-field's grabs (`sim-part none`, the part switch of
// docs/daemon.md) and puts the part back after them; a simulation without it cannot.
FlatFieldAction::Simulation CycleRunner::emptyFixture()
{
    FlatFieldAction::Simulation sim;
    if (!simulation_) return sim;
    auto shown = std::make_shared<std::string>();
    sim.showEmpty = [this, shown] {
        const auto parts = simulation_->parts();
        if (std::find(parts.begin(), parts.end(), drivers::kEmptyFixture) == parts.end()) return false;
        *shown = simulation_->part();
        return simulation_->selectPart(drivers::kEmptyFixture);
    };
    sim.restore = [this, shown] {
        if (!shown->empty()) (void)simulation_->selectPart(*shown);
    };
    return sim;
}

// The flat-field reference (docs/health.md, "In the daemon"): frames of the empty fixture, production paused.
void CycleRunner::runFlatField(FlatFieldJob job)
{
    FlatFieldAction::Taken taken;
    const bool ran = runMaintenance([&](const station::DaemonConfig& cfg) {
        // Between the frames: an abort ends it, and the runner counts as turning (the watchdog).
        const auto cancelled = [this] {
            lastLoopNs_ = clock_.nowNs();
            return abortRequested_.load() || stop_.stop_requested();
        };
        taken = flatField_.run(job, devices_, cfg, clock_, emptyFixture(), cancelled);
        return !taken.deviceFailed;
    });
    if (!ran) return flatField_.requeue(job);
    if (taken.reference) {
        std::string sha256;
        try {
            sha256 = sha256OfFile(taken.file);
        } catch (const std::exception& e) {
            hg::log::category("health")->warn("flat-field reference {}: {}", taken.file.string(), e.what());
        }
        {
            std::lock_guard lock(mutex_);
            healthWatch_.reference = taken.reference;
            healthWatch_.file = taken.file;
            healthWatch_.sha256 = sha256;
            healthWatch_.changed = true;
        }
        watchHealth();
    }
    flatField_.finish(taken);
}

// ---- a cycle ----------------------------------------------------------------

void CycleRunner::runCycle(const station::TriggerRequest& trigger)
{
    // A new reference or configuration is watched from this cycle on (the worker is idle now).
    watchHealth();
    Cycle cycle;
    cycle.started = clock_.now();
    cycleStartNs_ = clock_.nowNs();
    {
        std::lock_guard lock(mutex_);
        cycle.cfg = config_;
    }
    cycle.record.startedUnixMs = clock_.wallMs();
    cycle.record.triggerSeq = trigger.seq;
    cycle.record.manual = trigger.manual;
    cycle.record.serial = trigger.serial;
    cycle.record.program = trigger.program;
    cycle.record.purpose = trigger.purpose;
    // The part's temperature at the trigger, recorded and referred to 20 °C (docs/mastering.md, "Temperature").
    const auto& temperature = cycle.cfg->temperature;
    cycle.record.temperatureC = temperature_.atTrigger(temperature, trigger.partTemperatureC);
    inspector_.setPartTemperature(cycle.record.temperatureC, temperature ? temperature->sigmaC : 0.0);
    auto action = beginCycle(cycle);
    while (action.kind != Kind::Publish) {
        auto next = interruption(cycle);
        action = next ? *next : perform(cycle, action);
    }
    endCycle(cycle, action.stopMotion);
}

SequencerAction CycleRunner::beginCycle(Cycle& cycle)
{
    auto log = hg::log::category("seq");
    const auto& r = cycle.record;
    log->info("cycle {}{}: program {}, serial '{}'{}", r.manual ? "manual" : "seq ",
              r.manual ? std::string() : std::to_string(r.triggerSeq), r.program, r.serial,
              r.purpose == station::CyclePurpose::Production ? std::string() : ", " + std::string(enumName(r.purpose)));
    showLamps(LampPattern::Busy);
    // The simulated line puts a new part in the nest, seated within its play.
    auto it = cycle.cfg->programs.find(r.program);
    cycle.program = it == cycle.cfg->programs.end() ? nullptr : &it->second;
    if (simulation_) {
        simulation_->useProgram(cycle.program ? cycle.program->simulatedNominal : std::filesystem::path());
        simulation_->newPart();
    }
    if (cycle.program) cycle.poses = cycle.program->views;
    auto action = transition([&] {
        // The cycle's configuration gives its retries: a reload's count applies from the next cycle (docs/daemon.md).
        sequencer_.setRetries(cycle.cfg->sequencer.retries);
        return sequencer_.trigger(cycle.program ? cycle.program->views.size() : 1);
    });
    std::string error;
    if (!cycle.program)
        error = "part program " + std::to_string(r.program) + " is no longer configured";
    else if (const Status loaded = inspector_.begin(*cycle.program); !loaded.ok())
        error = loaded.message().empty() ? "the part program could not be loaded" : loaded.message();
    // The cycle loaded the program the changeover selected: PROGRAM_STATE says how that went.
    if (cycle.program)
        registers_.programPrepared(r.program,
                                   error.empty() ? station::ProgramState::Ready : station::ProgramState::LoadFailed);
    if (error.empty()) {
        noteLoaded(*cycle.program);
        return action;
    }
    log->error("{}", error);
    return feed(SequencerEvent::ProgramFailed);
}

// The PLC's abort acts at once; SIGTERM gives the cycle the grace period to finish.
std::optional<SequencerAction> CycleRunner::interruption(Cycle& cycle)
{
    takeCommands();
    if (cycle.interruptFed) return std::nullopt;
    const bool abort = abortRequested_;
    const bool graceOver =
        stop_.stop_requested() && clock_.nowNs() - stopRequestedNs_.load() >= ns(cycle.cfg->sequencer.shutdownGrace);
    if (!abort && !graceOver) return std::nullopt;
    cycle.interruptFed = true;
    const auto event = abort ? SequencerEvent::Abort : SequencerEvent::Shutdown;
    hg::log::category("seq")->warn("{} during {}", enumName(event), enumName(state()));
    auto next = feed(event);
    if (next.kind == Kind::None) return std::nullopt; // processing: let it finish
    return next;
}

SequencerAction CycleRunner::perform(Cycle& cycle, const SequencerAction& action)
{
    switch (action.kind) {
    case Kind::MoveTo:
        return move(cycle, action);
    case Kind::Settle:
        return settle(cycle, action);
    case Kind::Grab:
        return grab(cycle, action);
    case Kind::Finish:
        return finishInspection(cycle);
    default:
        break;
    }
    // Nothing to perform: an event was ignored in a state that has no action. Cannot happen
    // with a consistent table; end the cycle as an internal error rather than spin.
    hg::log::category("seq")->error("sequencer stalled in {}", enumName(state()));
    auto next = feed(SequencerEvent::DevicesFailed);
    return next.kind == Kind::Publish ? next : SequencerAction{Kind::Publish, action.view, false, true};
}

SequencerAction CycleRunner::move(Cycle& cycle, const SequencerAction& action)
{
    // The first views have measured the seat: the rest are taken where they see the seated part as planned.
    if (!cycle.posesChecked && action.view > 0 && action.view == inspector_.seatViews()) correctPoses(cycle);
    askRegion(cycle, action.view);
    const auto start = clock_.now();
    auto r = devices_.moveTo(cycle.poses[action.view], cycle.cfg->sequencer.moveTimeout, action.retry);
    cycle.move += clock_.since(start);
    if (!r.ok()) hg::log::category("seq")->warn("view {}: move failed: {}", action.view, r.message());
    return feed(station::moveEvent(r.code()));
}

// Between the grab of view k-1 and the move to view k = seatViews(): the seat
// of the first k views (their preparation ran while the fixture moved) turns
// the remaining planned poses so the camera sees the seated part from the
// planned directions (docs/alignment.md, "Poses corrected for the seat").
void CycleRunner::correctPoses(Cycle& cycle)
{
    cycle.posesChecked = true;
    const Stopwatch watch(clock_);
    const std::size_t first = inspector_.seatViews();
    const auto seat = inspector_.provisionalSeat();
    auto& j = cycle.poseCorrection;
    j = {{"after_views", first}};
    auto log = hg::log::category("seq");
    if (!seat || !seat->measured || !seat->withinLimits) {
        j["applied"] = false;
        j["reason"] = !seat ? "the first views could not be prepared"
                            : (seat->message.empty() ? "the seat is beyond the limits" : seat->message);
        log->info("poses as planned: the seat of the first {} views: {}", first, j["reason"].get<std::string>());
    } else {
        j["applied"] = true;
        j["seat"] = {{"shift_mm", seat->shiftMm},
                     {"rotation_deg", seat->rotationDeg},
                     {"residual_px", seat->residualPx},
                     {"inliers", seat->inliers},
                     {"samples", seat->samples}};
        j["seat_transform"] = align::seatJson(seat->seat, seat->referencePoint);
        const auto& fixture = cycle.cfg->station.fixture;
        cycle.rangeLimited.assign(cycle.poses.size(), false);
        for (std::size_t k = first; k < cycle.poses.size(); ++k) {
            const auto c = align::correctPose(fixture, cycle.poses[k], seat->seat, seat->referencePoint);
            cycle.poses[k] = c.pose;
            cycle.rangeLimited[k] = c.limited;
        }
        log->debug("poses {}..{} corrected for the seat of the first {} views (shift {:.3f} mm, rotation {:.3f}°)",
                   first, cycle.poses.size() - 1, first, seat->shiftMm, seat->rotationDeg);
    }
    j["ms"] = watch.ms();
}

SequencerAction CycleRunner::settle(Cycle& cycle, const SequencerAction&)
{
    const auto start = clock_.now();
    clock_.sleepUntil(start + cycle.cfg->sequencer.settle, [this] {
        takeCommands();
        return abortRequested_ || stop_.stop_requested();
    });
    cycle.settle += clock_.since(start);
    return feed(SequencerEvent::Settled);
}

// The camera is asked for the view's region as the fixture starts to move
// there, so a camera that applies it in the background does so during the
// motion (docs/camera.md, "Regions per grab"; docs/daemon.md, "Regions per
// view"). A camera that cannot sends whole frames: each frame says what it covers.
void CycleRunner::askRegion(Cycle& cycle, std::size_t view)
{
    const cv::Rect region = inspector_.region(view, cycle.poses[view]);
    if (auto r = devices_.setRegion(region); !r.ok())
        hg::log::category("seq")->warn("view {}: region [{}, {}, {}, {}] not set ({}): whole frames", view, region.x,
                                       region.y, region.width, region.height, r.message());
}

SequencerAction CycleRunner::grab(Cycle& cycle, const SequencerAction& action)
{
    // A retried grab follows a recovery, which may have put the camera back on whole frames.
    if (action.retry) askRegion(cycle, action.view);
    const auto start = clock_.now();
    GrabbedFrame frame;
    auto r = devices_.grab(cycle.cfg->sequencer.grabTimeout, frame);
    cycle.grab += clock_.since(start);
    cycle.region += Milliseconds(frame.regionChangeMs);
    cycle.payloadBytes += frame.payloadBytes;
    if (r.ok()) {
        cycle.lastFrameAt = clock_.now();
        // The last frame is in: the PLC may unload the part before the verdict (ACQ_DONE_SEQ, docs/plc.md).
        if (action.view + 1 == cycle.poses.size() && !cycle.record.manual)
            registers_.acquisitionDone(cycle.record.triggerSeq);
        inspector_.addView(action.view, cycle.poses[action.view], std::move(frame.image), frame.origin);
    } else {
        hg::log::category("seq")->warn("view {}: grab failed: {}", action.view, r.message());
    }
    return feed(station::grabEvent(r.code()));
}

SequencerAction CycleRunner::finishInspection(Cycle& cycle)
{
    const auto start = clock_.now();
    cycle.outcome = inspector_.finish();
    cycle.finish += clock_.since(start);
    const auto& outcome = cycle.outcome;
    if (!outcome.ok) {
        hg::log::category("seq")->error("inspection failed: {}", outcome.error);
        return feed(SequencerEvent::ProcessingFailed);
    }
    if (outcome.seatingFault) {
        // Not a station fault: the PLC re-seats the part and triggers again (FAULT_CODE 32, docs/plc.md).
        const auto& a = outcome.alignment;
        hg::log::category("seq")->warn("part not seated: shift {:.3f} mm, rotation {:.3f}°{}{}", a ? a->shiftMm : 0.0,
                                       a ? a->rotationDeg : 0.0, a && !a->message.empty() ? ": " : "",
                                       a ? a->message : std::string());
        return feed(SequencerEvent::NotSeated);
    }
    return feed(SequencerEvent::Processed);
}

void CycleRunner::endCycle(Cycle& cycle, bool stopMotion)
{
    if (stopMotion) devices_.stopMotion();
    recordOutcome(cycle);
    // Before DONE_SEQ: a PLC that sees the result and triggers again meets the refusal it earned.
    masteringJudged(cycle.record);
    commitAndPublish(cycle);
    report(cycle);
    reportHealth(cycle);
    if (cycle.saveImages) archivePart(cycle);
    if (cycle.archiveFull) {
        images_.post([archive = archiveOf(cycle)]() mutable { archive.makeRoom(); });
    }
    // A cycle that left the station in fault: the sequencer says recover (at once).
    if (!stop_.stop_requested()) schedule(sequencer_.afterPublish());
}

void CycleRunner::recordOutcome(Cycle& cycle)
{
    station::CycleOutcome how;
    {
        std::lock_guard lock(mutex_);
        how = sequencer_.outcome();
        cycle.record.faultCode = sequencer_.faultCode();
    }
    if (how != station::CycleOutcome::Inspected) inspector_.cancel();
    auto& record = cycle.record;
    const auto& outcome = cycle.outcome;
    record.part = outcome.part;
    record.programRelease = outcome.release;
    record.verdict = station::verdictOf(how, outcome.pass);
    // The seat is kept whatever the verdict: a part not seated is recorded with the pose that says so.
    if (outcome.ok && outcome.alignment) {
        record.alignment = align::toJson(*outcome.alignment);
        if (!cycle.poseCorrection.is_null()) record.alignment["pose_correction"] = poseCorrectionJson(cycle);
    }
    if (simulation_) {
        record.simulation = {{"part", simulation_->part()}};
        if (auto seat = simulation_->trueSeat()) record.simulation["seat"] = align::seatJson(seat->seat, seat->centre);
    }
    if (how == station::CycleOutcome::Inspected) {
        record.landmarks = outcome.landmarks;
        record.correctionId = outcome.correctionId;
    }
    // The station's health the views showed, whatever the verdict (docs/health.md, "In the daemon").
    if (outcome.health)
        record.health =
            station::HealthRecord{*outcome.health, vision::healthWarnings(*outcome.health, cycle.cfg->health.limits)};
    record.cycleId = store::newCycleId();
    record.cycleMs = static_cast<std::uint32_t>(std::lround(clock_.msSince(cycle.started)));
    // The cycle-time breakdown (docs/daemon.md): prepare runs on the pipeline's worker, mostly
    // while the fixture moves, so move + settle + grab + wait_for_verdict is the cycle, not the sum.
    using station::CycleStep;
    record.timings = {{CycleStep::Move, cycle.move},
                      {CycleStep::Settle, cycle.settle},
                      {CycleStep::Grab, cycle.grab},
                      {CycleStep::Region, cycle.region},
                      {CycleStep::Prepare, outcome.prepareTime},
                      {CycleStep::Traversal, outcome.traversalTime},
                      {CycleStep::Processing, outcome.processingTime},
                      {CycleStep::WaitForVerdict, cycle.finish}};
    if (!cycle.poseCorrection.is_null())
        record.timings[CycleStep::CorrectPoses] = Milliseconds(cycle.poseCorrection["ms"].get<double>());
    // A failed part's images are written after the result is shown: the record names their
    // folder now; the whole-frame drawing is not on the path from the last frame to DONE_SEQ.
    cycle.saveImages = archivesPart(cycle.cfg->results, record.verdict) &&
                       (!outcome.views.empty() || outcome.evidence) && archiveHasRoom(cycle);
    if (cycle.saveImages) cycle.imagesDir = archiveOf(cycle).folderFor(record.startedUnixMs, record.serial).string();
}

// Per view the planned and the commanded pose and how far off the planned
// direction the camera saw the part as finally measured (docs/alignment.md).
nlohmann::json CycleRunner::poseCorrectionJson(const Cycle& cycle) const
{
    nlohmann::json j = cycle.poseCorrection;
    const auto& fixture = cycle.cfg->station.fixture;
    const auto& a = *cycle.outcome.alignment;
    j["views"] = nlohmann::json::array();
    for (std::size_t k = 0; k < cycle.poses.size(); ++k) {
        const auto& planned = cycle.program->views[k];
        const auto& commanded = cycle.poses[k];
        j["views"].push_back(
            {{"view", k},
             {"planned", geometry::toJson(planned, fixture.type)},
             {"commanded", geometry::toJson(commanded, fixture.type)},
             {"corrected", !(planned == commanded)},
             {"limited", k < cycle.rangeLimited.size() && cycle.rangeLimited[k]},
             {"sight_error_deg", align::sightErrorDeg(fixture, planned, commanded, a.seat, a.referencePoint)}});
    }
    return j;
}

void CycleRunner::commitAndPublish(Cycle& cycle)
{
    auto& record = cycle.record;
    // The record is durable before the PLC can see DONE_SEQ (docs/contracts.md §6).
    const auto commitStart = clock_.now();
    commitRecord(cycle);
    cycle.commit = clock_.since(commitStart);
    // The lamps change with the registers (just before them), so whoever sees DONE_SEQ sees the
    // lamps right; a trigger refused from now on was refused after this part's verdict.
    const auto after = state();
    shownVerdict_ = record.verdict;
    shownFault_ = record.faultCode;
    const auto regs = registers_.snapshot();
    refusalsSeen_ = regs[station::reg::RejectedTriggers];
    showLamps(station::lampPattern(after, record.verdict, record.faultCode, attentionOf(regs)));
    const auto publishStart = clock_.now();
    registers_.publishResult(record.toPublished(station::plcStatus(after)));
    const auto published = clock_.now();
    cycle.publish = published - publishStart;
    // Last frame grabbed -> RESULT and DONE_SEQ readable on the registers (the benchmark's latency).
    if (cycle.lastFrameAt) cycle.lastFrameToPublish = published - *cycle.lastFrameAt;
    // The runner turns: a failed part's images, written next, count as the loop, not as a stall.
    lastLoopNs_ = clock_.nowNs();
    cycleStartNs_ = 0;
}

// The archive of the cycle's configuration, its retention aged on the runner's clock.
ImageArchive CycleRunner::archiveOf(const Cycle& cycle) const
{
    return ImageArchive(cycle.cfg->results.imageDir, cycle.cfg->results.retention, clock_);
}

// The record wins over images (docs/daemon.md, "Archived parts"): a commit the full volume
// refused is tried once more after the oldest archived folders made room.
void CycleRunner::commitRecord(Cycle& cycle)
{
    auto& record = cycle.record;
    auto log = hg::log::category("seq");
    for (int attempt = 0;; ++attempt) {
        try {
            store_.commit(record, cycle.imagesDir);
            return;
        } catch (const std::exception& e) {
            ImageArchive archive = archiveOf(cycle);
            if (attempt == 0 && !archive.hasRoom() && archive.makeRoom() > 0) {
                log->warn("{}; the oldest archived images made room, committing again", e.what());
                continue;
            }
            log->error("{}", e.what());
            record.verdict = station::Verdict::Error;
            record.faultCode = station::FaultCode::ResultStore;
            return;
        }
    }
}

// The verdict and its record win over images (docs/daemon.md, "Archived parts"): with less than
// min_free_mb free the part's images are not kept (its row names no folder), and the writer makes
// room for the next parts once the result is shown. Said once when it starts and once when it ends.
bool CycleRunner::archiveHasRoom(Cycle& cycle)
{
    const auto& results = cycle.cfg->results;
    const bool room = archiveOf(cycle).hasRoom();
    if (room != archiveHadRoom_) {
        auto log = hg::log::category("store");
        if (room)
            log->info("the results volume has room again: parts' images are kept");
        else
            log->warn("the results volume has less than results.retention.min_free_mb ({} MiB) free: parts' images "
                      "are not kept until the oldest archived folders have made room",
                      results.retention.minFreeBytes >> 20);
        archiveHadRoom_ = room;
    }
    cycle.archiveFull = !room;
    return room;
}

void CycleRunner::report(Cycle& cycle)
{
    const auto& record = cycle.record;
    auto timings = record.timings;
    timings[station::CycleStep::Commit] = cycle.commit;
    timings[station::CycleStep::Publish] = cycle.publish;
    if (cycle.lastFrameToPublish) timings[station::CycleStep::LastFrameToPublish] = *cycle.lastFrameToPublish;
    abortRequested_ = false;
    {
        std::lock_guard lock(mutex_);
        ++cycles_;
        if (record.verdict == station::Verdict::Error) ++faults_;
        lastImagesMs_ = cycle.saveImages ? std::make_shared<std::atomic<double>>(-1.0) : nullptr;
        lastCycle_ = {{"trigger_seq", record.triggerSeq},
                      {"serial", record.serial},
                      {"program", record.program},
                      {"verdict", std::string(enumName(record.verdict))},
                      {"fault_code", static_cast<int>(record.faultCode)},
                      {"cycle_ms", record.cycleMs},
                      {"landmarks_failed", record.landmarksFailed()},
                      {"landmarks_total", record.landmarks.size()},
                      {"manual", record.manual},
                      {"purpose", std::string(enumName(record.purpose))},
                      {"images_dir", cycle.imagesDir},
                      {"alignment", record.alignment},
                      {"timing_ms", station::toJson(timings)},
                      {"payload_bytes", cycle.payloadBytes}};
        putRelease(lastCycle_, record.programRelease);
        lastCycle_["temperature_c"] = record.temperatureC ? nlohmann::json(*record.temperatureC) : nlohmann::json();
        if (!record.simulation.is_null()) lastCycle_["simulation"] = record.simulation;
    }
    hg::log::category("seq")->info(
        "cycle done: {} (fault {}, {} ms: move {:.0f}, settle {:.0f}, grab {:.0f}, prepare {:.1f}, verdict wait "
        "{:.1f}, commit {:.1f}; last frame to result {:.1f})",
        enumName(record.verdict), static_cast<int>(record.faultCode), record.cycleMs, cycle.move.count(),
        cycle.settle.count(), cycle.grab.count(), cycle.outcome.prepareTime.count(), cycle.finish.count(),
        cycle.commit.count(), cycle.lastFrameToPublish.value_or(Milliseconds{}).count());
}

// On the writer's thread: the runner is free for the next trigger meanwhile. The job
// touches only what it was given and reports its time through its own counter.
void CycleRunner::archivePart(Cycle& cycle)
{
    ImageArchive archive = archiveOf(cycle);
    auto& outcome = cycle.outcome;
    auto evidence =
        outcome.views.empty() ? std::move(outcome.evidence) : [views = std::move(outcome.views)] { return views; };
    images_.post([archive, evidence = std::move(evidence), startedUnixMs = cycle.record.startedUnixMs,
                  serial = cycle.record.serial, dir = cycle.imagesDir, done = lastImagesMs_,
                  failed = cycle.record.verdict == station::Verdict::Fail, &clock = clock_]() mutable {
        auto log = hg::log::category("store");
        const Stopwatch watch(clock);
        try {
            if (archive.save(startedUnixMs, serial, evidence(), failed).empty())
                log->error("the archive of part '{}' could not be written to {}", serial, dir);
            archive.enforceRetention();
        } catch (const std::exception& e) {
            log->error("the archive of part '{}': {}", serial, e.what());
        }
        const double ms = watch.ms();
        log->debug("images of '{}' written in {:.0f} ms", serial, ms);
        done->store(ms);
    });
}

} // namespace hg::daemon
