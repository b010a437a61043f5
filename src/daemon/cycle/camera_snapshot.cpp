#include "cycle/camera_snapshot.h"

#include "hullgauge/common/log.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/vision/segmentation.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace hg::daemon {
namespace {

// Median grey of the pixels `select` marks (non-zero), from a histogram of
// every grey level of the frame's depth; 0 when none is selected.
double medianGrey(const cv::Mat& grey, const cv::Mat& select)
{
    const int levels = grey.depth() == CV_16U ? 65536 : 256;
    const int channels[] = {0};
    const int size[] = {levels};
    const float range[] = {0.0f, static_cast<float>(levels)};
    const float* ranges[] = {range};
    cv::Mat hist;
    cv::calcHist(&grey, 1, channels, select, hist, 1, size, ranges);
    const double total = cv::sum(hist)[0];
    if (total <= 0) return 0;
    double seen = 0;
    for (int v = 0; v < levels; ++v) {
        seen += hist.at<float>(v);
        if (seen >= total / 2) return v;
    }
    return levels - 1;
}

} // namespace

SnapshotFigures snapshotFigures(const cv::Mat& grey, const cv::Mat& mask, double threshold)
{
    SnapshotFigures f;
    f.threshold = threshold;
    f.objectFraction = static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total());
    cv::Mat backlight;
    cv::bitwise_not(mask, backlight);
    f.backlightGrey = medianGrey(grey, backlight);
    f.objectGrey = medianGrey(grey, mask);
    return f;
}

cv::Mat snapshotOverlay(const cv::Mat& grey, const cv::Mat& mask)
{
    cv::Mat grey8;
    if (grey.depth() == CV_16U)
        grey.convertTo(grey8, CV_8U, 1.0 / 257.0);
    else
        grey8 = grey;
    cv::Mat colour;
    cv::cvtColor(grey8, colour, cv::COLOR_GRAY2BGR);
    // The silhouette tinted blue, so a backlight too dim (object spilling into
    // the background) or a part too thin to hold (holes in it) shows at a glance.
    cv::Mat tinted;
    cv::addWeighted(colour, 0.6, cv::Mat(colour.size(), colour.type(), cv::Scalar(255, 120, 0)), 0.4, 0, tinted);
    tinted.copyTo(colour, mask);
    std::vector<std::vector<cv::Point>> outline;
    cv::findContours(mask.clone(), outline, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    const int thickness = std::max(1, colour.cols / 800);
    cv::drawContours(colour, outline, -1, cv::Scalar(0, 0, 255), thickness, cv::LINE_8);
    return colour;
}

Status CameraSnapshot::request(SnapshotJob job, station::SequencerState state)
{
    nlohmann::json status{{"pose_requested", job.pose.has_value()}};
    // The last frame's figures stay in the status until the next is grabbed.
    if (const auto last = queue_.status(); last.is_object() && last.contains("id")) status.update(last);
    status.erase("error");
    return queue_.request(std::move(job), state, std::move(status));
}

std::shared_ptr<const std::vector<unsigned char>> CameraSnapshot::png() const
{
    std::lock_guard lock(pngMutex_);
    return png_;
}

bool CameraSnapshot::run(const SnapshotJob& job, StationDevices& devices, const station::DaemonConfig& cfg,
                         Clock& clock)
{
    auto log = hg::log::category("camera");
    queue_.update({{"state", "running"}});
    if (job.pose) {
        if (auto r = devices.moveTo(*job.pose, cfg.sequencer.moveTimeout, false); !r.ok()) {
            queue_.update({{"state", "failed"}, {"error", "fixture: " + r.message()}});
            return false;
        }
        clock.sleepUntil(clock.now() + cfg.sequencer.settle, [] { return false; });
    }
    // Whole frames: the last cycle left the camera on its last view's region (docs/camera.md).
    if (auto r = devices.setRegion({}); !r.ok()) log->warn("snapshot: whole frames asked: {}", r.message());
    const auto grabStart = clock.now();
    GrabbedFrame grabbed;
    if (auto r = devices.grab(cfg.sequencer.grabTimeout, grabbed); !r.ok()) {
        queue_.update({{"state", "failed"}, {"error", "camera: " + r.message()}});
        return false;
    }
    const double grabMs = std::chrono::duration<double, std::milli>(clock.now() - grabStart).count();
    try {
        const auto grey = vision::toGrey(grabbed.image);
        const auto& seg = cfg.segmentation;
        const double threshold = vision::computeThreshold(grey, seg);
        const auto mask = vision::segmentRegion(grey, cv::Rect(0, 0, grey.cols, grey.rows), threshold, seg);
        const auto figures = snapshotFigures(grey, mask, threshold);
        auto png = std::make_shared<std::vector<unsigned char>>();
        cv::imencode(".png", snapshotOverlay(grey, mask), *png);
        {
            std::lock_guard lock(pngMutex_);
            png_ = std::move(png);
        }
        const auto nowMs = clock.wallMs();
        queue_.update({{"state", "done"},
                       {"id", ++frames_},
                       {"time", store::formatUtc(nowMs)},
                       {"width", grey.cols},
                       {"height", grey.rows},
                       {"depth_bits", grey.depth() == CV_16U ? 16 : 8},
                       {"pose", job.pose ? geometry::toJson(*job.pose, cfg.station.fixture.type) : nullptr},
                       {"grab_ms", grabMs},
                       {"segmentation",
                        {{"method", enumName(seg.method)},
                         {"threshold", figures.threshold},
                         {"object_is_dark", seg.objectIsDark}}},
                       {"object_fraction", figures.objectFraction},
                       {"backlight_grey", figures.backlightGrey},
                       {"object_grey", figures.objectGrey}});
        log->info("snapshot {}: {}x{}, threshold {:.0f}, object {:.1f} %", frames_, grey.cols, grey.rows,
                  figures.threshold, 100 * figures.objectFraction);
        return true;
    } catch (const std::exception& e) {
        queue_.update({{"state", "failed"}, {"error", std::string("segmentation: ") + e.what()}});
        return true;
    }
}

} // namespace hg::daemon
