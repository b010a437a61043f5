#include "fixture_server.h"

#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "modbus/modbus_link.h"
#include "modbus/register_map.h"
#include "simulated_drive.h"

#include <algorithm>
#include <arpa/inet.h>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <vector>

namespace hg::fixturesim {
namespace {

using drivers::SimulatedFault;
using drivers::fixture::RegisterMap;
using drivers::fixture::SimulatedDrive;

constexpr std::size_t kMaxClients = 16;
constexpr int kPollMs = 10;

// The simulated drive moves on the one steady clock every part of the station reads (docs/style.md point 9).
double steadySeconds()
{
    return std::chrono::duration<double>(Clock::steady().now().time_since_epoch()).count();
}

std::shared_ptr<spdlog::logger> logger()
{
    return log::category("fixture-sim");
}

/// A listening TCP socket on host:port (port 0: any free port).
int listenOn(const std::string& host, int port)
{
    int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) throw FaultError(std::string("fixture simulator: socket: ") + std::strerror(errno));
    int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
        ::close(fd);
        throw InputError("", "--host", "'" + host + "' is not an IPv4 address");
    }
    if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd, 8) != 0) {
        std::string why = std::strerror(errno);
        ::close(fd);
        throw FaultError("fixture simulator: cannot listen on " + host + ":" + std::to_string(port) + ": " + why);
    }
    return fd;
}

int boundPort(int fd)
{
    sockaddr_in addr{};
    socklen_t len = sizeof addr;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    return ntohs(addr.sin_port);
}

/// Address range a write request covers: FC 06 one register, FC 16 `count`.
struct WriteSpan {
    bool isWrite = false;
    int address = 0;
    int count = 0;
};

WriteSpan writeSpan(const std::uint8_t* query, int headerLength)
{
    const std::uint8_t* pdu = query + headerLength;
    int address = (pdu[1] << 8) | pdu[2];
    if (pdu[0] == MODBUS_FC_WRITE_SINGLE_REGISTER) return {true, address, 1};
    if (pdu[0] == MODBUS_FC_WRITE_MULTIPLE_REGISTERS) return {true, address, (pdu[3] << 8) | pdu[4]};
    return {};
}

} // namespace

struct FixtureServer::Impl {
    geometry::FixtureKinematics kinematics;
    drivers::fixture::ModbusSettings settings; // before `map`: parse() fills it
    RegisterMap map;
    ServerOptions options;
    SimulatedDrive drive;

    modbus_t* device = nullptr;  ///< protocol context of the device channel
    modbus_t* control = nullptr; ///< protocol context of the control channel
    modbus_mapping_t* deviceRegs = nullptr;
    modbus_mapping_t* controlRegs = nullptr;
    int deviceListen = -1;
    int controlListen = -1;
    int devicePort = -1;
    int ctlPort = -1;
    std::vector<int> deviceClients;
    std::vector<int> controlClients;
    SimulatedFault fault = SimulatedFault::None;
    unsigned requests = 0;
    unsigned connections = 0;

    Impl(const geometry::Station& station, const ServerOptions& opts)
        : kinematics(station.fixture), map(parse(station, kinematics, settings)), options(opts),
          drive(drivers::fixture::parseSimulatorSection((*station.document)["fixture"]["driver"], kinematics.type),
                steadySeconds())
    {
        deviceRegs = modbus_mapping_new(0, 0, map.end(), 0);
        controlRegs = modbus_mapping_new(0, 0, kControlRegisterCount, 0);
        if (!deviceRegs || !controlRegs) throw FaultError("fixture simulator: out of memory");
        controlRegs->tab_registers[kExceptionCode] = MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE;
        controlRegs->tab_registers[kDriveFaultCode] = 17;

        if (!options.rtuDevice.empty()) {
            const auto& s = settings;
            device = modbus_new_rtu(options.rtuDevice.c_str(), s.baud, s.parity, s.dataBits, s.stopBits);
            if (!device || modbus_set_slave(device, s.slaveId) != 0 || modbus_connect(device) != 0)
                throw FaultError("fixture simulator: cannot open " + options.rtuDevice + ": " + modbus_strerror(errno));
            if (s.rs485 && modbus_rtu_set_serial_mode(device, MODBUS_RTU_RS485) != 0)
                throw FaultError("fixture simulator: " + options.rtuDevice +
                                 ": cannot switch to RS-485 mode: " + modbus_strerror(errno));
        } else {
            device = modbus_new_tcp(options.host.c_str(), std::max(options.tcpPort, 0));
            if (!device) throw FaultError("fixture simulator: cannot create the Modbus TCP context");
            deviceListen = listenOn(options.host, std::max(options.tcpPort, 0));
            devicePort = boundPort(deviceListen);
        }
        if (options.controlPort >= 0) {
            control = modbus_new_tcp(options.host.c_str(), options.controlPort);
            if (!control) throw FaultError("fixture simulator: cannot create the Modbus TCP context");
            controlListen = listenOn(options.host, options.controlPort);
            ctlPort = boundPort(controlListen);
        }
        applyFault(options.initialFault);
    }

