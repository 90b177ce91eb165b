// What plugin.cpp shares with the registry (plugin_registry.cpp), private to core/src/plugins.
#ifndef GEOBARRIER_PLUGINS_PLUGIN_INTERNAL_HPP
#define GEOBARRIER_PLUGINS_PLUGIN_INTERNAL_HPP

#include <string>
#include <vector>

namespace geobarrier::detail {

// The non-empty items of a list separated by `sep`: a parameter's choices ("a|b"), GEOBARRIER_PLUGIN_PATH ("x:y").
std::vector<std::string> split_list(const std::string &s, char sep);

} // namespace geobarrier::detail

#endif // GEOBARRIER_PLUGINS_PLUGIN_INTERNAL_HPP
