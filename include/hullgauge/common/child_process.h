// A piece of work run in a process of its own (docs/part-program.md, "STEP
// parts", "A process of its own"): a library that can fault on a damaged
// file (Open CASCADE's STEP translation) faults there, and the program that
// asked — the daemon loading a part program, the tool checking one — gets an
// outcome it can name instead of the signal.
#pragma once

#include <chrono>
#include <functional>
#include <string>

namespace hg {

/// What a function run by runInChild came to.
struct ChildOutcome {
    enum class Kind {
        finished,  ///< returned; `output` is what it returned
        signalled, ///< ended by a signal (`signal`), a fault in what it ran
        timedOut,  ///< still running at the deadline: killed
        failed,    ///< could not be run, or ended otherwise (`detail` says how)
    };
    Kind kind = Kind::failed;
    std::string output;
    int signal = 0;
    std::string detail;
};

/// Runs `work` in a child process forked from this one and returns what it
/// returned, or how it ended. The child shares nothing with this process
/// after the fork: it ends with _exit, running no exit handlers and flushing
/// nothing of the parent's; what `work` throws ends it as `failed`. The
/// parent waits at most `deadline`, then kills the child. The caller's
/// threads go on; only the calling thread waits.
ChildOutcome runInChild(const std::function<std::string()>& work, std::chrono::milliseconds deadline);

/// "signal 11 (Segmentation fault)".
std::string describeSignal(int signal);

} // namespace hg
