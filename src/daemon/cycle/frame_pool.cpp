#include "cycle/frame_pool.h"

#include "hullgauge/common/log.h"

#include <atomic>
#include <opencv2/core.hpp>

namespace hg::daemon {
namespace {

/// Whether only the pool refers to the slot. The count is read atomically: a
/// frame released on the image job's thread is seen free here with its pixels done.
bool isFree(const cv::Mat& slot)
{
    return slot.empty() || std::atomic_ref<int>(slot.u->refcount).load(std::memory_order_acquire) == 1;
}

} // namespace

void FramePool::reserve(std::size_t slots, std::size_t pixels)
{
    if (pixels != pixels_) {
        // Slots a frame still refers to stay with that frame; the pool forgets them.
        for (cv::Mat& slot : slots_) slot.release();
        pixels_ = pixels;
    }
    slots_.resize(slots);
}

cv::Mat FramePool::copy(const cv::Mat& image)
{
    const std::size_t pixels = image.total();
    if (image.channels() == 1 && pixels <= pixels_ && pixels > 0) {
        for (cv::Mat& slot : slots_) {
            if (!isFree(slot)) continue;
            // A slot of another pixel type (the camera's format changed) is made anew.
            if (slot.empty() || slot.type() != image.type()) slot.create(1, static_cast<int>(pixels_), image.type());
            // The image's rows at the slot's front: a view sharing the slot's count.
            cv::Mat view = slot.colRange(0, static_cast<int>(pixels)).reshape(1, image.rows);
            image.copyTo(view);
            return view;
        }
    }
    ++overflows_;
    log::category("camera")->debug("frame pool: no free slot of {} for a {}x{} frame ({} slots held)", pixels_,
                                   image.cols, image.rows, held());
    return image.clone();
}

std::size_t FramePool::held() const
{
    std::size_t n = 0;
    for (const cv::Mat& slot : slots_)
        if (!isFree(slot)) ++n;
    return n;
}

} // namespace hg::daemon
