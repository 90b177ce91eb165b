// The flow-map engine for systems of dimension 6 in a translation unit of its own (flow_map.cpp,
// flow_map_engine::run_batches_for).
#define GEOBARRIER_FLOW_MAP_DIMENSION 6
#include "flow_map.cpp"
