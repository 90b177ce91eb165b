/* Test module that is a valid shared library but exports no geobarrier_plugin_entry: the loader must refuse it
 * with "no entry symbol". */
#include <geobarrier/abi.h>

GB_PLUGIN_EXPORT int geobarrier_not_the_entry(void) { return 42; }
