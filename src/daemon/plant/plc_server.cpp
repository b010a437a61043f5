#include "plant/plc_server.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <algorithm>
#include <arpa/inet.h>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <fmt/format.h>
#include <modbus/modbus.h>
#include <mutex>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

#ifndef HULLGAUGE_VERSION
#define HULLGAUGE_VERSION "0"
#endif

namespace hg::daemon {
namespace {

using station::ModbusException;

constexpr int kHeader = 7;          // MBAP header: transaction (2), protocol (2), length (2), unit (1)
constexpr int kMaxMbapLength = 254; // unit id + the longest PDU (253 bytes)
constexpr std::uint8_t kGatewayTargetFailed = 0x0B;
constexpr std::uint8_t kEncapsulatedInterface = 0x2B;
constexpr std::uint8_t kReadDeviceIdentification = 0x0E;

std::uint16_t be16(const std::uint8_t* p)
{
    return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

std::string peerText(int fd)
{
    sockaddr_in addr{};
    socklen_t len = sizeof addr;
    if (getpeername(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return "?";
    char buf[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &addr.sin_addr, buf, sizeof buf);
    return std::string(buf) + ":" + std::to_string(ntohs(addr.sin_port));
}

/// At most one journal line per kind every 10 s: a scanner's thousand connects
/// are one line and a count, not two thousand lines (the counters keep every one).
class RateLimitedLog {
  public:
    template <class... Args> void warn(Clock::time_point now, fmt::format_string<Args...> f, Args&&... args)
    {
        if (now < next_) {
            ++suppressed_;
            return;
        }
        auto log = hg::log::category("plc");
        if (suppressed_ > 0) log->warn("({} similar messages in the last 10 s not shown)", suppressed_);
        log->warn(f, std::forward<Args>(args)...);
        suppressed_ = 0;
        next_ = now + std::chrono::seconds(10);
    }

  private:
    Clock::time_point next_{};
    std::uint64_t suppressed_ = 0;
};

/// The basic device identification objects (Modbus application protocol, 6.21):
/// vendor name, product code, major.minor revision.
const std::array<std::string, 3> kIdentification{"hullgauge", "hullgauged", HULLGAUGE_VERSION};

} // namespace

struct PlcServer::Connection {
    int fd = -1;
    std::string peer;
    std::vector<std::uint8_t> buffer; ///< bytes of the request being assembled
    Clock::time_point partialSince{}; ///< when the first byte of the pending request came
    Clock::time_point lastRequest{};  ///< when the last complete request came (or the connect)
};

struct PlcServer::Impl {
    modbus_t* ctx = nullptr;
    int listenFd = -1;
    int wakeRead = -1;
    int wakeWrite = -1;
    std::vector<Connection> clients;
    RateLimitedLog refusals;
    RateLimitedLog drops;
    mutable std::mutex countersMutex;
    Counters counters;
};

PlcServer::PlcServer(PlcRegisters& registers, station::PlcConfig config, Clock& clock)
    : registers_(registers), config_(std::move(config)), clock_(clock)
{
}

PlcServer::~PlcServer()
{
    stop();
}

void PlcServer::start()
{
    auto log = hg::log::category("plc");
    impl_ = new Impl;
    impl_->ctx = modbus_new_tcp(config_.bindAddress.c_str(), config_.port);
    if (!impl_->ctx)
        throw FaultError("plc: cannot create the Modbus TCP context: " + std::string(modbus_strerror(errno)));
    impl_->listenFd = modbus_tcp_listen(impl_->ctx, config_.maxClients);
    if (impl_->listenFd < 0) {
        std::string why = modbus_strerror(errno);
        stop();
        throw FaultError("plc: cannot listen on " + config_.bindAddress + ":" + std::to_string(config_.port) + ": " +
                         why);
    }
    fcntl(impl_->listenFd, F_SETFD, FD_CLOEXEC);
    fcntl(impl_->listenFd, F_SETFL, fcntl(impl_->listenFd, F_GETFL) | O_NONBLOCK);
    sockaddr_in bound{};
    socklen_t len = sizeof bound;
    getsockname(impl_->listenFd, reinterpret_cast<sockaddr*>(&bound), &len);
    port_ = ntohs(bound.sin_port);
    int pipeFds[2];
    if (pipe2(pipeFds, O_CLOEXEC | O_NONBLOCK) != 0) {
        stop();
        throw FaultError("plc: cannot create the wake-up pipe: " + std::string(std::strerror(errno)));
    }
    impl_->wakeRead = pipeFds[0];
    impl_->wakeWrite = pipeFds[1];
    lastLoopNs_ = clock_.nowNs();
    log->info("Modbus TCP server on {}:{}, unit id {}, {} allowed client networks", config_.bindAddress, port_,
              config_.unitId,
              config_.allowedClients.empty() ? std::string("any") : std::to_string(config_.allowedClients.size()));
    // The stop ends the poll through the wake-up pipe.
    worker_.start([this](std::stop_token stop) { serve(stop); },
                  [fd = impl_->wakeWrite] {
                      char c = 1;
                      (void)!write(fd, &c, 1);
                  });
}

void PlcServer::stop()
{
    if (!impl_) return;
    worker_.stop();
    for (const auto& c : impl_->clients) ::close(c.fd);
    if (impl_->listenFd >= 0) ::close(impl_->listenFd);
    if (impl_->wakeRead >= 0) ::close(impl_->wakeRead);
    if (impl_->wakeWrite >= 0) ::close(impl_->wakeWrite);
    if (impl_->ctx) modbus_free(impl_->ctx);
    delete impl_;
    impl_ = nullptr;
}

PlcServer::Counters PlcServer::counters() const
{
    if (!impl_) return {};
    std::lock_guard lock(impl_->countersMutex);
    return impl_->counters;
}

bool PlcServer::allowed(std::uint32_t hostOrderAddress) const
{
    if (config_.allowedClients.empty()) return true;
    for (const auto& net : config_.allowedClients)
        if (net.contains(hostOrderAddress)) return true;
    return false;
}

void PlcServer::serve(std::stop_token stop)
{
    auto log = hg::log::category("plc");
    std::vector<pollfd> fds;
    while (!stop.stop_requested()) {
        lastLoopNs_ = clock_.nowNs();
        fds.assign({{impl_->wakeRead, POLLIN, 0}, {impl_->listenFd, POLLIN, 0}});
        for (const auto& c : impl_->clients) fds.push_back({c.fd, POLLIN, 0});
        // Wake up at least every 100 ms: the watchdog sees the loop turn, and
        // straggling frames and idle connections are closed on time.
        int n = poll(fds.data(), fds.size(), 100);
        if (n < 0) {
            if (errno == EINTR) continue;
            log->error("poll failed: {}", std::strerror(errno));
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            continue;
        }
        if (fds[0].revents) break;
        // Clients first, in the order polled: an accept below may close one to make room.
        for (std::size_t i = impl_->clients.size(); i-- > 0;)
            if (fds[i + 2].revents && !receive(impl_->clients[i])) close(i, nullptr);
        if (fds[1].revents & POLLIN) accept();
        expire();
    }
}

void PlcServer::accept()
{
    sockaddr_in addr{};
    socklen_t len = sizeof addr;
    int fd = accept4(impl_->listenFd, reinterpret_cast<sockaddr*>(&addr), &len, SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (fd < 0) return;
    const auto now = clock_.now();
    const std::string who = peerText(fd);
    auto refuse = [&](const std::string& why) {
        impl_->refusals.warn(now, "refused connection from {}: {}", who, why);
        std::lock_guard lock(impl_->countersMutex);
        ++impl_->counters.refusedConnections;
        ::close(fd);
    };
    if (!allowed(ntohl(addr.sin_addr.s_addr))) return refuse("not in plc.allowed_clients");
    if (static_cast<int>(impl_->clients.size()) >= config_.maxClients) {
        // The connection silent the longest yields, if it has been silent long enough to be idle.
        auto oldest = std::min_element(impl_->clients.begin(), impl_->clients.end(),
                                       [](const auto& a, const auto& b) { return a.lastRequest < b.lastRequest; });
        if (oldest == impl_->clients.end() || now - oldest->lastRequest < config_.yieldAfter)
            return refuse(std::to_string(impl_->clients.size()) + " clients already connected, none idle");
        {
            std::lock_guard lock(impl_->countersMutex);
            ++impl_->counters.yielded;
        }
        close(static_cast<std::size_t>(oldest - impl_->clients.begin()), "idle, yields its slot to a new client");
    }
    hg::log::category("plc")->debug("client {} connected", who);
    impl_->clients.push_back({fd, who, {}, {}, now});
    std::lock_guard lock(impl_->countersMutex);
    ++impl_->counters.acceptedConnections;
    impl_->counters.clients = static_cast<int>(impl_->clients.size());
}

void PlcServer::close(std::size_t index, const char* why)
{
    auto& c = impl_->clients[index];
    if (why) hg::log::category("plc")->debug("client {} closed: {}", c.peer, why);
    ::close(c.fd);
    impl_->clients.erase(impl_->clients.begin() + static_cast<std::ptrdiff_t>(index));
    std::lock_guard lock(impl_->countersMutex);
    impl_->counters.clients = static_cast<int>(impl_->clients.size());
}

void PlcServer::expire()
{
    const auto now = clock_.now();
    for (std::size_t i = impl_->clients.size(); i-- > 0;) {
        const auto& c = impl_->clients[i];
        if (!c.buffer.empty() && now - c.partialSince > config_.frameTimeout) {
            impl_->drops.warn(now, "client {} dropped: request incomplete after {} ms ({} bytes)", c.peer,
                              config_.frameTimeout.count(), c.buffer.size());
            {
                std::lock_guard lock(impl_->countersMutex);
                ++impl_->counters.droppedConnections;
            }
            close(i, nullptr);
        } else if (now - c.lastRequest > config_.idleTimeout) {
            {
                std::lock_guard lock(impl_->countersMutex);
                ++impl_->counters.idleClosed;
            }
            close(i, "no request within plc.idle_timeout_s");
        }
    }
}

bool PlcServer::receive(Connection& c)
{
    std::uint8_t chunk[1024];
    const ssize_t n = recv(c.fd, chunk, sizeof chunk, MSG_DONTWAIT);
    if (n == 0) {
        hg::log::category("plc")->debug("client {} disconnected", c.peer);
        return false;
    }
    if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return true;
        hg::log::category("plc")->debug("client {} disconnected: {}", c.peer, std::strerror(errno));
        return false;
    }
    const auto now = clock_.now();
    if (c.buffer.empty()) c.partialSince = now;
    c.buffer.insert(c.buffer.end(), chunk, chunk + n);
    // The frame is delimited by the MBAP header's length, whatever the function code.
    for (int length; (length = modbusFrameLength(c.buffer.data(), c.buffer.size())) != 0;) {
        if (length < 0) {
            impl_->drops.warn(now, "client {} dropped: malformed MBAP header (protocol {}, length {})", c.peer,
                              be16(c.buffer.data() + 2), be16(c.buffer.data() + 4));
            std::lock_guard lock(impl_->countersMutex);
            ++impl_->counters.droppedConnections;
            return false;
        }
        c.lastRequest = now;
        if (!handle(c, c.buffer.data(), length)) return false;
        c.buffer.erase(c.buffer.begin(), c.buffer.begin() + length);
        c.partialSince = now;
    }
    return true;
}

namespace {

std::vector<std::uint8_t> exceptionFrame(const std::uint8_t* req, std::uint8_t code)
{
    // A function code with the top bit already set keeps it (0x83 answers 0x83, never 0x03).
    return {req[0], req[1], 0, 0, 0, 3, req[6], static_cast<std::uint8_t>(req[7] | 0x80), code};
}

/// The request's transaction and unit id around `pdu`.
std::vector<std::uint8_t> replyFrame(const std::uint8_t* req, const std::vector<std::uint8_t>& pdu)
{
    std::vector<std::uint8_t> frame(kHeader + pdu.size());
    frame[0] = req[0];
    frame[1] = req[1];
    frame[4] = static_cast<std::uint8_t>((pdu.size() + 1) >> 8);
    frame[5] = static_cast<std::uint8_t>(pdu.size() + 1);
    frame[6] = req[6];
    std::copy(pdu.begin(), pdu.end(), frame.begin() + kHeader);
    return frame;
}

ModbusAnswer deviceIdentification(const std::uint8_t* req, int length)
{
    // Request PDU: 2B 0E <read device id code> <object id>.
    if (length != kHeader + 4) return {exceptionFrame(req, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE), true};
    const std::uint8_t code = req[kHeader + 2];
    std::uint8_t first = req[kHeader + 3];
    if (code < 1 || code > 4) return {exceptionFrame(req, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE), true};
    if (code == 4 && first >= kIdentification.size())
        return {exceptionFrame(req, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS), true};
    // Basic conformity with stream and individual access (0x81); the regular and
    // extended codes answer the basic objects, as a basic device must.
    if (code != 4 && first >= kIdentification.size()) first = 0;
    const std::size_t last = code == 4 ? first + 1u : kIdentification.size();
    std::vector<std::uint8_t> pdu{kEncapsulatedInterface,
                                  kReadDeviceIdentification,
                                  code,
                                  0x81,
                                  0x00,
                                  0x00,
                                  static_cast<std::uint8_t>(last - first)};
    for (std::size_t id = first; id < last; ++id) {
        pdu.push_back(static_cast<std::uint8_t>(id));
        pdu.push_back(static_cast<std::uint8_t>(kIdentification[id].size()));
        pdu.insert(pdu.end(), kIdentification[id].begin(), kIdentification[id].end());
    }
    return {replyFrame(req, pdu), false};
}

} // namespace

int modbusFrameLength(const std::uint8_t* data, std::size_t size)
{
    if (size < 6) return 0;
    const int length = be16(data + 4);
    if (be16(data + 2) != 0 || length < 2 || length > kMaxMbapLength) return -1;
    return size < static_cast<std::size_t>(6 + length) ? 0 : 6 + length;
}

ModbusAnswer answerModbusRequest(PlcRegisters& registers, int unitId, const std::uint8_t* req, int length)
{
    auto log = hg::log::category("plc");
    const std::uint8_t unit = req[kHeader - 1];
    const std::uint8_t function = req[kHeader];
    auto exception = [&](std::uint8_t code) { return ModbusAnswer{exceptionFrame(req, code), true}; };
    if (unit != unitId) {
        log->debug("request for unit {} (ours is {})", unit, unitId);
        return exception(kGatewayTargetFailed);
    }
    const std::uint8_t* pdu = req + kHeader;
    switch (function) {
    case MODBUS_FC_READ_HOLDING_REGISTERS: {
        if (length != kHeader + 5) return exception(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        auto address = be16(pdu + 1);
        auto count = be16(pdu + 3);
        if (count < 1 || count > MODBUS_MAX_READ_REGISTERS) return exception(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        std::vector<std::uint16_t> values;
        if (registers.read(address, count, values) != ModbusException::None)
            return exception(MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
        // One snapshot, taken under the register lock, is what the reply carries.
        std::vector<std::uint8_t> reply{MODBUS_FC_READ_HOLDING_REGISTERS, static_cast<std::uint8_t>(2 * count)};
        for (std::uint16_t v : values) {
            reply.push_back(static_cast<std::uint8_t>(v >> 8));
            reply.push_back(static_cast<std::uint8_t>(v));
        }
        log->trace("read {}+{}", address, count);
        return {replyFrame(req, reply), false};
    }
    case MODBUS_FC_WRITE_SINGLE_REGISTER: {
        if (length != kHeader + 5) return exception(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        auto address = be16(pdu + 1);
        std::uint16_t value = be16(pdu + 3);
        auto ex = registers.write(address, std::span<const std::uint16_t>(&value, 1));
        if (ex != ModbusException::None) return exception(static_cast<std::uint8_t>(ex));
        log->debug("write {} = {}", address, value);
        return {std::vector<std::uint8_t>(req, req + length), false}; // the echo of the request
    }
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS: {
        if (length < kHeader + 6) return exception(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        auto address = be16(pdu + 1);
        auto count = be16(pdu + 3);
        auto bytes = pdu[5];
        if (count < 1 || count > MODBUS_MAX_WRITE_REGISTERS || bytes != count * 2 || length != kHeader + 6 + bytes)
            return exception(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        std::vector<std::uint16_t> values(count);
        for (std::size_t i = 0; i < count; ++i) values[i] = be16(pdu + 6 + 2 * i);
        auto ex = registers.write(address, values);
        if (ex != ModbusException::None) return exception(static_cast<std::uint8_t>(ex));
        log->debug("write {}+{}", address, count);
        return {replyFrame(req, {MODBUS_FC_WRITE_MULTIPLE_REGISTERS, pdu[1], pdu[2], pdu[3], pdu[4]}), false};
    }
    case kEncapsulatedInterface:
        if (length > kHeader + 1 && pdu[1] == kReadDeviceIdentification) return deviceIdentification(req, length);
        return exception(MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
    default:
        return exception(MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
    }
}

bool PlcServer::handle(Connection& c, const std::uint8_t* req, int length)
{
    const ModbusAnswer answer = answerModbusRequest(registers_, config_.unitId, req, length);
    {
        std::lock_guard lock(impl_->countersMutex);
        ++impl_->counters.requests;
        if (answer.exception) ++impl_->counters.exceptions;
    }
    // Non-blocking: a client that does not read its answers is closed rather than stalling the loop.
    return send(c.fd, answer.frame.data(), answer.frame.size(), MSG_NOSIGNAL | MSG_DONTWAIT) ==
           static_cast<ssize_t>(answer.frame.size());
}

} // namespace hg::daemon
