"""Chi-square tests that every sampling routine of the tracer draws from exactly the density the
integrator divides by (the method and the catalogue: ``benchmarks/chi2/README.md``).

:mod:`.pearson` holds the statistics (:func:`chi2_test` of any ``sample(u)`` against any
``pdf(points)``), :mod:`.probes` the adapters to the core's routines, :mod:`.catalogue` the
routines, :mod:`.runner` the tests of one routine behind ``rtbench chi2``, :mod:`.plot` the
observed-versus-expected images.
"""
from .pearson import (DEFAULT_ALPHA, DEFAULT_N, DEFAULT_RESOLUTION, DOMAINS, MIN_EXPECTED, Chi2Result, Grid,
                      chi2_test, discrete_test, integrate, pearson, sidak)

__all__ = ["chi2_test", "discrete_test", "Chi2Result", "Grid", "sidak", "pearson", "integrate", "DOMAINS",
           "DEFAULT_N", "DEFAULT_RESOLUTION", "DEFAULT_ALPHA", "MIN_EXPECTED"]
