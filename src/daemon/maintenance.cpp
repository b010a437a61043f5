#include "maintenance.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <cerrno>
#include <cstring>
#include <grp.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

namespace hg::daemon {

MaintenanceServer::MaintenanceServer(std::filesystem::path path, const std::string& group, Handler handler)
    : path_(std::move(path)), handler_(std::move(handler))
{
    auto fail = [&](const std::string& what) {
        std::string why = std::strerror(errno);
        if (fd_ >= 0) close(fd_);
        fd_ = -1;
        throw FaultError("maintenance socket " + path_.string() + ": " + what + ": " + why);
    };
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path_.string().size() >= sizeof addr.sun_path) {
        errno = ENAMETOOLONG;
        fail("path too long");
    }
    std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
    std::error_code ec;
    std::filesystem::create_directories(path_.parent_path(), ec);
    // A socket left by a daemon that was killed: nobody listens on it any more.
    if (std::filesystem::is_socket(path_, ec)) std::filesystem::remove(path_, ec);
    fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd_ < 0) fail("socket");
    // Create it with 0660 directly (no window in which others could connect).
    mode_t old = umask(0117);
    int rc = bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    umask(old);
    if (rc != 0) fail("bind");
    if (!group.empty()) {
        struct group* entry = getgrnam(group.c_str());
        if (!entry) {
            errno = ENOENT;
            fail("unknown group '" + group + "'");
        }
        if (chown(path_.c_str(), static_cast<uid_t>(-1), entry->gr_gid) != 0) fail("chown to group " + group);
    }
    if (listen(fd_, 8) != 0) fail("listen");
    hg::log::category("daemon")->info("maintenance socket {}", path_.string());
}

MaintenanceServer::~MaintenanceServer()
{
    if (fd_ >= 0) {
        close(fd_);
        std::error_code ec;
        std::filesystem::remove(path_, ec);
    }
}

void MaintenanceServer::serveOne()
{
    int client = accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) return;
    timeval tv{1, 0};
    setsockopt(client, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    setsockopt(client, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    std::string line;
    char buf[512];
    while (line.find('\n') == std::string::npos && line.size() < 64 * 1024) {
        ssize_t n = read(client, buf, sizeof buf);
        if (n <= 0) break;
        line.append(buf, static_cast<std::size_t>(n));
    }
    nlohmann::json answer;
    auto request = nlohmann::json::parse(line.substr(0, line.find('\n')), nullptr, false);
    if (request.is_discarded() || !request.is_object() || !request.contains("command")) {
        answer = {{"ok", false}, {"error", "expected one JSON object with a \"command\" on one line"}};
    } else {
        try {
            answer = handler_(request);
        } catch (const std::exception& e) {
            answer = {{"ok", false}, {"error", e.what()}};
        }
    }
    auto text = answer.dump() + "\n";
    std::size_t sent = 0;
    while (sent < text.size()) {
        ssize_t n = write(client, text.data() + sent, text.size() - sent);
        if (n <= 0) break;
        sent += static_cast<std::size_t>(n);
    }
    close(client);
}

} // namespace hg::daemon
