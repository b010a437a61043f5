// The reload's worker (src/daemon/config_reload.h): the main loop is free
// while a configuration is read, a refusal says why, and a request during a
// reload reads the file again after it. The loads are held by the test.
#include "config_reload.h"

#include "hullgauge/common/error.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <poll.h>
#include <vector>

namespace {

using namespace std::chrono_literals;
using hg::daemon::ConfigPtr;
using hg::daemon::ConfigReload;

/// A load the test releases one call at a time; it records the files it read.
class HeldLoads {
  public:
    ConfigPtr load(const std::filesystem::path& file)
    {
        std::unique_lock lock(mutex_);
        started_.push_back(file);
        changed_.notify_all();
        changed_.wait(lock, [&] { return released_ >= started_.size(); });
        if (file.filename() == "bad.yaml") throw hg::InputError(file.string(), "octree.depth", "16 is above 15");
        auto config = std::make_shared<hg::station::DaemonConfig>();
        config->file = file;
        return config;
    }
    void releaseOne()
    {
        std::lock_guard lock(mutex_);
        ++released_;
        changed_.notify_all();
    }
    /// Waits (bounded) until `n` loads have started.
    bool started(std::size_t n)
    {
        std::unique_lock lock(mutex_);
        return changed_.wait_for(lock, 10s, [&] { return started_.size() >= n; });
    }
    std::vector<std::filesystem::path> files()
    {
        std::lock_guard lock(mutex_);
        return started_;
    }

  private:
    std::mutex mutex_;
    std::condition_variable changed_;
    std::vector<std::filesystem::path> started_;
    std::size_t released_ = 0;
};

bool readable(int fd, std::chrono::milliseconds timeout)
{
    pollfd p{fd, POLLIN, 0};
    return poll(&p, 1, static_cast<int>(timeout.count())) == 1 && (p.revents & POLLIN);
}

TEST(ConfigReload, TheCallerIsFreeWhileTheConfigurationIsRead)
{
    HeldLoads loads;
    ConfigReload reload([&](const std::filesystem::path& f) { return loads.load(f); });
    EXPECT_FALSE(reload.busy());
    reload.request("/etc/hullgauge/hullgauged.yaml");
    ASSERT_TRUE(loads.started(1));
    // The load is held: nothing to take, and request() has long returned.
    EXPECT_TRUE(reload.busy());
    EXPECT_FALSE(readable(reload.fd(), 0ms));
    EXPECT_FALSE(reload.take().has_value());
    loads.releaseOne();
    ASSERT_TRUE(readable(reload.fd(), 10'000ms));
    auto taken = reload.take();
    ASSERT_TRUE(taken.has_value());
    ASSERT_TRUE(taken->ok()) << taken->status().message();
    EXPECT_EQ(taken->value()->file, "/etc/hullgauge/hullgauged.yaml");
    EXPECT_FALSE(reload.busy());
    EXPECT_FALSE(readable(reload.fd(), 0ms)) << "taken once";
    EXPECT_FALSE(reload.take().has_value());
}

TEST(ConfigReload, ARefusedConfigurationSaysWhereAndWhy)
{
    HeldLoads loads;
    ConfigReload reload([&](const std::filesystem::path& f) { return loads.load(f); });
    loads.releaseOne();
    reload.request("/srv/bad.yaml");
    ASSERT_TRUE(readable(reload.fd(), 10'000ms));
    auto taken = reload.take();
    ASSERT_TRUE(taken.has_value());
    ASSERT_FALSE(taken->ok());
    EXPECT_NE(taken->status().message().find("octree.depth"), std::string::npos) << taken->status().message();
    EXPECT_NE(taken->status().message().find("16 is above 15"), std::string::npos) << taken->status().message();
}

// A SIGHUP during a reload: the file may have changed after it was read, so it is read once more.
TEST(ConfigReload, ARequestDuringAReloadReadsTheFileAgainAfterIt)
{
    HeldLoads loads;
    ConfigReload reload([&](const std::filesystem::path& f) { return loads.load(f); });
    reload.request("/srv/first.yaml");
    ASSERT_TRUE(loads.started(1));
    reload.request("/srv/second.yaml");
    reload.request("/srv/third.yaml"); // replaces the second: only the latest file counts
    loads.releaseOne();
    ASSERT_TRUE(loads.started(2));
    loads.releaseOne();
    std::filesystem::path last;
    for (int turn = 0; turn < 2 && (reload.busy() || last.empty()); ++turn) {
        ASSERT_TRUE(readable(reload.fd(), 10'000ms));
        if (auto taken = reload.take(); taken && taken->ok()) last = taken->value()->file;
    }
    EXPECT_EQ(last, "/srv/third.yaml");
    EXPECT_FALSE(reload.busy());
    EXPECT_EQ(loads.files(), (std::vector<std::filesystem::path>{"/srv/first.yaml", "/srv/third.yaml"}));
}

} // namespace
