// The web HMI's files — pages, scripts, Debian's JavaScript libraries, a
// part's display mesh — served with a validator and compressed once
// (docs/hmi.md, "Files and caching"). cpp-httplib would compress every answer
// again on every request, and with Brotli at its highest quality: three.js's
// 600 kB took longer to compress than to draw the page. Here each file is
// read and gzip-compressed once per version (its modification time and size),
// answered 304 when the browser already holds that version, and sent as it is
// to a browser that takes no gzip.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <httplib.h>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace hg::daemon {

class StaticFiles {
  public:
    /// `maxBytes`: what the cache may hold (raw and compressed together); the
    /// least recently served files leave first. A file larger than that is
    /// served from disk each time, uncompressed.
    explicit StaticFiles(std::size_t maxBytes = std::size_t{128} << 20);

    /// Answers `file` (404 when it cannot be read), typed by its extension.
    void serve(const httplib::Request& req, httplib::Response& res, const std::filesystem::path& file);

    /// The entity tag of a version of a file: its modification time and size,
    /// as web servers commonly form it.
    static std::string entityTag(std::filesystem::file_time_type modified, std::uintmax_t size);
    /// Whether an If-None-Match header names `etag` (or is `*`).
    static bool matches(const std::string& ifNoneMatch, const std::string& etag);
    /// Whether an Accept-Encoding header takes gzip (a q of 0 refuses it).
    static bool acceptsGzip(const std::string& acceptEncoding);
    /// gzip (RFC 1952) of `bytes` at zlib's default level.
    static std::string gzip(const std::string& bytes);

    /// What the cache holds now, in bytes (for the tests).
    std::size_t heldBytes() const;

  private:
    struct Version {
        std::string etag;
        std::string raw;
        std::string gzipped; ///< empty when compressing does not pay
    };
    struct Entry {
        std::filesystem::path file;
        std::shared_ptr<const Version> version;
    };

    std::shared_ptr<const Version> version(const std::filesystem::path& file, const std::string& etag);
    void evictBeyond(std::size_t limit);

    std::size_t maxBytes_;
    mutable std::mutex mutex_;
    std::list<Entry> recent_; ///< most recently served first
    std::map<std::filesystem::path, std::list<Entry>::iterator> index_;
    std::size_t held_ = 0;
};

} // namespace hg::daemon
