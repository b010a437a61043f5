// Mesh import/export and the closedness check: every format written by the
// test and read back, and each kind of broken mesh named precisely.
#include <filesystem>
#include <fstream>
#include <string>

#include <sys/stat.h>

#include <gtest/gtest.h>

#include "hgtest/log_capture.h"
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/primitives.h"

namespace hg::model {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;

InputError loadError(const fs::path& file)
{
    try {
        loadMesh(file);
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << "loading " << file << " did not throw";
    return InputError("", "", "");
}

class MeshFormats : public ::testing::TestWithParam<std::pair<std::string, MeshEncoding>> {};

TEST_P(MeshFormats, BoxRoundTripKeepsGeometry)
{
    hgtest::TempDir dir;
    const auto [name, encoding] = GetParam();
    // A 3 x 4 x 5 mm box away from the origin: volume 60 mm³, area 94 mm².
    const TriangleMesh box = makeBox(Vector3d(1, 2, 3), Vector3d(4, 6, 8));
    saveMesh(box, dir / name, encoding);
    const TriangleMesh loaded = loadMesh(dir / name);
    EXPECT_EQ(loaded.triangles.size(), 12u);
    EXPECT_EQ(loaded.vertices.size(), 8u); // STL's per-facet vertices merged
    EXPECT_NEAR(loaded.signedVolume(), 60.0, 1e-9);
    EXPECT_NEAR(loaded.area(), 94.0, 1e-9);
    EXPECT_TRUE(loaded.bounds().isApprox(Eigen::AlignedBox3d(Vector3d(1, 2, 3), Vector3d(4, 6, 8))));
    EXPECT_TRUE(checkMesh(loaded).ok());
}

INSTANTIATE_TEST_SUITE_P(
    AllFormats, MeshFormats,
    ::testing::Values(std::make_pair("b.stl", MeshEncoding::Binary), std::make_pair("a.stl", MeshEncoding::Ascii),
                      std::make_pair("m.obj", MeshEncoding::Ascii), std::make_pair("b.ply", MeshEncoding::Binary),
                      std::make_pair("a.ply", MeshEncoding::Ascii), std::make_pair("m.off", MeshEncoding::Ascii)));

TEST(MeshIo, HandWrittenAsciiStlTetrahedron)
{
    hgtest::TempDir dir;
    // Unit corner tetrahedron, facets listed outward: volume 1/6.
    const std::string facet = "facet normal 0 0 0\nouter loop\nvertex {}\nvertex {}\nvertex {}\nendloop\nendfacet\n";
    auto f = [&](const char* a, const char* b, const char* c) {
        std::string s = facet;
        for (const char* v : {a, b, c}) s.replace(s.find("{}"), 2, v);
        return s;
    };
    const std::string text = "solid tet\n" + f("0 0 0", "0 1 0", "1 0 0") + f("0 0 0", "1 0 0", "0 0 1") +
                             f("0 0 0", "0 0 1", "0 1 0") + f("1 0 0", "0 1 0", "0 0 1") + "endsolid tet\n";
    const TriangleMesh m = loadMesh(hgtest::writeFile(dir / "tet.stl", text));
    EXPECT_EQ(m.triangles.size(), 4u);
    EXPECT_NEAR(m.signedVolume(), 1.0 / 6.0, 1e-12);
}

TEST(MeshIo, ObjQuadsAreTriangulated)
{
    hgtest::TempDir dir;
    // A 2 mm cube written as six quads (counter-clockwise from outside).
    const std::string obj = "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 0 0 2\nv 2 0 2\nv 2 2 2\nv 0 2 2\n"
                            "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    const TriangleMesh m = loadMesh(hgtest::writeFile(dir / "cube.obj", obj));
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_NEAR(m.signedVolume(), 8.0, 1e-12);
}

TEST(MeshIo, TruncatedBinaryStlNamesFacetAndBytes)
{
    hgtest::TempDir dir;
    saveMesh(makeSphere(Vector3d::Zero(), 5.0, 16, 8), dir / "s.stl"); // 16*2 + 16*6*2 = 224 facets
    const auto size = fs::file_size(dir / "s.stl");
    ASSERT_EQ(size, 84u + 50u * 224u);
    // Keep the header and 5 whole facets plus 40 bytes of the sixth.
    fs::resize_file(dir / "s.stl", 84 + 5 * 50 + 40);
    const InputError e = loadError(dir / "s.stl");
    EXPECT_EQ(e.field(), "facet 6");
    EXPECT_NE(std::string(e.what()).find("s.stl: facet 6: file ends after 40 of 50 bytes"), std::string::npos)
        << e.what();
    fs::resize_file(dir / "s.stl", 84 + 7 * 50);
    EXPECT_NE(std::string(loadError(dir / "s.stl").what()).find("facet 8: file ends after 7 of the 224 facets"),
              std::string::npos);
    fs::resize_file(dir / "s.stl", 30);
    EXPECT_EQ(loadError(dir / "s.stl").field(), "header");
}

TEST(MeshIo, StlWithHoleNamesOpenEdges)
{
    hgtest::TempDir dir;
    TriangleMesh box = makeBox(Vector3d::Zero(), Vector3d(1, 1, 1));
    box.triangles.pop_back(); // one triangle missing: its 3 edges are open
    saveMesh(box, dir / "hole.stl");
    const InputError e = loadError(dir / "hole.stl");
    EXPECT_NE(std::string(e.what()).find("hole.stl: mesh: not closed: 3 open edges"), std::string::npos) << e.what();
    const MeshCheck c = checkMesh(box);
    EXPECT_EQ(c.openEdges, 3u);
    ASSERT_TRUE(c.firstOpenEdge);
    // The open edge lies on the removed triangle's face x = 1.
    EXPECT_DOUBLE_EQ((*c.firstOpenEdge)[0].x(), 1.0);
    EXPECT_DOUBLE_EQ((*c.firstOpenEdge)[1].x(), 1.0);
}

TEST(MeshIo, BoxesSharingAnEdgeAreNonManifold)
{
    hgtest::TempDir dir;
    TriangleMesh m = makeBox(Vector3d(0, 0, 0), Vector3d(1, 1, 1));
    m.append(makeBox(Vector3d(1, 1, 0), Vector3d(2, 2, 1))); // shares the edge x = y = 1
    saveMesh(m, dir / "edge.stl");
    const std::string what = loadError(dir / "edge.stl").what();
    EXPECT_NE(what.find("not a 2-manifold: 1 edge shared by more than two triangles"), std::string::npos) << what;
    EXPECT_NE(what.find("(1.0000, 1.0000, 0.0000)"), std::string::npos) << what;
}

TEST(MeshIo, BoxesTouchingAtACornerHaveANonManifoldVertex)
{
    hgtest::TempDir dir;
    TriangleMesh m = makeBox(Vector3d(0, 0, 0), Vector3d(1, 1, 1));
    m.append(makeBox(Vector3d(1, 1, 1), Vector3d(2, 2, 2)));
    saveMesh(m, dir / "corner.ply");
    const std::string what = loadError(dir / "corner.ply").what();
    EXPECT_NE(what.find("1 vertex where separate sheets touch, the first at (1.0000, 1.0000, 1.0000)"),
              std::string::npos)
        << what;
}

TEST(MeshIo, InvertedMeshIsFlippedWithAWarning)
{
    hgtest::TempDir dir;
    TriangleMesh box = makeBox(Vector3d::Zero(), Vector3d(2, 3, 4));
    box.flip();
    EXPECT_TRUE(checkMesh(box).inverted());
    EXPECT_NE(checkMesh(box).problem().find("inverted orientation"), std::string::npos);
    saveMesh(box, dir / "inv.stl");
    hgtest::LogCapture log("model");
    const TriangleMesh m = loadMesh(dir / "inv.stl");
    EXPECT_NEAR(m.signedVolume(), 24.0, 1e-12);
    EXPECT_NE(log.text().find("oriented inward"), std::string::npos) << log.text();
}

TEST(MeshIo, InconsistentTriangleIsReorientedWithAWarning)
{
    hgtest::TempDir dir;
    TriangleMesh box = makeBox(Vector3d::Zero(), Vector3d(2, 3, 4));
    std::swap(box.triangles[5][1], box.triangles[5][2]);
    const MeshCheck c = checkMesh(box);
    EXPECT_EQ(c.inconsistentEdges, 3u);
    EXPECT_FALSE(c.ok());
    saveMesh(box, dir / "mixed.obj");
    hgtest::LogCapture log("model");
    const TriangleMesh m = loadMesh(dir / "mixed.obj");
    EXPECT_NEAR(m.signedVolume(), 24.0, 1e-12);
    EXPECT_NE(log.text().find("inconsistent orientation"), std::string::npos) << log.text();
}

// Two overlapping closed shells are two bodies exported as one soup: the
// part is their union, 8 + 8 − 1 mm³ (docs/part-program.md, "Meshes as they come").
TEST(MeshIo, SelfIntersectingMeshOfOverlappingShellsIsRepairedToTheirUnion)
{
    hgtest::TempDir dir;
    TriangleMesh m = makeBox(Vector3d(0, 0, 0), Vector3d(2, 2, 2));
    m.append(makeBox(Vector3d(1, 1, 1), Vector3d(3, 3, 3)));
    saveMesh(m, dir / "overlap.stl");
    hgtest::LogCapture log("model");
    const ImportedMesh r = importMesh(dir / "overlap.stl");
    EXPECT_NEAR(r.mesh.signedVolume(), 15.0, 1e-9);
    EXPECT_TRUE(checkMesh(r.mesh).ok());
    EXPECT_GT(r.repair.selfIntersections, 0u);
    EXPECT_NE(log.text().find("self-intersecting triangle pairs removed"), std::string::npos) << log.text();
    // mesh_repair: strict refuses it, naming the defect.
    try {
        importMesh(dir / "overlap.stl", {MeshRepairMode::Strict});
        FAIL() << "strict mode accepted a self-intersecting mesh";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("self-intersecting triangle pairs"), std::string::npos) << e.what();
    }
}

TEST(MeshIo, BadFilesAreNamed)
{
    hgtest::TempDir dir;
    EXPECT_NE(std::string(loadError(hgtest::writeFile(dir / "m.xyz", "1 2 3\n")).what())
                  .find("m.xyz: mesh: unknown mesh format '.xyz'"),
              std::string::npos);
    EXPECT_NE(
        std::string(loadError(hgtest::writeFile(dir / "e.stl", "")).what()).find("e.stl: mesh: the file is empty"),
        std::string::npos);
    EXPECT_NE(std::string(loadError(dir / "missing.obj").what()).find("no such file"), std::string::npos);
    EXPECT_NE(std::string(loadError(hgtest::writeFile(dir / "p.step", "ISO-10303-21;")).what()).find("STEP"),
              std::string::npos);
}

// A path that names no regular file says what it names: a folder, a FIFO (a
// reader would block on it), a link to /dev/zero (a reader would never end).
TEST(MeshIo, PathsThatAreNoFileSayWhatTheyAre)
{
    hgtest::TempDir dir;
    fs::create_directory(dir / "folder.stl");
    ASSERT_EQ(::mkfifo((dir / "pipe.stl").c_str(), 0600), 0);
    fs::create_symlink("/dev/zero", dir / "zero.stl");
    fs::create_symlink(dir / "gone.stl", dir / "dangling.stl");
    const std::pair<const char*, const char*> cases[] = {
        {"folder.stl", "a folder, not a file"},
        {"pipe.stl", "a FIFO (named pipe), not a regular file"},
        {"zero.stl", "a character device, not a regular file"},
        {"dangling.stl", "a broken symbolic link (its target does not exist)"},
        {"missing.stl", "no such file"},
    };
    for (const auto& [name, problem] : cases) {
        const InputError e = loadError(dir / name);
        EXPECT_EQ(e.problem(), problem) << name;
        EXPECT_EQ(e.field(), "mesh") << name;
    }
}

// A 60-byte OFF file announcing 50 million faces once made the reader reserve
// 1.25 GB: the header's counts are checked against the limit and against what
// the file's bytes can hold (6 per vertex, 8 per face) before anything is read.
TEST(MeshIo, OffHeaderCountsAreCheckedBeforeTheBodyIsRead)
{
    hgtest::TempDir dir;
    const InputError huge = loadError(hgtest::writeFile(dir / "huge.off", "OFF\n4 50000000 0\n0 0 0\n1 0 0\n0 1 0\n"));
    EXPECT_EQ(huge.field(), "mesh");
    EXPECT_NE(huge.problem().find("announces 50000000 faces, more than the 4000000"), std::string::npos)
        << huge.problem();
    // Under the limit but past the file: 4 vertices and 1000 faces need 6·4 + 8·1000 − 1 = 8023 bytes.
    const InputError past = loadError(hgtest::writeFile(dir / "past.off", "# a comment\nOFF\n4 1000 0\n0 0 0\n"));
    EXPECT_EQ(past.field(), "header");
    EXPECT_EQ(past.line(), std::optional<int>(3));
    EXPECT_EQ(past.problem(), "4 vertices and 1000 faces take at least 8023 bytes; the file has 31");
    const InputError word = loadError(hgtest::writeFile(dir / "word.off", "OFF\n4 many 0\n"));
    EXPECT_EQ(word.problem(), "the face count 'many' is not a whole number");
    EXPECT_EQ(word.line(), std::optional<int>(2));
}

// A binary STL of 2 GB (sparse: no block of it is written) is refused by its
// size and its header's count before a facet is read, naming the limit.
TEST(MeshIo, AMeshPastTheSizeLimitsIsRefusedNamingTheLimit)
{
    hgtest::TempDir dir;
    const fs::path big = dir / "big.stl";
    {
        std::string head(84, '\0');
        const std::uint32_t facets = 40'000'000;
        for (int i = 0; i < 4; ++i) head[80 + i] = static_cast<char>((facets >> (8 * i)) & 0xff);
        std::ofstream(big, std::ios::binary) << head;
    }
    fs::resize_file(big, 84 + 50ull * 40'000'000);
    const InputError bytes = loadError(big);
    EXPECT_NE(bytes.problem().find("more than the 1024 MiB a mesh file may have"), std::string::npos)
        << bytes.problem();
    // The count alone, under a larger file limit.
    MeshRepairOptions limits;
    limits.maxFileBytes = std::uint64_t(4) << 30;
    try {
        (void)importMesh(big, limits);
        ADD_FAILURE() << "a 40 000 000-facet STL was read";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.problem()).find("announces 40000000 facets, more than the 4000000"), std::string::npos)
            << e.problem();
    }
    // The same counts in a PLY header.
    const InputError ply = loadError(hgtest::writeFile(
        dir / "big.ply",
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float "
        "y\nproperty float z\nelement face 5000000\nproperty list uchar int vertex_indices\nend_header\n"));
    EXPECT_NE(ply.problem().find("announces 5000000 faces"), std::string::npos) << ply.problem();
}

