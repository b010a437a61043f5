// The HMI's files (src/daemon/hmi/static_files.cpp) served by a real
// cpp-httplib server on 127.0.0.1 to its real client: validators and gzip as
// RFC 9110 and RFC 1952 say, decoded by zlib's own inflate, and a browser that
// offers Brotli never made to wait for it (docs/hmi.md, "Files and caching").
#include "hmi/static_files.h"

#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <httplib.h>
#include <random>
#include <thread>
#include <zlib.h>

namespace fs = std::filesystem;

namespace hg::daemon {
namespace {

std::string inflateGzip(const std::string& packed)
{
    z_stream z{};
    EXPECT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
    std::string out(1 << 20, '\0');
    std::string all;
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(packed.data()));
    z.avail_in = static_cast<uInt>(packed.size());
    int rc = Z_OK;
    while (rc == Z_OK) {
        z.next_out = reinterpret_cast<Bytef*>(out.data());
        z.avail_out = static_cast<uInt>(out.size());
        rc = inflate(&z, Z_NO_FLUSH);
        all.append(out.data(), out.size() - z.avail_out);
    }
    inflateEnd(&z);
    EXPECT_EQ(rc, Z_STREAM_END);
    return all;
}

void write(const fs::path& file, const std::string& text)
{
    std::ofstream(file, std::ios::binary) << text;
}

/// Script-like text: repetitive enough to compress well, like three.js.
std::string script(std::size_t lines)
{
    std::string s;
    for (std::size_t i = 0; i < lines; ++i) s += "function f" + std::to_string(i) + "(a, b) { return a * b + 1; }\n";
    return s;
}

class StaticFilesServed : public ::testing::Test {
  protected:
    void SetUp() override
    {
        dir = fs::temp_directory_path() / ("hg-static-" + std::to_string(std::random_device{}()));
        fs::create_directories(dir);
        server.Get(R"(/(.+))", [this](const httplib::Request& req, httplib::Response& res) {
            files.serve(req, res, dir / req.matches[1].str());
        });
        port = server.bind_to_any_port("127.0.0.1");
        ASSERT_GT(port, 0);
        // Bound and listening: a request queues until the loop accepts it.
        loop = std::jthread([this] { server.listen_after_bind(); });
    }
    void TearDown() override
    {
        server.stop();
        loop = {};
        fs::remove_all(dir);
    }
    httplib::Result get(const std::string& path, const httplib::Headers& headers)
    {
        httplib::Client client("127.0.0.1", port);
        client.set_connection_timeout(std::chrono::seconds(10));
        client.set_read_timeout(std::chrono::seconds(10));
        // The body exactly as sent: no decompression by the client.
        client.set_decompress(false);
        return client.Get(path, headers);
    }

