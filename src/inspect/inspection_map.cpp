#include "hullgauge/inspect/inspection_map.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <unordered_map>

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"

namespace hg::inspect {
namespace {

constexpr char kMagic[8] = {'H', 'G', 'M', 'A', 'P', '\r', '\n', '\x1a'};
// Version 2 stores the don't-care and hidden flags in the node's former
// reserved byte; version 1 had zero there, which reads as neither. Version 3
// adds each landmark's asymmetric limits (a flag byte, then lower and upper);
// a map without limits is written as version 2, which older readers read.
constexpr std::uint32_t kFormatVersion = 3;
constexpr std::uint32_t kVersionWithoutLimits = 2;
constexpr std::uint32_t kOldestReadableVersion = 1;
constexpr std::uint8_t kFlagDontCare = 1;
constexpr std::uint8_t kFlagHidden = 2;

/// FNV-1a over 64-bit little-endian words (the tail byte-wise): a corruption
/// check fast enough to keep loading a large map well under 10 ms.
std::uint64_t checksum(const std::uint8_t* data, std::size_t n)
{
    std::uint64_t h = 14695981039346656037ull;
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        std::uint64_t w;
        std::memcpy(&w, data + i, 8);
        h = (h ^ w) * 1099511628211ull;
    }
    for (; i < n; ++i) h = (h ^ data[i]) * 1099511628211ull;
    return h;
}

/// Little-endian writer/reader of the map file's fields.
class Writer {
  public:
    std::vector<std::uint8_t> bytes;
    template <typename T> void put(T v)
    {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
        bytes.insert(bytes.end(), p, p + sizeof(T));
    }
    void putString(const std::string& s)
    {
        put(static_cast<std::uint32_t>(s.size()));
        bytes.insert(bytes.end(), s.begin(), s.end());
    }
    void putVec(const Eigen::Vector3d& v)
    {
        put(v.x());
        put(v.y());
        put(v.z());
    }
    void putInts(const std::vector<std::int32_t>& v)
    {
        put(static_cast<std::uint64_t>(v.size()));
        const auto* p = reinterpret_cast<const std::uint8_t*>(v.data());
        bytes.insert(bytes.end(), p, p + v.size() * sizeof(std::int32_t));
    }
};

class Reader {
  public:
    Reader(const std::uint8_t* data, std::size_t size, std::string name)
        : p_(data), end_(data + size), name_(std::move(name))
    {
    }
    template <typename T> T get()
    {
        need(sizeof(T));
        T v;
        std::memcpy(&v, p_, sizeof(T));
        p_ += sizeof(T);
        return v;
    }
    std::string getString()
    {
        const auto n = get<std::uint32_t>();
        need(n);
        std::string s(reinterpret_cast<const char*>(p_), n);
        p_ += n;
        return s;
    }
    Eigen::Vector3d getVec()
    {
        const double x = get<double>(), y = get<double>(), z = get<double>();
        return {x, y, z};
    }
    std::vector<std::int32_t> getInts()
    {
        const auto n = get<std::uint64_t>();
        if (n > static_cast<std::uint64_t>(end_ - p_) / sizeof(std::int32_t)) fail("array longer than the file");
        std::vector<std::int32_t> v(n);
        if (n > 0) std::memcpy(v.data(), p_, n * sizeof(std::int32_t)); // an empty vector's data() may be null
        p_ += n * sizeof(std::int32_t);
        return v;
    }
    bool atEnd() const { return p_ == end_; }
    [[noreturn]] void fail(const std::string& problem) const { throw InputError(name_, "inspection map", problem); }

  private:
    void need(std::size_t n) const
    {
        if (static_cast<std::size_t>(end_ - p_) < n) fail("file is truncated");
    }
    const std::uint8_t* p_;
    const std::uint8_t* end_;
    std::string name_;
};

struct BuildNode {
    bool onPath = false;
    bool landmark = false;
    int ring = 255;
};

} // namespace

const std::array<Eigen::Vector3i, 26>& neighbourOffsets()
{
    static const std::array<Eigen::Vector3i, 26> offsets = [] {
        std::array<Eigen::Vector3i, 26> o{};
        int s = 0;
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz)
                    if (dx != 0 || dy != 0 || dz != 0) o[s++] = Eigen::Vector3i(dx, dy, dz);
        return o;
    }();
    return offsets;
}

