// The mastering run (docs/mastering.md, "The mastering run"): N cycles of a
// master part run by the daemon itself, the correction set computed from
// exactly those cycles, written into `mastering.folder` and put in force by a
// reload. One way for every caller: `hullgauge master --run` and the HMI's
// maintenance page both ask the maintenance command `master` for it and
// follow its status. It runs on a thread of its own, as a client of the
// station would — it sets the purpose, triggers manually, reads the stored
// rows — so the cycles are the runner's ordinary cycles; the purpose is put
// back to what it was however the run ends.
#pragma once

#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/status.h"
#include "hullgauge/common/worker.h"
#include "hullgauge/inspect/correction.h"
#include "hullgauge/station/plc_registers.h"
#include "hullgauge/store/audit_log.h"
#include "hullgauge/study/mastering.h"

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stop_token>
#include <string>

namespace hg::daemon {

/// What the run acts on; every function is called from the run's thread and must be safe there.
struct MasteringStation {
    std::function<station::CyclePurpose()> purpose;
    std::function<void(station::CyclePurpose)> setPurpose;
    /// A manual trigger (the maintenance command `trigger`'s rule).
    std::function<station::RejectReason(std::uint16_t program, const std::string& serial)> trigger;
    /// The configuration the cycles run with now (its mastering sets: the new one in force).
    std::function<std::shared_ptr<const station::DaemonConfig>()> config;
    /// The material the program names as the inspection loaded it ('' none); nothing when it is not loaded.
    std::function<std::optional<std::string>(std::uint16_t program)> material;
    /// Asks for a reload of the configuration (as SIGHUP).
    std::function<void()> reload;
    /// Records in the audit trail (docs/audit.md); the time is set by it.
    std::function<void(store::AuditEntry)> audit;
};

/// One run as asked for.
struct MasteringRequest {
    std::uint16_t program = 0;
    std::size_t cycles = 0; ///< N, 2..10000
    study::MasterCertificate master;
    std::optional<std::string> material; ///< none: the program's
    std::chrono::milliseconds timeout{120'000};
    /// Who asked (the audit trail's who, role and source).
    std::string who, role, source;
};

class MasteringRun {
  public:
    MasteringRun(MasteringStation station, Clock& clock = Clock::steady());
    /// Cancels a run and waits for it to put the purpose back.
    ~MasteringRun();
    MasteringRun(const MasteringRun&) = delete;
    MasteringRun& operator=(const MasteringRun&) = delete;

    /// Starts the run; NotAllowed saying why when one runs or the
    /// configuration has no `mastering.folder` (the other refusals — a cycle
    /// running, another job — are the caller's, who knows the runner).
    Status start(MasteringRequest request);
    /// Ends a running run at its next wait (`by` names who asked); false when none runs.
    bool cancel(const std::string& by);
    bool running() const;
    /// `state` (running, done, failed; null before the first), `program`,
    /// `master`, `cycles`, `cycle` (the one running or last judged), `step`,
    /// `results`, `progress` (a line per cycle), `purpose_before`,
    /// `previous_set`, `error` and, once done, `set` (id, file, method and per
    /// landmark the offset, gain, spread, U_corr and cycles).
    nlohmann::json status() const;

  private:
    void run(std::stop_token stop, const MasteringRequest& request);
    std::set<std::int64_t> runCycles(std::stop_token stop, const MasteringRequest& request,
                                     const station::DaemonConfig& config);
    std::int64_t runCycle(std::stop_token stop, const MasteringRequest& request, const station::DaemonConfig& config,
                          std::size_t k, std::int64_t afterId);
    inspect::CorrectionSet computeSet(const MasteringRequest& request, const station::DaemonConfig& config,
                                      const std::set<std::int64_t>& ids);
    void awaitInForce(std::stop_token stop, const MasteringRequest& request, const inspect::CorrectionSet& set);
    void waitFor(std::stop_token stop, const MasteringRequest& request, const std::string& what,
                 const std::function<bool()>& done);
    void update(const nlohmann::json& fields);
    void recordEnd(const MasteringRequest& request, const std::filesystem::path& file, const std::string& before,
                   const std::string& error);

    MasteringStation station_;
    Clock& clock_;
    mutable std::mutex mutex_; // guards status_, cancelledBy_
    nlohmann::json status_ = nullptr;
    std::string cancelledBy_;
    std::atomic<bool> running_{false};
    std::atomic<bool> cancel_{false};
    Worker worker_; ///< last: it ends before what it uses
};

/// The status's `set`: per landmark the offset ± U_corr a person reads (docs/mastering.md).
nlohmann::json correctionSummary(const inspect::CorrectionSet& set, const std::string& file);

/// "busy", "unknown part program", ... : why a manual trigger was refused, in words.
std::string triggerRefusal(station::RejectReason reason);

} // namespace hg::daemon