// Found by the PLY harness (docs/fuzzing.md): a property line before any
// element line crashed the reader; it is named at its header line instead.
TEST(MeshIo, PlyPropertyBeforeAnyElementIsNamedAtItsLine)
{
    hgtest::TempDir dir;
    const auto file = hgtest::writeFile(dir / "p.ply", "ply\nformat ascii 1.0\nproperty double x\n"
                                                       "element vertex 1\nend_header\n0\n");
    const InputError e = loadError(file);
    EXPECT_EQ(e.field(), "header");
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(std::string(e.what()).find("'property' before any 'element'"), std::string::npos) << e.what();
    // The same header with its element first still reaches the reader (and its own error).
    const auto fine = hgtest::writeFile(dir / "q.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"
                                                       "property double x\nend_header\n0\n");
    EXPECT_EQ(loadError(fine).field(), "mesh");
}

// Found by the PLY harness (docs/fuzzing.md): a vertex coordinate declared
// int16 (the simulated line's block with its z so declared) crashed the reader.
TEST(MeshIo, PlyVertexCoordinateThatIsNotARealNumberIsNamedAtItsLine)
{
    hgtest::TempDir dir;
    const auto file = hgtest::writeFile(dir / "z.ply", "ply\nformat ascii 1.0\ncomment stepped block\n"
                                                       "element vertex 3\nproperty float x\nproperty float y\n"
                                                       "property int16 z\nelement face 1\n"
                                                       "property list uchar int vertex_indices\nend_header\n"
                                                       "-30 -20 0\n30 -20 0\n30 -20 15\n3 0 1 2\n");
    const InputError e = loadError(file);
    EXPECT_EQ(e.field(), "header");
    EXPECT_EQ(e.line(), 7);
    EXPECT_NE(std::string(e.what()).find("vertex coordinate 'z' is int16"), std::string::npos) << e.what();
}

