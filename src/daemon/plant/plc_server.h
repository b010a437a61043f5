// The Modbus TCP server the PLC talks to (docs/contracts.md §6), over libmodbus.
//
// One thread serves every client with poll(): a listening socket, up to
// `max_clients` non-blocking connections, and a wake-up pipe for stop(). Each
// connection assembles its own frames from the MBAP header's length, so a
// client that sends a request a byte at a time never holds up the others
// (docs/plc.md, "Connections"). A complete request is checked and answered by
// answerModbusRequest (unit id, function code, address range, values via
// PlcRegisters), a pure function of the request bytes and the registers that
// the server sends and the fuzzing harness calls (docs/fuzzing.md). A reply to
// FC03 is built from one snapshot taken under the register lock, so the PLC
// never reads a half-published result.
//
// Robustness: a connection from an address outside `allowed_clients` is
// closed at once; a malformed frame (bad protocol id, bad length) or a frame
// whose bytes straggle past `frame_timeout_s` closes that client only; a
// connection silent for `idle_timeout_s` is closed; when every slot is taken,
// the connection idle the longest (silent for `yield_after_s` or more) yields
// to the new one. Every other client keeps being served.
#pragma once

#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/worker.h"
#include "plant/plc_registers.h"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace hg::daemon {

/// The length of the first Modbus TCP frame in `data` (MBAP header + PDU, as
/// the header's length field delimits it, whatever the function code): 0 while
/// fewer bytes than that have come, -1 for a malformed header (protocol id not
/// 0, length outside 2..254).
int modbusFrameLength(const std::uint8_t* data, std::size_t size);

/// The reply frame to one complete request, and whether it is an exception.
struct ModbusAnswer {
    std::vector<std::uint8_t> frame;
    bool exception = false;
};

/// Answers one complete request of `length` bytes (modbusFrameLength's, at
/// least 8): reads or writes `registers`, builds the normal reply as Modbus TCP
/// frames it (Modbus application protocol 6.3, 6.6, 6.12, 6.21) or an
/// exception reply. No I/O.
ModbusAnswer answerModbusRequest(PlcRegisters& registers, int unitId, const std::uint8_t* req, int length);

class PlcServer {
  public:
    /// `clock` times the frame, idle and yield timeouts and the loop's turns.
    PlcServer(PlcRegisters& registers, station::PlcConfig config, Clock& clock = Clock::steady());
    ~PlcServer();
    PlcServer(const PlcServer&) = delete;
    PlcServer& operator=(const PlcServer&) = delete;

    /// Binds and listens (throws hg::FaultError naming address and port when
    /// that fails), then serves on its own thread until stop().
    void start();
    void stop();

    /// The bound port (the configured one, or the kernel's choice for port 0).
    int port() const { return port_; }
    /// The time on its clock (ns) of the serving loop's last turn, for the watchdog.
    std::int64_t lastLoopNs() const { return lastLoopNs_.load(); }
    /// Counters for the maintenance socket.
    struct Counters {
        std::uint64_t requests = 0;
        std::uint64_t exceptions = 0;
        std::uint64_t acceptedConnections = 0;
        std::uint64_t refusedConnections = 0;
        std::uint64_t droppedConnections = 0; ///< closed for a malformed or straggling frame, or a failed send
        std::uint64_t idleClosed = 0;         ///< closed after `idle_timeout_s` without a request
        std::uint64_t yielded = 0;            ///< idle connections closed to make room for a new one
        int clients = 0;
    };
    Counters counters() const;

  private:
    struct Connection;
    void serve(std::stop_token stop);
    void accept();
    bool allowed(std::uint32_t hostOrderAddress) const;
    /// Reads what `c` sent and answers every complete request; false when it must be closed.
    bool receive(Connection& c);
    /// Answers one complete request (MBAP header + PDU); false when the client must be closed.
    bool handle(Connection& c, const std::uint8_t* req, int length);
    /// Closes connections whose frame straggles or which stayed silent too long.
    void expire();
    void close(std::size_t index, const char* why);

    PlcRegisters& registers_;
    station::PlcConfig config_;
    Clock& clock_;
    struct Impl;
    Impl* impl_ = nullptr;
    int port_ = 0;
    std::atomic<std::int64_t> lastLoopNs_{0};
    Worker worker_; ///< serve(); last, so it ends before what it uses
};

} // namespace hg::daemon
