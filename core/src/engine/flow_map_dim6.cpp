// The flow-map engine for systems of dimension 6 in a translation unit of its own (batch_integrator.hpp).
#include "batch_integrator.hpp"

namespace geobarrier::flow_map_engine {

template <> IntegratorStats run_batches_for<6>(const BatchRequest &request) { return run_batches_of<6>(request); }

} // namespace geobarrier::flow_map_engine
