#include "hmi/access.h"

#include "hmi/http_util.h"
#include "hullgauge/store/result_reader.h"

#include <algorithm>
#include <limits>
#include <sys/stat.h>

namespace hg::daemon {

namespace fs = std::filesystem;
using json = nlohmann::json;
using store::Permission;
using store::Role;

namespace {

/// The name a sign-in gives: an account's, or with the shared password any printable one ("engineer" by default).
std::string signInName(const json& body)
{
    if (!body.contains("name")) return "engineer";
    if (!body["name"].is_string()) throw HttpError(400, "name: not a string");
    const auto name = body["name"].get<std::string>();
    if (name.empty() || name.size() > 64 || !std::all_of(name.begin(), name.end(), [](char c) {
            return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f;
        }))
        throw HttpError(400, "name: 1 to 64 printable characters");
    return name;
}

std::string textOf(const json& body, const char* key)
{
    if (!body.contains(key)) throw HttpError(400, std::string(key) + ": missing");
    if (!body[key].is_string()) throw HttpError(400, std::string(key) + ": not a string");
    return body[key].get<std::string>();
}

Role roleOf(const json& body)
{
    const auto text = textOf(body, "role");
    const auto role = parseEnum<Role>(text);
    if (!role) throw HttpError(400, "role: '" + text + "' is not " + enumNameList<Role>(", ", " or "));
    return *role;
}

json permissionsOf(Role role)
{
    json may = json::object();
    for (const auto& [permission, name] : nameTable(Permission{}))
        may[std::string(name)] = store::allows(role, permission);
    return may;
}

/// "operator 'olga' may not change part programs: that needs an engineer or administrator".
std::string refusal(const Actor& actor, Permission permission)
{
    return std::string(enumName(actor.role)) + " '" + actor.name + "' may not " +
           std::string(store::describe(permission)) + ": that needs " + store::whoMay(permission);
}

} // namespace

Access::Access(ConfigSource config, std::shared_ptr<store::AuditLog> audit, Clock& clock)
    : config_(std::move(config)), audit_(std::move(audit)), clock_(clock),
      sessions_(config_()->http.sessionIdle, clock),
      // Guessing a password: five tries at once, then one every 12 s per address.
      signIns_(1.0 / 12.0, 5.0, clock)
{
}

std::vector<store::Account> Access::accounts()
{
    const fs::path file = station::usersFile(*config_());
    struct stat st {};
    FileKey key;
    key.path = file.string();
    if (::stat(file.c_str(), &st) == 0)
        key = {st.st_dev, st.st_ino, st.st_size, st.st_mtim.tv_sec * 1'000'000'000LL + st.st_mtim.tv_nsec,
               file.string()};
    std::lock_guard lock(accountsMutex_);
    if (key == accountsKey_) return accounts_;
    try {
        accounts_ = store::AccountsFile(file).accounts();
    } catch (const InputError& e) {
        // A broken accounts file lets nobody in by an account; the journal and the answer say why.
        hg::log::category("hmi")->error("accounts: {}", e.what());
        throw HttpError(500, std::string("accounts: ") + e.what());
    }
    accountsKey_ = key;
    return accounts_;
}

std::pair<Actor, Sessions::Session> Access::current(const httplib::Request& req)
{
    const auto id = sessionCookie(req);
    const auto session = sessions_.touch(id);
    if (!session) throw HttpError(401, "sign in first");
    Actor actor{session->name, session->role, "hmi " + req.remote_addr, session->shared};
    if (session->shared) return {actor, *session};
    const auto list = accounts();
    const auto it = std::find_if(list.begin(), list.end(), [&](const auto& a) { return a.name == session->name; });
    if (it == list.end()) {
        sessions_.close(id);
        throw HttpError(401, "account '" + session->name + "' no longer exists: sign in again");
    }
    actor.role = it->role;
    return {actor, *session};
}

Actor Access::reader(const httplib::Request& req, Permission permission)
{
    auto actor = current(req).first;
    requireRight(actor, permission, "read " + req.path, {});
    return actor;
}

void Access::requireRight(const Actor& actor, Permission permission, const std::string& action,
                          const std::string& object)
{
    if (store::allows(actor.role, permission)) return;
    const auto why = refusal(actor, permission);
    record(actor, action, object, "refused", why);
    hg::log::category("hmi")->warn("refused {} on '{}' from {}: {}", action, object, actor.source, why);
    throw HttpError(403, why);
}

Actor Access::authorize(const httplib::Request& req, Permission permission, const std::string& action,
                        const std::string& object)
{
    auto [actor, session] = current(req);
    if (!req.has_header("X-CSRF-Token")) throw HttpError(403, "CSRF token missing (header X-CSRF-Token)");
    if (req.get_header_value("X-CSRF-Token") != session.csrf)
        throw HttpError(403, "CSRF token does not match the session's (sign in again)");
    requireRight(actor, permission, action, object);
    return actor;
}

void Access::record(const Actor& by, const std::string& action, const std::string& object, const std::string& outcome,
                    const std::string& detail, const std::string& before, const std::string& after)
{
    store::AuditEntry entry{0,         clock_.wallMs(), by.name, std::string(enumName(by.role)),
                            by.source, action,          object,  outcome,
                            detail,    before,          after};
    if (by.shared)
        entry.detail =
            entry.detail.empty() ? "shared maintenance password" : entry.detail + " (shared maintenance password)";
    try {
        audit_->record(std::move(entry));
    } catch (const std::exception& e) {
        hg::log::category("hmi")->error("audit trail: {} ({} {} by {} not recorded)", e.what(), action, object,
                                        by.name);
    }
}

void Access::route(httplib::Server& server)
{
    routeSession(server);
    routeAccounts(server);
    routeAudit(server);
}

// Sign-in (docs/audit.md, "Roles"): an account's own password, else the shared maintenance password as an
// engineer under the name given; every sign-in, and every refused one, is in the audit trail.
void Access::routeSession(httplib::Server& server)
{
    server.Post(
        "/api/login", api([this](const httplib::Request& req, httplib::Response& res) {
            const auto list = accounts();
            const auto& shared = config_()->http.passwordHash;
            if (list.empty() && shared.empty())
                throw HttpError(403, "no accounts and no maintenance password are configured (add an "
                                     "account with `hullgauge users add`)");
            if (!signIns_.allow(req.remote_addr)) throw HttpError(429, "too many sign-in attempts");
            const auto body = json::parse(req.body, nullptr, false);
            if (!body.is_object() || !body.contains("password") || !body["password"].is_string())
                throw HttpError(400, "expected {\"name\": \"...\", \"password\": \"...\"}");
            const auto name = signInName(body);
            const auto password = body["password"].get<std::string>();
            const auto it = std::find_if(list.begin(), list.end(), [&](const auto& a) { return a.name == name; });
            Actor actor{name, it != list.end() ? it->role : Role::Engineer, "hmi " + req.remote_addr, it == list.end()};
            // An account's name is signed in with its own password only, never the shared one.
            const bool ok = it != list.end() ? verifyPassword(password, it->passwordHash)
                                             : !shared.empty() && verifyPassword(password, shared);
            if (!ok) {
                record({name, Role::Operator, actor.source}, "sign-in", name, "refused",
                       it != list.end() ? "wrong password" : "no such account and not the shared password");
                throw HttpError(401, "wrong password");
            }
            const auto session = sessions_.open(name, actor.role, actor.shared);
            res.set_header("Set-Cookie", "hg_session=" + session.id + "; Path=/; HttpOnly; SameSite=Strict");
            hg::log::category("hmi")->info("sign-in from {} as '{}' ({})", req.remote_addr, name, enumName(actor.role));
            record(actor, "sign-in", name, "done");
            sendJson(res, {{"csrf", session.csrf}, {"role", enumName(actor.role)}});
        }));
    server.Post("/api/logout", api([this](const httplib::Request& req, httplib::Response& res) {
                    sessions_.close(sessionCookie(req));
                    res.set_header("Set-Cookie", "hg_session=; Path=/; HttpOnly; SameSite=Strict; Max-Age=0");
                    sendJson(res, {{"ok", true}});
                }));
    server.Get("/api/session", api([this](const httplib::Request& req, httplib::Response& res) {
                   json body{{"signed_in", false},
                             {"configured", !config_()->http.passwordHash.empty() || !accounts().empty()}};
                   try {
                       const auto [actor, session] = current(req);
                       body.update({{"signed_in", true},
                                    {"csrf", session.csrf},
                                    {"name", actor.name},
                                    {"role", enumName(actor.role)},
                                    {"shared", actor.shared},
                                    {"may", permissionsOf(actor.role)}});
                   } catch (const HttpError&) {
                       // Not signed in (or the account went): the page offers the sign-in.
                   }
                   sendJson(res, body);
               }));
}

// The administrator's accounts (docs/audit.md, "Accounts"); each change in the audit trail, a password never.
void Access::routeAccounts(httplib::Server& server)
{
    server.Get("/api/users", api([this](const httplib::Request& req, httplib::Response& res) {
                   (void)reader(req, Permission::Users);
                   json users = json::array();
                   for (const auto& a : accounts()) users.push_back({{"name", a.name}, {"role", enumName(a.role)}});
                   sendJson(res, {{"users", users}, {"file", station::usersFile(*config_()).string()}});
               }));
    server.Post("/api/users", api([this](const httplib::Request& req, httplib::Response& res) {
                    // The right is checked before the body is judged: a refusal is a 403 whatever was sent,
                    // recorded with the name asked for when there is one.
                    const auto sent = json::parse(req.body, nullptr, false);
                    const auto asked = sent.is_object() && sent.contains("name") && sent["name"].is_string()
                                           ? sent["name"].get<std::string>()
                                           : std::string();
                    const auto actor = authorize(req, Permission::Users, "user.add", asked);
                    const auto body = jsonBody(req, "{\"name\": ..., \"role\": ..., \"password\": ...}");
                    const auto name = textOf(body, "name");
                    const store::Account account{name, roleOf(body), store::hashPassword(textOf(body, "password"))};
                    store::AccountsFile(station::usersFile(*config_())).add(account);
                    record(actor, "user.add", name, "done", {}, {}, "role: " + std::string(enumName(account.role)));
                    sendJson(res, {{"name", name}, {"role", enumName(account.role)}}, 201);
                }));
    server.Post(R"(/api/users/([A-Za-z0-9][A-Za-z0-9._-]{0,31}))",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto name = req.matches[1].str();
                    const auto actor = authorize(req, Permission::Users, "user.change", name);
                    const auto body = jsonBody(req, "{\"role\": ...} or {\"password\": ...}");
                    const store::AccountsFile file(station::usersFile(*config_()));
                    const auto before = file.find(name);
                    if (!before) throw HttpError(404, "no account '" + name + "'");
                    if (body.contains("role")) {
                        const auto role = roleOf(body);
                        file.setRole(name, role);
                        record(actor, "user.role", name, "done", {}, "role: " + std::string(enumName(before->role)),
                               "role: " + std::string(enumName(role)));
                    }
                    if (body.contains("password")) {
                        file.setPasswordHash(name, store::hashPassword(textOf(body, "password")));
                        record(actor, "user.password", name, "done", "password set by an administrator");
                    }
                    sendJson(res, {{"ok", true}});
                }));
    server.Post(R"(/api/users/([A-Za-z0-9][A-Za-z0-9._-]{0,31})/remove)",
                api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto name = req.matches[1].str();
                    const auto actor = authorize(req, Permission::Users, "user.remove", name);
                    const store::AccountsFile file(station::usersFile(*config_()));
                    const auto before = file.find(name);
                    if (!before) throw HttpError(404, "no account '" + name + "'");
                    file.remove(name);
                    record(actor, "user.remove", name, "done", {}, "role: " + std::string(enumName(before->role)));
                    sendJson(res, {{"ok", true}});
                }));
    // Everyone with an account changes their own password, knowing the current one.
    server.Post("/api/account/password", api([this](const httplib::Request& req, httplib::Response& res) {
                    const auto body = jsonBody(req, "{\"current\": ..., \"password\": ...}");
                    const auto actor = authorize(req, Permission::Read, "user.password");
                    if (actor.shared)
                        throw HttpError(403, "signed in with the shared maintenance password: no account");
                    const store::AccountsFile file(station::usersFile(*config_()));
                    const auto account = file.find(actor.name);
                    if (!account || !verifyPassword(textOf(body, "current"), account->passwordHash)) {
                        record(actor, "user.password", actor.name, "refused", "current password wrong");
                        throw HttpError(403, "current password wrong");
                    }
                    file.setPasswordHash(actor.name, store::hashPassword(textOf(body, "password")));
                    record(actor, "user.password", actor.name, "done", "own password changed");
                    sendJson(res, {{"ok", true}});
                }));
}