// Found by the PLY harness (docs/fuzzing.md): a vertex coordinate declared as a
// list (`property list uchar float z`) made CGAL's reader assert (release
// builds: dereference a null property).
TEST(MeshIo, PlyVertexCoordinateDeclaredAsAListIsNamedAtItsLine)
{
    hgtest::TempDir dir;
    const auto file = hgtest::writeFile(dir / "l.ply", "ply\nformat ascii 1.0\n"
                                                       "element vertex 3\nproperty float x\nproperty float y\n"
                                                       "property list uchar float z\nelement face 1\n"
                                                       "property list uchar int vertex_indices\nend_header\n"
                                                       "-30 -20 1 0\n30 -20 1 0\n30 -20 1 15\n3 0 1 2\n");
    const InputError e = loadError(file);
    EXPECT_EQ(e.field(), "header");
    EXPECT_EQ(e.line(), 6);
    EXPECT_NE(std::string(e.what()).find("vertex coordinate 'z' is a list of float"), std::string::npos) << e.what();
}

// Found by the PLY harness (docs/fuzzing.md): an element count of -2 (read as
// 2^64 - 2) of an element without properties kept the reader busy for ever.
TEST(MeshIo, PlyElementCountThatIsNegativeOrBeyondTheFileIsNamedAtItsLine)
{
    using namespace std::string_literals; // the element's name holds NUL bytes
    hgtest::TempDir dir;
    const std::string head = "ply\nformat binary_big_endian 1.0\n";
    InputError e =
        loadError(hgtest::writeFile(dir / "n.ply", head + "element verte\0\0 -2comment20 15\nend_header\n"s));
    EXPECT_EQ(e.field(), "header");
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(std::string(e.what()).find("count '-2comment20' is not a whole number"), std::string::npos) << e.what();
    e = loadError(hgtest::writeFile(dir / "b.ply", head + "element vertex 4000000000\nproperty float x\nend_header\n"));
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(std::string(e.what()).find("element 'vertex': count '4000000000'"), std::string::npos) << e.what();
}

