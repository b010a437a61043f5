#include "ply_check.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <spdlog/fmt/fmt.h>

#include "hullgauge/common/error.h"

namespace hg::model::detail {
namespace {

/// `text` as an error message can show it: bytes that are not printable ASCII as \xNN.
std::string printable(const std::string& text)
{
    std::string out;
    for (unsigned char c : text)
        out += c >= 0x20 && c < 0x7f ? std::string(1, static_cast<char>(c)) : fmt::format("\\x{:02x}", c);
    return out;
}

// PLY: CGAL's reader crashes or hangs instead of failing on four kinds of
// header: a `property` line before any `element` line (it files the property
// under the last element declared), a vertex coordinate x, y or z that is not a
// float or double (it reads the coordinate as one or the other), an element
// count that is negative (read as 2^64 - n) or beyond the file (an element
// without properties is then read for ever), and a header without
// `end_header`. The header is read first so such a file is named at its line.
// Every item of an element takes at least a byte, so a count above the file's
// size cannot be right. False when the file is no PLY file (its first word is
// not `ply`): the reader refuses it itself, and nothing of it is checked here.
bool checkPlyHeader(const std::filesystem::path& file, std::uintmax_t size)
{
    std::ifstream in(file, std::ios::binary);
    std::string line;
    std::optional<std::string> element;
    int number = 1;
    // Lines 1 and 2 are the signature and the format, which the reader checks itself.
    for (; std::getline(in, line); ++number) {
        std::istringstream words(line);
        std::string keyword, type, name;
        words >> keyword >> type >> name;
        if (number == 1 && keyword != "ply") return false; // not a PLY file: the reader says so
        if (number <= 2) continue;
        if (keyword == "end_header") return true;
        if (keyword == "element") {
            element = type;
            std::uintmax_t count = 0;
            const auto [end, error] = std::from_chars(name.data(), name.data() + name.size(), count);
            if (end == name.data() || error != std::errc() || count > size)
                throw InputError(file.string(), "header",
                                 fmt::format("element '{}': count '{}' is not a whole number of at most {} (the "
                                             "file's size in bytes)",
                                             printable(type), printable(name), size),
                                 number);
        }
        if (keyword != "property") continue;
        if (!element)
            throw InputError(file.string(), "header",
                             "'property' before any 'element' (a property belongs to the element declared above it)",
                             number);
        // `property list COUNT_TYPE ITEM_TYPE NAME`: the name is the fifth word, and a list is no coordinate.
        const bool list = type == "list";
        if (list) words >> type >> name;
        const bool coordinate = name == "x" || name == "y" || name == "z";
        const bool real = !list && (type == "float" || type == "float32" || type == "double" || type == "float64");
        if ((*element == "vertex" || *element == "vertices") && coordinate && !real)
            throw InputError(file.string(), "header",
                             fmt::format("vertex coordinate '{}' is {}{} (a coordinate is a float or a double)",
                                         printable(name), list ? "a list of " : "", printable(type)),
                             number);
    }
    // CGAL's reader takes a header that runs to the file's end as complete and
    // then reads the body from nothing: its list counts are never read, and it
    // sizes the lists with them (docs/fuzzing.md).
    throw InputError(file.string(), "header", "no 'end_header' line: the header runs to the end of the file",
                     number - 1);
}

/// A PLY scalar type as CGAL's reader takes it: its bytes in a binary file
/// (0: a name PLY does not have) and, in an ASCII file, the range of the
/// number it reads the value into — its char types through a short.
struct PlyType {
    std::string name;
    int bytes = 0;
    bool integer = false;
    long long min = 0;
    long long max = 0;
};

PlyType plyType(const std::string& name)
{
    constexpr long long s16 = 32767, u16 = 65535, s32 = 2147483647, u32 = 4294967295;
    static const std::map<std::string, PlyType> types{
        {"char", {"char", 1, true, -s16 - 1, s16}},   {"int8", {"int8", 1, true, -s16 - 1, s16}},
        {"uchar", {"uchar", 1, true, 0, u16}},        {"uint8", {"uint8", 1, true, 0, u16}},
        {"short", {"short", 2, true, -s16 - 1, s16}}, {"int16", {"int16", 2, true, -s16 - 1, s16}},
        {"ushort", {"ushort", 2, true, 0, u16}},      {"uint16", {"uint16", 2, true, 0, u16}},
        {"int", {"int", 4, true, -s32 - 1, s32}},     {"int32", {"int32", 4, true, -s32 - 1, s32}},
        {"uint", {"uint", 4, true, 0, u32}},          {"uint32", {"uint32", 4, true, 0, u32}},
        {"float", {"float", 4, false, 0, 0}},         {"float32", {"float32", 4, false, 0, 0}},
        {"double", {"double", 8, false, 0, 0}},       {"float64", {"float64", 8, false, 0, 0}}};
    const auto it = types.find(name);
    return it == types.end() ? PlyType{} : it->second;
}

struct PlyProperty {
    std::string name;
    PlyType count; ///< a list's; bytes 0 for a scalar
    PlyType item;
};

struct PlyElement {
    std::string name;
    std::uintmax_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyLayout {
    std::string format;
    std::vector<PlyElement> elements;
};

/// The header's format and elements as CGAL's reader takes them; the stream
/// is left at the body. Nothing when the header declares no element.
std::optional<PlyLayout> readPlyLayout(std::istream& in)
{
    PlyLayout layout;
    std::string line;
    // As CGAL's reader: the format on the second line only, any other `format` line ignored.
    for (int number = 1; std::getline(in, line); ++number) {
        std::istringstream words(line);
        std::string keyword, a, b, c, d;
        words >> keyword >> a >> b >> c >> d;
        if (number == 2) layout.format = a;
        if (number <= 2) continue;
        if (keyword == "end_header") return layout.elements.empty() ? std::nullopt : std::optional(layout);
        if (keyword == "element") {
            PlyElement e{a, 0, {}};
            const auto [end, error] = std::from_chars(b.data(), b.data() + b.size(), e.count);
            if (end == b.data() || error != std::errc()) return std::nullopt;
            layout.elements.push_back(std::move(e));
        }
        if (keyword != "property" || layout.elements.empty()) continue;
        PlyProperty p;
        p.name = a == "list" ? d : b;
        p.item = plyType(a == "list" ? c : a);
        if (a == "list") p.count = plyType(b);
        // A type PLY does not have: CGAL's reader leaves the property out of the element, and so does the walk.
        if (p.item.bytes == 0 || (a == "list" && p.count.bytes == 0)) continue;
        layout.elements.back().properties.push_back(std::move(p));
    }
    return std::nullopt;
}

/// `token` as CGAL's reader reads an ASCII value of `type`: the whole token a
/// number within the range it reads into, a finite one for a real. Nothing
/// where the reader would stop inside the token, fail on it or wrap it.
std::optional<double> asciiNumber(const std::string& token, const PlyType& type)
{
    const char* begin = token.data() + (token.size() > 1 && token[0] == '+' ? 1 : 0); // as `>>` reads it
    const char* end = token.data() + token.size();
    if (type.integer) {
        long long value = 0;
        const auto [stop, error] = std::from_chars(begin, end, value);
        if (error != std::errc() || stop != end || value < type.min || value > type.max) return std::nullopt;
        return static_cast<double>(value);
    }
    double value = 0.0;
    const auto [stop, error] = std::from_chars(begin, end, value);
    if (error != std::errc() || stop != end || !std::isfinite(value)) return std::nullopt;
    return value;
}

// The body walked as CGAL's reader will read it, item by item. The reader
// sizes each list by the count the file gives before reading its items, and
// once its stream has failed (a file that ends early, an ASCII value it stops
// inside or cannot hold) every later count is a number it never read: a
// count of 543 million in a file of 600 bytes allocated 2.2 GB, a negative
// one threw std::length_error, an unread one ran out of memory or time
// (docs/fuzzing.md, "Findings, fixed"). So every item must be there, every
// ASCII value a whole number of its type, and every list must fit in what is
// left of the file (a byte per item in ASCII, the item's size in binary).
class PlyWalk {
  public:
    PlyWalk(const std::filesystem::path& file, std::uintmax_t size, std::istream& in, const std::string& format)
        : file_(file.string()), size_(size), in_(in), ascii_(format == "ascii"),
          bigEndian_(format == "binary_big_endian")
    {
    }

