"""``--scene PATH`` and ``--param name=value``: user scenes on every command that takes scenes,
registered (:mod:`mitsuba_scenes.scene_files`) and then accepted wherever a suite name is."""
from __future__ import annotations

import argparse


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
    """Register ``args.scene_files``; return ``suite_names`` then the files' names without repeats
    (``default`` when there are neither)."""
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
