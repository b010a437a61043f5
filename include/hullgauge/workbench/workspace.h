// The part workbench's workspace (docs/workbench.md): one folder a part,
// holding its CAD model, its draft part program, the display meshes the page
// draws, the last plan and verification, and every released version. Every
// change takes the part's lock, checks the revision it was made on and
// replaces each file durably only after the whole change has been checked
// (docs/workbench.md, "Nothing half-written, one writer at a time").
//
// These functions read and write files: the workbench is an application
// layer over the core (model, plan, commission), like the CLI and the daemon.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "hullgauge/common/enum_names.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/part_program.h"

namespace hg::workbench {

namespace fs = std::filesystem;

/// A part name: 1–64 of [A-Za-z0-9._-], starting with a letter or digit.
bool validPartName(std::string_view name);

/// The verification the last commissioning wrote (`workbench.yaml` `verified`).
struct Verified {
    int revision = 0;
    std::string draftSha256;
    std::string stationSha256;
    std::string verificationSha256;
    bool released = false; ///< the verification says the draft may be released
};

/// `workbench.yaml`: the part's record.
struct PartRecord {
    std::string part;
    std::string cad; ///< the CAD file's name in the part folder
    int revision = 1;
    std::string changedBy;
    std::string changedAt; ///< ISO 8601, local time with offset
    std::string change;    ///< "landmark c3 moved", "added", ...
    std::optional<int> plcProgram;
    std::optional<Verified> verified;
    /// `tolerance_mm`: the tolerance a new landmark gets (`part add --tolerance`).
    double toleranceMm = 0.1;
};

/// Where a placed landmark landed on the part (docs/workbench.md, "Landmarks").
enum class Placement { Face, Edge, Corner };
constexpr auto nameTable(Placement)
{
    using enum Placement;
    return std::to_array<EnumName<Placement>>({{Face, "face"}, {Edge, "edge"}, {Corner, "corner"}});
}

/// One landmark of the draft as the workbench shows it: as loaded (position on
/// the surface, normal unit and outward).
struct DraftLandmark {
    std::string id;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    bool normalGiven = false; ///< written in the draft (else the loader's, from the surface)
    std::optional<double> toleranceMm;
    std::optional<std::pair<double, double>> limitsMm;
    Placement on = Placement::Face;
};

/// The draft as the workbench shows it.
struct Draft {
    int depth = 8;
    int adjacencyDepth = 4;
    double defaultToleranceMm = 0.1; ///< what a new landmark gets
    /// The play of the part in its nest: the alignment's limits (part program
    /// `alignment.max_shift_mm`, `max_rotation_deg`, their defaults when absent).
    double maxShiftMm = model::AlignmentSettings{}.maxShiftMm;
    double maxRotationDeg = model::AlignmentSettings{}.maxRotationDeg;
    std::vector<DraftLandmark> landmarks;
};

/// A released version (`releases/<part>.v<N>/`).
struct Version {
    int version = 0;
    std::string releasedBy, releasedAt, verificationSha256;
    std::optional<int> rolledBackFrom;
    bool inForce = false;
};

/// A part under work: its record, its draft, the CAD model's facts.
struct PartState {
    PartRecord record;
    Draft draft;
    std::string cadKind; ///< "stl", "obj", "ply", "off", "step"
    std::size_t triangles = 0;
    Eigen::Vector3d boundsMin = Eigen::Vector3d::Zero(), boundsMax = Eigen::Vector3d::Zero();
    std::string cadSha256;
    std::optional<int> releasedVersion; ///< the version in force (`<part>.yaml`), if any
    std::optional<Version> released;    ///< its release record (inForce true)
};

/// Options of a new part (`hullgauge part add`).
struct AddOptions {
    std::string name; ///< empty: the CAD file's stem
    std::string solid;
    double toleranceMm = 0.1;
    int depth = 8;
    int adjacencyDepth = 4;
};

/// A change to one landmark; what is absent stays as it was (for a new
/// landmark: `position` is required, the rest defaults).
struct LandmarkEdit {
    std::optional<Eigen::Vector3d> position;
    std::optional<std::string> newId;
    std::optional<Eigen::Vector3d> normal;
    bool normalFromMesh = false; ///< drop a given normal: the loader's from the surface
    std::optional<double> toleranceMm;
    std::optional<std::pair<double, double>> limitsMm;
};

/// What placing a landmark did (docs/workbench.md, "Landmarks").
struct Placed {
    DraftLandmark landmark;
    double movedMm = 0.0; ///< from the point given to where it lies
    int revision = 0;     ///< the draft's revision after the change
};

/// Who makes a change (the signed-in engineer's name, the shell's user).
struct Actor {
    std::string name;
};

/// A released part the daemon runs beside its `programs:` table
/// (docs/workbench.md, "Released parts on the station").
struct ReleasedPart {
    std::string part;
    int plcProgram = 0; ///< the PLC's PART_PROGRAM number
    int version = 0;    ///< the version in force
    fs::path program;   ///< `<part>.yaml`
    fs::path views;     ///< `<part>-views.yaml`
    fs::path cad;       ///< the CAD model (what the simulated camera renders)
};

/// Called as commissioning proceeds (commission::Progress): the phase, the
/// cycles done and their total; return false to cancel between two cycles.
using Progress = std::function<bool(const std::string& phase, std::size_t done, std::size_t total)>;

/// `hullgauge part suggest`: as `landmarks suggest` (docs/part-program.md,
/// "Suggesting landmarks") at the draft's octree and default tolerance.
struct SuggestSettings {
    std::size_t count = 8;
    std::size_t twinSeats = 8; ///< seats each pick is proven at on the twin; 0: not on the twin
};

/// What `hullgauge part plan` found (plan.json and plan.md are written either way).
struct PlanOutcome {
    bool feasible = false;
    std::vector<std::string> problems; ///< one sentence each when not feasible
    std::size_t views = 0;
};

/// `hullgauge part commission`: the verification's settings (as `hullgauge commission`'s).
struct CommissionSettings {
    std::size_t seats = 20;
    std::vector<double> defectMultiples{1.0, 2.0, 3.0};
    std::uint64_t seed = 1;
    double seatShiftMm = -1.0; ///< < 0: 80 % of the draft's alignment limits
    double seatRotationDeg = -1.0;
    Progress progress; ///< may be empty
};

/// What commissioning the draft gave.
struct CommissionOutcome {
    /// 0 verified and releasable, 1 verified but not releasable, 2 no plan
    /// (as `hullgauge commission`'s exit status).
    int status = 0;
    std::optional<Verified> verified;  ///< the record written (none without a plan)
    std::vector<std::string> problems; ///< the plan's when there is none; else each finding in words
};

/// The workspace folder. Every function that changes a part takes its lock.
class Workspace {
  public:
    explicit Workspace(fs::path folder);
    const fs::path& folder() const { return folder_; }
    fs::path partFolder(std::string_view part) const; ///< InputError (404-like) for an invalid or absent part