    void walk(const PlyElement& e)
    {
        if (e.properties.empty()) return; // its items take no byte and no token
        const bool lists = std::any_of(e.properties.begin(), e.properties.end(),
                                       [](const PlyProperty& p) { return p.count.bytes > 0; });
        if (!ascii_ && !lists) return skipFixed(e);
        for (std::uintmax_t item = 1; item <= e.count; ++item)
            for (const PlyProperty& p : e.properties) {
                if (p.count.bytes == 0) {
                    value(e, item, p);
                    continue;
                }
                const long long n = listCount(e, item, p);
                for (long long k = 0; ascii_ && k < n; ++k) value(e, item, p);
                if (!ascii_) skip(e, item, p, static_cast<std::uintmax_t>(n) * p.item.bytes);
            }
    }

  private:
    [[noreturn]] void fail(const PlyElement& e, std::uintmax_t item, const std::string& problem) const
    {
        throw InputError(file_, fmt::format("{} {}", printable(e.name), item), problem);
    }

    [[noreturn]] void ends(const PlyElement& e, std::uintmax_t item, const PlyProperty& p) const
    {
        fail(e, item,
             fmt::format("the file ends at property '{}' (the header announces {} of element '{}')", printable(p.name),
                         e.count, printable(e.name)));
    }

    std::uintmax_t left() const
    {
        const std::streamoff at = in_.tellg();
        return at < 0 ? 0 : size_ - std::min<std::uintmax_t>(size_, static_cast<std::uintmax_t>(at));
    }

