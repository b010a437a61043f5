// The Modbus TCP server against independent clients: pymodbus (tools/plc-client)
// and raw socket bytes. The register map behind it is the real one.
#include "daemon_harness.h"
#include "plant/plc_server.h"

#include <arpa/inet.h>
#include <cerrno>
#include <gtest/gtest.h>
#include <map>
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

station::PlcConfig withFrameTimeout(std::chrono::milliseconds t)
{
    station::PlcConfig cfg;
    cfg.frameTimeout = t;
    return cfg;
}

struct Server {
    PlcRegisters registers;
    std::unique_ptr<PlcServer> server;
    explicit Server(station::PlcConfig cfg = withFrameTimeout(200ms))
    {
        cfg.bindAddress = "127.0.0.1";
        cfg.port = hgdaemon::freePort();
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
    EXPECT_EQ(j["bad_command_4"], 3); // COMMAND takes 0..3
    EXPECT_EQ(j["write_handshake_register"], 2);
    EXPECT_EQ(j["write_counter"], 2);
    EXPECT_EQ(j["write_between_counters_and_ring"], 2);
    EXPECT_EQ(j["read_read_only"], 0);    // 100..223 in one read
    EXPECT_EQ(j["bad_purpose_value"], 3); // CYCLE_PURPOSE takes 0, 1, 2 only
    EXPECT_EQ(s.registers.snapshot()[11], 0);
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

    // The handshake extensions of the same result, decoded by the independent client.
    auto h = hgdaemon::plcClient(s.port(), "handshake");
    ASSERT_EQ(h.status, 0) << h.err;
    auto j = nlohmann::json::parse(h.out);
    EXPECT_EQ(j["acq_done_seq"], 77);
    EXPECT_EQ(j["result_seq"], 1);
    EXPECT_EQ(j["counters"]["fails"], 1);
    ASSERT_EQ(j["ring"].size(), 1u);
    EXPECT_EQ(j["ring"][0]["trigger_seq"], 77);
    EXPECT_EQ(j["ring"][0]["cycle_ms"], 70000);
    EXPECT_EQ(j["ring"][0]["landmarks_failed"], 1);
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
        // The others are served at once, while the server answers the bad client with an
        // exception or closes it (a straggling frame after plc.frame_timeout_s).
        auto again = roundTrip(good, readFrame(109, 1));
        EXPECT_EQ(again.size(), 11u) << "good client starved after a malformed frame";
        std::vector<std::uint8_t> reply(16);
        ssize_t n = read(bad, reply.data(), reply.size());
        if (n > 0) {
            EXPECT_EQ(n, 9) << "a malformed request gets an exception or a closed connection";
            EXPECT_GE(reply[7], 0x80);
        } else {
            EXPECT_EQ(n, 0) << "neither answered nor closed within 2 s";
        }
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
    EXPECT_GE(s.server->counters().droppedConnections, 3u); // protocol id, lying length, fragment
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

// Reads one Modbus TCP answer: the MBAP header, then as many bytes as its length says.
std::vector<std::uint8_t> readAnswer(int fd)
{
    std::vector<std::uint8_t> answer(7);
    for (std::size_t got = 0; got < answer.size();) {
        ssize_t n = read(fd, answer.data() + got, answer.size() - got);
        if (n <= 0) return {};
        got += static_cast<std::size_t>(n);
        if (got == 7) answer.resize(6 + ((answer[4] << 8) | answer[5]));
    }
    return answer;
}

TEST(PlcServer, AHalfSentRequestDoesNotDelayTheOtherClients)
{
    // The frame timeout is far longer than the good client's receive timeout (2 s): a
    // server that waited for the trickling client's frame would starve the good one.
    Server s(withFrameTimeout(8s));
    int trickler = connectTo(s.port());
    int good = connectTo(s.port());
    ASSERT_GE(trickler, 0);
    ASSERT_GE(good, 0);
    const auto frame = readFrame(109, 1);
    ASSERT_EQ(write(trickler, frame.data(), 5), 5); // half a request, the rest later
    for (int i = 0; i < 20; ++i) {
        auto a = roundTrip(good, readFrame(100, 3));
        ASSERT_EQ(a.size(), 15u) << "poll " << i << " unanswered while another client holds half a request";
    }
    // The trickling client's request completes a byte at a time and is answered.
    for (std::size_t i = 5; i < frame.size(); ++i) ASSERT_EQ(write(trickler, &frame[i], 1), 1);
    auto late = readAnswer(trickler);
    ASSERT_EQ(late.size(), 11u);
    EXPECT_EQ(late[7], 3);
    close(trickler);
    close(good);
}

TEST(PlcServer, UnsupportedFunctionCodesAnswerException01AndKeepTheConnection)
{
    Server s;
    int fd = connectTo(s.port());
    ASSERT_GE(fd, 0);
    const std::vector<std::vector<std::uint8_t>> requests = {
        {0, 1, 0, 0, 0, 6, 1, 0x08, 0x00, 0x00, 0x12, 0x34},                          // diagnostics, return query data
        {0, 2, 0, 0, 0, 10, 1, 0x14, 0x07, 0x06, 0x00, 0x01, 0x00, 0x00, 0x00, 0x02}, // read file record
        {0, 3, 0, 0, 0, 4, 1, 0x18, 0x00, 0x64},                                      // read FIFO queue
        {0, 4, 0, 0, 0, 5, 1, 0x2b, 0x0d, 0x00, 0x00},                                // MEI type 13 (CANopen)
        {0, 5, 0, 0, 0, 6, 1, 0x83, 0x00, 0x64, 0x00, 0x01},                          // top bit set
    };
    for (const auto& req : requests) {
        auto a = roundTrip(fd, req);
        ASSERT_EQ(a.size(), 9u) << "function " << int(req[7]);
        EXPECT_EQ(a[0], req[0]);
        EXPECT_EQ(a[1], req[1]); // the transaction id comes back
        EXPECT_EQ(a[5], 3);      // MBAP length: unit, function, code
        EXPECT_EQ(a[7], req[7] | 0x80) << "function " << int(req[7]);
        EXPECT_EQ(a[8], 1) << "function " << int(req[7]);
    }
    auto still = roundTrip(fd, readFrame(102, 1));
    EXPECT_EQ(still.size(), 11u) << "connection closed after an unsupported function";
    close(fd);
}

// The objects of a read device identification answer: id → text.
std::map<int, std::string> identificationObjects(const std::vector<std::uint8_t>& a)
{
    std::map<int, std::string> objects;
    std::size_t at = 7 + 7; // MBAP, then 2B 0E code conformity more next count
    for (int k = 0; k < a[13] && at + 2 <= a.size(); ++k) {
        const int id = a[at];
        const std::size_t len = a[at + 1];
        objects[id] = std::string(a.begin() + static_cast<long>(at + 2), a.begin() + static_cast<long>(at + 2 + len));
        at += 2 + len;
    }
    return objects;
}

TEST(PlcServer, DeviceIdentificationNamesVendorProductAndRevision)
{
    Server s;
    int fd = connectTo(s.port());
    ASSERT_GE(fd, 0);
    auto basic = roundTrip(fd, {0, 9, 0, 0, 0, 5, 1, 0x2b, 0x0e, 0x01, 0x00});
    ASSERT_GE(basic.size(), 14u);
    EXPECT_EQ(basic[7], 0x2b);
    EXPECT_EQ(basic[8], 0x0e);
    EXPECT_EQ(basic[9], 0x01);  // read device id code echoed
    EXPECT_EQ(basic[10], 0x81); // basic, stream and individual access
    EXPECT_EQ(basic[11], 0x00); // no more follows
    EXPECT_EQ(basic[13], 3);    // three objects
    EXPECT_EQ(((basic[4] << 8) | basic[5]) + 6, static_cast<int>(basic.size()));
    auto objects = identificationObjects(basic);
    EXPECT_EQ(objects[0], "hullgauge");
    EXPECT_EQ(objects[1], "hullgauged");
    EXPECT_FALSE(objects[2].empty());

    auto one = roundTrip(fd, {0, 10, 0, 0, 0, 5, 1, 0x2b, 0x0e, 0x04, 0x01});
    ASSERT_GE(one.size(), 14u);
    EXPECT_EQ(one[13], 1);
    EXPECT_EQ(identificationObjects(one)[1], "hullgauged");

    auto noSuchObject = roundTrip(fd, {0, 11, 0, 0, 0, 5, 1, 0x2b, 0x0e, 0x04, 0x07});
    ASSERT_EQ(noSuchObject.size(), 9u);
    EXPECT_EQ(noSuchObject[7], 0xab);
    EXPECT_EQ(noSuchObject[8], 2);
    auto badCode = roundTrip(fd, {0, 12, 0, 0, 0, 5, 1, 0x2b, 0x0e, 0x05, 0x00});
    ASSERT_EQ(badCode.size(), 9u);
    EXPECT_EQ(badCode[8], 3);
    close(fd);
}

/// True when the server closed `fd` (read returns 0) before `deadline`.
bool closedBy(int fd, std::chrono::steady_clock::time_point deadline)
{
    while (std::chrono::steady_clock::now() < deadline) {
        std::uint8_t b;
        ssize_t n = read(fd, &b, 1); // returns within the 2 s receive timeout
        if (n == 0) return true;
        if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return true;
    }
    return false;
}

TEST(PlcServer, IdleConnectionsAreClosed)
{
    station::PlcConfig cfg = withFrameTimeout(200ms);
    cfg.idleTimeout = 1s;
    Server s(cfg);
    int idle = connectTo(s.port());
    ASSERT_GE(idle, 0);
    EXPECT_TRUE(closedBy(idle, std::chrono::steady_clock::now() + 20s));
    EXPECT_GE(s.server->counters().idleClosed, 1u);
    close(idle);
}

TEST(PlcServer, WithEverySlotTakenTheLongestIdleConnectionYields)
{
    station::PlcConfig cfg = withFrameTimeout(200ms);
    cfg.maxClients = 3;
    cfg.yieldAfter = 300ms;
    Server s(cfg);
    int idleOld = connectTo(s.port());
    int idleNew = connectTo(s.port());
    int plc = connectTo(s.port());
    ASSERT_GE(idleOld, 0);
    ASSERT_GE(idleNew, 0);
    ASSERT_GE(plc, 0);
    ASSERT_EQ(roundTrip(plc, readFrame(102, 1)).size(), 11u);
    // A new client is refused until an idle one has been silent for yield_after_s; then it
    // is served in the slot of the connection silent the longest. The polling PLC stays.
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    int fresh = -1;
    while (fresh < 0 && std::chrono::steady_clock::now() < deadline) {
        ASSERT_EQ(roundTrip(plc, readFrame(109, 1)).size(), 11u) << "the polling PLC lost its connection";
        int c = connectTo(s.port());
        if (c >= 0 && roundTrip(c, readFrame(102, 1)).size() == 11u)
            fresh = c;
        else if (c >= 0)
            close(c);
    }
    ASSERT_GE(fresh, 0) << "a new client was never served while two connections stayed idle";
    EXPECT_TRUE(closedBy(idleOld, deadline));
    EXPECT_EQ(roundTrip(plc, readFrame(109, 1)).size(), 11u);
    EXPECT_GE(s.server->counters().yielded, 1u);
    for (int fd : {idleOld, idleNew, plc, fresh}) close(fd);
}

} // namespace
} // namespace hg::daemon