std::int32_t InspectionMap::find(VoxelKey key) const
{
    auto it =
        std::lower_bound(nodes_.begin(), nodes_.end(), key, [](const MapNode& n, VoxelKey k) { return n.key < k; });
    if (it == nodes_.end() || it->key != key) return -1;
    return static_cast<std::int32_t>(it - nodes_.begin());
}

std::int32_t InspectionMap::landmarkNode(std::size_t l, int level) const
{
    if (level < geometry_.coarsestLevel || level > geometry_.depth || l >= landmarks_.size()) return -1;
    const int levels = geometry_.depth - geometry_.coarsestLevel + 1;
    return landmarkNodes_[l * static_cast<std::size_t>(levels) +
                          static_cast<std::size_t>(level - geometry_.coarsestLevel)];
}

std::optional<std::size_t> InspectionMap::landmarkIndex(const std::string& id) const
{
    for (std::size_t i = 0; i < landmarks_.size(); ++i)
        if (landmarks_[i].id == id) return i;
    return std::nullopt;
}

InspectionMap InspectionMap::build(std::string partName, const MapGeometry& g, std::vector<MapLandmark> landmarks,
                                   std::vector<MapParameter> parameters, const LabelOracle& oracle)
{
    return build(std::move(partName), g, std::move(landmarks), std::move(parameters),
                 [&oracle](const Eigen::AlignedBox3d& box) {
                     return VoxelExpectation{oracle(box), false, false};
                 });
}

