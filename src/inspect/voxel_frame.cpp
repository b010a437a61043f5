#include "hullgauge/inspect/voxel_frame.h"

#include <algorithm>
#include <cmath>

namespace hg::inspect {

Eigen::AlignedBox3d VoxelFrame::box(int level, const Eigen::Vector3i& index) const
{
    const double s = voxelSize(level);
    const Eigen::Vector3d lo = origin + s * index.cast<double>();
    return {lo, lo + Eigen::Vector3d::Constant(s)};
}

Eigen::Vector3i VoxelFrame::indexAt(const Eigen::Vector3d& point, int level) const
{
    const double s = voxelSize(level);
    const int n = 1 << level;
    Eigen::Vector3i ijk;
    for (int a = 0; a < 3; ++a) ijk[a] = std::clamp(static_cast<int>(std::floor((point[a] - origin[a]) / s)), 0, n - 1);
    return ijk;
}

Eigen::Vector3i VoxelFrame::landmarkVoxel(const Eigen::Vector3d& position, const Eigen::Vector3d& normal,
                                          int level) const
{
    return indexAt(position - 0.25 * voxelSize() * normal, level);
}

} // namespace hg::inspect
