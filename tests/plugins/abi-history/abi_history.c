/* One plugin library built against a plugin ABI header of an earlier release, kept verbatim in this folder as taken
 * from the repository's history (abi_1_0.h: commit 03e2e39, abi_1_1.h: 6791bb2, abi_1_2.h: 7afad05). The build
 * compiles it once per header (GB_HISTORIC_ABI names it) and test_abi_history loads each into the current core: the
 * compatibility promise of docs/plugins.md, tested. Three plugins in one library, so that the descriptor array's
 * stride is exercised too, each with a known answer:
 *   system "history-saddle"    x' = a x, y' = -a y + f(t)  (Jacobian diag(a, -a), divergence 0)
 *   forcing "history-linear"   f(t) = slope t
 *   extractor "history-probe"  reports one barrier through the grid's corners with metrics the test predicts: the
 *                              sum of the unmasked "ftle" values, and where the core's host advects (1, 2).
 * Written in C without the SDK, as a plugin of that release written by hand would be. */
#include GB_HISTORIC_ABI

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

typedef struct saddle {
    double a;
} saddle;
typedef struct linear {
    double slope;
} linear;

static int probe_instance;

static void *create_saddle(const gb_param_values *values, gb_message *msg) {
    (void)msg;
    saddle *s = malloc(sizeof *s);
    if (!s) return NULL;
    s->a = values->values[0];
    return s;
}
static void *create_linear(const gb_param_values *values, gb_message *msg) {
    (void)msg;
    linear *l = malloc(sizeof *l);
    if (!l) return NULL;
    l->slope = values->values[0];
    return l;
}
static void *create_probe(const gb_param_values *values, gb_message *msg) {
    (void)values;
    (void)msg;
    return &probe_instance;
}
static void destroy(void *self) { free(self); }
static void destroy_probe(void *self) { (void)self; }

static gb_status saddle_rhs(void *self, uint64_t n, uint64_t ld, const double *t, const double *x, const double *f,
                            double *dxdt, int32_t *lane_status, gb_message *msg) {
    const double a = ((const saddle *)self)->a;
    uint64_t k;
    (void)t;
    (void)msg;
    for (k = 0; k < n; ++k) {
        dxdt[k] = a * x[k];
        dxdt[ld + k] = -a * x[ld + k] + f[k];
        lane_status[k] = GB_OK;
    }
    return GB_OK;
}
static gb_status saddle_jacobian(void *self, uint64_t n, uint64_t ld, const double *t, const double *x, const double *f,
                                 double *jac, int32_t *lane_status, gb_message *msg) {
    const double a = ((const saddle *)self)->a;
    uint64_t k;
    (void)t;
    (void)x;
    (void)f;
    (void)msg;
    for (k = 0; k < n; ++k) {
        jac[k] = a;
        jac[ld + k] = 0.0;
        jac[2 * ld + k] = 0.0;
        jac[3 * ld + k] = -a;
        lane_status[k] = GB_OK;
    }
    return GB_OK;
}
static gb_status saddle_divergence(void *self, uint64_t n, uint64_t ld, const double *t, const double *x,
                                   const double *f, double *div, int32_t *lane_status, gb_message *msg) {
    uint64_t k;
    (void)self;
    (void)ld;
    (void)t;
    (void)x;
    (void)f;
    (void)msg;
    for (k = 0; k < n; ++k) {
        div[k] = 0.0;
        lane_status[k] = GB_OK;
    }
    return GB_OK;
}

static gb_status linear_evaluate(void *self, uint64_t n, const double *t, double *f, gb_message *msg) {
    const double slope = ((const linear *)self)->slope;
    uint64_t k;
    (void)msg;
    for (k = 0; k < n; ++k) f[k] = slope * t[k];
    return GB_OK;
}

