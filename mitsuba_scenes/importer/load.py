""":func:`from_mitsuba`: parse a scene with Mitsuba's own parser, walk it, and return our scene or
refuse it whole.
"""
from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Mapping
from pathlib import Path
from xml.parsers import expat

import numpy as np

import reference_tracer as rt
from reference_tracer.validation import integrator_depths

from ..variants import import_mitsuba
from .emitters import read_constant, read_emitter
from .sensor import checked_film_size, read_camera, read_sampler, without_idle_clip_planes
from .shapes import mesh_object, read_shape
from .values import Context, UnsupportedSceneError, check_params, located, read_scalar


#: deepest element nesting of an XML file handed to Mitsuba's parser (which recurses and
#: crashes the interpreter on a file nested some thousands of levels deep).
MAX_XML_DEPTH = 1000


def check_xml_depth(path, *, limit: int = MAX_XML_DEPTH) -> None:
    """Raise ``ValueError`` if the XML file at ``path`` nests elements deeper than ``limit``.

    Streams the file (expat, which does not recurse) before Mitsuba's parser sees it.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "deep.xml"
    >>> _ = p.write_text("<a>" * 5 + "</a>" * 5)
    >>> try:
    ...     check_xml_depth(p, limit=4)
    ... except ValueError as exc:
    ...     print(str(exc).split(" nests ")[1])
    elements more than 4 deep (line 1); refused before Mitsuba's parser
    """
    depth = {"now": 0}
    parser = expat.ParserCreate()

    def start(name, attrs):
        depth["now"] += 1
        if depth["now"] > limit:
            raise ValueError(f"from_mitsuba: {path} nests elements more than {limit} deep "
                             f"(line {parser.CurrentLineNumber}); refused before Mitsuba's parser")

    def end(name):
        depth["now"] -= 1

    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        with open(path, "rb") as fh:
            parser.ParseFile(fh)
    except expat.ExpatError as exc:
        raise ValueError(f"from_mitsuba: {path} is not well-formed XML: {exc}") from None


@contextlib.contextmanager
def _as_value_error(where: str):
    """Mitsuba's parser raises ``RuntimeError`` for a bad scene: make it the documented ``ValueError``."""
    try:
        yield
    except RuntimeError as exc:
        raise ValueError(f"{where}: {' '.join(str(exc).split())}") from exc


