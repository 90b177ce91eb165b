// The wrappers that call a plugin across the ABI (plugin.hpp): an instance of its parameters, System, Forcing (a
// composite one with its terms) and Extractor, with the host services an extractor calls back (log, progress,
// barriers, advection).
#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <spdlog/spdlog.h>

#include <cstring>
#include <string>
#include <vector>

namespace geobarrier {

PluginInstance::PluginInstance(const PluginHandle &handle, const ParamValues &values)
    : m_handle(std::make_shared<const PluginHandle>(handle)) {
    char text[512] = {0};
    gb_message msg{text, sizeof text};
    void *self = handle.descriptor->create(values.c_view(), &msg);
    if (!self)
        throw PluginError(handle.info.file.string() + ": " + to_string(handle.info.kind) + " '" + handle.info.name +
                          "' could not be created: " + (text[0] ? text : "no message"));
    // The deleter holds the handle (and so the library) until the object is gone.
    auto keep = m_handle;
    m_self = std::shared_ptr<void>(self, [keep](void *p) { keep->descriptor->destroy(p); });
}

namespace {
// One message buffer per call keeps the wrappers thread-safe.
// Only the first byte is cleared: this runs on every batched call.
struct CallMessage {
    char text[512];
    gb_message msg{text, sizeof text};
    CallMessage() { text[0] = '\0'; }
};
} // namespace

System::System(const PluginHandle &handle, const ParamValues &values) : m_instance(handle, values) {
    if (handle.info.kind != PluginKind::system)
        throw PluginError(handle.info.file.string() + ": '" + handle.info.name + "' is not a system");
    m_table = handle.descriptor->system;
    if (handle.info.abi_minor >= 2) m_advance = m_table->advance;
}

void System::rhs(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *dxdt,
                 std::int32_t *lane_status) const {
    CallMessage m;
    check_plugin_status(m_table->rhs(m_instance.self(), n, ld, t, x, f, dxdt, lane_status, &m.msg), info(), "rhs",
                        m.text);
}

void System::jacobian(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *jac,
                      std::int32_t *lane_status) const {
    if (!m_table->jacobian) throw PluginError(info().file.string() + ": system '" + info().name + "' has no Jacobian");
    CallMessage m;
    check_plugin_status(m_table->jacobian(m_instance.self(), n, ld, t, x, f, jac, lane_status, &m.msg), info(),
                        "jacobian", m.text);
}

void System::divergence(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *div,
                        std::int32_t *lane_status) const {
    if (!m_table->divergence)
        throw PluginError(info().file.string() + ": system '" + info().name + "' has no divergence");
    CallMessage m;
    check_plugin_status(m_table->divergence(m_instance.self(), n, ld, t, x, f, div, lane_status, &m.msg), info(),
                        "divergence", m.text);
}

bool System::advance(const gb_advance_request &request) const {
    if (!m_advance) return false;
    CallMessage m;
    // The request names the numerics the core expects (ABI 1.3): a plugin compiled with other ones declines.
    gb_advance_request named = request;
    named.tableau_revision = GB_ADVANCE_TABLEAU_REVISION;
    const gb_status status = m_advance(m_instance.self(), &named, &m.msg);
    if (status == GB_UNSUPPORTED) return false;
    check_plugin_status(status, info(), "advance", m.text);
    return true;
}

Forcing::Forcing(const PluginHandle &handle, const ParamValues &values) : m_instance(handle, values) {
    if (handle.info.kind != PluginKind::forcing)
        throw PluginError(handle.info.file.string() + ": '" + handle.info.name + "' is not a forcing");
    m_table = handle.descriptor->forcing;
}

struct Forcing::Composite {
    std::vector<Forcing> terms;
    PluginInfo info; // the plugin's, with the weakest thread safety of the tree
};

Forcing::Forcing(const PluginHandle &handle, const ParamValues &values, std::vector<Forcing> terms)
    : Forcing(handle, values) {
    const PluginInfo &own = handle.info;
    const std::string who = own.file.string() + ": forcing '" + own.name + "'";
    if (!own.composite()) throw PluginError(who + " is not a composite forcing; it takes no terms");
    if (terms.size() < own.min_terms || terms.size() > own.max_terms)
        throw PluginError(who + " takes " + std::to_string(own.min_terms) + " to " + std::to_string(own.max_terms) +
                          " terms, not " + std::to_string(terms.size()));
    auto composite = std::make_shared<Composite>();
    composite->info = own;
    for (const Forcing &term : terms)
        if (term.info().thread_safety != GB_THREAD_SAFE_CONCURRENT)
            composite->info.thread_safety = GB_THREAD_SAFE_PER_INSTANCE;
    composite->terms = std::move(terms);
    m_composite = std::move(composite);
}

const PluginInfo &Forcing::info() const { return m_composite ? m_composite->info : m_instance.info(); }

const std::vector<Forcing> &Forcing::terms() const {
    static const std::vector<Forcing> none;
    return m_composite ? m_composite->terms : none;
}

void Forcing::evaluate(std::size_t n, const double *t, double *f) const {
    if (m_composite) {
        // The flow-map engine asks for one time per stage: the terms' values fit on the stack.
        const std::vector<Forcing> &terms = m_composite->terms;
        constexpr std::size_t small = 64;
        double stack_values[small];
        std::vector<double> heap_values;
        double *values = stack_values;
        if (terms.size() * n > small) {
            heap_values.resize(terms.size() * n);
            values = heap_values.data();
        }
        for (std::size_t j = 0; j < terms.size(); ++j) terms[j].evaluate(n, t, values + j * n);
        combine(n, t, terms.size(), n, values, f);
        return;
    }
    if (info().composite())
        throw PluginError(info().file.string() + ": composite forcing '" + info().name +
                          "' was created without its terms");
    CallMessage m;
    check_plugin_status(m_table->evaluate(m_instance.self(), n, t, f, &m.msg), info(), "evaluate", m.text);
}

void Forcing::combine(std::size_t n, const double *t, std::size_t term_count, std::size_t ld, const double *terms,
                      double *f) const {
    if (!info().composite())
        throw PluginError(info().file.string() + ": forcing '" + info().name + "' is not a composite forcing");
    CallMessage m;
    check_plugin_status(
        m_table->combine(m_instance.self(), n, t, static_cast<std::uint32_t>(term_count), ld, terms, f, &m.msg), info(),
        "combine", m.text);
}

Extractor::Extractor(const PluginHandle &handle, const ParamValues &values) : m_instance(handle, values) {
    if (handle.info.kind != PluginKind::extractor)
        throw PluginError(handle.info.file.string() + ": '" + handle.info.name + "' is not an extractor");
    m_table = handle.descriptor->extractor;
}

namespace {
struct ExtractContext {
    std::string plugin;
    const ExtractServices *services;
    std::vector<Barrier> barriers;
};
void host_log(void *context, std::int32_t level, const char *line) {
    auto *c = static_cast<ExtractContext *>(context);
    if (level >= 2)
        spdlog::warn("{}: {}", c->plugin, line ? line : "");
    else if (level == 1)
        spdlog::info("{}: {}", c->plugin, line ? line : "");
    else
        spdlog::debug("{}: {}", c->plugin, line ? line : "");
}
// Nonzero asks the extractor to stop: the user interrupted the run (SIGINT/SIGTERM, cancel.hpp).
std::int32_t host_progress(void *, double) { return cancel_requested() != 0; }
gb_status host_add_barrier(void *context, const char *kind, std::int32_t closed, std::uint64_t count, const double *xy,
                           std::uint32_t metric_count, const char *const *names, const double *values) {
    auto *c = static_cast<ExtractContext *>(context);
    if (!kind || (count > 0 && !xy) || (metric_count > 0 && (!names || !values))) return GB_ERROR;
    Barrier b;
    b.kind = kind;
    b.closed = closed != 0;
    b.xy.assign(xy, xy + 2 * count);
    for (std::uint32_t i = 0; i < metric_count; ++i) b.metrics.emplace_back(names[i] ? names[i] : "", values[i]);
    c->barriers.push_back(std::move(b));
    return GB_OK;
}
gb_status host_advect(void *context, std::uint64_t n, const double *xy, double t_from, double t_to, double *xy_out,
                      double *dF_out, std::uint8_t *mask_out, gb_message *msg) {
    auto *c = static_cast<ExtractContext *>(context);
    try {
        if (!c->services->advect) throw Error("this host offers no advection");
        c->services->advect(n, xy, t_from, t_to, xy_out, dF_out, mask_out);
        return GB_OK;
    } catch (const std::exception &e) {
        if (msg && msg->text && msg->capacity) {
            std::strncpy(msg->text, e.what(), msg->capacity - 1);
            msg->text[msg->capacity - 1] = '\0';
        }
        return GB_ERROR;
    }
}
gb_status host_set_barrier_attributes(void *context, std::uint32_t count, const char *const *names,
                                      const char *const *json_values) {
    auto *c = static_cast<ExtractContext *>(context);
    if (c->barriers.empty() || (count > 0 && (!names || !json_values))) return GB_ERROR;
    std::vector<std::pair<std::string, std::string>> parsed;
    for (std::uint32_t i = 0; i < count; ++i) {
        if (!names[i] || !json_values[i]) return GB_ERROR;
        const auto value = nlohmann::json::parse(json_values[i], nullptr, false);
        if (value.is_discarded() || value.is_object() || value.is_array()) return GB_ERROR;
        parsed.emplace_back(names[i], value.dump());
    }
    auto &attributes = c->barriers.back().attributes;
    attributes.insert(attributes.end(), parsed.begin(), parsed.end());
    return GB_OK;
}
} // namespace

std::vector<Barrier> Extractor::extract(const gb_extract_input &input, const ExtractServices &services) const {
    ExtractContext context{info().name, &services, {}};
    const gb_host host{&context,          &host_log,    &host_progress,
                       &host_add_barrier, &host_advect, &host_set_barrier_attributes};
    CallMessage m;
    check_plugin_status(m_table->extract(m_instance.self(), &host, &input, &m.msg), info(), "extract", m.text);
    return std::move(context.barriers);
}

} // namespace geobarrier