    std::vector<PartState> list() const;
    PartState read(std::string_view part) const;

    /// A new part from a CAD file (docs/workbench.md, "Adding a part").
    PartState add(const fs::path& cadFile, const AddOptions& options, const Actor& by);
    /// The same from an upload's bytes, `fileName` giving its kind (extension).
    PartState addUpload(std::string_view fileName, std::string_view bytes, const AddOptions& options, const Actor& by);

    Placed addLandmark(std::string_view part, int revision, const std::optional<std::string>& id,
                       const LandmarkEdit& edit, const Actor& by);
    Placed changeLandmark(std::string_view part, int revision, const std::string& id, const LandmarkEdit& edit,
                          const Actor& by);
    int removeLandmark(std::string_view part, int revision, const std::string& id, const Actor& by);

    /// The display mesh's file (binary STL); `lod`: the simplified one.
    std::filesystem::path displayMeshFile(std::string_view part, bool lod) const;

    std::vector<Version> versions(std::string_view part) const;
    /// Every part with a released program in force and a PLC program number,
    /// by name; a part whose record cannot be read is left out (and logged).
    std::vector<ReleasedPart> releasedParts() const;

    /// Suggests landmarks on the part at the station (`stationFile`), keeping
    /// every candidate in suggestions.json; returns what it wrote.
    nlohmann::json suggest(std::string_view part, const fs::path& stationFile, const SuggestSettings& settings);
    /// Plans the draft at the station: plan.json and plan.md in the part folder.
    PlanOutcome plan(std::string_view part, const fs::path& stationFile);
    /// The planned views of plan.json with their cameras in the part frame
    /// (`GET /api/parts/{part}/views`): `{"views": [{index, id, pose,
    /// landmarks, camera: {centre, rotation, fx, fy, cx, cy, width, height,
    /// working_distance_mm}}]}`. InputError when the part has no plan.
    nlohmann::json views(std::string_view part, const fs::path& stationFile) const;
    /// View `view` (1-based) of plan.json as the twin renders the nominal
    /// part at it, with every landmark the view observes drawn (projection,
    /// silhouette point, normal, id): PNG bytes (docs/workbench.md, "Views").
    std::string viewImage(std::string_view part, const fs::path& stationFile, int view) const;

