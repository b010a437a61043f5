// The octree inspection map (dissertation 3.3.1, 3.3.2, 3.5.1).
//
// Frame: voxel_frame.h (world = cubeOrigin + ΔV_L · index); each landmark's
// type-three node is VoxelFrame::landmarkKey, the voxel the planner reasons
// about too.
//
// Node types (3.3.2): type one — absent (no entry); type two — a node on a path
// to at least one landmark (downward links to its 8 children, -1 for type-one
// children); type three — the voxel holding a landmark at an inspection level;
// type four — a same-size neighbour of a landmark voxel or of another type-four
// node, out to `adjacencyDepth` 26-neighbour layers. Neighbour links are
// symmetric (each of the 26 slots of a network node points to the neighbour
// node or -1), which is the dissertation's double linkage: a node's "parents"
// are its linked neighbours nearer a landmark (smaller `ring`), its "children"
// those farther out. A neighbour reached from two landmarks is one node. A
// landmark voxel that also lies in another landmark's network stays one node
// (type three, it carries all of a type four's information).
//
// Storage is Open3D-style: nodes in one flat array sorted by their integer
// voxel key, links as indices into it, so traversal is index chasing and the
// file format is the arrays themselves.
//
// Inspection levels: networks (types three and four) exist at every level from
// `coarsestLevel` to `depth`; an inspection may run at any of those levels, on
// any subset of landmarks and with any adjacency up to `adjacencyDepth`,
// without rebuilding (3.3.7, 3.4).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hullgauge/inspect/voxel_frame.h"
#include "hullgauge/model/part_program.h"

namespace hg::inspect {

enum class NodeType : std::uint8_t { Path = 2, Landmark = 3, Adjacent = 4 };

struct MapNode {
    VoxelKey key = 0;
    NodeType type = NodeType::Path;
    /// Expected label from the CAD: object when >= 50 % of the voxel is inside
    /// (network nodes only; path nodes keep false).
    bool expectedObject = false;
    /// The CAD inside fraction is within kDontCareBand of 50 %: either
    /// reconstruction is right, so the voxel never counts as wrong.
    bool dontCare = false;
    /// Void in the CAD but enclosed by the part: no line of sight through the
    /// voxel misses the part, so no silhouette can prove it void (the type-four
    /// nodes 3.3.8 pares from the map as not visible). Never counts as wrong; a
    /// landmark whose normal line starts in such voxels is not_observable.
    bool hidden = false;
    /// 26-neighbour layers to the nearest landmark voxel of this level; 0 for a
    /// landmark voxel, 255 for a node that is on a path only.
    std::uint8_t ring = 255;
    /// Index of the first of 8 child slots in InspectionMap::children(), or -1.
    std::int32_t children = -1;
    /// Index of the first of 26 neighbour slots in InspectionMap::neighbours(), or -1.
    std::int32_t neighbours = -1;

    bool operator==(const MapNode&) const = default;
};

/// The 26 neighbour offsets, in slot order (dz fastest, then dy, then dx; the
/// centre skipped). Slot s and slot 25 - s are opposite.
const std::array<Eigen::Vector3i, 26>& neighbourOffsets();

/// The part program's parameter kinds (named by their table, model/part_program.h).
using ParameterKind = model::ParameterKind;

struct MapParameter {
    std::string id;
    ParameterKind kind = ParameterKind::Distance;
    std::vector<std::string> landmarks;
    double nominal = 0.0;   ///< mm, or mm² for an area
    double tolerance = 0.0; ///< same unit as nominal

    bool operator==(const MapParameter&) const = default;
};

struct MapGeometry {
    Eigen::Vector3d cubeOrigin = Eigen::Vector3d::Zero();
    double cubeSize = 1.0;  ///< mm
    int depth = 8;          ///< finest level (ΔV = cubeSize / 2^depth)
    int adjacencyDepth = 3; ///< type-four layers
    int coarsestLevel = 8;  ///< coarsest level with networks (<= depth)

