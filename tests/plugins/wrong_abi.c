/* Test plugin built for ABI major GB_ABI_VERSION_MAJOR + 1: the loader must refuse it, naming the file and both
 * versions, without reading past the version fields. Written by hand, without the SDK's macro. */
#include <geobarrier/abi.h>

#include <stddef.h>

static void *create(const gb_param_values *values, gb_message *msg) {
    (void)values;
    (void)msg;
    return NULL;
}
static void destroy(void *self) { (void)self; }
static gb_status evaluate(void *self, uint64_t n, const double *t, double *f, gb_message *msg) {
    (void)self;
    (void)msg;
    for (uint64_t k = 0; k < n; ++k) f[k] = t[k];
    return GB_OK;
}
static const gb_forcing_vtable forcing_table = {evaluate, 0u, 0u, NULL};
static const gb_plugin_descriptor descriptors[1] = {
    {GB_KIND_FORCING, "wrong-abi", "1.0.0", "forcing built for a future ABI major version", 0, NULL,
     GB_THREAD_SAFE_CONCURRENT, create, destroy, NULL, &forcing_table, NULL, NULL}};
static const gb_plugin_entry entry = {GB_ABI_VERSION_MAJOR + 1u, 0u, 1u, descriptors};

GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) { return &entry; }
