// hullgauge-gige-sim: a GigE Vision camera on a local address, built on
// Aravis' own fake GigE camera (ArvGvFakeCamera), which speaks the real
// GVCP (control) and GVSP (stream) protocols. The Aravis driver talks to it
// exactly as to a line camera, so CI exercises the real driver code.
//
// It serves grey images from PNG/TIFF files (or the views of a capture
// manifest, docs/contracts.md §3) one after the other, cycling; each frame the fake
// camera sends is the next image, cropped to the requested ROI and converted
// to the requested pixel format:
//   Mono8  : 8-bit images as is; 16-bit images >> 8
//   Mono12 : 8-bit << 4; 16-bit >> 4 (12 significant bits, unpacked in 16-bit words)
//   Mono16 : 8-bit * 257 (full scale); 16-bit as is
// The sensor size is the image size. Exposure and gain are device features
// (readable, writable) but do not alter the served pixels, so tests compare
// pixels exactly.
//
// Aravis' built-in fake description lacks Mono12 and the SFNC float features
// ExposureTime (µs) and Gain (dB); the simulator extends that description
// with them (over the fake's own registers) and serves the result.
//
// --region-increments gives the region features OffsetX/OffsetY/Width/Height
// a camera's coarser Inc (and Min of the sizes), --read-only-offset-x makes
// OffsetX read-only: the driver's region alignment and its fallback to whole
// frames are tested against them (docs/camera.md "Regions per grab").
//
// Prints "ready <address> <serial> <width>x<height> <n> images" on stdout once
// the control port listens; runs until SIGTERM/SIGINT.
#include <signal.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <arv.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace fs = std::filesystem;

namespace {

struct ImageSource {
    std::vector<cv::Mat> images; // CV_8UC1 or CV_16UC1, all the same size
    std::atomic<std::size_t> next{0};
    std::atomic<std::uint64_t> served{0};
};

cv::Mat loadGrey(const fs::path& file)
{
    cv::Mat m = cv::imread(file.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
    if (m.empty()) throw std::runtime_error(file.string() + ": cannot read image");
    if (m.channels() == 3)
        cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
    else if (m.channels() == 4)
        cv::cvtColor(m, m, cv::COLOR_BGRA2GRAY);
    if (m.depth() != CV_8U && m.depth() != CV_16U)
        throw std::runtime_error(file.string() + ": only 8- and 16-bit images can be served");
    return m;
}

std::vector<fs::path> imagesOfManifest(const fs::path& manifest)
{
    std::ifstream in(manifest);
    if (!in) throw std::runtime_error(manifest.string() + ": cannot open");
    nlohmann::json j;
    try {
        in >> j;
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error(manifest.string() + ": " + e.what());
    }
    std::vector<fs::path> out;
    if (!j.contains("views") || !j["views"].is_array())
        throw std::runtime_error(manifest.string() + ": views: expected an array");
    for (std::size_t i = 0; i < j["views"].size(); ++i) {
        const auto& v = j["views"][i];
        if (!v.contains("image") || !v["image"].is_string())
            throw std::runtime_error(manifest.string() + ": views[" + std::to_string(i) + "].image: expected a path");
        out.push_back(manifest.parent_path() / v["image"].get<std::string>());
    }
    return out;
}

std::vector<fs::path> imagesOfFolder(const fs::path& dir)
{
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(dir)) {
        auto ext = e.path().extension().string();
        for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".pgm") out.push_back(e.path());
    }
    std::sort(out.begin(), out.end());
    if (out.empty()) throw std::runtime_error(dir.string() + ": no PNG/TIFF/PGM images");
    return out;
}

