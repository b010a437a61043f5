// Writing calibration results into a station YAML file (docs/contracts.md §2, §5):
// only the keys a calibration owns change, every other key of an existing file
// is kept (in its order), the old file is kept as a time-stamped backup, and
// the new text goes to a temporary file in the same folder that is flushed and
// renamed over the old one — the file is never half-written.
//
// yaml-cpp does not keep comments: the backup holds the commented original.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "hullgauge/calib/fixture_axes.h"
#include "hullgauge/calib/intrinsics.h"
#include "hullgauge/calib/rail.h"
#include "hullgauge/calib/telecentric.h"

namespace hg::calib {

class StationFileUpdate {
  public:
    /// Loads `file` if it exists (syntax errors throw hg::InputError), else
    /// starts an empty document.
    explicit StationFileUpdate(std::filesystem::path file);

    /// camera.K, camera.dist, camera.image_size, camera.calibration.{rms_px,
    /// views, method, std_dev}.
    void setIntrinsics(const IntrinsicsResult& result, const std::string& method);
    /// camera.K from the rail procedure's least-squares fit (no distortion:
    /// camera.dist becomes zeros) and camera.calibration; camera.image_size
    /// must already be in the file (else hg::InputError naming `field`).
    void setRailIntrinsics(const RailCalibration& result, const std::string& field);
    /// A telecentric camera (docs/telecentric-calibration.md): camera.model
    /// `telecentric`, camera.image_size, camera.dist and either, with the
    /// sensor's horizontal pixel pitch given, camera.magnification,
    /// camera.pixel_pitch_mm [horizontal, vertical] and
    /// camera.principal_point, or else camera.K in px per mm — never both
    /// forms; camera.calibration as setIntrinsics writes it.
    void setTelecentricIntrinsics(const TelecentricCalibration& result, const std::string& method,
                                  std::optional<double> pixelPitchMm);
    /// fixture.type, fixture.camera_from_fixture, fixture.rotation_axis,
    /// fixture.declination_axis, fixture.calibration.{...}.
    void setFixtureAxes(const FixtureAxesResult& result);

    YAML::Node& root() { return root_; }

    /// Writes the file atomically; returns the backup's path when an old file
    /// existed. Failures throw hg::FaultError naming the file.
    std::optional<std::filesystem::path> commit();

  private:
    std::filesystem::path file_;
    YAML::Node root_;
    bool existed_ = false;
};

/// One station file's calibration records (docs/calibration.md): the
/// `camera.calibration` and `fixture.calibration` maps, null where the file
/// has none; `error` instead when the file could not be read.
struct StationCalibration {
    std::filesystem::path file;
    nlohmann::json camera;
    nlohmann::json fixture;
    std::string error;
};

/// The calibration history of a station: the station file's records, then
/// those of its backups (`<file>.bak-<UTC time>`, written by
/// StationFileUpdate::commit before each calibration replaced them), newest
/// first, at most `max` files.
std::vector<StationCalibration> calibrationHistory(const std::filesystem::path& stationFile, std::size_t max);

} // namespace hg::calib
