/* geobarrier plugin ABI: the one C boundary between the core and its plugins.
 *
 * Only plain C types cross it: fixed-width integers, double, const char* and
 * pointers to buffers that the caller owns. No C++ types, no exceptions: every
 * function a plugin exports returns a status and never throws.
 *
 * How the boundary evolves (the compatibility promise; docs/plugins.md says it for users):
 *   - Within one major version, published structs never change shape: a minor version only appends fields at the
 *     end of a struct that is not an array element, adds flags, adds enum values, or adds extensions by id.
 *   - Every struct has a version, that of the side that allocated it: what a plugin fills (entry, descriptors,
 *     tables, parameter specs) has the plugin's version, gb_plugin_entry.abi_minor; what the core fills (requests,
 *     inputs, the host) has the core's, which a plugin learns at load time from gb_host_info (minor 3; a core that
 *     does not call GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL is older than 1.3). Each side reads an appended field only
 *     when the other side's version has it. Structs introduced from 1.3 on also start with their size.
 *   - Arrays of structs (descriptors, parameter specs, fields) never grow: new per-plugin data comes as an
 *     extension by id (gb_plugin_entry.get_extension; gb_host_info.get_extension the other way).
 *   - A core loads every plugin of its major version, older or newer minor, and refuses another major version
 *     naming both versions. A new major version is for changes that cannot be made this way.
 *
 * Batched, structure-of-arrays evaluation: a batch holds `n` lanes; component
 * i of lane k lives at `x[i * ld + k]` (ld >= n). Every lane has its own time t[k]; threads, lifetimes: at the end.
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
/* Minor 1 appended: gb_system_vtable.domain_min/domain_max and the composite-forcing
 * fields of gb_forcing_vtable (min_terms, max_terms, combine). The core reads them only
 * from plugins whose entry says abi_minor >= 1. */
/* Minor 2 appended: gb_system_vtable.state_names/state_units and gb_extract_input.state_names/state_units.
 * The core reads the system's only from plugins whose entry says abi_minor >= 2; an extractor may read the
 * input's only when its host is 1.2 or newer (known from gb_host_info from 1.3 on; sdk::axis_label checks it).
 * Minor 2 also appended gb_system_vtable.advance (a fused Runge-Kutta step, gb_advance_request), read likewise. */
/* Minor 3 added: the host entry GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL (gb_host_info: the core's version, its fused-step
 * numerics revision and extensions by id), gb_plugin_entry.get_extension (extensions of a plugin by id, e.g.
 * GB_EXTENSION_BUILD_INFO), gb_advance_request.tableau_revision, and the flag GB_SYSTEM_JACOBIAN_DERIVED.
 * Minor 3 also added the method GB_ADVANCE_DOP853_CHECKED and appended gb_advance_request.lane_error (the fused
 * step's error estimate), read only with that method. */
/* Minor 4 added the core extension GB_EXTENSION_PLOT (gb_plot_service): an extractor draws its pictures through the
 * core, so that it needs nothing of the core's C++ library. */
#define GB_ABI_VERSION_MINOR 4u

/* The one symbol every plugin library exports. */
#define GB_PLUGIN_ENTRY_SYMBOL "geobarrier_plugin_entry"
/* ABI 1.3, optional: the entry a core of 1.3 or newer calls instead, with its gb_host_info (below), when the library
 * exports it. Same result as the plain entry; a plugin keeps the host info to know what the core offers. */
#define GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL "geobarrier_plugin_entry_with_host"

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
#define GB_UNSUPPORTED 3  /* advance() only: the plugin does not offer the requested method; nothing was written */

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
    const char *unit; /* "" when dimensionless; "path" on a string: a file path, relative to the experiment's folder */
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
#define GB_THREAD_SAFE_PER_INSTANCE 0u /* one thread at a time per instance: the core then integrates on one thread */

/* A caller-owned buffer for an error message (always NUL-terminated). */
typedef struct gb_message {
    char *text;
    size_t capacity;
} gb_message;

/* ---------------------------------------------------------------- systems */

