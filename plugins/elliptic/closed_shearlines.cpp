// Candidate elliptic regions from the CG line field's singularities, Poincaré sections across them, the return
// map of shearlines and its fixed points (paper Alg. 2, steps 2-3, with the regions found automatically).
#include "closed_shearlines.hpp"

#include <geobarrier/curves.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace geobarrier::elliptic {

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();
constexpr double pi = 3.14159265358979323846;

double grid_spacing(const Grid &g) { return std::min(g.dx(), g.dy()); }

bool inside(const Grid &g, double x, double y) { return x >= g.x_min && x <= g.x_max && y >= g.y_min && y <= g.y_max; }

} // namespace

double Section::length() const { return std::hypot(x1 - x0, y1 - y0); }

void Section::point(double sigma, double &x, double &y) const {
    x = x0 + sigma * (x1 - x0);
    y = y0 + sigma * (y1 - y0);
}

double otsu_threshold(const std::vector<double> &values) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::size_t count = 0;
    for (double v : values)
        if (std::isfinite(v)) {
            lo = std::min(lo, v);
            hi = std::max(hi, v);
            ++count;
        }
    if (count == 0) return nan_value;
    if (!(hi > lo)) return hi;
    constexpr int bins = 256;
    std::vector<double> hist(bins, 0.0);
    for (double v : values)
        if (std::isfinite(v)) hist[std::min(bins - 1, static_cast<int>((v - lo) / (hi - lo) * bins))] += 1.0;
    double total_moment = 0.0;
    for (int b = 0; b < bins; ++b) total_moment += b * hist[b];
    double weight_low = 0.0, moment_low = 0.0, best = -1.0;
    int best_bin = 0;
    for (int b = 0; b < bins; ++b) {
        weight_low += hist[b];
        moment_low += b * hist[b];
        const double weight_high = static_cast<double>(count) - weight_low;
        if (weight_low == 0.0 || weight_high == 0.0) continue;
        const double mean_low = moment_low / weight_low, mean_high = (total_moment - moment_low) / weight_high;
        const double between = weight_low * weight_high * (mean_low - mean_high) * (mean_low - mean_high);
        if (between > best) {
            best = between;
            best_bin = b;
        }
    }
    return lo + (best_bin + 1) * (hi - lo) / bins;
}

double island_ftle_threshold(const CauchyGreenField &cg, double given) {
    if (given > 0.0) return given;
    std::vector<double> ftle_values;
    ftle_values.reserve(cg.grid.size());
    for (std::size_t p = 0; p < cg.grid.size(); ++p)
        if (!(cg.mask[p] & mask_trajectory_bits) && std::isfinite(cg.ftle[p])) ftle_values.push_back(cg.ftle[p]);
    return otsu_threshold(ftle_values);
}

