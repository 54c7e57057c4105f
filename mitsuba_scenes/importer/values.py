"""The importer's walk of a parsed scene: its context (problems found, files, textures), the
decorator that places a reader's errors (:func:`located`) and the readers of plain values
(numbers, booleans, spectra, indices of refraction, matrices).
"""
from __future__ import annotations

import functools
import math
import os

import numpy as np


#: Named indices of refraction that Mitsuba accepts (its documented table).
IOR_TABLE = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
    "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
    "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501,
    "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
    "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046,
    "sodium chloride": 1.544, "amber": 1.55, "pet": 1.5750, "diamond": 2.419,
}


class UnsupportedSceneError(ValueError):
    """``from_mitsuba``'s refusal of a scene: things outside the supported subset, values our
    objects refuse (a negative radius), files that cannot be used (a mesh's broken faces).

    A ``ValueError`` whose message lists every item with its location; ``problems`` holds
    the same lines, ``features`` each one without its location (what the scene needs, e.g.
    ``"bsdf 'plastic'"``), in the same order.
    """

    def __init__(self, problems, features):
        self.problems, self.features = list(problems), list(features)
        super().__init__("from_mitsuba: the scene cannot be imported: what it uses outside the supported subset, "
                         f"or values and files it refuses ({len(self.problems)} found):\n  - "
                         + "\n  - ".join(self.problems))


class Context:
    """The state of one import: Mitsuba's module and parser state, the problems found so far,
    the textures made, and the folders where the scene's files are found."""

    def __init__(self, mi, state):
        self.mi, self.state, self.problems = mi, state, []
        self.textures = {}     # node index -> its texture (one object for every use), or None
        self.features = {}     # problem line -> the same without its location
        self.film_size = None  # (width, height) replacing the film's, or None
        self.base_dir = None   # folder of the XML file: relative mesh paths resolve there,
        self.search = []       # then in the folders of its <path> elements, in order

    def resolve(self, fname: str) -> str:
        """A file named by the scene, found as Mitsuba finds it: absolute, else in the XML's
        folder, else in its ``<path>`` folders (the first that has it)."""
        if os.path.isabs(fname) or self.base_dir is None:
            return fname
        for folder in [self.base_dir, *self.search]:
            candidate = os.path.join(folder, fname)
            if os.path.exists(candidate):
                return candidate
        return os.path.join(self.base_dir, fname)

    def confined(self, fname: str) -> str | None:
        """:meth:`resolve`'s file, or None where it lies outside the XML's folder and its
        ``<path>`` folders once symbolic links are resolved (an image a scene names is data
        of that scene: a shared scene may not make us read other files as textures). A
        scene given as a dict (Python code, no folder) is not confined."""
        path = self.resolve(fname)
        if self.base_dir is None:
            return path
        real = os.path.realpath(path)
        for folder in [self.base_dir, *self.search]:
            root = os.path.realpath(folder)
            if os.path.commonpath([root, real]) == root:
                return path
        return None

    def where(self, node) -> str:
        """The node's location: ``file (line L, col C)``, or ``dictionary node "key"`` in a
        dict; a string is a location already (a mesh object of a dict, which has no node)."""
        if isinstance(node, str):
            return node
        return self.mi.parser.file_location(self.state, node)

    def bad(self, node, what: str) -> None:
        msg = f"{what} ({self.where(node)})"
        if msg not in self.problems:
            self.problems.append(msg)
            self.features[msg] = what

    def node(self, ref):
        return self.state.nodes[ref.index()]

    def child(self, node, kind):
        """The child node of object type ``kind`` (e.g. ``mi.ObjectType.BSDF``), or None."""
        found = [c for c in self.children(node) if c.type == kind]
        if len(found) > 1:
            self.bad(node, f"{len(found)} children of type {str(kind).split('.')[-1]} (at most one)")
        return found[0] if found else None

    def children(self, node) -> list:
        p, T = node.props, self.mi.Properties.Type
        return [self.node(p[k]) for k in p.keys() if p.type(k) == T.ResolvedReference]


def located(reader):
    """Decorate ``reader(ctx, node, ...)``, the reader of one node of the parsed scene: a
    ``ValueError`` raised while it reads (a value that a ``reference_tracer`` constructor or
    one of its checks refuses: a negative radius or radiance, an index of refraction below
    the least) is recorded at that node, ``"<plugin>: <message> (<file> (line L, col C))"``
    (:meth:`Context.bad`), and the reader returns None, as for any problem it records
    itself; the import then refuses the scene with every problem listed. The one place where
    a constructor's error gets its location: every reader that builds objects is decorated.
    ``node`` may be a location string (a dict's mesh object, labelled ``mesh object``); a
    reader given no node (None: Mitsuba's default) lets the error through to its caller's.
    """
    @functools.wraps(reader)
    def read(ctx, node, *args, **kwargs):
        if node is None:
            return reader(ctx, node, *args, **kwargs)
        try:
            return reader(ctx, node, *args, **kwargs)
        except UnsupportedSceneError:
            raise
        except ValueError as exc:
            label = "mesh object" if isinstance(node, str) else node.props.plugin_name()
            ctx.bad(node, f"{label}: {' '.join(str(exc).split())}")
            return None
    return read


