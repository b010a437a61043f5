// One table of backends per device kind (docs/drivers.md): name -> factory,
// the simulated twin among them and always compiled, as Aravis lists its
// interfaces. The `backend` key of the driver section chooses the entry.
#pragma once

#include <string>
#include <string_view>

#include "hullgauge/common/config_node.h"

namespace hg::drivers {

template <class Factory> struct Backend {
    std::string_view name;
    Factory make;
};

/// The factory named by `backendNode`; an unknown name fails naming the key
/// and every backend of the table.
template <class Factory, std::size_t N>
Factory chooseBackend(const Backend<Factory> (&table)[N], const ConfigNode& backendNode, std::string_view kind)
{
    const std::string name = backendNode.asString();
    std::string known;
    for (std::size_t i = 0; i < N; ++i) {
        if (table[i].name == name) return table[i].make;
        known += (i == 0 ? "" : i + 1 == N ? " or " : ", ") + std::string(table[i].name);
    }
    backendNode.fail("unknown " + std::string(kind) + " backend '" + name + "' (expected " + known + ")");
}

} // namespace hg::drivers
