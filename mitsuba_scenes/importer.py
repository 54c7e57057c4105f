"""``from_mitsuba``: import the subset of Mitsuba 3 scenes that our tracer models.

The dict or XML file is parsed with Mitsuba's own parser (``mi.parser``: defaults,
includes, references and transform chains resolved exactly as Mitsuba does), then
walked node by node. Supported: ``perspective`` and ``thinlens`` sensors (``fov`` with any
``fov_axis``, ``to_world`` a rigid matrix or ``look_at``, clip planes (a pinhole's dropped where
they clip nothing of the scene); the lens's ``aperture_radius`` and ``focus_distance``),
``orthographic`` (``to_world`` a rotation and scale, clip planes), ``hdrfilm`` with a ``box``,
``tent`` or ``gaussian`` filter (film fields that change no pixel are ignored),
``independent`` sampler, ``path`` integrator (``max_depth``, ``rr_depth``) and ``direct``
(``emitter_samples``, ``bsdf_samples``, ``shading_samples``), shapes ``sphere``,
``rectangle``, ``cube``, ``obj``, ``ply`` (with ``to_world``, ``flip_normals`` and
``face_normals``: the vertex normals Mitsuba's loader gives, read from the file or
computed where it has none, shade the mesh smooth as in Mitsuba), BSDFs ``diffuse``,
``conductor`` and ``roughconductor`` (``ggx`` or ``beckmann``, isotropic, ``material``
names or RGB ``eta``/``k``), ``dielectric``, ``thindielectric``, ``roughdielectric`` (``ggx`` or
``beckmann``, isotropic), ``plastic`` and ``roughplastic`` (constant
reflectances, named or numeric ``int_ior``/``ext_ior``, ``nonlinear``; rough: ``ggx`` or
``beckmann``, isotropic), ``twosided`` around one of those that only reflects (Mitsuba's
nests no BSDF that transmits), references by id, ``area``
emitters (on their shape or declared at the top level and referenced), ``constant``,
``envmap`` (an OpenEXR or RGBE ``filename`` read by our own checked readers, or a
``bitmap``; ``scale``, a rotation ``to_world``), ``point`` (``position`` or ``to_world``,
``intensity``), ``spot`` (``to_world`` a similarity, ``intensity``, ``cutoff_angle``,
``beam_width``, a ``checkerboard`` or ``bitmap`` ``texture``), ``directional`` (``direction``
or ``to_world``, ``irradiance``) and ``projector`` (``to_world`` a similarity, ``irradiance``
a constant or a ``checkerboard`` or ``bitmap``, ``scale``, ``fov`` with ``fov_axis`` or
``focal_length``), RGB or scalar values, and ``checkerboard`` and ``bitmap`` textures (with
``to_uv``; bitmap ``filter_type``, ``wrap_mode``, ``raw``; declared inline or at the top
level and referenced) for ``diffuse.reflectance``, a plastic's ``diffuse_reflectance`` and a
conductor's ``specular_reflectance``, with the texture coordinates of each shape (a mesh
file's own), and ``mesh_attribute`` textures (``name``, ``scale``) on meshes, the attribute
as Mitsuba's loader made it (a PLY's vertex or face properties).
Anything else is refused with one ``ValueError`` listing every unsupported item and
where it is; no partial scene is ever returned.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import re
from pathlib import Path
from xml.parsers import expat

import numpy as np

import reference_tracer as rt
from reference_tracer.conductors import CONDUCTORS
from reference_tracer.materials import textures_of
from reference_tracer.meshfile import check_mesh_file, check_serialized_file, decode_obj, obj_undefined_normal
from reference_tracer.shapes import farthest_distance, surface_within

from .variants import import_mitsuba

__all__ = ["from_mitsuba", "UnsupportedSceneError", "IOR_TABLE"]

#: Named indices of refraction that Mitsuba accepts (its documented table).
IOR_TABLE = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
    "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
    "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501,
    "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
    "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046,
    "sodium chloride": 1.544, "amber": 1.55, "pet": 1.5750, "diamond": 2.419,
}

# Mitsuba defaults that matter here.
_DEFAULT_DIFFUSE = 0.5
_SENSOR_OK = {"fov", "fov_axis", "to_world", "near_clip", "far_clip", "focus_distance", "film", "sampler",
              "x_fov", "srf", "focal_length"}
# The sensors read, and the parameters each takes (the orthographic one has no field of
# view: its to_world's scale is the view's extent).
_SENSORS = {"perspective": _SENSOR_OK, "thinlens": _SENSOR_OK | {"aperture_radius"},
            "orthographic": {"to_world", "near_clip", "far_clip", "film", "sampler", "srf"}}
# ProjectiveCamera's defaults (src/render/sensor.cpp).
_NEAR_CLIP, _FAR_CLIP = 1e-2, 1e4
# hdrfilm parameters that change no pixel value of the RGB image rendered: the output file's
# format and channels, the banner (sample_border is checked where it matters).
_FILM_OK = {"width", "height", "rfilter", "pixel_format", "component_format", "sample_border",
            "compensate", "banner", "file_format"}


class UnsupportedSceneError(ValueError):
    """``from_mitsuba``'s refusal of a scene that uses things outside the supported subset.

    A ``ValueError`` whose message lists every item with its location; ``problems`` holds
    the same lines, ``features`` each one without its location (what the scene needs, e.g.
    ``"bsdf 'plastic'"``), in the same order.
    """

    def __init__(self, problems, features):
        self.problems, self.features = list(problems), list(features)
        super().__init__("from_mitsuba: the scene uses things outside the supported subset "
                         f"({len(self.problems)} found):\n  - " + "\n  - ".join(self.problems))


class _Ctx:
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


def _keys(node) -> list:
    """Names of the node's plain parameters (child objects excluded)."""
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    p = node.props
    return [k for k in p.keys() if p.type(k) != mi.Properties.Type.ResolvedReference]


def _colour(ctx, node, key, default):
    """RGB triple of property ``key`` (Color or Float), or None after recording a problem."""
    p = node.props
    if key not in p.keys():
        return (default,) * 3 if np.isscalar(default) else tuple(default)
    T = ctx.mi.Properties.Type
    t = p.type(key)
    if t in (T.Float, T.Integer):
        return (float(p[key]),) * 3
    if t == T.Color:
        return tuple(float(x) for x in np.array(p[key]).ravel()[:3])
    if t == T.Spectrum:
        return _spectrum_rgb(ctx, node, key)
    if t == T.ResolvedReference:
        sub = ctx.node(p[key])
        if sub.props.plugin_name() in ("rgb", "srgb") and "value" in sub.props.keys():
            return _colour(ctx, sub, "value", 0.0)
        where = (node.props.plugin_name(), key)
        why = ("only checkerboard, bitmap and mesh_attribute textures" if where in _TEXTURED else
               "only constant values here; " + _TEXTURES_READ)
        ctx.bad(sub, f"texture '{sub.props.plugin_name()}' for {node.props.plugin_name()}.{key} ({why})")
        return None
    ctx.bad(node, f"{node.props.plugin_name()}.{key} of type {t} (only RGB or scalar values are supported)")
    return None


#: (plugin, parameter) pairs that take a texture: the reflectances our materials texture.
_TEXTURED = {("diffuse", "reflectance"), ("plastic", "diffuse_reflectance"), ("roughplastic", "diffuse_reflectance"),
             ("conductor", "specular_reflectance"), ("roughconductor", "specular_reflectance"),
             ("spot", "texture"), ("projector", "irradiance")}
_TEXTURES_READ = ("textures are read for diffuse.reflectance, a plastic's diffuse_reflectance and a conductor's "
                  "specular_reflectance")


def _reflectance(ctx, node, key, default):
    """A reflectance that may be textured: an RGB triple (:func:`_colour`), a texture
    (``checkerboard``, ``bitmap``), or None after recording a problem."""
    p = node.props
    if key in p.keys() and p.type(key) == ctx.mi.Properties.Type.ResolvedReference:
        index = p[key].index()
        sub = ctx.node(p[key])
        if sub.props.plugin_name() in ("checkerboard", "bitmap", "mesh_attribute"):
            if index not in ctx.textures:   # a texture referenced twice is one object
                make = {"checkerboard": _checkerboard, "bitmap": _bitmap,
                        "mesh_attribute": _mesh_attribute}[sub.props.plugin_name()]
                ctx.textures[index] = make(ctx, sub)
            return ctx.textures[index]
    return _colour(ctx, node, key, default)


