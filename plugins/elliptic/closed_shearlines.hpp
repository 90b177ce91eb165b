// The numerical heart of the `elliptic` extractor (paper Alg. 2 without its manual step): candidate elliptic
// regions found from the index of the Cauchy–Green line field's singularities, a Poincaré section across each,
// the return map of shearlines launched from it, the map's fixed points by a secant method, and the closed
// shearlines through them. Host-free, so the tests drive it directly on synthetic fields.
#ifndef GEOBARRIER_ELLIPTIC_CLOSED_SHEARLINES_HPP
#define GEOBARRIER_ELLIPTIC_CLOSED_SHEARLINES_HPP

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/shear.hpp>
#include <geobarrier/tensor_lines.hpp>

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace geobarrier::elliptic {

// A Poincaré section: the segment from `start` (inside the region, normally its centre) to `end`. Launch points
// sit at sigma in (0, 1] along it; shearlines leave it towards its left normal n = Omega (end - start) / |.|.
struct Section {
    double x0 = 0.0, y0 = 0.0, x1 = 1.0, y1 = 0.0;
    double length() const;
    void point(double sigma, double &x, double &y) const;
};

// A candidate elliptic region: where closed shearlines may exist. Closed integral curves of a line field enclose
// singularities whose indices add up to +1, so candidates are (a) a singularity of index +1 on its own, or (b) two
// wedges (index +1/2) that are each other's nearest resolved singularity (CoherentStructures.jl's "Combine20"),
// centred between them; only singularities the grid resolves count (anisotropy below max_anisotropy at the
// points around them: where the eigenvector field turns by a right angle from one grid point to the next,
// lambda1 is far from lambda2 and the "winding" is aliasing, not a singularity). A candidate must also sit in an
// island of low FTLE (below the threshold, Otsu's between-class split of the FTLE values unless given); the
// section runs from the centre along the direction in which that island reaches furthest, to section_margin
// times that reach.
struct Candidate {
    double x = 0.0, y = 0.0;
    std::string origin; // "index +1 point", "wedge pair", "section given"
    double reach = 0.0; // distance from the centre to the first FTLE value above the threshold
    Section section;
};

struct CandidateSettings {
    double max_anisotropy = 0.3;  // singularities with more anisotropy around them are unresolved
    double ftle_threshold = 0.0;  // island boundary; 0 = automatic (Otsu)
    double section_margin = 1.25; // section length / island reach
    std::size_t directions = 16;  // directions tried for the section
};

struct CandidateReport {
    std::vector<TensorSingularity> singularities; // all found
    std::size_t resolved = 0;                     // of which pass the anisotropy test
    double ftle_threshold = 0.0;                  // the threshold used
    std::size_t rejected_high_ftle = 0;           // candidates outside low-FTLE islands
};

std::vector<Candidate> find_candidates(const CauchyGreenField &cg, const CandidateSettings &settings,
                                       CandidateReport *report = nullptr);

// Otsu's threshold of the finite values (the split maximising the between-class variance, 256 bins).
double otsu_threshold(const std::vector<double> &values);
// The FTLE above which an elliptic island ends: `given` when positive, else Otsu's split of the grid's FTLE values
// (points whose trajectory left the data or the box excluded).
double island_ftle_threshold(const CauchyGreenField &cg, double given);

struct ReturnMapSettings {
    std::size_t launch_points = 500;  // the paper's 500
    double max_turns = 1.5;           // a shearline may be at most max_turns * 2 pi * section length long
    double min_transversality = 0.05; // |<eta, n>| at a launch point below this: the section is tangent there
    std::size_t max_secant_iterations = 40;
    double closure_tolerance = 0.0; // |P(sigma) - sigma| * length at a fixed point; 0: 1e-3 grid spacings
    // A launched shearline whose return gap |P(sigma) - sigma| * length is below this is closed to within the
    // resolution of the line field (bilinear interpolation is exact only to O(h^2), so where the return map is
    // the identity to that order - nested closed shearlines, as in a twist region - its sign is noise). 0: none.
    double resolution_gap = 0.0;
    // ... and only inside a run of at least this many consecutive launch points that all close so: the band of
    // nested closed shearlines, not a return map that merely grazes the gap once (a secant root needs no run).
    std::size_t min_run = 3;
    // With a coarse field (closed_shearlines' `coarse`), the gap compared with resolution_gap is the Richardson
    // extrapolation (4 d_h - d_2h) / 3 of the gaps on the field and on the field sampled at twice the spacing:
    // bilinear interpolation errs by O(h^2), and that error of the return gap grows outwards (longer shearlines,
    // faster turning fields near the chaotic layer) until it exceeds any fixed fraction of h while the exact
    // field's shearlines still close.
    TensorLineSettings line;    // detect_closure and max_length are set by the search
    std::size_t keep_lines = 0; // launched shearlines kept for pictures (evenly spread)
};

// One fixed point of the return map and its closed shearline (x, y interleaved, not repeating its first point).
struct ClosedShearline {
    int sign = +1;            // eta+ or eta-
    double sigma = 0.0;       // where it crosses the section
    double closure_error = 0; // |P(sigma) - sigma| * section length
    bool fixed_point = true;  // a fixed point found by the secant method; false: closed within resolution_gap
    double extrapolated_gap = std::numeric_limits<double>::quiet_NaN(); // Richardson gap, as closure_error (coarse)
    std::size_t secant_iterations = 0;
    std::vector<double> xy;
};

struct ReturnMap {
    std::vector<double> sigma;    // launch points
    std::vector<double> image;    // P(sigma); NaN where the shearline did not return
    std::vector<StopReason> stop; // why it did not return (max_length when it ran out of budget)
    std::size_t returned = 0;
    std::vector<std::vector<double>> lines; // kept launched shearlines (pictures)
    std::vector<ClosedShearline> closed;
    std::size_t brackets = 0, failed_brackets = 0; // sign changes of P - id, and those whose secant failed
    std::size_t within_resolution = 0;             // launch points whose shearline closed within resolution_gap
    std::vector<double> extrapolated;              // (4 P_h - P_2h) / 3 with a coarse field; NaN where unknown
};

// The return map of `eta` on `section`, its fixed points and the shearlines closed within the resolution gap.
// `coarse` (may be null): the same field at twice the spacing (coarsened()), for the Richardson gap above.
ReturnMap closed_shearlines(const LineField &eta, int sign, const Section &section, const ReturnMapSettings &settings,
                            const LineField *coarse = nullptr);

// The field sampled at every other grid point (spacing 2h, the same box up to one trailing row or column when a
// count is even); points the field may not use stay unusable.
LineField coarsened(const LineField &field);

// A shearline launched from the section at sigma, followed until it crosses the section again in the same sense.
struct Shot {
    bool returned = false;
    double image = 0.0; // sigma of the return crossing
    StopReason stop = StopReason::max_length;
    std::vector<double> xy; // the path, ending at the crossing point when it returned
};
Shot shoot(const LineField &eta, const Section &section, double sigma, const ReturnMapSettings &settings,
           bool keep_path);
// The same from every sigma at once, in lockstep lanes (integrate_tensor_lines).
std::vector<Shot> shoot_all(const LineField &eta, const Section &section, const std::vector<double> &sigmas,
                            const ReturnMapSettings &settings, bool keep_path);

// Curve geometry for selecting barriers (x, y interleaved closed polylines, first point not repeated).
// Even-odd rule: is (x, y) inside the closed curve?
bool encloses(const std::vector<double> &closed_xy, double x, double y);
// Distance from (x, y) to the closed polyline.
double distance_to_curve(const std::vector<double> &closed_xy, double x, double y);
// The same for many points against one curve: its segments binned in square cells (about sqrt(n) per side over the
// curve's bounding box), so that a query visits the cells around the point ring by ring until no cell left can
// hold a nearer segment, instead of every segment. The value is distance_to_curve's (the same squared distance per
// segment, minimised over a set that holds the nearest). Keeps a reference to the curve.
class CurveDistance {
  public:
    explicit CurveDistance(const std::vector<double> &closed_xy);
    double operator()(double x, double y) const;

  private:
    const std::vector<double> &m_xy;
    double m_x0 = 0.0, m_y0 = 0.0, m_cell = 1.0;
    std::size_t m_nx = 1, m_ny = 1;
    std::vector<std::size_t> m_first;    // cell c holds segments m_segments[m_first[c] .. m_first[c + 1])
    std::vector<std::size_t> m_segments; // segment i: vertex i to vertex i + 1 (the last closes the curve)
};
// Symmetric Hausdorff distance between two closed polylines, measured from every `stride`-th vertex of each.
double curve_distance(const std::vector<double> &a, const std::vector<double> &b, std::size_t stride = 1);
// Largest distance between two vertices (the curve's diameter), from every `stride`-th vertex.
double curve_diameter(const std::vector<double> &closed_xy, std::size_t stride = 1);

} // namespace geobarrier::elliptic

#endif // GEOBARRIER_ELLIPTIC_CLOSED_SHEARLINES_HPP
