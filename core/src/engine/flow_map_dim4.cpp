// The flow-map engine for systems of dimension 4 in a translation unit of its own (flow_map.cpp,
// flow_map_engine::run_batches_for).
#define GEOBARRIER_FLOW_MAP_DIMENSION 4
#include "flow_map.cpp"
