// hullgauge-fixture-sim — the Modbus fixture simulator (docs/fixture.md).
// Serves the fixture drive's register map of a station YAML over Modbus TCP on
// a loopback address or RTU on a serial device/PTY, until SIGTERM or SIGINT.
#include "fixture_server.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>

namespace {

volatile std::sig_atomic_t stopRequested = 0;

extern "C" void onSignal(int)
{
    stopRequested = 1;
}

} // namespace

int main(int argc, char** argv)
{
    CLI::App app{"hullgauge-fixture-sim: Modbus fixture simulator (rotation/declination fixture or rail stage)"};
    std::string station;
    hg::fixturesim::ServerOptions options;
    int fault = 0;
    std::string logSpec = "info";
    app.add_option("--station", station, "station YAML whose fixture.driver section holds the register map")
        ->required();
    auto* tcp = app.add_option("--tcp-port", options.tcpPort, "serve Modbus TCP on this port (0: any free port)")
                    ->check(CLI::Range(0, 65535));
    auto* rtu = app.add_option("--rtu", options.rtuDevice, "serve Modbus RTU on this serial device or PTY");
    tcp->excludes(rtu);
    app.add_option("--host", options.host, "address to listen on (default 127.0.0.1)");
    app.add_option("--control-port", options.controlPort,
                   "Modbus TCP port of the simulator-control registers (0: any free port, -1: none)")
        ->check(CLI::Range(-1, 65535));
    app.add_option("--fault", fault, "initial fault mode 0..5 (see docs/fixture.md)")->check(CLI::Range(0, 5));
    app.add_option("--ready-file", options.readyFile, "write 'port=N' and 'control_port=M' here once listening");
    app.add_option("--log", logSpec, "log levels, e.g. 'info' or 'warn,fixture-sim=debug'");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int rc = app.exit(e);
        return rc == 0 ? 0 : static_cast<int>(hg::ExitStatus::BadInput);
    }
    if (options.tcpPort < 0 && options.rtuDevice.empty()) {
        std::cerr << "hullgauge-fixture-sim: give --tcp-port PORT or --rtu DEVICE\n";
        return static_cast<int>(hg::ExitStatus::BadInput);
    }
    options.initialFault = static_cast<hg::drivers::SimulatedFault>(fault);

    struct sigaction sa {};
    sa.sa_handler = onSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    std::signal(SIGPIPE, SIG_IGN);

    try {
        hg::log::configure(logSpec);
        auto stationData = hg::geometry::loadStation(station);
        hg::fixturesim::FixtureServer server(stationData, options);
        if (options.rtuDevice.empty())
            std::cout << "listening on " << options.host << ":" << server.tcpPort();
        else
            std::cout << "serving RTU on " << options.rtuDevice;
        if (server.controlPort() >= 0) std::cout << ", control port " << server.controlPort();
        std::cout << std::endl;
        server.run(stopRequested);
    } catch (const hg::InputError& e) {
        std::cerr << "hullgauge-fixture-sim: " << e.what() << '\n';
        return static_cast<int>(hg::ExitStatus::BadInput);
    } catch (const hg::FaultError& e) {
        std::cerr << "hullgauge-fixture-sim: " << e.what() << '\n';
        return static_cast<int>(hg::ExitStatus::Fault);
    } catch (const std::exception& e) {
        std::cerr << "hullgauge-fixture-sim: internal error: " << e.what() << '\n';
        return static_cast<int>(hg::ExitStatus::Fault);
    }
    return 0;
}