#define GB_SYSTEM_HAS_JACOBIAN 1u     /* jacobian() is provided */
#define GB_SYSTEM_HAS_DIVERGENCE 2u   /* divergence() is provided */
#define GB_SYSTEM_USES_FORCING 4u     /* the right-hand side reads the forcing values */
#define GB_SYSTEM_JACOBIAN_DERIVED 8u /* informational: the SDK derived jacobian() by automatic differentiation */

/* ABI 1.2: one fused explicit Runge-Kutta step of a batch (gb_system_vtable.advance). All lanes share the time t
 * (the core's lockstep engine); the step runs every stage of every lane inside the plugin, so a lane's stage
 * derivatives stay in registers instead of going through memory between stages. The method is a fixed Butcher
 * tableau that the SDK compiles in (<geobarrier/rk_tableaux.hpp>, the same tableaux as the core's kernel); a plugin
 * answers GB_UNSUPPORTED for a method it lacks and the core then takes its stage-by-stage path.
 *   forcing[i]   forcing value at t + c_i h, i < the method's stage count (0 when the system reads no forcing)
 *   x[i*ld+k]    state, i < dimension; x_out receives the state after the step (same layout; x_out != x)
 *   variational  nonzero: also advance the variational equations DF' = Dv DF (df[(i*dimension+j)*ld+k], row-major
 *                blocks of lanes, into df_out) and (log|det DF|)' = tr Dv (log_det[k], into log_det_out)
 *   lane_status  set by the plugin (GB_OK or GB_LANE_INVALID) for each lane
 * The core keeps everything else: masking (it restores lanes it had frozen), bounds, renormalisation, step counts. */
typedef enum gb_advance_method {
    GB_ADVANCE_RK4 = 1,           /* classic 4-stage Runge-Kutta */
    GB_ADVANCE_DOP853 = 2,        /* Dormand-Prince 8(5,3), 12 stages, as in Hairer's dop853.f, no error estimate */
    GB_ADVANCE_DOP853_CHECKED = 3 /* ABI 1.3: DOP853 that also writes lane_error (see gb_advance_request) */
} gb_advance_method;

/* The revision of the numerics a fused step must reproduce: the tableaux of <geobarrier/rk_tableaux.hpp> and the
 * order of the step's operations. Bumped whenever either changes, so that a plugin compiled with older numerics
 * declines (GB_UNSUPPORTED: the core then takes its own stage-by-stage path) rather than computing with stale ones.
 * Cores before 1.3 do not send it; their numerics are revision 1. */
#define GB_ADVANCE_TABLEAU_REVISION 1u

typedef struct gb_advance_request {
    int32_t method; /* gb_advance_method */
    int32_t variational;
    uint64_t n, ld;
    double t, h;
    const double *forcing;
    const double *x, *df, *log_det;
    double *x_out, *df_out, *log_det_out;
    int32_t *lane_status;
    /* ABI 1.3, appended (present when the host's gb_host_info says 1.3 or newer): the core's
     * GB_ADVANCE_TABLEAU_REVISION. A plugin whose compiled-in revision differs answers GB_UNSUPPORTED. */
    uint32_t tableau_revision;
    /* ABI 1.3, appended; read only for method GB_ADVANCE_DOP853_CHECKED, which a core older than 1.3 never sends (and
     * which a plugin older than 1.3 answers GB_UNSUPPORTED), so the struct's size never matters across versions.
     * lane_error[k] receives max over the state components i < dimension (not DF) of |sum_j e_j k_ij|, DOP853's
     * 5th-order error row (er1..er12 of dop853.f) over the lane's stage derivatives k_j (rk_tableaux.hpp,
     * lane_error_estimate); the core scales it by |h| and the tolerances and shrinks a step whose batch maximum
     * fails. */
    double *lane_error;
} gb_advance_request;

