// The flow-map engine for systems of dimension 2 in a translation unit of its own (batch_integrator.hpp).
#include "batch_integrator.hpp"

namespace geobarrier::flow_map_engine {

template <> IntegratorStats run_batches_for<2>(const BatchRequest &request) { return run_batches_of<2>(request); }

} // namespace geobarrier::flow_map_engine