InspectionMap InspectionMap::build(std::string partName, const MapGeometry& g, std::vector<MapLandmark> landmarks,
                                   std::vector<MapParameter> parameters, const ExpectationOracle& oracle)
{
    if (!(g.cubeSize > 0.0))
        throw ArgumentError("octree cube size must be positive, found " + formatNumber(g.cubeSize));
    if (g.depth < 0 || g.depth > kMaxDepth)
        throw ArgumentError("octree depth must be within 0.." + std::to_string(kMaxDepth) + ", found " +
                            std::to_string(g.depth));
    if (g.coarsestLevel < 0 || g.coarsestLevel > g.depth)
        throw ArgumentError("coarsest inspection level must be within 0..depth (0.." + std::to_string(g.depth) +
                            "), found " + std::to_string(g.coarsestLevel));
    if (g.adjacencyDepth < 1 || g.adjacencyDepth > 64)
        throw ArgumentError("adjacency depth must be within 1..64, found " + std::to_string(g.adjacencyDepth));

    InspectionMap map;
    map.partName_ = std::move(partName);
    map.geometry_ = g;
    map.frame_ = g.frame();
    const Eigen::AlignedBox3d cube(g.cubeOrigin, g.cubeOrigin + Eigen::Vector3d::Constant(g.cubeSize));
    for (MapLandmark& lm : landmarks) {
        if (!cube.contains(lm.position)) throw ArgumentError("landmark '" + lm.id + "' lies outside the octree cube");
        if (!(lm.normal.norm() > 0.0)) throw ArgumentError("landmark '" + lm.id + "' has a zero normal");
        lm.normal.normalize();
    }

    std::unordered_map<VoxelKey, BuildNode> build;
    build.reserve(landmarks.size() * 512);
    const int A = g.adjacencyDepth;
    for (const MapLandmark& lm : landmarks) {
        for (int level = 0; level <= g.depth; ++level) {
            const VoxelKey key = map.frame_.landmarkKey(lm, level);
            BuildNode& n = build[key];
            n.onPath = n.onPath || level < g.depth;
            if (level < g.coarsestLevel) continue;
            n.landmark = true;
            n.ring = 0;
            // Type-four network: every same-size voxel within A 26-neighbour
            // layers (Chebyshev distance) of the landmark voxel.
            const Eigen::Vector3i c = keyIndex(key);
            const int nmax = (1 << level) - 1;
            for (int dx = -A; dx <= A; ++dx)
                for (int dy = -A; dy <= A; ++dy)
                    for (int dz = -A; dz <= A; ++dz) {
                        const Eigen::Vector3i q = c + Eigen::Vector3i(dx, dy, dz);
                        if ((q.array() < 0).any() || (q.array() > nmax).any()) continue;
                        const int ring = std::max({std::abs(dx), std::abs(dy), std::abs(dz)});
                        BuildNode& m = build[makeKey(level, q.x(), q.y(), q.z())];
                        m.ring = std::min(m.ring, ring);
                    }
        }
    }

    std::vector<VoxelKey> keys;
    keys.reserve(build.size());
    for (const auto& [k, v] : build) keys.push_back(k);
    std::sort(keys.begin(), keys.end());
    map.nodes_.resize(keys.size());
    for (std::size_t i = 0; i < keys.size(); ++i) {
        const BuildNode& b = build[keys[i]];
        MapNode& n = map.nodes_[i];
        n.key = keys[i];
        n.ring = static_cast<std::uint8_t>(std::min(b.ring, 255));
        n.type = b.landmark ? NodeType::Landmark : (b.ring <= A ? NodeType::Adjacent : NodeType::Path);
    }
    for (std::size_t i = 0; i < keys.size(); ++i) {
        MapNode& n = map.nodes_[i];
        const BuildNode& b = build[keys[i]];
        const int level = keyLevel(n.key);
        const Eigen::Vector3i ijk = keyIndex(n.key);
        if (b.onPath) {
            n.children = static_cast<std::int32_t>(map.children_.size());
            for (int c = 0; c < 8; ++c)
                map.children_.push_back(map.find(
                    makeKey(level + 1, 2 * ijk.x() + (c >> 2 & 1), 2 * ijk.y() + (c >> 1 & 1), 2 * ijk.z() + (c & 1))));
        }
        if (n.ring <= A) {
            n.neighbours = static_cast<std::int32_t>(map.neighbours_.size());
            const int nmax = (1 << level) - 1;
            for (const Eigen::Vector3i& o : neighbourOffsets()) {
                const Eigen::Vector3i q = ijk + o;
                std::int32_t idx = -1;
                if ((q.array() >= 0).all() && (q.array() <= nmax).all()) {
                    idx = map.find(makeKey(level, q.x(), q.y(), q.z()));
                    if (idx >= 0 && map.nodes_[static_cast<std::size_t>(idx)].ring > A) idx = -1;
                }
                map.neighbours_.push_back(idx);
            }
            const VoxelExpectation e = oracle(map.frame_.box(n.key));
            n.expectedObject = e.object;
            n.dontCare = e.dontCare;
            n.hidden = e.hidden && !e.object;
        }
    }

    const int levels = g.depth - g.coarsestLevel + 1;
    map.landmarkNodes_.resize(landmarks.size() * static_cast<std::size_t>(levels));
    for (std::size_t l = 0; l < landmarks.size(); ++l)
        for (int level = g.coarsestLevel; level <= g.depth; ++level)
            map.landmarkNodes_[l * static_cast<std::size_t>(levels) +
                               static_cast<std::size_t>(level - g.coarsestLevel)] =
                map.find(map.frame_.landmarkKey(landmarks[l], level));
    map.rootIndex_ = map.nodes_.empty() ? -1 : 0;
    map.landmarks_ = std::move(landmarks);
    map.parameters_ = std::move(parameters);
    return map;
}