// Found by the PLY harness (docs/fuzzing.md): a header without `end_header`
// is complete to CGAL's reader, which then sizes each face's list with a count
// it never read (a timeout of an open-ended run).
TEST(MeshIo, PlyHeaderWithoutEndHeaderIsNamedAtItsLastLine)
{
    hgtest::TempDir dir;
    const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\nelement face 1\nproperty list int32 int vertex_indices\n";
    const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    // The same file with its `end_header` reaches the reader (one triangle: not a volume).
    EXPECT_EQ(loadError(hgtest::writeFile(dir / "fine.ply", header + "end_header\n" + body)).field(), "mesh");
    // Without it the header runs over the body's four lines to line 12.
    const InputError e = loadError(hgtest::writeFile(dir / "open.ply", header + body));
    EXPECT_EQ(e.field(), "header");
    EXPECT_EQ(e.line(), 12);
    EXPECT_NE(std::string(e.what()).find("no 'end_header' line"), std::string::npos) << e.what();
    // A file that is no PLY at all is left to the reader, which says so.
    EXPECT_EQ(loadError(hgtest::writeFile(dir / "stl.ply", "solid x\nendsolid x\n")).field(), "mesh");
}

TEST(MeshIo, PlyWhoseFirstLineIsNotPlyIsLeftToTheReader)
{
    hgtest::TempDir dir;
    // A header of PLY lines under a first line that is not `ply`: the walk of the
    // body would name the vertex's 'zero'; the reader refuses the file first.
    const std::string header = "uin(t8ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                               "property float z\nend_header\n";
    InputError e = loadError(hgtest::writeFile(dir / "a.ply", header + "0 0 zero\n1 0 0\n"));
    EXPECT_EQ(e.field(), "mesh") << e.what();
    // As a fuzzed file had it: an element of 33 billion items without properties.
    e = loadError(hgtest::writeFile(dir / "b.ply", "uin(t8ply\nformat ascii 1.0\nelement vertex 33333333333\n"
                                                   "end_header\n"));
    EXPECT_EQ(e.field(), "mesh") << e.what();
}

