#include "hullgauge/geometry/fixture_motion.h"
#include "hullgauge/geometry/station.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace hg::geometry {
namespace {

std::string joinedAxisNames(FixtureType type)
{
    auto names = axisNames(type);
    return names.size() == 1 ? names[0] : names[0] + ", " + names[1];
}

/// Refuses keys of `section` that are not axes of `type`, besides `others`.
void checkAxisKeys(const ConfigNode& section, FixtureType type, const std::vector<std::string>& others = {})
{
    auto names = axisNames(type);
    for (const auto& key : section.keys()) {
        if (std::find(others.begin(), others.end(), key) != others.end()) continue;
        if (std::find(names.begin(), names.end(), key) == names.end())
            section[key].fail("no axis '" + key + "' on this fixture type (axes: " + joinedAxisNames(type) + ")");
    }
}

/// The speed the simulated drive moves an axis at: the twin (backend `sim`)
/// at its max_speed; hullgauge-fixture-sim at the value the Modbus driver
/// wrote to the axis' speed register (`speed_value` rounded to a count, as
/// the register holds it), capped at max_speed, or max_speed while the
/// register is 0 (drivers/fixture/simulated_drive.cpp).
double simulatedSpeed(const ConfigNode& driver, const SimulatedAxisParams& p)
{
    auto backend = driver.optional("backend");
    if (!backend || backend->asString() != "modbus") return p.maxSpeed;
    auto registers = driver.optional("registers");
    auto axes = registers ? registers->optional("axes") : std::nullopt;
    auto axis = axes ? axes->optional(p.name) : std::nullopt;
    auto speed = axis ? axis->optional("speed") : std::nullopt;
    auto value = axis ? axis->optional("speed_value") : std::nullopt;
    if (!speed || !value) return p.maxSpeed;
    const double scale = (*speed)["scale"].asPositive();
    const double held = static_cast<double>(std::llround(value->asPositive() / scale)) * scale;
    return held > 0.0 ? std::min(held, p.maxSpeed) : p.maxSpeed;
}

/// The axes as the simulated drive of `fixture.driver` moves them (defaults
/// without a driver section).
std::vector<AxisMotion> simulatedAxes(const ConfigNode& fixture, FixtureType type)
{
    std::vector<AxisMotion> out;
    auto driver = fixture.optional("driver");
    std::vector<SimulatedAxisParams> params;
    if (driver)
        params = parseSimulatorSection(*driver, type);
    else
        for (const auto& name : axisNames(type)) params.push_back(defaultSimulatedAxis(name));
    for (const auto& p : params)
        out.push_back({p.name, driver ? simulatedSpeed(*driver, p) : p.maxSpeed, p.acceleration, p.settleS});
    return out;
}

} // namespace

std::vector<std::string> axisNames(FixtureType type)
{
    if (type == FixtureType::Rail) return {"rail"};
    return {"rotation", "declination"};
}

std::vector<double> axisValues(const FixturePose& pose, FixtureType type)
{
    if (type == FixtureType::Rail) return {pose.railMm};
    return {pose.rotationDeg, pose.declinationDeg};
}

FixturePose poseFromAxes(const std::vector<double>& values, FixtureType type)
{
    FixturePose pose;
    if (type == FixtureType::Rail) {
        pose.railMm = values.at(0);
    } else {
        pose.rotationDeg = values.at(0);
        pose.declinationDeg = values.at(1);
    }
    return pose;
}

double trapezoidDuration(double distance, double speed, double acceleration)
{
    if (distance <= 0.0) return 0.0;
    if (distance >= speed * speed / acceleration) return distance / speed + speed / acceleration;
    return 2.0 * std::sqrt(distance / acceleration);
}

double trapezoidDistance(double distance, double speed, double acceleration, double t)
{
    if (distance <= 0.0 || t <= 0.0) return 0.0;
    double total = trapezoidDuration(distance, speed, acceleration);
    if (t >= total) return distance;
    // Accelerate for ta (to the cruise speed or, on short moves, to the peak
    // speed at half distance), cruise, then mirror the acceleration phase.
    double ta = std::min(speed / acceleration, total / 2.0);
    double peak = acceleration * ta;
    if (t < ta) return 0.5 * acceleration * t * t;
    if (t < total - ta) return 0.5 * acceleration * ta * ta + peak * (t - ta);
    double left = total - t;
    return distance - 0.5 * acceleration * left * left;
}

SimulatedAxisParams defaultSimulatedAxis(const std::string& name)
{
    SimulatedAxisParams p;
    p.name = name;
    if (name == "declination") p.maxSpeed = 45.0, p.acceleration = 180.0;
    if (name == "rail") p.maxSpeed = 100.0, p.acceleration = 500.0;
    return p;
}

