// How the program's idle OpenMP threads wait: asleep, unless the user chose otherwise.
#pragma once

namespace geobarrier {

// Restarts the program (the same argv, on Linux) with OMP_WAIT_POLICY=passive when neither OMP_WAIT_POLICY nor
// GOMP_SPINCOUNT is set; returns when nothing is to be done or the restart failed (the program then runs on with the
// runtime's default). To be called first thing in main, before any thread or MPI starts.
void prefer_passive_openmp_wait(char **argv);

} // namespace geobarrier
