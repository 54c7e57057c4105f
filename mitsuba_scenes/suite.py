"""Registry of the scene suite: ``list_scenes()`` and ``get_scene(name, **params)``.

Scene files registered with :func:`mitsuba_scenes.scene_files.register_scene_file`
(``--scene PATH``) are known by name too (:func:`known_scenes`): :func:`get_scene` builds
them, with ``width`` and ``height`` overrides as for suite scenes.

Every suite scene but ``furnace`` renders as Mitsuba's ``path`` does by default: Russian
roulette from depth 5 (``rr_depth=5``), with at most 50 segments (``max_depth=50``); pass
``rr_depth=None`` for none. ``furnace`` keeps no roulette: its closed form is the exact
value of every path, and roulette would give its exact estimators (``mis``) a variance.
"""
from __future__ import annotations

import importlib
import inspect

import reference_tracer as rt

from .scene_files import registered, scene_file
from .scenes import SUITE


def list_scenes() -> list:
    """Names of the suite's scenes."""
    return list(SUITE)


def known_scenes() -> list:
    """The suite's scenes, then the scene files registered in this process."""
    return list(SUITE) + [e.name for e in registered()]


def scene_module(name: str):
    if name not in SUITE:
        raise ValueError(f"unknown scene {name!r}; the suite has: {', '.join(SUITE)} "
                         f"(a scene file is given with --scene PATH)")
    return importlib.import_module(f"mitsuba_scenes.scenes.{name}")


def describe_scene(name: str) -> str:
    """The first line of the scene module's docstring: what the scene tests (a file: its path)."""
    entry = scene_file(name)
    if entry is not None:
        return entry.describe()
    return (scene_module(name).__doc__ or name).strip().splitlines()[0]


def get_scene(name: str, **params) -> rt.Scene:
    """Build suite scene ``name``; keyword ``params`` (width, height, max_depth, ...) override defaults.

    A registered scene file takes ``width`` and ``height`` only (its own parameters were
    fixed when it was registered).
    """
    entry = scene_file(name)
    if entry is not None:
        unknown = sorted(set(params) - {"width", "height"})
        if unknown:
            raise ValueError(f"scene file {name!r} takes no parameter(s) {unknown} here; "
                             f"give them with --param when registering it")
        return entry.build(params.get("width"), params.get("height"))
    build = scene_module(name).build
    accepted = inspect.signature(build).parameters
    unknown = sorted(set(params) - set(accepted))
    if unknown:
        raise ValueError(f"scene {name!r} takes no parameter(s) {unknown}; it accepts {sorted(accepted)}")
    return build(**params)


def closed_form_reference(name: str, **params):
    """The exact image of suite scene ``name`` built with ``params``, or None.

    Scenes with an analytic answer define ``closed_form_image(**params)`` in their module
    (``furnace``); the harness and the gate use it as a zero-variance reference instead of
    a Mitsuba render (Mitsuba 3.9.1 is measurably biased on ``furnace``).
    """
    if scene_file(name) is not None:
        return None
    module = scene_module(name)
    fn = getattr(module, "closed_form_image", None)
    return None if fn is None else fn(**params)

