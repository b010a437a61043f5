// Mesh booleans against analytic volumes of box arrangements.
#include <gtest/gtest.h>

#include "hullgauge/common/error.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/model/solid.h"

namespace hg::model {
namespace {

using Eigen::Vector3d;

TEST(Csg, CornerCutFromABlock)
{
    // A 10 mm block missing a 2 mm cube at its corner (flush with three faces).
    const TriangleMesh block = makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    const TriangleMesh cut = difference(block, makeBox(Vector3d(8, 8, 8), Vector3d(12, 12, 12)));
    EXPECT_TRUE(checkMesh(cut).ok()) << checkMesh(cut).problem();
    EXPECT_NEAR(cut.signedVolume(), 1000.0 - 8.0, 1e-9);
    const Solid solid(cut);
    EXPECT_FALSE(solid.contains(Vector3d(9, 9, 9)));
    EXPECT_TRUE(solid.contains(Vector3d(9, 9, 7)));
    EXPECT_NEAR(solid.insideFraction(Eigen::AlignedBox3d(Vector3d(7, 7, 7), Vector3d(9, 9, 9))).estimate, 7.0 / 8.0,
                1e-12);
}

TEST(Csg, HoleThroughAPlateAndUnion)
{
    // A through hole of a 32-gon prism: removed volume is the polygon area times the thickness.
    const TriangleMesh plate = makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 4));
    const TriangleMesh drill = makeCylinder(Vector3d(0, 0, -1), 3.0, 6.0, 32);
    const double polygonArea = 0.5 * 32 * 9.0 * std::sin(2 * 3.14159265358979323846 / 32);
    const TriangleMesh holed = difference(plate, drill);
    EXPECT_TRUE(checkMesh(holed).ok());
    EXPECT_NEAR(holed.signedVolume(), 1600.0 - polygonArea * 4.0, 1e-9);

    const TriangleMesh both =
        unionOf(makeBox(Vector3d(0, 0, 0), Vector3d(2, 2, 2)), makeBox(Vector3d(1, 1, 1), Vector3d(3, 3, 3)));
    EXPECT_NEAR(both.signedVolume(), 8.0 + 8.0 - 1.0, 1e-12);
    const TriangleMesh common =
        intersectionOf(makeBox(Vector3d(0, 0, 0), Vector3d(2, 2, 2)), makeBox(Vector3d(1, 1, 1), Vector3d(3, 3, 3)));
    EXPECT_NEAR(common.signedVolume(), 1.0, 1e-12);
}

TEST(Csg, OpenOperandIsRefused)
{
    TriangleMesh open = makeBox(Vector3d(0, 0, 0), Vector3d(1, 1, 1));
    open.triangles.pop_back();
    EXPECT_THROW(difference(makeBox(Vector3d(0, 0, 0), Vector3d(2, 2, 2)), open), InputError);
}

} // namespace
} // namespace hg::model
