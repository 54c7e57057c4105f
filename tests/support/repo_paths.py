"""Where things are, for tests in any folder of ``tests/`` (ARCHITECTURE.md, Where to add a test).

``tests/support`` is on ``sys.path`` (``pythonpath`` in pyproject.toml), so a test imports
``from repo_paths import FIXTURES`` wherever it lives instead of counting ``parents``.
"""
from __future__ import annotations

from pathlib import Path

#: The repository's root (the folder of pyproject.toml).
ROOT = Path(__file__).resolve().parents[2]
#: ``tests/``.
TESTS = ROOT / "tests"
#: ``tests/fixtures``: the files tests read (XML scenes, published scenes, a corpus, normals).
FIXTURES = TESTS / "fixtures"
