// HTTP requests to the web HMI (docs/fuzzing.md): the input is what one client
// sends on one connection to the daemon's own HmiServer (cpp-httplib's request
// parsing, the guard of docs/hmi.md "Security", the routes and their
// parameters), on loopback. The connection is half-closed after the input, so
// the server sees the end of the request at once; the answer is read to its
// end. The main loop is absent (its mailbox refuses), the result store is
// empty, the clock moves a second per reading so the rate limits never stop
// the fuzzer. An answer that never comes is a hang (libFuzzer's -timeout).
#include "command_mailbox.h"
#include "fuzz_support.h"
#include "hmi/hmi_server.h"
#include "hullgauge/store/result_store.h"

#include <arpa/inet.h>
#include <atomic>
#include <memory>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace {

class FastClock : public hg::Clock {
  public:
    time_point now() const override { return time_point(std::chrono::seconds(++seconds_)); }
    wall_time wallNow() const override { return wall_time(std::chrono::seconds(seconds_.load())); }
    void sleepUntil(time_point, const std::function<bool()>&) override {}
    bool waitUntil(std::unique_lock<std::mutex>&, std::condition_variable&, time_point,
                   const std::function<bool()>& ready) override
    {
        return ready();
    }

  private:
    mutable std::atomic<std::int64_t> seconds_{1'000'000};
};

struct Hmi {
    FastClock clock;
    hg::daemon::CommandMailbox mailbox;
    std::unique_ptr<hg::daemon::HmiServer> server;

    Hmi()
    {
        const auto folder = hg::fuzz::workFolder();
        auto cfg = std::make_shared<hg::station::DaemonConfig>();
        cfg->results.database = folder / "results.db";
        cfg->results.imageDir = folder / "images";
        {
            hg::store::ResultStore store(cfg->results.database);
        }
        cfg->http.enabled = true;
        cfg->http.port = 0;
        cfg->http.assets = std::filesystem::path(HULLGAUGE_SOURCE_DIR) / "share/hmi";
        // "line secret", SHA-512 crypt with the fewest rounds: a sign-in costs little.
        cfg->http.passwordHash = "$6$rounds=1000$fuzzsalt$WqWUBTlMXK8ktuqK2G7ZrfMnF2WoMw5Pq9RKlWNn7eh.6YIvu.9JGM4V/"
                                 "V2/AH9NQL59iaXZSSytB0sNZdLEI.";
        cfg->http.threads = 2;
        mailbox.close();
        server = std::make_unique<hg::daemon::HmiServer>(cfg, mailbox, clock);
    }
};

void sendAll(int fd, const std::uint8_t* data, std::size_t size)
{
    while (size > 0) {
        const ssize_t n = send(fd, data, size, MSG_NOSIGNAL);
        if (n <= 0) return; // the server closed early (a refused request): its answer is still read
        data += n;
        size -= static_cast<std::size_t>(n);
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static Hmi hmi;
    const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(hmi.server->port()));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    // A refused connection is the machine's (ephemeral ports in TIME_WAIT, a full
    // backlog), not the server's answer to this input: the input is skipped.
    if (fd < 0) return 0;
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(fd);
        return 0;
    }
    sendAll(fd, data, size);
    shutdown(fd, SHUT_WR);
    char buf[65536];
    while (read(fd, buf, sizeof buf) > 0) {}
    close(fd);
    return 0;
}
