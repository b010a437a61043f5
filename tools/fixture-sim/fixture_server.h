// The Modbus fixture simulator: a libmodbus server that serves the fixture
// drive's register map (fixture.driver.registers of a station YAML) over TCP on
// a loopback address or RTU on a serial device, moves its axes with the shared
// motion model (drivers/fixture/simulated_drive.h), and injects the faults of
// docs/fixture.md. A second Modbus TCP port carries the simulator-control
// registers, so faults are switched at run time without touching the device
// channel the driver under test uses.
#pragma once

#include "hullgauge/drivers/simulation.h"
#include "hullgauge/geometry/station.h"

#include <atomic>
#include <csignal>
#include <filesystem>
#include <memory>
#include <string>

namespace hg::fixturesim {

/// Holding registers of the control port (0-based), documented in docs/fixture.md.
enum ControlRegister : int {
    kFaultMode = 0,      ///< rw: SimulatedFault value 0..5
    kExceptionCode = 1,  ///< rw: exception code answered in fault mode 2 (1..255, default 4)
    kDriveFaultCode = 2, ///< rw: fault code latched in fault mode 5 (1..65535, default 17)
    kMovesCompleted = 3, ///< ro: moves and homings that ended in position
    kRequestsServed = 4, ///< ro: device requests answered (low 16 bits)
    kConnections = 5,    ///< ro: device connections accepted (low 16 bits)
    kControlRegisterCount = 6,
};

struct ServerOptions {
    std::string host = "127.0.0.1";
    int tcpPort = -1;      ///< device channel on TCP (0 = any free port); -1 when RTU
    std::string rtuDevice; ///< device channel on RTU (serial device or PTY)
    int controlPort = 0;   ///< control channel (0 = any free port; -1 = none)
    drivers::SimulatedFault initialFault = drivers::SimulatedFault::None;
    std::filesystem::path readyFile; ///< written ("port=N\ncontrol_port=M\n") once listening
};

class FixtureServer {
  public:
    /// Validates the station's fixture.driver section (InputError on bad maps)
    /// and opens the channels (FaultError when a port or device cannot be opened).
    FixtureServer(const geometry::Station& station, const ServerOptions& options);
    ~FixtureServer();
    FixtureServer(const FixtureServer&) = delete;
    FixtureServer& operator=(const FixtureServer&) = delete;

    int tcpPort() const;
    int controlPort() const;

    /// Serves until `stop` becomes non-zero (checked at least every 10 ms).
    void run(const volatile std::sig_atomic_t& stop);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace hg::fixturesim