/// The fake camera's fill-pattern hook: copies the next image (ROI crop) into
/// the GVSP payload buffer in the requested pixel format.
void fillFromImages(ArvBuffer* buffer, void* data, guint32 /*exposureUs*/, guint32 /*gain*/, ArvPixelFormat format)
{
    auto* src = static_cast<ImageSource*>(data);
    // The payload memory of the buffer the fake camera allocated for us to fill.
    // Its reported size is the bytes received so far (0 here); the fake camera
    // calls this hook only after checking that the allocation holds the payload
    // of the current Width x Height x pixel format, which is what is written.
    auto* out = static_cast<unsigned char*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
    const int w = arv_buffer_get_image_width(buffer);
    const int h = arv_buffer_get_image_height(buffer);
    const int x0 = arv_buffer_get_image_x(buffer);
    const int y0 = arv_buffer_get_image_y(buffer);
    const std::size_t index = src->next.fetch_add(1) % src->images.size();
    const cv::Mat& img = src->images[index];
    src->served.fetch_add(1);
    if (!out || w <= 0 || h <= 0 || x0 + w > img.cols || y0 + h > img.rows) return;
    const cv::Mat roi = img(cv::Rect(x0, y0, w, h));
    const bool eight = img.depth() == CV_8U;
    if (format == ARV_PIXEL_FORMAT_MONO_8) {
        cv::Mat dst(h, w, CV_8UC1, out);
        if (eight)
            roi.copyTo(dst);
        else // truncating >> 8 (convertTo would round)
            for (int r = 0; r < h; ++r)
                for (int c = 0; c < w; ++c) dst.at<uint8_t>(r, c) = static_cast<uint8_t>(roi.at<uint16_t>(r, c) >> 8);
    } else if (format == ARV_PIXEL_FORMAT_MONO_12 || format == ARV_PIXEL_FORMAT_MONO_16) {
        cv::Mat dst(h, w, CV_16UC1, out); // little-endian words, as GVSP carries Mono12/Mono16
        for (int r = 0; r < h; ++r)
            for (int c = 0; c < w; ++c) {
                const unsigned v = eight ? roi.at<uint8_t>(r, c) : roi.at<uint16_t>(r, c);
                unsigned o;
                if (format == ARV_PIXEL_FORMAT_MONO_12)
                    o = eight ? v << 4 : v >> 4;
                else
                    o = eight ? v * 257u : v;
                dst.at<uint16_t>(r, c) = static_cast<uint16_t>(o);
            }
    } else {
        // Formats the simulator does not model (Bayer, RGB) stay black.
        std::memset(out, 0, static_cast<size_t>(w) * h * ARV_PIXEL_FORMAT_BIT_PER_PIXEL(format) / 8);
    }
}

/// Inserts `text` before the first occurrence of `anchor` (or after, when
/// `after`); fails loudly when Aravis' description changed shape.
void insertAt(std::string& xml, const std::string& anchor, const std::string& text, bool after = false)
{
    auto pos = xml.find(anchor);
    if (pos == std::string::npos)
        throw std::runtime_error("the Aravis fake camera description has no '" + anchor + "'; cannot extend it");
    xml.insert(after ? pos + anchor.size() : pos, text);
}

/// How the region features of the description differ from Aravis' fake camera
/// (increments of 1, all writable), to stand for cameras that have coarser
/// increments or cannot move their region.
struct RegionFeatures {
    std::vector<int> increments{1, 1, 1, 1}; ///< Inc of OffsetX, OffsetY, Width, Height
    bool offsetXReadOnly = false;
};

/// Replaces the <Inc> of the Integer feature `name`, and makes it read-only
/// (ImposedAccessMode RO) when asked: the registers behind stay as they are.
void reshapeIntegerFeature(std::string& xml, const std::string& name, int increment, bool readOnly)
{
    const std::string open = "<Integer Name=\"" + name + "\"";
    const auto begin = xml.find(open);
    const auto end = begin == std::string::npos ? begin : xml.find("</Integer>", begin);
    const auto inc = begin == std::string::npos ? begin : xml.find("<Inc>1</Inc>", begin);
    if (end == std::string::npos || inc == std::string::npos || inc > end)
        throw std::runtime_error("the Aravis fake camera description has no '" + name +
                                 "' with <Inc>; cannot reshape it");
    xml.replace(inc, std::strlen("<Inc>1</Inc>"), "<Inc>" + std::to_string(increment) + "</Inc>");
    // A size of Min + k * Inc: with steps above 1 the smallest size is one step, as on GigE cameras.
    const auto min = xml.find("<Min>1</Min>", begin);
    if (min != std::string::npos && min < inc)
        xml.replace(min, std::strlen("<Min>1</Min>"), "<Min>" + std::to_string(increment) + "</Min>");
    if (readOnly) xml.insert(inc, "<ImposedAccessMode>RO</ImposedAccessMode>\n\t\t");
}

