// The flow-map engine for systems of dimension 5 in a translation unit of its own (batch_integrator.hpp).
#include "batch_integrator.hpp"

namespace geobarrier::flow_map_engine {

template <> IntegratorStats run_batches_for<5>(const BatchRequest &request) { return run_batches_of<5>(request); }

} // namespace geobarrier::flow_map_engine