static gb_status probe_extract(void *self, const gb_host *host, const gb_extract_input *in, gb_message *msg) {
    const double *ftle = NULL;
    double sum = 0.0, corners[4], start[2] = {1.0, 2.0}, end[2] = {0.0, 0.0};
    uint8_t mask = 1;
    uint32_t i;
    uint64_t k;
    const char *names[2] = {"ftle_sum", "advected_x"};
    double values[2];
    (void)self;
    for (i = 0; i < in->field_count; ++i)
        if (strcmp(in->fields[i].name, "ftle") == 0) ftle = in->fields[i].data;
    if (!ftle) {
        strncpy(msg->text, "no ftle field", msg->capacity - 1);
        msg->text[msg->capacity - 1] = '\0';
        return GB_ERROR;
    }
    for (k = 0; k < in->nx * in->ny; ++k)
        if (in->mask[k] == 0) sum += ftle[k];
    if (host->advect(host->context, 1, start, in->t0, in->t1, end, NULL, &mask, msg) != GB_OK) return GB_ERROR;
    corners[0] = in->x_min;
    corners[1] = in->y_min;
    corners[2] = in->x_max;
    corners[3] = in->y_max;
    values[0] = sum;
    values[1] = end[0];
    host->log(host->context, 1, "history-probe ran");
    return host->add_barrier(host->context, "hyperbolic", 0, 2, corners, 2, names, values);
}

static const gb_param_spec saddle_params[1] = {
    {"a", GB_PARAM_REAL, 1.0, -1e300, 1e300, "", NULL, "1/time", "rate of the saddle"}};
static const gb_param_spec linear_params[1] = {
    {"slope", GB_PARAM_REAL, 0.5, -1e300, 1e300, "", NULL, "1/time", "f(t) = slope t"}};

#if GB_ABI_VERSION_MINOR >= 1
static const double domain_min[2] = {-3.0, -3.0}, domain_max[2] = {3.0, 3.0};
#endif
#if GB_ABI_VERSION_MINOR >= 2
static const char *const state_names[2] = {"p", "q"};
static const char *const state_units[2] = {"m", "m/s"};
#endif

static const gb_system_vtable saddle_table = {
    .dimension = 2,
    .capabilities = GB_SYSTEM_HAS_JACOBIAN | GB_SYSTEM_HAS_DIVERGENCE | GB_SYSTEM_USES_FORCING,
    .rhs = saddle_rhs,
    .jacobian = saddle_jacobian,
    .divergence = saddle_divergence,
#if GB_ABI_VERSION_MINOR >= 1
    .domain_min = domain_min,
    .domain_max = domain_max,
#endif
#if GB_ABI_VERSION_MINOR >= 2
    .state_names = state_names,
    .state_units = state_units,
    .advance = NULL,
#endif
};
static const gb_forcing_vtable linear_table = {.evaluate = linear_evaluate};
static const char *const probe_fields[2] = {"ftle", NULL};
static const gb_extractor_vtable probe_table = {.required_fields = probe_fields, .extract = probe_extract};

static const gb_plugin_descriptor descriptors[3] = {
    {.kind = GB_KIND_SYSTEM,
     .name = "history-saddle",
     .version = "1.0.0",
     .doc = "saddle x' = a x, y' = -a y + f",
     .param_count = 1,
     .params = saddle_params,
     .thread_safety = GB_THREAD_SAFE_CONCURRENT,
     .create = create_saddle,
     .destroy = destroy,
     .system = &saddle_table},
    {.kind = GB_KIND_FORCING,
     .name = "history-linear",
     .version = "1.0.0",
     .doc = "f(t) = slope t",
     .param_count = 1,
     .params = linear_params,
     .thread_safety = GB_THREAD_SAFE_CONCURRENT,
     .create = create_linear,
     .destroy = destroy,
     .forcing = &linear_table},
    {.kind = GB_KIND_EXTRACTOR,
     .name = "history-probe",
     .version = "1.0.0",
     .doc = "reports the grid's corners",
     .thread_safety = GB_THREAD_SAFE_CONCURRENT,
     .create = create_probe,
     .destroy = destroy_probe,
     .extractor = &probe_table},
};
static const gb_plugin_entry entry = {GB_ABI_VERSION_MAJOR, GB_ABI_VERSION_MINOR, 3u, descriptors};

GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) { return &entry; }
