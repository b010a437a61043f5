// The one voxel frame of the inspection map, the planner and the whole-object
// reconstruction (dissertation 3.3.1, 3.3.2), and the one landmark type the
// map and the planner share.
//
// Frame (as Open3D's VoxelGrid states its own): world = origin + ΔV_L · index.
// Voxel (level L, i, j, k) is the axis-aligned box
//   origin + ΔV_L · [i, i+1] x [j, j+1] x [k, k+1],  ΔV_L = cubeSize / 2^L
// in the part frame (mm); level 0 is the whole cube, level `depth` holds the
// inspection voxels (ΔV, the MAD of eq. 4.5.1-1). A point on a voxel face
// belongs to the voxel on the face's high side (index = floor).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hg::inspect {

/// (level, i, j, k) packed: level in bits 60..63, i, j, k in 20 bits each.
using VoxelKey = std::uint64_t;

constexpr int kMaxDepth = 15;

inline VoxelKey makeKey(int level, int i, int j, int k)
{
    return (static_cast<VoxelKey>(level) << 60) | (static_cast<VoxelKey>(i) << 40) | (static_cast<VoxelKey>(j) << 20) |
           static_cast<VoxelKey>(k);
}
inline VoxelKey makeKey(int level, const Eigen::Vector3i& index)
{
    return makeKey(level, index.x(), index.y(), index.z());
}
inline int keyLevel(VoxelKey key)
{
    return static_cast<int>(key >> 60);
}
inline Eigen::Vector3i keyIndex(VoxelKey key)
{
    return {static_cast<int>((key >> 40) & 0xFFFFF), static_cast<int>((key >> 20) & 0xFFFFF),
            static_cast<int>(key & 0xFFFFF)};
}

/// A designer landmark (5.3.1): a point on the CAD surface, its outward unit
/// normal and its tolerance. The inspection map stores these; the planner's
/// landmark adds the designer's best views.
struct MapLandmark {
    std::string id;
    Eigen::Vector3d position = Eigen::Vector3d::Zero(); ///< on the CAD surface, mm
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< outward unit normal
    /// Half the tolerance zone: the bracket's error_mm fails beyond it (docs/contracts.md §4).
    double toleranceMm = 0.0;
    /// Asymmetric limits [lower, upper] of the signed offset instead of
    /// ±tolerance (the part program's `limits_mm`, docs/part-program.md).
    std::optional<std::pair<double, double>> limitsMm{};

    double lowerMm() const { return limitsMm ? limitsMm->first : -toleranceMm; }
    double upperMm() const { return limitsMm ? limitsMm->second : toleranceMm; }
    bool operator==(const MapLandmark&) const = default;
};

struct VoxelFrame {
    Eigen::Vector3d origin = Eigen::Vector3d::Zero(); ///< low corner of the cube, mm
    double cubeSize = 1.0;                            ///< mm
    int depth = 8;                                    ///< level of the inspection voxels

    double voxelSize(int level) const { return cubeSize / static_cast<double>(std::uint64_t{1} << level); }
    /// ΔV, the inspection voxel edge.
    double voxelSize() const { return voxelSize(depth); }
    Eigen::AlignedBox3d box(int level, const Eigen::Vector3i& index) const;
    Eigen::AlignedBox3d box(VoxelKey key) const { return box(keyLevel(key), keyIndex(key)); }
    /// The voxel holding `point` at `level`, clamped into the cube.
    Eigen::Vector3i indexAt(const Eigen::Vector3d& point, int level) const;
    VoxelKey keyAt(const Eigen::Vector3d& point, int level) const { return makeKey(level, indexAt(point, level)); }

    /// The landmark's voxel at `level` (the type-three node of 3.3.2), for the
    /// map and the planner alike: the voxel holding the point a quarter of the
    /// inspection ΔV inside the surface, position − ΔV/4 · normal. 3.3.1 marks
    /// the landmark voxel as one that "needs to be present on the object" and
    /// 3.3.8 first asks whether it reconstructs to object, with its void
    /// neighbours (type four) proving the boundary (3.3.2, the witness of
    /// chapter 5's Rule 1); a landmark on a voxel face, the usual case for a
    /// face on the octree grid, touches two voxels, and this takes the one on
    /// the object side whichever way the normal points. A quarter ΔV is also
    /// how far a landmark may lie off the surface (PartProgram::
    /// surfaceToleranceMm), so the point stays on the object side. The one
    /// point serves every level, so the landmark voxels of coarser levels are
    /// the ancestors of the finest one.
    Eigen::Vector3i landmarkVoxel(const Eigen::Vector3d& position, const Eigen::Vector3d& normal, int level) const;
    VoxelKey landmarkKey(const MapLandmark& landmark, int level) const
    {
        return makeKey(level, landmarkVoxel(landmark.position, landmark.normal, level));
    }

    bool operator==(const VoxelFrame&) const = default;
};

} // namespace hg::inspect
