"""Registry of the scene suite: ``list_scenes()`` and ``get_scene(name, **params)``."""
from __future__ import annotations

import importlib
import inspect

import reference_tracer as rt

#: Scene names in suite order; each is a module in ``mitsuba_scenes.scenes``.
SUITE = ("cornell_box", "cornell_glass", "cornell_mirror", "cornell_mesh", "small_light",
         "large_light", "glossy_plates", "furnace")


def list_scenes() -> list:
    """Names of the suite's scenes."""
    return list(SUITE)


def scene_module(name: str):
    if name not in SUITE:
        raise ValueError(f"unknown scene {name!r}; the suite has: {', '.join(SUITE)}")
    return importlib.import_module(f"mitsuba_scenes.scenes.{name}")


def describe_scene(name: str) -> str:
    """The first line of the scene module's docstring: what the scene tests."""
    return (scene_module(name).__doc__ or name).strip().splitlines()[0]


def get_scene(name: str, **params) -> rt.Scene:
    """Build suite scene ``name``; keyword ``params`` (width, height, max_depth, ...) override defaults."""
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
    module = scene_module(name)
    fn = getattr(module, "closed_form_image", None)
    return None if fn is None else fn(**params)

