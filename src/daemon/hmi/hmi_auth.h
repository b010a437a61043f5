// The web HMI's guards (docs/hmi.md, "Security"): the signed-in people's
// sessions (their account and role, docs/audit.md) with their CSRF tokens, and a token-bucket
// rate limit per client address. No HTTP here: the server asks these and
// answers 401/403/429 itself; the clock is injected so the tests move it.
#pragma once

#include "hullgauge/common/clock.h"
#include "hullgauge/store/accounts.h"

#include <cstddef>
#include <map>
#include <mutex>
#include <optional>
#include <string>

namespace hg::daemon {

// The password checks live with the accounts (hullgauge/store/accounts.h), one implementation for the
// daemon and the tool.
using store::validPasswordHash;
using store::verifyPassword;

/// Signed-in maintenance sessions: an unguessable id (the HttpOnly cookie)
/// and its CSRF token (sent back in the X-CSRF-Token header of every
/// state-changing request). A session idle longer than `idle` is gone.
class Sessions {
  public:
    Sessions(Clock::duration idle, Clock& clock = Clock::steady());

    struct Session {
        std::string id;
        std::string csrf;
        /// The account signed in (docs/audit.md, "Roles"); with the shared maintenance
        /// password, the name given, which is what they said, not a proof.
        std::string name;
        store::Role role = store::Role::Engineer;
        bool shared = false; ///< signed in with the shared maintenance password, not an account's own
    };
    Session open(std::string name = {}, store::Role role = store::Role::Engineer, bool shared = false);
    /// The session when `id` is live (its idle time restarts), else nothing.
    std::optional<Session> touch(const std::string& id);
    void close(const std::string& id);

    static constexpr std::size_t kMaxSessions = 64;

  private:
    void expire();

    struct Entry {
        Session session;
        Clock::time_point last;
    };
    Clock::duration idle_;
    Clock& clock_;
    std::mutex mutex_;
    std::map<std::string, Entry> sessions_;
};

/// A token bucket per client address: `burst` requests at once, refilled at
/// `perSecond`. Addresses idle long enough to be full again are forgotten, so
/// the table stays bounded.
class RateLimiter {
  public:
    RateLimiter(double perSecond, double burst, Clock& clock = Clock::steady());
    /// Takes `cost` tokens for `address`; false (and nothing taken) when it has not enough.
    bool allow(const std::string& address, double cost = 1.0);

    static constexpr std::size_t kMaxAddresses = 4096;

  private:
    struct Bucket {
        double tokens;
        Clock::time_point last;
    };
    double perSecond_;
    double burst_;
    Clock& clock_;
    std::mutex mutex_;
    std::map<std::string, Bucket> buckets_;
};

/// `bytes` random bytes from the kernel (getrandom), hex-encoded.
std::string randomToken(std::size_t bytes = 32);

} // namespace hg::daemon
