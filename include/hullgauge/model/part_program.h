// The part program (docs/contracts.md §1): which CAD model, the octree of the
// inspection map (dissertation 3.3.1, MAD eq. 4.5.1-1), the designer's
// landmarks with tolerances and best views (5.3.1), and the geometric
// parameters built from them (4.6.4). The reference is docs/part-program.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullgauge/common/enum_names.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/model/mesh_repair.h"
#include "hullgauge/model/solid.h"

namespace hg::model {

class StepModel; // hullgauge/model/step_io.h

/// The deepest octree the inspection map represents: its voxel keys hold the
/// level in 4 bits (include/hullgauge/inspect/voxel_frame.h), so a program is
/// refused a deeper one when it is loaded.
constexpr int kMaxOctreeDepth = 15;

struct OctreeSpec {
    Eigen::Vector3d cubeOrigin = Eigen::Vector3d::Zero(); // low corner of the reconstruction cube, mm
    double cubeSize = 0.0;                                // edge of the cube, mm
    int depth = 0;                                        // octree levels below the cube, 1..kMaxOctreeDepth
    int adjacencyDepth = 1;                               // layers of type-four nodes (3.3.2)
    bool cubeFromMesh = false;                            // true when cube_origin/cube_size were derived from the mesh

    /// Voxel edge ΔV = cube_size / 2^depth: the minimum a priori discrimination (MAD, eq. 4.5.1-1).
    double voxelSize() const;
    /// Largest error the map can measure: adjacency_depth voxels.
    double maxMeasurableErrorMm() const { return adjacencyDepth * voxelSize(); }
};

/// A designer best view: the landmark is observed if, for every group, at
/// least one of the group's poses is used (AND over groups, OR inside one).
using BestViewGroup = std::vector<geometry::FixturePose>;

struct Landmark {
    std::string id;
    Eigen::Vector3d position; // part frame, mm, on the CAD surface
    Eigen::Vector3d normal;   // unit, outward
    bool normalFromMesh = false;
    /// A STEP part's landmark: `position` is the nearest point of the exact
    /// B-rep to the given one, and a normal not given is the B-rep's there
    /// (docs/part-program.md, "STEP parts").
    bool onBRep = false;
    double toleranceMm = 0.0; ///< half the tolerance zone (with `limits_mm`: (upper − lower) / 2)
    /// `limits_mm: [lower, upper]`: asymmetric limits of the signed offset instead of ±tolerance_mm.
    std::optional<std::pair<double, double>> limitsMm;
    std::vector<BestViewGroup> bestViews;
    /// Distance from the given position to the surface (a STEP part's exact
    /// B-rep, else the mesh), mm (within surfaceToleranceMm()).
    double distanceToSurfaceMm = 0.0;
};

/// Inspection map files (.hgmap) store the kind as its value in one byte: keep the order.
enum class ParameterKind : std::uint8_t { Distance, Perimeter, Area };
constexpr auto nameTable(ParameterKind)
{
    using enum ParameterKind;
    return std::to_array<EnumName<ParameterKind>>({{Distance, "distance"}, {Perimeter, "perimeter"}, {Area, "area"}});
}

/// A geometric parameter (dissertation 4.6.4): a distance between two
/// landmarks, or the perimeter or area of the closed polygon through 3 or more.
struct GeometricParameter {
    std::string id;
    ParameterKind kind = ParameterKind::Distance;
    std::vector<std::string> landmarkIds;
    std::vector<std::size_t> landmarkIndices; // into PartProgram::landmarks
    double nominalMm = 0.0;                   // mm, or mm² for an area
    double toleranceMm = 0.0;                 // mm, or mm² for an area
};

/// ISO 14253-1 decision rules (docs/inspection.md, "Decisions"): `guarded`
/// — conformance must be proven: the deviation lies inside the limits by at
/// least U, nonconformance when it lies outside by at least U, else
/// uncertain; `simple` — the deviation against the limits, U ignored. The
/// part program chooses one (`inspection.decision_rule`); inspect/deviation.h decides by it.
enum class DecisionRule { Guarded, Simple };
constexpr auto nameTable(DecisionRule)
{
    using enum DecisionRule;
    return std::to_array<EnumName<DecisionRule>>({{Guarded, "guarded"}, {Simple, "simple"}});
}

/// How the part is inspected: the optional `inspection` section
/// (docs/part-program.md), the run-time adaptation of the map (3.4). The daemon
/// and `hullgauge inspect` both inspect with it; an absent key keeps the
/// default given here, which is the behaviour before the section existed.
/// Masking stays an offline experiment (`inspect --mask`): the PLC's landmark
/// bits follow the program's landmark list.
struct InspectionSettings {
    int level = -1;                ///< octree level, 1..depth; -1 = octree.depth
    int adjacency = -1;            ///< type-four layers searched, 1..adjacency_depth; -1 = all
    bool centrePointTest = false;  ///< `method: centre`: the centre-point voxel test, not the volume source
    bool requireResolution = true; ///< `resolution_check`: eq. 4.4.4-19 required per landmark
    bool earlyExit = false;        ///< stop at the first landmark that is not ok (3.3.6)
    /// `deviation`: also the signed sub-voxel deviation and its uncertainty
    /// per landmark (docs/inspection.md, "Sub-voxel deviation").
    bool deviation = true;
    /// `decision_rule`: guarded (conformance proven beyond U, the default) or
    /// simple (the deviation against the tolerance as it is).
    bool simpleDecision = false;
};

/// How the part's seat is measured before it is inspected: the optional
/// `alignment` section (docs/part-program.md, docs/alignment.md). A part seated
/// beyond either limit is not inspected: it is a seating fault.
enum class AlignmentMethod { Silhouette, Datums, None };
constexpr auto nameTable(AlignmentMethod)
{
    using enum AlignmentMethod;
    return std::to_array<EnumName<AlignmentMethod>>({{Silhouette, "silhouette"}, {Datums, "datums"}, {None, "none"}});
}

struct AlignmentSettings {
    AlignmentMethod method = AlignmentMethod::Silhouette;
    /// `method: datums`: landmark ids whose CAD faces are the datums, in
    /// priority order (A, B, C: 3-2-1).
    std::vector<std::string> datums;
    double maxShiftMm = 1.0;     ///< limit on the shift of the part's reference point
    double maxRotationDeg = 1.0; ///< limit on the rotation angle
    /// The seat measured on this many first views corrects the planned poses
    /// of the views after them (docs/alignment.md, "Poses corrected for the
    /// seat"); 0: every view is taken at its planned pose.
    int correctPosesAfter = 2;
    /// Poses taken first, in this order, before the planned views
    /// (`seat_views`, docs/alignment.md, "Views for the seat"): where the
    /// planned views alone do not determine the seat from the first
    /// `correct_poses_after` of them.
    std::vector<geometry::FixturePose> seatViews;
};

/// A released program's record (docs/commissioning.md, "Release"): which
/// version it is, the digest of the verification report that proved it on
/// the station's digital twin, who released it and when.
struct ReleaseRecord {
    int version = 0;
    std::string verificationSha256; ///< 64 hex digits: SHA-256 of verification.json
    std::string releasedBy;
    std::string releasedAt; ///< ISO 8601 with the zone, as written
    /// `rolled_back_from`: the earlier version this one puts in force again
    /// (docs/workbench.md, rollback); its program, views and CAD model are that version's.
    std::optional<int> rolledBackFrom;
};

/// The part's material (the optional `material` section, docs/part-program.md):
/// its name keeps the master's correction sets apart (docs/mastering.md) and
/// its linear expansion coefficient refers the deviations to 20 °C (ISO 1).
struct Material {
    std::string name;
    double expansionPerK = 0.0; ///< α, 1/K (steel about 11.5e-6, aluminium about 23e-6)
    /// The point the part grows about, part frame (mm); default the centre of the mesh's bounding box.
    geometry::Vec3 expansionCentre = geometry::Vec3::Zero();
};

struct PartProgram {
    std::filesystem::path file;     // the YAML file
    std::string part;               // free-text name
    std::filesystem::path meshFile; // resolved relative to the YAML file
    /// `mesh_solid`: the solid of a STEP file that is the part, by name;
    /// empty for the union of all (docs/part-program.md, "STEP parts").
    std::string meshSolid;
    /// `mesh_repair` and `mesh_gap_mm` (docs/part-program.md, "Meshes as they come").
    MeshRepairOptions meshRepair;
    /// What was repaired in the mesh file (all zero for a STEP part).
    MeshRepairReport meshRepairReport;
    std::shared_ptr<const Solid> solid;
    /// A STEP part's exact B-rep, which `solid` is the tessellation of; null for a mesh file.
    std::shared_ptr<const StepModel> brep;
    OctreeSpec octree;
    std::vector<Landmark> landmarks;
    std::vector<GeometricParameter> parameters;
    InspectionSettings inspection;
    AlignmentSettings alignment;
    /// Kind of fixture the best views are written for (rotation/declination or rail), when any are given.
    std::optional<geometry::FixtureType> bestViewFixture;
    /// `release`: present in a program `hullgauge commission` released.
    std::optional<ReleaseRecord> release;
    /// `material`, when the program names one.
    std::optional<Material> material;