    /// Verifies the draft on the station's twin without releasing it
    /// (docs/workbench.md, "Proving and releasing"): plan, verification and
    /// report in the part folder, the `verified` record in workbench.yaml.
    /// A cancel (settings.progress returning false) throws
    /// commission::Cancelled and leaves the previous verification in place.
    CommissionOutcome commission(std::string_view part, const fs::path& stationFile, const CommissionSettings& settings,
                                 const Actor& by);
    /// Releases the verified draft as the next version (ReleaseRefused naming
    /// the condition unmet). `plcProgram` may be left out once the part has
    /// one; `takenPrograms` are the PLC program numbers the daemon's
    /// `programs:` table already uses.
    Version release(std::string_view part, int revision, const fs::path& stationFile, std::optional<int> plcProgram,
                    const std::vector<int>& takenPrograms, const Actor& by);
    /// Makes version `version` the one in force again as a new version.
    Version rollback(std::string_view part, int version, const Actor& by);
    /// Compares two versions, or a version and the draft (`"draft"`):
    /// `{from, to, landmarks: {added, removed, changed}, settings, views: {added, removed}}`.
    nlohmann::json diff(std::string_view part, const std::string& from, const std::string& to) const;

  private:
    PartState addFrom(const fs::path& staged, const std::string& name, const std::string& shownAs,
                      const AddOptions& options, const Actor& by);
    fs::path folder_;
};

/// The fraction of the part's bounding-box diagonal within which a placed
/// landmark snaps onto a sharp edge (`snap_mm`, docs/workbench.md).
inline constexpr double kSnapShareOfDiagonal = 0.02;
/// The largest display mesh drawn while the view moves (display/lod.stl).
inline constexpr std::size_t kLodTriangles = 25000;

/// The part as `GET /api/parts/{part}` answers its workspace facts:
/// `{name, revision, changed_by, changed_at, change, cad: {file, kind,
/// triangles, bounds_mm, sha256}, draft: {octree, tolerance_mm, landmarks},
/// plc_program, verified, released: {version, plc_program, released_by,
/// released_at, rolled_back_from}}`.
nlohmann::json toJson(const PartState& state);
nlohmann::json toJson(const Version& version);
nlohmann::json toJson(const Placed& placed);
/// A diff as lines of text, for the command line.
std::string diffText(const nlohmann::json& diff);

/// A change made on an older revision than the draft's (HTTP 409): names
/// the revision, who changed it, when and what.
struct StaleRevision : InputError {
    using InputError::InputError;
};

/// A part name that is not a part of the workspace (HTTP 404).
struct PartNotFound : InputError {
    using InputError::InputError;
};

/// A part of that name is already in the workspace (HTTP 409).
struct PartExists : InputError {
    using InputError::InputError;
};

/// A release or rollback refused (HTTP 409), naming the condition unmet.
struct ReleaseRefused : InputError {
    using InputError::InputError;
};

} // namespace hg::workbench
