#pragma once
// The parameters that more than one extractor takes, declared once: a key two extractors share has one spelling,
// one range and one default (issue 36), and an extractor of yours that takes the same key can declare it the same
// way. Only the description differs, since it says what the key does in that extractor.
#include <geobarrier/line_field.hpp>
#include <geobarrier/sdk.hpp>

#include <string_view>
#include <vector>

namespace geobarrier {

// Largest singular_gap: at 1 every point would be singular (lambda2 - lambda1 <= lambda2 always holds).
constexpr double max_singular_gap = 0.999;

// `singular_gap`: points with lambda2 - lambda1 <= singular_gap lambda2 are singular; line fields have no direction
// there (singular_mask, LineField::from_cauchy_green, shear_line_field).
constexpr gb_param_spec singular_gap_param(const char *doc) {
    return sdk::real_param("singular_gap", default_singular_gap, 0.0, max_singular_gap, "", doc);
}

// `families`: which shearline families are searched, eta+ (sign +1), eta- (sign -1) or both, in the paper's names
// (eq. `shrvec`).
constexpr gb_param_spec shearline_families_param(const char *doc) {
    return sdk::string_param("families", "both", "both|eta+|eta-", doc);
}

// `deviation_form`: which formula of the geodesic shear deviation d_g^eta± (ShearDeviationForm).
constexpr gb_param_spec deviation_form_param(const char *doc) {
    return sdk::string_param("deviation_form", "general", "general|area-preserving", doc);
}

// `line_method`: how tensor lines are integrated (tensor_line_method() parses it), in every extractor alike.
constexpr gb_param_spec line_method_param() {
    return sdk::string_param("line_method", "midpoint", "midpoint|rk4|bs32|dopri5",
                             "tensor-line integration: fixed half-cell steps (midpoint, rk4) or adaptive pairs at the "
                             "tolerance (bs32, dopri5); docs/extractors.md");
}

// The signs of the families a validated `families` value names, eta+ before eta-.
inline std::vector<int> shearline_family_signs(std::string_view families) {
    std::vector<int> signs;
    if (families != "eta-") signs.push_back(+1);
    if (families != "eta+") signs.push_back(-1);
    return signs;
}

} // namespace geobarrier