    /// How far a landmark may lie from the mesh surface: max(0.01 mm, ΔV/4).
    /// Tessellation of curved CAD faces moves the mesh off the designer's
    /// surface by the chord error; a quarter voxel keeps the landmark in the
    /// voxel the map puts it in.
    double surfaceToleranceMm() const;
    /// A STEP part's chord error: ΔV/20, so the tessellation moves the
    /// surface by a twentieth of the map's resolution at most.
    double tessellationDeflectionMm() const { return octree.voxelSize() / 20.0; }
    const Landmark* findLandmark(const std::string& id) const;
};

/// A CAD model read on its own, before a part program names its landmarks
/// (`hullgauge landmarks suggest`, docs/part-program.md "Suggesting
/// landmarks"): the solid, a STEP part's B-rep, and the default cube a part
/// program with this depth and adjacency depth derives (boundingCube). A STEP
/// part is tessellated exactly as loadPartProgram tessellates it.
struct CadModel {
    std::filesystem::path file;
    std::shared_ptr<const Solid> solid;
    std::shared_ptr<const StepModel> brep; ///< null for a mesh file
    OctreeSpec octree;
};

/// Reads a mesh (STL, OBJ, PLY, OFF) or STEP file; a bad file throws
/// InputError naming it, as does a depth too small for the default cube.
/// `solid` names the STEP file's solid that is the part, as `mesh_solid`
/// does (InputError with field "--solid" for a name no solid or several
/// carry, or for a mesh file); empty: the union of all.
CadModel loadCadModel(const std::filesystem::path& file, int depth, int adjacencyDepth, const std::string& solid = {});

/// Reads and validates a part program; every problem throws InputError with
/// file, line and field ("part.yaml:23: landmarks[2].position: ...").
PartProgram loadPartProgram(const std::filesystem::path& file);

/// The cube the loader derives when `cube_origin`/`cube_size` are absent:
/// the mesh bounding box, centred, with a margin of (adjacency_depth + 1)
/// voxels on every side so that every type-four neighbour of a boundary
/// voxel lies inside the cube. With E the longest bounding-box edge and
/// m = adjacency_depth + 1, the size solves S = E + 2 m S / 2^depth, i.e.
/// S = E / (1 - 2 m / 2^depth). Returns nullopt when 2^depth <= 2 m (no cube
/// is large enough).
std::optional<OctreeSpec> boundingCube(const Eigen::AlignedBox3d& bounds, int depth, int adjacencyDepth);

} // namespace hg::model
