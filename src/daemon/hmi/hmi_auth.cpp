#include "hmi/hmi_auth.h"

#include "hullgauge/common/error.h"

#include <algorithm>
#include <array>
#include <crypt.h>
#include <cstring>
#include <memory>
#include <sys/random.h>

namespace hg::daemon {

bool validPasswordHash(const std::string& hash)
{
    static constexpr std::array<const char*, 6> kPrefixes{"$y$", "$gy$", "$7$", "$6$", "$5$", "$2b$"};
    const bool known =
        std::any_of(kPrefixes.begin(), kPrefixes.end(), [&](const char* p) { return hash.rfind(p, 0) == 0; });
    // A whole hash: method, salt and the hashed password ("$6$salt$hash"), not a setting alone;
    // crypt_checksalt says whether this libcrypt supports the method and the setting is well formed.
    const auto fields = std::count(hash.begin(), hash.end(), '$');
    return known && fields >= 3 && hash.back() != '$' && hash.size() >= 20 &&
           crypt_checksalt(hash.c_str()) == CRYPT_SALT_OK;
}

bool verifyPassword(const std::string& password, const std::string& hash)
{
    if (!validPasswordHash(hash)) return false;
    auto data = std::make_unique<crypt_data>();
    const char* out = crypt_r(password.c_str(), hash.c_str(), data.get());
    // A failed crypt_r returns a string starting with '*', never the hash itself.
    if (!out || out[0] == '*') return false;
    const std::size_t n = std::strlen(out);
    if (n != hash.size()) return false;
    unsigned char diff = 0;
    for (std::size_t i = 0; i < n; ++i) diff |= static_cast<unsigned char>(out[i] ^ hash[i]);
    return diff == 0;
}

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

Sessions::Session Sessions::open(std::string name)
{
    std::lock_guard lock(mutex_);
    expire();
    // Bounded: the longest idle session yields to a new sign-in.
    if (sessions_.size() >= kMaxSessions) {
        auto oldest = std::min_element(sessions_.begin(), sessions_.end(),
                                       [](const auto& a, const auto& b) { return a.second.last < b.second.last; });
        sessions_.erase(oldest);
    }
    Session s{randomToken(), randomToken(), std::move(name)};
    sessions_[s.id] = {s.csrf, s.name, clock_.now()};
    return s;
}

std::optional<Sessions::Session> Sessions::touch(const std::string& id)
{
    std::lock_guard lock(mutex_);
    expire();
    auto it = sessions_.find(id);
    if (it == sessions_.end()) return std::nullopt;
    it->second.last = clock_.now();
    return Session{id, it->second.csrf, it->second.name};
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
