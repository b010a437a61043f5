// CAD parts as STEP files (docs/part-program.md, "STEP parts"): the exact
// boundary representation read with Open CASCADE, tessellated into the
// project's TriangleMesh for the inspection map, and kept for the exact
// surface queries the landmarks are snapped with.
//
// Units are millimetres in the part frame: the reader converts the file's
// own length unit. Open CASCADE stays behind this header (pimpl), so only
// step_io.cpp is compiled against it.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hullgauge/model/mesh.h"

namespace hg::model {

/// One solid of the file's product tree (docs/part-program.md, "STEP parts",
/// assemblies): a part placed in its assembly, or a free part.
struct StepSolid {
    /// The product's name as the CAD system shows it, or "solid N" (N its
    /// 1-based position in StepSummary::tree) when the file gives none.
    std::string name;
    /// Its instance name in the assembly (the reader gives the occurrence's
    /// id when it has no name); empty for a free part.
    std::string instance;
    std::size_t solids = 0; ///< bodies of the product (usually one; several are fused)
    double volumeMm3 = 0.0; ///< exact, as placed
    bool chosen = false;    ///< part of the part program's part
};

/// 'pin', or 'pin' (instance 'pin:2') when the instance has a name of its
/// own: a solid as errors and check-part name it.
std::string describe(const StepSolid& solid);

/// What the STEP file held, measured on the exact B-rep.
struct StepSummary {
    std::size_t solids = 0; ///< solids in the file
    std::size_t faces = 0;  ///< faces of the part after the union
    double volumeMm3 = 0.0; ///< exact volume (BRepGProp)
    Eigen::AlignedBox3d bounds;
    /// The file's solids in its order, with their names.
    std::vector<StepSolid> tree;
    /// The `mesh_solid` chosen; empty when the part is the union of all.
    std::string chosen;
};

/// The tessellation the inspection map is built from.
struct StepTessellation {
    double linearDeflectionMm = 0.0; ///< largest chord error (absolute)
    double angularDeflectionRad = 0.0;
    std::size_t triangles = 0;
};

/// A point of the exact surface with its outward unit normal.
struct BRepPoint {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    double distance = 0.0; ///< from the query point, mm
};

/// True when the path names a STEP file (.step or .stp, any case).
bool isStepFile(const std::filesystem::path& file);

class StepModel {
  public:
    /// Reads every solid of `file` and names it from the file's product tree;
    /// the part is the one named `solid` (a product or instance name), or
    /// without a name the union of all. Throws InputError(file, "mesh",
    /// problem) for a file that is missing, truncated or unreadable, holds no
    /// solid, or whose solid is not closed, and InputError(file, "mesh_solid",
    /// problem) when no solid or several carry the name (listing the names).
    /// Open CASCADE's parse and translation run in a process of their own
    /// (docs/part-program.md, "A process of its own"): a fault of the
    /// library on a damaged file, or a reader that does not finish within
    /// five minutes, is an InputError naming it, never a fault of the caller.
    static StepModel read(const std::filesystem::path& file, const std::string& solid = {});
    /// As read, all in this process: for the fuzz harness, which must see a
    /// fault of the library where it happens (docs/fuzzing.md).
    static StepModel readInThisProcess(const std::filesystem::path& file, const std::string& solid = {});
    ~StepModel();
    StepModel(StepModel&&) noexcept;
    StepModel& operator=(StepModel&&) noexcept;

    const StepSummary& summary() const;
    /// Tessellates every face with the chord error `linearDeflectionMm` and
    /// the angle `angularDeflectionRad` (absolute, not relative to the face
    /// size) and returns the closed, outward mesh (InputError otherwise).
    TriangleMesh tessellate(double linearDeflectionMm, double angularDeflectionRad);
    /// The last tessellation's parameters and size.
    const StepTessellation& tessellation() const;

    /// Nearest point of the exact surface to `point`, and the outward normal
    /// there: the mean of the normals of the faces within `radius` of that
    /// point (one face inside a face, the bisector on an edge).
    BRepPoint closestPoint(const Eigen::Vector3d& point, double radius) const;

  private:
    struct Impl;
    explicit StepModel(std::unique_ptr<Impl> impl);
    /// Open CASCADE's part of a read, on a file whose text was checked.
    static StepModel readCheckedText(const std::filesystem::path& file, const std::string& solid);
    BRepPoint nearestPoint(const Eigen::Vector3d& point, double radius) const;
    std::unique_ptr<Impl> impl_;
};

} // namespace hg::model
