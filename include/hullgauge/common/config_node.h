// A YAML node that knows the file it came from and its key path, so that every
// configuration error names file, line and field (docs/contracts.md §5, exit status 2):
//   station.yaml:12: fixture.rotation_range_deg: expected a sequence of 2 numbers
// Used by the station, part program, poses and daemon configuration loaders.
#pragma once

#include <filesystem>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "hullgauge/common/enum_names.h"

namespace hg {

class ConfigNode {
  public:
    /// Parses a YAML file; syntax errors and unreadable files throw InputError.
    static ConfigNode loadFile(const std::filesystem::path& file);
    /// Parses YAML text; `name` stands in for the file name in messages.
    static ConfigNode parse(const std::string& text, const std::string& name);

    ConfigNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path);

    const std::string& file() const { return *file_; }
    /// Key path from the document root, e.g. "landmarks[2].position".
    const std::string& path() const { return path_; }
    /// 1-based line of the node in its file (0 when unknown).
    int line() const;
    const YAML::Node& raw() const { return node_; }

    bool isMap() const { return node_.IsMap(); }
    bool isSequence() const { return node_.IsSequence(); }
    bool isNull() const { return !node_ || node_.IsNull(); }
    bool isScalar() const { return node_.IsScalar(); }

    bool has(std::string_view key) const;
    /// A required key of a map; missing keys throw InputError naming the key.
    ConfigNode operator[](std::string_view key) const;
    /// An optional key of a map; an explicit null counts as absent.
    std::optional<ConfigNode> optional(std::string_view key) const;
    /// Keys of a map in file order.
    std::vector<std::string> keys() const;
    /// Elements of a sequence (throws unless the node is a sequence).
    std::vector<ConfigNode> items() const;
    std::size_t size() const;

    double asDouble() const;
    /// A number within [lo, hi]; out-of-range values name the range.
    double asDoubleIn(double lo, double hi) const;
    double asPositive() const;
    long long asInt() const;
    long long asIntIn(long long lo, long long hi) const;
    bool asBool() const;
    std::string asString() const;
    /// A non-empty sequence of numbers; `expectedSize` 0 means any length.
    std::vector<double> asDoubles(std::size_t expectedSize = 0) const;
    Eigen::Vector2d asVector2() const;
    Eigen::Vector3d asVector3() const;
    /// A 3x3 matrix written as three rows of three numbers.
    Eigen::Matrix3d asMatrix3() const;
    /// The enumerator the scalar names (common/enum_names.h); any other text
    /// fails "unknown <what> '<text>' (expected a, b or c)".
    template <class E> E asEnum(std::string_view what) const
    {
        const std::string text = asString();
        if (const auto e = parseEnum<E>(text)) return *e;
        fail("unknown " + std::string(what) + " '" + text + "' (expected " + enumNameList<E>(", ", " or ") + ")");
    }

    /// Throws InputError if the map holds a key not in `allowed` (catches typos
    /// such as `tolerence_mm`, which would otherwise be silently ignored).
    void allowOnlyKeys(std::initializer_list<std::string_view> allowed) const;

    /// Throws InputError for this node: "file:line: path: problem".
    [[noreturn]] void fail(const std::string& problem) const;

  private:
    YAML::Node node_;
    std::shared_ptr<const std::string> file_;
    std::string path_;
};

/// Throws InputError naming the node unless `ok`.
inline void require(bool ok, const ConfigNode& node, const std::string& problem)
{
    if (!ok) node.fail(problem);
}

} // namespace hg
