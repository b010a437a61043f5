#include "hmi/part_jobs.h"

#include "hullgauge/common/child_process.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/eventfd.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace hg::daemon {

using nlohmann::json;

json toJson(const PartJob& job)
{
    json j{{"part", job.part},      {"kind", job.kind},   {"state", enumName(job.state)}, {"phase", job.phase},
           {"done", job.done},      {"total", job.total}, {"started_by", job.startedBy},  {"started_at", job.startedAt},
           {"message", job.message}};
    j["exit_status"] = job.exitStatus ? json(*job.exitStatus) : json(nullptr);
    return j;
}

struct PartJobs::Running {
    std::string part;
    pid_t pid = -1;
    int out = -1, err = -1;
    bool cancelled = false;
    Worker worker;
    ~Running()
    {
        worker.stop();
        if (out >= 0) ::close(out);
        if (err >= 0) ::close(err);
    }
};

PartJobs::PartJobs(std::filesystem::path cli, std::filesystem::path workspace, int maxJobs)
    : cli_(std::move(cli)), workspace_(std::move(workspace)), maxJobs_(maxJobs)
{
}

PartJobs::~PartJobs()
{
    std::map<std::string, std::unique_ptr<Running>> all;
    {
        std::lock_guard lock(mutex_);
        all.swap(running_);
        for (auto& [part, run] : all)
            if (jobs_[part].state == JobState::Running && run->pid > 0) ::kill(run->pid, SIGTERM);
    }
    all.clear(); // each follower reaps its process (SIGKILL after 5 s) and ends
}

namespace {

/// The command line: nice 10, so the line's cycles come first (docs/workbench.md).
std::vector<std::string> commandLine(const std::filesystem::path& cli, const std::filesystem::path& workspace,
                                     const std::string& kind, const std::string& part,
                                     const std::vector<std::string>& args)
{
    std::vector<std::string> argv{"nice", "-n", "10", cli.string(), "part", kind, "--workspace", workspace.string(),
                                  part};
    argv.insert(argv.end(), args.begin(), args.end());
    return argv;
}

/// Spawns `argv` with its stdout and stderr on two pipes; the pid, or a failure naming why.
Result<pid_t> spawn(const std::vector<std::string>& argv, int& out, int& err)
{
    int o[2], e[2];
    if (::pipe2(o, O_CLOEXEC) != 0) return Status::failure(std::string("pipe: ") + std::strerror(errno));
    if (::pipe2(e, O_CLOEXEC) != 0) {
        ::close(o[0]);
        ::close(o[1]);
        return Status::failure(std::string("pipe: ") + std::strerror(errno));
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, o[1], 1);
    posix_spawn_file_actions_adddup2(&actions, e[1], 2);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = -1;
    const int rc = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(o[1]);
    ::close(e[1]);
    if (rc != 0) {
        ::close(o[0]);
        ::close(e[0]);
        return Status::failure("cannot start " + argv[3] + ": " + std::strerror(rc));
    }
    out = o[0];
    err = e[0];
    return pid;
}

} // namespace

