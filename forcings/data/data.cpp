// A measured forcing: a time series read from a CSV file, joined by a natural cubic spline (twice continuously
// differentiable, so the ODE right-hand side stays smooth for the steppers). Unsorted, repeated or gapped samples
// are errors naming the file and line: a spline through them would silently invent a forcing.
#include <geobarrier/sdk.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using geobarrier::sdk::integer_param;
using geobarrier::sdk::Params;
using geobarrier::sdk::path_param;
using geobarrier::sdk::real_param;

std::string trim(const std::string &s) {
    const auto first = s.find_first_not_of(" \t\r");
    if (first == std::string::npos) return "";
    return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

std::string num(double v) {
    std::ostringstream s;
    s.precision(10);
    s << v;
    return s.str();
}

// The fields of one line: split at the file's delimiter (',', ';', tab), or at runs of blanks when it has none.
std::vector<std::string> split_fields(const std::string &line, char delimiter) {
    std::vector<std::string> fields;
    if (delimiter == ' ') {
        std::istringstream in(line);
        std::string field;
        while (in >> field) fields.push_back(field);
        return fields;
    }
    std::string field;
    std::istringstream in(line);
    while (std::getline(in, field, delimiter)) fields.push_back(trim(field));
    if (!line.empty() && line.back() == delimiter) fields.emplace_back();
    return fields;
}

// A whole field as a finite number, or false.
bool parse_number(const std::string &field, double &value) {
    if (field.empty()) return false;
    errno = 0;
    char *end = nullptr;
    value = std::strtod(field.c_str(), &end);
    return end == field.c_str() + field.size() && errno != ERANGE && std::isfinite(value);
}

struct Sample {
    double t, value;
    std::size_t line;
};

std::vector<Sample> read_series(const std::string &file, std::size_t time_column, std::size_t value_column,
                                double gap_factor) {
    if (file.empty()) throw std::invalid_argument("parameter \"file\" is required: the CSV file of the time series");
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file + ": cannot open the data file");
    std::vector<Sample> samples;
    char delimiter = 0;
    bool header_allowed = true;
    std::string raw;
    for (std::size_t line_no = 1; std::getline(in, raw); ++line_no) {
        const std::string line = trim(raw);
        if (line.empty() || line[0] == '#') continue;
        const std::string where = file + ":" + std::to_string(line_no) + ": ";
        if (!delimiter)
            delimiter = line.find(',') != std::string::npos    ? ','
                        : line.find(';') != std::string::npos  ? ';'
                        : line.find('\t') != std::string::npos ? '\t'
                                                               : ' ';
        const std::vector<std::string> fields = split_fields(line, delimiter);
        const std::size_t needed = std::max(time_column, value_column) + 1;
        double t = 0.0, value = 0.0;
        const bool time_ok = fields.size() > time_column && parse_number(fields[time_column], t);
        // The first line may be a header ("t,f"): its time field is not a number.
        if (!time_ok && header_allowed && fields.size() >= needed) {
            header_allowed = false;
            continue;
        }
        header_allowed = false;
        if (fields.size() < needed)
            throw std::runtime_error(where + "has " + std::to_string(fields.size()) + " field(s); time_column " +
                                     std::to_string(time_column) + " and value_column " + std::to_string(value_column) +
                                     " need " + std::to_string(needed));
        if (!time_ok) throw std::runtime_error(where + "time \"" + fields[time_column] + "\" is not a finite number");
        if (!parse_number(fields[value_column], value))
            throw std::runtime_error(where + "missing or non-numeric value \"" + fields[value_column] +
                                     "\" (a gap in the data): every time needs a finite value");
        if (!samples.empty()) {
            const Sample &previous = samples.back();
            if (t == previous.t)
                throw std::runtime_error(where + "time " + num(t) + " repeats line " + std::to_string(previous.line) +
                                         ": times must be strictly increasing");
            if (t < previous.t)
                throw std::runtime_error(where + "time " + num(t) + " comes before " + num(previous.t) + " (line " +
                                         std::to_string(previous.line) + "): the series must be sorted by time");
        }
        samples.push_back({t, value, line_no});
    }
    if (samples.size() < 2)
        throw std::runtime_error(file + ": needs at least 2 samples, found " + std::to_string(samples.size()));
    if (gap_factor > 0.0) {
        std::vector<double> spacing;
        for (std::size_t i = 1; i < samples.size(); ++i) spacing.push_back(samples[i].t - samples[i - 1].t);
        std::vector<double> sorted = spacing;
        std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
        const double median = sorted[sorted.size() / 2];
        for (std::size_t i = 1; i < samples.size(); ++i)
            if (spacing[i - 1] > gap_factor * median)
                throw std::runtime_error(file + ":" + std::to_string(samples[i].line) + ": gap in the data: time " +
                                         "jumps from " + num(samples[i - 1].t) + " (line " +
                                         std::to_string(samples[i - 1].line) + ") to " + num(samples[i].t) +
                                         ", more than gap_factor " + num(gap_factor) + " x the median spacing " +
                                         num(median) + " (fill the gap, or set gap_factor: 0 accepts any spacing)");
    }
    return samples;
}