    static RegisterMap parse(const geometry::Station& station, const geometry::FixtureKinematics& k,
                             drivers::fixture::ModbusSettings& settingsOut)
    {
        if (!station.document) throw InputError("", "fixture.driver", "the station has no driver configuration");
        auto driver = (*station.document)["fixture"]["driver"];
        // The simulator serves the driver's own section, validated as the driver does.
        (void)drivers::makeFixture(driver, k);
        settingsOut = drivers::fixture::parseModbusSettings(driver);
        return drivers::fixture::parseRegisterMap(driver["registers"], k);
    }

    ~Impl()
    {
        for (int fd : deviceClients) ::close(fd);
        for (int fd : controlClients) ::close(fd);
        if (deviceListen >= 0) ::close(deviceListen);
        if (controlListen >= 0) ::close(controlListen);
        // The TCP contexts borrow client sockets; never let them close one twice.
        for (modbus_t* ctx : {device, control}) {
            if (!ctx) continue;
            if (options.rtuDevice.empty() || ctx == control) modbus_set_socket(ctx, -1);
            modbus_close(ctx);
            modbus_free(ctx);
        }
        if (deviceRegs) modbus_mapping_free(deviceRegs);
        if (controlRegs) modbus_mapping_free(controlRegs);
    }

    void applyFault(SimulatedFault f)
    {
        double now = steadySeconds();
        SimulatedFault before = fault;
        fault = f;
        drive.setStallSwitch(f == SimulatedFault::NeverInPosition, now);
        drive.setDriveFaultSwitch(f == SimulatedFault::DriveFault, controlRegs->tab_registers[kDriveFaultCode], now);
        controlRegs->tab_registers[kFaultMode] = static_cast<std::uint16_t>(f);
        logger()->info("fault mode {}", static_cast<int>(f));
        if (!options.rtuDevice.empty()) return;
        // A dropped device: connections are cut and new ones refused until the
        // fault clears (on RTU a dropped device simply stops answering).
        if (f == SimulatedFault::Disconnect && before != SimulatedFault::Disconnect) {
            for (int fd : deviceClients) ::close(fd);
            deviceClients.clear();
            ::close(deviceListen);
            deviceListen = -1;
        } else if (f != SimulatedFault::Disconnect && deviceListen < 0) {
            deviceListen = listenOn(options.host, devicePort);
        }
    }

    /// Positions, status word and fault code as the drive reports them now.
    void refreshDeviceRegisters(double now)
    {
        drive.update(now);
        auto* regs = deviceRegs->tab_registers;
        for (std::size_t i = 0; i < map.axes.size(); ++i)
            map.axes[i].position.encode(drive.position(i, now), &regs[map.axes[i].position.address]);
        std::uint16_t word = 0;
        auto set = [&word](int bit, bool on) {
            if (on) word = static_cast<std::uint16_t>(word | (1u << bit));
        };
        set(map.inPositionBit, drive.inPosition(now));
        set(map.busyBit, drive.busy(now));
        set(map.faultBit, drive.faulted());
        set(map.homedBit, drive.homed());
        regs[map.statusAddress] = word;
        regs[map.faultCodeAddress] = static_cast<std::uint16_t>(drive.faultCode());
        controlRegs->tab_registers[kMovesCompleted] = static_cast<std::uint16_t>(drive.completedMoves());
        controlRegs->tab_registers[kRequestsServed] = static_cast<std::uint16_t>(requests);
        controlRegs->tab_registers[kConnections] = static_cast<std::uint16_t>(connections);
    }

    std::vector<double> speeds() const
    {
        std::vector<double> out;
        for (const auto& a : map.axes)
            out.push_back(a.speed ? a.speed->decode(&deviceRegs->tab_registers[a.speed->address]) : 0.0);
        return out;
    }

