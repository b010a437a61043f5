// The maintenance socket's requests (docs/fuzzing.md): the input is what a
// client sent, answered by answerMaintenanceRequest as the server answers it
// (the JSON line up to the command table). The handler stands in for the
// command table without a running daemon: it reads the request's fields the
// way the commands do (nlohmann's value() and at(), the calibration pattern
// through TargetSpec::parse) and names an unknown command in its answer.
#include "fuzz_support.h"
#include "hullgauge/calib/target.h"
#include "maintenance.h"

#include <nlohmann/json.hpp>
#include <string>

namespace {

using nlohmann::json;

json commandTable(const json& request)
{
    const auto command = request.at("command").get<std::string>();
    if (command == "results") return {{"ok", true}, {"limit", request.value("limit", 10)}};
    if (command == "trigger")
        return {{"ok", true}, {"program", request.value("program", 0)}, {"serial", request.value("serial", "")}};
    if (command == "purpose" && request.contains("purpose")) return {{"ok", true}, {"purpose", request["purpose"]}};
    if (command == "calibrate") {
        (void)hg::calib::TargetSpec::parse(request.value("pattern", std::string()), "pattern");
        return {{"ok", true}, {"poses", request.value("poses", std::string())}};
    }
    if (command == "snapshot") return {{"ok", true}, {"grab", request.value("grab", false)}};
    if (command == "sim-part")
        return {{"ok", true}, {"list", request.value("list", false)}, {"name", request.value("name", "")}};
    return {{"ok", false}, {"error", "unknown command '" + command + "'"}};
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    (void)hg::fuzz::workFolder(); // silences the log
    const std::string request(reinterpret_cast<const char*>(data), size);
    const std::string answer = hg::daemon::answerMaintenanceRequest(request, commandTable);
    if (answer.empty() || answer.back() != '\n' || !json::accept(answer.substr(0, answer.size() - 1))) std::abort();
    return 0;
}