CommandOutcome runPartCommand(const std::filesystem::path& cli, const std::filesystem::path& workspace,
                              const std::vector<std::string>& args, std::chrono::milliseconds deadline)
{
    CommandOutcome outcome;
    std::vector<std::string> argv{"nice", "-n",       "10",          cli.string(),
                                  "part", args.at(0), "--workspace", workspace.string()};
    argv.insert(argv.end(), args.begin() + 1, args.end());
    int fds[2] = {-1, -1};
    auto pid = spawn(argv, fds[0], fds[1]);
    if (!pid) {
        outcome.err = pid.message();
        return outcome;
    }
    std::string* text[2] = {&outcome.out, &outcome.err};
    bool open[2] = {true, true};
    const auto end = Clock::steady().now() + deadline;
    while (open[0] || open[1]) {
        if (Clock::steady().now() > end) {
            ::kill(pid.value(), SIGKILL);
            outcome.timedOut = true;
        }
        pollfd p[2] = {{open[0] ? fds[0] : -1, POLLIN, 0}, {open[1] ? fds[1] : -1, POLLIN, 0}};
        if (::poll(p, 2, 200) <= 0) continue;
        for (int k = 0; k < 2; ++k) {
            if (!(p[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
            char buffer[65536];
            const ssize_t n = ::read(fds[k], buffer, sizeof buffer);
            if (n > 0 && text[k]->size() < (64u << 20)) text[k]->append(buffer, static_cast<std::size_t>(n));
            if (n == 0 || (n < 0 && errno != EINTR && errno != EAGAIN)) open[k] = false;
        }
    }
    ::close(fds[0]);
    ::close(fds[1]);
    int status = 0;
    while (::waitpid(pid.value(), &status, 0) < 0 && errno == EINTR) {}
    if (WIFEXITED(status)) outcome.exitStatus = WEXITSTATUS(status);
    return outcome;
}

Status PartJobs::start(const std::string& part, const std::string& kind, const std::vector<std::string>& args,
                       const std::string& by)
{
    std::lock_guard lock(mutex_);
    int active = 0;
    for (const auto& [name, job] : jobs_) {
        if (job.state != JobState::Running) continue;
        if (name == part)
            return Status::failure(StatusCode::NotAllowed, "part " + part + " has a " + job.kind + " job running (" +
                                                               job.startedBy + ", " + job.startedAt +
                                                               "): wait for it or cancel it");
        ++active;
    }
    if (active >= maxJobs_)
        return Status::failure(StatusCode::NotAllowed, std::to_string(active) +
                                                           " workbench job(s) run on the station, at most " +
                                                           std::to_string(maxJobs_) + " (workbench.max_jobs)");
    running_.erase(part); // the last job's follower has ended: joined here
    auto run = std::make_unique<Running>();
    run->part = part;
    auto pid = spawn(commandLine(cli_, workspace_, kind, part, args), run->out, run->err);
    if (!pid) return pid.status();
    run->pid = pid.value();
    PartJob job;
    job.part = part;
    job.kind = kind;
    job.startedBy = by;
    job.startedAt = localTimestamp();
    jobs_[part] = job;
    hg::log::category("workbench")->info("{} of {} started by {} (pid {})", kind, part, by, run->pid);
    Running& r = *run;
    running_[part] = std::move(run);
    r.worker.start([this, &r](std::stop_token stop) { follow(r, stop); });
    return Status::success();
}

// One line of the command's stdout is a progress record; its stderr is kept for the message.
// False at the end of the pipe.
bool PartJobs::read(Running& run, int fd, std::string& pending, bool progress)
{
    char buffer[4096];
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0) return errno == EINTR || errno == EAGAIN;
    if (n == 0) return false;
    pending.append(buffer, static_cast<std::size_t>(n));
    for (auto eol = pending.find('\n'); eol != std::string::npos; eol = pending.find('\n')) {
        const std::string line = pending.substr(0, eol);
        pending.erase(0, eol + 1);
        const auto record = progress ? json::parse(line, nullptr, false) : json();
        std::lock_guard lock(mutex_);
        PartJob& job = jobs_[run.part];
        if (record.is_object() && record.contains("phase")) {
            job.phase = record.value("phase", job.phase);
            job.done = record.value("done", job.done);
            job.total = record.value("total", job.total);
        } else if (!line.empty()) {
            job.message = line.size() > 2000 ? line.substr(0, 2000) : line;
        }
    }
    if (pending.size() > 65536) pending.clear(); // a line without end: dropped, not kept growing
    return true;
}

// Reads the command's two pipes to their end, then reaps it. Asked to stop (the
// daemon ends), it sends SIGTERM, and SIGKILL after 5 s.
void PartJobs::follow(Running& run, std::stop_token stop)
{
    std::string pending[2];
    bool open[2] = {true, true};
    const int fds[2] = {run.out, run.err};
    std::optional<Clock::time_point> killAt;
    while (open[0] || open[1]) {
        if (stop.stop_requested() && !killAt) {
            ::kill(run.pid, SIGTERM);
            killAt = Clock::steady().now() + std::chrono::seconds(5);
        }
        if (killAt && Clock::steady().now() > *killAt) ::kill(run.pid, SIGKILL);
        pollfd p[2] = {{open[0] ? fds[0] : -1, POLLIN, 0}, {open[1] ? fds[1] : -1, POLLIN, 0}};
        if (::poll(p, 2, 200) <= 0) continue;
        for (int k = 0; k < 2; ++k)
            if (p[k].revents & (POLLIN | POLLHUP | POLLERR)) open[k] = read(run, fds[k], pending[k], k == 0);
    }
    int status = 0;
    while (::waitpid(run.pid, &status, 0) < 0 && errno == EINTR) {}
    std::lock_guard lock(mutex_);
    PartJob& job = jobs_[run.part];
    if (WIFEXITED(status)) job.exitStatus = WEXITSTATUS(status);
    const bool cancelled = run.cancelled || killAt.has_value();
    job.state = cancelled                                         ? JobState::Cancelled
                : job.exitStatus == 0                             ? JobState::Finished
                : job.kind == "commission" && job.exitStatus == 1 ? JobState::NotReleasable
                                                                  : JobState::Failed;
    if (WIFSIGNALED(status) && !cancelled) job.message = "ended by " + describeSignal(WTERMSIG(status));
    hg::log::category("workbench")
        ->info("{} of {} {} (exit {})", job.kind, job.part, enumName(job.state), job.exitStatus.value_or(-1));
}

std::optional<PartJob> PartJobs::job(const std::string& part) const
{
    std::lock_guard lock(mutex_);
    const auto it = jobs_.find(part);
    if (it == jobs_.end()) return std::nullopt;
    return it->second;
}

bool PartJobs::running(const std::string& part) const
{
    const auto j = job(part);
    return j && j->state == JobState::Running;
}

bool PartJobs::cancel(const std::string& part)
{
    std::lock_guard lock(mutex_);
    const auto it = running_.find(part);
    if (it == running_.end() || jobs_[part].state != JobState::Running) return false;
    it->second->cancelled = true;
    ::kill(it->second->pid, SIGTERM);
    hg::log::category("workbench")->info("{} of {} cancelled", jobs_[part].kind, part);
    return true;
}

} // namespace hg::daemon
