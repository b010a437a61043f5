// STEP import through Open CASCADE (docs/part-program.md, "STEP parts"): the
// one translation unit compiled against it (src/CMakeLists.txt).
#include "hullgauge/model/step_io.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <BRepAdaptor_Surface.hxx>
#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBndLib.hxx>
#include <BRepBuilderAPI_MakeVertex.hxx>
#include <BRepExtrema_DistShapeShape.hxx>
#include <BRepGProp.hxx>
#include <BRepLProp_SLProps.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GProp_GProps.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <IFSelect_WorkLibrary.hxx>
#include <Interface_Check.hxx>
#include <Interface_EntityIterator.hxx>
#include <Interface_Graph.hxx>
#include <Interface_InterfaceModel.hxx>
#include <Interface_Protocol.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPCAFControl_Reader.hxx>
#include <STEPControl_Controller.hxx>
#include <Standard_Failure.hxx>
#include <StepGeom_CartesianPoint.hxx>
#include <StepGeom_Pcurve.hxx>
#include <StepRepr_DefinitionalRepresentation.hxx>
#include <StepShape_Edge.hxx>
#include <StepShape_OrientedEdge.hxx>
#include <StepShape_VertexPoint.hxx>
#include <TCollection_AsciiString.hxx>
#include <TDF_Label.hxx>
#include <TDF_LabelSequence.hxx>
#include <TDataStd_Name.hxx>
#include <TDocStd_Document.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedDataMapOfShapeListOfShape.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopTools_ListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <TopoDS_Shell.hxx>
#include <TopoDS_Vertex.hxx>
#include <XCAFDoc_DocumentTool.hxx>
#include <XCAFDoc_ShapeTool.hxx>
#include <XSControl_WorkSession.hxx>
#include <nlohmann/json.hpp>
#include <spdlog/fmt/fmt.h>

#include "hullgauge/common/child_process.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "hullgauge/model/mesh_io.h"