    fs::path dir;
    StaticFiles files{std::size_t{1} << 20};
    httplib::Server server;
    int port = 0;
    std::jthread loop;
};

TEST(StaticFiles, EntityTagsAreComparedWeaklyInAList)
{
    const auto tag = StaticFiles::entityTag(fs::file_time_type(std::chrono::nanoseconds(0x1234)), 0x56);
    EXPECT_EQ(tag, "\"1234-56\"");
    EXPECT_TRUE(StaticFiles::matches("\"1234-56\"", tag));
    EXPECT_TRUE(StaticFiles::matches("\"aa-1\", W/\"1234-56\"", tag));
    EXPECT_TRUE(StaticFiles::matches("*", tag));
    EXPECT_FALSE(StaticFiles::matches("\"1234-57\"", tag));
    EXPECT_FALSE(StaticFiles::matches("", tag));
    EXPECT_FALSE(StaticFiles::matches("1234-56", tag)); // unquoted: not that tag
}

TEST(StaticFiles, GzipIsTakenUnlessItsQualityIsZero)
{
    EXPECT_TRUE(StaticFiles::acceptsGzip("gzip, deflate, br"));
    EXPECT_TRUE(StaticFiles::acceptsGzip("br;q=1.0, gzip;q=0.5"));
    EXPECT_TRUE(StaticFiles::acceptsGzip("*"));
    EXPECT_FALSE(StaticFiles::acceptsGzip("gzip;q=0"));
    EXPECT_FALSE(StaticFiles::acceptsGzip("br"));
    EXPECT_FALSE(StaticFiles::acceptsGzip("identity"));
    EXPECT_FALSE(StaticFiles::acceptsGzip(""));
}

TEST_F(StaticFilesServed, ABrowserOfferingBrotliGetsTheGzipCompressedOnce)
{
    const auto text = script(2000);
    write(dir / "three.min.js", text);
    const auto first = get("/three.min.js", {{"Accept-Encoding", "gzip, deflate, br"}});
    ASSERT_TRUE(first);
    EXPECT_EQ(first->status, 200);
    EXPECT_EQ(first->get_header_value("Content-Encoding"), "gzip");
    EXPECT_EQ(first->get_header_value("Vary"), "Accept-Encoding");
    EXPECT_EQ(first->get_header_value("Cache-Control"), "no-cache");
    EXPECT_LT(first->body.size(), text.size() / 4);
    EXPECT_EQ(inflateGzip(first->body), text);
    // The second answer is the same bytes, from the cache.
    const auto held = files.heldBytes();
    EXPECT_GT(held, text.size());
    const auto second = get("/three.min.js", {{"Accept-Encoding", "gzip, deflate, br"}});
    ASSERT_TRUE(second);
    EXPECT_EQ(second->body, first->body);
    EXPECT_EQ(files.heldBytes(), held);
}

TEST_F(StaticFilesServed, ABrowserTakingNoGzipGetsTheFileAsItIs)
{
    const auto text = script(500);
    write(dir / "page.html", text);
    for (const char* offer : {"br", "identity", "gzip;q=0"}) {
        const auto res = get("/page.html", {{"Accept-Encoding", offer}});
        ASSERT_TRUE(res) << offer;
        EXPECT_EQ(res->get_header_value("Content-Encoding"), "") << offer;
        EXPECT_EQ(res->body, text) << offer;
        EXPECT_EQ(res->get_header_value("Content-Type"), "text/html; charset=utf-8");
    }
}

TEST_F(StaticFilesServed, TheVersionHeldIsAnswered304AndAChangedFileIsNot)
{
    write(dir / "parts.js", script(100));
    const auto first = get("/parts.js", {});
    ASSERT_TRUE(first);
    const auto etag = first->get_header_value("ETag");
    ASSERT_FALSE(etag.empty());
    const auto again = get("/parts.js", {{"If-None-Match", etag}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
    EXPECT_TRUE(again->body.empty());
    EXPECT_EQ(again->get_header_value("ETag"), etag);
    // A new version (other size, a later time): a full answer with a new tag.
    write(dir / "parts.js", script(101));
    fs::last_write_time(dir / "parts.js", fs::last_write_time(dir / "parts.js") + std::chrono::seconds(5));
    const auto changed = get("/parts.js", {{"If-None-Match", etag}});
    ASSERT_TRUE(changed);
    EXPECT_EQ(changed->status, 200);
    EXPECT_NE(changed->get_header_value("ETag"), etag);
    EXPECT_EQ(changed->body, script(101));
}

TEST_F(StaticFilesServed, ImagesAreNotHeldAndMissingFilesAre404)
{
    const std::string png = "\x89PNG\r\n\x1a\n" + std::string(5000, 'x');
    write(dir / "view_0.png", png);
    const auto res = get("/view_0.png", {{"Accept-Encoding", "gzip"}});
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200);
    EXPECT_EQ(res->get_header_value("Content-Encoding"), "");
    EXPECT_EQ(res->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(res->body, png);
    EXPECT_EQ(files.heldBytes(), 0u);
    const auto missing = get("/nothing.js", {});
    ASSERT_TRUE(missing);
    EXPECT_EQ(missing->status, 404);
    fs::create_directories(dir / "folder.js");
    EXPECT_EQ(get("/folder.js", {})->status, 404);
}

TEST_F(StaticFilesServed, TheLeastRecentlyServedLeaveBeyondTheLimit)
{
    // Three files of ~0.45 MiB raw each (plus their gzip) in a cache of 1 MiB: two fit.
    const auto text = script(9000);
    for (const char* name : {"a.js", "b.js", "c.js"}) write(dir / name, text);
    ASSERT_TRUE(get("/a.js", {}));
    ASSERT_TRUE(get("/b.js", {}));
    const auto two = files.heldBytes();
    ASSERT_TRUE(get("/a.js", {})); // a is now the most recent
    ASSERT_TRUE(get("/c.js", {})); // b leaves
    EXPECT_LE(files.heldBytes(), std::size_t{1} << 20);
    EXPECT_EQ(files.heldBytes(), two);
    // Every file still answers whole.
    for (const char* name : {"a.js", "b.js", "c.js"}) EXPECT_EQ(get(std::string("/") + name, {})->body, text) << name;
}

} // namespace
} // namespace hg::daemon