def from_mitsuba(source, params=None, *, film_size=None) -> rt.Scene:
    """Import a Mitsuba 3 scene (dict or XML file) as a :class:`reference_tracer.Scene`.

    Parameters
    ----------
    source : dict or str or os.PathLike
        A ``mi.load_dict`` dictionary, or the path of a Mitsuba 3 XML file.
    params : mapping, optional
        XML only: values of the file's ``$name`` parameters by name (overriding its
        ``<default>`` values), as ``mi.load_file(path, **params)`` takes them.
    film_size : (int, int), optional
        ``(width, height)`` in pixels replacing the film's own, as if the file said so (the
        field of view follows its ``fov_axis`` as in Mitsuba); the same scene at another size
        is :func:`mitsuba_scenes.render.load_file` with the same ``film_size``.

    Returns
    -------
    reference_tracer.Scene

    Raises
    ------
    UnsupportedSceneError
        If the scene uses anything outside the supported subset (see the module
        docstring): one error (a ``ValueError``) listing every unsupported plugin or
        parameter with its location (file, line and column, or dictionary path).
    ValueError
        A file that is missing, not a file (a directory) or malformed, an unknown ``$name``,
        or ``params`` that is not a mapping.

    Notes
    -----
    Meshes are shaded as Mitsuba shades them: with the vertex normals its ``obj`` / ``ply``
    loader gives (the file's; computed from the faces where the file has none, so an OBJ
    without ``vn`` is smooth; none with ``face_normals=true``), and no reconciliation of
    shading and geometric normals (:class:`reference_tracer.Mesh`).
    A shape without a BSDF gets Mitsuba's default (``diffuse``, reflectance 0.5), except an
    emitter shape, which Mitsuba makes black (it reflects nothing: ``DiffuseLight`` with no
    albedo); a
    ``dielectric`` becomes ``Dielectric(int_ior / ext_ior)`` (exact: Mitsuba uses only
    the ratio); Mitsuba's default ``fov_axis`` is ``'x'``; ``rr_depth`` larger than
    ``max_depth`` means no Russian roulette (``rr_depth=None``). ``sample_count`` is
    not imported: spp is chosen when rendering. ``obj``/``ply`` files are read by Mitsuba
    itself.

    Examples
    --------
    >>> from mitsuba_scenes import from_mitsuba
    >>> from mitsuba_scenes.variants import import_mitsuba
    >>> mi = import_mitsuba()
    >>> d = mi.cornell_box()
    >>> d["sensor"]["film"]["rfilter"] = {"type": "box"}
    >>> scene = from_mitsuba(d)
    >>> len(scene.shapes), scene.max_depth
    (8, 8)
    """
    if params is not None and not isinstance(params, Mapping):
        raise ValueError(f"from_mitsuba: params must be a mapping of $name names to values (a dict such as "
                         f"{{'spp': 16}}), got {type(params).__name__}")
    mi = import_mitsuba()
    cfg = mi.parser.ParserConfig(mi.variant())
    params = {str(k): str(v) for k, v in (params or {}).items()}
    if film_size is not None:
        film_size = checked_film_size(film_size)
    if isinstance(source, dict):
        if params:
            raise ValueError("from_mitsuba: params apply to XML files only")
        if source.get("type") != "scene":
            raise ValueError(f"from_mitsuba needs a scene dict (type 'scene'), got type {source.get('type')!r}")
        with _as_value_error("from_mitsuba"):
            state = mi.parser.parse_dict(cfg, source)
    elif isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if not path.exists():
            raise ValueError(f"from_mitsuba: no such file {path}")
        if not path.is_file():
            what = "a file but a directory" if path.is_dir() else "a regular file"
            raise ValueError(f"from_mitsuba: {path} is not {what} (give a Mitsuba 3 XML file)")
        check_xml_depth(path)
        with _as_value_error(f"from_mitsuba: {path}"):  # a malformed file or an unknown $name
            state, search = _parse_with_search_paths(mi, lambda: mi.parser.parse_file(cfg, str(path), **params))
    else:
        raise ValueError(f"from_mitsuba takes a dict or an XML path, got {type(source).__name__}")
    with _as_value_error("from_mitsuba"):
        mi.parser.transform_upgrade(cfg, state)
        mi.parser.transform_resolve(cfg, state)
    ctx = Context(mi, state)
    ctx.film_size = film_size
    if not isinstance(source, dict):
        ctx.base_dir = str(Path(source).resolve().parent)
        ctx.search = search
    root = state.root
    T, OT = mi.Properties.Type, mi.ObjectType

    sensor = integrator = None
    shapes, background, lights = [], np.zeros(3), []
    environments = []  # the nodes of constant and envmap emitters (Mitsuba allows one)
    for key in root.props.keys():
        t = root.props.type(key)
        if t == T.Object:
            obj = root.props[key]
            if isinstance(obj, mi.Mesh):
                shape = mesh_object(ctx, f'dictionary node "{key}"', obj)
                if shape is not None:
                    shapes.append(shape)
            else:
                ctx.bad(root, f"instantiated object '{key}' of class {type(obj).__name__}")
            continue
        if t != T.ResolvedReference:
            continue
        node = ctx.node(root.props[key])
        kind, name = node.type, node.props.plugin_name()
        if kind == OT.Sensor:
            if sensor is not None:
                ctx.bad(node, "a second sensor")
            sensor = node
        elif kind == OT.Integrator:
            integrator = node
        elif kind == OT.Shape:
            for c in ctx.children(node):
                if c.type not in (OT.BSDF, OT.Emitter):
                    ctx.bad(c, f"{str(c.type).split('.')[-1].lower()} '{c.props.plugin_name()}' inside a shape")
            shape = read_shape(ctx, node, ctx.child(node, OT.BSDF), ctx.child(node, OT.Emitter))
            if shape is not None:
                shapes.append(shape)
        elif kind == OT.Emitter:
            if name in ("constant", "envmap"):
                environments.append(node)
            if name == "constant":
                c = read_constant(ctx, node)
                if c is not None:
                    background = background + np.asarray(c)
            elif name != "area":  # an area emitter declared here is used by reference: checked on its shape
                light = read_emitter(ctx, node)
                if light is not None:
                    lights.append(light)
        elif kind in (OT.BSDF, OT.Texture):
            continue   # declared here, used through references; checked where used
        elif kind == OT.Sampler:  # declared here for a sensor to reference: the same rule as inside one
            read_sampler(ctx, node)
        else:
            ctx.bad(node, f"{str(kind).split('.')[-1].lower()} '{name}'")

    if len(environments) > 1:
        ctx.bad(environments[1], f"a second environment emitter ({environments[1].props.plugin_name()} after "
                                 f"{environments[0].props.plugin_name()}; Mitsuba allows one)")
    camera = read_camera(ctx, sensor)
    if integrator is not None and integrator.props.plugin_name() == "moment":
        # `moment` adds the second moment of the wrapped integrator's samples as extra
        # channels; the image (the mean) is the wrapped integrator's own
        inner = [c for c in ctx.children(integrator) if c.type == OT.Integrator]
        if len(inner) != 1:
            ctx.bad(integrator, f"integrator 'moment' wrapping {len(inner)} integrators (one is Mitsuba's use)")
            integrator = None
        else:
            integrator = inner[0]
    settings = read_integrator(ctx, integrator) if integrator is not None else (-1, 5, None)
    scene = None
    if not ctx.problems:
        scene = _scene(ctx, root, camera=without_idle_clip_planes(camera, shapes), shapes=shapes,
                       max_depth=settings[0], rr_depth=settings[1], direct=settings[2],
                       background=tuple(background), lights=lights)
    if ctx.problems:
        raise UnsupportedSceneError(ctx.problems, [ctx.features.get(p, p) for p in ctx.problems])
    return scene


