// Why passive: with no policy set, libgomp keeps an idle thread spinning for 300 000 pause instructions (a few ms)
// after every parallel region and at every barrier before it sleeps. A run enters about 47 parallel regions, over 30
// of them in the hyperbolic extractor, most with serial work after them (the selection's chunks); on the 2-core machine
// of docs/extractor-measurements.md, shared with other work, the spinning thread took the core its own master thread
// was waiting for. Passive, the extractor's CPU seconds at 1000 x 1000 fell 20-40% (unforced Duffing 1.11 -> 0.84,
// the escape oscillator backward 0.67-0.78 -> 0.45-0.51) with the same barriers, the flow map's 1-15%. What passive
// costs is the wake-up of a sleeping thread, microseconds per region. libgomp reads the policy from the environment
// when it is loaded, before main (a setenv from a .preinit_array function, tried, did not reach it), so the program
// can only set it for a fresh image of itself.
#include "openmp_wait.hpp"

#include <cstdlib>
#include <cstring>
#if defined(__linux__)
#include <unistd.h>
#endif

namespace geobarrier {

void prefer_passive_openmp_wait(char **argv) {
#if defined(__linux__)
    if (std::getenv("OMP_WAIT_POLICY") || std::getenv("GOMP_SPINCOUNT")) return;
    // Under valgrind the restarted image would run outside the tool (its profile would be empty): stay.
    const char *preload = std::getenv("LD_PRELOAD");
    if (preload && std::strstr(preload, "vgpreload")) return;
    if (setenv("OMP_WAIT_POLICY", "passive", 0) != 0) return;
    execv("/proc/self/exe", argv); // returns only on failure: run on as we are
#else
    (void)argv;
#endif
}

} // namespace geobarrier