    void executeCommand(std::uint16_t value, double now)
    {
        if (value == map.moveCommand) {
            std::vector<double> targets;
            for (const auto& a : map.axes)
                targets.push_back(a.target.decode(&deviceRegs->tab_registers[a.target.address]));
            logger()->debug("move to {}", geometry::PoseOn{drivers::fixture::poseFromAxes(targets, kinematics.type),
                                                           kinematics.type});
            drive.move(targets, speeds(), now);
        } else if (value == map.homeCommand) {
            logger()->debug("home");
            drive.home(speeds(), now);
        } else if (value == map.stopCommand) {
            drive.stop(now);
        } else if (value == map.resetCommand) {
            drive.resetFault(now);
        }
    }

    /// One request on the device channel, answered as the fault mode says.
    void serveDevice(const std::uint8_t* query, int length)
    {
        if (fault == SimulatedFault::NoAnswer || fault == SimulatedFault::Disconnect) return; // swallowed
        if (fault == SimulatedFault::ExceptionReply) {
            modbus_reply_exception(device, query, controlRegs->tab_registers[kExceptionCode]);
            return;
        }
        int hl = modbus_get_header_length(device);
        int fc = query[hl];
        if (fc != MODBUS_FC_READ_HOLDING_REGISTERS && fc != MODBUS_FC_WRITE_SINGLE_REGISTER &&
            fc != MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
            modbus_reply_exception(device, query, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
            return;
        }
        double now = steadySeconds();
        refreshDeviceRegisters(now);
        auto span = writeSpan(query, hl);
        bool commandWritten = false;
        if (span.isWrite) {
            for (int a = span.address; a < span.address + span.count; ++a) {
                if (a < map.end() && !map.writable(a)) {
                    modbus_reply_exception(device, query, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
                    return;
                }
                commandWritten = commandWritten || a == map.commandAddress;
            }
            if (commandWritten) {
                // The command value sits in the request: FC 06 at pdu[3..4], FC 16 after the byte count.
                const std::uint8_t* pdu = query + hl;
                int offset = fc == MODBUS_FC_WRITE_SINGLE_REGISTER ? 3 : 6 + 2 * (map.commandAddress - span.address);
                auto value = static_cast<std::uint16_t>((pdu[offset] << 8) | pdu[offset + 1]);
                if (value != 0 && value != map.moveCommand && value != map.homeCommand && value != map.stopCommand &&
                    value != map.resetCommand) {
                    modbus_reply_exception(device, query, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
                    return;
                }
            }
        }
        if (modbus_reply(device, query, length, deviceRegs) < 0) {
            logger()->debug("reply failed: {}", modbus_strerror(errno));
            return;
        }
        ++requests;
        if (commandWritten) executeCommand(deviceRegs->tab_registers[map.commandAddress], now);
    }

    void serveControl(const std::uint8_t* query, int length)
    {
        int hl = modbus_get_header_length(control);
        int fc = query[hl];
        if (fc != MODBUS_FC_READ_HOLDING_REGISTERS && fc != MODBUS_FC_WRITE_SINGLE_REGISTER &&
            fc != MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
            modbus_reply_exception(control, query, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
            return;
        }
        refreshDeviceRegisters(steadySeconds());
        auto span = writeSpan(query, hl);
        if (span.isWrite) {
            const std::uint8_t* pdu = query + hl;
            for (int i = 0; i < span.count; ++i) {
                int a = span.address + i;
                int offset = fc == MODBUS_FC_WRITE_SINGLE_REGISTER ? 3 : 6 + 2 * i;
                int value = (pdu[offset] << 8) | pdu[offset + 1];
                bool ok = (a == kFaultMode && value <= 5) || (a == kExceptionCode && value >= 1 && value <= 255) ||
                          (a == kDriveFaultCode && value >= 1);
                if (a >= kControlRegisterCount || a > kDriveFaultCode) {
                    modbus_reply_exception(control, query, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
                    return;
                }
                if (!ok) {
                    modbus_reply_exception(control, query, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
                    return;
                }
            }
        }
        std::uint16_t modeBefore = controlRegs->tab_registers[kFaultMode];
        if (modbus_reply(control, query, length, controlRegs) < 0) return;
        std::uint16_t mode = controlRegs->tab_registers[kFaultMode];
        bool codeWritten =
            span.isWrite && span.address <= kDriveFaultCode && span.address + span.count > kDriveFaultCode;
        if (mode != modeBefore || (codeWritten && mode == static_cast<int>(SimulatedFault::DriveFault)))
            applyFault(static_cast<SimulatedFault>(mode));
    }

    /// Reads one request from a TCP client; false when the client has gone.
    bool receiveFrom(modbus_t* ctx, int fd, bool isControl)
    {
        std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> query{};
        modbus_set_socket(ctx, fd);
        int rc = modbus_receive(ctx, query.data());
        if (rc < 0) return false;
        if (rc == 0) return true;
        if (isControl)
            serveControl(query.data(), rc);
        else
            serveDevice(query.data(), rc);
        return true;
    }

    void acceptOn(int listenFd, std::vector<int>& clients, bool countIt)
    {
        int fd = ::accept4(listenFd, nullptr, nullptr, SOCK_CLOEXEC);
        if (fd < 0) return;
        if (clients.size() >= kMaxClients) {
            ::close(fd);
            return;
        }
        clients.push_back(fd);
        if (countIt) ++connections;
    }

    void run(const volatile std::sig_atomic_t& stop)
    {
        while (!stop) {
            std::vector<pollfd> fds;
            enum Kind { DeviceListen, ControlListen, Rtu, DeviceClient, ControlClient };
            std::vector<Kind> kinds;
            auto add = [&](int fd, Kind k) {
                fds.push_back({fd, POLLIN, 0});
                kinds.push_back(k);
            };
            if (deviceListen >= 0) add(deviceListen, DeviceListen);
            if (controlListen >= 0) add(controlListen, ControlListen);
            if (!options.rtuDevice.empty()) add(modbus_get_socket(device), Rtu);
            for (int fd : deviceClients) add(fd, DeviceClient);
            for (int fd : controlClients) add(fd, ControlClient);

            int n = ::poll(fds.data(), fds.size(), kPollMs);
            if (n < 0 && errno != EINTR)
                throw FaultError(std::string("fixture simulator: poll: ") + std::strerror(errno));
            if (n <= 0) continue;
            std::vector<int> goneDevice;
            std::vector<int> goneControl;
            for (std::size_t i = 0; i < fds.size() && !stop; ++i) {
                if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
                switch (kinds[i]) {
                case DeviceListen:
                    if (deviceListen >= 0) acceptOn(deviceListen, deviceClients, true);
                    break;
                case ControlListen:
                    acceptOn(controlListen, controlClients, false);
                    break;
                case Rtu: {
                    std::array<std::uint8_t, MODBUS_RTU_MAX_ADU_LENGTH> query{};
                    int rc = modbus_receive(device, query.data());
                    if (rc > 0)
                        serveDevice(query.data(), rc);
                    else if (rc < 0)
                        modbus_flush(device);
                    break;
                }
                case DeviceClient:
                    if (std::find(deviceClients.begin(), deviceClients.end(), fds[i].fd) == deviceClients.end()) break;
                    if (!receiveFrom(device, fds[i].fd, false)) goneDevice.push_back(fds[i].fd);
                    break;
                case ControlClient:
                    if (!receiveFrom(control, fds[i].fd, true)) goneControl.push_back(fds[i].fd);
                    break;
                }
            }
            for (int fd : goneDevice) {
                auto it = std::find(deviceClients.begin(), deviceClients.end(), fd);
                if (it == deviceClients.end()) continue;
                ::close(fd);
                deviceClients.erase(it);
            }
            for (int fd : goneControl) {
                ::close(fd);
                controlClients.erase(std::find(controlClients.begin(), controlClients.end(), fd));
            }
        }
        logger()->info("stopping");
    }
};

FixtureServer::FixtureServer(const geometry::Station& station, const ServerOptions& options)
    : impl_(std::make_unique<Impl>(station, options))
{
    if (!options.readyFile.empty()) {
        // Written whole under a temporary name, then renamed: a reader never sees half a file.
        auto tmp = options.readyFile;
        tmp += ".tmp";
        {
            std::ofstream out(tmp);
            out << "port=" << impl_->devicePort << "\ncontrol_port=" << impl_->ctlPort << "\n";
            if (!out) throw FaultError("fixture simulator: cannot write " + tmp.string());
        }
        std::filesystem::rename(tmp, options.readyFile);
    }
}

FixtureServer::~FixtureServer() = default;

int FixtureServer::tcpPort() const
{
    return impl_->devicePort;
}
int FixtureServer::controlPort() const
{
    return impl_->ctlPort;
}

void FixtureServer::run(const volatile std::sig_atomic_t& stop)
{
    impl_->run(stop);
}

} // namespace hg::fixturesim
