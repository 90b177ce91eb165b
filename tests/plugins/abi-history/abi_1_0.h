/* geobarrier plugin ABI: the one C boundary between the core and its plugins.
 *
 * Only plain C types cross it: fixed-width integers, double, const char* and
 * pointers to buffers that the caller owns. No C++ types, no exceptions: every
 * function a plugin exports returns a status and never throws. Published
 * structs never change shape within one ABI major version; a new minor version
 * may only append fields at the end of a struct, behind a size or version check.
 *
 * Batched, structure-of-arrays evaluation: a batch holds `n` lanes; component
 * i of lane k lives at `x[i * ld + k]` (ld >= n). Every lane has its own time.
 *
 * Plugin authors normally do not fill these structs by hand: <geobarrier/sdk.hpp>
 * turns a C++ class into them. This header compiles as C99 and as C++. */
#ifndef GEOBARRIER_ABI_H
#define GEOBARRIER_ABI_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A plugin built against another major version is refused at load time. */
#define GB_ABI_VERSION_MAJOR 1u
#define GB_ABI_VERSION_MINOR 0u

/* The one symbol every plugin library exports. */
#define GB_PLUGIN_ENTRY_SYMBOL "geobarrier_plugin_entry"

#if defined(_WIN32)
#define GB_PLUGIN_EXPORT __declspec(dllexport)
#else
#define GB_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

/* Status of a call, and of a single lane in a batch. */
typedef int32_t gb_status;
#define GB_OK 0
#define GB_ERROR 1        /* the call failed; see the message buffer */
#define GB_LANE_INVALID 2 /* lane status only: this state is outside the model's domain */

typedef enum gb_plugin_kind { GB_KIND_SYSTEM = 1, GB_KIND_FORCING = 2, GB_KIND_EXTRACTOR = 3 } gb_plugin_kind;

typedef enum gb_param_type {
    GB_PARAM_REAL = 1,
    GB_PARAM_INTEGER = 2, /* passed as a double holding an integer value */
    GB_PARAM_BOOL = 3,    /* passed as 0.0 or 1.0 */
    GB_PARAM_STRING = 4   /* passed in the strings array */
} gb_param_type;

/* One declared parameter. Ranges are inclusive; use +-HUGE_VAL for "unbounded".
 * For GB_PARAM_STRING, default_string is the default and choices (optional,
 * may be NULL) is a '|'-separated list of allowed values. */
typedef struct gb_param_spec {
    const char *name;
    int32_t type; /* gb_param_type */
    double default_value;
    double min_value;
    double max_value;
    const char *default_string;
    const char *choices;
    const char *unit; /* "" when dimensionless */
    const char *doc;  /* one line */
} gb_param_spec;

/* Parameter values handed to a factory: all declared parameters, validated and
 * with defaults filled in, in declaration order. values[i] holds parameter i
 * (numbers, bools as 0/1); strings[i] holds it when it is a string (else NULL). */
typedef struct gb_param_values {
    uint32_t count;
    const double *values;
    const char *const *strings;
} gb_param_values;

/* Thread contract of the objects a plugin creates. */
#define GB_THREAD_SAFE_CONCURRENT 1u   /* one instance may be called from many threads at once */
#define GB_THREAD_SAFE_PER_INSTANCE 0u /* one instance per thread; instances independent */

/* A caller-owned buffer for an error message (always NUL-terminated). */
typedef struct gb_message {
    char *text;
    size_t capacity;
} gb_message;

/* ---------------------------------------------------------------- systems */

#define GB_SYSTEM_HAS_JACOBIAN 1u   /* jacobian() is provided */
#define GB_SYSTEM_HAS_DIVERGENCE 2u /* divergence() is provided */
#define GB_SYSTEM_USES_FORCING 4u   /* the right-hand side reads the forcing values */

/* x' = v(x, t; f(t)) with state dimension `dimension`.
 *   t[k]        time of lane k
 *   x[i*ld+k]   state
 *   f[k]        forcing value at t[k] (evaluated by the core from the forcing plugin)
 *   dxdt[i*ld+k] output
 *   jac[(i*dimension+j)*ld+k] = d v_i / d x_j    (row-major blocks of lanes)
 *   div[k]      = trace of the Jacobian
 *   lane_status[k] is set by the plugin (GB_OK or GB_LANE_INVALID). */
typedef struct gb_system_vtable {
    uint32_t dimension;
    uint32_t capabilities;
    gb_status (*rhs)(void *self, uint64_t n, uint64_t ld, const double *t, const double *x, const double *f,
                     double *dxdt, int32_t *lane_status, gb_message *msg);
    gb_status (*jacobian)(void *self, uint64_t n, uint64_t ld, const double *t, const double *x, const double *f,
                          double *jac, int32_t *lane_status, gb_message *msg);
    gb_status (*divergence)(void *self, uint64_t n, uint64_t ld, const double *t, const double *x, const double *f,
                            double *div, int32_t *lane_status, gb_message *msg);
} gb_system_vtable;

