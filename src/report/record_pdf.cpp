#include "hullgauge/report/record_pdf.h"

#include "hullgauge/common/error.h"

#include <cairo-pdf.h>
#include <cairo.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <utility>

namespace hg::report {
namespace {

using nlohmann::json;

// A4 portrait in PostScript points (1/72 in): 210 mm × 297 mm.
constexpr double kPageW = 595.275591;
constexpr double kPageH = 841.889764;
constexpr double kMargin = 42.0; // ≈ 15 mm, inside every printer's unprintable border
constexpr double kContentW = kPageW - 2 * kMargin;
constexpr double kBodyTop = 66.0;             // below the running header
constexpr double kBodyBottom = kPageH - 50.0; // above the footer
constexpr double kRowH = 13.0;

struct Landmark {
    std::string id, status, decision;
    std::optional<double> deviation, uncertainty, bracketMin, bracketMax, tolerance;
    std::optional<std::pair<double, double>> limits;
};

struct Record {
    std::int64_t id = 0;
    std::string time, serial, part, verdict, purpose, sha256;
    std::int64_t program = 0;
    std::optional<std::int64_t> version, startedMs, faultCode, cycleMs, triggerSeq, failed;
    std::optional<bool> manual;
    json alignment;
    std::vector<Landmark> landmarks;
};

// ---- the row, checked before anything is drawn ----------------------------------------------------------------

/// Reads the fields of one JSON object, naming `prefix` + key in every refusal.
class Fields {
  public:
    Fields(const json& object, std::string where, std::string prefix)
        : o_(object), where_(std::move(where)), prefix_(std::move(prefix))
    {
        if (!o_.is_object()) fail("", "not a JSON object");
    }
    [[noreturn]] void fail(const std::string& key, const std::string& problem) const
    {
        auto field = prefix_ + key;
        if (!field.empty() && field.back() == '.') field.pop_back();
        throw InputError(where_, field.empty() ? "row" : field, problem);
    }
    const json* find(const char* key) const
    {
        const auto it = o_.find(key);
        return it == o_.end() || it->is_null() ? nullptr : &*it;
    }
    std::string text(const char* key) const
    {
        const auto* v = find(key);
        if (!v) fail(key, "missing");
        if (!v->is_string()) fail(key, "not a string");
        return v->get<std::string>();
    }
    std::string optionalText(const char* key) const { return find(key) ? text(key) : std::string(); }
    std::int64_t integer(const char* key) const
    {
        const auto v = optionalInteger(key);
        if (!v) fail(key, "missing");
        return *v;
    }
    std::optional<std::int64_t> optionalInteger(const char* key) const
    {
        const auto* v = find(key);
        if (!v) return std::nullopt;
        if (!v->is_number_integer()) fail(key, "not a whole number");
        return v->get<std::int64_t>();
    }
    std::optional<double> number(const char* key) const
    {
        const auto* v = find(key);
        if (!v) return std::nullopt;
        if (!v->is_number()) fail(key, "not a number");
        return v->get<double>();
    }

