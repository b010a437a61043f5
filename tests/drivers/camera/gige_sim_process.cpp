#include "gige_sim_process.h"

#include <fcntl.h>
#include <net/if.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "hgtest/paths.h"

namespace hgtest {

std::string isolateNetwork()
{
    if (::unshare(CLONE_NEWNET) != 0) {
        // Unprivileged: a user namespace grants CAP_NET_ADMIN over a new network namespace.
        if (::unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0)
            return std::string("cannot create a network namespace: ") + std::strerror(errno);
    }
    int s = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (s < 0) return std::string("socket: ") + std::strerror(errno);
    ifreq ifr{};
    std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
    bool ok = ::ioctl(s, SIOCGIFFLAGS, &ifr) == 0;
    ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP);
    ok = ok && ::ioctl(s, SIOCSIFFLAGS, &ifr) == 0;
    std::string err = ok ? "" : std::string("cannot bring loopback up: ") + std::strerror(errno);
    ::close(s);
    return err;
}

GigeSim::~GigeSim()
{
    if (pid_ > 0) kill();
    std::error_code ec;
    if (!errFile_.empty()) std::filesystem::remove(errFile_, ec);
}

void GigeSim::start(const std::vector<std::string>& args, int timeoutMs)
{
    if (pid_ > 0) throw std::runtime_error("simulator already running");
    const auto program = binaryDir() / "bin" / "hullgauge-gige-sim";
    errFile_ = std::filesystem::temp_directory_path() / ("hullgauge-gige-sim-" + std::to_string(::getpid()) + ".err");
    // Everything the child needs is prepared before fork: the parent may have
    // Aravis threads running, and the child must not allocate.
    std::vector<std::string> argv{program.string()};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    int err = ::open(errFile_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    int out[2];
    if (err < 0 || ::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("cannot create pipes for the simulator");
    pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        ::dup2(out[1], STDOUT_FILENO);
        ::dup2(err, STDERR_FILENO);
        ::execv(cargv[0], cargv.data());
        ::_exit(127);
    }
    ::close(err);
    ::close(out[1]);
    pid_ = pid;
    std::string line;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeoutMs);
    bool ready = false;
    while (!ready) {
        auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) break;
        pollfd p{out[0], POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
        char c;
        ssize_t n = ::read(out[0], &c, 1);
        if (n <= 0) break;
        if (c == '\n')
            ready = line.rfind("ready ", 0) == 0;
        else
            line += c;
        if (c == '\n' && !ready) line.clear();
    }
    ::close(out[0]);
    if (!ready) {
        kill();
        std::ifstream e(errFile_);
        std::stringstream ss;
        ss << e.rdbuf();
        throw std::runtime_error("hullgauge-gige-sim did not become ready: " + ss.str());
    }
    ready_ = line;
}

void GigeSim::kill()
{
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
}

void GigeSim::stop()
{
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    for (int i = 0; i < 50; ++i) {
        if (::waitpid(pid_, nullptr, WNOHANG) == pid_) {
            pid_ = -1;
            return;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    kill();
}

} // namespace hgtest
