// docs/part-program.md, "A process of its own".
#include "hullgauge/common/child_process.h"
#include "hullgauge/common/clock.h"

#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <string_view>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <spdlog/fmt/fmt.h>

namespace hg {

namespace {

// The child's side: the work's result written whole to the pipe, then
// _exit (no exit handlers, no flushing of buffers copied from the parent).
[[noreturn]] void serveInChild(const std::function<std::string()>& work, int out)
{
    int status = 0;
    try {
        const std::string result = work();
        std::string_view rest = result;
        while (!rest.empty()) {
            const ssize_t n = ::write(out, rest.data(), rest.size());
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                status = 3;
                break;
            }
            rest.remove_prefix(static_cast<std::size_t>(n));
        }
    } catch (...) {
        status = 2;
    }
    ::_exit(status);
}

// The parent's side: reads the pipe to its end or to the deadline.
bool readUntilEnd(int in, Clock::time_point deadline, std::string& output)
{
    char buffer[65536];
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::steady().now());
        if (left.count() <= 0) return false;
        pollfd fd{in, POLLIN, 0};
        const int ready = ::poll(&fd, 1, static_cast<int>(std::min<long long>(left.count(), 60'000)));
        if (ready < 0 && errno != EINTR) return false;
        if (ready <= 0) continue;
        const ssize_t n = ::read(in, buffer, sizeof buffer);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return true; // the end: the child closed its side (or ended)
        output.append(buffer, static_cast<std::size_t>(n));
    }
}

int waitFor(pid_t pid)
{
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    return status;
}

} // namespace

ChildOutcome runInChild(const std::function<std::string()>& work, std::chrono::milliseconds deadline)
{
    ChildOutcome outcome;
    int pipeEnds[2];
    if (::pipe2(pipeEnds, O_CLOEXEC) != 0) {
        outcome.detail = fmt::format("no pipe: {}", std::strerror(errno));
        return outcome;
    }
    // poll() waits on the child in real time: the steady clock's deadline.
    const auto until = Clock::steady().now() + deadline;
    const pid_t pid = ::fork();
    if (pid < 0) {
        outcome.detail = fmt::format("no child process: {}", std::strerror(errno));
        ::close(pipeEnds[0]);
        ::close(pipeEnds[1]);
        return outcome;
    }
    if (pid == 0) {
        ::close(pipeEnds[0]);
        serveInChild(work, pipeEnds[1]);
    }
    ::close(pipeEnds[1]);
    const bool ended = readUntilEnd(pipeEnds[0], until, outcome.output);
    ::close(pipeEnds[0]);
    if (!ended) ::kill(pid, SIGKILL);
    const int status = waitFor(pid);
    if (!ended) {
        outcome.kind = ChildOutcome::Kind::timedOut;
        outcome.output.clear();
    } else if (WIFSIGNALED(status)) {
        outcome.kind = ChildOutcome::Kind::signalled;
        outcome.signal = WTERMSIG(status);
        outcome.output.clear();
    } else if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        outcome.kind = ChildOutcome::Kind::finished;
    } else {
        outcome.detail =
            WIFEXITED(status) && WEXITSTATUS(status) == 2
                ? std::string("the work threw")
                : fmt::format("the child ended with status {}", WIFEXITED(status) ? WEXITSTATUS(status) : -1);
        outcome.output.clear();
    }
    return outcome;
}

std::string describeSignal(int signal)
{
    const char* name = ::strsignal(signal);
    return fmt::format("signal {} ({})", signal, name ? name : "unknown");
}

} // namespace hg