std::vector<Candidate> find_candidates(const CauchyGreenField &cg, const CandidateSettings &settings,
                                       CandidateReport *report) {
    const Grid &g = cg.grid;
    const double h = grid_spacing(g);
    CandidateReport local;
    CandidateReport &r = report ? *report : local;
    r = CandidateReport{};
    r.singularities = tensor_singularities(cg);
    std::vector<TensorSingularity> resolved;
    for (const auto &s : r.singularities)
        if (s.anisotropy < settings.max_anisotropy) resolved.push_back(s);
    r.resolved = resolved.size();

    r.ftle_threshold = island_ftle_threshold(cg, settings.ftle_threshold);

    // Centres: index +1 points, and mutually nearest wedge pairs.
    std::vector<Candidate> centres;
    const std::size_t n = resolved.size();
    std::vector<std::size_t> nearest(n, n);
    for (std::size_t a = 0; a < n; ++a) {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t b = 0; b < n; ++b) {
            if (a == b) continue;
            const double d = std::hypot(resolved[a].x - resolved[b].x, resolved[a].y - resolved[b].y);
            if (d < best) {
                best = d;
                nearest[a] = b;
            }
        }
    }
    for (std::size_t a = 0; a < n; ++a) {
        if (resolved[a].twice_index == 2) centres.push_back({resolved[a].x, resolved[a].y, "index +1 point", 0.0, {}});
        const std::size_t b = nearest[a];
        if (resolved[a].twice_index == 1 && b < n && b > a && nearest[b] == a && resolved[b].twice_index == 1)
            centres.push_back(
                {0.5 * (resolved[a].x + resolved[b].x), 0.5 * (resolved[a].y + resolved[b].y), "wedge pair", 0.0, {}});
    }

    std::vector<Candidate> out;
    const double threshold = r.ftle_threshold;
    auto ftle_at = [&](double x, double y) { return sample_field(g, cg.ftle, cg.mask, x, y, mask_trajectory_bits); };
    for (Candidate c : centres) {
        const double f0 = ftle_at(c.x, c.y);
        if (!(f0 < threshold)) {
            ++r.rejected_high_ftle;
            continue;
        }
        // Two candidates closer than two grid spacings are one.
        bool duplicate = false;
        for (const Candidate &o : out) duplicate = duplicate || std::hypot(o.x - c.x, o.y - c.y) < 2.0 * h;
        if (duplicate) continue;
        // The island's reach in each direction: march until the FTLE exceeds the threshold or the data ends.
        double best_reach = 0.0, best_ux = 1.0, best_uy = 0.0;
        const std::size_t dirs = std::max<std::size_t>(settings.directions, 1);
        for (std::size_t k = 0; k < dirs; ++k) {
            const double theta = 2.0 * pi * static_cast<double>(k) / static_cast<double>(dirs);
            const double ux = std::cos(theta), uy = std::sin(theta);
            double reach = 0.0;
            for (double s = 0.5 * h;; s += 0.5 * h) {
                const double f = ftle_at(c.x + s * ux, c.y + s * uy);
                if (!(f < threshold)) break;
                reach = s;
            }
            if (reach > best_reach) {
                best_reach = reach;
                best_ux = ux;
                best_uy = uy;
            }
        }
        if (best_reach < 2.0 * h) continue; // no island to speak of
        c.reach = best_reach;
        double len = settings.section_margin * best_reach;
        // Keep the section inside the box.
        while (len > best_reach && !inside(g, c.x + len * best_ux, c.y + len * best_uy)) len -= 0.5 * h;
        c.section = {c.x, c.y, c.x + len * best_ux, c.y + len * best_uy};
        out.push_back(c);
    }
    return out;
}

namespace {

// Stops each launched shearline at its first crossing of the section in the launch direction (left normal), at
// least min_return along it and within the section's first 1.5 lengths; records where it crossed.
class SectionCrossing : public TensorLineObserver {
  public:
    SectionCrossing(const Section &section, double min_return, std::size_t lines)
        : m_section(section), m_min_return(min_return), m_cross(2 * lines, nan_value), m_image(lines, nan_value) {
        m_len = section.length();
        m_ux = (section.x1 - section.x0) / m_len;
        m_uy = (section.y1 - section.y0) / m_len;
    }
    bool stop_after(std::size_t line, double ax, double ay, double bx, double by, double s) override {
        const double nx = -m_uy, ny = m_ux; // left normal: Omega u
        const double a0 = (ax - m_section.x0) * nx + (ay - m_section.y0) * ny;
        const double a1 = (bx - m_section.x0) * nx + (by - m_section.y0) * ny;
        const double s_a = s - std::sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay));
        if (!(s_a >= m_min_return && a0 < 0.0 && a1 >= 0.0)) return false;
        const double t = a0 / (a0 - a1);
        const double qx = ax + t * (bx - ax), qy = ay + t * (by - ay);
        const double sigma = ((qx - m_section.x0) * m_ux + (qy - m_section.y0) * m_uy) / m_len;
        if (!(sigma > 0.0 && sigma <= 1.5)) return false;
        m_cross[2 * line] = qx;
        m_cross[2 * line + 1] = qy;
        m_image[line] = sigma;
        return true;
    }
    double image(std::size_t line) const { return m_image[line]; }
    double cross_x(std::size_t line) const { return m_cross[2 * line]; }
    double cross_y(std::size_t line) const { return m_cross[2 * line + 1]; }

  private:
    const Section &m_section;
    double m_min_return, m_len = 1.0, m_ux = 1.0, m_uy = 0.0;
    std::vector<double> m_cross, m_image;
};

} // namespace

