#include "hmi/http_util.h"

#include "hullgauge/common/json.h"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <regex>
#include <sstream>

namespace hg::daemon {

namespace fs = std::filesystem;
using nlohmann::json;

void sendJson(httplib::Response& res, const json& body, int status)
{
    res.status = status;
    res.set_header("Cache-Control", "no-store");
    res.set_content(dumpJson(body), kJson);
}

void sendError(httplib::Response& res, int status, const std::string& message)
{
    sendJson(res, {{"error", message}}, status);
}

std::optional<std::string> readFile(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    if (!in) return std::nullopt;
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
}

const char* contentType(const fs::path& file)
{
    const auto ext = file.extension().string();
    if (ext == ".html") return "text/html; charset=utf-8";
    if (ext == ".js") return "text/javascript; charset=utf-8";
    if (ext == ".css") return "text/css; charset=utf-8";
    if (ext == ".svg") return "image/svg+xml";
    if (ext == ".png") return "image/png";
    if (ext == ".stl") return "model/stl";
    return "application/octet-stream";
}

std::optional<std::int64_t> intParam(const httplib::Request& req, const char* name, std::int64_t lo, std::int64_t hi)
{
    if (!req.has_param(name)) return std::nullopt;
    const auto text = req.get_param_value(name);
    std::int64_t value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi)
        throw HttpError(400, std::string(name) + ": '" + text + "' is not a whole number in " + std::to_string(lo) +
                                 ".." + std::to_string(hi));
    return value;
}

std::string oneOf(const httplib::Request& req, const char* name, const std::vector<std::string>& allowed,
                  const std::string& fallback)
{
    if (!req.has_param(name)) return fallback;
    auto value = req.get_param_value(name);
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        throw HttpError(400, std::string(name) + ": '" + value + "' is not one of " + list);
    }
    return value;
}

json jsonBody(const httplib::Request& req, const char* expected)
{
    auto body = json::parse(req.body, nullptr, false);
    if (!body.is_object()) throw HttpError(400, std::string("expected ") + expected);
    return body;
}

std::string sessionCookie(const httplib::Request& req)
{
    const auto cookies = req.get_header_value("Cookie");
    static const std::regex kSession(R"((?:^|;\s*)hg_session=([0-9a-f]{64})(?:;|$))");
    std::smatch m;
    return std::regex_search(cookies, m, kSession) ? m[1].str() : std::string();
}

} // namespace hg::daemon
