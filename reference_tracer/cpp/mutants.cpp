// The self-test's seeded bugs (mutants.h): every instantiation of the integrator and the
// pixel loop but the tracer's. Built only into the self-test's module,
// reference_tracer._mutants (CMakeLists.txt), never into the tracer's _core: inside one
// link-time optimisation unit, a dozen more copies of the integrator exhausted GCC's
// whole-program inlining budget and left the tracer's own hot functions out of line.
#include "integrator_impl.h"
#include "render_pixel.h"

namespace rt {

#define RT_INSTANTIATE_MUTANT(id, name)                                                                    \
    template class Integrator<Mutant::id>;                                                                  \
    template void render_pixel<Mutant::id>(const Scene&, const Integrator<Mutant::id>&, int, int, int, uint64_t, \
                                           const PixelSums&, uint64_t&, uint64_t&);
RT_MUTANTS(RT_INSTANTIATE_MUTANT)
#undef RT_INSTANTIATE_MUTANT

}  // namespace rt
