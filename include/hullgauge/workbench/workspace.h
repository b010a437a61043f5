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
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hullgauge/common/enum_names.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"

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
    std::vector<DraftLandmark> landmarks;
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

/// A released version (`releases/<part>.v<N>/`).
struct Version {
    int version = 0;
    std::string releasedBy, releasedAt, verificationSha256;
    std::optional<int> rolledBackFrom;
    bool inForce = false;
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
    PartState addUpload(std::string_view fileName, std::string_view bytes, const AddOptions& options,
                        const Actor& by);

    Placed addLandmark(std::string_view part, int revision, const std::optional<std::string>& id,
                       const LandmarkEdit& edit, const Actor& by);
    Placed changeLandmark(std::string_view part, int revision, const std::string& id, const LandmarkEdit& edit,
                          const Actor& by);
    int removeLandmark(std::string_view part, int revision, const std::string& id, const Actor& by);

    /// The display mesh (binary STL bytes); `lod`: the simplified one.
    std::string displayMesh(std::string_view part, bool lod) const;

    std::vector<Version> versions(std::string_view part) const;

  private:
    fs::path folder_;
};

/// A change made on an older revision than the draft's (HTTP 409): names
/// the revision, who changed it, when and what.
struct StaleRevision : InputError {
    using InputError::InputError;
};

} // namespace hg::workbench