std::vector<Shot> shoot_all(const LineField &eta, const Section &section, const std::vector<double> &sigmas,
                            const ReturnMapSettings &settings, bool keep_path) {
    std::vector<Shot> shots(sigmas.size());
    const Grid &g = eta.grid();
    const double h = grid_spacing(g);
    const double len = section.length();
    const double ux = (section.x1 - section.x0) / len, uy = (section.y1 - section.y0) / len;
    const double nx = -uy, ny = ux; // left normal: Omega u
    // Launches: transverse to the section, pointing to its left.
    std::vector<double> starts;
    std::vector<std::size_t> launched;
    for (std::size_t k = 0; k < sigmas.size(); ++k) {
        double px, py, vx, vy;
        section.point(sigmas[k], px, py);
        const LineStatus st = eta.evaluate(px, py, nx, ny, vx, vy);
        if (st != LineStatus::ok) {
            shots[k].stop = st == LineStatus::outside  ? StopReason::domain_edge
                            : st == LineStatus::masked ? StopReason::masked
                                                       : StopReason::singular;
            continue;
        }
        if (vx * nx + vy * ny < settings.min_transversality) {
            shots[k].stop = StopReason::singular; // tangent to the section: no transverse launch
            continue;
        }
        starts.insert(starts.end(), {px, py, vx, vy});
        launched.push_back(k);
    }
    const double budget = settings.max_turns * 2.0 * pi * len;
    TensorLineSettings ls = settings.line;
    ls.detect_closure = false;
    ls.max_length = budget;
    // About chunk / (h/2) steps per length `chunk` where the field is resolved; where it turns too fast for the grid
    // (chaotic layers) an adaptive method shrinks its steps a hundredfold. Such shearlines cannot close within the
    // field's resolution anyway: give up on them at ten times the resolved step count instead of crawling on.
    const double chunk = std::max(pi * len, 20.0 * h);
    const double step = settings.line.max_step > 0.0 ? settings.line.max_step : 0.5 * h;
    const double chunks = std::ceil(budget / chunk);
    ls.max_steps = std::min<std::size_t>(settings.line.max_steps,
                                         static_cast<std::size_t>(chunks * (10.0 * std::ceil(chunk / step) + 100.0)));
    SectionCrossing crossing(section, 2.0 * h, launched.size());
    std::vector<TensorLine> lines = integrate_tensor_lines(eta, starts, ls, &crossing);
    for (std::size_t m = 0; m < launched.size(); ++m) {
        Shot &shot = shots[launched[m]];
        TensorLine &line = lines[m];
        shot.returned = line.stop == StopReason::observer;
        shot.stop = shot.returned ? StopReason::max_length : line.stop;
        if (shot.returned) {
            shot.image = crossing.image(m);
            // The path ends at the crossing point instead of the step's end beyond it.
            line.xy.resize(line.xy.size() - 2);
            line.xy.push_back(crossing.cross_x(m));
            line.xy.push_back(crossing.cross_y(m));
        }
        if (keep_path) shot.xy = std::move(line.xy);
    }
    return shots;
}

Shot shoot(const LineField &eta, const Section &section, double sigma, const ReturnMapSettings &settings,
           bool keep_path) {
    return std::move(shoot_all(eta, section, {sigma}, settings, keep_path).front());
}

LineField coarsened(const LineField &field) {
    const Grid &g = field.grid();
    Grid c = g;
    c.nx = (g.nx + 1) / 2;
    c.ny = (g.ny + 1) / 2;
    c.x_max = g.x(2 * (c.nx - 1));
    c.y_max = g.y(2 * (c.ny - 1));
    std::vector<double> vx(c.size()), vy(c.size());
    std::vector<std::uint8_t> unusable(c.size(), 0);
    for (std::size_t i = 0; i < c.ny; ++i)
        for (std::size_t j = 0; j < c.nx; ++j)
            unusable[i * c.nx + j] = field.point_vector(2 * i, 2 * j, vx[i * c.nx + j], vy[i * c.nx + j]) ? 0 : 1;
    return LineField(c, std::move(vx), std::move(vy), {}, std::move(unusable));
}