def _to_uv(ctx, node):
    """A texture's ``to_uv`` (Mitsuba keeps rows and columns 0, 1 and the translation of
    the 4x4 matrix) as the 4x4 matrix, or None."""
    return _matrix(ctx, node, "to_uv") if "to_uv" in node.props.keys() else None


def _mesh_attribute(ctx, node):
    """Mitsuba's ``mesh_attribute`` (its ``name`` and ``scale``); the values are the mesh's,
    read where the shape is (:func:`_mesh_attributes`). None after recording a problem."""
    _extra(ctx, node, {"name", "scale"}, "texture")
    if "name" not in node.props.keys():
        ctx.bad(node, "mesh_attribute without a name")
        return None
    scale = _scalar(ctx, node, "scale", 1.0)
    try:
        return rt.MeshAttribute(str(node.props["name"]), float(scale))
    except (TypeError, ValueError) as exc:
        ctx.bad(node, f"mesh_attribute: {exc}")
        return None


#: the buffers of Mitsuba's mesh that are its geometry, not attributes.
_MESH_BUFFERS = {"vertex_positions", "vertex_normals", "vertex_texcoords", "faces"}


def _mesh_attributes(params, mat) -> dict | None:
    """The attributes of a Mitsuba mesh that ``mat``'s mesh_attribute textures read (as its
    loader made them: ``mi.traverse``), or None where it has no such texture. A missing one is
    left for :meth:`reference_tracer.MeshAttribute.values` to name."""
    names = {t.name for t in textures_of(mat) if isinstance(t, rt.MeshAttribute)}
    if not names:
        return None
    out = {}
    for key in params.keys():
        if key in names and key not in _MESH_BUFFERS:
            out[key] = np.array(params[key], dtype=np.float64)
    return out


def _checkerboard(ctx, node):
    _extra(ctx, node, {"color0", "color1", "to_uv"}, "texture")
    c0, c1 = _colour(ctx, node, "color0", 0.4), _colour(ctx, node, "color1", 0.2)
    if c0 is None or c1 is None:
        return None
    try:
        return rt.Checkerboard(c0, c1, to_uv=_to_uv(ctx, node))
    except ValueError as exc:
        ctx.bad(node, f"checkerboard: {exc}")
        return None


def _bitmap(ctx, node):
    """Mitsuba's ``bitmap`` from its file (read by :func:`reference_tracer.textures.read_image`,
    which checks the file and its header first), or None after recording a problem."""
    _extra(ctx, node, {"filename", "filter_type", "wrap_mode", "raw", "to_uv", "format", "accel"}, "texture")
    p = node.props
    if "filename" not in p.keys():
        ctx.bad(node, "bitmap without a filename (only bitmaps read from files)")
        return None
    fmt = _scalar(ctx, node, "format", "auto")
    if fmt != "auto":
        ctx.bad(node, f"bitmap format='{fmt}' (only 'auto': the file's own precision)")
        return None
    raw = _bool(ctx, node, "raw", False)
    if raw is None:
        return None
    fname = ctx.confined(str(p["filename"]))
    if fname is None:
        ctx.bad(node, f"bitmap {p['filename']!r} lies outside the scene's folder and its <path> folders (an image "
                      "a scene reads must be part of it)")
        return None
    try:
        return rt.Bitmap(fname, filter=_scalar(ctx, node, "filter_type", "bilinear"),
                         wrap=_scalar(ctx, node, "wrap_mode", "repeat"), raw=raw, to_uv=_to_uv(ctx, node))
    except (ValueError, OSError) as exc:
        ctx.bad(node, f"bitmap {fname} cannot be used: {exc}")
        return None


def _material(ctx, node, factory, *args, **kwargs):
    """``factory(*args, **kwargs)``, or None after recording its ``ValueError`` (a value
    Mitsuba takes and we do not, such as a texture beyond [0, 1]) with the place."""
    try:
        return factory(*args, **kwargs)
    except ValueError as exc:
        ctx.bad(node, f"{node.props.plugin_name()}: {exc}")
        return None


#: Parameters Mitsuba reads as unbounded textures (an index of refraction, a roughness):
#: their spectra are not clipped to reflectances when converted to RGB.
_UNBOUNDED = {"eta", "k", "alpha", "alpha_u", "alpha_v"}


def _spectrum_rgb(ctx, node, key) -> tuple:
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


def _scalar(ctx, node, key, default):
    p = node.props
    if key not in p.keys():
        return default
    v = p[key]
    return float(v) if not isinstance(v, str) else v


def _film_size(ctx, film, key, default) -> int:
    """A film's width or height: a whole number >= 1 (1.5 is refused, not truncated to 1)."""
    v = _scalar(ctx, film, key, default)
    if isinstance(v, str) or not float(v).is_integer() or not 1 <= float(v) <= 2**31 - 1:
        ctx.bad(film, f"film {key} must be a whole number of pixels >= 1, got {v!r}")
        return default
    return int(v)


def _extra(ctx, node, allowed, kind):
    for k in _keys(node):
        if k not in allowed:
            ctx.bad(node, f"{kind} '{node.props.plugin_name()}' parameter '{k}' is not supported")


def _ior(ctx, node, key, default):
    """An index of refraction as Mitsuba reads it: a float, or a name of its table (any case)."""
    p = node.props
    if key in p.keys() and p.type(key) not in (ctx.mi.Properties.Type.Float, ctx.mi.Properties.Type.String):
        ctx.bad(node, f"{p.plugin_name()} {key} of type {p.type(key)} (a float or one of Mitsuba's IOR names)")
        return None
    v = _scalar(ctx, node, key, default)
    if isinstance(v, str):
        if v.lower() not in IOR_TABLE:
            ctx.bad(node, f"{p.plugin_name()} {key}='{v}' is not a known IOR name "
                          f"(Mitsuba's: {', '.join(IOR_TABLE)})")
            return None
        return IOR_TABLE[v.lower()]
    return float(v)


def _bool(ctx, node, key, default: bool):
    """A boolean property (Mitsuba refuses any other type for one), or None after recording a problem."""
    p = node.props
    if key not in p.keys():
        return default
    if p.type(key) != ctx.mi.Properties.Type.Bool:
        ctx.bad(node, f"{p.plugin_name()} {key} of type {p.type(key)} (a boolean)")
        return None
    return bool(p[key])


def _plastic(ctx, node, name, two_sided):
    """Our Plastic or RoughPlastic for Mitsuba's ``plastic`` / ``roughplastic`` node, or None."""
    rough = name == "roughplastic"
    allowed = {"diffuse_reflectance", "specular_reflectance", "int_ior", "ext_ior", "nonlinear"}
    if rough:
        allowed |= {"distribution", "alpha", "alpha_u", "alpha_v", "sample_visible"}
    _extra(ctx, node, allowed, "bsdf")
    ok = True
    diffuse = _reflectance(ctx, node, "diffuse_reflectance", _DEFAULT_DIFFUSE)
    specular = _colour(ctx, node, "specular_reflectance", 1.0)
    int_ior, ext_ior = _ior(ctx, node, "int_ior", "polypropylene"), _ior(ctx, node, "ext_ior", "air")
    nonlinear = _bool(ctx, node, "nonlinear", False)
    kw = {}
    if rough:
        dist = _distribution(ctx, node, "roughplastic")
        ok = ok and dist is not None
        alpha = _roughness(ctx, node)
        if alpha is None:
            ok = False
        else:
            kw = {"alpha": max(alpha, 1e-4), "distribution": dist}  # Mitsuba clamps alpha to 1e-4 too
    if not ok or None in (diffuse, specular, int_ior, ext_ior, nonlinear):
        return None
    try:
        return (rt.RoughPlastic if rough else rt.Plastic)(
            diffuse, specular_reflectance=specular, int_ior=int_ior, ext_ior=ext_ior, nonlinear=nonlinear,
            two_sided=two_sided, **kw)
    except ValueError as exc:  # values Mitsuba takes and we do not (or neither does), with the place
        ctx.bad(node, f"{name}: {exc}")
        return None


