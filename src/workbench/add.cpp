// Adding a part (docs/workbench.md, "Adding a part"): the CAD model read with
// every check of a part program's `mesh`, the part folder built under a
// temporary name in the workspace and renamed into place only when all of it
// is there; a refused model leaves nothing.
#include "hullgauge/common/digest.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/format.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/step_io.h"
#include "hullgauge/workbench/display.h"
#include "hullgauge/workbench/workspace.h"

#include "draft.h"
#include "part_files.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>

namespace hg::workbench {
namespace {

/// The CAD file's extension, lower case, when it is one the loader reads.
std::string cadExtension(const fs::path& file)
{
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    for (const char* known : {".stl", ".obj", ".ply", ".off", ".step", ".stp"})
        if (ext == known) return ext;
    throw InputError(file.string(), "",
                     "not a CAD model the station reads (STL, OBJ, PLY, OFF or STEP: .stl, .obj, .ply, .off, .step, "
                     ".stp)");
}

std::string partNameFor(const AddOptions& options, const fs::path& file)
{
    const std::string name = options.name.empty() ? file.stem().string() : options.name;
    if (!validPartName(name))
        throw InputError("", "name",
                         "'" + name +
                             "' is no part name: 1–64 letters, digits, '.', '_' or '-', starting with a letter or "
                             "digit (give one)");
    return name;
}

void checkOptions(const AddOptions& o)
{
    if (o.depth < 1 || o.depth > model::kMaxOctreeDepth)
        throw InputError("", "depth", "octree depth " + std::to_string(o.depth) + " is outside 1..15");
    if (o.adjacencyDepth < 1 || o.adjacencyDepth > 64)
        throw InputError("", "adjacency_depth",
                         "adjacency depth " + std::to_string(o.adjacencyDepth) + " is outside 1..64");
    if (!(o.toleranceMm > 0.0))
        throw InputError("", "tolerance_mm", "tolerance " + formatNumber(o.toleranceMm) + " mm is not positive");
}

/// A fresh folder in the workspace for a part being built: hidden, named by
/// the process and a counter, so two additions never share one.
fs::path stagingFolder(const fs::path& workspace, const std::string& name)
{
    static std::atomic<int> counter{0};
    return workspace / (".adding-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(++counter));
}

/// The loader's refusal, naming the file as the engineer gave it rather than its staged copy.
[[noreturn]] void refuse(const InputError& e, const fs::path& staged, const std::string& shownAs)
{
    std::string problem = e.problem();
    for (std::size_t at; (at = problem.find(staged.string())) != std::string::npos;)
        problem.replace(at, staged.string().size(), shownAs);
    throw InputError(e.file() == staged.string() ? shownAs : e.file(), e.field(), problem, e.line());
}

std::string kindOf(const std::string& extension)
{
    return extension == ".stp" ? "step" : extension.substr(1);
}

YAML::Node newDraft(const std::string& name, const std::string& cadName, const AddOptions& options)
{
    YAML::Node draft(YAML::NodeType::Map);
    draft["part"] = name;
    draft["mesh"] = cadName;
    if (!options.solid.empty()) draft["mesh_solid"] = options.solid;
    draft["octree"]["depth"] = options.depth;
    draft["octree"]["adjacency_depth"] = options.adjacencyDepth;
    YAML::Node landmarks(YAML::NodeType::Sequence);
    landmarks.SetStyle(YAML::EmitterStyle::Flow);
    draft["landmarks"] = landmarks;
    return draft;
}

/// The display meshes and the model's facts (display/).
void writeDisplay(const fs::path& staged, const model::CadModel& cad, const std::string& kind,
                  const std::string& cadSha256)
{
    const model::TriangleMesh& mesh = cad.solid->mesh();
    files::createFolders(staged / files::kDisplay);
    model::saveMesh(mesh, staged / files::kModelStl, model::MeshEncoding::Binary);
    files::syncFile(staged / files::kModelStl);
    const model::TriangleMesh lod = simplifiedMesh(mesh, kLodTriangles);
    model::saveMesh(lod, staged / files::kLodStl, model::MeshEncoding::Binary);
    files::syncFile(staged / files::kLodStl);
    const Eigen::AlignedBox3d bounds = cad.brep ? cad.brep->summary().bounds : mesh.bounds();
    const nlohmann::json facts = {{"kind", kind},
                                  {"triangles", mesh.triangles.size()},
                                  {"lod_triangles", lod.triangles.size()},
                                  {"bounds_mm", {geometry::toJson(bounds.min()), geometry::toJson(bounds.max())}},
                                  {"sha256", cadSha256}};
    writeFileDurably(staged / files::kModelFacts, facts.dump(2) + "\n");
}

} // namespace

PartState Workspace::add(const fs::path& cadFile, const AddOptions& options, const Actor& by)
{
    const std::string ext = cadExtension(cadFile);
    const std::string name = partNameFor(options, cadFile);
    std::error_code ec;
    if (!fs::is_regular_file(cadFile, ec)) throw InputError(cadFile.string(), "", "no such file");
    checkOptions(options);
    if (files::exists(folder_ / name))
        throw PartExists("", "name", "a part named '" + name + "' is already in the workspace " + folder_.string());
    files::createFolders(folder_);
    const fs::path staged = stagingFolder(folder_, name);
    try {
        files::createFolders(staged);
        files::copyFile(cadFile, staged / (name + ext));
        return addFrom(staged, name, cadFile.string(), options, by);
    } catch (...) {
        fs::remove_all(staged, ec);
        throw;
    }
}

PartState Workspace::addUpload(std::string_view fileName, std::string_view bytes, const AddOptions& options,
                               const Actor& by)
{
    const fs::path file = fs::path(std::string(fileName)).filename();
    const std::string ext = cadExtension(file);
    const std::string name = partNameFor(options, file);
    checkOptions(options);
    if (files::exists(folder_ / name))
        throw PartExists("", "name", "a part named '" + name + "' is already in the workspace " + folder_.string());
    files::createFolders(folder_);
    const fs::path staged = stagingFolder(folder_, name);
    std::error_code ec;
    try {
        files::createFolders(staged);
        writeFileDurably(staged / (name + ext), bytes);
        return addFrom(staged, name, file.string(), options, by);
    } catch (...) {
        fs::remove_all(staged, ec);
        throw;
    }
}

PartState Workspace::addFrom(const fs::path& staged, const std::string& name, const std::string& shownAs,
                             const AddOptions& options, const Actor& by)
{
    const std::string ext = cadExtension(shownAs);
    const std::string cadName = name + ext;
    const fs::path cadPath = staged / cadName;
    model::CadModel cad;
    try {
        cad = model::loadCadModel(cadPath, options.depth, options.adjacencyDepth, options.solid);
    } catch (const InputError& e) {
        refuse(e, cadPath, shownAs);
    }
    const std::string cadSha = sha256OfFile(cadPath);
    writeDisplay(staged, cad, kindOf(ext), cadSha);

    const std::string draftText = files::emitDraft(newDraft(name, cadName, options));
    writeFileDurably(files::draftFile(staged, name), draftText);
    const nlohmann::json cache = {{"draft_sha256", sha256Hex(draftText)}, {"landmarks", nlohmann::json::array()}};
    writeFileDurably(staged / files::kLandmarkCache, cache.dump(2) + "\n");
    PartRecord record;
    record.part = name;
    record.cad = cadName;
    record.revision = 0;
    record.toleranceMm = options.toleranceMm;
    files::recordChange(record, by, "added");
    writeFileDurably(staged / files::kRecord, files::recordYaml(record));
    syncFolder(staged / files::kDisplay);
    syncFolder(staged);
    if (!files::renameNoReplace(staged, folder_ / name))
        throw PartExists("", "name", "a part named '" + name + "' is already in the workspace " + folder_.string());
    return read(name);
}

} // namespace hg::workbench
