"""Colours and textures of the importer: constant, ``checkerboard``, ``bitmap`` and
``mesh_attribute`` values, and where each may be used.
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt
from reference_tracer.material_textures import textures_of

from .values import check_params, located, read_bool, read_matrix, read_scalar, read_spectrum


def read_colour(ctx, node, key, default):
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
        return read_spectrum(ctx, node, key)
    if t == T.ResolvedReference:
        sub = ctx.node(p[key])
        if sub.props.plugin_name() in ("rgb", "srgb") and "value" in sub.props.keys():
            return read_colour(ctx, sub, "value", 0.0)
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


def read_reflectance(ctx, node, key, default):
    """A reflectance that may be textured: an RGB triple (:func:`read_colour`), a texture
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
    return read_colour(ctx, node, key, default)


def _to_uv(ctx, node):
    """A texture's ``to_uv`` (Mitsuba keeps rows and columns 0, 1 and the translation of
    the 4x4 matrix) as the 4x4 matrix, or None."""
    return read_matrix(ctx, node, "to_uv") if "to_uv" in node.props.keys() else None


@located
def _mesh_attribute(ctx, node):
    """Mitsuba's ``mesh_attribute`` (its ``name`` and ``scale``); the values are the mesh's,
    read where the shape is (:func:`mesh_attributes`). None after recording a problem."""
    check_params(ctx, node, {"name", "scale"}, "texture")
    if "name" not in node.props.keys():
        ctx.bad(node, "mesh_attribute without a name")
        return None
    scale = read_scalar(ctx, node, "scale", 1.0)
    try:
        return rt.MeshAttribute(str(node.props["name"]), float(scale))
    except TypeError as exc:   # (a ValueError is placed at the node by located)
        ctx.bad(node, f"mesh_attribute: {exc}")
        return None


#: the buffers of Mitsuba's mesh that are its geometry, not attributes.
_MESH_BUFFERS = {"vertex_positions", "vertex_normals", "vertex_texcoords", "faces"}


def mesh_attributes(params, mat) -> dict | None:
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


@located
def _checkerboard(ctx, node):
    check_params(ctx, node, {"color0", "color1", "to_uv"}, "texture")
    c0, c1 = read_colour(ctx, node, "color0", 0.4), read_colour(ctx, node, "color1", 0.2)
    if c0 is None or c1 is None:
        return None
    return rt.Checkerboard(c0, c1, to_uv=_to_uv(ctx, node))


@located
def _bitmap(ctx, node):
    """Mitsuba's ``bitmap`` from its file (read by :func:`reference_tracer.image_files.read_image`,
    which checks the file and its header first), or None after recording a problem."""
    check_params(ctx, node, {"filename", "filter_type", "wrap_mode", "raw", "to_uv", "format", "accel"}, "texture")
    p = node.props
    if "filename" not in p.keys():
        ctx.bad(node, "bitmap without a filename (only bitmaps read from files)")
        return None
    fmt = read_scalar(ctx, node, "format", "auto")
    if fmt != "auto":
        ctx.bad(node, f"bitmap format='{fmt}' (only 'auto': the file's own precision)")
        return None
    raw = read_bool(ctx, node, "raw", False)
    if raw is None:
        return None
    fname = ctx.confined(str(p["filename"]))
    if fname is None:
        ctx.bad(node, f"bitmap {p['filename']!r} lies outside the scene's folder and its <path> folders (an image "
                      "a scene reads must be part of it)")
        return None
    try:
        return rt.Bitmap(fname, filter=read_scalar(ctx, node, "filter_type", "bilinear"),
                         wrap=read_scalar(ctx, node, "wrap_mode", "repeat"), raw=raw, to_uv=_to_uv(ctx, node))
    except (ValueError, OSError) as exc:
        ctx.bad(node, f"bitmap {fname} cannot be used: {exc}")
        return None
