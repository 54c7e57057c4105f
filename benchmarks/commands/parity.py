"""``rtbench parity [SCENE...] [--scene PATH]``: first-hit AOVs at pixel centres, ours vs Mitsuba
(:mod:`benchmarks.parity`); a Mitsuba XML file is loaded by Mitsuba itself, at its own size or at
``--width`` x ``--height`` (both renderers' films resized, as ``rtbench render`` resizes it)."""
from __future__ import annotations

import sys
import warnings

from benchmarks.commands import _args as A

HELP = ("first-hit AOV parity at pixel centres (distance, normal, albedo, emission, shape), ours vs Mitsuba; "
        "exit 1 with mismatch maps on a difference")

#: the width of suite and Python scenes without ``--width`` (an XML file keeps its own film).
DEFAULT_WIDTH = 64


def add_arguments(parser) -> None:
    A.add_scene_args(parser, what="suite scenes (default: the whole suite, unless --scene is given)")
    A.add_size_args(parser, width=None,
                    default_help=f"{DEFAULT_WIDTH} for suite and Python scenes, an XML file's own film size")
    A.add_out_arg(parser, default="rtbench-parity")  # the mismatch maps of failing scenes
    A.add_json_arg(parser)  # one row per scene
    A.add_quiet_arg(parser)
    A.add_scene_path_args(parser)


def parity_of(name: str, *, width: int | None = None, height: int | None = None):
    """The :class:`benchmarks.parity.ParityReport` of scene ``name`` (suite or registered file) at
    ``width`` x ``height`` (height defaults to width). Without a width a suite or Python scene
    is checked at its own size and an XML file at its film's; with one, an XML file's films are
    resized in both renderers (``from_mitsuba(..., film_size=)`` and
    :func:`mitsuba_scenes.render.load_file`), its field of view following its ``fov_axis``."""
    from mitsuba_scenes import get_scene
    from mitsuba_scenes.scene_files import scene_file

    from benchmarks.parity import run_parity

    if width is None and height is not None:
        raise ValueError("--height needs --width")
    size = None if width is None else (width, height or width)
    entry = scene_file(name)
    if entry is not None and entry.kind == "xml":
        scene = get_scene(name) if size is None else get_scene(name, width=size[0], height=size[1])
        return run_parity(scene, mitsuba=entry.path, params=entry.params, name=name, film_size=size)
    scene = get_scene(name)
    if size is not None:
        scene = scene.with_camera_size(*size)
    return run_parity(scene, name=name)


def check_user_scenes(names, out, *, command: str, skipped: str, width: int, height: int) -> bool:
    """Parity of the scene files among ``names`` at ``width`` x ``height``, the size ``command`` renders
    them at (:func:`parity_of`), before it renders them: False, after printing each failure's findings
    and mismatch maps and that ``command`` stops (``skipped``), when one fails. An XML file without a
    ``<film>`` is checked at Mitsuba's default film size, with a warning: Mitsuba cannot load it at
    another size without a film to resize (:func:`mitsuba_scenes.render.load_file`)."""
    from mitsuba_scenes.scene_files import scene_file

    ok = True
    for name in names:
        entry = scene_file(name)
        if entry is None:
            continue
        try:
            size = (width, height) if entry.kind != "xml" or _has_film(entry) else (None, None)
            if size[0] is None:
                warnings.warn(f"{name}: the file has no <film>, so its parity is checked at Mitsuba's default "
                              f"film size (768x576), not at {width}x{height}")
            report = parity_of(name, width=size[0], height=size[1])
        except ValueError as exc:  # e.g. Metal fuzz: no Mitsuba equivalent, no parity possible
            raise ValueError(f"{name}: no parity check possible, Mitsuba cannot load this scene: {exc} (gate such "
                             f"scenes against a store of ours: gate --reference STORE)") from None
        print(report.summary(), file=sys.stderr)
        if not report.passed:
            ok = False
            _explain(report, out)
    if not ok:
        print(f"rtbench {command}: the scene file(s) above translate differently in the two renderers; fix that "
              f"first ({skipped})", file=sys.stderr)
    return ok


def _has_film(entry) -> bool:
    """Whether Mitsuba XML scene file ``entry`` declares a ``<film>`` (with its parameters)."""
    from mitsuba_scenes.render import film_sizes
    from mitsuba_scenes.variants import select_variant

    select_variant(None)
    return bool(film_sizes(entry.path, params=entry.params))


def _explain(report, out) -> None:
    from benchmarks.parity import write_mismatch_maps

    for line in report.findings:
        print(f"  {line}", file=sys.stderr)
    png, exr = write_mismatch_maps(report, out)
    print(f"  mismatch maps: {png} and {exr}", file=sys.stderr)


def run(args) -> int:
    from mitsuba_scenes import list_scenes
    from mitsuba_scenes.scene_files import scene_file

    from benchmarks.store import write_json

    names = A.resolve_scenes(args, suite_names=args.scenes, default=list_scenes(), known=True)
    rows, failed = [], 0
    for name in names:
        xml = getattr(scene_file(name), "kind", None) == "xml"
        width = args.width if args.width is not None or xml else DEFAULT_WIDTH
        report = parity_of(name, width=width, height=args.height)
        if not args.quiet or not report.passed:
            print(report.summary(), flush=True)
        rows.append(report.to_dict())
        if not report.passed:
            failed += 1
            _explain(report, args.out)
    if args.json:
        write_json(args.json, rows)
    if failed:
        print(f"rtbench parity: {failed} of {len(names)} scene(s) differ from Mitsuba", file=sys.stderr)
    return 1 if failed else 0