struct Data {
    static constexpr const char *name = "data";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "measured forcing: a CSV time series (t, f) joined by a natural cubic spline (C2); defined on its time range";
    static constexpr gb_param_spec params[] = {
        path_param("file", "", "CSV file, one sample per line (# comments, an optional header line)"),
        integer_param("time_column", 0, 0, 1000, "column of the time, counted from 0"),
        integer_param("value_column", 1, 0, 1000, "column of the forcing value, counted from 0"),
        real_param("scale", 1.0, -HUGE_VAL, HUGE_VAL, "", "factor applied to the values"),
        real_param("gap_factor", 1.5, 0.0, HUGE_VAL, "",
                   "a spacing above gap_factor x the median spacing is a gap, an error (0: any spacing)"),
    };

    explicit Data(const Params &p) : m_file(p.string("file")) {
        const std::vector<Sample> samples =
            read_series(m_file, static_cast<std::size_t>(p.integer("time_column")),
                        static_cast<std::size_t>(p.integer("value_column")), p.real("gap_factor"));
        const double scale = p.real("scale");
        for (const Sample &s : samples) {
            m_t.push_back(s.t);
            m_f.push_back(scale * s.value);
        }
        fit_natural_spline();
    }

    // Second derivatives m_m of the natural cubic spline (m_m = 0 at both ends): the tridiagonal system
    // h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = 6 (slope[i] - slope[i-1]), solved by the Thomas algorithm
    // (diagonally dominant, so stable without pivoting).
    void fit_natural_spline() {
        const std::size_t n = m_t.size();
        m_m.assign(n, 0.0);
        if (n < 3) return;
        std::vector<double> diag(n, 0.0), upper(n, 0.0), rhs(n, 0.0);
        for (std::size_t i = 1; i + 1 < n; ++i) {
            const double h0 = m_t[i] - m_t[i - 1], h1 = m_t[i + 1] - m_t[i];
            diag[i] = 2.0 * (h0 + h1);
            upper[i] = h1;
            rhs[i] = 6.0 * ((m_f[i + 1] - m_f[i]) / h1 - (m_f[i] - m_f[i - 1]) / h0);
            if (i > 1) { // eliminate the sub-diagonal entry h0 with row i - 1
                const double w = h0 / diag[i - 1];
                diag[i] -= w * upper[i - 1];
                rhs[i] -= w * rhs[i - 1];
            }
        }
        for (std::size_t i = n - 2; i >= 1; --i) {
            m_m[i] = (rhs[i] - upper[i] * m_m[i + 1]) / diag[i];
            if (i == 1) break;
        }
    }

    void evaluate(std::size_t n, const double *t, double *f) const {
        const double first = m_t.front(), last = m_t.back();
        for (std::size_t k = 0; k < n; ++k) {
            const double tk = t[k];
            if (!(tk >= first && tk <= last))
                throw std::runtime_error("t = " + num(tk) + " is outside the data's time range [" + num(first) + ", " +
                                         num(last) + "] (" + m_file + ")");
            // Interval i with m_t[i] <= tk <= m_t[i + 1].
            std::size_t i = static_cast<std::size_t>(std::upper_bound(m_t.begin(), m_t.end(), tk) - m_t.begin());
            i = std::min(i, m_t.size() - 1) - 1;
            const double h = m_t[i + 1] - m_t[i];
            const double a = (m_t[i + 1] - tk) / h, b = (tk - m_t[i]) / h;
            f[k] =
                a * m_f[i] + b * m_f[i + 1] + ((a * a * a - a) * m_m[i] + (b * b * b - b) * m_m[i + 1]) * (h * h / 6.0);
        }
    }

    std::string m_file;
    std::vector<double> m_t, m_f, m_m;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<Data>())