# --------------------------------------------------------------------------- BSDFs
#: BSDFs with a transmission component (a mask's and null's pass-through is one): Mitsuba's
#: twosided refuses to nest them.
_TRANSMITTING = ("dielectric", "thindielectric", "roughdielectric", "mask", "null")


def _bsdf(ctx, node, *, two_sided=False, emitter=None):
    """Material for BSDF ``node``.

    None (no ``<bsdf>``): Mitsuba's default diffuse 0.5 on a plain shape, but *black* on an
    emitter shape - Mitsuba gives an area emitter without a BSDF a black diffuse BSDF
    (``mi.traverse`` shows reflectance 0), so the light reflects nothing.
    """
    if node is None:
        if emitter is not None:
            return rt.DiffuseLight(emitter, albedo=None)
        return rt.Lambertian((_DEFAULT_DIFFUSE,) * 3)
    name = node.props.plugin_name()
    if name == "twosided":
        subs = ctx.children(node)
        transmits = [s.props.plugin_name() for s in subs if s.props.plugin_name() in _TRANSMITTING]
        if transmits:
            ctx.bad(node, f"twosided around a {transmits[0]}, a BSDF that transmits: Mitsuba refuses it too "
                          "(\"Only materials without a transmission component can be nested!\")")
            return None
        if len(subs) != 1 or _keys(node):
            if len(subs) == 2 and subs[0].props == subs[1].props:
                pass
            else:
                ctx.bad(node, "twosided with two different BSDFs is not supported")
                return None
        if emitter is not None:
            # Mitsuba's area emitter is one-sided whatever the BSDF: a black twosided BSDF
            # reflects nothing on either side, exactly our DiffuseLight without albedo
            inner = subs[0]
            albedo = (_reflectance(ctx, inner, "reflectance", _DEFAULT_DIFFUSE)
                      if inner.props.plugin_name() == "diffuse" and not set(_keys(inner)) - {"reflectance"}
                      else None)
            if albedo is not None and not isinstance(albedo, rt.Texture) and max(albedo) == 0.0:
                return rt.DiffuseLight(emitter, albedo=None)
            ctx.bad(node, "an area emitter on a twosided BSDF that reflects (our DiffuseLight reflects on its front "
                          "only; a black twosided diffuse is supported)")
            return None
        return _bsdf(ctx, subs[0], two_sided=True)
    if name == "diffuse":
        _extra(ctx, node, {"reflectance"}, "bsdf")
        albedo = _reflectance(ctx, node, "reflectance", _DEFAULT_DIFFUSE)
        if albedo is None:
            return None
        if emitter is not None:
            black = not isinstance(albedo, rt.Texture) and max(albedo) == 0
            return _material(ctx, node, rt.DiffuseLight, emitter, albedo=None if black else albedo)
        return _material(ctx, node, rt.Lambertian, albedo, two_sided=two_sided)
    if emitter is not None:
        ctx.bad(node, f"an area emitter on a '{name}' BSDF (our emitters reflect as diffuse only)")
        return None
    if name == "mask":
        return _mask(ctx, node, two_sided)
    if name == "conductor":
        _extra(ctx, node, {"material", "specular_reflectance", "eta", "k"}, "bsdf")
        ior = _conductor_ior(ctx, node)
        albedo = _reflectance(ctx, node, "specular_reflectance", 1.0)
        if ior is None or albedo is None:
            return None
        return _material(ctx, node, rt.Metal, albedo, fuzz=0.0, two_sided=two_sided, **ior)
    if name == "roughconductor":
        _extra(ctx, node, {"material", "specular_reflectance", "distribution", "alpha", "alpha_u", "alpha_v",
                           "sample_visible", "eta", "k"}, "bsdf")
        dist = _distribution(ctx, node, "roughconductor")
        ok = dist is not None
        alpha = _roughness(ctx, node)
        ior = _conductor_ior(ctx, node)
        albedo = _reflectance(ctx, node, "specular_reflectance", 1.0)
        if not ok or alpha is None or ior is None or albedo is None:
            return None
        return _material(ctx, node, rt.RoughConductor, albedo, alpha=alpha, distribution=dist, two_sided=two_sided,
                         **ior)
    if name in ("plastic", "roughplastic"):
        return _plastic(ctx, node, name, two_sided)
    if name in ("dielectric", "thindielectric", "roughdielectric"):
        rough = name == "roughdielectric"
        _extra(ctx, node, {"int_ior", "ext_ior", "specular_reflectance", "specular_transmittance"}
               | ({"distribution", "alpha", "alpha_u", "alpha_v", "sample_visible"} if rough else set()), "bsdf")
        ok = True
        for k in ("specular_reflectance", "specular_transmittance"):
            c = _colour(ctx, node, k, 1.0)
            if c is not None and c != (1.0, 1.0, 1.0):
                ctx.bad(node, f"{name} {k}={c} (only 1)")
                ok = False
        i, e = _ior(ctx, node, "int_ior", "bk7"), _ior(ctx, node, "ext_ior", "air")
        if rough:
            dist = _distribution(ctx, node, "roughdielectric")
            ok = ok and dist is not None
            alpha = _roughness(ctx, node)
            if not ok or alpha is None or i is None or e is None:
                return None
            return rt.RoughDielectric(i / e, alpha, distribution=dist)
        if not ok or i is None or e is None:
            return None
        # Mitsuba's (thin) dielectric depends on int_ior / ext_ior only: exact with ext = 1.
        return rt.Dielectric(i / e) if name == "dielectric" else rt.ThinDielectric(i / e)
    ctx.bad(node, f"bsdf '{name}'")
    return None


def _opacity(ctx, node):
    """A mask's opacity as Mitsuba's ``eval_1`` reads it: a number (default 0.5), the mean of an
    RGB value's channels (an ``rgb`` texture's ``eval_1``), or a ``checkerboard`` or ``bitmap``
    texture (:class:`reference_tracer.Mask` reads its ``eval_1``); None after recording a problem."""
    p = node.props
    if "opacity" in p.keys() and p.type("opacity") == ctx.mi.Properties.Type.ResolvedReference:
        sub = ctx.node(p["opacity"])
        if sub.props.plugin_name() in ("checkerboard", "bitmap", "mesh_attribute"):
            return _reflectance(ctx, node, "opacity", 0.5)
        if sub.props.plugin_name() not in ("rgb", "srgb"):
            ctx.bad(sub, f"texture '{sub.props.plugin_name()}' for mask.opacity (a number, an RGB value, or a "
                         "checkerboard or bitmap texture)")
            return None
    c = _colour(ctx, node, "opacity", 0.5)
    if c is None:
        return None
    return sum(c) / 3.0


def _mask(ctx, node, two_sided):
    """Mitsuba's ``mask`` around one nested BSDF (within a ``twosided``, or around one: the
    same BSDF), its opacity clipped to [0, 1] as Mitsuba clips it; None after recording a
    problem."""
    _extra(ctx, node, {"opacity"}, "bsdf")
    nested = [c for c in ctx.children(node) if c.type == ctx.mi.ObjectType.BSDF]
    if len(nested) != 1:
        ctx.bad(node, "mask without a nested BSDF" if not nested else
                f"mask with {len(nested)} nested BSDFs (Mitsuba takes exactly one)")
        return None
    opacity = _opacity(ctx, node)
    if isinstance(opacity, float) and math.isnan(opacity):
        ctx.bad(node, "mask opacity NaN")
        return None
    inner = _bsdf(ctx, nested[0], two_sided=two_sided)
    if inner is None or opacity is None:
        return None
    if isinstance(inner, rt.Mask):
        ctx.bad(node, "a mask around a mask (one mask only)")
        return None
    return _material(ctx, node, rt.Mask, inner, opacity, clip=True)