namespace hg::model {

struct StepModel::Impl {
    std::string name; // the file, as errors name it
    TopoDS_Shape shape;
    TopTools_IndexedMapOfShape faces;
    StepSummary summary;
    StepTessellation tessellation;
};

namespace {

Eigen::Vector3d toEigen(const gp_Pnt& p)
{
    return {p.X(), p.Y(), p.Z()};
}

[[noreturn]] void fail(const std::string& name, const std::string& problem)
{
    throw InputError(name, "mesh", problem);
}

// Open CASCADE writes its reader's diagnostics to standard output through a
// process-wide messenger; the command line promises one line on stderr for
// bad input (README, "The tools") and JSON alone on stdout, so the printer
// goes once, and the problems are reported as InputError instead.
void silenceOpenCascade()
{
    static std::once_flag once;
    std::call_once(once, [] {
        Message::DefaultMessenger()->RemovePrinters(STANDARD_TYPE(Message_PrinterOStream));
        // Coordinates in millimetres whatever unit the file declares (the
        // parameter exists once the STEP controller is initialised).
        STEPControl_Controller::Init();
        Interface_Static::SetCVal("xstep.cascade.unit", "MM");
    });
}

std::string fileText(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A STEP exchange file ends with END-ISO-10303-21; (ISO 10303-21): a file
// cut short in transfer is told apart from a damaged one before parsing.
bool endsLikeStep(std::string_view text)
{
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
    constexpr std::string_view end = "END-ISO-10303-21;";
    return text.size() >= end.size() && text.substr(text.size() - end.size()) == end;
}

// The end of the string or comment opening at `i`, counting its line breaks
// into `line`. A string ends where Open CASCADE's lexer ends it, so that this
// scan sees the instances its parser will: at a quote followed, after spaces
// and line breaks, by ',' or ')'. A quote elsewhere, '' among them, is part
// of the string (`'it's',` is read whole); in a well-formed file the rule
// agrees with ISO 10303-21's doubled quote.
std::size_t skipStringOrComment(std::string_view text, std::size_t i, std::size_t& line)
{
    std::size_t stop = text.size();
    if (text[i] == '\'') {
        for (std::size_t quote = text.find('\'', i + 1); quote != std::string_view::npos;
             quote = text.find('\'', quote + 1)) {
            std::size_t k = quote + 1;
            while (k < text.size() && (text[k] == ' ' || text[k] == '\n' || text[k] == '\r')) ++k;
            if (k < text.size() && (text[k] == ',' || text[k] == ')')) {
                stop = quote + 1;
                break;
            }
        }
    } else if (const std::size_t end = text.find("*/", i + 2); end != std::string_view::npos) {
        stop = end + 2;
    }
    line += static_cast<std::size_t>(std::count(text.begin() + static_cast<std::ptrdiff_t>(i),
                                                text.begin() + static_cast<std::ptrdiff_t>(stop), '\n'));
    return stop;
}

// An instance's entity type after its `=`: a keyword (a letter, then
// letters, digits and underscores; `!` first for a user-defined one) before
// its parameters' `(`, for a complex instance after its own `(`. Empty when
// it is one, else the text found there (printable ASCII, the rest as '?').
std::string entityTypeProblem(std::string_view text, std::size_t at)
{
    const auto blank = [&](std::size_t k) {
        return k < text.size() && std::isspace(static_cast<unsigned char>(text[k]));
    };
    const auto keyword = [&](std::size_t k) {
        return k < text.size() && (std::isalnum(static_cast<unsigned char>(text[k])) || text[k] == '_');
    };
    std::size_t k = at;
    while (blank(k)) ++k;
    const std::size_t start = k;
    if (k < text.size() && text[k] == '(') // a complex instance: its first part's keyword and '('
        for (++k; blank(k);) ++k;
    if (k < text.size() && (std::isalpha(static_cast<unsigned char>(text[k])) || text[k] == '!')) {
        for (++k; keyword(k);) ++k;
        while (blank(k)) ++k;
        if (k < text.size() && text[k] == '(') return {};
    }
    std::string found(text.substr(start, std::min<std::size_t>(16, text.size() - start)));
    for (char& c : found)
        if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
    return found.empty() ? "the end of the file" : "'" + found + "'";
}

// ISO 10303-21 names each entity instance once (`#12 = TYPE(...);`). Open
// CASCADE's parser resolves the references of a file that names one twice in
// a second pass over tables it leaves partly unset, and hung or crashed
// there as what memory held had it; an instance whose type is no keyword
// (a fuzzed `#21 = 14StepShape_EdgeEDGE_CURVE(...)`) it loaded as a null it
// then dereferenced, and a name beyond an int wrapped into the negative
// numbers it marks lists with (docs/fuzzing.md, "Findings, fixed"). Such a
// file is refused before it is parsed, naming the instance and its line
// (both lines for a name defined twice).
void requireWellFormedInstances(const std::string& name, std::string_view text)
{
    std::unordered_map<std::string_view, std::size_t> defined; // instance name -> its line
    std::size_t line = 1;
    int depth = 0; // parentheses: a name outside them, followed by '=', is an instance's
    for (std::size_t i = 0; i < text.size();) {
        const char c = text[i];
        if (c == '\'' || (c == '/' && i + 1 < text.size() && text[i + 1] == '*')) {
            i = skipStringOrComment(text, i, line);
            continue;
        }
        ++i;
        if (c == '\n') ++line;
        depth += c == '(' ? 1 : c == ')' ? -1 : 0;
        if (c == ';') depth = 0;
        if (c != '#') continue;
        const std::size_t digits = i;
        while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
        std::string_view number = text.substr(digits, i - digits);
        while (number.size() > 1 && number.front() == '0') number.remove_prefix(1); // #012 is #12
        // The reader holds a name in an int; one beyond wraps into its markers for lists.
        if (number.size() > 10 || (number.size() == 10 && number > "2147483647"))
            fail(name, fmt::format("not a consistent STEP file: line {}: the entity name #{} is beyond 2147483647",
                                   line, number));
        if (depth > 0) continue;
        std::size_t after = i;
        while (after < text.size() && (text[after] == ' ' || text[after] == '\t' || text[after] == '\r')) ++after;
        if (number.empty() || after >= text.size() || text[after] != '=') continue;
        const auto [first, isNew] = defined.emplace(number, line);
        if (!isNew)
            fail(name, fmt::format("not a consistent STEP file: entity #{} is defined twice (lines {} and {})", number,
                                   first->second, line));
        if (const std::string problem = entityTypeProblem(text, after + 1); !problem.empty())
            fail(name,
                 fmt::format("not a consistent STEP file: entity #{} (line {}): no entity type after '=', found {}",
                             number, line, problem));
    }
}

// "2 shells, 6 faces": what a file without a solid holds instead.
std::string describeContent(const TopoDS_Shape& shape)
{
    std::vector<std::string> parts;
    const std::array<std::pair<TopAbs_ShapeEnum, const char*>, 4> kinds = {
        {{TopAbs_SHELL, "shell"}, {TopAbs_FACE, "face"}, {TopAbs_WIRE, "wire"}, {TopAbs_EDGE, "edge"}}};
    for (const auto& [kind, word] : kinds) {
        TopTools_IndexedMapOfShape map;
        TopExp::MapShapes(shape, kind, map);
        if (map.Extent() > 0) parts.push_back(fmt::format("{} {}{}", map.Extent(), word, map.Extent() == 1 ? "" : "s"));
    }
    if (parts.empty()) return "nothing";
    // Edges of one face only (seams and degenerate edges aside) leave the surface open.
    TopTools_IndexedDataMapOfShapeListOfShape edgeFaces;
    TopExp::MapShapesAndAncestors(shape, TopAbs_EDGE, TopAbs_FACE, edgeFaces);
    int freeEdges = 0;
    for (int i = 1; i <= edgeFaces.Extent(); ++i) {
        const TopoDS_Edge& edge = TopoDS::Edge(edgeFaces.FindKey(i));
        const TopTools_ListOfShape& faces = edgeFaces(i);
        if (!BRep_Tool::Degenerated(edge) && faces.Extent() == 1 &&
            !BRep_Tool::IsClosed(edge, TopoDS::Face(faces.First())))
            ++freeEdges;
    }
    const std::string text = fmt::format("{}", fmt::join(parts, ", "));
    return freeEdges == 0 ? text : fmt::format("{} ({} free edges: the surface is not closed)", text, freeEdges);
}

/// A solid of the file's product tree, its bodies placed in the file's frame.
struct TreeEntry {
    StepSolid info;
    TopTools_IndexedMapOfShape solids;
};

/// The file as the reader's XCAF document holds it.
struct ProductTree {
    TopoDS_Compound content; // every free shape: what a file without a solid holds instead
    std::vector<TreeEntry> entries;
};

std::string labelName(const TDF_Label& label)
{
    Handle(TDataStd_Name) attribute;
    if (!label.FindAttribute(TDataStd_Name::GetID(), attribute)) return {};
    // No replacement character: the name is converted to UTF-8 as it is.
    return TCollection_AsciiString(attribute->Get()).ToCString();
}

// Open CASCADE names an instance it was given no name for by a link to its
// product's label ("=>[0:1:1:2]"), which no CAD system shows: no name.
std::string instanceName(const TDF_Label& component)
{
    const std::string name = labelName(component);
    return name.rfind("=>[", 0) == 0 ? std::string() : name;
}

// The leaves of the product tree below `label`, placed by the locations of
// the instances above them (docs/part-program.md, "STEP parts").
void collect(const TDF_Label& label, const TopLoc_Location& placement, const std::string& instance, ProductTree& tree)
{
    if (XCAFDoc_ShapeTool::IsAssembly(label)) {
        TDF_LabelSequence components;
        XCAFDoc_ShapeTool::GetComponents(label, components, /*getsubchilds=*/false);
        for (int i = 1; i <= components.Length(); ++i) {
            TDF_Label product;
            if (!XCAFDoc_ShapeTool::GetReferredShape(components(i), product)) continue;
            collect(product, placement * XCAFDoc_ShapeTool::GetLocation(components(i)), instanceName(components(i)),
                    tree);
        }
        return;
    }
    TreeEntry entry;
    TopExp::MapShapes(XCAFDoc_ShapeTool::GetShape(label).Moved(placement), TopAbs_SOLID, entry.solids);
    if (entry.solids.Extent() == 0) return; // a surface or a sketch in the tree: nothing to inspect
    entry.info.name = labelName(label);
    entry.info.instance = instance;
    entry.info.solids = static_cast<std::size_t>(entry.solids.Extent());
    tree.entries.push_back(std::move(entry));
}

// Open CASCADE's reader loads a file whose references dangle, or point to an
// entity of the wrong type, and records a failure for each, leaving the
// field null; the transfer then dereferences the null (docs/fuzzing.md,
// "Findings, fixed"). A file with load failures is refused before transfer,
// naming the first entity and what was wrong with it.
void requireConsistentEntities(const std::string& name, const Handle(Interface_InterfaceModel) & model)
{
    int failures = 0;
    std::string first;
    for (Standard_Integer i = 1; i <= model->NbEntities(); ++i) {
        const Handle(Interface_Check) check = model->Check(i, /*syntactic=*/true);
        if (check.IsNull() || check->NbFails() == 0) continue;
        if (first.empty())
            first = fmt::format("entity {}: {}", model->StringLabel(model->Value(i))->ToCString(),
                                check->CFail(1, /*final=*/true));
        failures += check->NbFails();
    }
    if (failures > 0)
        fail(name, fmt::format("not a consistent STEP file: {}{}", first,
                               failures > 1 ? fmt::format(" (and {} more failures)", failures - 1) : ""));
}

// The entities of a part's geometry and topology refer to one another as a
// tree shared from below: a point is used by many vertices, but no entity is
// (through others) part of itself. Open CASCADE follows the references
// recursively when it translates them, so a cycle overflowed the stack: an
// oriented edge that is its own edge (in the reader's own checks), a surface
// curve that is its own 3D curve (StepToGeom::MakeCurve; docs/fuzzing.md,
// "Findings, fixed"). A file with a cycle is refused before any of that,
// naming the entities around it. Depth-first, without recursion: a chain of
// references in a real file is as long as the file.
void requireAcyclicReferences(const std::string& name, const Handle(Interface_InterfaceModel) & model,
                              const Handle(Interface_Protocol) & protocol)
{
    const Interface_Graph graph(model, protocol, /*theModeStats=*/false);
    const Standard_Integer count = model->NbEntities();
    enum class Mark : std::uint8_t { unseen, open, done };
    std::vector<Mark> mark(static_cast<std::size_t>(count) + 1, Mark::unseen);
    struct Frame {
        Standard_Integer entity;
        Interface_EntityIterator shared;
    };
    for (Standard_Integer root = 1; root <= count; ++root) {
        if (mark[static_cast<std::size_t>(root)] != Mark::unseen) continue;
        std::vector<Frame> path{{root, graph.Shareds(model->Value(root))}};
        mark[static_cast<std::size_t>(root)] = Mark::open;
        while (!path.empty()) {
            Interface_EntityIterator& next = path.back().shared;
            if (!next.More()) {
                mark[static_cast<std::size_t>(path.back().entity)] = Mark::done;
                path.pop_back();
                continue;
            }
            const Standard_Integer entity = graph.EntityNumber(next.Value());
            next.Next();
            if (entity <= 0 || entity > count) continue;
            if (mark[static_cast<std::size_t>(entity)] == Mark::open) {
                std::vector<std::string> cycle;
                auto from = std::find_if(path.begin(), path.end(), [&](const Frame& f) { return f.entity == entity; });
                for (; from != path.end(); ++from)
                    cycle.emplace_back(model->StringLabel(model->Value(from->entity))->ToCString());
                cycle.push_back(cycle.front());
                if (cycle.size() > 8) { // a long cycle by its first four and last three
                    cycle.erase(cycle.begin() + 4, cycle.end() - 3);
                    cycle.insert(cycle.begin() + 4, "...");
                }
                fail(name, fmt::format("not a consistent STEP file: entity {} refers to itself ({})", cycle.front(),
                                       fmt::join(cycle, " -> ")));
            }
            if (mark[static_cast<std::size_t>(entity)] == Mark::done) continue;
            mark[static_cast<std::size_t>(entity)] = Mark::open;
            path.push_back({entity, graph.Shareds(model->Value(entity))});
        }
    }
}

// An oriented edge names the edge it runs along, and Open CASCADE asks it for
// its end vertices through that reference: one naming no edge dereferenced
// the null (docs/fuzzing.md, "Findings, fixed"). Such a file is refused
// naming the oriented edge. The chain ends: requireAcyclicReferences ran.
void requireEdgesThatEnd(const std::string& name, const Handle(Interface_InterfaceModel) & model)
{
    for (Standard_Integer i = 1; i <= model->NbEntities(); ++i) {
        const auto oriented = Handle(StepShape_OrientedEdge)::DownCast(model->Value(i));
        if (oriented.IsNull()) continue;
        Handle(StepShape_Edge) edge = oriented->EdgeElement();
        while (!edge.IsNull() && edge->IsKind(STANDARD_TYPE(StepShape_OrientedEdge)))
            edge = Handle(StepShape_OrientedEdge)::DownCast(edge)->EdgeElement();
        if (edge.IsNull())
            fail(name, fmt::format("not a consistent STEP file: entity {}: an oriented edge without an edge",
                                   model->StringLabel(oriented)->ToCString()));
    }
}

// The reader turns a vertex into a point by taking its geometry as a
// cartesian point of three coordinates, without looking: a vertex whose point
// is of another kind, or a cartesian point without its coordinates (a fuzzed
// entity name the parser read so), dereferenced the null (docs/fuzzing.md,
// "Findings, fixed"). Such a file is refused naming the vertex.
void requireVerticesWithPoints(const std::string& name, const Handle(Interface_InterfaceModel) & model)
{
    for (Standard_Integer i = 1; i <= model->NbEntities(); ++i) {
        const auto vertex = Handle(StepShape_VertexPoint)::DownCast(model->Value(i));
        if (vertex.IsNull()) continue;
        const auto point = Handle(StepGeom_CartesianPoint)::DownCast(vertex->VertexGeometry());
        if (!point.IsNull() && point->NbCoordinates() == 3) continue;
        fail(name, fmt::format("not a consistent STEP file: entity {}: a vertex whose point is not a cartesian point "
                               "of three coordinates",
                               model->StringLabel(vertex)->ToCString()));
    }
}

// A curve in a face's parameters (a pcurve) is the first item of its
// definitional representation, which the reader takes as a curve without
// looking: an item of a type the reader does not know (a garbled entity
// name) was translated as a null curve and dereferenced (docs/fuzzing.md,
// "Findings, fixed"). Such a file is refused naming the pcurve.
void requirePcurvesWithCurves(const std::string& name, const Handle(Interface_InterfaceModel) & model)
{
    for (Standard_Integer i = 1; i <= model->NbEntities(); ++i) {
        const auto pcurve = Handle(StepGeom_Pcurve)::DownCast(model->Value(i));
        if (pcurve.IsNull()) continue;
        const Handle(StepRepr_DefinitionalRepresentation) definition = pcurve->ReferenceToCurve();
        if (definition.IsNull()) continue; // the reader checks this one itself
        Handle(StepRepr_RepresentationItem) first;
        if (definition->NbItems() > 0) first = definition->ItemsValue(1);
        if (!first.IsNull() && first->IsKind(STANDARD_TYPE(StepGeom_Curve))) continue;
        fail(name, fmt::format("not a consistent STEP file: entity {}: a curve in a face's parameters whose "
                               "representation does not begin with a curve",
                               model->StringLabel(pcurve)->ToCString()));
    }
}

// The file parsed into the reader's session, what its ReadFile does, with the
// checks above between the parse and the session's own checks over the model
// (which call into the entities and are where the recursion above happened).
void loadModel(const std::string& name, STEPControl_Reader& reader)
{
    const Handle(XSControl_WorkSession) session = reader.WS();
    Handle(Interface_InterfaceModel) model;
    Standard_Integer status = 1;
    try {
        status = session->WorkLibrary()->ReadFile(name.c_str(), model, session->Protocol());
    } catch (const Standard_Failure& e) {
        fail(name, fmt::format("not a readable STEP file: {}", e.GetMessageString()));
    }
    if (status != 0 || model.IsNull()) fail(name, "not a readable STEP file (the reader found a syntax error)");
    requireConsistentEntities(name, model);
    requireAcyclicReferences(name, model, session->Protocol());
    requireEdgesThatEnd(name, model);
    requireVerticesWithPoints(name, model);
    requirePcurvesWithCurves(name, model);
    session->SetModel(model);
    session->SetLoadedFile(name.c_str());
    session->InitTransferReader(4);
}

// The reader's XCAF document with the names (product and instance names as
// the CAD system wrote them); colours, layers and the rest are not read.
ProductTree readTree(const std::string& name)
{
    STEPCAFControl_Reader reader;
    reader.SetNameMode(true);
    reader.SetColorMode(false);
    reader.SetLayerMode(false);
    reader.SetPropsMode(false);
    reader.SetGDTMode(false);
    reader.SetMatMode(false);
    reader.SetViewMode(false);
    loadModel(name, reader.ChangeReader());
    Handle(TDocStd_Document) document = new TDocStd_Document("MDTV-XCAF");
    XCAFDoc_DocumentTool::Set(document->Main());
    if (!reader.Transfer(document)) fail(name, "the STEP file holds no shape the reader can transfer");
    const Handle(XCAFDoc_ShapeTool) shapes = XCAFDoc_DocumentTool::ShapeTool(document->Main());
    TDF_LabelSequence free;
    shapes->GetFreeShapes(free);
    if (free.IsEmpty()) fail(name, "the STEP file holds no shape");
    ProductTree tree;
    BRep_Builder builder;
    builder.MakeCompound(tree.content);
    for (int i = 1; i <= free.Length(); ++i) {
        builder.Add(tree.content, XCAFDoc_ShapeTool::GetShape(free(i)));
        collect(free(i), TopLoc_Location(), "", tree);
    }
    // A solid without a name is called by its place in the file's order.
    for (std::size_t i = 0; i < tree.entries.size(); ++i) {
        StepSolid& info = tree.entries[i].info;
        if (info.name.empty()) info.name = fmt::format("solid {}", i + 1);
        TopoDS_Compound bodies;
        builder.MakeCompound(bodies);
        for (int k = 1; k <= tree.entries[i].solids.Extent(); ++k) builder.Add(bodies, tree.entries[i].solids(k));
        GProp_GProps props;
        BRepGProp::VolumeProperties(bodies, props);
        info.volumeMm3 = props.Mass();
    }
    return tree;
}

std::string listOf(const std::vector<const TreeEntry*>& entries)
{
    std::vector<std::string> names;
    for (const TreeEntry* entry : entries) names.push_back(describe(entry->info));
    return fmt::format("{}", fmt::join(names, ", "));
}

// `mesh_solid`: the index of the one entry whose product or instance name is `wanted`.
std::size_t chosenEntry(const std::string& name, const ProductTree& tree, const std::string& wanted)
{
    std::vector<const TreeEntry*> all, matches;
    std::size_t index = 0;
    for (std::size_t i = 0; i < tree.entries.size(); ++i) {
        const TreeEntry& entry = tree.entries[i];
        all.push_back(&entry);
        if (entry.info.name == wanted || entry.info.instance == wanted) {
            matches.push_back(&entry);
            index = i;
        }
    }
    if (matches.empty())
        throw InputError(name, "mesh_solid",
                         fmt::format("no solid named '{}'; the file's {} solid{}: {}", wanted, all.size(),
                                     all.size() == 1 ? " is" : "s are", listOf(all)));
    if (matches.size() > 1)
        throw InputError(name, "mesh_solid",
                         fmt::format("'{}' names {} solids (ambiguous): {}; give one's instance name", wanted,
                                     matches.size(), listOf(matches)));
    return index;
}

/// The solids the part is made of: the chosen one's, or every solid of the file.
TopTools_IndexedMapOfShape partSolids(const std::string& name, ProductTree& tree, const std::string& wanted,
                                      StepSummary& summary)
{
    TopTools_IndexedMapOfShape solids;
    for (const TreeEntry& entry : tree.entries)
        for (int k = 1; k <= entry.solids.Extent(); ++k) solids.Add(entry.solids(k));
    if (solids.Extent() == 0) fail(name, "the STEP file holds no solid, only " + describeContent(tree.content));
    summary.solids = static_cast<std::size_t>(solids.Extent());
    if (!wanted.empty()) {
        TreeEntry& entry = tree.entries[chosenEntry(name, tree, wanted)];
        solids = entry.solids;
        entry.info.chosen = true;
        summary.chosen = wanted;
    }
    for (const TreeEntry& entry : tree.entries) summary.tree.push_back(entry.info);
    return solids;
}

// Every solid must be bounded by closed shells: an open one (a face missing)
// encloses no volume to inspect.
void requireClosedSolids(const std::string& name, const TopTools_IndexedMapOfShape& solids)
{
    for (int i = 1; i <= solids.Extent(); ++i)
        for (TopExp_Explorer shell(solids(i), TopAbs_SHELL); shell.More(); shell.Next())
            if (!BRep_Tool::IsClosed(shell.Current()))
                fail(name, fmt::format("solid {} of {} is not closed (its shell has free edges)", i, solids.Extent()));
}

// The part: the one solid, or the union of several (an assembly's bodies
// that touch or overlap become one; docs/part-program.md, "STEP parts").
TopoDS_Shape unionOf(const std::string& name, const TopTools_IndexedMapOfShape& solids)
{
    if (solids.Extent() == 1) return solids(1);
    TopTools_ListOfShape arguments, tools;
    arguments.Append(solids(1));
    for (int i = 2; i <= solids.Extent(); ++i) tools.Append(solids(i));
    BRepAlgoAPI_Fuse fuse;
    fuse.SetArguments(arguments);
    fuse.SetTools(tools);
    fuse.Build();
    if (!fuse.IsDone()) fail(name, fmt::format("the union of its {} solids failed", solids.Extent()));
    return fuse.Shape();
}

/// Merges vertices closer than `tol` (a face's seam and the edges it shares
/// with its neighbours carry the same points in each face's triangulation)
/// and drops the triangles that collapse.
void weld(TriangleMesh& mesh, double tol)
{
    // Cells of the tolerance's size numbered in doubles, hashed unsigned: a
    // part a hundred metres from its origin has cell numbers past 10^11, whose
    // products with signed integers overflowed (docs/fuzzing.md, "Findings,
    // fixed"); far out, neighbouring cells that round to one number are
    // searched twice.
    using Cell = std::array<double, 3>;
    struct CellHash {
        std::size_t operator()(const Cell& c) const
        {
            const std::hash<double> h;
            return h(c[0]) * 73856093u ^ h(c[1]) * 19349663u ^ h(c[2]) * 83492791u;
        }
    };
    std::unordered_map<Cell, std::vector<int>, CellHash> grid;
    std::vector<Eigen::Vector3d> kept;
    std::vector<int> index(mesh.vertices.size());
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        const Eigen::Vector3d& p = mesh.vertices[i];
        const Cell c = {std::floor(p.x() / tol), std::floor(p.y() / tol), std::floor(p.z() / tol)};
        int found = -1;
        for (int dx = -1; dx <= 1 && found < 0; ++dx)
            for (int dy = -1; dy <= 1 && found < 0; ++dy)
                for (int dz = -1; dz <= 1 && found < 0; ++dz) {
                    auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
                    if (it == grid.end()) continue;
                    for (int k : it->second)
                        if ((kept[k] - p).norm() <= tol) found = k;
                }
        if (found < 0) {
            found = static_cast<int>(kept.size());
            kept.push_back(p);
            grid[c].push_back(found);
        }
        index[i] = found;
    }
    std::vector<std::array<int, 3>> triangles;
    for (const auto& t : mesh.triangles) {
        const std::array<int, 3> w = {index[t[0]], index[t[1]], index[t[2]]};
        if (w[0] != w[1] && w[1] != w[2] && w[0] != w[2]) triangles.push_back(w);
    }
    mesh.vertices = std::move(kept);
    mesh.triangles = std::move(triangles);
}

// The outward unit normal of `face` at its point nearest to `p`, and that point.
std::optional<BRepPoint> nearestOnFace(const TopoDS_Vertex& vertex, const TopoDS_Face& face)
{
    BRepExtrema_DistShapeShape dist(vertex, face);
    if (!dist.IsDone() || dist.NbSolution() == 0) return std::nullopt;
    BRepPoint result;
    result.distance = dist.Value();
    const gp_Pnt on = dist.PointOnShape2(1);
    result.point = toEigen(on);
    double u = 0.0, v = 0.0;
    if (dist.SupportTypeShape2(1) == BRepExtrema_IsInFace) {
        dist.ParOnFaceS2(1, u, v);
    } else {
        // On the face's boundary: the surface parameters of that point.
        GeomAPI_ProjectPointOnSurf project(on, BRep_Tool::Surface(face));
        if (project.NbPoints() == 0) return std::nullopt;
        project.LowerDistanceParameters(u, v);
    }
    BRepAdaptor_Surface surface(face);
    BRepLProp_SLProps props(surface, u, v, 1, 1e-9);
    if (!props.IsNormalDefined()) return std::nullopt;
    gp_Dir n = props.Normal();
    // The surface's own normal points out of the material only on a forward face.
    if (face.Orientation() == TopAbs_REVERSED) n.Reverse();
    result.normal = Eigen::Vector3d(n.X(), n.Y(), n.Z());
    return result;
}

// Every face's triangulation, placed and oriented as the face is, in one
// mesh (vertices of shared edges not yet merged).
TriangleMesh triangles(const std::string& name, const TopoDS_Shape& shape, const TopTools_IndexedMapOfShape& faces,
                       double linearDeflectionMm, double angularDeflectionRad)
{
    BRepMesh_IncrementalMesh mesher(shape, linearDeflectionMm, /*isRelative=*/false, angularDeflectionRad,
                                    /*isInParallel=*/false);
    if (!mesher.IsDone()) fail(name, "the tessellation failed");
    TriangleMesh mesh;
    for (int f = 1; f <= faces.Extent(); ++f) {
        const TopoDS_Face& face = TopoDS::Face(faces(f));
        TopLoc_Location location;
        const Handle(Poly_Triangulation) triangulation = BRep_Tool::Triangulation(face, location);
        if (triangulation.IsNull()) fail(name, fmt::format("face {} could not be tessellated", f));
        const gp_Trsf trsf = location.Transformation();
        const int offset = static_cast<int>(mesh.vertices.size());
        for (int i = 1; i <= triangulation->NbNodes(); ++i)
            mesh.vertices.push_back(toEigen(triangulation->Node(i).Transformed(trsf)));
        // Triangles run counter-clockwise about the surface's normal: a
        // reversed face, or a mirroring placement, turns them the other way.
        const bool flip = (face.Orientation() == TopAbs_REVERSED) != trsf.IsNegative();
        for (int t = 1; t <= triangulation->NbTriangles(); ++t) {
            int a, b, c;
            triangulation->Triangle(t).Get(a, b, c);
            if (flip) std::swap(b, c);
            mesh.triangles.push_back({offset + a - 1, offset + b - 1, offset + c - 1});
        }
    }
    return mesh;
}

// The checks on the file's text, before Open CASCADE sees it.
void requireStepText(const std::string& name, const std::filesystem::path& file)
{
    std::error_code ec;
    if (auto problem = notARegularFile(file); !problem.empty()) fail(name, problem);
    if (std::filesystem::file_size(file, ec) == 0) fail(name, "the file is empty");
    const std::string text = fileText(file);
    if (!endsLikeStep(text)) fail(name, "the file ends before END-ISO-10303-21; (truncated or not a STEP file)");
    requireWellFormedInstances(name, text);
}

// Open CASCADE's translation of a large assembly takes seconds to a minute
// on the line PC; five minutes is a reader that will not finish.
constexpr std::chrono::seconds kStepReadDeadline{300};

// A child that did not answer is a refusal naming how it ended.
void requireFinished(const std::string& name, const ChildOutcome& outcome)
{
    switch (outcome.kind) {
    case ChildOutcome::Kind::finished:
        return;
    case ChildOutcome::Kind::signalled:
        fail(name, fmt::format("Open CASCADE's reader ended with {} on it: the file is damaged in a way no check "
                               "before the reader names (docs/fuzzing.md)",
                               describeSignal(outcome.signal)));
    case ChildOutcome::Kind::timedOut:
        fail(name, fmt::format("Open CASCADE's reader did not finish within {} s", kStepReadDeadline.count()));
    case ChildOutcome::Kind::failed:
        fail(name, fmt::format("the reader's process failed: {}", outcome.detail));
    }
    fail(name, "the reader's process failed");
}

nlohmann::json summaryJson(const StepSummary& summary)
{
    nlohmann::json tree = nlohmann::json::array();
    for (const StepSolid& s : summary.tree)
        tree.push_back({{"name", s.name},
                        {"instance", s.instance},
                        {"solids", s.solids},
                        {"volume_mm3", s.volumeMm3},
                        {"chosen", s.chosen}});
    const Eigen::Vector3d& lo = summary.bounds.min();
    const Eigen::Vector3d& hi = summary.bounds.max();
    return {{"solids", summary.solids},
            {"faces", summary.faces},
            {"volume_mm3", summary.volumeMm3},
            {"bounds", {lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z()}},
            {"tree", tree},
            {"chosen", summary.chosen}};
}

StepSummary summaryFrom(const nlohmann::json& j)
{
    StepSummary summary;
    summary.solids = j.at("solids").get<std::size_t>();
    summary.faces = j.at("faces").get<std::size_t>();
    summary.volumeMm3 = j.at("volume_mm3").get<double>();
    const auto b = j.at("bounds").get<std::vector<double>>();
    if (b.size() != 6) throw nlohmann::json::other_error::create(501, "bounds: six numbers", &j);
    summary.bounds = Eigen::AlignedBox3d(Eigen::Vector3d(b[0], b[1], b[2]), Eigen::Vector3d(b[3], b[4], b[5]));
    for (const auto& s : j.at("tree"))
        summary.tree.push_back({s.at("name").get<std::string>(), s.at("instance").get<std::string>(),
                                s.at("solids").get<std::size_t>(), s.at("volume_mm3").get<double>(),
                                s.at("chosen").get<bool>()});
    summary.chosen = j.at("chosen").get<std::string>();
    return summary;
}

// Open CASCADE's own BRep text of the shape (numbers asked for with 17 digits).
std::string brepText(const TopoDS_Shape& shape)
{
    std::ostringstream out;
    out.precision(17);
    BRepTools::Write(shape, out);
    return out.str();
}

TopoDS_Shape shapeFrom(const std::string& name, const std::string& text)
{
    std::istringstream in(text);
    TopoDS_Shape shape;
    BRep_Builder builder;
    try {
        BRepTools::Read(shape, in, builder);
    } catch (const Standard_Failure& e) {
        fail(name, fmt::format("the reader's process answered a shape that cannot be read: {}", e.GetMessageString()));
    }
    if (shape.IsNull()) fail(name, "the reader's process answered no shape");
    return shape;
}

} // namespace

std::string describe(const StepSolid& solid)
{
    if (solid.instance.empty() || solid.instance == solid.name) return fmt::format("'{}'", solid.name);
    return fmt::format("'{}' (instance '{}')", solid.name, solid.instance);
}

bool isStepFile(const std::filesystem::path& file)
{
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext == ".step" || ext == ".stp";
}

StepModel::StepModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl))
{
}
StepModel::~StepModel() = default;
StepModel::StepModel(StepModel&&) noexcept = default;
StepModel& StepModel::operator=(StepModel&&) noexcept = default;