@located
def _scene(ctx, root, **fields):
    """``rt.Scene(**fields)`` of parts each checked at its own node; anything the scene as a
    whole refuses is placed at the ``<scene>`` element."""
    return rt.Scene(**fields)


@located
def read_integrator(ctx, node):
    """``(max_depth, rr_depth, direct)`` of a ``path`` or ``direct`` integrator as our scene
    takes them (:func:`reference_tracer.validation.integrator_depths`, checked here so that a value
    it refuses is placed at the integrator); None after recording a problem."""
    iname = node.props.plugin_name()
    if iname not in ("path", "direct"):
        ctx.bad(node, f"integrator '{iname}' (only 'path' and 'direct')")
        return None
    if "hide_emitters" in node.props.keys() and bool(node.props["hide_emitters"]):
        ctx.bad(node, f"{iname} hide_emitters=true")
    if iname == "direct":
        return -1, 5, read_direct(ctx, node)
    check_params(ctx, node, {"max_depth", "rr_depth", "hide_emitters"}, "integrator")
    max_depth = int(read_scalar(ctx, node, "max_depth", -1))
    rr_depth = int(read_scalar(ctx, node, "rr_depth", 5))
    if max_depth != -1 and rr_depth > max_depth:
        rr = None
    elif max_depth == -1 and rr_depth >= rt.MAX_DEPTH_CAP:
        rr = None
    else:
        rr = rr_depth
    return (*integrator_depths(max_depth, rr), None)


@located
def read_direct(ctx, node):
    """Mitsuba's ``direct``: ``shading_samples`` (default 1) sets both counts, which
    ``emitter_samples`` and ``bsdf_samples`` override."""
    check_params(ctx, node, {"shading_samples", "emitter_samples", "bsdf_samples", "hide_emitters"}, "integrator")
    shading = read_scalar(ctx, node, "shading_samples", 1)
    counts = [read_scalar(ctx, node, name, shading) for name in ("emitter_samples", "bsdf_samples")]
    if any(isinstance(c, str) or not float(c).is_integer() for c in counts):
        ctx.bad(node, f"direct sample counts must be whole numbers, got {counts}")
        return None
    return rt.Direct(*(int(c) for c in counts))


#: A ``<path value="...">`` element of a Mitsuba XML file.
_PATH_ELEMENT = re.compile(rb"<path\s+value\s*=\s*(\"[^\"]*\"|'[^']*')")


def _parse_with_search_paths(mi, parse) -> tuple:
    """``(state, folders)``: the parsed file and the folders its ``<path>`` elements name
    (in the file and the files it includes, each relative to its own file, in order), read
    from the files themselves. Mitsuba's global file resolver is left as it was: parsing
    adds those folders to it, where they would serve another scene's files (and would
    already be there when a file was loaded before, by Mitsuba or by us)."""
    resolver = mi.file_resolver()
    before = [str(p) for p in resolver]
    try:
        state = parse()
    finally:
        resolver.clear()
        for p in before:
            resolver.append(p)
    folders = []
    for f in state.files:
        f = Path(str(f))
        try:
            text = f.read_bytes()
        except OSError:
            continue
        for m in _PATH_ELEMENT.finditer(text):
            value = m.group(1)[1:-1].decode("utf-8", "replace")
            folder = str((f.parent / value).resolve()) if not os.path.isabs(value) else value
            if folder not in folders:
                folders.append(folder)
    return state, folders