def _distribution(ctx, node, name: str):
    """A microfacet BSDF's distribution (Mitsuba's default beckmann), or None after recording a
    problem: another name, or ``sample_visible=false`` (another estimator of the same image,
    which ours does not implement)."""
    ok = True
    dist = _scalar(ctx, node, "distribution", "beckmann")
    if dist not in rt.DISTRIBUTIONS:
        ctx.bad(node, f"{name} distribution '{dist}' (ggx or beckmann)")
        ok = False
    if _bool(ctx, node, "sample_visible", True) is not True:
        ctx.bad(node, f"{name} sample_visible=false (the estimator differs; its image does not)")
        ok = False
    return dist if ok else None


def _roughness(ctx, node):
    """A microfacet BSDF's isotropic alpha (Mitsuba's default 0.1), or None after recording a problem:
    a texture, or alpha_u differing from alpha_v (anisotropy), is not modelled."""
    T = ctx.mi.Properties.Type
    for key in ("alpha", "alpha_u", "alpha_v"):
        if key in node.props.keys() and node.props.type(key) not in (T.Float, T.Integer):
            ctx.bad(node, f"{node.props.plugin_name()} {key} given as a texture (a textured roughness is not "
                          "supported: only a number; textures are read for reflectances)")
            return None
    au, av = _scalar(ctx, node, "alpha_u", None), _scalar(ctx, node, "alpha_v", None)
    if au is not None or av is not None:
        if au != av:
            ctx.bad(node, f"anisotropic {node.props.plugin_name()} (alpha_u={au}, alpha_v={av})")
            return None
        return float(au)
    return float(_scalar(ctx, node, "alpha", 0.1))


def _conductor_ior(ctx, node):
    """``{"eta", "k"}`` or ``{"material"}`` keyword arguments of our conductors, as Mitsuba reads
    them (``material`` defaults to "none", Fresnel 1; ``eta`` with ``k`` defaulting to 1), or None."""
    keys = node.props.keys()
    if "eta" in keys or "k" in keys:
        if "material" in keys:
            ctx.bad(node, f"{node.props.plugin_name()} with both material and eta/k (Mitsuba refuses it too)")
            return None
        eta = _colour(ctx, node, "eta", 0.0)
        k = _colour(ctx, node, "k", 1.0)
        return None if eta is None or k is None else {"eta": eta, "k": k}
    material = _scalar(ctx, node, "material", "none")
    if not isinstance(material, str) or material not in CONDUCTORS:
        ctx.bad(node, f"{node.props.plugin_name()} material='{material}' (not one of Mitsuba's named conductors)")
        return None
    return {"material": material}


# --------------------------------------------------------------------------- lights
#: Parameters every emitter may have that change Mitsuba's variance, never its image: the
#: share of light samples it gets (our selection is by power; docs/conventions.md, Light transport).
_EMITTER_ANY = {"sampling_weight"}


def _point3(ctx, node, key):
    """A ``<point>`` / ``<vector>`` property as a 3-vector, or None after recording a problem."""
    p = node.props
    try:
        v = np.array(p[key], dtype=np.float64).ravel()
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        ctx.bad(node, f"{p.plugin_name()}.{key} must be a finite 3-vector")
        return None
    return v


def _conformal_axis(ctx, node, m):
    """The unit +z axis of ``to_world`` (a spot's or directional light's direction), or None
    after recording a problem: its linear part must be a rotation times a uniform scale
    (a stretch would change the shape of a spot's cone)."""
    rs = _rigid_scale(m)
    if rs is None or not np.allclose(rs[1], rs[1][0], rtol=1e-5):
        ctx.bad(node, f"{node.props.plugin_name()} to_world is not a similarity (rotation, uniform scale, "
                      "translation)")
        return None
    z = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
    return z / np.linalg.norm(z)


def _envmap(ctx, node):
    """Our EnvMap for Mitsuba's ``envmap`` node (its file read by our checked readers), or None."""
    _extra(ctx, node, {"filename", "bitmap", "scale", "to_world", "mis_compensation"} | _EMITTER_ANY, "emitter")
    keys = node.props.keys()
    scale = _scalar(ctx, node, "scale", 1.0)
    if isinstance(scale, str):
        ctx.bad(node, f"envmap scale={scale!r} (a number)")
        return None
    m = _matrix(ctx, node)
    try:
        if "bitmap" in keys:   # a mi.Bitmap object, as load_dict takes it (and to_mitsuba gives it)
            if "filename" in keys:
                ctx.bad(node, "envmap with both bitmap and filename (Mitsuba refuses it too)")
                return None
            image = np.array(node.props["bitmap"], dtype=np.float64)
        elif "filename" in keys:
            image = ctx.resolve(str(node.props["filename"]))
        else:
            ctx.bad(node, "envmap without a filename")
            return None
        return rt.EnvMap(image, scale=float(scale), to_world=m)
    except (ValueError, OSError) as exc:
        ctx.bad(node, f"envmap: {exc}")
        return None


def _light(ctx, node):
    """Our light for a top-level Mitsuba emitter other than ``area`` and ``constant``: an
    EnvMap, PointLight, SpotLight or DirectionalLight; None after recording a problem."""
    name = node.props.plugin_name()
    keys = node.props.keys()
    if name == "envmap":
        return _envmap(ctx, node)
    try:
        if name == "point":
            _extra(ctx, node, {"position", "to_world", "intensity"} | _EMITTER_ANY, "emitter")
            if "position" in keys and "to_world" in keys:
                ctx.bad(node, "point light with both position and to_world (Mitsuba refuses it too)")
                return None
            position = _point3(ctx, node, "position") if "position" in keys else _matrix(ctx, node)[:3, 3]
            intensity = _colour(ctx, node, "intensity", 1.0)
            if position is None or intensity is None:
                return None
            return rt.PointLight(position, intensity)
        if name == "spot":
            _extra(ctx, node, {"to_world", "intensity", "cutoff_angle", "beam_width", "texture"} | _EMITTER_ANY,
                   "emitter")
            m = _matrix(ctx, node)
            axis = _conformal_axis(ctx, node, m)
            intensity = _colour(ctx, node, "intensity", 1.0)
            cutoff = _scalar(ctx, node, "cutoff_angle", 20.0)
            beam = _scalar(ctx, node, "beam_width", None)
            texture = None
            if "texture" in keys:
                texture = _reflectance(ctx, node, "texture", 1.0)
                if texture is None:
                    return None
                if not isinstance(texture, rt.Texture):
                    ctx.bad(node, "spot texture must be a checkerboard or bitmap (Mitsuba refuses a constant one: "
                                  "the intensity is the constant)")
                    return None
            if axis is None or intensity is None:
                return None
            return rt.SpotLight(m[:3, 3], axis, intensity, cutoff_angle=cutoff,
                                beam_width=None if beam is None else beam, texture=texture,
                                up=_axis_up(m))
        if name == "projector":
            return _projector(ctx, node)
        if name == "directional":
            _extra(ctx, node, {"direction", "to_world", "irradiance"} | _EMITTER_ANY, "emitter")
            if "direction" in keys and "to_world" in keys:
                ctx.bad(node, "directional light with both direction and to_world (Mitsuba refuses it too)")
                return None
            if "direction" in keys:
                direction = _point3(ctx, node, "direction")
            else:
                m = _matrix(ctx, node)
                direction = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
                if not abs(np.linalg.norm(direction) - 1.0) < 1e-5:
                    # Mitsuba uses to_world's +z axis as the light's direction without
                    # normalising it: a scaled axis would scale its light
                    ctx.bad(node, "directional to_world scales its +z axis (Mitsuba would not normalise it)")
                    return None
            irradiance = _colour(ctx, node, "irradiance", 1.0)
            if direction is None or irradiance is None:
                return None
            return rt.DirectionalLight(direction, irradiance)
    except ValueError as exc:   # a value Mitsuba takes and we do not (or neither does), with the place
        ctx.bad(node, f"{name}: {exc}")
        return None
    ctx.bad(node, f"emitter '{name}' (area on shapes, constant, envmap, point, spot, directional and projector "
                  "are supported)")
    return None


