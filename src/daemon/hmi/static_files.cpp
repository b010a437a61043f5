#include "hmi/static_files.h"

#include "hmi/http_util.h"

#include <chrono>
#include <fmt/format.h>
#include <stdexcept>
#include <zlib.h>

namespace fs = std::filesystem;

namespace hg::daemon {

namespace {

/// Text compresses to a fraction; PNG frames are compressed already.
bool compressible(const fs::path& file)
{
    const auto ext = file.extension().string();
    return ext == ".html" || ext == ".js" || ext == ".css" || ext == ".svg" || ext == ".stl" || ext == ".json";
}

/// Sends `body` as it is. A content provider of known length keeps cpp-httplib
/// from compressing it again (it compresses only bodies set whole).
void sendBody(httplib::Response& res, std::shared_ptr<const std::string> body, const std::string& type)
{
    const auto size = body->size();
    if (size == 0) return res.set_content("", type);
    res.set_content_provider(size, type, [body](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
        if (offset > body->size()) return false;
        return sink.write(body->data() + offset, std::min(length, body->size() - offset));
    });
}

/// An empty answer: cpp-httplib sends no body with a content provider of length 0.
void sendEmpty(httplib::Response& res, const std::string& type)
{
    res.set_content("", type);
}

} // namespace

StaticFiles::StaticFiles(std::size_t maxBytes) : maxBytes_(maxBytes)
{
}

std::string StaticFiles::entityTag(fs::file_time_type modified, std::uintmax_t size)
{
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(modified.time_since_epoch()).count();
    return fmt::format("\"{:x}-{:x}\"", static_cast<std::uint64_t>(ns), size);
}

bool StaticFiles::matches(const std::string& ifNoneMatch, const std::string& etag)
{
    // A list of tags, each possibly weak (W/"…"); the weak comparison of RFC 9110 8.8.3.2.
    std::size_t at = 0;
    while (at < ifNoneMatch.size()) {
        const auto comma = ifNoneMatch.find(',', at);
        auto tag = ifNoneMatch.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
        at = comma == std::string::npos ? ifNoneMatch.size() : comma + 1;
        const auto first = tag.find_first_not_of(" \t");
        const auto last = tag.find_last_not_of(" \t");
        if (first == std::string::npos) continue;
        tag = tag.substr(first, last - first + 1);
        if (tag == "*") return true;
        if (tag.rfind("W/", 0) == 0) tag = tag.substr(2);
        if (tag == etag) return true;
    }
    return false;
}

bool StaticFiles::acceptsGzip(const std::string& acceptEncoding)
{
    std::size_t at = 0;
    while (at < acceptEncoding.size()) {
        const auto comma = acceptEncoding.find(',', at);
        const auto item = acceptEncoding.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
        at = comma == std::string::npos ? acceptEncoding.size() : comma + 1;
        const auto semi = item.find(';');
        auto coding = item.substr(0, semi);
        coding.erase(0, coding.find_first_not_of(" \t"));
        coding.erase(coding.find_last_not_of(" \t") + 1);
        if (coding != "gzip" && coding != "x-gzip" && coding != "*") continue;
        if (semi == std::string::npos) return true;
        const auto q = item.find("q=", semi);
        return q == std::string::npos || std::strtod(item.c_str() + q + 2, nullptr) > 0.0;
    }
    return false;
}

std::string StaticFiles::gzip(const std::string& bytes)
{
    z_stream z{};
    // 15 + 16: the largest window with the gzip wrapper of RFC 1952.
    if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
        throw std::runtime_error("zlib: cannot start a gzip stream");
    std::string out(deflateBound(&z, static_cast<uLong>(bytes.size())), '\0');
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
    z.avail_in = static_cast<uInt>(bytes.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    const int rc = deflate(&z, Z_FINISH);
    out.resize(z.total_out);
    deflateEnd(&z);
    if (rc != Z_STREAM_END) throw std::runtime_error("zlib: gzip did not finish");
    return out;
}

std::size_t StaticFiles::heldBytes() const
{
    std::lock_guard lock(mutex_);
    return held_;
}

void StaticFiles::evictBeyond(std::size_t limit)
{
    while (held_ > limit && !recent_.empty()) {
        const auto& last = recent_.back();
        held_ -= last.version->raw.size() + last.version->gzipped.size();
        index_.erase(last.file);
        recent_.pop_back();
    }
}

std::shared_ptr<const StaticFiles::Version> StaticFiles::version(const fs::path& file, const std::string& etag)
{
    {
        std::lock_guard lock(mutex_);
        if (const auto it = index_.find(file); it != index_.end()) {
            recent_.splice(recent_.begin(), recent_, it->second);
            if (it->second->version->etag == etag) return it->second->version;
        }
    }
    // Read and compressed outside the lock: two requests for a new version may
    // both do it, and the later one's copy is kept; nothing waits on another.
    auto raw = readFile(file);
    if (!raw) return nullptr;
    auto v = std::make_shared<Version>();
    v->etag = etag;
    v->raw = std::move(*raw);
    if (compressible(file) && v->raw.size() > 1024) {
        auto packed = gzip(v->raw);
        if (packed.size() < v->raw.size()) v->gzipped = std::move(packed);
    }
    const std::size_t bytes = v->raw.size() + v->gzipped.size();
    if (bytes > maxBytes_ || !compressible(file)) return v;
    std::lock_guard lock(mutex_);
    if (const auto it = index_.find(file); it != index_.end()) {
        held_ -= it->second->version->raw.size() + it->second->version->gzipped.size();
        recent_.erase(it->second);
        index_.erase(it);
    }
    evictBeyond(maxBytes_ - bytes);
    recent_.push_front(Entry{file, v});
    index_[file] = recent_.begin();
    held_ += bytes;
    return v;
}

void StaticFiles::serve(const httplib::Request& req, httplib::Response& res, const fs::path& file)
{
    std::error_code ec;
    const auto modified = fs::last_write_time(file, ec);
    const auto size = ec ? 0 : fs::file_size(file, ec);
    if (ec || !fs::is_regular_file(file)) return sendError(res, 404, "not found");
    const auto etag = entityTag(modified, size);
    const std::string type = contentType(file);
    // Revalidated on every use (no-cache), so a changed page or a new mesh is never stale.
    res.set_header("Cache-Control", "no-cache");
    res.set_header("ETag", etag);
    if (compressible(file)) res.set_header("Vary", "Accept-Encoding");
    if (matches(req.get_header_value("If-None-Match"), etag)) {
        res.status = 304;
        return sendEmpty(res, type);
    }
    const auto v = version(file, etag);
    if (!v) return sendError(res, 404, "not found");
    if (!v->gzipped.empty() && acceptsGzip(req.get_header_value("Accept-Encoding"))) {
        res.set_header("Content-Encoding", "gzip");
        return sendBody(res, std::shared_ptr<const std::string>(v, &v->gzipped), type);
    }
    sendBody(res, std::shared_ptr<const std::string>(v, &v->raw), type);
}

} // namespace hg::daemon
