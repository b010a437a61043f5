#include "hmi/request_gate.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>

#include <spdlog/fmt/fmt.h>

namespace hg::daemon {
namespace {

std::string lower(std::string_view s)
{
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return out;
}

std::string_view trim(std::string_view s)
{
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    return s;
}

/// The next line of `text` from `pos` without its line end; false when no line end has come yet.
bool nextLine(const std::string& text, std::size_t& pos, std::string_view& line)
{
    const auto end = text.find('\n', pos);
    if (end == std::string::npos) return false;
    line = std::string_view(text).substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = end + 1;
    return true;
}

bool isToken(std::string_view s)
{
    return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) {
        return std::isalnum(c) || std::string_view("!#$%&'*+-.^_`|~").find(char(c)) != std::string_view::npos;
    });
}

/// The host of a Host value or of an Origin's authority, lower-case, without port or IPv6 brackets.
std::string hostOf(std::string_view authority)
{
    if (!authority.empty() && authority.front() == '[') {
        const auto close = authority.find(']');
        return lower(authority.substr(1, close == std::string_view::npos ? authority.size() - 1 : close - 1));
    }
    return lower(authority.substr(0, authority.find(':')));
}

} // namespace

RequestGate::RequestGate(GateLimits limits) : limits_(std::move(limits))
{
}

RequestGate::State RequestGate::feed(std::string_view bytes)
{
    if (state_ != State::Reading) return state_;
    in_.append(bytes);
    if (!headDone_) {
        if (readHead() != State::Reading || !headDone_) return state_;
    }
    return readBody();
}

bool RequestGate::takeContinue()
{
    const bool wanted = continue_;
    continue_ = false;
    return wanted && state_ == State::Reading;
}

RequestGate::State RequestGate::refuse(int status, std::string reason)
{
    status_ = status;
    reason_ = std::move(reason);
    in_.clear();
    return state_ = State::Refused;
}

// The head ends at its first empty line. Its size and line count are checked
// on every byte that arrives, so 500 000 header lines cost the gate 16 KiB.
RequestGate::State RequestGate::readHead()
{
    std::size_t pos = 0;
    std::string_view line;
    lines_ = 0;
    while (nextLine(in_, pos, line)) {
        if (line.empty() && lines_ == 0) continue; // stray line ends before a request line (RFC 9112 2.2)
        if (line.empty()) {
            const std::string head = in_.substr(0, pos);
            in_.erase(0, pos);
            headDone_ = true;
            return checkHead(head);
        }
        if (++lines_ > limits_.maxHeaderCount + 1)
            return refuse(431, fmt::format("more than {} header lines", limits_.maxHeaderCount));
        if (pos > limits_.maxHeadBytes) break;
    }
    // No empty line yet: everything received is head.
    if (in_.size() > limits_.maxHeadBytes)
        return refuse(431, fmt::format("request head larger than {} bytes", limits_.maxHeadBytes));
    return state_;
}

bool RequestGate::hostAllowed(std::string_view host) const
{
    return limits_.allowedHosts.empty() ||
           std::find(limits_.allowedHosts.begin(), limits_.allowedHosts.end(), host) != limits_.allowedHosts.end();
}

