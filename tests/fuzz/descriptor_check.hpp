// What the descriptor fuzzer checks on each input, shared by the libFuzzer target (fuzz_descriptor.cpp) and by the
// regression test that replays its corpus and every input it once crashed on (test_fuzz_regressions.cpp).
//
// The input is decoded into a plugin library's entry, as a library's entry function would return it (descriptors,
// parameter schemas, a system's dimension, domain and state names, an extractor's field list, names short, long, or
// 65 bytes without an end), and handed to the loader's reader (detail::read_plugin_entry, plugin.cpp) without any
// library. The entry keeps the ABI's contract: arrays as long as they are declared, strings ended; except that a name
// may lack its end beyond max_declared_name_length + 1 characters, which the reader must not read past
// (AddressSanitizer says when it does). The reader must accept the entry or refuse it with a PluginError; what it
// accepts must keep every declared limit. Anything else escaping (another exception: the fuzzer reports it as a crash)
// is a bug.
#ifndef GEOBARRIER_TESTS_FUZZ_DESCRIPTOR_CHECK_HPP
#define GEOBARRIER_TESTS_FUZZ_DESCRIPTOR_CHECK_HPP

#include "plugins/plugin_entry.hpp"

#include <geobarrier/abi.h>
#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace geobarrier::fuzz {

// Reads the input front to back; past its end every value is 0.
class ByteReader {
  public:
    ByteReader(const std::uint8_t *data, std::size_t size) : m_data(data), m_size(size) {}
    std::uint8_t u8() { return m_at < m_size ? m_data[m_at++] : 0; }
    std::uint32_t u32() {
        std::uint32_t v = 0;
        for (int k = 0; k < 4; ++k) v |= static_cast<std::uint32_t>(u8()) << (8 * k);
        return v;
    }
    double f64() {
        std::uint64_t bits = 0;
        for (int k = 0; k < 8; ++k) bits |= static_cast<std::uint64_t>(u8()) << (8 * k);
        double v;
        std::memcpy(&v, &bits, sizeof v);
        return v;
    }
    // A count: small ones often (the 0x00-0xef range maps to 0..limit), the raw 32 bits after a 0xf0-0xff byte.
    std::uint32_t count(std::uint32_t limit) {
        const std::uint8_t b = u8();
        return b >= 0xf0 ? u32() : b % (limit + 1);
    }

  private:
    const std::uint8_t *m_data;
    std::size_t m_size, m_at = 0;
};

// Owns everything an entry points to.
class EntryBuilder {
  public:
    explicit EntryBuilder(ByteReader &in) : m_in(in) {}

    // A string by its first byte: 0xff none (NULL); 0x80-0xfe, where `unended` allows it, 65 bytes with no end (a name
    // the reader must bound; otherwise 65 ended characters); 0x40-0x7f a string of 64 to 127 characters; below, 0 to
    // 63 characters. Characters come from the input.
    const char *text(bool unended = true) {
        const std::uint8_t b = m_in.u8();
        if (b == 0xff) return nullptr;
        const bool ended = b < 0x80 || !unended;
        const std::size_t length = b >= 0x80 ? max_declared_name_length + 1 : b >= 0x40 ? 64 + (b & 0x3f) : b;
        auto buffer = std::make_unique<char[]>(length + (ended ? 1 : 0));
        for (std::size_t k = 0; k < length; ++k) buffer[k] = static_cast<char>(m_in.u8());
        if (ended) buffer[length] = '\0';
        m_text.push_back(std::move(buffer));
        return m_text.back().get();
    }
    // Strings a plugin must end (versions, docs, units, choices).
    const char *ended_text() { return text(false); }

    gb_plugin_entry entry() {
        gb_plugin_entry e{};
        e.abi_major = m_in.u8() == 0 ? GB_ABI_VERSION_MAJOR + 1 : GB_ABI_VERSION_MAJOR;
        e.abi_minor = m_in.u8() % 5;
        e.count = m_in.count(3);
        if (e.count <= 3) { // a larger count is declared without the descriptors: the reader would run off its array
            std::vector<gb_plugin_descriptor> &ds = m_descriptors.emplace_back(e.count);
            for (gb_plugin_descriptor &d : ds) d = descriptor();
            e.descriptors = m_in.u8() == 0xff ? nullptr : ds.data();
        } else {
            e.count = 0;
        }
        return e;
    }

  private:
    gb_plugin_descriptor descriptor() {
        gb_plugin_descriptor d{};
        d.kind = static_cast<std::int32_t>(m_in.u8() % 5) - 1;
        d.name = text();
        d.version = ended_text();
        d.doc = ended_text();
        d.thread_safety = m_in.u8();
        const std::uint8_t flags = m_in.u8();
        if (flags & 1) d.create = [](const gb_param_values *, gb_message *) -> void * { return nullptr; };
        if (flags & 2) d.destroy = [](void *) {};
        if (flags & 4) d.core_version = ended_text();
        if (flags & 8) d.system = system();
        if (flags & 16) d.forcing = forcing();
        if (flags & 32) d.extractor = extractor();
        d.param_count = m_in.count(6);
        if (d.param_count <= max_declared_params) {
            std::vector<gb_param_spec> &ps = m_params.emplace_back(d.param_count);
            for (gb_param_spec &p : ps) p = param();
            d.params = (flags & 64) ? nullptr : ps.data();
        } // else: more than a plugin may declare, and no array: refused before one is read
        return d;
    }

    gb_param_spec param() {
        gb_param_spec p{};
        p.name = text();
        p.type = static_cast<std::int32_t>(m_in.u8() % 6) - 1;
        p.default_value = m_in.f64();
        p.min_value = m_in.f64();
        p.max_value = m_in.f64();
        p.default_string = ended_text();
        p.choices = ended_text();
        p.unit = ended_text();
        p.doc = ended_text();
        return p;
    }