    VoxelFrame frame() const { return {cubeOrigin, cubeSize, depth}; }
    bool operator==(const MapGeometry&) const = default;
};

/// Expected label of a voxel: true = object (>= 50 % inside; Solid::isObjectVoxel).
using LabelOracle = std::function<bool(const Eigen::AlignedBox3d&)>;

/// Half-width of the "don't care" band of CAD inside fractions around 50 %.
/// A face lying on a voxel mid-plane puts the voxel exactly at the tie of
/// the CAD label (object at >= 50 % inside) and of the 50 % rule (void at >=
/// 50 % background); within |f - 0.5| < 0.02 (a face within 2 % of ΔV of the
/// mid-plane) the reconstruction may go either way and is not an error.
constexpr double kDontCareBand = 0.02;

/// What the CAD says of one network voxel (see MapNode).
struct VoxelExpectation {
    bool object = false;
    bool dontCare = false;
    bool hidden = false;
};
using ExpectationOracle = std::function<VoxelExpectation(const Eigen::AlignedBox3d&)>;

class InspectionMap {
  public:
    /// Builds the map (3.5.1): path nodes to every landmark, type-three nodes at
    /// each inspection level, type-four networks out to adjacencyDepth, labels
    /// from `oracle`. Throws ArgumentError for an impossible geometry
    /// or a landmark outside the cube.
    static InspectionMap build(std::string partName, const MapGeometry& geometry, std::vector<MapLandmark> landmarks,
                               std::vector<MapParameter> parameters, const LabelOracle& oracle);
    /// The same with the full expectation per voxel (don't-care band, hidden
    /// voxels), as cadLabels() gives it.
    static InspectionMap build(std::string partName, const MapGeometry& geometry, std::vector<MapLandmark> landmarks,
                               std::vector<MapParameter> parameters, const ExpectationOracle& oracle);

    /// Versioned binary file ("HGMAP", format version 2, checksum). Version 1
    /// files (no don't-care or hidden voxels) are still read.
    void save(const std::filesystem::path& file) const;
    std::vector<std::uint8_t> serialise() const;
    /// Throws hg::InputError naming the file for a wrong magic, version, size or checksum.
    static InspectionMap load(const std::filesystem::path& file);
    static InspectionMap deserialise(const std::vector<std::uint8_t>& bytes, const std::string& name);

    const std::string& partName() const { return partName_; }
    const MapGeometry& geometry() const { return geometry_; }
    const VoxelFrame& frame() const { return frame_; }

    const std::vector<MapNode>& nodes() const { return nodes_; }
    const std::vector<std::int32_t>& children() const { return children_; }
    const std::vector<std::int32_t>& neighbours() const { return neighbours_; }
    const std::vector<MapLandmark>& landmarks() const { return landmarks_; }
    const std::vector<MapParameter>& parameters() const { return parameters_; }
    /// Root node index (level 0), -1 for a map without landmarks.
    std::int32_t root() const { return nodes_.empty() ? -1 : rootIndex_; }
    /// Node index of landmark `l`'s voxel at `level` (coarsestLevel..depth).
    std::int32_t landmarkNode(std::size_t l, int level) const;
    /// Node index of a key, or -1 (binary search).
    std::int32_t find(VoxelKey key) const;
    /// Neighbour slot s of node n (-1 when absent or n has no network links).
    std::int32_t neighbour(std::int32_t n, int slot) const
    {
        const std::int32_t base = nodes_[static_cast<std::size_t>(n)].neighbours;
        return base < 0 ? -1 : neighbours_[static_cast<std::size_t>(base) + slot];
    }
    /// Walks the neighbour network breadth-first from `layer`, one 26-neighbour
    /// layer at a time (Open3D's Octree::Traverse idea, on the same-size
    /// networks of 3.3.2): `visit(v)` is called for every linked neighbour v
    /// of a node being expanded, in slot order, and returns whether to expand
    /// v in turn, so the goal-driven inspection prunes every branch it has
    /// settled (3.3.8); `done()` is asked before each layer and ends the walk.
    /// The visitor keeps its own record of the nodes it has seen.
    template <typename Visit, typename Done>
    void walkNetwork(std::vector<std::int32_t> layer, Visit&& visit, Done&& done) const
    {
        while (!layer.empty() && !done()) {
            std::vector<std::int32_t> next;
            for (const std::int32_t u : layer)
                for (int s = 0; s < 26; ++s) {
                    const std::int32_t v = neighbour(u, s);
                    if (v >= 0 && visit(v)) next.push_back(v);
                }
            layer = std::move(next);
        }
    }
    /// Index of a landmark by id, or std::nullopt.
    std::optional<std::size_t> landmarkIndex(const std::string& id) const;

    /// Every field, the derived frame and the landmark table included.
    bool operator==(const InspectionMap&) const = default;

  private:
    std::string partName_;
    MapGeometry geometry_;
    VoxelFrame frame_;
    std::vector<MapNode> nodes_;
    std::vector<std::int32_t> children_;
    std::vector<std::int32_t> neighbours_;
    std::vector<MapLandmark> landmarks_;
    std::vector<MapParameter> parameters_;
    /// landmarkNodes_[l * levels + (level - coarsestLevel)]
    std::vector<std::int32_t> landmarkNodes_;
    std::int32_t rootIndex_ = -1;
};

} // namespace hg::inspect
