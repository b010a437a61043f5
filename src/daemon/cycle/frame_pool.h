// The frames the daemon keeps after the camera's buffer goes back to the
// driver (docs/daemon.md, "Memory"): a fixed number of slots, each as large
// as the camera's configured region, allocated once and reused, so a cycle's
// frames cost no allocation and the memory does not grow with the cycles.
#pragma once

#include <cstddef>
#include <opencv2/core/mat.hpp>
#include <vector>

namespace hg::daemon {

class FramePool {
  public:
    /// `slots` buffers of `pixels` pixels each, allocated on first use (a
    /// slot holds any region of the camera's configured one). Reserving again
    /// with other sizes drops the slots no frame refers to any more.
    void reserve(std::size_t slots, std::size_t pixels);

    /// A copy of `image` (single channel, continuous or not) in a slot no
    /// frame refers to any more; the slot is free again when the last cv::Mat
    /// referring to the copy goes. When every slot is held, or the image is
    /// larger than a slot, the copy is of its own (counted by overflows()):
    /// the cycle never waits for memory and never gets a wrong image.
    cv::Mat copy(const cv::Mat& image);

    std::size_t slots() const { return slots_.size(); }
    /// Copies that found no free slot since the pool was made.
    std::size_t overflows() const { return overflows_; }
    /// Slots some frame refers to now.
    std::size_t held() const;

  private:
    std::vector<cv::Mat> slots_; ///< 1 × pixels each, empty until first used
    std::size_t pixels_ = 0;
    std::size_t overflows_ = 0;
};

} // namespace hg::daemon
