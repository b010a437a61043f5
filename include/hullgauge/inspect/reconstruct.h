// Whole-object reconstruction with the volume-source test (3.3.4): an octree
// over the cube, grey nodes subdivided level by level. A node whose footprint
// is all background in some view is void with everything below it; a node
// whose footprint is all object in every view (and inside every frame) is
// object with everything below it; otherwise it is split, and at the finest
// level the 50 % rule decides. This is the dense baseline the goal-driven
// inspection is measured against, and `hullgauge reconstruct`.
#pragma once

#include <cstdint>
#include <vector>

#include "hullgauge/inspect/voxel_test.h"

namespace hg::inspect {

struct HullNode {
    int level = 0;
    Eigen::Vector3i index = Eigen::Vector3i::Zero();
};

struct HullReconstruction {
    Eigen::Vector3d cubeOrigin = Eigen::Vector3d::Zero();
    double cubeSize = 0.0;
    int depth = 0;
    /// Object nodes (leaves of the octree at any level).
    std::vector<HullNode> objectNodes;
    /// Finest-level voxels inside object nodes (8^(depth - level) each).
    std::uint64_t objectVoxels = 0;
    /// Finest-level voxels no view decides (left out of the object).
    std::uint64_t undecidedVoxels = 0;
    std::uint64_t footprintsMeasured = 0;

    double voxelSize() const { return cubeSize / static_cast<double>(std::uint64_t{1} << depth); }
    double volumeMm3() const;
    Box3 box(const HullNode& n) const;
};

HullReconstruction reconstructHull(const std::vector<SilhouetteView>& views, const Eigen::Vector3d& cubeOrigin,
                                   double cubeSize, int depth, VoxelTestMethod method = VoxelTestMethod::VolumeSource);

} // namespace hg::inspect
