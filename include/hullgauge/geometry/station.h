// The station description (docs/contracts.md §2): camera intrinsics, fixture
// kinematics, environment. Driver and communication sections of the same file
// are kept as raw configuration for the drivers to read (`sections`).
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <vector>

#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/fixture.h"

namespace hg::geometry {

/// What the station's calibration records say of their own uncertainty
/// (docs/calibration.md; docs/inspection.md, "Uncertainty budget"): the
/// `std_dev` of `camera.calibration` and the `rms_mm` of `fixture.calibration`.
struct CalibrationUncertainty {
    /// One standard deviation of fx, fy, cx, cy (px), k1, k2, p1, p2, k3; 0 where not recorded.
    std::array<double, 9> intrinsicsStdDev{};
    /// The fixture model's object-space RMS residual (mm); 0 when not recorded.
    double fixtureRmsMm = 0.0;
    bool recorded() const;
};

/// How clearly the station's frames show the part's outline: the grey
/// levels' noise and the backlight's contrast (`camera.image_quality`,
/// docs/config-reference.md), from which the capability check predicts the
/// edge noise before any frame is taken. The defaults are a dim, noisy
/// 8-bit image: a station that knows better says so.
struct ImageQuality {
    double noiseGrey = 2.0;      ///< standard deviation of a background pixel, grey levels
    double contrastGrey = 100.0; ///< background level − object level, grey levels
    /// The optics' blur, Gaussian σ in pixels (`blur_sigma_px`, 0 when not
    /// given): what the digital twin renders with (docs/commissioning.md).
    double blurSigmaPx = 0.0;
    bool given = false; ///< false: the defaults above
};

struct Station {
    Intrinsics camera;
    /// Physical pixel pitch (µm) for MED reports (eq. 4.5.2-2/3), when known.
    std::optional<Vec2> pixelSizeUm;
    /// Sharp range [near, far] of camera-frame depth along the optical axis in
    /// mm (Rule 4), when known; a telecentric camera's is about its plane of
    /// best focus, z = 0 (docs/telecentric.md).
    std::optional<Range> depthOfFieldMm;
    /// Telecentric only: the diameter (mm) of the object-side field around the
    /// optical axis the lens is telecentric over (Rule 4), when known.
    std::optional<double> telecentricFieldMm;
    FixtureKinematics fixture;
    /// Floor plane z in the part frame; no line of sight passes below it (Assumption 2.10).
    double floorZMm = 0.0;
    CalibrationUncertainty calibration;
    ImageQuality imageQuality;
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
/// A station file's `camera` section alone, validated as loadStation
/// validates it (pinhole or telecentric, docs/telecentric.md): for the tools
/// that need the calibrated camera of a station still being calibrated.
Intrinsics parseCameraSection(const ConfigNode& camera);

/// Loads a poses file: a YAML list of `{rotation_deg, declination_deg}` or
/// `{rail_mm}` maps (docs/contracts.md §5). Each pose is checked against the fixture's
/// type and ranges when `fixture` is given.
std::vector<FixturePose> loadPoses(const std::filesystem::path& file, const FixtureKinematics* fixture = nullptr);

} // namespace hg::geometry
