/* Test plugins whose descriptor declares far more than the loader accepts (plugin.hpp, max_declared_*), written by
 * hand without the SDK, one library per limit (GB_LIMIT_CASE): a system of dimension 2^32 - 1, a system of 2^32 - 1
 * parameters, and a system whose name is 70 characters long. Each gives real arrays of two entries only: a loader
 * that sized anything from the declared count before checking it would read far past them (or build 2^32 state
 * names first, for a minute and gigabytes). The loader must refuse each at once, naming the file and the limit. */
#include <geobarrier/abi.h>

#include <stddef.h>
#include <stdint.h>

static int instance;
static void *create(const gb_param_values *values, gb_message *msg) {
    (void)values;
    (void)msg;
    return &instance;
}
static void destroy(void *self) { (void)self; }

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

static const char *const names[2] = {"x", "y"};
static const char *const units[2] = {"", ""};
static const double domain_min[2] = {-1.0, -1.0}, domain_max[2] = {1.0, 1.0};
static const gb_param_spec params[2] = {{"a", GB_PARAM_REAL, 0.0, -1.0, 1.0, NULL, NULL, "", "a parameter"},
                                        {"b", GB_PARAM_REAL, 0.0, -1.0, 1.0, NULL, NULL, "", "a parameter"}};

#if GB_LIMIT_CASE == 1
#define DIMENSION 0xffffffffu
#define PARAM_COUNT 0u
#define NAME "huge-dimension"
#elif GB_LIMIT_CASE == 2
#define DIMENSION 2u
#define PARAM_COUNT 0xffffffffu
#define NAME "huge-param-count"
#else
#define DIMENSION 2u
#define PARAM_COUNT 0u
#define NAME                                                                                                           \
    "a-name-of-seventy-characters-"                                                                                    \
    "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
#endif

static const gb_system_vtable system_table = {DIMENSION,  0u,         rhs,   NULL,  NULL,
                                              domain_min, domain_max, names, units, NULL};

static const gb_plugin_descriptor descriptors[1] = {{GB_KIND_SYSTEM, NAME, "1.0.0", "declares beyond the limits (test)",
                                                     PARAM_COUNT, params, GB_THREAD_SAFE_CONCURRENT, create, destroy,
                                                     &system_table, NULL, NULL, NULL}};
static const gb_plugin_entry entry = {GB_ABI_VERSION_MAJOR, GB_ABI_VERSION_MINOR, 1u, descriptors, NULL};

GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) { return &entry; }
