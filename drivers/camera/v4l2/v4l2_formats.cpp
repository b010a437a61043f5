#include "v4l2_formats.h"

#include <algorithm>

#include <linux/videodev2.h>

namespace hg::drivers::v4l2 {

std::vector<std::uint32_t> candidateFourccs(PixelFormat want)
{
    switch (want) {
    case PixelFormat::Mono8:
        return {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_YUYV};
    case PixelFormat::Mono12:
        return {V4L2_PIX_FMT_Y12};
    case PixelFormat::Mono16:
        return {V4L2_PIX_FMT_Y16};
    }
    return {};
}

std::optional<std::uint32_t> negotiate(PixelFormat want, const std::vector<std::uint32_t>& offered)
{
    for (std::uint32_t c : candidateFourccs(want))
        if (std::find(offered.begin(), offered.end(), c) != offered.end()) return c;
    return std::nullopt;
}

bool needsConversion(std::uint32_t fourcc)
{
    return fourcc == V4L2_PIX_FMT_YUYV;
}

std::string fourccName(std::uint32_t fourcc)
{
    std::string s;
    for (int i = 0; i < 4; ++i) {
        char c = static_cast<char>((fourcc >> (8 * i)) & 0xff);
        s += (c >= 32 && c < 127) ? c : '?';
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

void yuyvToGrey(const std::uint8_t* src, std::size_t bytesPerLine, int width, int height, cv::Mat& dst)
{
    for (int r = 0; r < height; ++r) {
        const std::uint8_t* row = src + static_cast<std::size_t>(r) * bytesPerLine;
        auto* out = dst.ptr<std::uint8_t>(r);
        for (int c = 0; c < width; ++c) out[c] = row[2 * c]; // Y samples sit at even bytes
    }
}

namespace {
bool contains(const Roi& outer, const Roi& inner)
{
    return inner.x >= outer.x && inner.y >= outer.y && inner.x + inner.width <= outer.x + outer.width &&
           inner.y + inner.height <= outer.y + outer.height;
}
} // namespace

std::optional<Roi> acceptedCrop(const Roi& asked, const Roi& chosen, const Roi& bounds)
{
    if (chosen.width <= 0 || chosen.height <= 0 || !contains(chosen, asked) || !contains(bounds, chosen))
        return std::nullopt;
    return chosen;
}

} // namespace hg::drivers::v4l2
