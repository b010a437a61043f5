// The Modbus TCP server against independent clients: pymodbus (tools/plc-client)
// and raw socket bytes. The register map behind it is the real one.
#include "daemon_harness.h"
#include "plc_server.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;

int connectTo(int port)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    timeval tv{2, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

std::vector<std::uint8_t> roundTrip(int fd, const std::vector<std::uint8_t>& frame)
{
    (void)!write(fd, frame.data(), frame.size());
    std::vector<std::uint8_t> answer(300);
    ssize_t n = read(fd, answer.data(), answer.size());
    answer.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    return answer;
}

// FC03 read of `count` registers from `address`, unit 1, transaction 0x1234.
std::vector<std::uint8_t> readFrame(std::uint16_t address, std::uint16_t count, std::uint8_t unit = 1)
{
    return {0x12,
            0x34,
            0,
            0,
            0,
            6,
            unit,
            3,
            static_cast<std::uint8_t>(address >> 8),
            static_cast<std::uint8_t>(address),
            static_cast<std::uint8_t>(count >> 8),
            static_cast<std::uint8_t>(count)};
}

struct Server {
    PlcRegisters registers;
    std::unique_ptr<PlcServer> server;
    explicit Server(station::PlcConfig cfg = {})
    {
        cfg.bindAddress = "127.0.0.1";
        cfg.port = hgdaemon::freePort();
        cfg.frameTimeout = 200ms;
        registers.setKnownPrograms({1});
        registers.setStatus(station::PlcStatus::Ready);
        server = std::make_unique<PlcServer>(registers, cfg);
        server->start();
    }
    int port() const { return server->port(); }
};

TEST(PlcServer, AccessRulesAnswerTheDocumentedExceptions)
{
    Server s;
    auto r = hgdaemon::plcClient(s.port(), "probe");
    ASSERT_EQ(r.status, 0) << r.err;
    auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["write_read_only"], 2);
    EXPECT_EQ(j["write_unmapped"], 2);
    EXPECT_EQ(j["write_past_map"], 2);
    EXPECT_EQ(j["write_block_into_read_only"], 2);
    EXPECT_EQ(j["bad_serial_value"], 3);
    EXPECT_EQ(j["bad_command_value"], 3);
    EXPECT_EQ(j["read_past_map"], 2);
    EXPECT_EQ(j["write_program"], 0);
    EXPECT_EQ(j["read_map"], 0);
    EXPECT_EQ(s.registers.snapshot()[1], 1); // the good write landed
}

TEST(PlcServer, IndependentClientReadsWhatThePublisherWrote)
{
    Server s;
    station::PublishedResult p;
    p.seq = 77;
    p.result = station::PlcResult::Fail;
    p.landmarksFailed = 1;
    p.landmarksTotal = 3;
    p.cycleMs = 70000;
    p.landmarkOk = {true, false, true};
    s.registers.publishResult(p);
    auto r = hgdaemon::plcClient(s.port(), "read 100 21");
    ASSERT_EQ(r.status, 0) << r.err;
    auto v = nlohmann::json::parse(r.out);
    EXPECT_EQ(v[1], 77);
    EXPECT_EQ(v[3], 2);
    EXPECT_EQ(v[7], 1);    // 70000 = 0x0001'1170: high word
    EXPECT_EQ(v[8], 4464); // low word 0x1170
    EXPECT_EQ(v[20], 5);   // bits 0 and 2
}

TEST(PlcServer, MalformedFramesDropOnlyTheirClient)
{
    Server s;
    int good = connectTo(s.port());
    ASSERT_GE(good, 0);
    auto answer = roundTrip(good, readFrame(102, 1));
    ASSERT_EQ(answer.size(), 11u);
    EXPECT_EQ(answer[7], 3);
    EXPECT_EQ(answer[10], 0); // STATUS ready

    const std::vector<std::vector<std::uint8_t>> garbage = {
        {0x12, 0x34, 0x00, 0x07, 0, 6, 1, 3, 0, 100, 0, 1},       // protocol id 7
        {0x12, 0x34, 0, 0, 0, 60, 1, 3, 0, 100, 0, 1},            // MBAP length lies
        {0x12, 0x34, 0, 0, 0, 9, 1, 16, 0, 0, 0, 100, 200, 0, 1}, // FC16 byte count beyond the frame
        {0xde, 0xad, 0xbe, 0xef},                                 // a fragment, then silence
        {0x12, 0x34, 0, 0, 0, 4, 1, 0x2b, 0x0e, 0x01},            // unsupported function with data
    };
    for (const auto& frame : garbage) {
        int bad = connectTo(s.port());
        ASSERT_GE(bad, 0);
        (void)!write(bad, frame.data(), frame.size());
        // The server closes the connection (or answers an exception) and keeps serving others.
        auto t0 = std::chrono::steady_clock::now();
        auto again = roundTrip(good, readFrame(109, 1));
        EXPECT_EQ(again.size(), 11u) << "good client starved after a malformed frame";
        EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
        close(bad);
    }
    // An unknown function code without data gets exception 01.
    int other = connectTo(s.port());
    auto ex = roundTrip(other, {0x00, 0x01, 0, 0, 0, 2, 1, 0x07});
    ASSERT_EQ(ex.size(), 9u);
    EXPECT_EQ(ex[7], 0x87);
    EXPECT_EQ(ex[8], 1);
    // A request for another unit id: gateway target exception (0x0B).
    auto unit = roundTrip(other, readFrame(102, 1, 9));
    ASSERT_EQ(unit.size(), 9u);
    EXPECT_EQ(unit[8], 0x0B);
    // Quantity 0 or above 125: exception 03.
    auto qty = roundTrip(other, readFrame(0, 126));
    ASSERT_EQ(qty.size(), 9u);
    EXPECT_EQ(qty[8], 3);
    close(other);
    close(good);
    auto probe = hgdaemon::plcClient(s.port(), "read 102 1");
    EXPECT_EQ(probe.status, 0) << probe.err;
    EXPECT_GE(s.server->counters().droppedConnections, 4u);
}

TEST(PlcServer, ClientsOutsideTheAllowListAreRefused)
{
    station::PlcConfig cfg;
    cfg.allowedClients = {*station::parseIpv4Network("10.9.9.0/24")};
    Server s(cfg);
    auto r = hgdaemon::plcClient(s.port(), "read 102 1");
    EXPECT_NE(r.status, 0);
    EXPECT_GE(s.server->counters().refusedConnections, 1u);

    station::PlcConfig open;
    open.allowedClients = {*station::parseIpv4Network("127.0.0.0/8")};
    Server t(open);
    auto ok = hgdaemon::plcClient(t.port(), "read 102 1");
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_EQ(t.server->counters().refusedConnections, 0u);
}

TEST(PlcServer, SeveralClientsAtOnce)
{
    Server s;
    std::vector<int> fds;
    for (int i = 0; i < 5; ++i) fds.push_back(connectTo(s.port()));
    for (int round = 0; round < 20; ++round)
        for (int fd : fds) {
            auto a = roundTrip(fd, readFrame(100, 10));
            ASSERT_EQ(a.size(), 9u + 20u);
        }
    for (int fd : fds) close(fd);
}

} // namespace
} // namespace hg::daemon