TEST(MeshIo, PlyListLongerThanTheFileOrNegativeIsNamedAtItsItem)
{
    // A tetrahedron; its second face's list count is the case (docs/fuzzing.md,
    // "Findings, fixed": CGAL's reader sized a vector with it).
    using namespace std::string_literals;
    hgtest::TempDir dir;
    const std::string ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                              "property float z\nelement face 4\nproperty list char int vertex_indices\nend_header\n"
                              "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n";
    const std::string rest = "\n3 0 3 2\n3 1 2 3\n";
    // The well-formed file loads: four faces, volume 1/6.
    const TriangleMesh tetra = loadMesh(hgtest::writeFile(dir / "t.ply", ascii + "3 0 1 3" + rest));
    EXPECT_EQ(tetra.triangles.size(), 4u);
    EXPECT_NEAR(tetra.signedVolume(), 1.0 / 6.0, 1e-12);
    InputError e = loadError(hgtest::writeFile(dir / "long.ply", ascii + "120 0 1 3" + rest));
    EXPECT_EQ(e.field(), "face 2");
    EXPECT_NE(std::string(e.what()).find("list 'vertex_indices' holds 120 items: more than fit in the"),
              std::string::npos)
        << e.what();
    e = loadError(hgtest::writeFile(dir / "negative.ply", ascii + "-3 0 1 3" + rest));
    EXPECT_EQ(e.field(), "face 2");
    EXPECT_NE(std::string(e.what()).find("holds -3 items: a negative number"), std::string::npos) << e.what();
    // A property of a type PLY does not have is left out by CGAL's reader and
    // by the check alike (a fuzzed header's `property redat y` had stopped the check).
    // A list at the file's end: the reader would size it with a count it failed to read.
    e = loadError(hgtest::writeFile(dir / "short.ply", ascii + "3 0 1 3\n3 0 3 2\n"));
    EXPECT_EQ(e.field(), "face 4");
    EXPECT_NE(std::string(e.what()).find("no count where one is due"), std::string::npos) << e.what();
    std::string unknown = ascii;
    unknown.insert(unknown.find("property list"), "property flot w\n");
    e = loadError(hgtest::writeFile(dir / "unknown.ply", unknown + "120 0 1 3" + rest));
    EXPECT_EQ(e.field(), "face 2");
    // Binary, little-endian: an int32 count of 2^31 - 1 after three faces.
    std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 4\nproperty list int32 int vertex_indices\nend_header\n";
    binary += std::string(4 * 12, '\0');
    for (int f = 0; f < 3; ++f) binary += "\x03\0\0\0"s + std::string(12, '\0');
    binary += "\xff\xff\xff\x7f"s + std::string(12, '\0');
    e = loadError(hgtest::writeFile(dir / "b.ply", binary));
    EXPECT_EQ(e.field(), "face 4");
    EXPECT_NE(std::string(e.what()).find("holds 2147483647 items: more than fit in the 12 bytes left"),
              std::string::npos)
        << e.what();
    // A second `format` line is ignored, as CGAL's reader ignores it (a fuzzed
    // file read as ASCII by the check and as binary by the reader timed out).
    binary.insert(binary.find("element"), "format ascii 1.0\n");
    e = loadError(hgtest::writeFile(dir / "b2.ply", binary));
    EXPECT_EQ(e.field(), "face 4");
}