namespace {

// Richardson extrapolation of a whole shearline from its paths on the field (h) and on the coarsened field (2h),
// both from the same launch point to the return crossing: at equal fractions tau of their arclength,
// x(tau) = (4 x_h(tau) - x_2h(tau)) / 3. Interpolation errs by O(h^2) in the direction of eta, so both paths
// (and their parametrisations) differ from the exact field's shearline by C(tau) h^2 and 4 C(tau) h^2; the result
// is the exact field's shearline to higher order and returns to the section at the extrapolated P.
std::vector<double> extrapolated_path(const std::vector<double> &fine, const std::vector<double> &coarse) {
    const std::vector<double> sf = cumulative_length(fine), sc = cumulative_length(coarse);
    const double lf = sf.back(), lc = sc.back();
    std::vector<double> out(fine.size());
    const std::size_t m = sc.size();
    std::size_t q = 0;
    for (std::size_t k = 0; k < sf.size(); ++k) {
        const double target = sf[k] / lf * lc;
        while (q + 2 < m && sc[q + 1] < target) ++q;
        // Cubic Lagrange interpolation in arclength through the four vertices around the target: a chord (linear
        // interpolation) would cut inside the curve by step^2 / (8 radius), an O(h^2) error of its own that the
        // extrapolation would amplify, while the cubic's is O(step^4).
        const std::size_t a = std::min(q > 0 ? q - 1 : 0, m >= 4 ? m - 4 : 0);
        const std::size_t b = std::min(a + 4, m);
        for (int c = 0; c < 2; ++c) {
            double xc = 0.0;
            for (std::size_t i = a; i < b; ++i) {
                double w = 1.0;
                for (std::size_t j = a; j < b; ++j)
                    if (j != i) w *= (target - sc[j]) / (sc[i] - sc[j]);
                xc += w * coarse[2 * i + c];
            }
            out[2 * k + c] = (4.0 * fine[2 * k + c] - xc) / 3.0;
        }
    }
    return out;
}

// The return map's samples: launch points sigma_k = (k + 1) / n on (0, 1], their images still unknown.
ReturnMap return_map_at_launch_points(std::size_t n) {
    ReturnMap map;
    map.sigma.resize(n);
    map.image.assign(n, nan_value);
    map.stop.assign(n, StopReason::max_length);
    map.extrapolated.assign(n, nan_value);
    for (std::size_t k = 0; k < n; ++k) map.sigma[k] = static_cast<double>(k + 1) / static_cast<double>(n);
    return map;
}

// Paths of launched shearlines kept after sampling the return map: every few for pictures, and those closed within
// resolution_gap (closed shearlines themselves) with their paths on the coarse field where it gave a return.
struct LaunchPaths {
    std::vector<std::vector<double>> fine, coarse;
};

// Richardson: P_h = P + C h^2, P_2h = P + 4 C h^2, so P = (4 P_h - P_2h) / 3 to higher order. Shot again on the
// coarse field only where the gap on the grid is below a grid spacing h: beyond, the two shearlines cross different
// cells and the O(h^2) expansion no longer describes their difference. Where it applies, the gap becomes the
// extrapolated one and the coarse path is kept.
void extrapolate_gaps(const LineField &coarse, const Section &section, const ReturnMapSettings &settings, double h,
                      const std::vector<Shot> &shots, ReturnMap &map, std::vector<double> &gaps,
                      std::vector<std::vector<double>> &coarse_paths) {
    std::vector<double> coarse_sigma;
    std::vector<std::size_t> coarse_of;
    for (std::size_t k = 0; k < shots.size(); ++k)
        if (shots[k].returned && gaps[k] <= h) {
            coarse_sigma.push_back(map.sigma[k]);
            coarse_of.push_back(k);
        }
    if (coarse_sigma.empty()) return;
    std::vector<Shot> coarse_shots = shoot_all(coarse, section, coarse_sigma, settings, true);
    const double len = section.length();
    for (std::size_t m = 0; m < coarse_of.size(); ++m) {
        const std::size_t k = coarse_of[m];
        Shot &c = coarse_shots[m];
        if (c.returned && c.xy.size() >= 8) {
            map.extrapolated[k] = (4.0 * shots[k].image - c.image) / 3.0;
            gaps[k] = std::abs(map.extrapolated[k] - map.sigma[k]) * len;
            coarse_paths[k] = std::move(c.xy);
        }
    }
}

// Samples the return map P at every launch point at once, in lockstep lanes (Alg. 2 step 3), with the Richardson
// gaps when a coarse field is given; keeps the launched shearlines for pictures in map.lines and returns the paths
// the closed shearlines need.
LaunchPaths sample_return_map(const LineField &eta, const LineField *coarse, const Section &section,
                              const ReturnMapSettings &settings, ReturnMap &map) {
    const std::size_t n = map.sigma.size();
    const double len = section.length();
    const double h = grid_spacing(eta.grid());
    std::vector<Shot> shots = shoot_all(eta, section, map.sigma, settings, true);
    std::vector<double> gaps(n, nan_value);
    for (std::size_t k = 0; k < n; ++k) {
        const Shot &s = shots[k];
        if (s.returned) map.image[k] = s.image;
        map.stop[k] = s.stop;
        gaps[k] = s.returned ? std::abs(s.image - map.sigma[k]) * len : nan_value;
    }
    LaunchPaths paths{std::vector<std::vector<double>>(n), std::vector<std::vector<double>>(n)};
    if (coarse && settings.resolution_gap > 0.0)
        extrapolate_gaps(*coarse, section, settings, h, shots, map, gaps, paths.coarse);
    const std::size_t keep_every = settings.keep_lines ? std::max<std::size_t>(n / settings.keep_lines, 1) : 0;
    for (std::size_t k = 0; k < n; ++k) {
        const bool picture = keep_every && k % keep_every == keep_every / 2;
        const bool near = shots[k].returned && settings.resolution_gap > 0.0 && gaps[k] <= settings.resolution_gap;
        if (picture || near) paths.fine[k] = std::move(shots[k].xy);
        if (!near) paths.coarse[k].clear();
    }
    for (std::size_t k = 0; k < n; ++k)
        if (keep_every && k % keep_every == keep_every / 2 && paths.fine[k].size() >= 4)
            map.lines.push_back(paths.fine[k]);
    for (double v : map.image) map.returned += std::isfinite(v) ? 1 : 0;
    return paths;
}

// A sign change of the displacement d(sigma) = P(sigma) - sigma between neighbouring launch points (or a zero at
// a): a fixed point of P lies in [a, b].
struct Bracket {
    double a, fa, b, fb;
};

std::vector<Bracket> sign_change_brackets(const ReturnMap &map) {
    std::vector<Bracket> brackets;
    for (std::size_t k = 0; k + 1 < map.sigma.size(); ++k) {
        if (!std::isfinite(map.image[k]) || !std::isfinite(map.image[k + 1])) continue;
        const double fa = map.image[k] - map.sigma[k], fb = map.image[k + 1] - map.sigma[k + 1];
        if ((fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0) || fa == 0.0)
            brackets.push_back({map.sigma[k], fa, map.sigma[k + 1], fb});
    }
    return brackets;
}

// The fixed point in a bracket by secant steps kept inside it (the Illinois variant of regula falsi: a stale end's
// value is halved, so convergence stays superlinear even when one end never moves). Converged when
// |P(root) - root| * length <= tol; `iterations` counts the shearlines shot.
bool secant_fixed_point(const LineField &eta, const Section &section, const ReturnMapSettings &settings, Bracket br,
                        double tol, double &root, std::size_t &iterations) {
    const double len = section.length();
    root = br.a;
    iterations = 0;
    if (std::abs(br.fa) * len <= tol) return true;
    int side = 0;
    while (iterations < settings.max_secant_iterations) {
        ++iterations;
        const double c = (br.a * br.fb - br.b * br.fa) / (br.fb - br.fa);
        const Shot s = shoot(eta, section, c, settings, false);
        if (!s.returned) return false;
        const double fc = s.image - c;
        root = c;
        if (std::abs(fc) * len <= tol) return true;
        if ((fc > 0.0) == (br.fb > 0.0)) {
            br.b = c;
            br.fb = fc;
            if (side == -1) br.fa *= 0.5;
            side = -1;
        } else {
            br.a = c;
            br.fa = fc;
            if (side == +1) br.fb *= 0.5;
            side = +1;
        }
        if (std::abs(br.b - br.a) * len < 1e-12 * std::max(len, 1.0)) return false;
    }
    return false;
}

// Alg. 2 step 3: the closed shearline through each fixed point of P, brackets in parallel; a bracket whose secant
// fails counts in map.failed_brackets.
void closed_at_fixed_points(const LineField &eta, int sign, const Section &section, const ReturnMapSettings &settings,
                            ReturnMap &map) {
    const std::vector<Bracket> brackets = sign_change_brackets(map);
    map.brackets = brackets.size();
    const double len = section.length();
    const double h = grid_spacing(eta.grid());
    const double tol = settings.closure_tolerance > 0.0 ? settings.closure_tolerance : 1e-3 * h;
    std::vector<ClosedShearline> found(brackets.size());
    std::vector<std::uint8_t> ok(brackets.size(), 0);
#pragma omp parallel for schedule(dynamic, 1)
    for (long long bb = 0; bb < static_cast<long long>(brackets.size()); ++bb) {
        const std::size_t b = static_cast<std::size_t>(bb);
        double root = 0.0;
        std::size_t iterations = 0;
        if (!secant_fixed_point(eta, section, settings, brackets[b], tol, root, iterations)) continue;
        Shot s = shoot(eta, section, root, settings, true);
        if (!s.returned || s.xy.size() < 8) continue;
        ClosedShearline c;
        c.sign = sign;
        c.sigma = root;
        c.closure_error = std::abs(s.image - root) * len;
        c.secant_iterations = iterations;
        s.xy.resize(s.xy.size() - 2); // the return crossing duplicates the launch point to within the tolerance
        c.xy = std::move(s.xy);
        found[b] = std::move(c);
        ok[b] = 1;
    }
    for (std::size_t b = 0; b < found.size(); ++b) {
        if (ok[b])
            map.closed.push_back(std::move(found[b]));
        else
            ++map.failed_brackets;
    }
}

// Launched shearlines that close to within the field's resolution, inside a run of at least min_run consecutive
// launch points that all do (the band of nested closed shearlines of a twist region, where the sign of P - id is
// noise); with coarse paths, the Richardson-extrapolated path is the closed shearline.
void closed_within_resolution(int sign, const Section &section, const ReturnMapSettings &settings, LaunchPaths &paths,
                              ReturnMap &map) {
    const std::size_t n = map.sigma.size();
    const double len = section.length();
    std::vector<std::uint8_t> close(n, 0);
    for (std::size_t k = 0; k < n; ++k) {
        const double p = std::isfinite(map.extrapolated[k]) ? map.extrapolated[k] : map.image[k];
        close[k] = std::isfinite(p) && std::abs(p - map.sigma[k]) * len <= settings.resolution_gap;
    }
    std::vector<std::size_t> near;
    for (std::size_t k = 0; k < n;) {
        std::size_t end = k;
        while (end < n && close[end]) ++end;
        if (end - k >= std::max<std::size_t>(settings.min_run, 1))
            for (std::size_t q = k; q < end; ++q) near.push_back(q);
        k = std::max(end, k + 1);
    }
    map.within_resolution = near.size();
    for (std::size_t k : near) {
        if (paths.fine[k].size() < 8) continue;
        ClosedShearline c;
        c.sign = sign;
        c.sigma = map.sigma[k];
        c.closure_error = std::abs(map.image[k] - map.sigma[k]) * len;
        c.fixed_point = false;
        c.extrapolated_gap = std::abs(map.extrapolated[k] - map.sigma[k]) * len; // NaN without a coarse field
        c.xy = paths.coarse[k].empty() ? std::move(paths.fine[k]) : extrapolated_path(paths.fine[k], paths.coarse[k]);
        c.xy.resize(c.xy.size() - 2); // the return crossing: within resolution_gap of the launch point
        map.closed.push_back(std::move(c));
    }
}

} // namespace

