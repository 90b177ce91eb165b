// Aperiodic forcing for the paper's eqs. duffing-ex3/duffing-ex4 (Fig. force-ex3): logistic-map samples, one per
// `interval`, joined by a uniform cubic B-spline so that f is C^2 and the ODE right-hand side stays smooth.
//
// Definition (the reference docs quote it; keep them in step):
//   z_0 = seed,            z_{n+1} = (r z_n) (1 - z_n)          for n = 0 .. span-1   (forward stream)
//   z_{-1} = W(seed, 1),   z_{-m-1} = (r z_{-m}) (1 - z_{-m})    for m = 1 .. span-1   (backward stream)
//   W(x, j) = 0.05 + 0.9 frac(x + j phi),  phi = 0.6180339887498949 (golden ratio - 1), frac(y) = y - floor(y)
//   g_n = amplitude (2 z_n - 1)
//   f(t) = sum_n g_n B3((t - start) / interval - n),   B3 the centred uniform cubic B-spline on [-2, 2]
// defined for t in [start + (1 - span) interval, start + (span - 1) interval]; outside it evaluation fails.
// Guard: an iterate that is not strictly inside (0, 1), or that equals bit-for-bit one of the previous
// `cycle_window` values of its stream (in floating point the orbit would repeat from then on), is replaced by
// W(seed, 1 + m) for the m-th such event (m = 1, 2, ..., forward stream first). More than `max_reinjections`
// events mean r sits in a periodic window of the map, and creation fails.
// No mean is subtracted: at r = 4 the invariant density 1 / (pi sqrt(z (1 - z))) is symmetric about 1/2, so
// E[g] = 0, and a sample mean would make f(t) depend on `span`. With this definition f on a common window does
// not depend on `span` at all.
#include <geobarrier/sdk.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using geobarrier::sdk::integer_param;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

constexpr double golden_phi = 0.6180339887498949;
constexpr int cycle_window = 64; // cycles up to this period are caught the moment they close
// At r = 4, about 1 seed in 1000 needs one re-injection in 2 x 200000 samples (its orbit hits 1/2 -> 1 -> 0); in a
// periodic window (r = 3.63, 3.74, 3.83, ...) the orbit lands on the cycle again within a few hundred steps.
constexpr int max_reinjections = 16;

// A deterministic value in [0.05, 0.95] (a golden-ratio Weyl sequence): the backward stream's first value and the
// re-injected value after a degenerate step. Kept off 0 and 1; the next step's guard checks the orbit again.
double weyl(double x, double j) {
    const double y = x + j * golden_phi;
    return 0.05 + 0.9 * (y - std::floor(y));
}

std::string format_number(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
}

struct ChaoticMap {
    static constexpr const char *name = "chaotic-map";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "aperiodic forcing: logistic-map samples amplitude (2 z_n - 1) joined by a C^2 cubic B-spline";
    static constexpr gb_param_spec params[] = {
        real_param("amplitude", 0.1, 0.0, HUGE_VAL, "", "bound on |f|: samples are amplitude (2 z_n - 1)"),
        real_param("interval", 1.0, 1e-9, HUGE_VAL, "time", "time between consecutive map samples (spline knots)"),
        real_param("seed", 0.3141592653589793, 0.0, 1.0, "",
                   "z_0, the map's initial value (degenerate orbits are re-injected)"),
        real_param("r", 4.0, 3.57, 4.0, "", "logistic map parameter: z_{n+1} = r z_n (1 - z_n); 4 is fully chaotic"),
        real_param("start", 0.0, -HUGE_VAL, HUGE_VAL, "time", "time of sample z_0"),
        integer_param("span", 200000, 2, 10000000,
                      "samples on each side of start: f is defined for |t - start| <= (span - 1) interval"),
    };

    explicit ChaoticMap(const Params &p)
        : m_amplitude(p.real("amplitude")), m_interval(p.real("interval")), m_seed(p.real("seed")), m_r(p.real("r")),
          m_start(p.real("start")), m_span(p.integer("span")) {
        if (!(m_interval > 0.0)) throw std::invalid_argument("chaotic-map: interval must be positive");
        if (m_span < 2) throw std::invalid_argument("chaotic-map: span must be at least 2");
        m_t_lo = m_start + static_cast<double>(1 - m_span) * m_interval;
        m_t_hi = m_start + static_cast<double>(m_span - 1) * m_interval;
        m_samples.assign(static_cast<std::size_t>(2 * m_span + 1), 0.0);
        double *g = m_samples.data() + m_span; // g[n], n in [-span, span]
        int events = 0;
        iterate_stream(m_seed, g, +1, events);
        iterate_stream(weyl(m_seed, 1.0), g - 1, -1, events);
        for (double &v : m_samples) v = m_amplitude * (2.0 * v - 1.0);
    }

