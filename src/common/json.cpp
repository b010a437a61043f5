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

std::string joinPath(const std::vector<std::string>& path)
{
    std::string out;
    for (const auto& p : path) out += (out.empty() ? "" : ".") + p;
    return out;
}

} // namespace

nlohmann::json parseJson(const std::string& text, const std::string& name)
{
    constexpr int kMaxDepth = 64;
    std::vector<std::set<std::string>> objects; // keys seen in each open object
    std::vector<std::string> path;              // key of each open object's current member
    std::map<std::string, int> keyCount;        // occurrences of each key so far, to find its line
    // The DOM parser's callback sees each key as the parsed value of its key event.
    auto check = [&](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using E = nlohmann::json::parse_event_t;
        if (depth > kMaxDepth) throw InputError(name, joinPath(path), "nested deeper than 64 levels");
        switch (event) {
        case E::object_start:
            objects.emplace_back();
            path.emplace_back();
            break;
        case E::object_end:
            if (!objects.empty()) objects.pop_back();
            if (!path.empty()) path.pop_back();
            break;
        case E::key: {
            const std::string key = parsed.get<std::string>();
            const int occurrence = ++keyCount[key];
            if (!path.empty()) path.back() = key;
            if (!objects.empty() && !objects.back().insert(key).second)
                throw InputError(name, joinPath(path), "duplicate key '" + key + "'", keyLine(text, key, occurrence));
            break;
        }
        default: break;
        }
        return true;
    };
    try {
        return nlohmann::json::parse(text, check);
    } catch (const nlohmann::json::parse_error& e) {
        // e.byte is 1-based: the character where the parser stopped.
        throw InputError(name, joinPath(path), "JSON " + withoutId(e.what()),
                         lineAt(text, e.byte > 0 ? e.byte - 1 : 0));
    } catch (const nlohmann::json::out_of_range& e) {
        throw InputError(name, joinPath(path), withoutId(e.what()));
    }
}

} // namespace hg
