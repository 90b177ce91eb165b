// The reader of a plugin library's descriptors (plugin.cpp), on its own: what load_plugin_library does with the entry
// a library's entry function returned, without the library. The fuzzer of the descriptor reader
// (tests/fuzz/fuzz_descriptor.cpp) feeds it entries built from its input.
#ifndef GEOBARRIER_PLUGIN_ENTRY_HPP
#define GEOBARRIER_PLUGIN_ENTRY_HPP

#include <geobarrier/abi.h>
#include <geobarrier/plugin.hpp>

#include <filesystem>
#include <vector>

namespace geobarrier::detail {

// Checks the entry's ABI and reads every descriptor it declares, each declared limit (plugin.hpp, max_declared_*)
// checked before anything is sized from it; one PluginInfo per descriptor, in order. Throws PluginError
// "<file>: <reason>" for a malformed entry. Reads only what the ABI lets a plugin declare: strings up to their end
// (names at most max_declared_name_length + 1 characters far), arrays of the length they declare.
std::vector<PluginInfo> read_plugin_entry(const gb_plugin_entry &entry, const std::filesystem::path &file);

} // namespace geobarrier::detail

#endif // GEOBARRIER_PLUGIN_ENTRY_HPP
