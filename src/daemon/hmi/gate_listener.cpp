#include "hmi/gate_listener.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"

#include <algorithm>
#include <arpa/inet.h>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <memory>
#include <netinet/in.h>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <spdlog/fmt/fmt.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>
#include <vector>

namespace hg::daemon {
namespace {

struct Pending {
    int fd = -1;
    RequestGate gate;
    Clock::time_point deadline;
    std::string ip;
    int port = 0;
    /// Answered with a refusal: what the client still sends is read and
    /// dropped (up to kDrainBytes, until the deadline) before the close, so
    /// the close does not reset the connection before the answer is read.
    bool draining = false;
    std::size_t drained = 0;
    /// An upload's deadline was extended for its size (once, when its head was read).
    bool uploadTimed = false;
};

constexpr std::size_t kDrainBytes = 1 << 20;
constexpr std::chrono::seconds kDrainTime{2};

std::string_view reasonPhrase(int status)
{
    switch (status) {
    case 400:
        return "Bad Request";
    case 403:
        return "Forbidden";
    case 405:
        return "Method Not Allowed";
    case 408:
        return "Request Timeout";
    case 413:
        return "Content Too Large";
    case 417:
        return "Expectation Failed";
    case 421:
        return "Misdirected Request";
    case 431:
        return "Request Header Fields Too Large";
    case 501:
        return "Not Implemented";
    default:
        return "Error";
    }
}

/// The gate's own answer, as the HMI answers every refusal (docs/hmi.md): a JSON
/// error, the connection closed. Written without blocking: a client that does
/// not read it loses it, the listener does not wait for it.
void answerRefusal(int fd, int status, const std::string& reason)
{
    // The reason may quote what the client sent (its Host, its Origin), which need not be UTF-8.
    const std::string body = dumpJson({{"error", reason}});
    std::string out = fmt::format("HTTP/1.1 {} {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n"
                                  "Connection: close\r\nX-Content-Type-Options: nosniff\r\n",
                                  status, reasonPhrase(status), body.size());
    if (status == 405) out += fmt::format("Allow: {}\r\n", RequestGate::kAllowedMethods);
    out += "\r\n" + body;
    (void)::send(fd, out.data(), out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    ::shutdown(fd, SHUT_WR);
}

void peerOf(int fd, std::string& ip, int& port)
{
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if (::getpeername(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return;
    char text[INET6_ADDRSTRLEN] = {};
    if (addr.ss_family == AF_INET) {
        const auto* a = reinterpret_cast<const sockaddr_in*>(&addr);
        ::inet_ntop(AF_INET, &a->sin_addr, text, sizeof text);
        port = ntohs(a->sin_port);
    } else if (addr.ss_family == AF_INET6) {
        const auto* a = reinterpret_cast<const sockaddr_in6*>(&addr);
        ::inet_ntop(AF_INET6, &a->sin6_addr, text, sizeof text);
        port = ntohs(a->sin6_port);
    }
    ip = text;
}

} // namespace

GateListener::GateListener(int listenFd, Options options, Answer answer, Clock& clock)
    : listenFd_(listenFd), options_(std::move(options)), answer_(std::move(answer)), clock_(clock)
{
    wakeFd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (wakeFd_ < 0) throw FaultError(std::string("web HMI: eventfd: ") + std::strerror(errno));
    ::fcntl(listenFd_, F_SETFL, ::fcntl(listenFd_, F_GETFL) | O_NONBLOCK);
    worker_.start([this](std::stop_token stop) { run(stop); },
                  [this] {
                      const std::uint64_t one = 1;
                      (void)!::write(wakeFd_, &one, sizeof one);
                  });
}

GateListener::~GateListener()
{
    stop();
    if (wakeFd_ >= 0) ::close(wakeFd_);
}

void GateListener::stop()
{
    worker_.stop();
}

void GateListener::run(std::stop_token stop)
{
    std::vector<std::unique_ptr<Pending>> pending;
    const auto close = [&](std::size_t k) {
        ::close(pending[k]->fd);
        pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(k));
    };
    char buffer[16384];
    while (!stop.stop_requested()) {
        std::vector<pollfd> fds{{listenFd_, POLLIN, 0}, {wakeFd_, POLLIN, 0}};
        for (const auto& p : pending) fds.push_back({p->fd, POLLIN, 0});
        (void)::poll(fds.data(), fds.size(), 100);
        if (stop.stop_requested()) break;
        // Deadlines first: a request not whole within the timeout is answered 408.
        const auto now = clock_.now();
        for (std::size_t k = pending.size(); k-- > 0;) {
            if (now < pending[k]->deadline) continue;
            if (!pending[k]->draining) {
                answerRefusal(pending[k]->fd, 408,
                              fmt::format("the request was not whole within {} s (http.request_timeout_s)",
                                          options_.requestTimeout.count() / 1000.0));
                ++refused_;
            }
            close(k);
            fds.erase(fds.begin() + 2 + static_cast<std::ptrdiff_t>(k));
        }
        for (std::size_t k = pending.size(); k-- > 0;) {
            if (!(fds[2 + k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
            Pending& p = *pending[k];
            const ssize_t n = ::recv(p.fd, buffer, sizeof buffer, MSG_DONTWAIT);
            if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
                close(k);
                continue;
            }
            if (n < 0) continue;
            if (p.draining) {
                p.drained += static_cast<std::size_t>(n);
                if (p.drained > kDrainBytes) close(k);
                continue;
            }
            const RequestGate::State state = p.gate.feed(std::string_view(buffer, static_cast<std::size_t>(n)));
            if (p.gate.takeContinue()) (void)::send(p.fd, "HTTP/1.1 100 Continue\r\n\r\n", 25, MSG_NOSIGNAL);
            if (!p.uploadTimed && p.gate.uploadBytes() > 0) {
                // A CAD upload may take longer than a request: its size at the slowest rate the plant network is
                // expected to carry (docs/workbench.md), on top of request_timeout_s.
                p.deadline += std::chrono::milliseconds(p.gate.uploadBytes() * 1000 / options_.uploadBytesPerSecond);
                p.uploadTimed = true;
            }
            if (state == RequestGate::State::Refused) {
                answerRefusal(p.fd, p.gate.status(), p.gate.reason());
                ++refused_;
                p.draining = true;
                p.deadline = clock_.now() + kDrainTime;
            } else if (state == RequestGate::State::Complete) {
                ::fcntl(p.fd, F_SETFL, ::fcntl(p.fd, F_GETFL) & ~O_NONBLOCK);
                answer_(GatedRequest{p.fd, p.gate.request(), p.ip, p.port});
                pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(k));
            }
        }
        // New connections, each with its deadline; at the bound the longest-waiting request makes room.
        for (int accepted = 0; accepted < 64; ++accepted) {
            const int fd = ::accept4(listenFd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
            if (fd < 0) break;
            if (pending.size() >= options_.maxPending) {
                if (!pending.front()->draining) {
                    answerRefusal(pending.front()->fd, 408,
                                  "too many requests in progress; the longest-waiting is closed");
                    ++refused_;
                }
                close(0);
            }
            auto p = std::make_unique<Pending>(
                Pending{fd, RequestGate(options_.limits), clock_.now() + options_.requestTimeout, {}, 0});
            peerOf(fd, p->ip, p->port);
            pending.push_back(std::move(p));
        }
    }
    for (auto& p : pending) ::close(p->fd);
}

} // namespace hg::daemon