/* ---------------------------------------------------------------- forcings */

/* f[k] = forcing value at t[k], for n times. */
typedef struct gb_forcing_vtable {
    gb_status (*evaluate)(void *self, uint64_t n, const double *t, double *f, gb_message *msg);
} gb_forcing_vtable;

/* -------------------------------------------------------------- extractors */

/* A named scalar field on the grid, row-major (ny rows of nx), row index = y.
 * Masked points hold NaN and mask[] != 0. */
typedef struct gb_field {
    const char *name;
    const double *data;
} gb_field;

/* What the core hands an extractor: the grid, the time interval, and the
 * fields the extractor asked for through `required_fields`. */
typedef struct gb_extract_input {
    double x_min, x_max, y_min, y_max;
    uint64_t nx, ny;
    double t0, t1;
    const uint8_t *mask; /* nx*ny, 0 = valid */
    uint32_t field_count;
    const gb_field *fields;
    const char *output_dir; /* folder for the extractor's own files (pictures); exists */
    int32_t plots;          /* nonzero when the experiment asked for pictures */
} gb_extract_input;

/* Services the core offers an extractor during extract(): the host pattern of
 * stable plugin ABIs. `context` is opaque and must be passed back. */
typedef struct gb_host {
    void *context;
    /* Log one line at level 0 = debug, 1 = info, 2 = warning. */
    void (*log)(void *context, int32_t level, const char *line);
    /* Report progress in [0, 1]; returns nonzero when the user asked to stop. */
    int32_t (*progress)(void *context, double fraction);
    /* Report one barrier: `count` points (x, y interleaved) at t0, plus named
     * numeric metrics. kind: "hyperbolic" | "elliptic" | "parabolic". */
    gb_status (*add_barrier)(void *context, const char *kind, int32_t closed, uint64_t count, const double *xy,
                             uint32_t metric_count, const char *const *metric_names, const double *metric_values);
    /* Advect n points (x, y interleaved) of the experiment's system from t_from to
     * t_to with the experiment's integrator. xy_out receives 2n values, mask_out n
     * MaskBits (0 = valid; masked points hold NaN). dF_out, when not NULL, receives
     * 4n values F11 F12 F21 F22 of the flow map's gradient at each point. */
    gb_status (*advect)(void *context, uint64_t n, const double *xy, double t_from, double t_to, double *xy_out,
                        double *dF_out, uint8_t *mask_out, gb_message *msg);
} gb_host;

typedef struct gb_extractor_vtable {
    /* NULL-terminated list of field names the extractor needs (e.g. "lambda2"). */
    const char *const *required_fields;
    gb_status (*extract)(void *self, const gb_host *host, const gb_extract_input *input, gb_message *msg);
} gb_extractor_vtable;

/* ---------------------------------------------------------------- entry */

typedef struct gb_plugin_descriptor {
    int32_t kind;        /* gb_plugin_kind */
    const char *name;    /* unique within its kind, [a-z0-9-]+ */
    const char *version; /* the plugin's own version, e.g. "1.0.0" */
    const char *doc;     /* one line */
    uint32_t param_count;
    const gb_param_spec *params;
    uint32_t thread_safety; /* GB_THREAD_SAFE_* */
    /* Create an instance from validated values; NULL on failure (message set). */
    void *(*create)(const gb_param_values *values, gb_message *msg);
    void (*destroy)(void *self);
    /* Exactly one of these is non-NULL, matching `kind`. */
    const gb_system_vtable *system;
    const gb_forcing_vtable *forcing;
    const gb_extractor_vtable *extractor;
    /* The geobarrier core version a plugin that also links the core's C++ library
     * (libgeobarrier: tensor lines, curves, pictures) was built against; the loader
     * refuses any other version, since C++ interfaces carry no ABI promise. NULL for
     * plugins that use only this header. */
    const char *core_version;
} gb_plugin_descriptor;

typedef struct gb_plugin_entry {
    uint32_t abi_major; /* must equal GB_ABI_VERSION_MAJOR; checked before anything else is read */
    uint32_t abi_minor;
    uint32_t count;
    const gb_plugin_descriptor *descriptors;
} gb_plugin_entry;

/* Signature of the exported entry point, named GB_PLUGIN_ENTRY_SYMBOL. */
typedef const gb_plugin_entry *(*gb_plugin_entry_fn)(void);

#ifdef __cplusplus
}
#endif

#endif /* GEOBARRIER_ABI_H */
