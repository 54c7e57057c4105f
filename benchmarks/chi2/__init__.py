"""Chi-square tests that every sampling routine of the tracer draws from the density the integrator
divides by (``benchmarks/chi2/README.md``): :mod:`.pearson` the statistics, :mod:`.probes` the adapters
to the core, :mod:`.catalogue` the routines, :mod:`.runner` their tests, :mod:`.plot` the images.
"""
from .pearson import (DEFAULT_ALPHA, DEFAULT_N, DEFAULT_RESOLUTION, DOMAINS, MIN_EXPECTED, Chi2Result, Grid,
                      chi2_test, discrete_test, integrate, pearson, sidak)

__all__ = ["chi2_test", "discrete_test", "Chi2Result", "Grid", "sidak", "pearson", "integrate", "DOMAINS",
           "DEFAULT_N", "DEFAULT_RESOLUTION", "DEFAULT_ALPHA", "MIN_EXPECTED"]
