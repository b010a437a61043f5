#include "daemon_harness.h"
#include "hgtest/station.h"

#include <arpa/inet.h>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <netinet/in.h>
#include <signal.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace hgdaemon {

int freePort()
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    socklen_t len = sizeof addr;
    getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    close(fd);
    return ntohs(addr.sin_port);
}

std::filesystem::path writeConfig(const hgtest::TempDir& dir, int port, const std::string& extra, int views)
{
    hgtest::writeFile(dir / "station.yaml", hgtest::stationYaml({.imageSize = {64, 48}, .focalPx = 80}));
    hgtest::writeFile(dir / "part.yaml", "part: fake-block\nmesh: block.stl\nlandmarks:\n"
                                         "  - {id: L0, position: [0, 0, 10], tolerance_mm: 0.2}\n");
    std::string poses;
    for (int k = 0; k < views; ++k) poses += "- {rotation_deg: " + std::to_string(k * 20) + ", declination_deg: 20}\n";
    hgtest::writeFile(dir / "views.yaml", poses);
    return hgtest::writeFile(dir / "hullgauged.yaml", "station: station.yaml\n"
                                                      "programs:\n"
                                                      "  1: {part: part.yaml, views: views.yaml}\n"
                                                      "plc: {bind: 127.0.0.1, port: " +
                                                          std::to_string(port) +
                                                          ", heartbeat_period_s: 0.2}\n"
                                                          "results: {database: results.db, images: images}\n"
                                                          "maintenance: {socket: hg.sock}\n"
                                                          "sequencer: {move_timeout_s: 0.3, grab_timeout_s: 0.2, "
                                                          "settle_s: 0.001}\n" +
                                                          extra);
}

DaemonProcess::DaemonProcess(const std::filesystem::path& config, std::map<std::string, std::string> env,
                             std::vector<std::string> args)
{
    log_ = config.parent_path() / "daemon.log";
    auto program = hgtest::binaryDir() / "tests" / "hullgauged-fake";
    pid_ = fork();
    if (pid_ == 0) {
        int fd = open(log_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
        dup2(fd, 1);
        dup2(fd, 2);
        for (auto& [k, v] : env) setenv(k.c_str(), v == "$PID" ? std::to_string(getpid()).c_str() : v.c_str(), 1);
        std::vector<std::string> words{program, "--config", config, "--log", "info"};
        words.insert(words.end(), args.begin(), args.end());
        std::vector<char*> argv;
        for (auto& w : words) argv.push_back(w.data());
        argv.push_back(nullptr);
        execv(program.c_str(), argv.data());
        _exit(127);
    }
}

DaemonProcess::~DaemonProcess()
{
    if (pid_ > 0) {
        kill(pid_, SIGKILL);
        waitpid(pid_, nullptr, 0);
    }
}

int DaemonProcess::signal(int sig)
{
    kill(pid_, sig);
    if (sig == SIGTERM || sig == SIGKILL || sig == SIGINT) return wait(std::chrono::seconds(15));
    return 0;
}

int DaemonProcess::wait(std::chrono::milliseconds timeout)
{
    auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
        int status = 0;
        if (waitpid(pid_, &status, WNOHANG) == pid_) {
            pid_ = -1;
            return status;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
}

std::string DaemonProcess::logText() const
{
    return readText(log_);
}

bool eventually(const std::function<bool()>& condition, std::chrono::milliseconds deadline)
{
    const auto until = std::chrono::steady_clock::now() + deadline;
    while (!condition()) {
        if (std::chrono::steady_clock::now() > until) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
}

std::size_t occurrences(const std::string& text, const std::string& what)
{
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

std::string readText(const std::filesystem::path& file)
{
    std::ifstream in(file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

nlohmann::json maintenance(const std::filesystem::path& socketPath, const nlohmann::json& request)
{
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, socketPath.c_str(), sizeof addr.sun_path - 1);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(fd);
        return nullptr;
    }
    auto text = request.dump() + "\n";
    (void)!write(fd, text.data(), text.size());
    std::string answer;
    char buf[4096];
    ssize_t n;
    while ((n = read(fd, buf, sizeof buf)) > 0) answer.append(buf, static_cast<std::size_t>(n));
    close(fd);
    return nlohmann::json::parse(answer, nullptr, false);
}

bool waitForState(const std::filesystem::path& socket, const std::string& state, std::chrono::milliseconds timeout)
{
    auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
        auto s = maintenance(socket, {{"command", "status"}});
        if (s.is_object() && s.value("ok", false) && s["sequencer"]["state"] == state) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
}

hgtest::RunResult plcClient(int port, const std::string& args)
{
    auto tool = hgtest::sourceDir() / "tools" / "plc-client";
    return hgtest::run("/usr/bin/python3 " + tool.string() + " --port " + std::to_string(port) + " " + args);
}

} // namespace hgdaemon