def param_names(node) -> list:
    """Names of the node's plain parameters (child objects excluded)."""
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    p = node.props
    return [k for k in p.keys() if p.type(k) != mi.Properties.Type.ResolvedReference]


#: Parameters Mitsuba reads as unbounded textures (an index of refraction, a roughness):
#: their spectra are not clipped to reflectances when converted to RGB.
_UNBOUNDED = {"eta", "k", "alpha", "alpha_u", "alpha_v"}


def read_spectrum(ctx, node, key) -> tuple:
    """A ``<spectrum>`` as Mitsuba's RGB variants see it (``Properties::get_texture``): a
    uniform value is grey, or for an emitter that value times the sRGB of XYZ (1, 1, 1) (so
    that RGB and spectral variants agree); wavelength:value pairs are integrated against
    the CIE curves (``spectrum_list_to_srgb``), bounded unless an emitter's or an unbounded
    parameter's, under D65 unless an emitter's."""
    mi = ctx.mi
    sp = node.props[key]
    emitter = node.type == mi.ObjectType.Emitter
    values = [float(v) for v in sp.values]
    if not values or not all(math.isfinite(v) for v in values):
        ctx.bad(node, f"{node.props.plugin_name()}.{key}: a spectrum with no or non-finite values")
        return None
    if sp.is_uniform():
        if emitter:
            return tuple(float(c) * values[0] for c in np.ravel(mi.xyz_to_srgb(mi.Color3f(1.0)))[:3])
        return (values[0],) * 3
    rgb = mi.spectrum_list_to_srgb([float(w) for w in sp.wavelengths], values,
                                   not (emitter or key in _UNBOUNDED), not emitter)
    return tuple(float(c) for c in np.ravel(rgb)[:3])


def read_scalar(ctx, node, key, default):
    p = node.props
    if key not in p.keys():
        return default
    v = p[key]
    return float(v) if not isinstance(v, str) else v


def read_film_size(ctx, film, key, default) -> int:
    """A film's width or height: a whole number >= 1 (1.5 is refused, not truncated to 1)."""
    v = read_scalar(ctx, film, key, default)
    if isinstance(v, str) or not float(v).is_integer() or not 1 <= float(v) <= 2**31 - 1:
        ctx.bad(film, f"film {key} must be a whole number of pixels >= 1, got {v!r}")
        return default
    return int(v)


def check_params(ctx, node, allowed, kind):
    for k in param_names(node):
        if k not in allowed:
            ctx.bad(node, f"{kind} '{node.props.plugin_name()}' parameter '{k}' is not supported")


def read_ior(ctx, node, key, default):
    """An index of refraction as Mitsuba reads it: a float, or a name of its table (any case)."""
    p = node.props
    if key in p.keys() and p.type(key) not in (ctx.mi.Properties.Type.Float, ctx.mi.Properties.Type.String):
        ctx.bad(node, f"{p.plugin_name()} {key} of type {p.type(key)} (a float or one of Mitsuba's IOR names)")
        return None
    v = read_scalar(ctx, node, key, default)
    if isinstance(v, str):
        if v.lower() not in IOR_TABLE:
            ctx.bad(node, f"{p.plugin_name()} {key}='{v}' is not a known IOR name "
                          f"(Mitsuba's: {', '.join(IOR_TABLE)})")
            return None
        return IOR_TABLE[v.lower()]
    return float(v)


def read_bool(ctx, node, key, default: bool):
    """A boolean property (Mitsuba refuses any other type for one), or None after recording a problem."""
    p = node.props
    if key not in p.keys():
        return default
    if p.type(key) != ctx.mi.Properties.Type.Bool:
        ctx.bad(node, f"{p.plugin_name()} {key} of type {p.type(key)} (a boolean)")
        return None
    return bool(p[key])


def read_matrix(ctx, node, key="to_world") -> np.ndarray:
    p = node.props
    if key not in p.keys():
        return np.eye(4)
    return np.array(p[key].matrix, dtype=np.float64)


def rigid_scale(m: np.ndarray):
    """(R, scales) if the linear part is R . diag(scales) with R a rotation, else None."""
    lin = m[:3, :3]
    s = np.linalg.norm(lin, axis=0)
    if np.any(s == 0):
        return None
    R = lin / s
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-5) or np.linalg.det(R) <= 0:
        return None
    return R, s