std::vector<SimulatedAxisParams> parseSimulatorSection(const ConfigNode& driver, FixtureType type)
{
    std::vector<SimulatedAxisParams> out;
    auto section = driver.optional("simulator");
    std::optional<ConfigNode> axes;
    if (section) {
        section->allowOnlyKeys({"axes"});
        axes = section->optional("axes");
        if (axes) checkAxisKeys(*axes, type);
    }
    for (const auto& name : axisNames(type)) {
        SimulatedAxisParams p = defaultSimulatedAxis(name);
        if (auto a = axes ? axes->optional(name) : std::nullopt) {
            a->allowOnlyKeys({"max_speed", "acceleration", "settle_s", "home_position", "start_position"});
            if (auto v = a->optional("max_speed")) p.maxSpeed = v->asPositive();
            if (auto v = a->optional("acceleration")) p.acceleration = v->asPositive();
            if (auto v = a->optional("settle_s")) p.settleS = v->asDoubleIn(0.0, 60.0);
            if (auto v = a->optional("home_position")) p.homePosition = v->asDouble();
            if (auto v = a->optional("start_position")) p.startPosition = v->asDouble();
        }
        out.push_back(p);
    }
    return out;
}

std::vector<double> FixtureMotion::axisSeconds(const FixturePose& from, const FixturePose& to) const
{
    const auto a = axisValues(from, type);
    const auto b = axisValues(to, type);
    std::vector<double> out;
    for (std::size_t i = 0; i < axes.size() && i < a.size(); ++i) {
        // An axis that does not move settles too: the drive starts every
        // axis' (possibly empty) profile and settle with the move command.
        const double d = std::abs(b[i] - a[i]);
        out.push_back(trapezoidDuration(d, axes[i].speed, axes[i].acceleration) + axes[i].settleS);
    }
    return out;
}

double FixtureMotion::moveSeconds(const FixturePose& from, const FixturePose& to) const
{
    const auto t = axisSeconds(from, to);
    return t.empty() ? 0.0 : *std::max_element(t.begin(), t.end());
}

FixtureMotion defaultFixtureMotion(FixtureType type)
{
    FixtureMotion m;
    m.type = type;
    for (const auto& name : axisNames(type)) {
        const auto p = defaultSimulatedAxis(name);
        m.axes.push_back({p.name, p.maxSpeed, p.acceleration, p.settleS});
    }
    return m;
}

FixtureMotion parseFixtureMotion(const ConfigNode& fixture, const ConfigNode& camera, FixtureType type)
{
    FixtureMotion m;
    m.type = type;
    m.axes = simulatedAxes(fixture, type);
    m.source = fixture.has("driver") ? "fixture.driver.simulator" : "defaults";
    if (auto motion = fixture.optional("motion")) {
        checkAxisKeys(*motion, type, {"settle_s"});
        const std::string unit = type == FixtureType::Rail ? "mm" : "deg";
        for (auto& axis : m.axes) {
            auto a = motion->optional(axis.name);
            if (!a) continue;
            m.source = "fixture.motion";
            const std::string speedKey = "speed_" + unit + "_s", accelerationKey = "acceleration_" + unit + "_s2";
            a->allowOnlyKeys({speedKey, accelerationKey, "settle_s"});
            if (auto v = a->optional(speedKey)) axis.speed = v->asPositive();
            if (auto v = a->optional(accelerationKey)) axis.acceleration = v->asPositive();
            if (auto v = a->optional("settle_s")) axis.settleS = v->asDoubleIn(0.0, 60.0);
        }
        if (auto v = motion->optional("settle_s")) m.settleS = v->asDoubleIn(0.0, 60.0);
    }
    if (auto v = camera.optional("grab_s")) {
        m.grabS = v->asDoubleIn(0.0, 60.0);
    } else if (auto driver = camera.optional("driver")) {
        if (auto exposure = driver->optional("exposure_us")) m.grabS = exposure->asDoubleIn(0.0, 6e7) * 1e-6;
    }
    return m;
}

FixtureMotion stationMotion(const Station& station)
{
    const auto type = station.fixture.type;
    if (!station.document || !station.document->has("fixture") || !station.document->has("camera"))
        return defaultFixtureMotion(type);
    const auto& root = *station.document;
    // A station whose kinematics were changed in code after loading no longer matches its file.
    auto typeNode = root["fixture"].optional("type");
    if (!typeNode || typeNode->asString() != enumName(type)) return defaultFixtureMotion(type);
    return parseFixtureMotion(root["fixture"], root["camera"], type);
}

} // namespace hg::geometry