/* x' = v(x, t; f(t)) with state dimension `dimension`.
 *   t[k]        time of lane k (equal in every lane of the lockstep engine's calls, not in general)
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
    /* ABI 1.1: the documented domain, `dimension` bounds each (lower, upper), or NULL when the
     * model is meant for any state. `geobarrier check-plugin` samples it for non-finite values
     * and generated docs print it; states outside it are not refused by the core. */
    const double *domain_min;
    const double *domain_max;
    /* ABI 1.2: the name and unit of each state component, `dimension` entries each (e.g. {"x", "y"} and
     * {"m", "m/s"}; "" for a nondimensional one), or NULL when the plugin declares none. Pictures label their
     * axes "name [unit]"; generated docs print them. */
    const char *const *state_names;
    const char *const *state_units;
    /* ABI 1.2: one fused Runge-Kutta step (see gb_advance_request), or NULL; the SDK generates it for systems that
     * give a per-lane vector field. Returns GB_OK, GB_UNSUPPORTED (method not offered) or GB_ERROR. */
    gb_status (*advance)(void *self, const gb_advance_request *request, gb_message *msg);
} gb_system_vtable;

/* ---------------------------------------------------------------- forcings */

/* f[k] = forcing value at t[k], for n times.
 *
 * ABI 1.1, composite forcings (e.g. "sum", "ramp"): a forcing with max_terms > 0 combines the
 * values of other forcings, its terms, which the experiment names in the forcing's "terms" (or
 * "base") entry. Plugins never call each other: the core evaluates every term at the n times and
 * hands the values to combine(), with terms[j*ld + k] = value of term j at t[k] (ld >= n).
 * A composite forcing's evaluate() is only called by a core older than 1.1, and should fail with
 * a message saying so. Plain forcings leave these fields 0 / NULL. */
typedef struct gb_forcing_vtable {
    gb_status (*evaluate)(void *self, uint64_t n, const double *t, double *f, gb_message *msg);
    uint32_t min_terms;
    uint32_t max_terms;
    gb_status (*combine)(void *self, uint64_t n, const double *t, uint32_t term_count, uint64_t ld, const double *terms,
                         double *f, gb_message *msg);
} gb_forcing_vtable;

/* -------------------------------------------------------------- extractors */

/* A named scalar field on the grid, row-major (ny rows of nx), row index = y.
 * Masked points hold NaN and mask[] != 0. The names an extractor may ask for are the grid variables of the
 * products (docs/experiment-format.md: "ftle", "lambda1", "xi1_x", "strain_deviation", ...) and "exit_time":
 * the time t at which each point's trajectory left the experiment's `bounds` (bounds whose exits stop, the
 * default), NaN where it stayed within them up to t1 (the captured set) or could not leave: every run hands it
 * over, all NaN when the experiment has no such bounds (an extractor needs no bounds to run). A core that predates
 * "exit_time" (within ABI 1.4) refuses an extractor asking for it when the experiment is read, with a one-line
 * error, rather than handing over nothing. */
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
    /* ABI 1.2, appended: the system's state names and units (2 entries each, never NULL; "" when the system
     * declares none), for the axes of the extractor's pictures. A 1.1 host's struct ends before them. */
    const char *const *state_names;
    const char *const *state_units;
} gb_extract_input;

/* Services the core offers an extractor during extract() only, from extract()'s thread only (see the end): the host
 * pattern of stable plugin ABIs. `context` is opaque and must be passed back. */
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
    /* ABI 1.1, appended: attach non-numeric attributes to the barrier this extractor reported last, e.g.
     * "family" = "\"+\"" or "outermost" = "true". Each value is one JSON literal (a string in quotes, true,
     * false, null or a number), copied as such into barriers.json. A core older than 1.1 hands over a shorter
     * struct, so a plugin may call this only when it knows its host is 1.1 or newer: from gb_host_info (1.3), or
     * because it links the core library (the loader checks the core's C++ series). */
    gb_status (*set_barrier_attributes)(void *context, uint32_t count, const char *const *names,
                                        const char *const *json_values);
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
     * refuses a core of another C++ series (another SOVERSION: major.minor while the major is 0, else the major),
     * since C++ interfaces change between series. NULL for plugins that use only this header. */
    const char *core_version;
} gb_plugin_descriptor;

/* ABI 1.3: what the core tells a plugin about itself, through GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL. It lives as long as
 * the process; a plugin may keep the pointer. */