    // Writes z into first[0], first[step], ..., span values for the forward stream (step +1, from z_0 = seed)
    // and the backward one (step -1, from z_{-1}).
    void iterate_stream(double z, double *first, int step, int &events) const {
        const long long count = step > 0 ? m_span + 1 : m_span;
        double recent[cycle_window];
        for (double &v : recent) v = -1.0; // not a map value
        first[0] = z;
        recent[0] = z;
        for (long long n = 1; n < count; ++n) {
            // Exactly two IEEE multiplications and one subtraction, in this order (see CMakeLists: no contraction).
            const double a = m_r * z;
            const double b = 1.0 - z;
            double w = a * b;
            bool repeat = false;
            for (int j = 0; j < cycle_window; ++j) repeat |= (recent[j] == w);
            if (!(w > 0.0 && w < 1.0) || repeat) {
                ++events;
                if (events > max_reinjections)
                    throw std::invalid_argument(
                        "chaotic-map: the logistic orbit at r = " + format_number(m_r) + " from seed " +
                        format_number(m_seed) + " fell onto a cycle or onto 0/1 more than " +
                        std::to_string(max_reinjections) +
                        " times: r lies in a periodic window of the map; use r = 4 (fully chaotic) or another r");
                w = weyl(m_seed, 1.0 + events);
            }
            z = w;
            first[n * step] = z;
            recent[n % cycle_window] = z;
        }
    }

    // f(t) for n times. A first pass checks the window (a reduction), so the evaluation loop has no branch.
    void evaluate(std::size_t n, const double *t, double *f) const {
        bool outside = false;
        for (std::size_t k = 0; k < n; ++k) outside |= !(t[k] >= m_t_lo && t[k] <= m_t_hi);
        if (outside) {
            std::size_t bad = 0;
            while (bad < n && t[bad] >= m_t_lo && t[bad] <= m_t_hi) ++bad;
            throw std::out_of_range("chaotic-map: t = " + format_number(t[bad]) +
                                    " is outside the forcing's time window [" + format_number(m_t_lo) + ", " +
                                    format_number(m_t_hi) + "] (start " + format_number(m_start) + ", " +
                                    std::to_string(m_span) + " samples of interval " + format_number(m_interval) +
                                    " on each side); raise 'span' or move 'start'");
        }
        const double *__restrict g = m_samples.data() + m_span;
        const double *__restrict tt = t;
        double *__restrict out = f;
        const double start = m_start, interval = m_interval;
        // Piece i covers u in [i, i+1] and uses g_{i-1} .. g_{i+2}; clamping keeps rounding at the window's ends
        // inside the samples (there the spline is continuous, so the clamped piece gives the same value).
        const double first_piece = static_cast<double>(1 - m_span), last_piece = static_cast<double>(m_span - 2);
        for (std::size_t k = 0; k < n; ++k) {
            const double u = (tt[k] - start) / interval;
            const double piece = std::min(std::max(std::floor(u), first_piece), last_piece);
            const long long i = static_cast<long long>(piece);
            const double s = u - piece, c = 1.0 - s;
            const double s2 = s * s, s3 = s2 * s;
            // Uniform cubic B-spline weights; nonnegative and summing to 1, so |f| <= max |g_n| <= amplitude.
            const double w0 = c * c * c / 6.0;
            const double w1 = (3.0 * s3 - 6.0 * s2 + 4.0) / 6.0;
            const double w2 = (-3.0 * s3 + 3.0 * s2 + 3.0 * s + 1.0) / 6.0;
            const double w3 = s3 / 6.0;
            out[k] = w0 * g[i - 1] + w1 * g[i] + w2 * g[i + 1] + w3 * g[i + 2];
        }
    }

    double m_amplitude, m_interval, m_seed, m_r, m_start;
    long long m_span;
    double m_t_lo = 0.0, m_t_hi = 0.0;
    std::vector<double> m_samples; // g_n for n = -span .. span
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<ChaoticMap>())
