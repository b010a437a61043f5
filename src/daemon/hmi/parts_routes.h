// The workbench's HTTP API (docs/workbench.md, "HTTP API"): the parts of the
// workspace, their display meshes and landmarks, the views of their plan,
// their jobs (suggest, plan, commission: processes of their own, part_jobs.h)
// and their versions. Reads are open like every GET of the HMI; changes need
// the signed-in engineer's session and its CSRF token, and a release makes
// the daemon reload so the new version runs from its next cycle.
#pragma once

#include "command_mailbox.h"
#include "daemon_config.h"
#include "hmi/hmi_auth.h"
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
    using SignedIn = std::function<Sessions::Session(const httplib::Request&)>;

    /// Routes /parts and /api/parts/… on `server` when `workbench` is configured.
    PartsRoutes(httplib::Server& server, const station::WorkbenchConfig& workbench, ConfigSource config,
                SignedIn signedIn, CommandMailbox& mailbox, StaticFiles& files);

  private:
    void routeReads(httplib::Server& server);
    void routeLandmarks(httplib::Server& server);
    void routeJobs(httplib::Server& server);
    void routeVersions(httplib::Server& server);
    nlohmann::json partJson(const std::string& part) const;
    nlohmann::json reloaded(const std::string& part);
    /// Runs `hullgauge part <args…>` and waits (at most `deadline`): its stdout; 409 with its words when it refuses.
    std::string runPart(const std::vector<std::string>& args, std::chrono::seconds deadline) const;

    station::WorkbenchConfig workbench_;
    workbench::Workspace workspace_;
    ConfigSource config_;
    SignedIn signedIn_;
    CommandMailbox& mailbox_;
    StaticFiles& files_;
    std::unique_ptr<PartJobs> jobs_;
};

} // namespace hg::daemon
