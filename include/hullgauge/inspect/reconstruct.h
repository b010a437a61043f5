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

#include "hullgauge/inspect/voxel_frame.h"
#include "hullgauge/inspect/voxel_test.h"

namespace hg::inspect {

struct HullNode {
    int level = 0;
    Eigen::Vector3i index = Eigen::Vector3i::Zero();
};

struct HullReconstruction {
    /// The cube and the finest level (voxel_frame.h).
    VoxelFrame frame;
    /// Object nodes (leaves of the octree at any level).
    std::vector<HullNode> objectNodes;
    /// Finest-level voxels inside object nodes (8^(depth - level) each).
    std::uint64_t objectVoxels = 0;
    /// Finest-level voxels no view decides (left out of the object).
    std::uint64_t undecidedVoxels = 0;
    std::uint64_t footprintsMeasured = 0;

    double voxelSize() const { return frame.voxelSize(); }
    double volumeMm3() const;
    Box3 box(const HullNode& n) const { return frame.box(n.level, n.index); }
};

HullReconstruction reconstructHull(const std::vector<SilhouetteView>& views, const VoxelFrame& frame,
                                   VoxelTestMethod method = VoxelTestMethod::VolumeSource);

} // namespace hg::inspect
