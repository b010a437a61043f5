#include "cycle/image_archive.h"

#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace hg::daemon {
namespace fs = std::filesystem;
namespace {

/// A folder being written is named so: hidden, skipped and, once stale, removed by the retention.
constexpr std::string_view kPartialPrefix = ".partial-";

bool isPartial(const fs::path& dir)
{
    return dir.filename().string().rfind(kPartialPrefix, 0) == 0;
}

/// `image` as a lossless PNG in `file` (8 or 16 bit as the Mat holds it).
void writePng(const fs::path& file, const cv::Mat& image)
{
    std::vector<uchar> bytes;
    if (!cv::imencode(".png", image, bytes)) throw FaultError("cannot encode " + file.string());
    writeFileDurably(file, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

/// The frame a browser shows well: 8-bit grey as grabbed, else scaled to 8 bit as the annotated picture is.
cv::Mat eightBit(const cv::Mat& image)
{
    if (image.depth() != CV_16U) return image;
    double maxValue = 0;
    cv::minMaxLoc(image, nullptr, &maxValue);
    cv::Mat grey;
    image.convertTo(grey, CV_8U, maxValue > 0 ? 255.0 / maxValue : 1.0);
    return grey;
}

/// The plain frame of view `k` for the HMI's overlay (docs/daemon.md, "Archived parts"): the capture's own
/// PNG when it is stored 8-bit grey, else frame_<k>.png written now. Returns its file name.
std::string writeFrame(const fs::path& dir, std::size_t k, const ViewEvidence& view, const std::string& captureFile)
{
    if (!captureFile.empty() && view.image.type() == CV_8UC1) return captureFile;
    const std::string name = "frame_" + std::to_string(k) + ".png";
    writePng(dir / name, eightBit(view.image));
    return name;
}

/// Every file of an archived part into `dir` (docs/daemon.md, "Archived parts").
void writeArchive(const fs::path& dir, const std::vector<ViewEvidence>& views)
{
    const bool capture = std::all_of(views.begin(), views.end(), [](const ViewEvidence& v) { return v.capture; });
    vision::CaptureManifest manifest;
    manifest.segmentation = views.front().segmentation;
    manifest.calibration = views.front().calibration;
    if (views.front().imageQuality.given) manifest.imageQuality = views.front().imageQuality;
    for (std::size_t k = 0; k < views.size(); ++k) {
        const std::string stem = "view_" + std::to_string(k);
        writePng(dir / (stem + ".png"), annotate(views[k]));
        std::string captureFile;
        if (capture) {
            vision::ManifestView view = *views[k].capture;
            captureFile = view.id + ".png";
            view.image = dir / captureFile;
            writePng(view.image, views[k].image);
            manifest.views.push_back(std::move(view));
        }
        const std::string frame = writeFrame(dir, k, views[k], captureFile);
        writeFileDurably(dir / (stem + ".json"), overlayJson(views[k], frame).dump());
    }
    if (capture) writeFileDurably(dir / "manifest.json", vision::manifestJson(manifest, dir));
    syncFolder(dir);
}

/// The archived folders, oldest first (not the hidden ones being written).
std::vector<fs::path> foldersOldestFirst(const fs::path& root)
{
    std::vector<std::pair<fs::file_time_type, fs::path>> found;
    std::error_code ec;
    for (const auto& d : fs::directory_iterator(root, ec))
        if (d.is_directory(ec) && !isPartial(d.path())) found.emplace_back(d.last_write_time(ec), d.path());
    std::sort(found.begin(), found.end());
    std::vector<fs::path> folders;
    for (auto& [time, dir] : found) folders.push_back(std::move(dir));
    return folders;
}

} // namespace

std::uint64_t volumeFreeBytes(const fs::path& path)
{
    std::error_code ec;
    for (fs::path at = path; !at.empty(); at = at.parent_path()) {
        const auto info = fs::space(at, ec);
        if (!ec) return info.available;
        if (at == at.parent_path()) break;
    }
    // Nothing to ask: the free-space rule stands aside, the write itself then says what failed.
    return std::numeric_limits<std::uint64_t>::max();
}

bool archivesPart(const station::ResultsConfig& results, station::Verdict verdict)
{
    if (verdict == station::Verdict::Fail) return results.archiveAll || results.saveFailedImages;
    return verdict == station::Verdict::Pass && results.archiveAll;
}

cv::Scalar statusColour(inspect::LandmarkStatus status)
{
    using enum inspect::LandmarkStatus;
    switch (status) {
    case Ok:
        return {0, 200, 0};
    case OutOfTolerance:
        return {0, 0, 255};
    case Overflow:
        return {255, 0, 255};
    case NotFound:
        return {0, 140, 255};
    case NotObservable:
    case NotInspected:
    case Uncertain:
        break;
    }
    return {160, 160, 160};
}

nlohmann::json overlayJson(const ViewEvidence& view, const std::string& frame)
{
    const auto point = [](const cv::Point2d& p) {
        // Hundredths of a pixel: finer than the outline's accuracy, and a short file.
        return nlohmann::json::array({std::round(p.x * 100.0) / 100.0, std::round(p.y * 100.0) / 100.0});
    };
    auto outline = nlohmann::json::array();
    for (const auto& polyline : view.outline) {
        auto points = nlohmann::json::array();
        for (const auto& p : polyline.points) points.push_back(point(p));
        outline.push_back({{"closed", polyline.closed}, {"points", std::move(points)}});
    }
    auto landmarks = nlohmann::json::array();
    for (const auto& mark : view.landmarks) {
        if (mark.pixel.x < -0.5 || mark.pixel.y < -0.5 || mark.pixel.x > view.image.cols - 0.5 ||
            mark.pixel.y > view.image.rows - 0.5)
            continue; // not in this frame
        nlohmann::json l = mark.outcome ? station::toJson(*mark.outcome)
                                        : nlohmann::json{{"id", mark.id}, {"status", enumName(mark.status)}};
        l["pixel"] = point(mark.pixel);
        l["direction"] = mark.direction == cv::Point2d() ? nlohmann::json() : point(mark.direction);
        landmarks.push_back(std::move(l));
    }
    return {{"image_size", {view.image.cols, view.image.rows}},
            {"frame", frame},
            {"seat", view.seatMeasured ? "measured" : "nominal"},
            {"outline", std::move(outline)},
            {"landmarks", std::move(landmarks)}};
}

cv::Mat annotate(const ViewEvidence& view)
{
    const cv::Mat grey = eightBit(view.image);
    cv::Mat out;
    if (grey.channels() == 1)
        cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
    else
        out = grey.clone();
    const int thickness = std::max(1, out.cols / 800);
    if (!view.silhouette.empty()) {
        std::vector<std::vector<cv::Point>> contours;
        cv::Mat mask = view.silhouette != 0;
        cv::findContours(mask, contours, cv::RETR_LIST, cv::CHAIN_APPROX_SIMPLE);
        cv::drawContours(out, contours, -1, cv::Scalar(255, 160, 0), thickness); // silhouette outline: blue
    }
    const int radius = std::max(4, out.cols / 150);
    for (const auto& mark : view.landmarks) {
        cv::Point p(cvRound(mark.pixel.x), cvRound(mark.pixel.y));
        auto colour = statusColour(mark.status);
        cv::circle(out, p, radius, colour, thickness + 1);
        cv::putText(out, mark.id, p + cv::Point(radius + 2, -radius), cv::FONT_HERSHEY_SIMPLEX, 0.4 * thickness + 0.2,
                    colour, thickness);
    }
    return out;
}

ImageArchive::ImageArchive(fs::path root, station::RetentionConfig retention, const Clock& clock,
                           FreeSpaceProbe freeBytes)
    : root_(std::move(root)), retention_(retention), clock_(&clock), freeBytes_(std::move(freeBytes))
{
}

bool ImageArchive::hasRoom() const
{
    return freeBytes_(root_) >= retention_.minFreeBytes;
}

std::size_t ImageArchive::makeRoom()
{
    if (hasRoom()) return 0;
    const auto before = freeBytes_(root_);
    std::size_t removed = 0;
    std::error_code ec;
    for (const auto& dir : foldersOldestFirst(root_)) {
        if (hasRoom()) break;
        fs::remove_all(dir, ec);
        if (!ec) ++removed;
    }
    auto log = hg::log::category("store");
    if (removed)
        log->warn("the results volume had {} MiB free, under results.retention.min_free_mb {}: removed the oldest {} "
                  "archived folders (failed parts too); now {} MiB free",
                  before >> 20, retention_.minFreeBytes >> 20, removed, freeBytes_(root_) >> 20);
    return removed;
}

fs::path ImageArchive::folderFor(std::int64_t startedUnixMs, const std::string& serial) const
{
    std::string safe;
    for (char c : serial) safe.push_back(std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_');
    return root_ / (std::to_string(startedUnixMs) + (safe.empty() ? "" : "_" + safe));
}

fs::path ImageArchive::save(std::int64_t startedUnixMs, const std::string& serial,
                            const std::vector<ViewEvidence>& views, bool failed)
{
    if (views.empty()) return {};
    const fs::path dir = folderFor(startedUnixMs, serial);
    // Written whole into a hidden folder, then renamed: a reader never sees half an archive.
    const fs::path partial = root_ / (std::string(kPartialPrefix) + dir.filename().string());
    std::error_code ec;
    try {
        fs::remove_all(partial);
        fs::create_directories(partial);
        writeArchive(partial, views);
        if (failed) std::ofstream(partial / kFailedMarker).put('\n');
        fs::rename(partial, dir);
        syncFolder(root_);
    } catch (const std::exception& e) {
        hg::log::category("store")->error("cannot write the archive {}: {}", dir.string(), e.what());
        fs::remove_all(partial, ec);
        return {};
    }
    return dir;
}

std::size_t ImageArchive::enforceRetention()
{
    struct Entry {
        fs::path dir;
        fs::file_time_type time;
        std::uintmax_t bytes = 0;
        bool failed = false;
    };
    std::vector<Entry> entries;
    std::vector<fs::path> stale;
    std::error_code ec;
    for (const auto& d : fs::directory_iterator(root_, ec)) {
        if (!d.is_directory()) continue;
        // Saves and the retention run on one thread: a partial folder here was cut short by a crash.
        if (isPartial(d.path())) {
            stale.push_back(d.path());
            continue;
        }
        Entry e{d.path(), d.last_write_time(ec), 0, fs::exists(d.path() / kFailedMarker, ec)};
        for (const auto& f : fs::recursive_directory_iterator(d.path(), ec))
            if (f.is_regular_file()) e.bytes += f.file_size(ec);
        entries.push_back(std::move(e));
    }
    for (const auto& dir : stale) fs::remove_all(dir, ec);
    // Newest first; walk and keep while every limit holds.
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.time > b.time; });
    const auto cutoff = std::chrono::file_clock::from_sys(clock_->wallNow()) - retention_.maxAge;
    std::uintmax_t total = 0;
    std::size_t removed = 0, failedSeen = 0;
    for (std::size_t i = 0; i < entries.size(); ++i) {
        total += entries[i].bytes;
        // The newest keep_failed rejects stay whatever the other limits say.
        if (entries[i].failed && ++failedSeen <= retention_.keepFailed) continue;
        bool keep = i < retention_.maxCount && entries[i].time >= cutoff && total <= retention_.maxBytes;
        if (keep) continue;
        fs::remove_all(entries[i].dir, ec);
        if (!ec) ++removed;
    }
    if (removed) hg::log::category("store")->info("image retention removed {} folders", removed);
    return removed + makeRoom();
}

} // namespace hg::daemon