def _axis_up(m: np.ndarray) -> tuple:
    """The image of +y under ``to_world`` (a light's up: with its +z axis, Mitsuba's look_at
    frame gives back the rotation of a similarity)."""
    y = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    return tuple(float(v) for v in y / np.linalg.norm(y))


def _projector(ctx, node):
    """Our ProjectorLight for Mitsuba's ``projector``, or None after recording a problem.
    A uniform scale s of ``to_world`` multiplies what arrives by s (Mitsuba's 1 / (z_local^2
    cos) with z_local = z / s and the axis n of length s), folded into ``scale``."""
    _extra(ctx, node, {"to_world", "irradiance", "scale", "fov", "fov_axis", "focal_length"} | _EMITTER_ANY,
           "emitter")
    keys = node.props.keys()
    m = _matrix(ctx, node)
    axis = _conformal_axis(ctx, node, m)
    irradiance = _reflectance(ctx, node, "irradiance", 1.0)
    scale = _scalar(ctx, node, "scale", 1.0)
    if isinstance(scale, str):
        ctx.bad(node, f"projector scale={scale!r} (a number)")
        return None
    if "fov" in keys and "focal_length" in keys:
        ctx.bad(node, "projector with both fov and focal_length (Mitsuba refuses it too)")
        return None
    if axis is None or irradiance is None:
        return None
    if "fov" in keys:
        fov, fov_axis = _scalar(ctx, node, "fov", None), str(_scalar(ctx, node, "fov_axis", "x")).lower()
    else:
        text = str(_scalar(ctx, node, "focal_length", "50mm"))
        try:
            f = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            ctx.bad(node, f"projector focal_length={text!r} (of the form <x>mm)")
            return None
        fov, fov_axis = 2.0 * math.degrees(math.atan(math.sqrt(36.0 ** 2 + 24.0 ** 2) / (2.0 * f))), "diagonal"
    s = float(np.linalg.norm(m[:3, 2]))
    try:
        return rt.ProjectorLight(m[:3, 3], axis, irradiance, up=_axis_up(m), fov=fov, fov_axis=fov_axis,
                                 scale=float(scale) * s)
    except (TypeError, ValueError) as exc:
        ctx.bad(node, f"projector: {exc}")
        return None


# --------------------------------------------------------------------------- shapes
def _matrix(ctx, node, key="to_world") -> np.ndarray:
    p = node.props
    if key not in p.keys():
        return np.eye(4)
    return np.array(p[key].matrix, dtype=np.float64)


def _rigid_scale(m: np.ndarray):
    """(R, scales) if the linear part is R . diag(scales) with R a rotation, else None."""
    lin = m[:3, :3]
    s = np.linalg.norm(lin, axis=0)
    if np.any(s == 0):
        return None
    R = lin / s
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-5) or np.linalg.det(R) <= 0:
        return None
    return R, s


def _shape(ctx, node, bsdf_node, emitter_node, mesh_obj=None):
    name = node.props.plugin_name() if node is not None else "mesh"
    emitter = None
    if emitter_node is not None:
        ename = emitter_node.props.plugin_name()
        if ename != "area":
            ctx.bad(emitter_node, f"emitter '{ename}' attached to a shape (only 'area')")
            return None
        _extra(ctx, emitter_node, {"radiance"}, "emitter")
        emitter = _colour(ctx, emitter_node, "radiance", 1.0)
        if emitter is None:
            return None
    mat = _bsdf(ctx, bsdf_node, emitter=emitter)
    if mat is None:
        return None
    # a textured shape keeps what its texture coordinates follow: a sphere's rotation, a
    # rectangle's own axes, a mesh's coordinates
    textured = bool(textures_of(mat))
    if name not in ("ply", "obj", "serialized") and mesh_obj is None and any(
            isinstance(t, rt.MeshAttribute) for t in textures_of(mat)):
        ctx.bad(node, f"a mesh_attribute texture on a '{name}' shape (only meshes have attributes)")
        return None
    flip = bool(node.props["flip_normals"]) if "flip_normals" in node.props.keys() else False
    m = _matrix(ctx, node)
    if name == "sphere":
        _extra(ctx, node, {"center", "radius", "to_world", "flip_normals", "bsdf", "emitter"}, "shape")
        c = np.array(node.props["center"], dtype=np.float64) if "center" in node.props.keys() else np.zeros(3)
        r = _scalar(ctx, node, "radius", 1.0)
        rs = _rigid_scale(m)
        if rs is None or not np.allclose(rs[1], rs[1][0], rtol=1e-5):
            ctx.bad(node, "sphere to_world is not a similarity (rotation, uniform scale, translation)")
            return None
        if textured:
            return rt.Sphere(c, r, mat, flip_normals=flip, transform=tuple(map(tuple, m)))
        return rt.Sphere(m[:3, :3] @ c + m[:3, 3], r * rs[1][0], mat, flip_normals=flip)
    if name == "rectangle":
        _extra(ctx, node, {"to_world", "flip_normals", "bsdf", "emitter"}, "shape")
        lin, t = m[:3, :3], m[:3, 3]
        Q, u, v = t - lin[:, 0] - lin[:, 1], 2 * lin[:, 0], 2 * lin[:, 1]
        det = np.linalg.det(lin)
        if det == 0:
            ctx.bad(node, "rectangle to_world is singular")
            return None
        if det < 0:   # Mitsuba's normal is to_world's inverse transpose of +z: -(u x v) here
            if textured:
                flip = not flip   # the same quad, keeping u and v (its texture coordinates)
            else:
                u, v = v, u
        return rt.Quad(Q, u, v, mat, flip_normals=flip)
    if name == "cube":
        _extra(ctx, node, {"to_world", "flip_normals", "bsdf", "emitter"}, "shape")
        rs = _rigid_scale(m)
        if rs is None:
            ctx.bad(node, "cube to_world has shear or a reflection (only rotation, per-axis scale, translation)")
            return None
        R, s = rs
        tf = np.eye(4)
        tf[:3, :3], tf[:3, 3] = R, m[:3, 3]
        return rt.Box(-s, s, mat, flip_normals=flip, transform=tuple(map(tuple, tf)))
    if name in ("ply", "obj", "serialized") or mesh_obj is not None:
        if mesh_obj is None:
            _extra(ctx, node, {"filename", "to_world", "flip_normals", "bsdf", "emitter", "face_normals",
                               "flip_tex_coords", "shape_index"}, "shape")
            fname = ctx.resolve(str(node.props["filename"]))
            extra = {}
            try:  # before Mitsuba allocates what a header declares: a regular file, counts it can hold
                if name == "serialized":
                    index = _scalar(ctx, node, "shape_index", 0)
                    if isinstance(index, str) or not float(index).is_integer() or index < 0:
                        raise ValueError(f"shape_index must be a whole number >= 0, got {index!r}")
                    extra = {"shape_index": int(index)}
                    check_serialized_file(fname, int(index))
                else:
                    if "shape_index" in node.props.keys():
                        ctx.bad(node, f"{name} parameter 'shape_index' (serialized meshes only)")
                    if "flip_tex_coords" in node.props.keys():
                        extra = {"flip_tex_coords": bool(node.props["flip_tex_coords"])}
                    check_mesh_file(fname)
            except (ValueError, OSError) as exc:
                ctx.bad(node, f"{name} mesh {fname} cannot be used: {exc}")
                return None
            face_normals = bool(node.props["face_normals"]) if "face_normals" in node.props.keys() else False
            if name == "obj" and not face_normals:
                line = _obj_undefined_normal(fname)
                if line is not None:
                    ctx.bad(node, f"obj mesh {fname} line {line}: a face whose first corner has no normal index, in "
                                  "a file with vertex normals (Mitsuba leaves that vertex's normal undefined)")
                    return None
            if name == "obj" and textured:
                line = _obj_undefined_normal(fname, texcoords=True)
                if line is not None:
                    ctx.bad(node, f"obj mesh {fname} line {line}: a face whose first corner has no texture "
                                  "coordinate index, in a file with texture coordinates (Mitsuba leaves that "
                                  "vertex's coordinates undefined)")
                    return None
            try:
                with _one_thread():
                    mesh_obj = ctx.mi.load_dict({"type": name, "filename": fname,
                                                 "to_world": ctx.mi.ScalarTransform4f(m.tolist()),
                                                 "face_normals": face_normals, **extra})
            except Exception as exc:  # Mitsuba raises RuntimeError with the reason
                ctx.bad(node, f"{name} mesh could not be loaded: {exc}")
                return None
        params = ctx.mi.traverse(mesh_obj)
        v = np.array(params["vertex_positions"], dtype=np.float64).reshape(-1, 3)
        f = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
        if len(f) == 0:
            ctx.bad(node, f"{name} mesh {node.props['filename'] if 'filename' in node.props.keys() else ''} "
                          "holds no triangles")
            return None
        normals = _mesh_normals(params, mesh_obj, v, f)
        if isinstance(normals, str):
            source = f" {node.props['filename']}:" if "filename" in node.props.keys() else ""
            ctx.bad(node, f"{name} mesh{source} {normals}")
            return None
        uv = None
        if textured and mesh_obj.has_vertex_texcoords():  # else Mitsuba's: each triangle's barycentrics
            uv = np.array(params["vertex_texcoords"], dtype=np.float64).reshape(-1, 2)
            if uv.shape != (len(v), 2) or not np.all(np.isfinite(uv[np.unique(f)])):
                ctx.bad(node, f"{name} mesh: texture coordinates that are not one finite pair per vertex")
                return None
            uv = np.where(np.isfinite(uv), uv, 0.0)   # vertices of no face: never looked up
        attributes = _mesh_attributes(params, mat)
        if attributes is not None:
            for key, a in list(attributes.items()):
                rows = len(v) if key.startswith("vertex_") else len(f)
                if a.size % rows:
                    ctx.bad(node, f"{name} mesh: attribute {key!r} of {a.size} values for {rows} rows")
                    return None
                attributes[key] = a.reshape(rows, -1)
        try:
            mesh = rt.Mesh(v, f, mat, flip_normals=flip, normals=normals, uv=uv, attributes=attributes)
            for t in textures_of(mat):
                if isinstance(t, rt.MeshAttribute):
                    t.values(mesh)
        except ValueError as exc:
            ctx.bad(node, f"{name} mesh: {exc}")
            return None
        return mesh
    ctx.bad(node, f"shape '{name}'")
    return None