const StepSummary& StepModel::summary() const
{
    return impl_->summary;
}

const StepTessellation& StepModel::tessellation() const
{
    return impl_->tessellation;
}

StepModel StepModel::readInThisProcess(const std::filesystem::path& file, const std::string& solid)
{
    requireStepText(file.string(), file);
    return readCheckedText(file, solid);
}

StepModel StepModel::readCheckedText(const std::filesystem::path& file, const std::string& solid)
{
    auto impl = std::make_unique<Impl>();
    const std::string& name = impl->name = file.string();
    silenceOpenCascade();
    try {
        ProductTree tree = readTree(name);
        const TopTools_IndexedMapOfShape solids = partSolids(name, tree, solid, impl->summary);
        requireClosedSolids(name, solids);
        impl->shape = unionOf(name, solids);
        // The summary is measured inside the guard too: Open CASCADE throws
        // from the volume integration and from a void bounding box as well.
        TopExp::MapShapes(impl->shape, TopAbs_FACE, impl->faces);
        impl->summary.faces = static_cast<std::size_t>(impl->faces.Extent());
        GProp_GProps props;
        BRepGProp::VolumeProperties(impl->shape, props);
        impl->summary.volumeMm3 = props.Mass();
        if (!(impl->summary.volumeMm3 > 0.0)) fail(name, "the solid encloses no volume (its faces point inward)");
        Bnd_Box box;
        BRepBndLib::AddOptimal(impl->shape, box, false, false);
        double x0, y0, z0, x1, y1, z1;
        box.Get(x0, y0, z0, x1, y1, z1);
        impl->summary.bounds = Eigen::AlignedBox3d(Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1));
    } catch (const Standard_Failure& e) {
        fail(name, fmt::format("Open CASCADE could not read it: {}", e.GetMessageString()));
    }
    return StepModel(std::move(impl));
}

