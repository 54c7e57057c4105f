""":func:`to_mitsuba`: the records as a ``mi.load_dict`` dictionary."""
from __future__ import annotations

import numpy as np

import reference_tracer as rt

from ..variants import import_mitsuba
from .records import lower, sensor_params


def _transform(mi, m: np.ndarray):
    return mi.ScalarTransform4f(np.asarray(m, dtype=np.float64).tolist())


def mitsuba_values(mi, rec):
    """A record in Mitsuba's dict syntax with its plain values made Mitsuba's: a ``to_uv``
    matrix a transform, a bitmap's ``data`` array an ``mi.Bitmap`` (float32: linear)."""
    if not isinstance(rec, dict):
        return rec
    out = {}
    for key, val in rec.items():
        if key == "to_uv":
            out[key] = _transform(mi, val)
        elif key == "data" and rec.get("type") == "bitmap":
            out["bitmap"] = mi.Bitmap(np.array(val, dtype=np.float32, order="C"))  # a writable copy
        else:
            out[key] = mitsuba_values(mi, val)
    return out


def _make_mesh(mi, rec: dict):
    """An ``mi.Mesh`` carrying its BSDF and emitter; with vertex normals where the record
    has them (smooth shading), else none (flat); with its texture coordinates where it has
    them."""
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(mitsuba_values(mi, rec["bsdf"]))
    if "emitter" in rec:
        props["emitter"] = mi.load_dict({"type": "area", "radiance": {"type": "rgb", "value": rec["emitter"]}})
    if rec.get("flip_normals"):
        props["flip_normals"] = True
    vertices, faces, normals, uv = rec["vertices"], rec["faces"], rec.get("normals"), rec.get("uv")
    mesh = mi.Mesh(rec["name"], vertex_count=len(vertices), face_count=len(faces), props=props,
                   has_vertex_normals=normals is not None, has_vertex_texcoords=uv is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = type(params["vertex_positions"])(
        np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = type(params["faces"])(np.ascontiguousarray(faces, dtype=np.uint32).ravel())
    if normals is not None:  # given with the positions: the update keeps them (no recomputation)
        params["vertex_normals"] = type(params["vertex_normals"])(
            np.ascontiguousarray(normals, dtype=np.float32).ravel())
    if uv is not None:
        texcoords = np.ascontiguousarray(uv, dtype=np.float32).ravel()
        params["vertex_texcoords"] = type(params["vertex_texcoords"])(texcoords)
    params.update()
    for name, values in rec.get("attributes", {}).items():
        mesh.add_attribute(name, values.shape[1], np.ascontiguousarray(values, dtype=np.float32).ravel().tolist())
    return mesh


def to_mitsuba(scene: rt.Scene, *, variant: str | None = None) -> dict:
    """Translate ``scene`` into a dict for ``mi.load_dict``.

    Triangles and meshes become ``mi.Mesh`` objects, which belong to the active
    Mitsuba variant: the dict must be loaded under the same variant (a variant is
    selected with :func:`mitsuba_scenes.variants.import_mitsuba` if none is set, or
    ``variant`` is activated).

    Parameters
    ----------
    scene : reference_tracer.Scene
    variant : str or None, keyword-only
        Mitsuba variant to activate first; None keeps the active one.

    Returns
    -------
    dict

    Raises
    ------
    ValueError
        For anything without an exact Mitsuba equivalent (e.g. ``Metal`` with
        ``fuzz > 0``), listing every offending object.

    Examples
    --------
    >>> import mitsuba as mi
    >>> from mitsuba_scenes import get_scene, to_mitsuba
    >>> d = to_mitsuba(get_scene("cornell_box", width=16, height=16), variant="scalar_rgb")
    >>> d["sensor"]["fov_axis"], d["sensor"]["film"]["rfilter"]["type"]
    ('y', 'box')
    >>> scene = mi.load_dict(d)
    """
    low = lower(scene)
    mi = import_mitsuba(variant)
    cam, integ = low["camera"], low["integrator"]
    d = {
        "type": "scene",
        "integrator": dict(integ),
        "sensor": {
            "type": cam["type"], **sensor_params(cam),
            "to_world": _transform(mi, cam["to_world"]),
            "sampler": {"type": "independent", "sample_count": 4},
            "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"],
                     "rfilter": dict(cam["rfilter"]), "pixel_format": "rgb", "component_format": "float32",
                     "sample_border": False},
        },
    }
    if low["background"] is not None:
        d["background"] = {"type": "constant", "radiance": {"type": "rgb", "value": low["background"]}}
    for i, rec in enumerate(low["lights"]):
        entry = dict(rec)
        if rec["type"] == "envmap":
            entry["bitmap"] = mi.Bitmap(np.array(entry.pop("pixels"), dtype=np.float32, order="C"))  # a writable copy
        for key in ("texture", "irradiance"):   # a textured spot's, a projector's
            if isinstance(entry.get(key), dict) and entry[key]["type"] != "rgb":
                entry[key] = mitsuba_values(mi, entry[key])
        if "to_world" in entry:
            entry["to_world"] = _transform(mi, entry["to_world"])
        d[f"light_{i:03d}_{rec['type']}"] = entry
    for rec in low["shapes"]:
        name = rec["name"]
        if rec["type"] == "mesh":
            d[name] = _make_mesh(mi, rec)
            continue
        entry = {"type": rec["type"], "bsdf": mitsuba_values(mi, rec["bsdf"])}
        if "center" in rec:
            entry.update(center=rec["center"], radius=rec["radius"])
        else:
            entry["to_world"] = _transform(mi, rec["to_world"])
        if rec["flip_normals"]:
            entry["flip_normals"] = True
        if "emitter" in rec:
            entry["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": rec["emitter"]}}
        d[name] = entry
    return d