// Found by the PLY harness (docs/fuzzing.md): CGAL's reader reads an ASCII
// value with `>>`, so it stops inside `2!6`, fails on a number its type
// cannot hold and wraps `-1` into an unsigned count; once its stream has
// failed, the next list count is one it never read (out of memory). Every
// ASCII value must be a whole number of its type.
TEST(MeshIo, PlyAsciiValueTheReaderCannotReadWholeIsNamedAtItsItem)
{
    hgtest::TempDir dir;
    const std::string header = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                               "property float z\nelement face 4\nproperty list uint int vertex_indices\nend_header\n";
    const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
    const auto load = [&](const std::string& name, const std::string& body) {
        return hgtest::writeFile(dir / name, header + body);
    };
    // Written as exporters write numbers (a sign, an exponent, a leading dot) it loads: volume 1/6.
    const TriangleMesh tetra = loadMesh(
        load("t.ply", "+0 0.0 -0\n1e0 0 .0\n0 1 0\n0 0 1.000\n" + std::string("3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")));
    EXPECT_NEAR(tetra.signedVolume(), 1.0 / 6.0, 1e-12);
    InputError e = loadError(load("stop.ply", vertices + "3 0 2 1\n3 0 1 3\n3 0 3 2!6\n3 1 2 3\n"));
    EXPECT_EQ(e.field(), "face 3");
    EXPECT_NE(std::string(e.what()).find("property 'vertex_indices': '2!6' is not a number of type int"),
              std::string::npos)
        << e.what();
    e = loadError(load("wide.ply", vertices + "3 0 2 1\n3 0 1 3000000000\n3 0 3 2\n3 1 2 3\n"));
    EXPECT_EQ(e.field(), "face 2");
    e = loadError(load("wrap.ply", vertices + "3 0 2 1\n-1 0 1 3\n3 0 3 2\n3 1 2 3\n"));
    EXPECT_EQ(e.field(), "face 2");
    EXPECT_NE(std::string(e.what()).find("no count where one is due ('-1' is not a whole number of type uint)"),
              std::string::npos)
        << e.what();
    // The reader cuts a uchar count to its byte: 259 items written would be read as 3 and the next 256 as counts.
    std::string uchar = header;
    uchar.replace(uchar.find("list uint"), 9, "list uchar");
    std::string items;
    for (int k = 0; k < 259; ++k) items += " 0";
    e = loadError(
        hgtest::writeFile(dir / "byte.ply", uchar + vertices + "259" + items + "\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"));
    EXPECT_EQ(e.field(), "face 1");
    EXPECT_NE(std::string(e.what()).find("'259' is not a whole number of type uchar"), std::string::npos) << e.what();
    e = loadError(load("coordinate.ply", "0 0 0\n1 0 0\n0 1 nan\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"));
    EXPECT_EQ(e.field(), "vertex 3");
    EXPECT_NE(std::string(e.what()).find("property 'z': 'nan' is not a number of type float"), std::string::npos)
        << e.what();
}