// docs/part-program.md, "A process of its own": the text checks here, the
// rest (Open CASCADE's parse and translation, the checks between them, the
// union and the measures) in a child process, whose answer is the summary
// and the part's shape in Open CASCADE's own BRep text, or the refusal.
StepModel StepModel::read(const std::filesystem::path& file, const std::string& solid)
{
    const std::string name = file.string();
    requireStepText(name, file); // a file refused on its text needs no process
    const auto work = [&]() -> std::string {
        nlohmann::json answer;
        try {
            const StepModel model = readCheckedText(file, solid); // the text was checked here
            answer["summary"] = summaryJson(model.impl_->summary);
            answer["brep"] = brepText(model.impl_->shape);
        } catch (const InputError& e) {
            answer["error"] = {{"field", e.field()}, {"problem", e.problem()}};
        }
        return answer.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    };
    const ChildOutcome outcome = runInChild(work, kStepReadDeadline);
    requireFinished(name, outcome);
    auto impl = std::make_unique<Impl>();
    impl->name = name;
    try {
        const nlohmann::json answer = nlohmann::json::parse(outcome.output);
        if (answer.contains("error"))
            throw InputError(name, answer["error"].at("field").get<std::string>(),
                             answer["error"].at("problem").get<std::string>());
        impl->summary = summaryFrom(answer.at("summary"));
        impl->shape = shapeFrom(name, answer.at("brep").get<std::string>());
    } catch (const nlohmann::json::exception& e) {
        fail(name, fmt::format("the reader's process answered what cannot be read: {}", e.what()));
    }
    TopExp::MapShapes(impl->shape, TopAbs_FACE, impl->faces);
    return StepModel(std::move(impl));
}

