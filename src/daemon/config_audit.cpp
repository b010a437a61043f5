#include "config_audit.h"

#include "hullgauge/common/digest.h"
#include "hullgauge/common/log.h"

#include <fstream>
#include <sstream>
#include <vector>

namespace hg::daemon {

namespace {

/// The largest text kept whole; a bigger file is recorded by its digest and size.
constexpr std::uintmax_t kMaxKeptBytes = 1u << 20;

struct WatchedFile {
    std::filesystem::path path;
    std::string kind;
};

std::vector<WatchedFile> filesOf(const station::DaemonConfig& config)
{
    std::vector<WatchedFile> files{{config.file, "daemon configuration"}, {config.stationFile, "station file"}};
    for (const auto& [number, ref] : config.programs) {
        files.push_back({ref.partFile, "part program " + std::to_string(number)});
        if (!ref.viewsFile.empty()) files.push_back({ref.viewsFile, "view plan of program " + std::to_string(number)});
    }
    return files;
}

store::AuditLog::Watched readWatched(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) return {"unreadable", "(cannot be read)"};
    std::ostringstream bytes;
    bytes << in.rdbuf();
    const std::string text = bytes.str();
    const auto digest = sha256Hex(text);
    if (text.size() > kMaxKeptBytes)
        return {digest, "(" + std::to_string(text.size()) + " bytes, SHA-256 " + digest + "; not kept as text)"};
    return {digest, text};
}

} // namespace

int recordConfigurationFiles(store::AuditLog& audit, const station::DaemonConfig& config, const std::string& when,
                             std::int64_t wallMs)
{
    int recorded = 0;
    for (const auto& file : filesOf(config)) {
        const auto path = std::filesystem::absolute(file.path).lexically_normal().string();
        try {
            const auto now = readWatched(file.path);
            const auto before = audit.watched(path);
            if (before && before->sha256 == now.sha256) continue;
            store::AuditEntry entry;
            entry.atMs = wallMs;
            entry.who = "hullgauged";
            entry.source = "daemon";
            entry.action = before ? "file.changed" : "file.recorded";
            entry.object = path;
            entry.outcome = "done";
            entry.detail = file.kind + (before ? ", changed" : ", first recorded") + "; found at " + when;
            entry.before = before ? before->content : std::string();
            entry.after = now.content;
            audit.recordFileChange(path, now, std::move(entry));
            ++recorded;
        } catch (const std::exception& e) {
            // The trail failing never stops the station; the journal says what was not recorded.
            hg::log::category("daemon")->error("audit trail: {} not recorded: {}", path, e.what());
        }
    }
    return recorded;
}

} // namespace hg::daemon
