#include "cycle_runner.h"

#include "hullgauge/calib/station_file.h"
#include "hullgauge/common/log.h"

#include <cmath>
#include <functional>
#include <optional>
#include <thread>

namespace hg::daemon {
namespace {

using station::SequencerAction;
using station::SequencerEvent;
using station::SequencerState;
using Clock = std::chrono::steady_clock;
using Kind = SequencerAction::Kind;

/// Settle time: sleeps in short slices so an abort is not delayed by it.
void sleepUntil(Clock::time_point until, const std::function<bool()>& stop)
{
    while (Clock::now() < until && !stop())
        std::this_thread::sleep_for(std::min<Clock::duration>(std::chrono::milliseconds(5), until - Clock::now()));
}

std::int64_t nowNs()
{
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

std::int64_t wallMs()
{
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

double msSince(Clock::time_point t)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

SequencerEvent moveEvent(const Status& r)
{
    switch (r.code()) {
    case StatusCode::Ok:
        return SequencerEvent::InPosition;
    case StatusCode::Timeout:
        return SequencerEvent::MoveTimeout;
    case StatusCode::Fault:
        return SequencerEvent::MoveFault;
    case StatusCode::NotAllowed:
        return SequencerEvent::MoveRefused;
    default:
        return SequencerEvent::MoveCommError;
    }
}

SequencerEvent grabEvent(const Status& r)
{
    switch (r.code()) {
    case StatusCode::Ok:
        return SequencerEvent::FrameOk;
    case StatusCode::Timeout:
        return SequencerEvent::FrameTimeout;
    case StatusCode::BadFrame:
        return SequencerEvent::FrameBad;
    default:
        return SequencerEvent::FrameError;
    }
}

} // namespace

std::string_view toString(LampPattern p)
{
    switch (p) {
    case LampPattern::Off:
        return "off";
    case LampPattern::Busy:
        return "busy";
    case LampPattern::Pass:
        return "pass";
    case LampPattern::Fail:
        return "fail";
    case LampPattern::Fault:
        return "fault";
    }
    return "off";
}

CycleRunner::CycleRunner(station::PlcRegisters& registers, StationDevices& devices, Inspector& inspector,
                         ResultStore& store, std::shared_ptr<const station::DaemonConfig> config)
    : registers_(registers), devices_(devices), inspector_(inspector), store_(store), config_(std::move(config)),
      sequencer_(config_->sequencer.retries)
{
}

CycleRunner::~CycleRunner()
{
    stop();
}

void CycleRunner::start(std::function<void()> onDevicesActive)
{
    onDevicesActive_ = std::move(onDevicesActive);
    lastLoopNs_ = nowNs();
    thread_ = std::thread([this] { run(); });
}

void CycleRunner::stop()
{
    if (!thread_.joinable()) return;
    stopRequestedNs_ = nowNs();
    stopRequested_ = true;
    thread_.join();
}

void CycleRunner::setConfig(std::shared_ptr<const station::DaemonConfig> config)
{
    std::lock_guard lock(mutex_);
    config_ = std::move(config);
}

station::SequencerState CycleRunner::state() const
{
    std::lock_guard lock(mutex_);
    return sequencer_.state();
}

bool CycleRunner::healthy() const
{
    std::chrono::milliseconds maxCycle;
    {
        std::lock_guard lock(mutex_);
        maxCycle = config_->watchdog.maxCycle;
    }
    auto now = nowNs();
    auto cycleStart = cycleStartNs_.load();
    if (cycleStart != 0 && now - cycleStart > std::chrono::nanoseconds(maxCycle).count()) return false;
    // A calibration step (move, settle, grab) is bounded by its timeouts.
    if (auto step = calibrationStepNs_.load(); step != 0) {
        std::chrono::milliseconds bound;
        {
            std::lock_guard lock(mutex_);
            bound = config_->sequencer.moveTimeout + config_->sequencer.settle + config_->sequencer.grabTimeout +
                    std::chrono::seconds(5);
        }
        return now - step <= std::chrono::nanoseconds(bound).count();
    }
    // Outside a cycle the thread turns at least every 200 ms; inside one each step is bounded by its timeout.
    if (cycleStart == 0 && now - lastLoopNs_.load() > std::chrono::nanoseconds(std::chrono::seconds(5)).count())
        return false;
    return true;
}

nlohmann::json CycleRunner::describe() const
{
    std::lock_guard lock(mutex_);
    // Between the sequencer's end of cycle and the published result (commit, PLC registers) the
    // operator sees "processing": "done" promises a result that is already stored.
    auto shown = sequencer_.state();
    if (cycleStartNs_.load() != 0 && !station::isBusy(shown)) shown = SequencerState::Processing;
    nlohmann::json j{{"state", std::string(station::toString(shown))},
                     {"cycles", cycles_},
                     {"faults", faults_},
                     {"last_cycle", lastCycle_}};
    if (station::isBusy(sequencer_.state())) {
        j["view"] = sequencer_.view();
        j["views"] = sequencer_.viewCount();
    }
    if (sequencer_.state() == SequencerState::Fault) {
        j["fault_code"] = static_cast<int>(sequencer_.faultCode());
        j["fault"] = std::string(station::describe(sequencer_.faultCode()));
    }
    return j;
}

void CycleRunner::setState(std::function<SequencerAction()> step, SequencerAction& action)
{
    auto log = hg::log::category("seq");
    std::lock_guard lock(mutex_);
    auto before = sequencer_.state();
    action = step();
    if (sequencer_.state() != before)
        log->debug("{} -> {}", station::toString(before), station::toString(sequencer_.state()));
}

void CycleRunner::run()
{
    auto log = hg::log::category("seq");
    SequencerAction action;
    auto started = devices_.start();
    if (started.ok()) {
        setState([&] { return sequencer_.onEvent(SequencerEvent::DevicesActive); }, action);
        registers_.setStatus(station::PlcStatus::Ready);
        devices_.showLamps(LampPattern::Off);
        log->info("devices active; ready");
        if (onDevicesActive_) onDevicesActive_();
    } else {
        log->error("devices failed to start: {}", started.message());
        setState([&] { return sequencer_.onEvent(SequencerEvent::DevicesFailed); }, action);
        registers_.setStatus(station::PlcStatus::Fault);
        devices_.showLamps(LampPattern::Fault);
    }

    auto lastRecovery = Clock::now();
    while (!stopRequested_) {
        lastLoopNs_ = nowNs();
        auto command = registers_.takeCommand();
        if (state() == SequencerState::Fault) {
            // Retry recovery every 2 s, or at once when the PLC asks for a fault reset.
            if (command == station::PlcCommand::ResetFault || Clock::now() - lastRecovery > std::chrono::seconds(2)) {
                recover();
                lastRecovery = Clock::now();
            }
        }
        bool calibrationQueued = false;
        {
            std::lock_guard lock(mutex_);
            calibrationQueued = calibrationJob_.has_value();
        }
        if (!calibrationQueued) abortRequested_ = false; // an abort outside a cycle has nothing to abort
        // Triggers first: a queued calibration starts only when none is pending.
        if (auto trigger = registers_.waitTrigger(std::chrono::milliseconds(calibrationQueued ? 0 : 200))) {
            runCycle(*trigger);
            continue;
        }
        if (calibrationQueued) {
            std::optional<CalibrationJob> job;
            {
                std::lock_guard lock(mutex_);
                job.swap(calibrationJob_);
                // A cycle before it faulted the station: the calibration is not started.
                if (job && sequencer_.state() == SequencerState::Fault) {
                    calibration_["state"] = "failed";
                    calibration_["error"] = "the station went into fault before the calibration started";
                    job.reset();
                }
            }
            if (job) runCalibration(std::move(*job));
        }
    }
    devices_.showLamps(LampPattern::Off);
    devices_.shutdown();
    log->info("devices shut down");
}

bool CycleRunner::requestCalibration(CalibrationJob job, std::string& why)
{
    std::lock_guard lock(mutex_);
    const auto st = sequencer_.state();
    if (calibrationJob_ || st == SequencerState::Calibrating) {
        why = "a calibration is already queued or running";
        return false;
    }
    if (st == SequencerState::Fault || st == SequencerState::Starting) {
        why = std::string("the station is not ready (") + std::string(station::toString(st)) + ")";
        return false;
    }
    calibration_ = {{"state", "queued"},
                    {"poses", job.poses.size()},
                    {"out", job.out.string()},
                    {"progress", nlohmann::json::array()}};
    calibrationJob_ = std::move(job);
    return true;
}

nlohmann::json CycleRunner::calibration() const
{
    std::lock_guard lock(mutex_);
    return calibration_;
}

// The live fixture calibration (calib::runFixtureSequence) through the
// station's own devices, between cycles: STATUS 5 refuses triggers, the amber
// lamp shows the station busy, the sequencer sits in `calibrating`. The
// station file is written with a backup only when the axes were solved; the
// running configuration is not touched (a reload takes the new calibration).
void CycleRunner::runCalibration(CalibrationJob job)
{
    auto log = hg::log::category("calib");
    auto finish = [&](const char* state, nlohmann::json extra) {
        std::lock_guard lock(mutex_);
        calibration_["state"] = state;
        calibration_.update(extra);
    };
    if (!registers_.enterMaintenance()) {
        // A trigger was accepted in the meantime: its cycle runs first.
        std::lock_guard lock(mutex_);
        calibrationJob_ = std::move(job);
        return;
    }
    SequencerAction action;
    setState([&] { return sequencer_.onEvent(SequencerEvent::CalibrationStart); }, action);
    devices_.showLamps(LampPattern::Busy);
    abortRequested_ = false;
    std::shared_ptr<const station::DaemonConfig> cfg;
    {
        std::lock_guard lock(mutex_);
        cfg = config_;
        calibration_["state"] = "running";
    }
    log->info("calibration: {} poses, target {}, writing {}", job.poses.size(), job.target.toString(),
              job.out.string());
    calib::FixtureSequenceIo io;
    io.moveTo = [&](const geometry::FixturePose& pose) {
        calibrationStepNs_ = nowNs();
        auto r = devices_.moveTo(pose, cfg->sequencer.moveTimeout, false);
        if (!r.ok()) return r;
        sleepUntil(Clock::now() + cfg->sequencer.settle, [this] { return abortRequested_.load(); });
        return Status::success();
    };
    io.grab = [&](cv::Mat& image) {
        calibrationStepNs_ = nowNs();
        return devices_.grab(cfg->sequencer.grabTimeout, image);
    };
    io.progress = [&](std::size_t, std::size_t, const std::string& line) {
        log->info("calibration {}", line);
        std::lock_guard lock(mutex_);
        calibration_["progress"].push_back(line);
    };
    io.cancelled = [&] { return abortRequested_.load() || stopRequested_.load(); };
    bool ok = false;
    try {
        auto result = calib::runFixtureSequence(job.poses, job.target, cfg->station.camera, cfg->station.fixture.type,
                                                io, "poses");
        calib::StationFileUpdate update(job.out);
        update.setFixtureAxes(result.axes);
        const auto backup = update.commit();
        finish("done", {{"report", calib::formatFixtureReport(result.axes)},
                        {"views_used", result.views.size()},
                        {"backup", backup ? backup->string() : std::string()}});
        log->info("calibration written to {}", job.out.string());
        ok = true;
    } catch (const std::exception& e) {
        log->error("calibration failed: {}", e.what());
        finish("failed", {{"error", e.what()}});
    }
    calibrationStepNs_ = 0;
    abortRequested_ = false;
    setState([&] { return sequencer_.onEvent(SequencerEvent::CalibrationEnd); }, action);
    registers_.setStatus(station::PlcStatus::Ready);
    devices_.showLamps(LampPattern::Off);
    // A failed step may have left the drive faulted or the camera stopped: bring
    // the station back the way a cycle fault does before production resumes.
    if (!ok) {
        auto r = devices_.recover();
        if (!r.ok()) {
            setState([&] { return sequencer_.onEvent(SequencerEvent::DevicesFailed); }, action);
            registers_.setStatus(station::PlcStatus::Fault);
            devices_.showLamps(LampPattern::Fault);
        }
    }
}

void CycleRunner::recover()
{
    auto log = hg::log::category("seq");
    SequencerAction action;
    auto r = devices_.recover();
    if (r.ok()) {
        setState([&] { return sequencer_.onEvent(SequencerEvent::Recovered); }, action);
        registers_.setStatus(station::PlcStatus::Ready);
        devices_.showLamps(LampPattern::Off);
        bool first = false;
        {
            std::lock_guard lock(mutex_);
            first = cycles_ == 0 && faults_ == 0;
        }
        log->info("recovered; ready");
        if (first && onDevicesActive_) {
            onDevicesActive_();
            onDevicesActive_ = nullptr;
        }
    } else {
        setState([&] { return sequencer_.onEvent(SequencerEvent::RecoveryFailed); }, action);
        log->warn("recovery failed: {}", r.message());
    }
}

bool CycleRunner::interrupted()
{
    if (registers_.takeCommand() == station::PlcCommand::Abort) abortRequested_ = true;
    return abortRequested_ || stopRequested_;
}

void CycleRunner::runCycle(const station::TriggerRequest& trigger)
{
    auto log = hg::log::category("seq");
    const auto cycleStart = Clock::now();
    cycleStartNs_ = nowNs();
    std::shared_ptr<const station::DaemonConfig> cfg;
    {
        std::lock_guard lock(mutex_);
        cfg = config_;
    }
    station::InspectionRecord record;
    record.startedUnixMs = wallMs();
    record.triggerSeq = trigger.seq;
    record.manual = trigger.manual;
    record.serial = trigger.serial;
    record.program = trigger.program;
    double moveMs = 0, settleMs = 0, grabMs = 0, finishMs = 0;
    std::optional<Clock::time_point> lastFrameAt; // when the last good frame was in (latency, issue 6)

    log->info("cycle {}{}: program {}, serial '{}'", trigger.manual ? "manual" : "seq ",
              trigger.manual ? std::string() : std::to_string(trigger.seq), trigger.program, trigger.serial);
    devices_.showLamps(LampPattern::Busy);

    auto programIt = cfg->programs.find(trigger.program);
    const station::PartProgramRef* program = programIt == cfg->programs.end() ? nullptr : &programIt->second;
    SequencerAction action;
    setState([&] { return sequencer_.trigger(program ? program->views.size() : 1); }, action);
    std::string programError;
    if (!program)
        programError = "part program " + std::to_string(trigger.program) + " is no longer configured";
    else if (!inspector_.begin(*program, programError) && programError.empty())
        programError = "the part program could not be loaded";
    if (!programError.empty()) {
        log->error("{}", programError);
        setState([&] { return sequencer_.onEvent(SequencerEvent::ProgramFailed); }, action);
    }

    InspectionOutcome outcome;
    bool abortFed = false;
    while (action.kind != Kind::Publish) {
        if (!abortFed && interrupted()) {
            // SIGTERM gets the grace period to let the cycle finish; the PLC's abort acts at once.
            bool graceOver = !stopRequested_ || nowNs() - stopRequestedNs_.load() >=
                                                    std::chrono::nanoseconds(cfg->sequencer.shutdownGrace).count();
            if (abortRequested_ || graceOver) {
                abortFed = true;
                auto event = abortRequested_ ? SequencerEvent::Abort : SequencerEvent::Shutdown;
                log->warn("{} during {}", station::toString(event), station::toString(state()));
                SequencerAction next;
                setState([&] { return sequencer_.onEvent(event); }, next);
                if (next.kind != Kind::None) {
                    action = next;
                    continue;
                }
            }
        }
        const auto stepStart = Clock::now();
        switch (action.kind) {
        case Kind::MoveTo: {
            auto pose = program->views[action.view];
            auto r = devices_.moveTo(pose, cfg->sequencer.moveTimeout, action.retry);
            moveMs += msSince(stepStart);
            if (!r.ok()) log->warn("view {}: move failed: {}", action.view, r.message());
            setState([&] { return sequencer_.onEvent(moveEvent(r)); }, action);
            break;
        }
        case Kind::Settle: {
            sleepUntil(stepStart + cfg->sequencer.settle, [this] { return interrupted(); });
            settleMs += msSince(stepStart);
            setState([&] { return sequencer_.onEvent(SequencerEvent::Settled); }, action);
            break;
        }
        case Kind::Grab: {
            cv::Mat image;
            auto r = devices_.grab(cfg->sequencer.grabTimeout, image);
            grabMs += msSince(stepStart);
            if (r.ok()) {
                lastFrameAt = Clock::now();
                inspector_.addView(action.view, program->views[action.view], image);
            } else
                log->warn("view {}: grab failed: {}", action.view, r.message());
            setState([&] { return sequencer_.onEvent(grabEvent(r)); }, action);
            break;
        }
        case Kind::Finish: {
            outcome = inspector_.finish();
            finishMs += msSince(stepStart);
            if (!outcome.ok) log->error("inspection failed: {}", outcome.error);
            setState(
                [&] {
                    return sequencer_.onEvent(outcome.ok ? SequencerEvent::Processed
                                                         : SequencerEvent::ProcessingFailed);
                },
                action);
            break;
        }
        default: {
            // Nothing to perform: an event was ignored in a state that has no action. Cannot
            // happen with a consistent table; end the cycle as an internal error rather than spin.
            log->error("sequencer stalled in {}", station::toString(state()));
            SequencerAction next;
            setState([&] { return sequencer_.onEvent(SequencerEvent::DevicesFailed); }, next);
            action = next;
            break;
        }
        }
    }

    if (action.stopMotion) devices_.stopMotion();
    station::CycleOutcome how;
    station::FaultCode code;
    station::SequencerState after;
    {
        std::lock_guard lock(mutex_);
        how = sequencer_.outcome();
        code = sequencer_.faultCode();
        after = sequencer_.state();
    }
    if (how != station::CycleOutcome::Inspected) inspector_.cancel();
    record.part = outcome.part;
    record.faultCode = code;
    if (how == station::CycleOutcome::Inspected) {
        record.verdict = outcome.pass ? station::Verdict::Pass : station::Verdict::Fail;
        record.landmarks = outcome.landmarks;
    } else {
        record.verdict = how == station::CycleOutcome::Aborted ? station::Verdict::Aborted : station::Verdict::Error;
    }
    record.cycleMs = static_cast<std::uint32_t>(std::lround(msSince(cycleStart)));
    // The cycle-time breakdown (docs/daemon.md): prepare runs on the pipeline's worker, mostly
    // while the fixture moves, so move + settle + grab + wait_for_verdict is the cycle, not the sum.
    record.timingMs = {{"move", moveMs},
                       {"settle", settleMs},
                       {"grab", grabMs},
                       {"prepare", outcome.prepareMs},
                       {"traversal", outcome.traversalMs},
                       {"processing", outcome.processingMs},
                       {"wait_for_verdict", finishMs}};

    // A failed part's images are written after the result is shown (below): the record names
    // their folder now; the whole-frame drawing is not on the path from the last frame to DONE_SEQ.
    std::string imagesDir;
    ImageArchive archive(cfg->results.imageDir, cfg->results.retention);
    const bool saveImages = archivesPart(cfg->results, record.verdict) && (!outcome.views.empty() || outcome.evidence);
    if (saveImages) imagesDir = archive.folderFor(record.startedUnixMs, record.serial).string();
    // The record is durable before the PLC can see DONE_SEQ (CONTRACTS §6, issue 6).
    const auto commitStart = Clock::now();
    try {
        store_.commit(record, imagesDir);
    } catch (const std::exception& e) {
        log->error("{}", e.what());
        record.verdict = station::Verdict::Error;
        record.faultCode = station::FaultCode::ResultStore;
    }
    const double commitMs = msSince(commitStart);
    // The lamps change with the registers (just before them), so whoever sees DONE_SEQ sees the lamps right.
    LampPattern lamps = LampPattern::Off;
    if (after == SequencerState::Fault)
        lamps = LampPattern::Fault;
    else if (record.verdict == station::Verdict::Pass)
        lamps = LampPattern::Pass;
    else if (record.verdict == station::Verdict::Fail)
        lamps = LampPattern::Fail;
    devices_.showLamps(lamps);
    auto statusAfter = after == SequencerState::Fault ? station::PlcStatus::Fault : station::PlcStatus::Done;
    const auto publishStart = Clock::now();
    registers_.publishResult(record.toPublished(statusAfter));
    const auto published = Clock::now();
    // The runner turns: a failed part's images, written next, count as the loop, not as a stall.
    lastLoopNs_ = nowNs();
    cycleStartNs_ = 0;
    auto timing = record.timingMs;
    timing["commit"] = commitMs;
    timing["publish"] = std::chrono::duration<double, std::milli>(published - publishStart).count();
    // Last frame grabbed -> RESULT and DONE_SEQ readable on the registers (the benchmark's latency).
    if (lastFrameAt)
        timing["last_frame_to_publish"] = std::chrono::duration<double, std::milli>(published - *lastFrameAt).count();
    abortRequested_ = false;
    {
        std::lock_guard lock(mutex_);
        ++cycles_;
        if (record.verdict == station::Verdict::Error) ++faults_;
        lastCycle_ = {{"trigger_seq", record.triggerSeq},
                      {"serial", record.serial},
                      {"program", record.program},
                      {"verdict", std::string(station::toString(record.verdict))},
                      {"fault_code", static_cast<int>(record.faultCode)},
                      {"cycle_ms", record.cycleMs},
                      {"landmarks_failed", record.landmarksFailed()},
                      {"landmarks_total", record.landmarks.size()},
                      {"manual", record.manual},
                      {"images_dir", imagesDir},
                      {"timing_ms", timing}};
    }
    if (saveImages) {
        // On the writer's thread: the runner is free for the next trigger meanwhile.
        auto evidence =
            outcome.views.empty() ? std::move(outcome.evidence) : [views = std::move(outcome.views)] { return views; };
        images_.post([this, archive, evidence = std::move(evidence), startedUnixMs = record.startedUnixMs,
                      serial = record.serial, imagesDir, seq = record.triggerSeq, manual = record.manual]() mutable {
            auto storeLog = hg::log::category("store");
            const auto imagesStart = Clock::now();
            try {
                if (archive.save(startedUnixMs, serial, evidence()).empty())
                    storeLog->error("the archive of part '{}' could not be written to {}", serial, imagesDir);
                archive.enforceRetention();
            } catch (const std::exception& e) {
                storeLog->error("the archive of part '{}': {}", serial, e.what());
            }
            const double ms = msSince(imagesStart);
            storeLog->debug("images of '{}' written in {:.0f} ms", serial, ms);
            std::lock_guard lock(mutex_);
            if (lastCycle_.is_object() && lastCycle_.value("trigger_seq", -1) == seq &&
                lastCycle_.value("manual", !manual) == manual)
                lastCycle_["timing_ms"]["images"] = ms;
        });
    }
    log->info("cycle done: {} (fault {}, {} ms: move {:.0f}, settle {:.0f}, grab {:.0f}, prepare {:.1f}, verdict wait "
              "{:.1f}, commit {:.1f}; last frame to result {:.1f})",
              station::toString(record.verdict), static_cast<int>(record.faultCode), record.cycleMs, moveMs, settleMs,
              grabMs, outcome.prepareMs, finishMs, commitMs, timing.value("last_frame_to_publish", 0.0));
    if (sequencer_.afterPublish().kind == Kind::Recover && !stopRequested_) recover();
}

} // namespace hg::daemon