std::vector<std::uint8_t> InspectionMap::serialise() const
{
    const bool limits = std::any_of(landmarks_.begin(), landmarks_.end(),
                                    [](const MapLandmark& lm) { return lm.limitsMm.has_value(); });
    const std::uint32_t version = limits ? kFormatVersion : kVersionWithoutLimits;
    Writer w;
    w.putString(partName_);
    w.putVec(geometry_.cubeOrigin);
    w.put(geometry_.cubeSize);
    w.put(static_cast<std::int32_t>(geometry_.depth));
    w.put(static_cast<std::int32_t>(geometry_.adjacencyDepth));
    w.put(static_cast<std::int32_t>(geometry_.coarsestLevel));
    w.put(static_cast<std::uint64_t>(nodes_.size()));
    for (const MapNode& n : nodes_) {
        w.put(n.key);
        w.put(static_cast<std::uint8_t>(n.type));
        w.put(static_cast<std::uint8_t>(n.expectedObject ? 1 : 0));
        w.put(n.ring);
        w.put(static_cast<std::uint8_t>((n.dontCare ? kFlagDontCare : 0) | (n.hidden ? kFlagHidden : 0)));
        w.put(n.children);
        w.put(n.neighbours);
    }
    w.putInts(children_);
    w.putInts(neighbours_);
    w.put(static_cast<std::uint32_t>(landmarks_.size()));
    for (const MapLandmark& lm : landmarks_) {
        w.putString(lm.id);
        w.putVec(lm.position);
        w.putVec(lm.normal);
        w.put(lm.toleranceMm);
        if (version >= 3) w.put(static_cast<std::uint8_t>(lm.limitsMm ? 1 : 0));
        if (lm.limitsMm) {
            w.put(lm.limitsMm->first);
            w.put(lm.limitsMm->second);
        }
    }
    w.put(static_cast<std::uint32_t>(parameters_.size()));
    for (const MapParameter& p : parameters_) {
        w.putString(p.id);
        w.put(static_cast<std::uint8_t>(p.kind));
        w.put(static_cast<std::uint32_t>(p.landmarks.size()));
        for (const std::string& s : p.landmarks) w.putString(s);
        w.put(p.nominal);
        w.put(p.tolerance);
    }
    w.putInts(landmarkNodes_);
    w.put(rootIndex_);

    std::vector<std::uint8_t> out(kMagic, kMagic + 8);
    Writer h;
    h.put(version);
    h.put(std::uint32_t{0});
    h.put(static_cast<std::uint64_t>(w.bytes.size()));
    h.put(checksum(w.bytes.data(), w.bytes.size()));
    out.insert(out.end(), h.bytes.begin(), h.bytes.end());
    out.insert(out.end(), w.bytes.begin(), w.bytes.end());
    return out;
}

void InspectionMap::save(const std::filesystem::path& file) const
{
    const auto bytes = serialise();
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    if (!out) throw FaultError("cannot write inspection map " + file.string());
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw FaultError("cannot write inspection map " + file.string());
}

InspectionMap InspectionMap::load(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(file.string(), "", "cannot open inspection map");
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    in.seekg(0, std::ios::beg);
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(std::max<std::streamoff>(size, 0)));
    if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
        throw InputError(file.string(), "", "cannot read inspection map");
    return deserialise(bytes, file.string());
}