// The audit trail (docs/audit.md, "Reading and export"): every signed-in account reads it; JSON or CSV.
void Access::routeAudit(httplib::Server& server)
{
    server.Get(
        "/api/audit", api([this](const httplib::Request& req, httplib::Response& res) {
            (void)reader(req, Permission::Read);
            store::AuditQuery q;
            if (req.has_param("since")) q.sinceMs = store::parseUtc(req.get_param_value("since"), "since");
            if (req.has_param("until")) q.untilMs = store::parseUtc(req.get_param_value("until"), "until");
            q.who = req.get_param_value("who");
            q.actionPrefix = req.get_param_value("action");
            q.outcome = oneOf(req, "outcome", {"", "done", "refused", "failed"}, "");
            q.beforeId = intParam(req, "before", 1, std::numeric_limits<std::int64_t>::max());
            const auto format = oneOf(req, "format", {"json", "csv"}, "json");
            q.limit = static_cast<int>(
                intParam(req, "limit", 1, format == "csv" ? 100000 : 1000).value_or(format == "csv" ? 100000 : 200));
            const auto entries = audit_->select(q);
            if (format == "csv") {
                res.set_header("Content-Disposition", "attachment; filename=\"audit.csv\"");
                res.set_header("Cache-Control", "no-store");
                res.set_content(store::auditCsv(entries), "text/csv; charset=utf-8");
                return;
            }
            json rows = json::array();
            for (const auto& e : entries) rows.push_back(store::toJson(e));
            json body{{"entries", rows}};
            if (q.limit > 0 && static_cast<int>(entries.size()) == q.limit) body["next_before"] = entries.back().id;
            sendJson(res, body);
        }));
}

} // namespace hg::daemon
