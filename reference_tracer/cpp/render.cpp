// The tracer's pixel loop: render_pixel<Mutant::None> (definition in render_pixel.h).
#include "render_pixel.h"

namespace rt {

template void render_pixel<Mutant::None>(const Scene&, const Integrator<Mutant::None>&, int, int, int, uint64_t,
                                         const PixelSums&, uint64_t&, uint64_t&);

}  // namespace rt