ReturnMap closed_shearlines(const LineField &eta, int sign, const Section &section, const ReturnMapSettings &settings,
                            const LineField *coarse) {
    ReturnMap map = return_map_at_launch_points(std::max<std::size_t>(settings.launch_points, 2));
    LaunchPaths paths = sample_return_map(eta, coarse, section, settings, map);
    closed_at_fixed_points(eta, sign, section, settings, map);
    if (settings.resolution_gap > 0.0) closed_within_resolution(sign, section, settings, paths, map);
    std::sort(map.closed.begin(), map.closed.end(),
              [](const ClosedShearline &a, const ClosedShearline &b) { return a.sigma < b.sigma; });
    return map;
}

bool encloses(const std::vector<double> &c, double x, double y) {
    const std::size_t n = c.size() / 2;
    bool in = false;
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
        const double xi = c[2 * i], yi = c[2 * i + 1], xj = c[2 * j], yj = c[2 * j + 1];
        if ((yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) in = !in;
    }
    return in;
}

namespace {

// Squared distance from (x, y) to segment i (vertex i to the next, cyclically) of the closed polyline c.
double segment_distance2(const std::vector<double> &c, std::size_t i, double x, double y) {
    const std::size_t j = (i + 1) % (c.size() / 2);
    const double ax = c[2 * i], ay = c[2 * i + 1], bx = c[2 * j], by = c[2 * j + 1];
    const double ux = bx - ax, uy = by - ay, uu = ux * ux + uy * uy;
    const double t = uu > 0.0 ? std::clamp(((x - ax) * ux + (y - ay) * uy) / uu, 0.0, 1.0) : 0.0;
    const double ex = x - ax - t * ux, ey = y - ay - t * uy;
    return ex * ex + ey * ey;
}

} // namespace

