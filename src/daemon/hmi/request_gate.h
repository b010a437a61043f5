// The web HMI's request gate (docs/hmi.md, "Bounded"): one connection's
// request read as its bytes arrive, checked against every limit before the
// HTTP library sees it — the head's size and header count (431), the method
// (405), the Host and Origin against the allowed host names (421, 403), the
// body's size whatever its transfer encoding (413, answered as soon as the
// announced or decoded size passes the limit, before the rest is read). A
// request the gate passes is whole and its body plain (a chunked body is
// decoded and given a Content-Length), so a library thread is taken only to
// answer, never to wait on a slow client.
//
// Pure: bytes in, a verdict out; the socket loop that feeds it and keeps its
// deadline is in hmi_server.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace hg::daemon {

struct GateLimits {
    std::size_t maxHeadBytes = 16 * 1024; ///< request line and headers, with their line ends
    std::size_t maxHeaderCount = 100;
    std::size_t maxBodyBytes = 64 * 1024; ///< `http.max_request_bytes`, decoded size of a chunked body
    /// Host names a request may name in Host and Origin, lower-case, without
    /// port (`http.allowed_hosts`); empty: any (the gate is then no guard against DNS rebinding).
    std::vector<std::string> allowedHosts;
    /// The one request that may carry more (docs/workbench.md): `POST
    /// <uploadTarget>[?query]`, a CAD upload, up to `maxUploadBytes`
    /// (`workbench.max_upload_bytes`); empty target: none.
    std::string uploadTarget;
    std::size_t maxUploadBytes = 0;
};

class RequestGate {
  public:
    enum class State { Reading, Complete, Refused };

    explicit RequestGate(GateLimits limits);

    /// Takes the next bytes of the connection; the state after them. Bytes
    /// after a complete or refused request are ignored (one request per connection).
    State feed(std::string_view bytes);
    State state() const { return state_; }

    /// True once after a head asking `Expect: 100-continue` was accepted: the
    /// caller sends "HTTP/1.1 100 Continue" so the client sends its body.
    bool takeContinue();

    /// Complete: the request as the library reads it (head, and the body with a Content-Length).
    const std::string& request() const { return out_; }
    /// Refused: the HTTP status and the reason in words, for a JSON answer.
    int status() const { return status_; }
    const std::string& reason() const { return reason_; }
    /// Refused with 405: the methods the HMI answers.
    static constexpr std::string_view kAllowedMethods = "GET, HEAD, POST";
    /// An upload's announced body size once its head is read (0 for any other
    /// request): the listener gives it time to arrive in proportion.
    std::uint64_t uploadBytes() const { return upload_ ? length_ : 0; }

  private:
    State refuse(int status, std::string reason);
    State readHead();
    State checkHead(std::string_view head);
    State readBody();
    State readChunks();
    bool hostAllowed(std::string_view host) const;
    std::size_t bodyLimit() const { return upload_ ? limits_.maxUploadBytes : limits_.maxBodyBytes; }

    GateLimits limits_;
    State state_ = State::Reading;
    std::string in_;           ///< bytes received and not yet consumed
    std::string head_;         ///< the head as the library will read it, without its blank line
    std::string body_;         ///< the body, decoded
    std::uint64_t length_ = 0; ///< Content-Length, when not chunked
    bool chunked_ = false;
    bool inTrailers_ = false;
    bool chunksDone_ = false;
    std::uint64_t chunkLeft_ = 0; ///< bytes of the current chunk still to come (+2 for its CRLF once started)
    bool inChunk_ = false;
    bool continue_ = false;
    bool headDone_ = false;
    bool upload_ = false; ///< the upload request: its own body limit
    std::size_t lines_ = 0;
    std::string out_;
    int status_ = 0;
    std::string reason_;
};

} // namespace hg::daemon
