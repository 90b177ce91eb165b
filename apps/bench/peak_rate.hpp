// The core's measured peak of fused multiply-adds, per vector width: the denominator of the bench's "share of the
// machine's limit" (section widths). Measured rather than taken from a data sheet: the number of FMA units per core
// at 512 bits differs between models of the same family, and a virtual machine's clock is not its nominal one.
#pragma once

namespace geobarrier::bench {

// Lane multiply-adds per second one core sustains with vectors of `lanes` doubles (8: AVX-512, 4: AVX2 with FMA),
// over about `seconds` of independent FMA chains; 0 when this CPU lacks the instructions.
double peak_lane_fma_rate(int lanes, double seconds = 0.3);

} // namespace geobarrier::bench