// A body that ends before the items its header announces is named at the
// item where it ends, ASCII and binary: the reader would go on reading from
// a failed stream (docs/fuzzing.md).
TEST(MeshIo, PlyBodyThatEndsEarlyIsNamedAtItsItem)
{
    using namespace std::string_literals;
    hgtest::TempDir dir;
    const std::string ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                              "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
    InputError e = loadError(hgtest::writeFile(dir / "a.ply", ascii + "0 0 0\n1 0 0\n0 1 0\n0 0\n"));
    EXPECT_EQ(e.field(), "vertex 4");
    EXPECT_NE(std::string(e.what()).find("the file ends at property 'z' (the header announces 4 of element "
                                         "'vertex')"),
              std::string::npos)
        << e.what();
    // Binary: 4 vertices of 12 bytes announced, 2 and a half there.
    const std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 1\n"
                               "property list uchar int vertex_indices\nend_header\n";
    e = loadError(hgtest::writeFile(dir / "b.ply", binary + std::string(30, '\0')));
    EXPECT_EQ(e.field(), "vertex 3");
    EXPECT_NE(std::string(e.what()).find("the file ends at property 'y'"), std::string::npos) << e.what();
    // All vertices there, the face's three indices of 4 bytes cut after 8.
    e = loadError(hgtest::writeFile(dir / "c.ply", binary + std::string(48, '\0') + "\x03"s + std::string(8, '\0')));
    EXPECT_EQ(e.field(), "face 1");
    EXPECT_NE(std::string(e.what()).find("list 'vertex_indices' holds 3 items: more than fit in the 8 bytes left"),
              std::string::npos)
        << e.what();
}

TEST(MeshCheckTest, PrimitivesAreClosedAndOutward)
{
    for (const TriangleMesh& m : {makeBox(Vector3d::Zero(), Vector3d(1, 2, 3)), makeSphere(Vector3d(1, 1, 1), 2.0),
                                  makeCylinder(Vector3d::Zero(), 3.0, 5.0, 24)}) {
        const MeshCheck c = checkMesh(m);
        EXPECT_TRUE(c.ok()) << c.problem();
        EXPECT_EQ(c.problem(), "");
    }
}

TEST(MeshCheckTest, RequireSolidMeshFlipsOnlyInvertedMeshes)
{
    TriangleMesh box = makeBox(Vector3d::Zero(), Vector3d(1, 1, 1));
    box.flip();
    requireSolidMesh(box, "box");
    EXPECT_NEAR(box.signedVolume(), 1.0, 1e-15);
    box.triangles.pop_back();
    try {
        requireSolidMesh(box, "box");
        FAIL() << "an open mesh was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "box");
        EXPECT_EQ(e.field(), "mesh");
    }
}

} // namespace
} // namespace hg::model
