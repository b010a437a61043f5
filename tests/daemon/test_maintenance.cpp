// The maintenance socket's answer to a request line (answerMaintenanceRequest):
// malformed requests are answered as errors, never fail the daemon; who asked
// is the socket's peer, never what the request says (docs/audit.md).
#include "maintenance.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace hg::daemon {
namespace {

using nlohmann::json;

json echoCommand(const json& request)
{
    return {{"ok", false}, {"error", "unknown command '" + request.at("command").get<std::string>() + "'"}};
}

json answerTo(const std::string& request)
{
    const std::string line = answerMaintenanceRequest(request, echoCommand);
    EXPECT_EQ(line.back(), '\n');
    return json::parse(line); // throws, failing the test, unless the line is JSON
}

TEST(MaintenanceRequest, TheCommandTableAnswersAnObjectWithACommand)
{
    const json answer = answerTo("{\"command\": \"nope\"}\n");
    EXPECT_EQ(answer["error"], "unknown command 'nope'");
}

TEST(MaintenanceRequest, ALineThatIsNotAnObjectWithACommandIsAnErrorNamingIt)
{
    EXPECT_NE(answerTo("[1, 2]\n")["error"].get<std::string>().find("command"), std::string::npos);
    EXPECT_NE(answerTo("{\"command\": 1}\n")["error"].get<std::string>().find("type must be string"),
              std::string::npos);
    EXPECT_NE(answerTo(std::string(100, 'x'))["error"].get<std::string>().find("without a newline"), std::string::npos);
}

// Found by the maintenance harness (docs/fuzzing.md): a syntax error quoting
// bytes that are not UTF-8 made the answer's dump throw, which ended the daemon.
TEST(MaintenanceRequest, BytesThatAreNotUtf8InAnErrorComeBackAsReplacementCharacters)
{
    const std::string request = "{\"command\":" + std::string(40, '\xd2') + " \"\"suttas}\n";
    const json answer = answerTo(request);
    EXPECT_EQ(answer["ok"], false);
    const std::string error = answer["error"];
    EXPECT_NE(error.find("request"), std::string::npos) << error;
    EXPECT_NE(error.find("\xEF\xBF\xBD"), std::string::npos) << error; // U+FFFD
}

/// The request as the command table receives it.
json handedOn(const std::string& request, const std::string& peer)
{
    json seen;
    const auto line = answerMaintenanceRequest(
        request,
        [&seen](const json& r) {
            seen = r;
            return json{{"ok", true}};
        },
        peer);
    EXPECT_EQ(json::parse(line)["ok"], true) << line;
    return seen;
}

TEST(MaintenanceRequest, TheCallerIsTheSocketsPeerNeverWhatTheRequestClaims)
{
    const json plain = handedOn("{\"command\": \"purpose\", \"purpose\": \"master\"}\n", "unix:olga");
    EXPECT_EQ(plain, (json{{"command", "purpose"},
                           {"purpose", "master"},
                           {"caller", {{"who", "unix:olga"}, {"source", "socket"}}}}));
    // A caller the request names is replaced whole: no role or source of its own survives.
    const json claimed = handedOn(
        R"({"command": "reload", "caller": {"who": "anna", "role": "administrator", "source": "hmi 10.0.0.1"}})"
        "\n",
        "unix:olga");
    EXPECT_EQ(claimed, (json{{"command", "reload"}, {"caller", {{"who", "unix:olga"}, {"source", "socket"}}}}));
    // Without a peer (the peer's credentials unknown) the request names no caller at all.
    const json anonymous = handedOn(R"({"command": "reload", "caller": {"who": "anna", "role": "administrator"}})"
                                    "\n",
                                    "");
    EXPECT_EQ(anonymous, (json{{"command", "reload"}}));
}

} // namespace
} // namespace hg::daemon