/// The fake camera's GenICam description, extended with Mono12 and the SFNC
/// features ExposureTime (µs, over the exposure register) and Gain (dB, stored
/// in tenths of a dB in the fake's raw gain register), its region features as
/// `region` says.
std::string extendedDescription(const RegionFeatures& region)
{
    ArvFakeCamera* plain = arv_fake_camera_new("HGSIMXML");
    size_t size = 0;
    const char* base = arv_fake_camera_get_genicam_xml(plain, &size);
    std::string xml(base ? base : "", size);
    g_object_unref(plain);
    if (xml.empty()) throw std::runtime_error("Aravis' fake camera has no GenICam description");

    insertAt(
        xml, "<EnumEntry Name=\"Mono16\"",
        "<EnumEntry Name=\"Mono12\" NameSpace=\"Standard\">\n\t\t\t<Value>17825797</Value>\n\t\t</EnumEntry>\n\t\t");
    insertAt(xml, "<Float Name=\"ExposureTimeAbs\"",
             "<Float Name=\"ExposureTime\" NameSpace=\"Standard\">\n"
             "\t\t<Description>Exposure duration, in microseconds.</Description>\n"
             "\t\t<pValue>ExposureTimeAbsConverter</pValue>\n"
             "\t\t<Min>10.0</Min>\n\t\t<Max>10000000.0</Max>\n\t\t<Unit>us</Unit>\n\t</Float>\n\n\t");
    insertAt(xml, "<Integer Name=\"GainRaw\"",
             "<Float Name=\"Gain\" NameSpace=\"Standard\">\n"
             "\t\t<Description>Analog gain, in dB.</Description>\n"
             "\t\t<pValue>GainDbConverter</pValue>\n"
             "\t\t<Min>0.0</Min>\n\t\t<Max>24.0</Max>\n\t\t<Unit>dB</Unit>\n\t</Float>\n\n"
             "\t<Converter Name=\"GainDbConverter\" NameSpace=\"Custom\">\n"
             "\t\t<FormulaTo>FROM * 10</FormulaTo>\n\t\t<FormulaFrom>TO / 10</FormulaFrom>\n"
             "\t\t<pValue>GainRawRegister</pValue>\n\t</Converter>\n\n\t");
    insertAt(xml, "<pFeature>ExposureTimeAbs</pFeature>", "\n\t\t<pFeature>ExposureTime</pFeature>", true);
    insertAt(xml, "<pFeature>GainRaw</pFeature>", "<pFeature>Gain</pFeature>\n\t\t");
    insertAt(xml, "<pFeature>AcquisitionControl</pFeature>", "\n\t\t<pFeature>AnalogControl</pFeature>", true);
    const char* names[] = {"OffsetX", "OffsetY", "Width", "Height"};
    for (int i = 0; i < 4; ++i)
        reshapeIntegerFeature(xml, names[i], region.increments[i], i == 0 && region.offsetXReadOnly);
    return xml;
}

} // namespace

