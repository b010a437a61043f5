// Who may do what on the web HMI, and the record of it (docs/audit.md): the
// sign-in against each person's account (or the shared maintenance password,
// as an engineer), the sessions with their role, the check of every
// state-changing request against the role's rights — a refusal is a 403 and an
// entry in the audit trail —, the administrator's accounts API and the audit
// trail's API (JSON and CSV).
#pragma once

#include "daemon_config.h"
#include "hmi/hmi_auth.h"
#include "hullgauge/store/accounts.h"
#include "hullgauge/store/audit_log.h"

#include <functional>
#include <memory>
#include <mutex>
#include <sys/types.h>

namespace httplib {
class Server;
struct Request;
} // namespace httplib

namespace hg::daemon {

/// The person behind a request, as the audit trail names them.
struct Actor {
    std::string name;
    store::Role role = store::Role::Operator;
    std::string source; ///< `hmi <client address>`
    bool shared = false;
};

class Access {
  public:
    using ConfigSource = std::function<std::shared_ptr<const station::DaemonConfig>()>;

    Access(ConfigSource config, std::shared_ptr<store::AuditLog> audit, Clock& clock);

    /// The signed-in person of a state-changing request (CSRF token checked), allowed `permission`:
    /// 401 without a session, 403 with a bad token, 403 and an audit entry (`action` on `object`,
    /// refused) when the role does not hold the right.
    Actor authorize(const httplib::Request& req, store::Permission permission, const std::string& action,
                    const std::string& object = {});
    /// The same for a reading that needs a session (the audit trail, the accounts): no CSRF token.
    Actor reader(const httplib::Request& req, store::Permission permission);
    /// Appends to the audit trail; the time is the clock's wall time. A failure to write is logged,
    /// never turned into the request's failure after the change was made.
    void record(const Actor& by, const std::string& action, const std::string& object, const std::string& outcome,
                const std::string& detail = {}, const std::string& before = {}, const std::string& after = {});

    /// POST /api/login, /api/logout, GET /api/session, the accounts API and GET /api/audit.
    void route(httplib::Server& server);

  private:
    void routeSession(httplib::Server& server);
    void routeAccounts(httplib::Server& server);
    void routeAudit(httplib::Server& server);
    /// The session's person with their role as the accounts file says now (a removed account's session
    /// ends, a changed role applies at once); 401 without one.
    std::pair<Actor, Sessions::Session> current(const httplib::Request& req);
    /// Nothing when the role holds `permission`; else the refusal recorded and thrown as 403.
    void requireRight(const Actor& actor, store::Permission permission, const std::string& action,
                      const std::string& object);
    /// The accounts file, read again only when it changed on disk (the tool writes it too).
    std::vector<store::Account> accounts();

    ConfigSource config_;
    std::shared_ptr<store::AuditLog> audit_;
    Clock& clock_;
    Sessions sessions_;
    RateLimiter signIns_;

    std::mutex accountsMutex_;
    std::vector<store::Account> accounts_;
    struct FileKey {
        dev_t dev = 0;
        ino_t ino = 0;
        off_t size = -1;
        long long mtimeNs = -1;
        std::string path;
        bool operator==(const FileKey&) const = default;
    } accountsKey_;
};

} // namespace hg::daemon
