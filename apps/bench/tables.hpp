// Numbers as the report prints them, and the spread of per-run ratios.
#pragma once

#include <string>
#include <vector>

namespace geobarrier::bench {

// "12.35" with `digits` decimals; "–" for NaN.
std::string fixed(double v, int digits);
// "1.2e-04"; "–" for NaN.
std::string sci(double v);
// "%.6g", empty for NaN (bench.csv).
std::string csv_number(double v);
// "median (least–most) over n runs" of per-run ratios; "–" for fewer than two runs (the previous column has it).
std::string ratio_spread(std::vector<double> ratios);

} // namespace geobarrier::bench
