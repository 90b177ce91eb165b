// A test plugin whose exported entry function throws a C++ exception instead of returning its table (a broken or
// hostile plugin): the loader must turn that into a one-line error naming the file, not crash.
#include <geobarrier/abi.h>

#include <stdexcept>

extern "C" GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) {
    throw std::runtime_error("deliberate failure in the plugin entry");
}
