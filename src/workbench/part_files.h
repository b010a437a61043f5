// The files of a part folder (docs/workbench.md, "The workspace") and the
// ways they are read, locked and replaced: shared by the workspace's
// translation units, not part of its interface.
#pragma once

#include "hullgauge/workbench/workspace.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace hg::model {
struct PartProgram;
struct CadModel;
} // namespace hg::model

namespace hg::workbench::files {

inline constexpr const char* kRecord = "workbench.yaml";
inline constexpr const char* kLock = ".lock";
inline constexpr const char* kSuggestions = "suggestions.json";
inline constexpr const char* kPlanJson = "plan.json";
inline constexpr const char* kPlanMd = "plan.md";
inline constexpr const char* kVerificationJson = "verification.json";
inline constexpr const char* kVerificationMd = "verification.md";
inline constexpr const char* kHistory = "history.jsonl";
inline constexpr const char* kDisplay = "display";
inline constexpr const char* kModelStl = "display/model.stl";
inline constexpr const char* kLodStl = "display/lod.stl";
/// The CAD model's facts (kind, triangles, bounds, digest), written at add.
inline constexpr const char* kModelFacts = "display/model.json";
/// The draft's landmarks as loaded (position, normal, where they lie), keyed
/// by the draft's digest: what a read shows without loading the CAD model.
inline constexpr const char* kLandmarkCache = "display/landmarks.json";

fs::path draftFile(const fs::path& partFolder, const std::string& part);
fs::path releasedFile(const fs::path& partFolder, const std::string& part);
fs::path viewsFile(const fs::path& partFolder, const std::string& part);
fs::path keptFolder(const fs::path& partFolder, const std::string& part, int version);

/// flock on `<part>/.lock`, held while the object lives: exclusive for a
/// change, shared for a read that must see the files of one change.
class PartLock {
  public:
    PartLock(const fs::path& partFolder, bool exclusive);
    ~PartLock();
    PartLock(const PartLock&) = delete;
    PartLock& operator=(const PartLock&) = delete;

  private:
    int fd_ = -1;
};

/// A file's bytes; InputError naming it when it cannot be read.
std::string readText(const fs::path& file);
/// Whether `path` exists (false when it cannot be told).
bool exists(const fs::path& path);
/// The std::filesystem operations a change needs, FaultError naming the path on failure.
void createFolders(const fs::path& folder);
void removeAll(const fs::path& path);
void copyFile(const fs::path& from, const fs::path& to);
/// Renames `from` to `to` unless `to` exists (renameat2 RENAME_NOREPLACE);
/// false when it exists.
bool renameNoReplace(const fs::path& from, const fs::path& to);
/// Renames a checked file into place and flushes its folder.
void renameInto(const fs::path& from, const fs::path& to);
/// Flushes a file written by another library (a mesh writer) to the disk.
void syncFile(const fs::path& file);

PartRecord readRecord(const fs::path& partFolder);
std::string recordYaml(const PartRecord& record);
void writeRecord(const fs::path& partFolder, const PartRecord& record);
/// Refuses a change made on an older revision (StaleRevision, the form of docs/workbench.md).
void checkRevision(const PartRecord& record, int revision);
/// The record after a change of the draft by `by`: revision + 1, who, when, what.
void recordChange(PartRecord& record, const Actor& by, const std::string& change);

/// The draft as a YAML document (any keys of a part program kept).
YAML::Node loadDraftNode(const fs::path& draft);
/// The draft's text as the workbench writes it.
std::string emitDraft(const YAML::Node& draft);
/// The draft's landmark entries (an empty sequence when it has none).
YAML::Node landmarksOf(const YAML::Node& draft);

/// The CAD model of the draft, read as `landmarks suggest` reads it (the
/// draft's octree depth and adjacency depth, its `mesh_solid`).
model::CadModel loadDraftCad(const fs::path& partFolder, const PartRecord& record, const YAML::Node& draft);
/// The draft loaded as the daemon loads a part program; a refusal names the
/// draft file (`shownAs`) in the loader's words.
model::PartProgram loadProgramAs(const fs::path& file, const std::string& shownAs);

/// The release record of a program file (`release`), read without loading
/// the program; none for a file that is absent or holds no record.
std::optional<Version> releaseRecordOf(const fs::path& program);

/// Appends one line to history.jsonl (the whole file replaced durably).
void appendHistory(const fs::path& partFolder, const nlohmann::json& line);

/// "(40, 0, 30)": a point as the workbench's messages write it.
std::string pointText(const Eigen::Vector3d& p);
/// "17.500": a distance in millimetres as the workbench's messages write it.
std::string mmText(double mm);

} // namespace hg::workbench::files