int main(int argc, char** argv)
{
    CLI::App app{"hullgauge-gige-sim: GigE Vision camera simulator (Aravis fake camera over GVCP/GVSP) serving images"};
    std::string address = "127.0.0.1";
    std::string serial = "HGSIM0001";
    std::string imagesDir;
    std::string manifest;
    std::vector<std::string> imageFiles;
    double frameRate = 25.0;
    double triggerPollHz = 500.0;
    RegionFeatures region;
    app.add_option("--address", address, "IPv4 address of a local interface to serve on (default 127.0.0.1)");
    app.add_option("--serial", serial, "serial number the camera reports");
    auto* dirOpt = app.add_option("--images", imagesDir, "folder of images served in name order");
    auto* manOpt = app.add_option("--manifest", manifest, "capture manifest (JSON) whose view images are served");
    auto* fileOpt = app.add_option("--image", imageFiles, "an image to serve (repeatable, in order)");
    app.add_option("--frame-rate", frameRate, "free-run frame rate, frames per second")->check(CLI::Range(0.1, 1000.0));
    app.add_option("--trigger-poll-hz", triggerPollHz, "how often a software trigger is looked for, Hz")
        ->check(CLI::Range(1.0, 10000.0));
    app.add_option("--region-increments", region.increments,
                   "Inc of OffsetX, OffsetY, Width and Height (4 integers, default 1 1 1 1)")
        ->expected(4)
        ->delimiter(',')
        ->check(CLI::Range(1, 256));
    app.add_flag("--read-only-offset-x", region.offsetXReadOnly,
                 "make OffsetX read-only (a camera that cannot move its region)");
    dirOpt->excludes(manOpt)->excludes(fileOpt);
    manOpt->excludes(fileOpt);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int rc = app.exit(e);
        return rc == 0 ? 0 : 2;
    }

    // Block the stop signals before Aravis starts its threads, then wait for them here.
    sigset_t stopSignals;
    sigemptyset(&stopSignals);
    sigaddset(&stopSignals, SIGTERM);
    sigaddset(&stopSignals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);

    ImageSource source;
    fs::path xmlFile;
    try {
        std::vector<fs::path> files;
        if (!imagesDir.empty())
            files = imagesOfFolder(imagesDir);
        else if (!manifest.empty())
            files = imagesOfManifest(manifest);
        else
            for (auto& f : imageFiles) files.emplace_back(f);
        if (files.empty()) throw std::runtime_error("give --images DIR, --manifest FILE or --image FILE...");
        for (const auto& f : files) {
            source.images.push_back(loadGrey(f));
            const auto& first = source.images.front();
            const auto& last = source.images.back();
            if (last.size() != first.size() || last.depth() != first.depth())
                throw std::runtime_error(f.string() + ": size or bit depth differs from " + files.front().string());
        }
        if (serial.empty() || serial.size() >= 16) throw std::runtime_error("--serial: 1 to 15 characters");

        // The description is served from a file the fake camera reads at start.
        xmlFile = fs::temp_directory_path() / ("hullgauge-gige-sim-" + std::to_string(getpid()) + ".xml");
        std::ofstream(xmlFile) << extendedDescription(region);
    } catch (const std::exception& e) {
        std::cerr << "hullgauge-gige-sim: " << e.what() << '\n';
        return 2;
    }

    ArvGvFakeCamera* gv = arv_gv_fake_camera_new_full(address.c_str(), serial.c_str(), xmlFile.string().c_str());
    std::error_code ec;
    fs::remove(xmlFile, ec);
    if (!gv || !arv_gv_fake_camera_is_running(gv)) {
        std::cerr << "hullgauge-gige-sim: cannot serve on " << address
                  << " (no local interface with that address, or the GVCP port 3956 is taken)\n";
        if (gv) g_object_unref(gv);
        return 3;
    }
    ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(gv);
    const cv::Size sensor = source.images.front().size();
    const bool sixteen = source.images.front().depth() == CV_16U;
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_WIDTH, static_cast<guint32>(sensor.width));
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_HEIGHT, static_cast<guint32>(sensor.height));
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_WIDTH, static_cast<guint32>(sensor.width));
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_HEIGHT, static_cast<guint32>(sensor.height));
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_PIXEL_FORMAT,
                                   sixteen ? ARV_PIXEL_FORMAT_MONO_16 : ARV_PIXEL_FORMAT_MONO_8);
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US,
                                   static_cast<guint32>(1e6 / frameRate));
    arv_fake_camera_set_trigger_frequency(fake, triggerPollHz);
    arv_fake_camera_set_fill_pattern(fake, fillFromImages, &source);

    std::cout << "ready " << address << ' ' << serial << ' ' << sensor.width << 'x' << sensor.height << ' '
              << source.images.size() << " images" << std::endl;

    int sig = 0;
    sigwait(&stopSignals, &sig);
    g_object_unref(gv);
    std::cerr << "hullgauge-gige-sim: stopped after serving " << source.served.load() << " frames\n";
    return 0;
}
