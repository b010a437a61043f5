// The workbench's HTTP API (docs/workbench.md, "HTTP API"): the parts of the
// workspace, their display meshes and landmarks, the views of their plan,
// their jobs (suggest, plan, commission: processes of their own, part_jobs.h)
// and their versions. Reads are open like every GET of the HMI; changes need
// a signed-in engineer's session and its CSRF token, each is recorded in the
// audit trail with the part before and after (docs/audit.md), and a release makes
// the daemon reload so the new version runs from its next cycle.
#pragma once

#include "command_mailbox.h"
#include "daemon_config.h"
#include "hmi/access.h"
#include "hmi/part_jobs.h"
#include "hmi/static_files.h"
#include "hullgauge/workbench/workspace.h"

#include <functional>
#include <memory>

namespace httplib {
class Server;
struct Request;
} // namespace httplib

namespace hg::daemon {

class PartsRoutes {
  public:
    using ConfigSource = std::function<std::shared_ptr<const station::DaemonConfig>()>;

    /// Routes /parts and /api/parts/… on `server` when `workbench` is configured.
    PartsRoutes(httplib::Server& server, const station::WorkbenchConfig& workbench, ConfigSource config, Access& access,
                CommandMailbox& mailbox, StaticFiles& files);

  private:
    void routeReads(httplib::Server& server);
    void routeLandmarks(httplib::Server& server);
    void routeJobs(httplib::Server& server);
    void routeVersions(httplib::Server& server);
    nlohmann::json partJson(const std::string& part) const;
    nlohmann::json reloaded(const std::string& part);
    /// The signed-in engineer allowed to change part programs (403, recorded, otherwise).
    Actor engineer(const httplib::Request& req, const std::string& action, const std::string& part);
    /// The part as the audit trail shows it before and after a change: revision, draft, PLC program, release.
    std::string auditState(const std::string& part) const;
    /// Runs `change` and records it with the part's state before and after (docs/audit.md).
    template <class Change>
    auto audited(const Actor& by, const std::string& action, const std::string& part, Change&& change);
    /// Runs `hullgauge part <args…>` and waits (at most `deadline`): its stdout; 409 with its words when it refuses.
    std::string runPart(const std::vector<std::string>& args, std::chrono::seconds deadline) const;

    station::WorkbenchConfig workbench_;
    workbench::Workspace workspace_;
    ConfigSource config_;
    Access& access_;
    CommandMailbox& mailbox_;
    StaticFiles& files_;
    std::unique_ptr<PartJobs> jobs_;
};

} // namespace hg::daemon
