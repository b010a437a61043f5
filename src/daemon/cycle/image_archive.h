// The parts' archive (docs/daemon.md, "Archived parts"): one folder per
// archived inspection holding, per view, the frame as grabbed, a PNG with
// the silhouette outline and the landmarks drawn in their status colours, the
// overlay the HMI draws on the plain frame (view_<k>.json), and a
// capture manifest (docs/contracts.md §3) with the cameras and the segmentation the
// daemon inspected with, so `hullgauge inspect --part P --views
// <folder>/manifest.json` reproduces its landmark results. A folder is written
// whole or not at all (a hidden partial folder renamed when complete), and the
// archive is kept within the retention limits (count, age, bytes; oldest
// removed first).
#pragma once

#include "cycle/inspector.h"
#include "daemon_config.h"
#include "hullgauge/common/clock.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core/types.hpp>
#include <string>
#include <vector>

namespace hg::daemon {

/// BGR colour of a landmark status: ok green, out_of_tolerance red, overflow
/// magenta, not_found orange, any other grey.
cv::Scalar statusColour(inspect::LandmarkStatus status);

/// The annotated picture of one view (BGR, the frame scaled to 8 bit).
cv::Mat annotate(const ViewEvidence& view);

/// The overlay the HMI draws on view's plain frame `frame` (a file of the part's folder): view_<k>.json
/// (docs/daemon.md, "Archived parts"; docs/hmi.md, "Reject views"): the image size, the nominal outline at
/// the seat as polylines, each landmark in the frame with its pixel, measuring direction and outcome.
nlohmann::json overlayJson(const ViewEvidence& view, const std::string& frame);

/// Whether a part with `verdict` is archived: every inspected part with
/// `archive_all`, else a failed one with `save_failed_images`.
bool archivesPart(const station::ResultsConfig& results, station::Verdict verdict);

/// The bytes free for the daemon on the volume that holds `path` (or its nearest
/// existing parent); the archive's probe, which tests replace.
using FreeSpaceProbe = std::function<std::uint64_t(const std::filesystem::path& path)>;
std::uint64_t volumeFreeBytes(const std::filesystem::path& path);

class ImageArchive {
  public:
    /// The file that marks a failed part's folder (its verdict, for the retention).
    static constexpr const char* kFailedMarker = "FAILED";

    /// `clock`'s wall time is the now the retention's `max_age_days` counts back from.
    ImageArchive(std::filesystem::path root, station::RetentionConfig retention, const Clock& clock = Clock::steady(),
                 FreeSpaceProbe freeBytes = volumeFreeBytes);

    /// The folder of an archived inspection: `<root>/<startedUnixMs>_<serial>`
    /// (serial characters other than letters, digits and '-' become '_').
    std::filesystem::path folderFor(std::int64_t startedUnixMs, const std::string& serial) const;
    /// Writes `views` into folderFor(startedUnixMs, serial): view_<k>.png (annotated), view_<k>.json
    /// (overlayJson) with the plain frame it names, and when every view carries its capture, <id>.png (the
    /// frame, lossless; the overlay's frame when it is 8-bit grey, else frame_<k>.png) and manifest.json; a failed
    /// part's folder also holds the marker file FAILED. Returns the folder, or an empty path when there was nothing to
    /// write or the folder could not be written whole (logged; nothing is left). Never throws.
    std::filesystem::path save(std::int64_t startedUnixMs, const std::string& serial,
                               const std::vector<ViewEvidence>& views, bool failed = false);
    /// Removes the oldest folders beyond max_count, older than max_age_days,
    /// or beyond max_bytes in total (raw frames, pictures and manifests all
    /// count), and any partial folder a crash left — but never the folders of
    /// the newest keep_failed failed parts.
    /// Then, while the volume has less than min_free_mb free, the oldest
    /// folders (failed ones too) until it has.
    /// Returns how many archived folders were removed.
    std::size_t enforceRetention();
    /// Whether the volume has min_free_mb free: a part's images are written only then.
    bool hasRoom() const;
    /// Removes the oldest folders, failed ones too (never one being written), until the volume
    /// has min_free_mb free or no folder is left; returns how many were removed. Safe beside
    /// a save on another thread: it skips the hidden folder being written.
    std::size_t makeRoom();

  private:
    std::filesystem::path root_;
    station::RetentionConfig retention_;
    const Clock* clock_;
    FreeSpaceProbe freeBytes_;
};

} // namespace hg::daemon
