/* Test plugin built for plugin ABI 1.1, before the state names and units (1.2) were appended to gb_system_vtable.
 * Its system table has the 1.1 layout, and the words after it hold poison pointers: a core that read the 1.2
 * fields from a plugin declaring minor 1 would dereference (or call) them and crash. Written by hand, without the
 * SDK. */
#include <geobarrier/abi.h>

#include <stddef.h>

/* gb_system_vtable as ABI 1.1 published it. */
typedef struct system_vtable_1_1 {
    uint32_t dimension;
    uint32_t capabilities;
    gb_status (*rhs)(void *, uint64_t, uint64_t, const double *, const double *, const double *, double *, int32_t *,
                     gb_message *);
    gb_status (*jacobian)(void *, uint64_t, uint64_t, const double *, const double *, const double *, double *,
                          int32_t *, gb_message *);
    gb_status (*divergence)(void *, uint64_t, uint64_t, const double *, const double *, const double *, double *,
                            int32_t *, gb_message *);
    const double *domain_min;
    const double *domain_max;
} system_vtable_1_1;

static int instance;
static void *create(const gb_param_values *values, gb_message *msg) {
    (void)values;
    (void)msg;
    return &instance;
}
static void destroy(void *self) { (void)self; }

/* x' = -y, y' = x (a rigid rotation). */
static gb_status rhs(void *self, uint64_t n, uint64_t ld, const double *t, const double *x, const double *f,
                     double *dxdt, int32_t *lane_status, gb_message *msg) {
    (void)self;
    (void)t;
    (void)f;
    (void)msg;
    for (uint64_t k = 0; k < n; ++k) {
        dxdt[k] = -x[ld + k];
        dxdt[ld + k] = x[k];
        lane_status[k] = GB_OK;
    }
    return GB_OK;
}

static const struct {
    system_vtable_1_1 table;
    const void *poison[3]; /* where a 1.2 table has state_names, state_units and advance */
} system_table = {{2u, 0u, rhs, NULL, NULL, NULL, NULL},
                  {(const void *)(uintptr_t)8u, (const void *)(uintptr_t)8u, (const void *)(uintptr_t)8u}};

static const gb_plugin_descriptor descriptors[1] = {
    {GB_KIND_SYSTEM, "abi-one-one", "1.0.0", "rigid rotation built for plugin ABI 1.1", 0, NULL,
     GB_THREAD_SAFE_CONCURRENT, create, destroy, (const gb_system_vtable *)&system_table.table, NULL, NULL, NULL}};
static const gb_plugin_entry entry = {GB_ABI_VERSION_MAJOR, 1u, 1u, descriptors};

GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) { return &entry; }