    const gb_system_vtable *system() {
        gb_system_vtable &s = m_systems.emplace_back();
        s.dimension = m_in.count(8);
        s.capabilities = m_in.u8();
        const std::uint8_t flags = m_in.u8();
        if (flags & 1)
            s.rhs = [](void *, std::uint64_t, std::uint64_t, const double *, const double *, const double *, double *,
                       std::int32_t *, gb_message *) -> gb_status { return GB_OK; };
        if (flags & 2)
            s.jacobian = [](void *, std::uint64_t, std::uint64_t, const double *, const double *, const double *,
                            double *, std::int32_t *, gb_message *) -> gb_status { return GB_OK; };
        if (s.dimension <= max_declared_dimension) { // arrays of `dimension` entries, as the ABI says
            if (flags & 4) s.domain_min = numbers(s.dimension);
            if (flags & 8) s.domain_max = numbers(s.dimension);
            if (flags & 16) s.state_names = texts(s.dimension, false);
            if (flags & 32) s.state_units = texts(s.dimension, true);
        }
        return &s;
    }

    const gb_forcing_vtable *forcing() {
        gb_forcing_vtable &f = m_forcings.emplace_back();
        const std::uint8_t flags = m_in.u8();
        if (flags & 1)
            f.evaluate = [](void *, std::uint64_t, const double *, double *, gb_message *) -> gb_status {
                return GB_OK;
            };
        if (flags & 2)
            f.combine = [](void *, std::uint64_t, const double *, std::uint32_t, std::uint64_t, const double *,
                           double *, gb_message *) -> gb_status { return GB_OK; };
        f.min_terms = m_in.count(4);
        f.max_terms = m_in.count(4);
        return &f;
    }

    const gb_extractor_vtable *extractor() {
        gb_extractor_vtable &x = m_extractors.emplace_back();
        const std::uint8_t flags = m_in.u8();
        if (flags & 1)
            x.extract = [](void *, const gb_host *, const gb_extract_input *, gb_message *) -> gb_status {
                return GB_OK;
            };
        if (flags & 2) {
            // NULL-terminated; up to 80 names (more than a plugin may declare), none of them NULL before the end.
            const std::uint32_t n = m_in.count(80) % 81;
            std::vector<const char *> &list = m_lists.emplace_back();
            for (std::uint32_t k = 0; k < n; ++k) {
                const char *name = text();
                list.push_back(name ? name : "");
            }
            list.push_back(nullptr);
            x.required_fields = list.data();
        }
        return &x;
    }

    const double *numbers(std::uint32_t n) {
        std::vector<double> &v = m_numbers.emplace_back(n);
        for (double &x : v) x = m_in.f64();
        return v.data();
    }
    const char *const *texts(std::uint32_t n, bool ended) {
        std::vector<const char *> &v = m_lists.emplace_back(n);
        for (const char *&t : v) t = text(!ended);
        return v.data();
    }

    ByteReader &m_in;
    // deques: what an entry points to never moves while more is added
    std::deque<std::unique_ptr<char[]>> m_text;
    std::deque<std::vector<gb_plugin_descriptor>> m_descriptors;
    std::deque<std::vector<gb_param_spec>> m_params;
    std::deque<gb_system_vtable> m_systems;
    std::deque<gb_forcing_vtable> m_forcings;
    std::deque<gb_extractor_vtable> m_extractors;
    std::deque<std::vector<const char *>> m_lists;
    std::deque<std::vector<double>> m_numbers;
};

inline void require(bool ok, const std::string &what) {
    if (!ok) throw std::logic_error("the descriptor reader accepted " + what);
}

// Decodes the input into an entry and reads it. Returns true when the reader accepted it (after checking that what it
// accepted keeps every declared limit), false when it refused it with a PluginError; anything else escapes.
inline bool check_descriptor_bytes(const std::uint8_t *data, std::size_t size) {
    ByteReader in(data, size);
    EntryBuilder builder(in);
    const gb_plugin_entry entry = builder.entry();
    std::vector<PluginInfo> infos;
    try {
        infos = detail::read_plugin_entry(entry, "fuzzed.so");
    } catch (const PluginError &e) {
        require(std::string(e.what()).rfind("fuzzed.so: ", 0) == 0, "... no: refused without naming the file");
        return false;
    }
    require(infos.size() == entry.count && entry.count > 0, "a count of plugins other than the entry's");
    for (const PluginInfo &info : infos) {
        require(!info.name.empty() && info.name.size() <= max_declared_name_length, "a name out of bounds");
        require(info.params.size() <= max_declared_params, "too many parameters");
        for (const ParamSpec &p : info.params)
            require(!p.name.empty() && p.name.size() <= max_declared_name_length, "a parameter name out of bounds");
        if (info.kind == PluginKind::system) {
            require(info.dimension >= 1 && info.dimension <= max_declared_dimension, "a dimension out of bounds");
            require(info.state_names.empty() || info.state_names.size() == info.dimension, "state names not one each");
            require(info.domain_min.size() == info.domain_max.size(), "a domain with one side");
            for (std::size_t k = 0; k < info.domain_min.size(); ++k)
                require(info.domain_min[k] < info.domain_max[k], "an empty domain");
            for (const std::string &name : info.state_names)
                require(name.size() <= max_declared_name_length, "a state name out of bounds");
        }
        require(info.required_fields.size() <= max_declared_fields, "too many required fields");
    }
    return true;
}

} // namespace geobarrier::fuzz

#endif // GEOBARRIER_TESTS_FUZZ_DESCRIPTOR_CHECK_HPP
