// Failed-part images: one folder per failed inspection holding a PNG per view
// with the silhouette outline and the landmarks drawn in their status colours,
// kept within the retention limits (count, age, bytes; oldest removed first).
#pragma once

#include "daemon_config.h"
#include "inspector.h"

#include <cstdint>
#include <filesystem>
#include <opencv2/core/types.hpp>
#include <string>
#include <vector>

namespace hg::daemon {

/// BGR colour of a landmark status: ok green, out_of_tolerance red, overflow
/// magenta, not_found orange, not_observable grey.
cv::Scalar statusColour(const std::string& status);

/// The annotated picture of one view (BGR, the frame scaled to 8 bit).
cv::Mat annotate(const ViewEvidence& view);

class ImageArchive {
  public:
    ImageArchive(std::filesystem::path root, station::RetentionConfig retention);

    /// The folder of a failed inspection: `<root>/<startedUnixMs>_<serial>`
    /// (serial characters other than letters, digits and '-' become '_').
    std::filesystem::path folderFor(std::int64_t startedUnixMs, const std::string& serial) const;
    /// Writes `views` as view_<k>.png into folderFor(startedUnixMs, serial);
    /// returns the folder (empty when there was nothing to write).
    /// Never throws: a failure is logged and the record keeps an empty path.
    std::filesystem::path saveFailed(std::int64_t startedUnixMs, const std::string& serial,
                                     const std::vector<ViewEvidence>& views);
    /// Removes the oldest folders beyond max_count, older than max_age_days,
    /// or beyond max_bytes in total. Returns how many were removed.
    std::size_t enforceRetention();

  private:
    std::filesystem::path root_;
    station::RetentionConfig retention_;
};

} // namespace hg::daemon
