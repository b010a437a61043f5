// STEP assemblies for the tests of `mesh_solid` (docs/part-program.md, "STEP
// parts"): products with names (or none), placed by named (or unnamed)
// instances in one assembly, written through Open CASCADE's XCAF document
// and its STEP writer as a CAD system writes its product tree.
#pragma once

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <BRepAlgoAPI_Cut.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <STEPCAFControl_Writer.hxx>
#include <TDF_Label.hxx>
#include <TDataStd_Name.hxx>
#include <TDocStd_Document.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS_Shape.hxx>
#include <XCAFDoc_DocumentTool.hxx>
#include <XCAFDoc_ShapeTool.hxx>
#include <gp_Trsf.hxx>
#include <gtest/gtest.h>

#include <Eigen/Core>

namespace hgtest {

/// One placement of a product in the assembly; an empty name leaves the
/// instance unnamed (Open CASCADE then writes a link to its product).
struct StepInstance {
    std::string name;
    Eigen::Vector3d at = Eigen::Vector3d::Zero();
};

/// A product of the assembly; an empty name is written as PRODUCT('', '', …).
struct StepProduct {
    std::string name;
    TopoDS_Shape shape;
    std::vector<StepInstance> instances;
};

/// The bracket: the box [0, 40] x [0, 30] x [0, 20] less a through bore r = 6
/// along z about (20, 15) (as part (a) of test_step_io.cpp).
inline TopoDS_Shape bracketShape()
{
    const TopoDS_Shape box = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(40, 30, 20)).Shape();
    const gp_Ax2 axis(gp_Pnt(20, 15, -1), gp::DZ());
    return BRepAlgoAPI_Cut(box, BRepPrimAPI_MakeCylinder(axis, 6.0, 22).Shape()).Shape();
}

/// The pin: a cylinder r = 5, 30 long, its axis along z from its own origin.
constexpr double kPinRadius = 5.0;
constexpr double kPinLength = 30.0;
inline TopoDS_Shape pinShape()
{
    return BRepPrimAPI_MakeCylinder(kPinRadius, kPinLength).Shape();
}

/// Writes the assembly "assembly" of `products` to `file`.
inline std::filesystem::path writeStepAssembly(const std::vector<StepProduct>& products,
                                               const std::filesystem::path& file)
{
    Handle(TDocStd_Document) document = new TDocStd_Document("MDTV-XCAF");
    XCAFDoc_DocumentTool::Set(document->Main());
    const Handle(XCAFDoc_ShapeTool) shapes = XCAFDoc_DocumentTool::ShapeTool(document->Main());
    const TDF_Label assembly = shapes->NewShape();
    TDataStd_Name::Set(assembly, "assembly");
    std::vector<std::string> unnamed;
    for (const StepProduct& product : products) {
        const TDF_Label label = shapes->AddShape(product.shape, /*makeAssembly=*/false);
        // Replaces the shape-type name ("SOLID") the tool gives a new label.
        // The writer names a product without a name after itself ("Open
        // CASCADE STEP translator …"): a marker, emptied in the file below.
        std::string name = product.name;
        if (name.empty()) unnamed.push_back(name = "unnamed-product-" + std::to_string(unnamed.size() + 1));
        TDataStd_Name::Set(label, name.c_str());
        for (const StepInstance& instance : product.instances) {
            gp_Trsf placement;
            placement.SetTranslation(gp_Vec(instance.at.x(), instance.at.y(), instance.at.z()));
            const TDF_Label component = shapes->AddComponent(assembly, label, TopLoc_Location(placement));
            if (!instance.name.empty()) TDataStd_Name::Set(component, instance.name.c_str());
        }
    }
    shapes->UpdateAssemblies();
    STEPCAFControl_Writer writer;
    writer.SetNameMode(true);
    EXPECT_TRUE(writer.Transfer(document));
    EXPECT_EQ(writer.Write(file.c_str()), IFSelect_RetDone);
    if (unnamed.empty()) return file;
    std::string text;
    {
        std::ifstream in(file);
        text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    for (const std::string& marker : unnamed) {
        const std::string record = "PRODUCT('" + marker + "','" + marker + "'";
        const std::size_t at = text.find(record);
        EXPECT_NE(at, std::string::npos) << record;
        if (at != std::string::npos) text.replace(at, record.size(), "PRODUCT('',''");
    }
    std::ofstream(file) << text;
    return file;
}

/// "bracket" at the origin and "pin" placed at (100, 0, 0), instances unnamed.
inline std::filesystem::path writeBracketAndPin(const std::filesystem::path& file)
{
    return writeStepAssembly({{"bracket", bracketShape(), {{"", Eigen::Vector3d::Zero()}}},
                              {"pin", pinShape(), {{"", Eigen::Vector3d(100, 0, 0)}}}},
                             file);
}

} // namespace hgtest
