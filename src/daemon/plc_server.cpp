#include "plc_server.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <arpa/inet.h>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <mutex>
#include <netinet/in.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

namespace hg::daemon {
namespace {

using station::ModbusException;

constexpr int kHeader = 7; // MBAP header: transaction (2), protocol (2), length (2), unit (1)
constexpr std::uint8_t kGatewayTargetFailed = 0x0B;

std::int64_t nowNs()
{
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

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

} // namespace

struct PlcServer::Impl {
    modbus_t* ctx = nullptr;
    modbus_mapping_t* scratch = nullptr; // the reply buffer; never the source of truth
    int listenFd = -1;
    int wakeRead = -1;
    int wakeWrite = -1;
    std::vector<int> clients;
    mutable std::mutex countersMutex;
    Counters counters;
};

PlcServer::PlcServer(PlcRegisters& registers, station::PlcConfig config)
    : registers_(registers), config_(std::move(config))
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
    impl_->scratch = modbus_mapping_new_start_address(0, 0, 0, 0, 0, station::reg::Count, 0, 0);
    auto frameS = static_cast<std::uint32_t>(config_.frameTimeout.count() / 1000);
    auto frameUs = static_cast<std::uint32_t>((config_.frameTimeout.count() % 1000) * 1000);
    modbus_set_byte_timeout(impl_->ctx, frameS, frameUs);
    modbus_set_indication_timeout(impl_->ctx, frameS, frameUs);
    impl_->listenFd = modbus_tcp_listen(impl_->ctx, config_.maxClients);
    if (impl_->listenFd < 0) {
        std::string why = modbus_strerror(errno);
        stop();
        throw FaultError("plc: cannot listen on " + config_.bindAddress + ":" + std::to_string(config_.port) + ": " +
                         why);
    }
    fcntl(impl_->listenFd, F_SETFD, FD_CLOEXEC);
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
    running_ = true;
    lastLoopNs_ = nowNs();
    log->info("Modbus TCP server on {}:{}, unit id {}, {} allowed client networks", config_.bindAddress, port_,
              config_.unitId,
              config_.allowedClients.empty() ? std::string("any") : std::to_string(config_.allowedClients.size()));
    thread_ = std::thread([this] { serve(); });
}

void PlcServer::stop()
{
    if (!impl_) return;
    if (running_.exchange(false) && impl_->wakeWrite >= 0) {
        char c = 1;
        (void)!write(impl_->wakeWrite, &c, 1);
    }
    if (thread_.joinable()) thread_.join();
    for (int fd : impl_->clients) close(fd);
    if (impl_->listenFd >= 0) close(impl_->listenFd);
    if (impl_->wakeRead >= 0) close(impl_->wakeRead);
    if (impl_->wakeWrite >= 0) close(impl_->wakeWrite);
    if (impl_->scratch) modbus_mapping_free(impl_->scratch);
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

void PlcServer::serve()
{
    auto log = hg::log::category("plc");
    while (running_) {
        lastLoopNs_ = nowNs();
        fd_set readSet;
        FD_ZERO(&readSet);
        FD_SET(impl_->listenFd, &readSet);
        FD_SET(impl_->wakeRead, &readSet);
        int maxFd = std::max(impl_->listenFd, impl_->wakeRead);
        for (int fd : impl_->clients) {
            FD_SET(fd, &readSet);
            maxFd = std::max(maxFd, fd);
        }
        // Wake up at least twice a second so the watchdog sees the loop turn.
        timeval tv{0, 500'000};
        int n = select(maxFd + 1, &readSet, nullptr, nullptr, &tv);
        if (n < 0) {
            if (errno == EINTR) continue;
            log->error("select failed: {}", std::strerror(errno));
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            continue;
        }
        if (FD_ISSET(impl_->wakeRead, &readSet)) break;

        if (FD_ISSET(impl_->listenFd, &readSet)) {
            sockaddr_in addr{};
            socklen_t len = sizeof addr;
            int fd = accept4(impl_->listenFd, reinterpret_cast<sockaddr*>(&addr), &len, SOCK_CLOEXEC);
            if (fd >= 0) {
                std::lock_guard lock(impl_->countersMutex);
                auto who = peerText(fd);
                if (!allowed(ntohl(addr.sin_addr.s_addr))) {
                    log->warn("refused connection from {}: not in plc.allowed_clients", who);
                    ++impl_->counters.refusedConnections;
                    close(fd);
                } else if (static_cast<int>(impl_->clients.size()) >= config_.maxClients || fd >= FD_SETSIZE) {
                    log->warn("refused connection from {}: {} clients already connected", who, impl_->clients.size());
                    ++impl_->counters.refusedConnections;
                    close(fd);
                } else {
                    log->info("client {} connected", who);
                    impl_->clients.push_back(fd);
                    impl_->counters.clients = static_cast<int>(impl_->clients.size());
                }
            }
        }

        for (std::size_t i = 0; i < impl_->clients.size();) {
            int fd = impl_->clients[i];
            if (FD_ISSET(fd, &readSet) && !handle(fd)) {
                close(fd);
                impl_->clients.erase(impl_->clients.begin() + static_cast<std::ptrdiff_t>(i));
                std::lock_guard lock(impl_->countersMutex);
                impl_->counters.clients = static_cast<int>(impl_->clients.size());
                continue;
            }
            ++i;
        }
    }
}

bool PlcServer::handle(int fd)
{
    auto log = hg::log::category("plc");
    std::uint8_t req[MODBUS_TCP_MAX_ADU_LENGTH];
    modbus_set_socket(impl_->ctx, fd);
    int rc = modbus_receive(impl_->ctx, req);
    if (rc <= 0) {
        // -1: connection closed, frame timeout or a frame libmodbus cannot parse; 0: ignored.
        if (rc < 0) {
            if (errno == ECONNRESET || errno == 0 || errno == EBADF)
                log->info("client {} disconnected", peerText(fd));
            else
                log->warn("client {} dropped: {}", peerText(fd), modbus_strerror(errno));
            std::lock_guard lock(impl_->countersMutex);
            ++impl_->counters.droppedConnections;
            return false;
        }
        return true;
    }
    // libmodbus delimits TCP frames by function code, not by the MBAP length:
    // check the header ourselves so a forged frame cannot desynchronise the stream.
    if (rc < kHeader + 1 || be16(req + 2) != 0 || be16(req + 4) != rc - 6) {
        log->warn("client {} dropped: malformed MBAP header ({} bytes, protocol {}, length {})", peerText(fd), rc,
                  be16(req + 2), be16(req + 4));
        std::lock_guard lock(impl_->countersMutex);
        ++impl_->counters.droppedConnections;
        return false;
    }
    {
        std::lock_guard lock(impl_->countersMutex);
        ++impl_->counters.requests;
    }
    auto reject = [&](std::uint8_t code) {
        std::lock_guard lock(impl_->countersMutex);
        ++impl_->counters.exceptions;
        return modbus_reply_exception(impl_->ctx, req, code) >= 0;
    };
    const std::uint8_t unit = req[kHeader - 1];
    const std::uint8_t function = req[kHeader];
    if (unit != config_.unitId) {
        log->debug("request for unit {} (ours is {})", unit, config_.unitId);
        return reject(kGatewayTargetFailed);
    }
    const std::uint8_t* pdu = req + kHeader;
    switch (function) {
    case MODBUS_FC_READ_HOLDING_REGISTERS: {
        if (rc != kHeader + 5) return false;
        auto address = be16(pdu + 1);
        auto count = be16(pdu + 3);
        if (count < 1 || count > MODBUS_MAX_READ_REGISTERS) return reject(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        std::vector<std::uint16_t> values;
        if (registers_.read(address, count, values) != ModbusException::None)
            return reject(MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
        // One snapshot, taken under the register lock, is what the reply carries.
        std::copy(values.begin(), values.end(), impl_->scratch->tab_registers + address);
        log->trace("read {}+{}", address, count);
        return modbus_reply(impl_->ctx, req, rc, impl_->scratch) >= 0;
    }
    case MODBUS_FC_WRITE_SINGLE_REGISTER: {
        if (rc != kHeader + 5) return false;
        auto address = be16(pdu + 1);
        std::uint16_t value = be16(pdu + 3);
        auto ex = registers_.write(address, std::span<const std::uint16_t>(&value, 1));
        if (ex != ModbusException::None) return reject(static_cast<std::uint8_t>(ex));
        log->debug("write {} = {}", address, value);
        if (address >= station::reg::Count) return false; // cannot happen: write() refused it
        return modbus_reply(impl_->ctx, req, rc, impl_->scratch) >= 0;
    }
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS: {
        if (rc < kHeader + 6) return false;
        auto address = be16(pdu + 1);
        auto count = be16(pdu + 3);
        auto bytes = pdu[5];
        if (count < 1 || count > MODBUS_MAX_WRITE_REGISTERS || bytes != count * 2 || rc != kHeader + 6 + bytes)
            return reject(MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        std::vector<std::uint16_t> values(count);
        for (std::size_t i = 0; i < count; ++i) values[i] = be16(pdu + 6 + 2 * i);
        auto ex = registers_.write(address, values);
        if (ex != ModbusException::None) return reject(static_cast<std::uint8_t>(ex));
        log->debug("write {}+{}", address, count);
        return modbus_reply(impl_->ctx, req, rc, impl_->scratch) >= 0;
    }
    default:
        return reject(MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
    }
}

} // namespace hg::daemon