double distance_to_curve(const std::vector<double> &c, double x, double y) {
    const std::size_t n = c.size() / 2;
    double best = std::numeric_limits<double>::infinity();
    // Squared: one sqrt at the end, not a hypot per segment.
    for (std::size_t i = 0; i < n; ++i) best = std::min(best, segment_distance2(c, i, x, y));
    return std::sqrt(best);
}

CurveDistance::CurveDistance(const std::vector<double> &c) : m_xy(c) {
    const std::size_t n = c.size() / 2;
    if (n == 0) return;
    double x1 = c[0], y1 = c[1];
    m_x0 = c[0];
    m_y0 = c[1];
    for (std::size_t k = 0; k < n; ++k) {
        m_x0 = std::min(m_x0, c[2 * k]);
        x1 = std::max(x1, c[2 * k]);
        m_y0 = std::min(m_y0, c[2 * k + 1]);
        y1 = std::max(y1, c[2 * k + 1]);
    }
    const double side = static_cast<double>(
        std::clamp<std::size_t>(static_cast<std::size_t>(std::sqrt(static_cast<double>(n))), 1, 256));
    m_cell = std::max(std::max(x1 - m_x0, y1 - m_y0) / side, std::numeric_limits<double>::min());
    m_nx = std::min<std::size_t>(static_cast<std::size_t>((x1 - m_x0) / m_cell) + 1, 257);
    m_ny = std::min<std::size_t>(static_cast<std::size_t>((y1 - m_y0) / m_cell) + 1, 257);
    // Each segment goes into every cell its bounding box meets: counted, then placed (compressed rows).
    auto cell_range = [&](std::size_t i, std::size_t &i0, std::size_t &i1, std::size_t &j0, std::size_t &j1) {
        const std::size_t k = (i + 1) % n;
        auto column = [&](double x) { return std::min(static_cast<std::size_t>((x - m_x0) / m_cell), m_nx - 1); };
        auto row = [&](double y) { return std::min(static_cast<std::size_t>((y - m_y0) / m_cell), m_ny - 1); };
        j0 = column(std::min(c[2 * i], c[2 * k]));
        j1 = column(std::max(c[2 * i], c[2 * k]));
        i0 = row(std::min(c[2 * i + 1], c[2 * k + 1]));
        i1 = row(std::max(c[2 * i + 1], c[2 * k + 1]));
    };
    m_first.assign(m_nx * m_ny + 1, 0);
    std::size_t i0, i1, j0, j1;
    for (std::size_t s = 0; s < n; ++s) {
        cell_range(s, i0, i1, j0, j1);
        for (std::size_t i = i0; i <= i1; ++i)
            for (std::size_t j = j0; j <= j1; ++j) ++m_first[i * m_nx + j + 1];
    }
    for (std::size_t q = 0; q < m_nx * m_ny; ++q) m_first[q + 1] += m_first[q];
    m_segments.resize(m_first.back());
    std::vector<std::size_t> fill(m_first.begin(), m_first.end() - 1);
    for (std::size_t s = 0; s < n; ++s) {
        cell_range(s, i0, i1, j0, j1);
        for (std::size_t i = i0; i <= i1; ++i)
            for (std::size_t j = j0; j <= j1; ++j) m_segments[fill[i * m_nx + j]++] = s;
    }
}

