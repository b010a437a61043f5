#include "daemon_socket.h"

#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

namespace hg::cli {

std::string daemonSocketPath(const std::string& given)
{
    if (!given.empty()) return given;
    if (const char* env = std::getenv("HULLGAUGE_SOCKET"); env && *env) return env;
    return kDefaultSocket;
}

nlohmann::json daemonAnswer(const std::string& path, const nlohmann::json& req)
{
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof addr.sun_path) throw InputError("", "--socket", "path longer than 107 bytes");
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) throw FaultError(std::string("socket: ") + std::strerror(errno));
    timeval tv{10, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        std::string why = std::strerror(errno);
        close(fd);
        throw FaultError("cannot reach the daemon at " + path + ": " + why +
                         " (is hullgauged running? use --socket or $HULLGAUGE_SOCKET)");
    }
    auto text = req.dump() + "\n";
    if (write(fd, text.data(), text.size()) != static_cast<ssize_t>(text.size())) {
        close(fd);
        throw FaultError("cannot send to the daemon at " + path);
    }
    std::string answer;
    char buf[4096];
    ssize_t n;
    while ((n = read(fd, buf, sizeof buf)) > 0) answer.append(buf, static_cast<std::size_t>(n));
    close(fd);
    auto j = nlohmann::json::parse(answer, nullptr, false);
    if (j.is_discarded() || !j.is_object()) throw FaultError("the daemon at " + path + " sent no valid answer");
    return j;
}

nlohmann::json daemonRequest(const std::string& path, const nlohmann::json& req)
{
    auto j = daemonAnswer(path, req);
    if (!j.value("ok", false)) throw FaultError("daemon: " + j.value("error", std::string("request failed")));
    return j;
}

nlohmann::json followJob(const std::string& path, const nlohmann::json& poll, const std::string& key,
                         const std::string& what, double waitS,
                         const std::function<void(const nlohmann::json&)>& progress)
{
    Clock& clock = Clock::steady();
    const auto deadline =
        clock.now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(waitS));
    while (true) {
        auto job = daemonRequest(path, poll)[key];
        if (progress) progress(job);
        const auto state = job.value("state", std::string());
        if (state == "done") return job;
        if (state == "failed") throw FaultError(job.value("error", what + " failed"));
        if (clock.now() > deadline)
            throw FaultError(what + " still " + state + " after --wait-timeout; follow it with ctl status");
        clock.sleepUntil(clock.now() + std::chrono::milliseconds(200), [] { return false; });
    }
}

} // namespace hg::cli
