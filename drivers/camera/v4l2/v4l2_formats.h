// Pure logic of the V4L2 backend, testable without a device: which device
// formats serve a requested pixel format, and YUYV to grey.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "hullgauge/drivers/camera.h"

namespace hg::drivers::v4l2 {

/// Device formats (V4L2 fourcc codes) that can deliver `want`, best first:
/// Mono8 <- GREY, then YUYV (luma taken); Mono12 <- Y12; Mono16 <- Y16.
std::vector<std::uint32_t> candidateFourccs(PixelFormat want);

/// The first candidate for `want` that the device offers, or std::nullopt.
std::optional<std::uint32_t> negotiate(PixelFormat want, const std::vector<std::uint32_t>& offered);

/// True when frames in `fourcc` must be converted (not viewed in place).
bool needsConversion(std::uint32_t fourcc);

/// "GREY", "YUYV", ... from a fourcc code.
std::string fourccName(std::uint32_t fourcc);

/// Packed YUYV 4:2:2 (Y0 U0 Y1 V0 per pixel pair, `bytesPerLine` per row) to
/// 8-bit grey: the luma samples, unchanged (full-range Y is the grey level).
/// `dst` must be CV_8UC1 of width x height.
void yuyvToGrey(const std::uint8_t* src, std::size_t bytesPerLine, int width, int height, cv::Mat& dst);

/// The crop a device chose for `asked` (VIDIOC_S_SELECTION adjusts instead
/// of refusing), as the region frames will cover; std::nullopt when it does
/// not contain `asked` or leaves `bounds` (then the crop must be undone).
std::optional<Roi> acceptedCrop(const Roi& asked, const Roi& chosen, const Roi& bounds);

} // namespace hg::drivers::v4l2