def _obj_undefined_normal(fname, *, texcoords: bool = False):
    """:func:`reference_tracer.meshfile.obj_undefined_normal` of an OBJ file (None if unreadable:
    Mitsuba's loader then says why); of its texture coordinates with ``texcoords``."""
    try:
        return obj_undefined_normal(decode_obj(Path(fname).read_bytes()), texcoords=texcoords)
    except (OSError, ValueError):
        return None


@contextlib.contextmanager
def _one_thread():
    """Dr.Jit on one thread for the block: Mitsuba computes a mesh's missing vertex normals
    with a parallel scatter-add, whose order of float32 additions (so the last bits of the
    normals, and the scene's content hash) varies from run to run on several threads."""
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)

    threads = dr.thread_count()
    dr.set_thread_count(1)
    try:
        yield
    finally:
        dr.set_thread_count(threads)


def _mesh_normals(params, mesh, v, f):
    """The vertex normals Mitsuba shades ``mesh`` with (world space, as its loader stored
    them: the file's, or computed), None where it shades flat, or a sentence saying why
    they cannot be used.

    Flat also where every vertex normal equals its triangle's own normal (a quad of two
    coplanar triangles, a box stored with a vertex per face corner): Mitsuba's shading is
    then the flat one (to 1e-5), and the mesh keeps the flat fast path. A normal that is
    not a unit vector is refused: Mitsuba normalises every normal it reads or computes, so
    another value is one it left undefined (an OBJ face corner without a normal index in a
    file with normals) or a zero or non-number normal of a PLY file (Mitsuba's shading
    there is NaN)."""
    if not mesh.has_vertex_normals():
        return None
    n = np.array(params["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    if n.shape != v.shape:
        return f"has {len(n)} vertex normals for {len(v)} vertices"
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    length = np.linalg.norm(n, axis=1)
    bad = used & ~(np.abs(length - 1.0) <= 1e-3)
    if bad.any():
        i = int(np.argmax(bad))
        return (f"vertex normal {i} is {n[i].tolist()}, not a unit vector: undefined in Mitsuba (a zero or "
                "non-number normal in the file, or an OBJ face corner without a normal index in a file "
                "with normals)")
    if _normals_are_flat(params, v, f):
        return None
    n[~used] = (1.0, 0.0, 0.0)   # vertices of no face: never shaded
    return n


def _normals_are_flat(params, v, f, *, tol: float = 1e-5) -> bool:
    """Whether every vertex normal of every triangle is that triangle's own normal: Mitsuba then
    shades the mesh exactly as a flat one (a quad of two coplanar triangles, a box stored with
    a vertex per face corner), and the vertex normals change nothing."""
    n = np.array(params["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    if len(f) == 0 or n.shape != v.shape:
        return False
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(e, axis=1, keepdims=True)
    ok = length[:, 0] > 0
    fn = np.where(length > 0, e / np.where(length > 0, length, 1.0), 0.0)
    for j in range(3):
        vn = n[f[:, j]]
        vn = vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
        if np.any(np.abs(vn[ok] - fn[ok]) > tol):
            return False
    return True


# --------------------------------------------------------------------------- sensor
def _vfov(ctx, node, fov, axis, width, height):
    t = math.tan(math.radians(fov) / 2)
    aspect = width / height
    if axis == "y":
        return fov
    if axis == "x":
        ty = t / aspect
    elif axis == "smaller":
        ty = t if height <= width else t / aspect
    elif axis == "larger":
        ty = t if height >= width else t / aspect
    elif axis == "diagonal":
        ty = t * height / math.hypot(width, height)
    else:
        ctx.bad(node, f"perspective fov_axis='{axis}'")
        return None
    return math.degrees(2 * math.atan(ty))


def _focal_length_fov(ctx, sensor):
    """The diagonal field of view of a sensor without ``fov``, as Mitsuba's ``parse_fov``
    derives it: from ``focal_length`` ("<x>mm", default 50mm) on a 36 x 24 mm film."""
    p = sensor.props
    text = "50mm"
    if "focal_length" in p.keys():
        if p.type("focal_length") != ctx.mi.Properties.Type.String:
            ctx.bad(sensor, f"perspective focal_length of type {p.type('focal_length')} (a string such as '50mm')")
            return None
        text = str(p["focal_length"])
    try:
        value = float(text[:-2] if text.endswith("mm") else text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        ctx.bad(sensor, f"perspective focal_length={text!r} (a positive length in mm)")
        return None
    return math.degrees(2.0 * math.atan(math.hypot(36.0, 24.0) / (2.0 * value)))


def _camera(ctx, sensor):
    if sensor is None:
        ctx.problems.append("no sensor (a perspective, thinlens or orthographic sensor is required)")
        return None
    kind = sensor.props.plugin_name()
    if kind not in _SENSORS:
        ctx.bad(sensor, f"sensor '{kind}' (only {', '.join(repr(k) for k in _SENSORS)})")
        return None
    _extra(ctx, sensor, _SENSORS[kind], "sensor")
    OT = ctx.mi.ObjectType
    film, sampler = ctx.child(sensor, OT.Film), ctx.child(sensor, OT.Sampler)
    width = height = 768 if film is None else None
    rfilter = rt.Filter("gaussian")  # Mitsuba's default film's filter
    if film is None:
        width, height = 768, 576
    else:
        if film.props.plugin_name() != "hdrfilm":
            ctx.bad(film, f"film '{film.props.plugin_name()}' (only 'hdrfilm')")
        _extra(ctx, film, _FILM_OK, "film")
        width, height = _film_size(ctx, film, "width", 768), _film_size(ctx, film, "height", 576)
        rfilter = _rfilter(ctx, ctx.child(film, OT.ReconstructionFilter))
        if "sample_border" in film.props.keys() and bool(film.props["sample_border"]):
            ctx.bad(film, "hdrfilm sample_border=true")
    if ctx.film_size is not None:
        width, height = ctx.film_size
    if sampler is not None:
        _sampler(ctx, sampler)
    if kind == "orthographic":  # (its own problems are reported even where the rfilter's are)
        camera = _orthographic(ctx, sensor, width, height, rfilter or rt.Filter())
        return camera if rfilter is not None else None
    if "x_fov" in sensor.props.keys():
        fov, axis = _scalar(ctx, sensor, "x_fov", 39.3077), "x"
    elif "fov" in sensor.props.keys():
        fov, axis = _scalar(ctx, sensor, "fov", 39.3077), _scalar(ctx, sensor, "fov_axis", "x")
    else:
        fov, axis = _focal_length_fov(ctx, sensor), "diagonal"
        if fov is None:
            return None
    vfov = _vfov(ctx, sensor, float(fov), axis, width, height)
    m = _matrix(ctx, sensor)
    lin = m[:3, :3]
    left, up, fwd = lin[:, 0], lin[:, 1], lin[:, 2]
    if not np.allclose(lin.T @ lin, np.eye(3), atol=1e-4) or not np.allclose(np.cross(up, fwd), left, atol=1e-4):
        ctx.bad(sensor, "sensor to_world is not a rigid look_at frame (scale, shear or a mirrored image)")
        return None
    if vfov is None:
        return None
    origin = m[:3, 3]
    if rfilter is None:
        return None
    # Mitsuba's perspective and thinlens sensors start rays on their near plane and end them
    # at the far one: ours the same (from_mitsuba then drops the planes that clip nothing).
    clip = _clip_planes(ctx, sensor)
    if clip is None:
        return None
    lens = dict(near_clip=clip[0], far_clip=clip[1])
    if kind == "thinlens":
        if "aperture_radius" not in sensor.props.keys():
            ctx.bad(sensor, "thinlens without aperture_radius (Mitsuba requires it)")
            return None
        radius = _scalar(ctx, sensor, "aperture_radius", 0.0)
        focus = _scalar(ctx, sensor, "focus_distance", clip[1])
        if isinstance(radius, str) or isinstance(focus, str) or not radius >= 0 or not focus > 0:
            ctx.bad(sensor, f"thinlens aperture_radius {radius!r} / focus_distance {focus!r} (need >= 0 and > 0)")
            return None
        # Mitsuba widens a zero aperture to float epsilon: a pinhole to within 1e-7.
        if radius > 0:
            lens.update(aperture_radius=float(radius), focus_distance=float(focus))
    return rt.Camera(lookfrom=origin, lookat=origin + fwd, vup=up, vfov=vfov, width=width, height=height,
                     filter=rfilter, **lens)


def _clip_planes(ctx, sensor):
    """(near_clip, far_clip) of a projective camera, Mitsuba's defaults where not given; None if bad."""
    near = _scalar(ctx, sensor, "near_clip", _NEAR_CLIP)
    far = _scalar(ctx, sensor, "far_clip", _FAR_CLIP)
    if isinstance(near, str) or isinstance(far, str) or not 0 < near < far or not math.isfinite(far):
        ctx.bad(sensor, f"sensor near_clip {near!r} / far_clip {far!r} (need 0 < near_clip < far_clip, finite)")
        return None
    return float(near), float(far)


def _orthographic(ctx, sensor, width, height, rfilter):
    """Mitsuba's orthographic sensor: to_world = look_at . scale(sx, sy, sz) (any rotation).

    In camera space the view is [-1, 1] x [-1/aspect, 1/aspect] (orthographic_projection in
    transform.h, aspect = width / height), scaled by to_world: a view 2 sx wide and
    2 sy / aspect high. A ray starts at camera z = near_clip, that is near_clip * sz along the
    view direction in world space, and reaches far_clip - near_clip beyond it.
    """
    clip = _clip_planes(ctx, sensor)
    m = _matrix(ctx, sensor)
    rs = _rigid_scale(m)
    if rs is None or clip is None:
        if rs is None:
            ctx.bad(sensor, "orthographic to_world is not a rotation and scale along the camera's axes (shear or "
                            "a mirrored image)")
        return None
    R, (sx, sy, sz) = rs
    up, fwd = R[:, 1], R[:, 2]
    origin = m[:3, 3]
    near, far = clip
    aspect = width / height
    view_w, view_h = 2.0 * sx, 2.0 * sy / aspect
    # square pixels (equal x and y scales, to float precision) leave view_width to the aspect
    square = abs(sx - sy) <= 1e-6 * max(sx, sy)
    return rt.Camera(lookfrom=origin, lookat=origin + fwd, vup=up, width=width, height=height, filter=rfilter,
                     projection="orthographic", view_height=view_h, view_width=None if square else view_w,
                     near_clip=near * sz, far_clip=near * sz + (far - near))


# Mitsuba's randomised samplers: each places a pixel's samples differently (strata, jittered
# grids, scrambled low-discrepancy points) but every sample is uniform over the pixel, so
# the expected image is the independent sampler's; only the noise differs. Our tracer
# samples independently. A sampler whose jitter is off puts samples at cell centres: a
# different (biased) image, refused.
_RANDOMISED_SAMPLERS = {
    "independent": set(),
    "stratified": {"jitter"},
    "multijitter": {"jitter"},
    "orthogonal": {"jitter", "strength"},
    "ldsampler": set(),
    "sobol": set(),
    "pmj02": set(),
}


def _sampler(ctx, node):
    """Check a sampler: one of Mitsuba's randomised samplers, read as ``independent``."""
    name = node.props.plugin_name()
    if name not in _RANDOMISED_SAMPLERS:
        ctx.bad(node, f"sampler '{name}' (only Mitsuba's randomised samplers: "
                      f"{', '.join(sorted(_RANDOMISED_SAMPLERS))})")
        return
    _extra(ctx, node, _RANDOMISED_SAMPLERS[name] | {"sample_count", "seed"}, "sampler")
    if "jitter" in node.props.keys() and not bool(node.props["jitter"]):
        ctx.bad(node, f"sampler '{name}' with jitter=false (samples at cell centres: not the independent "
                      "sampler's expected image)")


def _rfilter(ctx, node):
    """Our :class:`reference_tracer.Filter` of a film's rfilter (Mitsuba's default: gaussian), or None."""
    if node is None:
        return rt.Filter("gaussian")
    name = node.props.plugin_name()
    if name == "box":
        _extra(ctx, node, set(), "rfilter")
        return rt.Filter("box")
    if name == "tent":
        _extra(ctx, node, {"radius"}, "rfilter")
        return rt.Filter("tent", radius=float(_scalar(ctx, node, "radius", 1.0)))
    if name == "gaussian":
        _extra(ctx, node, {"stddev"}, "rfilter")
        return rt.Filter("gaussian", stddev=float(_scalar(ctx, node, "stddev", 0.5)))
    ctx.bad(node, f"rfilter '{name}' (box, tent and gaussian are supported)")
    return None


# --------------------------------------------------------------------------- entry point
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
    params : dict, optional
        XML only: values of the file's ``$name`` parameters (overriding its
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
        A file that is missing or malformed, or an unknown ``$name``.

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
    mi = import_mitsuba()
    cfg = mi.parser.ParserConfig(mi.variant())
    params = {str(k): str(v) for k, v in (params or {}).items()}
    if film_size is not None:
        film_size = _checked_film_size(film_size)
    if isinstance(source, dict):
        if params:
            raise ValueError("from_mitsuba: params apply to XML files only")
        if source.get("type") != "scene":
            raise ValueError(f"from_mitsuba needs a scene dict (type 'scene'), got type {source.get('type')!r}")
        with _as_value_error("from_mitsuba"):
            state = mi.parser.parse_dict(cfg, source)
    elif isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if not path.is_file():
            raise ValueError(f"from_mitsuba: no such file {path}")
        check_xml_depth(path)
        with _as_value_error(f"from_mitsuba: {path}"):  # a malformed file or an unknown $name
            state, search = _parse_with_search_paths(mi, lambda: mi.parser.parse_file(cfg, str(path), **params))
    else:
        raise ValueError(f"from_mitsuba takes a dict or an XML path, got {type(source).__name__}")
    with _as_value_error("from_mitsuba"):
        mi.parser.transform_upgrade(cfg, state)
        mi.parser.transform_resolve(cfg, state)
    ctx = _Ctx(mi, state)
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
                shape = _mesh_object(ctx, root, key, obj)
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
            shape = _shape(ctx, node, ctx.child(node, OT.BSDF), ctx.child(node, OT.Emitter))
            if shape is not None:
                shapes.append(shape)
        elif kind == OT.Emitter:
            if name in ("constant", "envmap"):
                environments.append(node)
            if name == "constant":
                _extra(ctx, node, {"radiance"} | _EMITTER_ANY, "emitter")
                c = _colour(ctx, node, "radiance", 1.0)
                if c is not None:
                    background = background + np.asarray(c)
            elif name != "area":  # an area emitter declared here is used by reference: checked on its shape
                light = _light(ctx, node)
                if light is not None:
                    lights.append(light)
        elif kind in (OT.BSDF, OT.Texture):
            continue   # declared here, used through references; checked where used
        elif kind == OT.Sampler:  # declared here for a sensor to reference: the same rule as inside one
            _sampler(ctx, node)
        else:
            ctx.bad(node, f"{str(kind).split('.')[-1].lower()} '{name}'")

    if len(environments) > 1:
        ctx.bad(environments[1], f"a second environment emitter ({environments[1].props.plugin_name()} after "
                                 f"{environments[0].props.plugin_name()}; Mitsuba allows one)")
    camera = _camera(ctx, sensor)
    max_depth, rr_depth, direct = -1, 5, None
    if integrator is not None and integrator.props.plugin_name() == "moment":
        # `moment` adds the second moment of the wrapped integrator's samples as extra
        # channels; the image (the mean) is the wrapped integrator's own
        inner = [c for c in ctx.children(integrator) if c.type == OT.Integrator]
        if len(inner) != 1:
            ctx.bad(integrator, f"integrator 'moment' wrapping {len(inner)} integrators (one is Mitsuba's use)")
            integrator = None
        else:
            integrator = inner[0]
    if integrator is not None:
        iname = integrator.props.plugin_name()
        if iname not in ("path", "direct"):
            ctx.bad(integrator, f"integrator '{iname}' (only 'path' and 'direct')")
        elif "hide_emitters" in integrator.props.keys() and bool(integrator.props["hide_emitters"]):
            ctx.bad(integrator, f"{iname} hide_emitters=true")
        if iname == "path":
            _extra(ctx, integrator, {"max_depth", "rr_depth", "hide_emitters"}, "integrator")
            max_depth = int(_scalar(ctx, integrator, "max_depth", -1))
            rr_depth = int(_scalar(ctx, integrator, "rr_depth", 5))
        elif iname == "direct":
            direct = _direct(ctx, integrator)
    if ctx.problems:
        raise UnsupportedSceneError(ctx.problems, [ctx.features.get(p, p) for p in ctx.problems])
    if max_depth != -1 and rr_depth > max_depth:
        rr = None
    elif max_depth == -1 and rr_depth >= rt.MAX_DEPTH_CAP:
        rr = None
    else:
        rr = rr_depth
    return rt.Scene(camera=_without_idle_clip_planes(camera, shapes), shapes=shapes, max_depth=max_depth,
                    rr_depth=rr, background=tuple(background), direct=direct, lights=lights)


#: relative room left for Mitsuba's float32 ray arithmetic when a clip plane is judged idle.
_CLIP_ROOM = 1e-3


def _without_idle_clip_planes(camera, shapes):
    """A pinhole ``camera`` without those of its clip planes that clip nothing of ``shapes``.

    Mitsuba's perspective sensor always has clip planes (0.01 and 10^4 unless the file says
    otherwise), while a pinhole without them is the core's fast path (``Camera::plain``: rays
    from the eye, unbounded). A camera ray starts on the near plane, at most
    ``near_clip * sqrt(1 + tx^2 + ty^2)`` from the eye (the corners of the view on that plane;
    tx, ty the tangents of the half fields of view): where no surface comes that near, the
    plane hides nothing. A hit beyond the far plane lies more than ``far_clip`` from the eye:
    where every surface is nearer, the plane cuts nothing. A plane that clips nothing is
    dropped (the same image, and the content hash of a camera without it); one that may clip
    is kept. A thin lens and an orthographic camera keep theirs: neither is the plain pinhole.
    """
    if camera.is_thin_lens or camera.is_orthographic:
        return camera
    eye = np.asarray(camera.lookfrom)
    ty = math.tan(math.radians(camera.vfov) / 2.0)
    tx = ty * camera.aspect
    corner = camera.near_clip * math.sqrt(1.0 + tx * tx + ty * ty)
    near = camera.near_clip if surface_within(shapes, eye, corner * (1.0 + _CLIP_ROOM)) else 0.0
    far = camera.far_clip if farthest_distance(shapes, eye) * (1.0 + _CLIP_ROOM) >= camera.far_clip else math.inf
    return dataclasses.replace(camera, near_clip=near, far_clip=far)


def _checked_film_size(size) -> tuple:
    """``(width, height)`` as two whole numbers >= 1, else ``ValueError``."""
    try:
        w, h = size
    except (TypeError, ValueError):
        raise ValueError(f"film_size must be (width, height), got {size!r}") from None
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 2**31 - 1:
            raise ValueError(f"film_size must be two whole numbers >= 1, got {size!r}")
    return int(w), int(h)


def _direct(ctx, node):
    """Mitsuba's ``direct``: ``shading_samples`` (default 1) sets both counts, which
    ``emitter_samples`` and ``bsdf_samples`` override."""
    _extra(ctx, node, {"shading_samples", "emitter_samples", "bsdf_samples", "hide_emitters"}, "integrator")
    shading = _scalar(ctx, node, "shading_samples", 1)
    counts = [_scalar(ctx, node, name, shading) for name in ("emitter_samples", "bsdf_samples")]
    if any(isinstance(c, str) or not float(c).is_integer() for c in counts):
        ctx.bad(node, f"direct sample counts must be whole numbers, got {counts}")
        return None
    try:
        return rt.Direct(*(int(c) for c in counts))
    except ValueError as e:
        ctx.bad(node, f"direct: {e}")
        return None


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


def _mesh_object(ctx, root, key, mesh):
    """A ``mi.Mesh`` given as an object in the dict (as :func:`to_mitsuba` makes them)."""
    where = f'dictionary node "{key}"'
    params = ctx.mi.traverse(mesh)
    keys = set(params.keys())
    bsdf = mesh.bsdf()
    cls = type(bsdf).__name__ if bsdf is not None else None
    refl = [k for k in keys if k.startswith("bsdf.") and k.endswith("reflectance.value")]
    if bsdf is None or refl != ["bsdf.reflectance.value"] or any(
            k.startswith("bsdf.") and k != "bsdf.reflectance.value" for k in keys):
        ctx.problems.append(f"mesh object whose BSDF is not a plain diffuse ({cls}); write the scene "
                            f"with to_xml and import the XML instead ({where})")
        return None
    albedo = tuple(float(x) for x in np.array(params["bsdf.reflectance.value"]).ravel()[:3])
    if len(albedo) == 1:
        albedo = albedo * 3
    em = mesh.emitter()
    if em is not None:
        rad = [k for k in keys if k.startswith("emitter.")]
        if rad != ["emitter.radiance.value"]:
            ctx.problems.append(f"mesh object with an emitter other than a constant area light ({where})")
            return None
        L = tuple(float(x) for x in np.array(params["emitter.radiance.value"]).ravel()[:3])
        mat = rt.DiffuseLight(L * (3 if len(L) == 1 else 1), albedo=None if max(albedo) == 0 else albedo)
    else:
        mat = rt.Lambertian(albedo)
    v = np.array(params["vertex_positions"], dtype=np.float64).reshape(-1, 3)
    f = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
    normals = _mesh_normals(params, mesh, v, f)
    if isinstance(normals, str):
        ctx.problems.append(f"mesh object whose {normals} ({where})")
        return None
    flip = bool(mesh.has_flipped_normals())
    return rt.Mesh(v, f, mat, flip_normals=flip, normals=normals)