  private:
    const json& o_;
    std::string where_;
    std::string prefix_;
};

Landmark landmarkOf(const json& l, const std::string& where, std::size_t index)
{
    const Fields f(l, where, "landmarks[" + std::to_string(index) + "].");
    Landmark m;
    m.id = f.text("id");
    m.status = f.text("status");
    m.decision = f.optionalText("decision");
    m.deviation = f.number("deviation_mm");
    m.uncertainty = f.number("uncertainty_mm");
    m.bracketMin = f.number("error_min_mm");
    m.bracketMax = f.number("error_max_mm");
    m.tolerance = f.number("tolerance_mm");
    if (const auto* limits = f.find("limits_mm")) {
        if (!limits->is_array() || limits->size() != 2 || !(*limits)[0].is_number() || !(*limits)[1].is_number())
            f.fail("limits_mm", "not a pair of numbers [lower, upper]");
        m.limits = std::pair((*limits)[0].get<double>(), (*limits)[1].get<double>());
    }
    if (!m.limits && !m.tolerance) f.fail("tolerance_mm", "missing (the landmark has no tolerance zone)");
    return m;
}

Record recordOf(const json& row)
{
    Record r;
    r.id = Fields(row, "", "").integer("id");
    const auto where = "result " + std::to_string(r.id);
    const Fields f(row, where, "");
    r.time = f.text("time");
    r.serial = f.text("serial");
    r.program = f.integer("program");
    r.part = f.text("part");
    r.verdict = f.text("verdict");
    r.purpose = f.optionalText("purpose");
    r.version = f.optionalInteger("program_version");
    r.sha256 = f.optionalText("program_sha256");
    r.startedMs = f.optionalInteger("started_unix_ms");
    r.faultCode = f.optionalInteger("fault_code");
    r.cycleMs = f.optionalInteger("cycle_ms");
    r.triggerSeq = f.optionalInteger("trigger_seq");
    r.failed = f.optionalInteger("landmarks_failed");
    if (const auto* manual = f.find("manual")) r.manual = manual->is_boolean() && manual->get<bool>();
    if (const auto* alignment = f.find("alignment"); alignment && alignment->is_object()) r.alignment = *alignment;
    const auto* landmarks = f.find("landmarks");
    if (!landmarks) f.fail("landmarks", "missing");
    if (!landmarks->is_array()) f.fail("landmarks", "not an array");
    for (std::size_t i = 0; i < landmarks->size(); ++i) r.landmarks.push_back(landmarkOf((*landmarks)[i], where, i));
    return r;
}

// ---- cairo ------------------------------------------------------------------------------------------------------

struct SurfaceFree {
    void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextFree {
    void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceFree>;
using Context = std::unique_ptr<cairo_t, ContextFree>;

struct PngBytes {
    const std::vector<unsigned char>& bytes;
    std::size_t at = 0;
};

cairo_status_t readPng(void* closure, unsigned char* data, unsigned int length)
{
    auto& in = *static_cast<PngBytes*>(closure);
    if (in.bytes.size() - in.at < length) return CAIRO_STATUS_READ_ERROR;
    std::copy_n(in.bytes.begin() + static_cast<std::ptrdiff_t>(in.at), length, data);
    in.at += length;
    return CAIRO_STATUS_SUCCESS;
}

struct DecodedView {
    std::string name;
    Surface image;
    int width = 0, height = 0;
};

DecodedView decode(const RecordView& view)
{
    // cairo reports every unreadable PNG as a bare status; the signature check names the common case.
    static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (view.png.size() < 8 || !std::equal(kSignature, kSignature + 8, view.png.begin()))
        throw InputError(view.name, "", "not a PNG image (no PNG signature)");
    PngBytes in{view.png};
    Surface image(cairo_image_surface_create_from_png_stream(readPng, &in));
    if (const auto status = cairo_surface_status(image.get()); status != CAIRO_STATUS_SUCCESS)
        throw InputError(view.name, "",
                         std::string("not a PNG image cairo can read: ") + cairo_status_to_string(status));
    const int width = cairo_image_surface_get_width(image.get());
    const int height = cairo_image_surface_get_height(image.get());
    return {view.name, std::move(image), width, height};
}

cairo_status_t writeTo(void* closure, const unsigned char* data, unsigned int length)
{
    auto* out = static_cast<std::ostream*>(closure);
    if (!out) return CAIRO_STATUS_SUCCESS; // the counting pass (pageCount) writes nowhere
    out->write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(length));
    return *out ? CAIRO_STATUS_SUCCESS : CAIRO_STATUS_WRITE_ERROR;
}

// ---- words and numbers ------------------------------------------------------------------------------------------

std::string mm(std::optional<double> v, int digits = 4)
{
    if (!v) return "—";
    char b[48];
    std::snprintf(b, sizeof b, "%.*f", digits, *v);
    return b;
}

std::string zoneText(const Landmark& l)
{
    return l.limits ? "[" + mm(l.limits->first) + ", " + mm(l.limits->second) + "]" : "±" + mm(l.tolerance);
}

/// Whether the landmark is read by its deviation (docs/hmi.md, "Landmark rows"): measured, and its
/// bracket placed the surface (ok, out of tolerance, uncertain); otherwise by its voxel bracket.
bool readByDeviation(const Landmark& l)
{
    return l.deviation && (l.status == "ok" || l.status == "out_of_tolerance" || l.status == "uncertain");
}

/// Whether the deviation and the bracket of |error| disagree by more than the bracket's width — a fault
/// of the inspection itself (docs/hmi.md, "Landmark rows"); an overflow's bracket is open above.
bool inspectionFault(const Landmark& l)
{
    if (!l.deviation || !l.bracketMin || !l.bracketMax) return false;
    const double width = *l.bracketMax - *l.bracketMin, e = std::abs(*l.deviation);
    return e < *l.bracketMin - width || (l.status != "overflow" && e > *l.bracketMax + width);
}

/// The voxel bracket where the bracket reads the landmark, or where it contradicts the deviation.
std::string bracketText(const Landmark& l)
{
    if ((readByDeviation(l) && !inspectionFault(l)) || (!l.bracketMin && !l.bracketMax)) return "";
    return "[" + mm(l.bracketMin) + ", " + mm(l.bracketMax) + "]";
}

std::string versionText(const Record& r)
{
    return r.version ? "version " + std::to_string(*r.version) : "draft (no release)";
}

/// The start time in the station's own zone, with the zone's name and offset.
std::string stationLocalTime(std::int64_t unixMs)
{
    const auto seconds = static_cast<std::time_t>(unixMs / 1000);
    std::tm tm{};
    localtime_r(&seconds, &tm);
    char b[64];
    std::strftime(b, sizeof b, "%Y-%m-%d %H:%M:%S %Z (UTC%z)", &tm);
    std::string text = b;
    // strftime writes the offset as +hhmm; ISO 8601's extended form is +hh:mm.
    text.insert(text.size() - 3, ":");
    return text;
}

std::string upper(std::string s)
{
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::toupper(c)); });
    return s;
}