typedef struct gb_host_info {
    uint32_t struct_size; /* sizeof(gb_host_info) in the core: a field past it is absent */
    uint32_t abi_major;   /* the core's plugin ABI: the version of every struct the core fills */
    uint32_t abi_minor;
    uint32_t tableau_revision; /* the core's GB_ADVANCE_TABLEAU_REVISION */
    const char *core_version;  /* the geobarrier release, e.g. "0.1.0" (for messages; compare ABI versions instead) */
    /* A feature of the core by id (a string such as GB_EXTENSION_BUILD_INFO), or NULL when it lacks it. Each
     * extension is a struct that starts with its uint32_t size. */
    const void *(*get_extension)(const char *id);
} gb_host_info;

/* ABI 1.3 extension "geobarrier.build-info", offered by the SDK's plugins (gb_plugin_entry.get_extension) and by the
 * core (gb_host_info.get_extension): how the code was compiled, so that check-plugin can say when a plugin was built
 * for a lesser CPU than the core (its fused step then runs slower). */
#define GB_EXTENSION_BUILD_INFO "geobarrier.build-info"
typedef struct gb_build_info {
    uint32_t struct_size;
    uint32_t tableau_revision; /* GB_ADVANCE_TABLEAU_REVISION the code was compiled with */
    uint32_t vector_bits;      /* widest vectors the compiler could use: 128 (e.g. SSE2), 256 (AVX2), 512 (AVX-512) */
    uint32_t fma;              /* nonzero when a * b + c compiles to one fused multiply-add */
} gb_build_info;

/* ABI 1.4 extension "geobarrier.plot", offered by the core (gb_host_info.get_extension): pictures drawn by the core
 * (PLplot, PNG, written atomically) from plain arrays, so that an extractor draws them without linking the core. A
 * core older than 1.4 answers NULL for it: the extractor then skips its pictures (the SDK logs a note,
 * <geobarrier/sdk_plot.hpp>). Called from the thread that runs extract() only, like gb_host. Strings are UTF-8;
 * colours are a name the core knows ("red", "blue", "black", "white", "green", "orange", ...) or "#rrggbb". Arrays of
 * gb_plot_curve and gb_plot_series never grow; gb_plot_field, gb_plot_xy and gb_plot_service start with their size. */
#define GB_EXTENSION_PLOT "geobarrier.plot"

/* A polyline drawn over a field picture: `count` points, x and y interleaved. */
typedef struct gb_plot_curve {
    const double *xy;
    uint64_t count;
    const char *color;
    double width;
    int32_t closed;
    int32_t points_only; /* nonzero: filled discs of marker_px diameter (pixels), no line */
    double marker_px;
} gb_plot_curve;

/* A field on the grid (values and mask as in gb_extract_input: row-major, ny rows of nx; mask 0 = valid, masked
 * points drawn in light grey) as a colour map with axes, a colour bar and curves over it. */
typedef struct gb_plot_field {
    uint32_t struct_size;
    double x_min, x_max, y_min, y_max;
    uint64_t nx, ny;
    const double *values;
    const uint8_t *mask; /* may be NULL: nothing masked */
    const char *title, *x_label, *y_label, *colorbar_label;
    uint32_t curve_count;
    const gb_plot_curve *curves;
    int32_t width_px; /* the picture's width; its height follows the box's aspect */
} gb_plot_field;

/* One series of an x-y picture; non-finite points split a line. */
typedef enum gb_plot_style { GB_PLOT_LINE = 0, GB_PLOT_POINTS = 1, GB_PLOT_LINE_POINTS = 2 } gb_plot_style;
typedef enum gb_plot_dash { GB_PLOT_SOLID = 0, GB_PLOT_DASHED = 1, GB_PLOT_DOTTED = 2 } gb_plot_dash;
typedef struct gb_plot_series {
    const double *xy;
    uint64_t count;
    const char *label; /* legend entry; "" or NULL: not listed */
    const char *color;
    double width;
    int32_t style; /* gb_plot_style */
    int32_t dash;  /* gb_plot_dash */
    double marker_px;
    int32_t closed;
} gb_plot_series;

