"""``--scene PATH`` and ``--param name=value``: user scenes on every command that takes scenes.

Each parser that takes scenes calls :func:`add_scene_path_args` once; its ``run`` calls
:func:`resolve_scenes` once, which registers the files (:mod:`mitsuba_scenes.scene_files`)
and returns the scene names to use: the suite names given as positional arguments (or the
command's default when there are none and no file), then the files' names. Registered
names are accepted everywhere a suite name is (references, sweeps, the gate, speed).
"""
from __future__ import annotations

import argparse

__all__ = ["add_scene_path_args", "resolve_scenes"]


def add_scene_path_args(parser: argparse.ArgumentParser) -> None:
    """Add ``--scene PATH`` (repeatable) and ``--param NAME=VALUE`` (repeatable) to ``parser``."""
    group = parser.add_argument_group("scene files")
    group.add_argument("--scene", dest="scene_files", action="append", default=[], metavar="PATH",
                       help="a scene file, beside suite names (repeatable): a Mitsuba 3 XML file (imported "
                            "by from_mitsuba; unsupported features are refused with file:line) or a Python "
                            "file defining build(width, height) that returns a reference_tracer.Scene")
    group.add_argument("--param", dest="scene_params", action="append", default=[], metavar="NAME=VALUE",
                       help="a parameter of the scene files (repeatable): an XML $NAME value (overrides its "
                            "<default>) or a keyword argument of build(); with several files, each gets the "
                            "parameters it takes")


def resolve_scenes(args, *, suite_names=None, default=None) -> list:
    """Register ``args.scene_files`` and return the scene names to run.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed by a parser given :func:`add_scene_path_args`.
    suite_names : sequence of str or None
        Suite names from the command line (positional ``SCENE`` arguments).
    default : sequence of str or None
        Names used when neither suite names nor scene files are given (None: none).

    Returns
    -------
    list of str
        Suite names then scene-file names, without repeats.
    """
    from mitsuba_scenes.scene_files import params_used, parse_params, register_scene_file

    params = parse_params(getattr(args, "scene_params", []))
    files = list(getattr(args, "scene_files", []) or [])
    if params and not files:
        raise ValueError("--param applies to scene files: give one with --scene PATH")
    names = list(suite_names or [])
    used = set()
    for path in files:
        mine = params_used(path, params) if len(files) > 1 else params
        used.update(mine)
        names.append(register_scene_file(path, mine).name)
    unused = sorted(set(params) - used)
    if unused:
        raise ValueError(f"--param {', '.join(unused)}: no scene file takes it")
    if not names:
        names = list(default or [])
    return list(dict.fromkeys(names))
