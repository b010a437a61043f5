#include "hmi/hmi_auth.h"

#include "hullgauge/common/error.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <memory>
#include <sys/random.h>

namespace hg::daemon {

std::string randomToken(std::size_t bytes)
{
    std::string raw(bytes, '\0');
    std::size_t got = 0;
    while (got < bytes) {
        const ssize_t n = getrandom(raw.data() + got, bytes - got, 0);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw FaultError(std::string("getrandom: ") + std::strerror(errno));
        }
        got += static_cast<std::size_t>(n);
    }
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    hex.reserve(2 * bytes);
    for (unsigned char c : raw) {
        hex += kHex[c >> 4];
        hex += kHex[c & 15];
    }
    return hex;
}

Sessions::Sessions(Clock::duration idle, Clock& clock) : idle_(idle), clock_(clock)
{
}

void Sessions::expire()
{
    const auto now = clock_.now();
    std::erase_if(sessions_, [&](const auto& kv) { return now - kv.second.last > idle_; });
}

Sessions::Session Sessions::open(std::string name, store::Role role, bool shared)
{
    std::lock_guard lock(mutex_);
    expire();
    // Bounded: the longest idle session yields to a new sign-in.
    if (sessions_.size() >= kMaxSessions) {
        auto oldest = std::min_element(sessions_.begin(), sessions_.end(),
                                       [](const auto& a, const auto& b) { return a.second.last < b.second.last; });
        sessions_.erase(oldest);
    }
    Session s{randomToken(), randomToken(), std::move(name), role, shared};
    sessions_[s.id] = {s, clock_.now()};
    return s;
}

std::optional<Sessions::Session> Sessions::touch(const std::string& id)
{
    std::lock_guard lock(mutex_);
    expire();
    auto it = sessions_.find(id);
    if (it == sessions_.end()) return std::nullopt;
    it->second.last = clock_.now();
    return it->second.session;
}

void Sessions::close(const std::string& id)
{
    std::lock_guard lock(mutex_);
    sessions_.erase(id);
}

RateLimiter::RateLimiter(double perSecond, double burst, Clock& clock)
    : perSecond_(perSecond), burst_(burst), clock_(clock)
{
}

bool RateLimiter::allow(const std::string& address, double cost)
{
    std::lock_guard lock(mutex_);
    const auto now = clock_.now();
    if (buckets_.size() >= kMaxAddresses) {
        // A bucket that has refilled completely carries no information.
        std::erase_if(buckets_, [&](const auto& kv) {
            const double refill = std::chrono::duration<double>(now - kv.second.last).count() * perSecond_;
            return kv.second.tokens + refill >= burst_;
        });
        if (buckets_.size() >= kMaxAddresses) return false; // a flood of addresses: refuse the new ones
    }
    auto [it, fresh] = buckets_.try_emplace(address, Bucket{burst_, now});
    Bucket& b = it->second;
    if (!fresh) {
        const double elapsed = std::chrono::duration<double>(now - b.last).count();
        b.tokens = std::min(burst_, b.tokens + elapsed * perSecond_);
        b.last = now;
    }
    if (b.tokens < cost) return false;
    b.tokens -= cost;
    return true;
}

} // namespace hg::daemon
