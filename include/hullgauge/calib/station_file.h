// Writing calibration results into a station YAML file (docs/contracts.md §2, §5):
// only the keys a calibration owns change, every other key of an existing file
// is kept (in its order), the old file is kept as a time-stamped backup, and
// the new text goes to a temporary file in the same folder that is flushed and
// renamed over the old one — the file is never half-written.
//
// yaml-cpp does not keep comments: the backup holds the commented original.
#pragma once

#include <filesystem>
#include <optional>

#include <yaml-cpp/yaml.h>

#include "hullgauge/calib/fixture_axes.h"
#include "hullgauge/calib/intrinsics.h"
#include "hullgauge/calib/rail.h"

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

} // namespace hg::calib