TriangleMesh StepModel::tessellate(double linearDeflectionMm, double angularDeflectionRad)
{
    const std::string& name = impl_->name;
    TriangleMesh mesh;
    try {
        mesh = triangles(name, impl_->shape, impl_->faces, linearDeflectionMm, angularDeflectionRad);
    } catch (const Standard_Failure& e) {
        fail(name, fmt::format("the tessellation failed: {}", e.GetMessageString()));
    }
    // Points of shared edges coincide to rounding; a nanometre is far below any chord error.
    weld(mesh, 1e-6);
    requireSolidMesh(mesh, name);
    impl_->tessellation = {linearDeflectionMm, angularDeflectionRad, mesh.triangles.size()};
    return mesh;
}

BRepPoint StepModel::closestPoint(const Eigen::Vector3d& point, double radius) const
{
    try {
        return nearestPoint(point, radius);
    } catch (const Standard_Failure& e) {
        fail(impl_->name, fmt::format("the nearest surface point to ({}, {}, {}) failed: {}", point.x(), point.y(),
                                      point.z(), e.GetMessageString()));
    }
}

BRepPoint StepModel::nearestPoint(const Eigen::Vector3d& point, double radius) const
{
    const TopoDS_Vertex query = BRepBuilderAPI_MakeVertex(gp_Pnt(point.x(), point.y(), point.z()));
    BRepPoint best;
    best.distance = std::numeric_limits<double>::infinity();
    for (int f = 1; f <= impl_->faces.Extent(); ++f) {
        const auto onFace = nearestOnFace(query, TopoDS::Face(impl_->faces(f)));
        if (onFace && onFace->distance < best.distance) best = *onFace;
    }
    if (!std::isfinite(best.distance)) throw InputError(impl_->name, "mesh", "no face has a nearest point");
    // On an edge or a corner every face that meets there has a say, as the
    // mesh's angle-weighted normal does (docs/part-program.md, "STEP parts").
    const TopoDS_Vertex snapped = BRepBuilderAPI_MakeVertex(gp_Pnt(best.point.x(), best.point.y(), best.point.z()));
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int f = 1; f <= impl_->faces.Extent(); ++f) {
        const auto onFace = nearestOnFace(snapped, TopoDS::Face(impl_->faces(f)));
        if (onFace && onFace->distance <= radius) sum += onFace->normal;
    }
    if (sum.norm() > 1e-12) best.normal = sum.normalized();
    return best;
}

} // namespace hg::model
