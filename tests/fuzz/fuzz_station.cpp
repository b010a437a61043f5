// The station file (docs/fuzzing.md): parseStation on the parsed YAML, as
// loadStation does for every program that reads station.yaml.
#include "fuzz_support.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/station.h"

#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    (void)hg::fuzz::workFolder(); // silences the log
    const std::string text(reinterpret_cast<const char*>(data), size);
    hg::fuzz::expectDocumentedErrors(
        [&] { (void)hg::geometry::parseStation(hg::ConfigNode::parse(text, "station.yaml")); });
    return 0;
}
