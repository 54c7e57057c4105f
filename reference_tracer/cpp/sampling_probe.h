// Batch access to the tracer's sampling routines for their chi-square tests (see
// sampling_probe.cpp and benchmarks/chi2). Registered on the `_core` module; renders never
// call any of it.
#pragma once

#include <nanobind/nanobind.h>

namespace rt {

// Adds warp_sample, warp_pdf, bsdf_sample and bsdf_eval_pdf to the module.
void register_sampling_probe(nanobind::module_& m);

}  // namespace rt
