"""Coverage of a folder of Mitsuba 3 scenes, behind ``rtbench corpus DIR``: which load, which we
import, which agree (the statuses: :data:`~.judge.STATUSES`, ``docs/mitsuba.md``).

:mod:`.scan` finds the scenes, fragments and content hashes, :mod:`.judge` judges one scene
in the process of :mod:`.worker` (with a time limit), :mod:`.results` writes
``corpus.json``, the tables and ``corpus.md``.
"""
from __future__ import annotations

from .judge import OUT_OF_SCOPE, STATUSES, small_film
from .scan import scan

__all__ = ["STATUSES", "OUT_OF_SCOPE", "small_film", "scan"]
