#include "hullgauge/common/config_node.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>
#include <yaml-cpp/eventhandler.h>

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"

namespace hg {
namespace {

std::string describe(const YAML::Node& n)
{
    if (!n) return "nothing";
    switch (n.Type()) {
    case YAML::NodeType::Null:
        return "null";
    case YAML::NodeType::Scalar:
        return "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence:
        return "a sequence";
    case YAML::NodeType::Map:
        return "a map";
    default:
        return "an undefined value";
    }
}

std::string keyText(const YAML::Node& key)
{
    return key.IsScalar() ? key.Scalar() : describe(key);
}

/// Refuses a map that names one key twice. yaml-cpp keeps both entries and
/// answers lookups with the first, so `depth: 8` then `depth: 3` would build
/// depth 8 without a word; bad input must be named instead (docs/style.md
/// point 4). A key that is a map or a sequence (YAML's `? {a: 1}` or
/// `[a, b]: 1`) names nothing a reader looks up, and reading it as a name
/// threw yaml-cpp's own exception past every caller (docs/fuzzing.md,
/// "Findings, fixed"): it is refused at its line too. `budget` bounds the
/// walk over a document whose aliases repeat one subtree many times.
/// Watches a YAML document's events for content: a scalar, a map, a sequence or an alias.
class ContentSeen : public YAML::EventHandler {
  public:
    std::optional<YAML::Mark> at; ///< where the document's content begins, when it has any

    void OnDocumentStart(const YAML::Mark&) override {}
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
    void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { seen(mark); }
    void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override
    {
        seen(mark);
    }
    void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override
    {
        seen(mark);
    }
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override
    {
        seen(mark);
    }
    void OnMapEnd() override {}

  private:
    void seen(const YAML::Mark& mark)
    {
        if (!at) at = mark;
    }
};

/// Refuses a second document with content: it was once silently ignored, and with it whatever
/// the engineer wrote there. A stream holds at most one document more than it has '---' and
/// '...' lines; the walk stops there, as yaml-cpp's parser can report the same empty document
/// forever (on "," for one).
void rejectSecondDocument(const std::string& text, const std::string& name)
{
    std::size_t bound = 1;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);)
        if (line.rfind("---", 0) == 0 || line.rfind("...", 0) == 0) ++bound;
    std::istringstream in(text);
    YAML::Parser parser(in);
    for (std::size_t k = 0; k < bound; ++k) {
        ContentSeen content;
        if (!parser.HandleNextDocument(content)) return;
        if (k > 0 && content.at)
            throw InputError(name, "",
                             "a second YAML document begins here; a configuration file is one document (remove "
                             "the '---' line or the text after it)",
                             content.at->is_null() ? std::nullopt : std::optional<int>(content.at->line + 1));
    }
}

void rejectDuplicateKeys(const YAML::Node& node, const std::string& file, const std::string& path, long& budget)
{
    if (--budget < 0) throw InputError(file, path, "document too large (more than 1000000 nodes, aliases counted)");
    if (node.IsSequence()) {
        std::size_t i = 0;
        for (const auto& item : node) rejectDuplicateKeys(item, file, path + "[" + std::to_string(i++) + "]", budget);
        return;
    }
    if (!node.IsMap()) return;
    std::vector<std::pair<std::string, int>> seen;
    for (const auto& entry : node) {
        const std::string key = keyText(entry.first);
        const int line = entry.first.Mark().is_null() ? 0 : entry.first.Mark().line + 1;
        if (entry.first.IsMap() || entry.first.IsSequence())
            throw InputError(file, path.empty() ? "(document)" : path, "a key must be a name, found " + key,
                             line > 0 ? std::optional<int>(line) : std::nullopt);
        const std::string childPath = path.empty() ? key : path + "." + key;
        for (const auto& [k, firstLine] : seen)
            if (k == key)
                throw InputError(file, childPath,
                                 "duplicate key '" + key + "'" +
                                     (firstLine > 0 ? " (first given at line " + std::to_string(firstLine) + ")" : ""),
                                 line > 0 ? std::optional<int>(line) : std::nullopt);
        seen.emplace_back(key, line);
        rejectDuplicateKeys(entry.second, file, childPath, budget);
    }
}

} // namespace

ConfigNode ConfigNode::loadFile(const std::filesystem::path& file)
{
    // Configuration files are small: a device node (/dev/zero), a FIFO or a
    // file past the limit is refused before a byte is read, so a wrong path
    // can never grow the reader without bound.
    constexpr std::uintmax_t kMaxBytes = 16u << 20;
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (ec || !std::filesystem::exists(status)) throw InputError(file.string(), "", "cannot open file");
    if (!std::filesystem::is_regular_file(status)) throw InputError(file.string(), "", "not a regular file");
    const auto size = std::filesystem::file_size(file, ec);
    if (!ec && size > kMaxBytes) throw InputError(file.string(), "", "file larger than 16 MiB");
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(file.string(), "", "cannot open file");
    std::string text;
    char chunk[65536];
    while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
        text.append(chunk, static_cast<std::size_t>(in.gcount()));
        if (text.size() > kMaxBytes) throw InputError(file.string(), "", "file larger than 16 MiB");
    }
    return parse(text, file.string());
}

ConfigNode ConfigNode::parse(const std::string& text, const std::string& name)
{
    auto fileName = std::make_shared<const std::string>(name);
    try {
        YAML::Node root = YAML::Load(text);
        rejectSecondDocument(text, name);
        if (!root || root.IsNull()) throw InputError(name, "", "file is empty");
        long budget = 1000000;
        rejectDuplicateKeys(root, name, "", budget);
        return ConfigNode(root, fileName, "");
    } catch (const YAML::Exception& e) {
        throw InputError(name, "", "YAML syntax error: " + e.msg,
                         e.mark.is_null() ? std::nullopt : std::optional<int>(e.mark.line + 1));
    }
}