RequestGate::State RequestGate::checkHead(std::string_view head)
{
    std::size_t pos = 0;
    const std::string text(head);
    std::string_view line;
    nextLine(text, pos, line);
    while (line.empty()) nextLine(text, pos, line);
    const auto sp1 = line.find(' '), sp2 = line.rfind(' ');
    if (sp1 == std::string_view::npos || sp2 == sp1 || line.substr(sp2 + 1).rfind("HTTP/1.", 0) != 0)
        return refuse(400, "the request line is not 'METHOD target HTTP/1.x'");
    const std::string_view method = line.substr(0, sp1);
    if (method != "GET" && method != "HEAD" && method != "POST")
        return refuse(405, fmt::format("method '{}' is not one the HMI answers ({})", isToken(method) ? method : "?",
                                       kAllowedMethods));
    head_ = std::string(line) + "\r\n";
    const std::string_view target = line.substr(sp1 + 1, sp2 - sp1 - 1);
    upload_ = method == "POST" && !limits_.uploadTarget.empty() && target.rfind(limits_.uploadTarget, 0) == 0 &&
              (target.size() == limits_.uploadTarget.size() || target[limits_.uploadTarget.size()] == '?');
    std::optional<std::string> host, contentLength;
    bool sawEncoding = false;
    for (int number = 2; nextLine(text, pos, line) && !line.empty(); ++number) {
        const auto colon = line.find(':');
        const std::string_view name = colon == std::string_view::npos ? std::string_view() : line.substr(0, colon);
        if (!isToken(name)) return refuse(400, fmt::format("header line {} is not 'Name: value'", number));
        const std::string key = lower(name);
        const std::string_view value = trim(line.substr(colon + 1));
        if (key == "host") {
            if (host) return refuse(400, "two Host headers");
            host = std::string(value);
            if (!hostAllowed(hostOf(*host)))
                return refuse(
                    421, fmt::format("Host '{}' is not a name this station answers to (http.allowed_hosts)", *host));
        } else if (key == "content-length") {
            if (contentLength && *contentLength != value) return refuse(400, "two different Content-Length headers");
            contentLength = std::string(value);
            continue;
        } else if (key == "transfer-encoding") {
            if (lower(value) != "chunked")
                return refuse(501, fmt::format("Transfer-Encoding '{}' is not supported (only chunked)", value));
            sawEncoding = true;
            continue;
        } else if (key == "expect") {
            if (lower(value) != "100-continue") return refuse(417, fmt::format("Expect '{}' is not supported", value));
            continue_ = true;
            continue;
        } else if (key == "origin" && value != "null") {
            const auto scheme = value.find("://");
            const std::string origin =
                scheme == std::string_view::npos ? std::string() : hostOf(value.substr(scheme + 3));
            if (origin.empty() || !hostAllowed(origin))
                return refuse(403, fmt::format("Origin '{}' is not an allowed host (http.allowed_hosts)", value));
        }
        head_ += std::string(line) + "\r\n";
    }
    if (!host) return refuse(400, "no Host header");
    if (sawEncoding && contentLength) return refuse(400, "both Content-Length and Transfer-Encoding");
    chunked_ = sawEncoding;
    if (contentLength) {
        const auto& v = *contentLength;
        const auto [end, error] = std::from_chars(v.data(), v.data() + v.size(), length_);
        if (v.empty() || end != v.data() + v.size() || error != std::errc())
            return refuse(400, fmt::format("Content-Length '{}' is not a byte count", v));
    }
    if (length_ > bodyLimit())
        return refuse(413, fmt::format("the body of {} bytes is larger than the {} allowed ({})", length_, bodyLimit(),
                                       upload_ ? "workbench.max_upload_bytes" : "http.max_request_bytes"));
    return state_;
}

RequestGate::State RequestGate::readBody()
{
    if (chunked_) {
        if (readChunks() != State::Reading || !chunksDone_) return state_;
    } else {
        if (in_.size() < length_) return state_;
        body_ = in_.substr(0, length_);
    }
    out_ = head_;
    if (!body_.empty() || chunked_ || length_ > 0) out_ += fmt::format("Content-Length: {}\r\n", body_.size());
    out_ += "\r\n" + body_;
    in_.clear();
    return state_ = State::Complete;
}

// RFC 9112 7.1: size line (hex, extensions after ';'), data, CRLF; a zero size,
// then trailer lines up to an empty one. The decoded size is held to the
// limit as it grows: a 100 MB chunked body is refused after its first 64 KiB.
RequestGate::State RequestGate::readChunks()
{
    std::size_t pos = 0;
    std::string_view line;
    while (state_ == State::Reading) {
        if (inTrailers_) {
            if (!nextLine(in_, pos, line)) break;
            if (line.empty()) {
                chunksDone_ = true;
                return state_; // readBody finishes; bytes after the request are not read
            }
            if (++lines_ > limits_.maxHeaderCount + 1)
                return refuse(431, fmt::format("more than {} header and trailer lines", limits_.maxHeaderCount));
            continue;
        }
        if (inChunk_) {
            const std::size_t take = std::min<std::uint64_t>(chunkLeft_, in_.size() - pos);
            body_.append(in_, pos, take);
            pos += take;
            chunkLeft_ -= take;
            if (chunkLeft_ > 0) break;
            if (in_.size() - pos < 2) break;
            if (in_.compare(pos, 2, "\r\n") != 0) return refuse(400, "a chunk is longer than its size line says");
            pos += 2;
            inChunk_ = false;
            continue;
        }
        if (!nextLine(in_, pos, line)) {
            if (in_.size() - pos > 1024) return refuse(400, "a chunk size line longer than 1 KiB");
            break;
        }
        const std::string_view hex = trim(line.substr(0, line.find(';')));
        std::uint64_t size = 0;
        const auto [end, error] = std::from_chars(hex.data(), hex.data() + hex.size(), size, 16);
        if (hex.empty() || end != hex.data() + hex.size() || error != std::errc())
            return refuse(400, fmt::format("chunk size '{}' is not a hexadecimal byte count", hex));
        if (size == 0) {
            inTrailers_ = true;
            continue;
        }
        if (size > bodyLimit() || body_.size() + size > bodyLimit())
            return refuse(413, fmt::format("the chunked body is larger than the {} bytes allowed ({})", bodyLimit(),
                                           upload_ ? "workbench.max_upload_bytes" : "http.max_request_bytes"));
        chunkLeft_ = size;
        inChunk_ = true;
    }
    if (state_ == State::Reading) in_.erase(0, pos);
    return state_;
}

} // namespace hg::daemon
