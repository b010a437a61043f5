#include "hullgauge/inspect/reconstruct.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"

#include <string>

namespace hg::inspect {

double HullReconstruction::volumeMm3() const
{
    const double v = voxelSize();
    return static_cast<double>(objectVoxels) * v * v * v;
}

HullReconstruction reconstructHull(const std::vector<SilhouetteView>& views, const VoxelFrame& frame,
                                   VoxelTestMethod method)
{
    if (!(frame.cubeSize > 0.0))
        throw ArgumentError("frame.cubeSize must be positive, found " + formatNumber(frame.cubeSize));
    if (frame.depth < 0 || frame.depth > 20)
        throw ArgumentError("frame.depth must be within 0..20, found " + std::to_string(frame.depth));
    const int depth = frame.depth;
    HullReconstruction r;
    r.frame = frame;
    const VoxelTester tester(&views, method);
    std::vector<HullNode> level{HullNode{}};
    for (int L = 0; L <= depth && !level.empty(); ++L) {
        std::vector<HullNode> next;
        const std::uint64_t below = std::uint64_t{1} << (3 * (depth - L));
        for (const HullNode& n : level) {
            const Box3 b = r.box(n);
            if (L == depth) {
                const VoxelLabel lab = tester.classify(b);
                r.footprintsMeasured += views.size();
                if (lab == VoxelLabel::Object) {
                    r.objectNodes.push_back(n);
                    r.objectVoxels += 1;
                } else if (lab == VoxelLabel::Undecided) {
                    r.undecidedVoxels += 1;
                }
                continue;
            }
            bool allBackgroundSomewhere = false, allObjectEverywhere = !views.empty();
            for (std::size_t v = 0; v < views.size() && !allBackgroundSomewhere; ++v) {
                const FootprintMeasure m = tester.measure(b, v);
                ++r.footprintsMeasured;
                if (!m.inFront || m.area <= 0.0) {
                    allObjectEverywhere = false;
                    continue;
                }
                if (m.unknown <= 1e-9 * m.area && m.background >= m.area * (1.0 - 1e-9)) allBackgroundSomewhere = true;
                if (m.unknown > 1e-9 * m.area || m.background > 1e-9 * m.area) allObjectEverywhere = false;
            }
            if (allBackgroundSomewhere) continue; // void, and every voxel below it
            if (allObjectEverywhere) {
                // Every sub-voxel's footprint lies inside this one's: all object.
                r.objectNodes.push_back(n);
                r.objectVoxels += below;
                continue;
            }
            for (int c = 0; c < 8; ++c)
                next.push_back({L + 1, 2 * n.index + Eigen::Vector3i(c >> 2 & 1, c >> 1 & 1, c & 1)});
        }
        level = std::move(next);
    }
    return r;
}

} // namespace hg::inspect