// ---- drawing ----------------------------------------------------------------------------------------------------

struct Font {
    double size = 9.0;
    bool bold = false;
    bool mono = false;
};
enum class Align { Left, Right, Centre };

/// Lays the record out on the pages of one PDF surface; run twice (pageCount)
/// so that every footer can say "page k of n".
class RecordLayout {
  public:
    RecordLayout(cairo_t* cr, const Record& r, const std::vector<DecodedView>& views, const RecordOptions& options,
                 int totalPages)
        : cr_(cr), r_(r), views_(views), options_(options), totalPages_(totalPages)
    {
    }
    /// Draws every page; returns how many.
    int draw()
    {
        startPage();
        summary();
        alignment();
        landmarkTable();
        viewPages();
        cairo_show_page(cr_);
        return page_;
    }

  private:
    void show(const std::string& s, double x, double baseline, Font f, Align align = Align::Left, double width = 0);
    void startPage();
    void newPage(const std::string& heading);
    void heading(const std::string& text);
    void fact(const std::string& key, const std::string& value, Font f = {});
    void summary();
    void alignment();
    void landmarkTable();
    void tableHeader();
    void landmarkRow(const Landmark& l);
    void viewPages();

    cairo_t* cr_;
    const Record& r_;
    const std::vector<DecodedView>& views_;
    const RecordOptions& options_;
    int totalPages_;
    int page_ = 0;
    double y_ = kBodyTop;
};