ConfigNode::ConfigNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path))
{
}

int ConfigNode::line() const
{
    if (!node_) return 0;
    auto m = node_.Mark();
    return m.is_null() ? 0 : m.line + 1;
}

void ConfigNode::fail(const std::string& problem) const
{
    int l = line();
    throw InputError(*file_, path_.empty() ? std::string("(document)") : path_, problem,
                     l > 0 ? std::optional<int>(l) : std::nullopt);
}

bool ConfigNode::has(std::string_view key) const
{
    return node_.IsMap() && node_[std::string(key)] && !node_[std::string(key)].IsNull();
}

ConfigNode ConfigNode::operator[](std::string_view key) const
{
    if (!node_.IsMap()) fail("expected a map with key '" + std::string(key) + "', found " + describe(node_));
    auto child = node_[std::string(key)];
    std::string childPath = path_.empty() ? std::string(key) : path_ + "." + std::string(key);
    if (!child || child.IsNull()) fail("missing required key '" + std::string(key) + "'");
    return ConfigNode(child, file_, childPath);
}

std::optional<ConfigNode> ConfigNode::optional(std::string_view key) const
{
    if (!has(key)) {
        if (!isNull() && !node_.IsMap()) fail("expected a map, found " + describe(node_));
        return std::nullopt;
    }
    return (*this)[key];
}

std::vector<std::string> ConfigNode::keys() const
{
    if (!node_.IsMap()) fail("expected a map, found " + describe(node_));
    std::vector<std::string> out;
    for (auto it = node_.begin(); it != node_.end(); ++it) out.push_back(it->first.as<std::string>());
    return out;
}

std::vector<ConfigNode> ConfigNode::items() const
{
    if (!node_.IsSequence()) fail("expected a sequence, found " + describe(node_));
    std::vector<ConfigNode> out;
    std::size_t i = 0;
    for (auto it = node_.begin(); it != node_.end(); ++it, ++i)
        out.emplace_back(*it, file_, path_ + "[" + std::to_string(i) + "]");
    return out;
}

std::size_t ConfigNode::size() const
{
    if (!node_.IsSequence() && !node_.IsMap()) fail("expected a sequence or map, found " + describe(node_));
    return node_.size();
}

double ConfigNode::asDouble() const
{
    if (!node_.IsScalar()) fail("expected a number, found " + describe(node_));
    double v = 0;
    if (!YAML::convert<double>::decode(node_, v) || !std::isfinite(v))
        fail("expected a finite number, found " + describe(node_));
    return v;
}

double ConfigNode::asDoubleIn(double lo, double hi) const
{
    double v = asDouble();
    if (v < lo || v > hi)
        fail("value " + formatNumber(v) + " is outside [" + formatNumber(lo) + ", " + formatNumber(hi) + "]");
    return v;
}

double ConfigNode::asPositive() const
{
    double v = asDouble();
    if (!(v > 0)) fail("expected a positive number, found " + formatNumber(v));
    return v;
}

long long ConfigNode::asInt() const
{
    if (!node_.IsScalar()) fail("expected an integer, found " + describe(node_));
    long long v = 0;
    if (!YAML::convert<long long>::decode(node_, v)) fail("expected an integer, found " + describe(node_));
    return v;
}

long long ConfigNode::asIntIn(long long lo, long long hi) const
{
    long long v = asInt();
    if (v < lo || v > hi)
        fail("value " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
}

bool ConfigNode::asBool() const
{
    bool v = false;
    if (!node_.IsScalar() || !YAML::convert<bool>::decode(node_, v))
        fail("expected true or false, found " + describe(node_));
    return v;
}

std::string ConfigNode::asString() const
{
    if (!node_.IsScalar()) fail("expected a string, found " + describe(node_));
    return node_.Scalar();
}

std::vector<double> ConfigNode::asDoubles(std::size_t expectedSize) const
{
    auto what = expectedSize ? "a sequence of " + std::to_string(expectedSize) + " numbers"
                             : std::string("a sequence of numbers");
    if (!node_.IsSequence()) fail("expected " + what + ", found " + describe(node_));
    if ((expectedSize && node_.size() != expectedSize) || node_.size() == 0)
        fail("expected " + what + ", found " + std::to_string(node_.size()) + " elements");
    std::vector<double> out;
    for (const auto& item : items()) out.push_back(item.asDouble());
    return out;
}

Eigen::Vector2d ConfigNode::asVector2() const
{
    auto v = asDoubles(2);
    return {v[0], v[1]};
}

Eigen::Vector3d ConfigNode::asVector3() const
{
    auto v = asDoubles(3);
    return {v[0], v[1], v[2]};
}

Eigen::Matrix3d ConfigNode::asMatrix3() const
{
    if (!node_.IsSequence() || node_.size() != 3) fail("expected a 3x3 matrix (three rows of three numbers)");
    Eigen::Matrix3d m;
    auto rows = items();
    for (int r = 0; r < 3; ++r) {
        auto row = rows[r].asDoubles(3);
        for (int c = 0; c < 3; ++c) m(r, c) = row[c];
    }
    return m;
}

void ConfigNode::allowOnlyKeys(std::initializer_list<std::string_view> allowed) const
{
    for (const auto& key : keys()) {
        if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
        std::string list;
        for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        auto child = node_[key];
        ConfigNode(child, file_, path_.empty() ? key : path_ + "." + key)
            .fail("unknown key '" + key + "' (allowed here: " + list + ")");
    }
}

} // namespace hg
