"""Chi-square goodness-of-fit tests of the tracer's sampling routines against their pdfs.

That is this package's one job: show that every routine that draws a direction (warps,
BSDFs, the glass's lobe choice, light sampling) draws from exactly the density the
integrator divides by, as Mitsuba 3's ``mitsuba.chi2`` and pbrt-v4's sampling tests do.

* :mod:`.pearson` - the statistics: :func:`chi2_test` (any ``sample(u)`` against any
  ``pdf(points)`` on the sphere, hemisphere or disk), :func:`discrete_test`,
  :func:`sidak`, :func:`pearson` (pooling), :func:`integrate` (adaptive quadrature).
* :mod:`.probes` - adapters from the C++ core's routines to ``sample`` / ``pdf``.
* :mod:`.catalogue` - every routine with its parameters (``ROUTINES``, :func:`~.catalogue.select`).
* :mod:`.routine` - one routine (:class:`~.routine.Routine`) and its outcome (:class:`~.routine.Row`).
* :mod:`.runner` - :func:`~.runner.run_routine`, behind ``rtbench chi2``.
* :mod:`.plot` - observed-versus-expected images.

The method (Pearson's statistic, pooling, Sidak's correction, the quadrature, what is
checked besides the distribution) is written up in ``benchmarks/chi2/README.md``.
"""
from .pearson import (DEFAULT_ALPHA, DEFAULT_N, DEFAULT_RESOLUTION, DOMAINS, MIN_EXPECTED, Chi2Result, Grid,
                      chi2_test, discrete_test, integrate, pearson, sidak)

__all__ = ["chi2_test", "discrete_test", "Chi2Result", "Grid", "sidak", "pearson", "integrate", "DOMAINS",
           "DEFAULT_N", "DEFAULT_RESOLUTION", "DEFAULT_ALPHA", "MIN_EXPECTED"]