/// One line of text; shrunk to at most `width` (down to 60 %), then cut with an ellipsis.
void RecordLayout::show(const std::string& s, double x, double baseline, Font f, Align align, double width)
{
    cairo_select_font_face(cr_, f.mono ? "DejaVu Sans Mono" : "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                           f.bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr_, f.size);
    std::string text = s;
    cairo_text_extents_t e{};
    cairo_text_extents(cr_, text.c_str(), &e);
    if (width > 0 && e.x_advance > width) {
        // 2 % below the proportional size: hinted advances do not scale exactly.
        cairo_set_font_size(cr_, std::max(f.size * 0.6, 0.98 * f.size * width / e.x_advance));
        cairo_text_extents(cr_, text.c_str(), &e);
        while (e.x_advance > width && text.size() > 1) {
            // Cut whole UTF-8 characters: drop continuation bytes with their lead byte.
            while (!text.empty() && (static_cast<unsigned char>(text.back()) & 0xC0) == 0x80) text.pop_back();
            if (!text.empty()) text.pop_back();
            const auto cut = text + "…";
            cairo_text_extents(cr_, cut.c_str(), &e);
            if (e.x_advance <= width) text = cut;
        }
    }
    const double dx = align == Align::Right ? -e.x_advance : align == Align::Centre ? -e.x_advance / 2 : 0.0;
    cairo_move_to(cr_, x + dx, baseline);
    cairo_show_text(cr_, text.c_str());
}

/// A new page with the running header (station, serial, time) and the footer.
void RecordLayout::startPage()
{
    ++page_;
    y_ = kBodyTop;
    cairo_set_source_rgb(cr_, 0, 0, 0);
    const Font small{7.5};
    show(options_.station.empty() ? "" : "Station " + options_.station, kMargin, 34, small, Align::Left, 170);
    show("Serial " + (r_.serial.empty() ? std::string("(none)") : r_.serial), kPageW / 2, 34, {7.5, true},
         Align::Centre, 170);
    show(r_.time, kPageW - kMargin, 34, small, Align::Right, 170);
    cairo_set_line_width(cr_, 0.6);
    cairo_move_to(cr_, kMargin, 40);
    cairo_line_to(cr_, kPageW - kMargin, 40);
    cairo_move_to(cr_, kMargin, kPageH - 38);
    cairo_line_to(cr_, kPageW - kMargin, kPageH - 38);
    cairo_stroke(cr_);
    show("hullgauge part record, result " + std::to_string(r_.id), kMargin, kPageH - 28, small);
    if (options_.generatedUnixMs) {
        char made[32];
        const auto seconds = static_cast<std::time_t>(*options_.generatedUnixMs / 1000);
        std::tm tm{};
        gmtime_r(&seconds, &tm);
        std::strftime(made, sizeof made, "%Y-%m-%dT%H:%M:%SZ", &tm);
        show(std::string("made ") + made, kPageW / 2, kPageH - 28, small, Align::Centre);
    }
    const auto of = totalPages_ > 0 ? " of " + std::to_string(totalPages_) : std::string();
    show("page " + std::to_string(page_) + of, kPageW - kMargin, kPageH - 28, small, Align::Right);
}

void RecordLayout::newPage(const std::string& title)
{
    cairo_show_page(cr_);
    startPage();
    if (!title.empty()) heading(title);
}

void RecordLayout::heading(const std::string& text)
{
    y_ += 8;
    show(text, kMargin, y_ + 11, {11, true});
    y_ += 18;
}

void RecordLayout::fact(const std::string& key, const std::string& value, Font f)
{
    show(key, kMargin, y_ + 10, {9});
    show(value, kMargin + 130, y_ + 10, f, Align::Left, kContentW - 130);
    y_ += kRowH;
}

/// The title, the verdict large and the part's facts.
void RecordLayout::summary()
{
    show("Part record", kMargin, y_ + 20, {20, true});
    show("Result " + std::to_string(r_.id), kMargin, y_ + 38, {10});
    // The verdict in a box: black on white, readable on any printer.
    const double boxW = 180, boxH = 58, boxX = kPageW - kMargin - boxW;
    cairo_set_line_width(cr_, 2.0);
    cairo_rectangle(cr_, boxX, y_, boxW, boxH);
    cairo_stroke(cr_);
    show(upper(r_.verdict), boxX + boxW / 2, y_ + 42, {32, true}, Align::Centre, boxW - 12);
    y_ += boxH + 14;
    if (!options_.station.empty()) fact("Station", options_.station);
    fact("Serial", r_.serial.empty() ? "(none)" : r_.serial, {9, true});
    fact("Part", r_.part);
    fact("Program", std::to_string(r_.program));
    fact("Program version", versionText(r_), {9, true});
    if (!r_.sha256.empty()) fact("Program SHA-256", r_.sha256, {7.5, false, true});
    fact("Time (UTC)", r_.time);
    if (r_.startedMs) fact("Time (station)", stationLocalTime(*r_.startedMs));
    if (!r_.purpose.empty()) fact("Purpose", r_.purpose);
    if (r_.manual && r_.triggerSeq)
        fact("Trigger",
             std::string(*r_.manual ? "maintenance" : "PLC") + ", sequence " + std::to_string(*r_.triggerSeq));
    fact("Verdict", r_.verdict, {9, true});
    if (r_.faultCode) fact("Fault code", *r_.faultCode == 0 ? "0 (none)" : std::to_string(*r_.faultCode));
    if (r_.cycleMs) fact("Cycle time", std::to_string(*r_.cycleMs) + " ms");
    const auto failed = r_.failed ? *r_.failed
                                  : std::count_if(r_.landmarks.begin(), r_.landmarks.end(),
                                                  [](const Landmark& l) { return l.status != "ok"; });
    fact("Landmarks failed", std::to_string(failed) + " of " + std::to_string(r_.landmarks.size()));
}

/// The seat the station measured in the nest (docs/alignment.md), when the cycle measured one.
void RecordLayout::alignment()
{
    if (!r_.alignment.is_object()) return;
    const auto& a = r_.alignment;
    auto number = [&](const char* key) {
        const auto it = a.find(key);
        return it != a.end() && it->is_number() ? std::optional<double>(it->get<double>()) : std::nullopt;
    };
    heading("Alignment");
    if (a.contains("measured") && a["measured"].is_boolean() && !a["measured"].get<bool>()) {
        const auto message = a.contains("message") && a["message"].is_string() ? a["message"].get<std::string>() : "";
        fact("Seat", "not measured" + (message.empty() ? std::string() : ": " + message));
        return;
    }
    fact("Seat shift", mm(number("shift_mm"), 4) + " mm (U " + mm(number("shift_uncertainty_mm"), 4) + " mm)");
    fact("Seat rotation", mm(number("rotation_deg"), 3) + "° (U " + mm(number("rotation_uncertainty_deg"), 3) + "°)");
    if (const auto residual = number("residual_px")) fact("Residual", mm(residual, 2) + " px");
    if (a.contains("within_limits") && a["within_limits"].is_boolean())
        fact("Within the nest's limits", a["within_limits"].get<bool>() ? "yes" : "no");
}

// The landmark table's columns: left edge and width (pt, from the margin).
struct Column {
    const char* title;
    double x, width;
    Align align;
};
constexpr Column kColumns[] = {{"Landmark", 0, 104, Align::Left},       {"Status", 108, 72, Align::Left},
                               {"Deviation mm", 184, 58, Align::Right}, {"U mm", 246, 36, Align::Right},
                               {"Zone mm", 290, 80, Align::Left},       {"Decision", 372, 62, Align::Left},
                               {"Bracket mm", 436, 75.28, Align::Left}};

void RecordLayout::tableHeader()
{
    for (const auto& c : kColumns) {
        const double x = kMargin + c.x + (c.align == Align::Right ? c.width : 0);
        show(c.title, x, y_ + 10, {8, true}, c.align, c.width);
    }
    cairo_set_line_width(cr_, 0.8);
    cairo_move_to(cr_, kMargin, y_ + kRowH);
    cairo_line_to(cr_, kPageW - kMargin, y_ + kRowH);
    cairo_stroke(cr_);
    y_ += kRowH + 2;
}

void RecordLayout::landmarkRow(const Landmark& l)
{
    const bool bad = l.status != "ok";
    const std::string cells[] = {l.id,
                                 statusWords(l.status),
                                 readByDeviation(l) ? mm(l.deviation) : "",
                                 readByDeviation(l) ? mm(l.uncertainty) : "",
                                 zoneText(l),
                                 inspectionFault(l)                          ? "inspection fault"
                                 : readByDeviation(l) && !l.decision.empty() ? decisionWords(l.decision)
                                                                             : "",
                                 bracketText(l)};
    for (std::size_t i = 0; i < std::size(kColumns); ++i) {
        const auto& c = kColumns[i];
        const double x = kMargin + c.x + (c.align == Align::Right ? c.width : 0);
        show(cells[i], x, y_ + 9.5, {8, bad && (i == 0 || i == 1)}, c.align, c.width);
    }
    cairo_set_line_width(cr_, 0.3);
    cairo_move_to(cr_, kMargin, y_ + kRowH - 1);
    cairo_line_to(cr_, kPageW - kMargin, y_ + kRowH - 1);
    cairo_stroke(cr_);
    y_ += kRowH;
}

/// Every landmark, the table's head repeated on each page it runs onto.
void RecordLayout::landmarkTable()
{
    if (y_ + 18 + 2 * kRowH > kBodyBottom) newPage("");
    heading("Landmarks (" + std::to_string(r_.landmarks.size()) + ")");
    tableHeader();
    for (const auto& l : r_.landmarks) {
        if (y_ + kRowH > kBodyBottom) {
            newPage("Landmarks (continued)");
            tableHeader();
        }
        landmarkRow(l);
    }
    if (r_.landmarks.empty()) show("The program has no landmarks.", kMargin, y_ + 10, {9});
    if (y_ + 3 * kRowH > kBodyBottom) newPage("");
    show("Deviation: signed, outward positive; U: its expanded uncertainty (k = 2).", kMargin, y_ + 16, {7});
    show("Bracket: where no deviation was measured, the interval the surface lies in from the voxels.", kMargin,
         y_ + 26, {7});
    y_ += 3 * kRowH;
}

/// The annotated views after the table, on pages of their own; each one whole on a page.
void RecordLayout::viewPages()
{
    newPage("Annotated views");
    if (views_.empty()) {
        show("No images archived for this part.", kMargin, y_ + 10, {9});
        return;
    }
    const double fullHeight = kBodyBottom - kBodyTop - 18;
    for (const auto& v : views_) {
        const double scale = std::min(kContentW / v.width, fullHeight / v.height);
        const double h = v.height * scale, w = v.width * scale;
        if (y_ + h + 16 > kBodyBottom) newPage("");
        cairo_save(cr_);
        cairo_translate(cr_, kMargin + (kContentW - w) / 2, y_);
        cairo_scale(cr_, scale, scale);
        cairo_set_source_surface(cr_, v.image.get(), 0, 0);
        cairo_paint(cr_);
        cairo_restore(cr_);
        y_ += h;
        show(v.name + " (" + std::to_string(v.width) + " × " + std::to_string(v.height) + " px)", kPageW / 2, y_ + 11,
             {8}, Align::Centre, kContentW);
        y_ += 22;
    }
}

/// Draws the record on a new PDF surface writing to `out` (nowhere: null); returns its page count.
int render(std::ostream* out, const Record& r, const std::vector<DecodedView>& views, const RecordOptions& options,
           int totalPages)
{
    Surface pdf(cairo_pdf_surface_create_for_stream(writeTo, out, kPageW, kPageH));
    const auto title = "hullgauge part record " + std::to_string(r.id) + " " + r.serial;
    cairo_pdf_surface_set_metadata(pdf.get(), CAIRO_PDF_METADATA_TITLE, title.c_str());
    cairo_pdf_surface_set_metadata(pdf.get(), CAIRO_PDF_METADATA_CREATOR, "hullgauge");
    int pages = 0;
    {
        Context cr(cairo_create(pdf.get()));
        pages = RecordLayout(cr.get(), r, views, options, totalPages).draw();
        if (const auto status = cairo_status(cr.get()); status != CAIRO_STATUS_SUCCESS)
            throw FaultError(std::string("part record ") + std::to_string(r.id) +
                             ": cairo could not draw it: " + cairo_status_to_string(status));
    }
    cairo_surface_finish(pdf.get());
    if (const auto status = cairo_surface_status(pdf.get()); status != CAIRO_STATUS_SUCCESS)
        throw FaultError(std::string("part record ") + std::to_string(r.id) +
                         ": the PDF could not be written: " + cairo_status_to_string(status));
    return pages;
}

} // namespace

