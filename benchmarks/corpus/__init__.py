"""Coverage of a folder of Mitsuba 3 scenes: which load, which we import, which agree.

``rtbench corpus DIR`` (:mod:`benchmarks.commands.corpus`) judges every scene XML under a
folder, unmodified, and records one status per scene (:data:`~benchmarks.corpus.judge.STATUSES`):

* ``agrees`` / ``disagrees``: Mitsuba loads it, we import it, and the two renders at a small
  film size agree or not (:func:`benchmarks.gate.agreement.agreement`);
* ``render-error``: it imports but our import or a render raised (or the worker died);
* ``refused``: in scope, but our importer refuses it: the features it still needs;
* ``out-of-scope``: our refusal names a plugin outside the tracer's scope (participating
  media, polarisation, hair, SDF grids, ``aov``, ``ptracer``) or Mitsuba needs a spectral
  variant for it;
* ``mitsuba-fails``: Mitsuba itself cannot load it in an RGB variant (its one-line reason);
* ``timeout``: no verdict within the time limit.

Modules: :mod:`~benchmarks.corpus.scan` (files, fragments, content hashes),
:mod:`~benchmarks.corpus.judge` (one scene), :mod:`~benchmarks.corpus.worker` (the process
that judges them, with a time limit), :mod:`~benchmarks.corpus.results` (``corpus.json``,
the tables, ``corpus.md``).
"""
from __future__ import annotations

from .judge import OUT_OF_SCOPE, STATUSES, small_film
from .scan import scan

__all__ = ["STATUSES", "OUT_OF_SCOPE", "small_film", "scan"]
