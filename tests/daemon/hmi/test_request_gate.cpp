// The HMI's request gate (src/daemon/hmi/request_gate.cpp): requests fed as a
// client would send them, byte by byte or in pieces, against hand-written
// expectations of RFC 9112 and the limits of docs/hmi.md.
#include "hmi/request_gate.h"

#include <gtest/gtest.h>
#include <string>

namespace hg::daemon {
namespace {

using State = RequestGate::State;

GateLimits limits()
{
    GateLimits l;
    l.maxBodyBytes = 64 * 1024;
    l.allowedHosts = {"127.0.0.1", "localhost", "line-7.plant.example"};
    return l;
}

RequestGate fed(const std::string& bytes)
{
    RequestGate gate(limits());
    gate.feed(bytes);
    return gate;
}

TEST(RequestGate, ARequestTrickledByteByByteIsCompleteAtItsLastByteOnly)
{
    const std::string request = "POST /api/login HTTP/1.1\r\nHost: 127.0.0.1:8080\r\nContent-Length: 5\r\n\r\nhello";
    RequestGate gate(limits());
    for (std::size_t i = 0; i + 1 < request.size(); ++i)
        ASSERT_EQ(gate.feed(request.substr(i, 1)), State::Reading) << i;
    ASSERT_EQ(gate.feed(request.substr(request.size() - 1)), State::Complete);
    EXPECT_EQ(gate.request(), request);
}

TEST(RequestGate, AGetWithoutBodyPassesAsItCame)
{
    const std::string request = "GET /api/status HTTP/1.1\r\nHost: localhost\r\nAccept: */*\r\n\r\n";
    const RequestGate gate = fed(request);
    ASSERT_EQ(gate.state(), State::Complete);
    EXPECT_EQ(gate.request(), request);
}

// 200 000 header lines were once read whole (and answered 200, +50 MiB kept):
// the gate refuses at the 101st line, having held at most the head's limit.
TEST(RequestGate, TooManyOrTooLargeHeadersAre431)
{
    RequestGate many(limits());
    many.feed("GET / HTTP/1.1\r\nHost: localhost\r\n");
    State state = State::Reading;
    int sent = 0;
    for (; sent < 200000 && state == State::Reading; ++sent) state = many.feed("X-A: b\r\n");
    EXPECT_EQ(state, State::Refused);
    EXPECT_EQ(many.status(), 431);
    EXPECT_EQ(many.reason(), "more than 100 header lines");
    EXPECT_EQ(sent, 100) << "refused at the 101st header (Host the first)";

    const RequestGate large = fed("GET / HTTP/1.1\r\nHost: localhost\r\nX-Big: " + std::string(17000, 'a'));
    EXPECT_EQ(large.state(), State::Refused);
    EXPECT_EQ(large.status(), 431);
    EXPECT_EQ(large.reason(), "request head larger than 16384 bytes");
}

TEST(RequestGate, MethodsTheHmiDoesNotAnswerAre405)
{
    for (const char* method : {"FOO", "TRACE", "PUT", "DELETE", "OPTIONS"}) {
        const RequestGate gate = fed(std::string(method) + " / HTTP/1.1\r\nHost: localhost\r\n\r\n");
        EXPECT_EQ(gate.status(), 405) << method;
        EXPECT_EQ(gate.reason(), std::string("method '") + method + "' is not one the HMI answers (GET, HEAD, POST)");
    }
    EXPECT_EQ(fed("GARBAGE\r\n\r\n").status(), 400);
}

// DNS rebinding: a page of a.example whose name now resolves to the station
// sends Host: a.example and Origin: http://a.example — consistent with each
// other, so only a list of the station's own names refuses it.
TEST(RequestGate, HostAndOriginMustBeAllowedNames)
{
    const RequestGate rebound =
        fed("POST /api/login HTTP/1.1\r\nHost: a.example\r\nOrigin: http://a.example\r\nContent-Length: 0\r\n\r\n");
    EXPECT_EQ(rebound.status(), 421);
    EXPECT_EQ(rebound.reason(), "Host 'a.example' is not a name this station answers to (http.allowed_hosts)");
    const RequestGate origin = fed(
        "POST /api/login HTTP/1.1\r\nHost: localhost\r\nOrigin: http://evil.example:80\r\nContent-Length: 0\r\n\r\n");
    EXPECT_EQ(origin.status(), 403);
    EXPECT_EQ(fed("GET / HTTP/1.1\r\n\r\n").reason(), "no Host header");
    EXPECT_EQ(fed("GET / HTTP/1.1\r\nHost: LINE-7.plant.example:8080\r\n"
                  "Origin: http://line-7.plant.example:8080\r\n\r\n")
                  .state(),
              State::Complete)
        << "names compare without case and port";
}

// Content-Length: -1 was once answered 413 after 5 s: it is no byte count, 400 at once.
TEST(RequestGate, ContentLengthIsABoundedByteCountRefusedBeforeTheBody)
{
    EXPECT_EQ(fed("POST / HTTP/1.1\r\nHost: localhost\r\nContent-Length: -1\r\n\r\n").reason(),
              "Content-Length '-1' is not a byte count");
    const RequestGate big = fed("POST / HTTP/1.1\r\nHost: localhost\r\nContent-Length: 100000000\r\n\r\n");
    EXPECT_EQ(big.status(), 413);
    EXPECT_EQ(big.reason(), "the body of 100000000 bytes is larger than the 65536 allowed (http.max_request_bytes)");
    EXPECT_EQ(fed("POST / HTTP/1.1\r\nHost: localhost\r\nContent-Length: 5\r\nContent-Length: 6\r\n\r\n").status(),
              400);
    EXPECT_EQ(
        fed("POST / HTTP/1.1\r\nHost: localhost\r\nContent-Length: 5\r\nTransfer-Encoding: chunked\r\n\r\n").reason(),
        "both Content-Length and Transfer-Encoding");
}

TEST(RequestGate, AChunkedBodyIsDecodedAndGivenItsLength)
{
    RequestGate gate(limits());
    const std::string head = "POST /api/login HTTP/1.1\r\nHost: localhost\r\nTransfer-Encoding: chunked\r\n\r\n";
    const std::string body = "5;ext=1\r\nhello\r\n7\r\n, world\r\n0\r\nX-Trailer: t\r\n\r\n";
    ASSERT_EQ(gate.feed(head), State::Reading);
    for (std::size_t i = 0; i + 1 < body.size(); ++i) ASSERT_EQ(gate.feed(body.substr(i, 1)), State::Reading) << i;
    ASSERT_EQ(gate.feed(body.substr(body.size() - 1)), State::Complete);
    EXPECT_EQ(gate.request(), "POST /api/login HTTP/1.1\r\nHost: localhost\r\nContent-Length: 12\r\n\r\nhello, world");
}

// A 100 MB chunked POST was once read and parsed whole (RSS 82 → 383 MiB):
// the decoded size is held to the limit as it grows.
TEST(RequestGate, AChunkedBodyPastTheLimitIs413AfterTheLimitNotTheBody)
{
    RequestGate gate(limits());
    gate.feed("POST /api/login HTTP/1.1\r\nHost: localhost\r\nTransfer-Encoding: chunked\r\n\r\n");
    const std::string piece = "8000\r\n" + std::string(0x8000, 'x') + "\r\n"; // 32 KiB chunks
    int pieces = 0;
    State state = State::Reading;
    for (; pieces < 3200 && state == State::Reading; ++pieces) state = gate.feed(piece);
    EXPECT_EQ(state, State::Refused);
    EXPECT_EQ(gate.status(), 413);
    EXPECT_EQ(pieces, 3) << "64 KiB are two chunks; the third's size line passes the limit";
    EXPECT_EQ(fed("POST / HTTP/1.1\r\nHost: localhost\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n").reason(),
              "chunk size 'zz' is not a hexadecimal byte count");
    EXPECT_EQ(fed("POST / HTTP/1.1\r\nHost: localhost\r\nTransfer-Encoding: gzip\r\n\r\n").status(), 501);
}

TEST(RequestGate, Expect100ContinueIsAskedForOnceAndNotPassedOn)
{
    RequestGate gate(limits());
    gate.feed("POST / HTTP/1.1\r\nHost: localhost\r\nExpect: 100-continue\r\nContent-Length: 2\r\n\r\n");
    EXPECT_TRUE(gate.takeContinue());
    EXPECT_FALSE(gate.takeContinue());
    ASSERT_EQ(gate.feed("ok"), State::Complete);
    EXPECT_EQ(gate.request(), "POST / HTTP/1.1\r\nHost: localhost\r\nContent-Length: 2\r\n\r\nok");
}

// The workbench's CAD upload (docs/workbench.md) has its own limit; only a
// POST to exactly its target gets it, never a GET, another path or a path
// that only begins with the same letters.
TEST(RequestGate, OnlyTheUploadTargetGetsTheUploadLimit)
{
    GateLimits l = limits();
    l.uploadTarget = "/api/parts";
    l.maxUploadBytes = 1 << 20;
    const auto head = [](const std::string& line, std::size_t length) {
        return line + " HTTP/1.1\r\nHost: localhost\r\nContent-Length: " + std::to_string(length) + "\r\n\r\n";
    };
    RequestGate upload(l);
    EXPECT_EQ(upload.feed(head("POST /api/parts?name=b&file=b.stl", 500000)), State::Reading);
    EXPECT_EQ(upload.uploadBytes(), 500000u);
    RequestGate tooLarge(l);
    EXPECT_EQ(tooLarge.feed(head("POST /api/parts", (1 << 20) + 1)), State::Refused);
    EXPECT_EQ(tooLarge.status(), 413);
    EXPECT_EQ(tooLarge.reason(), "the body of 1048577 bytes is larger than the 1048576 allowed "
                                 "(workbench.max_upload_bytes)");
    for (const std::string line : {"POST /api/parts/b/landmarks", "POST /api/partsx", "POST /api/login"}) {
        RequestGate other(l);
        EXPECT_EQ(other.feed(head(line, 500000)), State::Refused) << line;
        EXPECT_EQ(other.status(), 413) << line;
        EXPECT_EQ(other.uploadBytes(), 0u) << line;
    }
}

} // namespace
} // namespace hg::daemon
