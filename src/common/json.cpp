#include "hullgauge/common/json.h"

#include "hullgauge/common/error.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <optional>
#include <set>
#include <vector>

namespace hg {
namespace {

/// 1-based line of byte `offset` in `text`.
int lineAt(const std::string& text, std::size_t offset)
{
    offset = std::min(offset, text.size());
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(offset), '\n'));
}

/// Line of the `occurrence`-th (1-based) appearance of `"key"` followed by a
/// colon: where the parser met that key (the callback has no position).
std::optional<int> keyLine(const std::string& text, const std::string& key, int occurrence)
{
    const std::string quoted = nlohmann::json(key).dump();
    std::size_t at = 0;
    while ((at = text.find(quoted, at)) != std::string::npos) {
        std::size_t after = at + quoted.size();
        while (after < text.size() && std::isspace(static_cast<unsigned char>(text[after]))) ++after;
        const bool isKey = after < text.size() && text[after] == ':' && (at == 0 || text[at - 1] != '\\');
        if (isKey && --occurrence == 0) return lineAt(text, at);
        at += quoted.size();
    }
    return std::nullopt;
}

/// nlohmann's message without its "[json.exception.parse_error.101] " prefix.
std::string withoutId(const char* what)
{
    std::string s(what);
    auto close = s.find("] ");
    return s.rfind("[json.exception.", 0) == 0 && close != std::string::npos ? s.substr(close + 2) : s;
}

/// One open object or array while parsing: the keys seen in an object, the
/// index of the current element of an array.
struct Open {
    bool array = false;
    int index = -1;
    std::string key;
    std::set<std::string> keys;
};

/// "views[1].image": the path of the member being parsed.
std::string pathOf(const std::vector<Open>& open)
{
    std::string out;
    for (const auto& o : open) {
        if (o.array && o.index >= 0) out += "[" + std::to_string(o.index) + "]";
        if (!o.array && !o.key.empty()) out += (out.empty() ? "" : ".") + o.key;
    }
    return out;
}

} // namespace

nlohmann::json parseJson(const std::string& text, const std::string& name)
{
    constexpr int kMaxDepth = 64;
    std::vector<Open> open;
    std::map<std::string, int> keyCount; // occurrences of each key so far, to find its line
    // The DOM parser's callback sees each key as the parsed value of its key event.
    auto check = [&](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using E = nlohmann::json::parse_event_t;
        if (depth > kMaxDepth) throw InputError(name, pathOf(open), "nested deeper than 64 levels");
        const bool startsElement = event == E::value || event == E::object_start || event == E::array_start;
        if (startsElement && !open.empty() && open.back().array) ++open.back().index;
        switch (event) {
        case E::object_start:
            open.push_back({});
            break;
        case E::array_start:
            open.push_back({true, -1, {}, {}});
            break;
        case E::object_end:
        case E::array_end:
            if (!open.empty()) open.pop_back();
            break;
        case E::key: {
            const std::string key = parsed.get<std::string>();
            const int occurrence = ++keyCount[key];
            if (open.empty()) break;
            open.back().key = key;
            if (!open.back().keys.insert(key).second)
                throw InputError(name, pathOf(open), "duplicate key '" + key + "'", keyLine(text, key, occurrence));
            break;
        }
        default:
            break;
        }
        return true;
    };
    try {
        return nlohmann::json::parse(text, check);
    } catch (const nlohmann::json::parse_error& e) {
        // e.byte is 1-based: the character where the parser stopped.
        throw InputError(name, pathOf(open), "JSON " + withoutId(e.what()), lineAt(text, e.byte > 0 ? e.byte - 1 : 0));
    } catch (const nlohmann::json::out_of_range& e) {
        throw InputError(name, pathOf(open), withoutId(e.what()));
    }
}

std::string dumpJson(const nlohmann::json& value)
{
    return value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

} // namespace hg
