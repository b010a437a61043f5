#include "part_files.h"

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/format.h"
#include "hullgauge/model/part_program.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace hg::workbench::files {

fs::path draftFile(const fs::path& partFolder, const std::string& part)
{
    return partFolder / (part + ".draft.yaml");
}

fs::path releasedFile(const fs::path& partFolder, const std::string& part)
{
    return partFolder / (part + ".yaml");
}

fs::path viewsFile(const fs::path& partFolder, const std::string& part)
{
    return partFolder / (part + "-views.yaml");
}

fs::path keptFolder(const fs::path& partFolder, const std::string& part, int version)
{
    return partFolder / "releases" / (part + ".v" + std::to_string(version));
}

namespace {

[[noreturn]] void fail(const fs::path& path, const std::string& what, const std::string& why)
{
    throw FaultError(path.string() + ": " + what + ": " + why);
}

} // namespace

PartLock::PartLock(const fs::path& partFolder, bool exclusive)
{
    const fs::path file = partFolder / kLock;
    fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) fail(file, "cannot open the part's lock", std::strerror(errno));
    // Waits for the other writer (the HMI, a shell's `hullgauge part`): a change is short.
    while (::flock(fd_, exclusive ? LOCK_EX : LOCK_SH) != 0) {
        if (errno == EINTR) continue;
        const int err = errno;
        ::close(fd_);
        fail(file, "cannot lock the part", std::strerror(err));
    }
}

PartLock::~PartLock()
{
    if (fd_ >= 0) ::close(fd_); // closing releases the flock
}

std::string readText(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(file.string(), "", "cannot be read");
    std::ostringstream s;
    s << in.rdbuf();
    if (in.bad()) throw InputError(file.string(), "", "cannot be read");
    return s.str();
}

bool exists(const fs::path& path)
{
    std::error_code ec;
    return fs::exists(path, ec);
}

void createFolders(const fs::path& folder)
{
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec) fail(folder, "cannot create the folder", ec.message());
}

void removeAll(const fs::path& path)
{
    std::error_code ec;
    fs::remove_all(path, ec);
    if (ec) fail(path, "cannot remove it", ec.message());
}

void copyFile(const fs::path& from, const fs::path& to)
{
    std::error_code ec;
    fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
    if (ec) fail(to, "cannot copy " + from.string() + " to it", ec.message());
    syncFile(to);
}

bool renameNoReplace(const fs::path& from, const fs::path& to)
{
    if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0) {
        syncFolder(to.parent_path().empty() ? fs::path(".") : to.parent_path());
        return true;
    }
    if (errno == EEXIST || errno == ENOTEMPTY) return false;
    fail(to, "cannot rename " + from.string() + " to it", std::strerror(errno));
}

void renameInto(const fs::path& from, const fs::path& to)
{
    std::error_code ec;
    fs::rename(from, to, ec);
    if (ec) fail(to, "cannot replace it with " + from.string(), ec.message());
    syncFolder(to.parent_path().empty() ? fs::path(".") : to.parent_path());
}

void syncFile(const fs::path& file)
{
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) fail(file, "cannot open", std::strerror(errno));
    const int synced = ::fsync(fd);
    const int err = errno;
    ::close(fd);
    if (synced != 0) fail(file, "cannot flush to disk", std::strerror(err));
}

namespace {

Verified parseVerified(const ConfigNode& node)
{
    node.allowOnlyKeys({"revision", "draft_sha256", "station_sha256", "verification_sha256", "released"});
    Verified v;
    v.revision = static_cast<int>(node["revision"].asIntIn(1, 1 << 30));
    v.draftSha256 = node["draft_sha256"].asString();
    v.stationSha256 = node["station_sha256"].asString();
    v.verificationSha256 = node["verification_sha256"].asString();
    v.released = node["released"].asBool();
    return v;
}

} // namespace

PartRecord readRecord(const fs::path& partFolder)
{
    const ConfigNode root = ConfigNode::loadFile(partFolder / kRecord);
    if (!root.isMap()) root.fail("expected a map with keys part, cad, revision, ...");
    root.allowOnlyKeys(
        {"part", "cad", "revision", "changed_by", "changed_at", "change", "plc_program", "verified", "tolerance_mm"});
    PartRecord r;
    r.part = root["part"].asString();
    if (!validPartName(r.part)) root["part"].fail("'" + r.part + "' is no part name");
    r.cad = root["cad"].asString();
    if (r.cad.empty() || r.cad.find('/') != std::string::npos) root["cad"].fail("expected a file name in the folder");
    r.revision = static_cast<int>(root["revision"].asIntIn(1, 1 << 30));
    if (auto n = root.optional("changed_by")) r.changedBy = n->asString();
    if (auto n = root.optional("changed_at")) r.changedAt = n->asString();
    if (auto n = root.optional("change")) r.change = n->asString();
    if (auto n = root.optional("plc_program"); n && !n->isNull()) r.plcProgram = static_cast<int>(n->asIntIn(1, 65535));
    if (auto n = root.optional("verified"); n && !n->isNull()) r.verified = parseVerified(*n);
    if (auto n = root.optional("tolerance_mm")) r.toleranceMm = n->asPositive();
    return r;
}