std::string statusWords(std::string_view status)
{
    static const std::pair<std::string_view, const char*> kWords[] = {{"ok", "ok"},
                                                                      {"out_of_tolerance", "out of tolerance"},
                                                                      {"overflow", "out of range"},
                                                                      {"not_found", "not found"},
                                                                      {"not_observable", "not observable"},
                                                                      {"not_inspected", "not inspected"},
                                                                      {"uncertain", "uncertain"}};
    for (const auto& [name, words] : kWords)
        if (status == name) return words;
    return std::string(status);
}

std::string decisionWords(std::string_view decision)
{
    if (decision == "conforms") return "conforms";
    if (decision == "nonconforms") return "does not conform";
    if (decision == "uncertain") return "undecided";
    return std::string(decision);
}

std::string recordFileName(const json& row)
{
    const auto id = Fields(row, "", "").integer("id");
    std::string serial = row.value("serial", "");
    for (char& c : serial)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-') c = '_';
    return "hullgauge-record-" + std::to_string(id) + (serial.empty() ? "" : "-" + serial) + ".pdf";
}

void writeRecordPdf(std::ostream& out, const json& row, const std::vector<RecordView>& views,
                    const RecordOptions& options)
{
    const auto record = recordOf(row);
    std::vector<DecodedView> decoded;
    for (const auto& v : views) decoded.push_back(decode(v));
    // The first pass counts the pages, so that the second's footers say "page k of n".
    const int pages = render(nullptr, record, decoded, options, 0);
    render(&out, record, decoded, options, pages);
    out.flush();
    if (!out) throw FaultError("part record " + std::to_string(record.id) + ": the PDF could not be written");
}

} // namespace hg::report
