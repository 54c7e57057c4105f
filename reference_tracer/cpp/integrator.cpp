// The tracer's integrator: Integrator<Mutant::None> (definitions in integrator_impl.h).
#include "integrator_impl.h"

namespace rt {

template class Integrator<Mutant::None>;

}  // namespace rt