double CurveDistance::operator()(double x, double y) const {
    if (m_first.empty() || !std::isfinite(x) || !std::isfinite(y)) return distance_to_curve(m_xy, x, y);
    // The point's cell, or the nearest cell when it lies outside the box: then every cell r rings away is at least
    // (r - 1) cells from it along the axis of that ring.
    auto clamp_index = [&](double v, std::size_t count) {
        return v <= 0.0 ? std::size_t{0} : std::min(static_cast<std::size_t>(v), count - 1);
    };
    const std::size_t ci = clamp_index((y - m_y0) / m_cell, m_ny), cj = clamp_index((x - m_x0) / m_cell, m_nx);
    double best = std::numeric_limits<double>::infinity();
    auto visit = [&](std::size_t i, std::size_t j) {
        const std::size_t q = i * m_nx + j;
        for (std::size_t s = m_first[q]; s < m_first[q + 1]; ++s)
            best = std::min(best, segment_distance2(m_xy, m_segments[s], x, y));
    };
    const std::size_t rings = std::max(m_nx, m_ny);
    for (std::size_t r = 0; r <= rings; ++r) {
        // Rings r and beyond lie (r - 1) cells away or more; half a cell of margin against rounding.
        const double bound = (static_cast<double>(r) - 1.5) * m_cell;
        if (r >= 2 && best < bound * bound) break;
        const long long lo_i = static_cast<long long>(ci) - static_cast<long long>(r),
                        hi_i = static_cast<long long>(ci) + static_cast<long long>(r),
                        lo_j = static_cast<long long>(cj) - static_cast<long long>(r),
                        hi_j = static_cast<long long>(cj) + static_cast<long long>(r);
        const long long nx = static_cast<long long>(m_nx), ny = static_cast<long long>(m_ny);
        for (long long i = std::max(lo_i, 0LL); i <= std::min(hi_i, ny - 1); ++i) {
            if (i == lo_i || i == hi_i) { // the ring's bottom and top rows, whole
                for (long long j = std::max(lo_j, 0LL); j <= std::min(hi_j, nx - 1); ++j)
                    visit(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
                continue;
            }
            if (lo_j >= 0) visit(static_cast<std::size_t>(i), static_cast<std::size_t>(lo_j)); // its sides
            if (hi_j < nx) visit(static_cast<std::size_t>(i), static_cast<std::size_t>(hi_j));
        }
    }
    return std::sqrt(best);
}

double curve_distance(const std::vector<double> &a, const std::vector<double> &b, std::size_t stride) {
    stride = std::max<std::size_t>(stride, 1);
    double d = 0.0;
    for (std::size_t k = 0; 2 * k + 1 < a.size(); k += stride)
        d = std::max(d, distance_to_curve(b, a[2 * k], a[2 * k + 1]));
    for (std::size_t k = 0; 2 * k + 1 < b.size(); k += stride)
        d = std::max(d, distance_to_curve(a, b[2 * k], b[2 * k + 1]));
    return d;
}

double curve_diameter(const std::vector<double> &c, std::size_t stride) {
    stride = std::max<std::size_t>(stride, 1);
    double d2 = 0.0; // squared: one sqrt at the end
    for (std::size_t i = 0; 2 * i + 1 < c.size(); i += stride)
        for (std::size_t j = i + stride; 2 * j + 1 < c.size(); j += stride) {
            const double ex = c[2 * i] - c[2 * j], ey = c[2 * i + 1] - c[2 * j + 1];
            d2 = std::max(d2, ex * ex + ey * ey);
        }
    return std::sqrt(d2);
}

} // namespace geobarrier::elliptic
