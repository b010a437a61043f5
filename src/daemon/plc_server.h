// The Modbus TCP server the PLC talks to (CONTRACTS §6), over libmodbus.
//
// One thread serves every client with select(): a listening socket, up to
// `max_clients` connections, and a wake-up pipe for stop(). Each request is
// parsed by libmodbus (modbus_receive), checked here (unit id, function code,
// address range, values via PlcRegisters) and answered with modbus_reply or
// modbus_reply_exception. A reply to FC03 is built from one snapshot taken
// under the register lock, so the PLC never reads a half-published result.
//
// Robustness: a connection from an address outside `allowed_clients` is
// closed at once; a malformed frame (bad protocol id, bad length) or a frame
// whose bytes straggle past `frame_timeout_s` closes that client only; every
// other client keeps being served and new clients are accepted.
#pragma once

#include "daemon_config.h"
#include "plc_registers.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace hg::daemon {

class PlcServer {
  public:
    PlcServer(PlcRegisters& registers, station::PlcConfig config);
    ~PlcServer();
    PlcServer(const PlcServer&) = delete;
    PlcServer& operator=(const PlcServer&) = delete;

    /// Binds and listens (throws hg::FaultError naming address and port when
    /// that fails), then serves on its own thread until stop().
    void start();
    void stop();

    /// The bound port (the configured one, or the kernel's choice for port 0).
    int port() const { return port_; }
    /// Monotonic time (ns) of the serving loop's last turn, for the watchdog.
    std::int64_t lastLoopNs() const { return lastLoopNs_.load(); }
    /// Counters for the maintenance socket.
    struct Counters {
        std::uint64_t requests = 0;
        std::uint64_t exceptions = 0;
        std::uint64_t refusedConnections = 0;
        std::uint64_t droppedConnections = 0;
        int clients = 0;
    };
    Counters counters() const;

  private:
    void serve();
    bool allowed(std::uint32_t hostOrderAddress) const;
    /// Handles one request on `fd`; false when the client must be closed.
    bool handle(int fd);

    PlcRegisters& registers_;
    station::PlcConfig config_;
    struct Impl;
    Impl* impl_ = nullptr;
    int port_ = 0;
    std::thread thread_;
    std::atomic<bool> running_{false};
    std::atomic<std::int64_t> lastLoopNs_{0};
};

} // namespace hg::daemon