typedef enum gb_plot_legend {
    GB_LEGEND_TOP_RIGHT = 0,
    GB_LEGEND_TOP_LEFT = 1,
    GB_LEGEND_BOTTOM_RIGHT = 2,
    GB_LEGEND_BOTTOM_LEFT = 3,
    GB_LEGEND_OUTSIDE_RIGHT = 4
} gb_plot_legend;

/* An x-y picture: axes, a title, series and, when a series has a label, a legend. */
typedef struct gb_plot_xy {
    uint32_t struct_size;
    const char *title, *x_label, *y_label;
    uint32_t series_count;
    const gb_plot_series *series;
    int32_t log_x, log_y;             /* logarithmic axes (non-positive values left out) */
    int32_t equal_aspect;             /* one unit of x as long as one of y */
    double aspect;                    /* box height / width when not equal_aspect */
    int32_t has_x_range, has_y_range; /* else the data's range, padded by 3% */
    double x_range[2], y_range[2];
    int32_t legend; /* gb_plot_legend */
    int32_t width_px;
} gb_plot_xy;

typedef struct gb_plot_service {
    uint32_t struct_size;
    /* Write the picture to `file` (a path; PNG). GB_ERROR with the reason in msg when it cannot. */
    gb_status (*field_png)(const char *file, const gb_plot_field *plot, gb_message *msg);
    gb_status (*xy_png)(const char *file, const gb_plot_xy *plot, gb_message *msg);
} gb_plot_service;

typedef struct gb_plugin_entry {
    uint32_t abi_major; /* must equal GB_ABI_VERSION_MAJOR; checked before anything else is read */
    uint32_t abi_minor;
    uint32_t count;
    const gb_plugin_descriptor *descriptors;
    /* ABI 1.3, appended (read when abi_minor >= 3), may be NULL: an extension of plugin `descriptor` (an index
     * into descriptors), or of the library when descriptor is UINT32_MAX, by id; NULL when it has none. */
    const void *(*get_extension)(uint32_t descriptor, const char *id);
} gb_plugin_entry;

/* Signatures of the exported entry points, named GB_PLUGIN_ENTRY_SYMBOL and GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL. */
typedef const gb_plugin_entry *(*gb_plugin_entry_fn)(void);
typedef const gb_plugin_entry *(*gb_plugin_entry_with_host_fn)(const gb_host_info *host);

#ifdef __cplusplus
}
#endif

/* The contracts of every call across this boundary.
 *
 * Times. Every lane carries its own time t[k]: the core's lockstep engine passes the same value in every lane of a
 * call (a batch advances together), while other callers (check-plugin's conformance checks, forcings evaluated at
 * sample times) pass different ones; read t[k] per lane, never assume the lanes' times are equal. A fused step
 * (gb_advance_request) is the exception: all its lanes share t.
 *
 * Pointer lifetimes. What the caller passes into a call (states, times, forcing values, output buffers, requests,
 * gb_param_values and its strings, gb_extract_input with its fields, mask and names, the gb_host, gb_message) is
 * valid only during that call: copy what must outlive it. What a plugin hands the core (the entry, descriptors,
 * parameter specs, vtables, names, docs, required_fields, domain and state names, extensions) must stay valid and
 * unchanged as long as the library is loaded. An instance (`self`, from create) is valid until destroy, which the
 * core calls exactly once, after its last call on that instance. Arrays given to gb_host.add_barrier and
 * set_barrier_attributes are copied before the call returns. gb_host_info lives as long as the process.
 *
 * Threads. The core calls an entry point, create and destroy from one thread at a time. A system's or forcing's
 * rhs, jacobian, divergence, advance, evaluate and combine are called on one instance from several threads at once
 * (each call with its own buffers) when the descriptor says GB_THREAD_SAFE_CONCURRENT. With
 * GB_THREAD_SAFE_PER_INSTANCE they are called from one thread at a time: the core does not create one instance per
 * thread, it integrates with such a system or forcing (or a composite forcing with such a term) on one thread;
 * separate instances are independent. An extractor's extract() runs on one thread; it may use threads of its own,
 * but calls the gb_host functions only from the thread that runs extract() (the host's list of barriers has no
 * lock). */

#endif /* GEOBARRIER_ABI_H */
