// The station description (docs/contracts.md §2): camera intrinsics, fixture
// kinematics, environment. Driver and communication sections of the same file
// are kept as raw configuration for the drivers to read (`sections`).
#pragma once

#include <filesystem>
#include <optional>
#include <vector>

#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/fixture.h"

namespace hg::geometry {

struct Station {
    Intrinsics camera;
    /// Physical pixel pitch (µm) for MED reports (eq. 4.5.2-2/3), when known.
    std::optional<Vec2> pixelSizeUm;
    /// Sharp range [near, far] along the optical axis in mm (Rule 4), when known.
    std::optional<Range> depthOfFieldMm;
    FixtureKinematics fixture;
    /// Floor plane z in the part frame; no line of sight passes below it (Assumption 2.10).
    double floorZMm = 0.0;
    /// The whole document, for driver sections (camera.driver, fixture.driver, lamps, ...).
    std::optional<ConfigNode> document;

    /// The posed camera at a fixture position.
    CameraModel cameraAt(const FixturePose& pose) const;
};

/// Loads and validates a station YAML file; errors throw InputError naming
/// file, line and key.
Station loadStation(const std::filesystem::path& file);
/// As loadStation, from a parsed document.
Station parseStation(const ConfigNode& root);

/// Loads a poses file: a YAML list of `{rotation_deg, declination_deg}` or
/// `{rail_mm}` maps (docs/contracts.md §5). Each pose is checked against the fixture's
/// type and ranges when `fixture` is given.
std::vector<FixturePose> loadPoses(const std::filesystem::path& file, const FixtureKinematics* fixture = nullptr);

} // namespace hg::geometry