    void skip(const PlyElement& e, std::uintmax_t item, const PlyProperty& p, std::uintmax_t bytes)
    {
        if (bytes > left()) ends(e, item, p);
        in_.seekg(static_cast<std::streamoff>(bytes), std::ios::cur);
    }

    // An element of fixed-size items in a binary file: all of them must be there.
    void skipFixed(const PlyElement& e)
    {
        std::uintmax_t stride = 0;
        for (const PlyProperty& p : e.properties) stride += static_cast<std::uintmax_t>(p.item.bytes);
        if (stride == 0) return;
        const std::uintmax_t room = left(), whole = room / stride;
        if (e.count > whole) {
            // The property the file ends in: the one whose bytes are not all there.
            std::uintmax_t rest = room - whole * stride;
            auto p = e.properties.begin();
            for (; rest >= static_cast<std::uintmax_t>(p->item.bytes); ++p) rest -= p->item.bytes;
            ends(e, whole + 1, *p);
        }
        in_.seekg(static_cast<std::streamoff>(e.count * stride), std::ios::cur);
    }

    void value(const PlyElement& e, std::uintmax_t item, const PlyProperty& p)
    {
        if (!ascii_) return skip(e, item, p, static_cast<std::uintmax_t>(p.item.bytes));
        std::string token;
        if (!(in_ >> token)) ends(e, item, p);
        if (!asciiNumber(token, p.item))
            fail(e, item,
                 fmt::format("property '{}': '{}' is not a number of type {}", printable(p.name), printable(token),
                             p.item.name));
    }

    long long listCount(const PlyElement& e, std::uintmax_t item, const PlyProperty& p)
    {
        const auto missing = [&](const std::string& why) {
            fail(e, item, fmt::format("list '{}': no count where one is due ({})", printable(p.name), why));
        };
        long long count = 0;
        if (ascii_) {
            std::string token;
            if (!(in_ >> token)) missing("the file ends");
            // A count of a char type is read through a short and then cut to its
            // byte (300 as a uchar would be 44): only the byte's own range keeps
            // the reader's items and the walk's the same.
            const auto v = asciiNumber(token, p.count);
            const long long low = p.count.min < 0 ? -128 : 0, high = p.count.min < 0 ? 127 : 255;
            if (!v || (p.count.bytes == 1 && (*v < low || *v > high)))
                missing(fmt::format("'{}' is not a whole number of type {}", printable(token), p.count.name));
            count = static_cast<long long>(*v);
        } else {
            const auto v = binaryCount(p);
            if (!v) missing("the file ends");
            count = *v;
        }
        const std::uintmax_t room = left() / (ascii_ ? 1 : static_cast<std::uintmax_t>(p.item.bytes));
        if (count < 0 || static_cast<std::uintmax_t>(count) > room)
            fail(e, item,
                 fmt::format("list '{}' holds {} items: {}", printable(p.name), count,
                             count < 0 ? std::string("a negative number")
                                       : fmt::format("more than fit in the {} bytes left of the file", left())));
        return count;
    }

    /// A binary list count of `p.count`'s type, signed where the type is; nothing at the file's end.
    std::optional<long long> binaryCount(const PlyProperty& p)
    {
        unsigned char raw[4] = {};
        if (!in_.read(reinterpret_cast<char*>(raw), p.count.bytes)) return std::nullopt;
        unsigned long long value = 0;
        for (int i = 0; i < p.count.bytes; ++i) value = (value << 8) | raw[bigEndian_ ? i : p.count.bytes - 1 - i];
        const unsigned long long sign = 1ull << (8 * p.count.bytes - 1);
        if (p.count.min < 0 && (value & sign)) return static_cast<long long>(value) - static_cast<long long>(sign << 1);
        return static_cast<long long>(value);
    }

    std::string file_;
    std::uintmax_t size_;
    std::istream& in_;
    bool ascii_;
    bool bigEndian_;
};

} // namespace

void checkPly(const std::filesystem::path& file, std::uintmax_t size)
{
    // A file that is no PLY is not walked: its lines say nothing of its body
    // (a fuzzed first line, then an element of 33 billion empty items, kept the walk busy).
    if (!checkPlyHeader(file, size)) return;
    std::ifstream in(file, std::ios::binary);
    const std::optional<PlyLayout> layout = readPlyLayout(in);
    if (!layout) return;
    PlyWalk walk(file, size, in, layout->format);
    for (const PlyElement& e : layout->elements) walk.walk(e);
}

std::optional<std::uintmax_t> plyAnnouncedFaces(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::string first;
    if (!std::getline(in, first) || first.rfind("ply", 0) != 0) return std::nullopt;
    in.seekg(0);
    const std::optional<PlyLayout> layout = readPlyLayout(in);
    if (!layout) return std::nullopt;
    for (const PlyElement& e : layout->elements)
        if (e.name == "face" || e.name == "faces") return e.count;
    return std::nullopt;
}

} // namespace hg::model::detail