std::string recordYaml(const PartRecord& record)
{
    YAML::Emitter out;
    out << YAML::BeginMap;
    out << YAML::Key << "part" << YAML::Value << record.part;
    out << YAML::Key << "cad" << YAML::Value << record.cad;
    out << YAML::Key << "revision" << YAML::Value << record.revision;
    out << YAML::Key << "changed_by" << YAML::Value << YAML::DoubleQuoted << record.changedBy;
    out << YAML::Key << "changed_at" << YAML::Value << record.changedAt;
    out << YAML::Key << "change" << YAML::Value << YAML::DoubleQuoted << record.change;
    out << YAML::Key << "tolerance_mm" << YAML::Value << formatNumber(record.toleranceMm, 12);
    if (record.plcProgram) out << YAML::Key << "plc_program" << YAML::Value << *record.plcProgram;
    if (record.verified) {
        const Verified& v = *record.verified;
        out << YAML::Key << "verified" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "revision" << YAML::Value << v.revision;
        out << YAML::Key << "draft_sha256" << YAML::Value << v.draftSha256;
        out << YAML::Key << "station_sha256" << YAML::Value << v.stationSha256;
        out << YAML::Key << "verification_sha256" << YAML::Value << v.verificationSha256;
        out << YAML::Key << "released" << YAML::Value << v.released;
        out << YAML::EndMap;
    }
    out << YAML::EndMap;
    return std::string("# The part's record in the workbench (docs/workbench.md).\n") + out.c_str() + "\n";
}

void writeRecord(const fs::path& partFolder, const PartRecord& record)
{
    replaceFileDurably(partFolder / kRecord, recordYaml(record));
}

void checkRevision(const PartRecord& record, int revision)
{
    if (revision == record.revision) return;
    // "10:32:05" of "2026-12-07T10:32:05+01:00".
    const std::string at = record.changedAt.size() >= 19 ? record.changedAt.substr(11, 8) : record.changedAt;
    throw StaleRevision("", "",
                        "the draft of " + record.part + " is at revision " + std::to_string(record.revision) + " (" +
                            record.changedBy + ", " + at + ": " + record.change +
                            "); this change was made on revision " + std::to_string(revision) +
                            ": reload the part and make it again");
}

void recordChange(PartRecord& record, const Actor& by, const std::string& change)
{
    ++record.revision;
    record.changedBy = by.name;
    record.changedAt = localTimestamp();
    record.change = change;
}

YAML::Node loadDraftNode(const fs::path& draft)
{
    const std::string text = readText(draft);
    YAML::Node node;
    try {
        node = YAML::Load(text);
    } catch (const YAML::Exception& e) {
        throw InputError(draft.string(), "", "not a YAML document: " + std::string(e.what()));
    }
    if (!node.IsMap()) throw InputError(draft.string(), "", "expected a part program (a map)");
    return node;
}

std::string emitDraft(const YAML::Node& draft)
{
    // A list of landmarks one a line, the empty list as [].
    if (draft["landmarks"] && draft["landmarks"].IsSequence()) {
        YAML::Node landmarks = YAML::Node(draft)["landmarks"]; // the same node: yaml-cpp's nodes are references
        landmarks.SetStyle(landmarks.size() == 0 ? YAML::EmitterStyle::Flow : YAML::EmitterStyle::Block);
    }
    YAML::Emitter out;
    out << draft;
    return std::string("# Draft part program of the part workbench (docs/workbench.md).\n") + out.c_str() + "\n";
}

YAML::Node landmarksOf(const YAML::Node& draft)
{
    if (draft["landmarks"] && draft["landmarks"].IsSequence()) return draft["landmarks"];
    return YAML::Node(YAML::NodeType::Sequence);
}

model::CadModel loadDraftCad(const fs::path& partFolder, const PartRecord& record, const YAML::Node& draft)
{
    int depth = 8, adjacency = 4;
    std::string solid;
    try {
        if (draft["octree"] && draft["octree"]["depth"]) depth = draft["octree"]["depth"].as<int>();
        if (draft["octree"] && draft["octree"]["adjacency_depth"])
            adjacency = draft["octree"]["adjacency_depth"].as<int>();
        if (draft["mesh_solid"]) solid = draft["mesh_solid"].as<std::string>();
    } catch (const YAML::Exception& e) {
        throw InputError(draftFile(partFolder, record.part).string(), "octree", e.what());
    }
    return model::loadCadModel(partFolder / record.cad, depth, adjacency, solid);
}

model::PartProgram loadProgramAs(const fs::path& file, const std::string& shownAs)
{
    try {
        return model::loadPartProgram(file);
    } catch (const InputError& e) {
        // The loader names the file it read: the draft as it would be.
        if (e.file() != file.string()) throw;
        throw InputError(shownAs, e.field(), e.problem(), e.line());
    }
}

std::optional<Version> releaseRecordOf(const fs::path& program)
{
    if (!files::exists(program)) return std::nullopt;
    const ConfigNode root = ConfigNode::loadFile(program);
    if (!root.isMap() || !root.has("release")) return std::nullopt;
    const ConfigNode r = root["release"];
    Version v;
    v.version = static_cast<int>(r["version"].asIntIn(1, 1000000));
    v.verificationSha256 = r["verification_sha256"].asString();
    v.releasedBy = r["released_by"].asString();
    v.releasedAt = r["released_at"].asString();
    if (auto n = r.optional("rolled_back_from")) v.rolledBackFrom = static_cast<int>(n->asIntIn(1, 1000000));
    return v;
}

void appendHistory(const fs::path& partFolder, const nlohmann::json& line)
{
    const fs::path file = partFolder / kHistory;
    std::string text = files::exists(file) ? readText(file) : std::string();
    if (!text.empty() && text.back() != '\n') text += '\n';
    replaceFileDurably(file, text + line.dump() + "\n");
}

std::string mmText(double mm)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.3f", mm);
    return b;
}

std::string pointText(const Eigen::Vector3d& p)
{
    return "(" + formatNumber(p.x()) + ", " + formatNumber(p.y()) + ", " + formatNumber(p.z()) + ")";
}

} // namespace hg::workbench::files