InspectionMap InspectionMap::deserialise(const std::vector<std::uint8_t>& bytes, const std::string& name)
{
    Reader head(bytes.data(), bytes.size(), name);
    if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0) head.fail("not an inspection map (bad magic)");
    Reader hr(bytes.data() + 8, bytes.size() - 8, name);
    const auto version = hr.get<std::uint32_t>();
    if (version < kOldestReadableVersion || version > kFormatVersion)
        hr.fail("format version " + std::to_string(version) + " is not supported (this program reads " +
                std::to_string(kOldestReadableVersion) + ".." + std::to_string(kFormatVersion) +
                "); rebuild it with 'hullgauge build-map'");
    hr.get<std::uint32_t>();
    const auto size = hr.get<std::uint64_t>();
    const auto stored = hr.get<std::uint64_t>();
    constexpr std::size_t headerSize = 8 + 4 + 4 + 8 + 8;
    if (bytes.size() - headerSize != size) hr.fail("file is truncated or has trailing bytes");
    const std::uint8_t* payload = bytes.data() + headerSize;
    if (checksum(payload, size) != stored) hr.fail("checksum mismatch (file is corrupt)");

    Reader r(payload, size, name);
    InspectionMap map;
    map.partName_ = r.getString();
    map.geometry_.cubeOrigin = r.getVec();
    map.geometry_.cubeSize = r.get<double>();
    map.geometry_.depth = r.get<std::int32_t>();
    map.geometry_.adjacencyDepth = r.get<std::int32_t>();
    map.geometry_.coarsestLevel = r.get<std::int32_t>();
    const MapGeometry& g = map.geometry_;
    map.frame_ = g.frame();
    if (!(g.cubeSize > 0) || g.depth < 0 || g.depth > kMaxDepth || g.coarsestLevel < 0 || g.coarsestLevel > g.depth ||
        g.adjacencyDepth < 1 || g.adjacencyDepth > 64)
        r.fail("octree geometry out of range");
    const auto nNodes = r.get<std::uint64_t>();
    if (nNodes > size / 20) r.fail("node count larger than the file");
    map.nodes_.resize(nNodes);
    for (MapNode& n : map.nodes_) {
        n.key = r.get<VoxelKey>();
        const auto type = r.get<std::uint8_t>();
        if (type < 2 || type > 4) r.fail("bad node type");
        n.type = static_cast<NodeType>(type);
        n.expectedObject = r.get<std::uint8_t>() != 0;
        n.ring = r.get<std::uint8_t>();
        const auto flags = r.get<std::uint8_t>();
        if (flags & ~(kFlagDontCare | kFlagHidden)) r.fail("bad node flags");
        n.dontCare = (flags & kFlagDontCare) != 0;
        n.hidden = (flags & kFlagHidden) != 0;
        n.children = r.get<std::int32_t>();
        n.neighbours = r.get<std::int32_t>();
    }
    map.children_ = r.getInts();
    map.neighbours_ = r.getInts();
    const auto nLandmarks = r.get<std::uint32_t>();
    for (std::uint32_t i = 0; i < nLandmarks; ++i) {
        MapLandmark lm;
        lm.id = r.getString();
        lm.position = r.getVec();
        lm.normal = r.getVec();
        lm.toleranceMm = r.get<double>();
        if (version >= 3) {
            const auto hasLimits = r.get<std::uint8_t>();
            if (hasLimits > 1) r.fail("bad landmark limits flag");
            if (hasLimits) {
                const double lower = r.get<double>(), upper = r.get<double>();
                if (!(lower < upper)) r.fail("landmark limits out of order");
                lm.limitsMm = std::make_pair(lower, upper);
            }
        }
        map.landmarks_.push_back(std::move(lm));
    }
    const auto nParams = r.get<std::uint32_t>();
    for (std::uint32_t i = 0; i < nParams; ++i) {
        MapParameter p;
        p.id = r.getString();
        const auto kind = r.get<std::uint8_t>();
        if (kind > 2) r.fail("bad parameter kind");
        p.kind = static_cast<ParameterKind>(kind);
        const auto nl = r.get<std::uint32_t>();
        for (std::uint32_t k = 0; k < nl; ++k) p.landmarks.push_back(r.getString());
        p.nominal = r.get<double>();
        p.tolerance = r.get<double>();
        map.parameters_.push_back(std::move(p));
    }
    map.landmarkNodes_ = r.getInts();
    map.rootIndex_ = r.get<std::int32_t>();
    if (!r.atEnd()) r.fail("unexpected bytes after the landmark table");

    // Every link must point into the node array: a corrupt file must not crash the traversal.
    const auto n = static_cast<std::int32_t>(map.nodes_.size());
    auto inRange = [&](std::int32_t i) { return i >= -1 && i < n; };
    for (const MapNode& node : map.nodes_) {
        if (node.children >= 0 && static_cast<std::size_t>(node.children) + 8 > map.children_.size())
            r.fail("child link out of range");
        if (node.neighbours >= 0 && static_cast<std::size_t>(node.neighbours) + 26 > map.neighbours_.size())
            r.fail("neighbour link out of range");
    }
    if (!std::all_of(map.children_.begin(), map.children_.end(), inRange) ||
        !std::all_of(map.neighbours_.begin(), map.neighbours_.end(), inRange) ||
        !std::all_of(map.landmarkNodes_.begin(), map.landmarkNodes_.end(), inRange) || !inRange(map.rootIndex_))
        r.fail("node index out of range");
    if (map.landmarkNodes_.size() != map.landmarks_.size() * static_cast<std::size_t>(g.depth - g.coarsestLevel + 1))
        r.fail("landmark table does not match the octree levels");
    return map;
}

} // namespace hg::inspect
