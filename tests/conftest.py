"""Fixtures shared by several test modules."""
from __future__ import annotations

import pytest


@pytest.fixture
def fresh_registries():
    """No registered scene files (``--scene``) or external renderers (``--renderer``) before
    or after the test: both registries are per process, and a test must not see another's."""
    from benchmarks.external import clear_externals
    from mitsuba_scenes.scene_files import clear_registry

    clear_registry()
    clear_externals()
    yield
    clear_registry()
    clear_externals()


@pytest.fixture(scope="session")
def jit_variant():
    """'llvm_ad_rgb' when it works here (the timed Mitsuba side of the speed benchmarks), else None."""
    from mitsuba_scenes.variants import select_variant

    try:
        select_variant("llvm_ad_rgb")
        return "llvm_ad_rgb"
    except (RuntimeError, ValueError):
        return None
