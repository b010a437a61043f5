// The web HMI's answers (docs/hmi.md, "JSON API"): every answer JSON with
// `Cache-Control: no-store`, every refusal `{"error": "what was wrong"}` with
// its 4xx (the files: hmi/static_files.h). Shared by the routes of
// hmi_server.cpp and parts_routes.cpp.
#pragma once

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <cstdint>
#include <filesystem>
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hg::daemon {

/// A request the API refuses: its HTTP status and what was wrong.
struct HttpError : std::runtime_error {
    int status;
    HttpError(int s, const std::string& what) : std::runtime_error(what), status(s) {}
};

inline constexpr const char* kJson = "application/json";

void sendJson(httplib::Response& res, const nlohmann::json& body, int status = 200);
void sendError(httplib::Response& res, int status, const std::string& message);
/// The media type of a page, script, style, image or mesh, by its extension.
const char* contentType(const std::filesystem::path& file);
std::optional<std::string> readFile(const std::filesystem::path& file);

/// Runs `handler`, turning a refused request into its 4xx (an InputError is
/// 400) and any other failure into 500 (logged).
template <class Handler> httplib::Server::Handler api(Handler handler)
{
    return [handler](const httplib::Request& req, httplib::Response& res) {
        try {
            handler(req, res);
        } catch (const HttpError& e) {
            sendError(res, e.status, e.what());
        } catch (const InputError& e) {
            sendError(res, 400, e.what());
        } catch (const std::exception& e) {
            hg::log::category("hmi")->error("{} {}: {}", req.method, req.path, e.what());
            sendError(res, 500, e.what());
        }
    };
}

/// A query parameter as a whole number in [lo, hi]; nothing when absent.
std::optional<std::int64_t> intParam(const httplib::Request& req, const char* name, std::int64_t lo, std::int64_t hi);
/// A query parameter that must be one of `allowed`; `fallback` when absent.
std::string oneOf(const httplib::Request& req, const char* name, const std::vector<std::string>& allowed,
                  const std::string& fallback);
/// A POST's body as a JSON object (400 naming what was expected otherwise).
nlohmann::json jsonBody(const httplib::Request& req, const char* expected);
/// The client's own session: the cookie `hg_session`.
std::string sessionCookie(const httplib::Request& req);

} // namespace hg::daemon
