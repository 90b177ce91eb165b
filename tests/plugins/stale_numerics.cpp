// The rigid-rotation test system compiled with fused-step numerics of revision 0, older than any core's
// (GB_ADVANCE_TABLEAU_REVISION starts at 1): its advance() must decline every request, so that the core takes its own
// stage-by-stage path instead of computing with stale tableaux. test_abi_history loads it by path.
#define GEOBARRIER_SDK_TABLEAU_REVISION 0u
#include "rigid_rotation.cpp"
