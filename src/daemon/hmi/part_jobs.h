// The workbench's long work (docs/workbench.md, "HTTP API"): suggesting
// landmarks, planning and commissioning a part, each a `hullgauge part …`
// process of its own at nice 10 — it takes seconds of both cores, and the
// line's cycles come first; a fault in it (a damaged CAD file) ends that
// process, never the daemon. One job per part, at most `workbench.max_jobs`
// at once; its progress read from the JSON lines the command prints
// (`--progress`), a cancel is SIGTERM (the command stops between two cycles
// and leaves the previous verification in place).
#pragma once

#include "hullgauge/common/clock.h"
#include "hullgauge/common/enum_names.h"
#include "hullgauge/common/status.h"
#include "hullgauge/common/worker.h"

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <sys/types.h>
#include <vector>

namespace hg::daemon {

/// How a job ended. `NotReleasable`: a commissioning that verified the draft
/// and found it not releasable (`hullgauge part commission` exit status 1,
/// docs/commissioning.md) — the report says why; not a fault of the job.
enum class JobState { Running, Finished, NotReleasable, Failed, Cancelled };
constexpr auto nameTable(JobState)
{
    using enum JobState;
    return std::to_array<EnumName<JobState>>({{Running, "running"},
                                              {Finished, "finished"},
                                              {NotReleasable, "not_releasable"},
                                              {Failed, "failed"},
                                              {Cancelled, "cancelled"}});
}

/// What a part's job is doing or came to.
struct PartJob {
    std::string part;
    std::string kind; ///< "commission", "suggest", "plan"
    JobState state = JobState::Running;
    std::string phase;
    std::size_t done = 0, total = 0;
    std::string startedBy, startedAt;
    std::optional<int> exitStatus;
    /// The command's last words on stderr (its refusal or its summary).
    std::string message;
};

nlohmann::json toJson(const PartJob& job);

/// How a `hullgauge part` command run to its end came out.
struct CommandOutcome {
    std::optional<int> exitStatus; ///< none: ended by a signal or killed at the deadline
    std::string out, err;
    bool timedOut = false;
};

/// Runs `hullgauge part <verb> --workspace W <rest…>` (args = verb, rest…) at
/// nice 10 and waits for it, at most `deadline` (then SIGKILL).
CommandOutcome runPartCommand(const std::filesystem::path& cli, const std::filesystem::path& workspace,
                              const std::vector<std::string>& args, std::chrono::milliseconds deadline);

class PartJobs {
  public:
    PartJobs(std::filesystem::path cli, std::filesystem::path workspace, int maxJobs);
    /// Cancels what runs and waits for it (SIGTERM, after 5 s SIGKILL).
    ~PartJobs();
    PartJobs(const PartJobs&) = delete;
    PartJobs& operator=(const PartJobs&) = delete;

    /// Starts `hullgauge part <kind> --workspace W <part> <args…>`;
    /// refused (NotAllowed) while the part has a job or max_jobs run.
    Status start(const std::string& part, const std::string& kind, const std::vector<std::string>& args,
                 const std::string& by);
    /// The part's job, running or the last one that ended.
    std::optional<PartJob> job(const std::string& part) const;
    /// True while any job of the part runs.
    bool running(const std::string& part) const;
    /// SIGTERM to the part's running job; false when none runs.
    bool cancel(const std::string& part);

  private:
    struct Running;
    void follow(Running& run, std::stop_token stop);
    bool read(Running& run, int fd, std::string& pending, bool progress);

    std::filesystem::path cli_, workspace_;
    int maxJobs_;
    mutable std::mutex mutex_;
    std::map<std::string, PartJob> jobs_;
    std::map<std::string, std::unique_ptr<Running>> running_;
};

} // namespace hg::daemon
