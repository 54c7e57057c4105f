"""PLY files as Mitsuba's ``ply`` plugin reads them, parsed by trimesh (:func:`parse_ply`, no
processing: the file's vertex order kept): vertex normals from ``nx ny nz``, texture
coordinates from ``u v`` (or ``texture_u texture_v``, ``s t``), and the other vertex and face
properties grouped into mesh attributes as Mitsuba groups them (:func:`ply_attributes`).
"""
from __future__ import annotations

import io

import numpy as np

from ..image_files import srgb_to_linear
from ..validation import not_directions
from .data import MeshData

__all__ = ["parse_ply", "ply_attributes"]


def parse_ply(data: bytes, *, name: str = "PLY", normals: bool = True) -> MeshData:
    """The vertices, faces, (with ``normals``) vertex normals, texture coordinates and
    attributes of a PLY file's bytes, through trimesh (no processing: vertex order kept).

    Raises ``ValueError`` naming the file (``name``) for trimesh's own errors, a bad normal,
    and normals or texture coordinates that are not one per vertex.
    """
    import trimesh  # deferred: trimesh takes about 1.5 s to import

    try:
        tm = trimesh.load(io.BytesIO(data), file_type="ply", process=False, force="mesh")
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types; name the file in all cases
        raise ValueError(f"{name} is not an OBJ or PLY mesh trimesh can read: {type(exc).__name__}: {exc}") from exc
    vertices = np.asarray(tm.vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(tm.faces, dtype=np.int64).reshape(-1, 3)
    n = _ply_normals(tm, faces, name) if normals else None
    if n is not None and n.shape != vertices.shape:  # trimesh changed the vertices: not the file's
        raise ValueError(f"{name}: {len(n)} vertex normals for {len(vertices)} vertices")
    uv = _ply_texcoords(tm)
    if uv is not None and len(uv) != len(vertices):
        raise ValueError(f"{name}: {len(uv)} texture coordinates for {len(vertices)} vertices")
    attributes = ply_attributes(tm, len(vertices), len(faces), name=name)
    return MeshData(vertices, faces, n, uv, attributes)


def _ply_normals(tm, faces: np.ndarray, name: str) -> np.ndarray | None:
    """The ``nx ny nz`` vertex properties trimesh read from a PLY (None unless all three).
    A normal that is zero or not finite is refused where a face uses its vertex (Mitsuba's
    shading would be NaN there), and replaced by (1, 0, 0) elsewhere (never shaded)."""
    raw = (tm.metadata or {}).get("_ply_raw", {}).get("vertex", {})
    data = raw.get("data")
    try:
        columns = [np.asarray(data[k], dtype=np.float64).reshape(-1) for k in ("nx", "ny", "nz")]
    except (KeyError, ValueError, TypeError, IndexError):
        return None
    n = np.stack(columns, axis=1)
    bad = not_directions(n)
    if bad.any():
        used = np.zeros(len(n), dtype=bool)
        used[faces[(faces >= 0) & (faces < len(n))]] = True
        if (bad & used).any():
            i = int(np.argmax(bad & used))
            raise ValueError(f"{name}: vertex normal {i} is {n[i].tolist()}: zero or not finite")
        n[bad] = (1.0, 0.0, 0.0)
    return n


#: Mitsuba's attribute postfixes (src/shapes/ply.h, find_other_fields): column j is a
#: category (x y z w, r g b a, 0 1 2 3, 1 2 3 4), row k an attribute's k-th channel.
_POSTFIXES = ("xr01", "yg12", "zb23", "wa34")
#: the properties of each element that are not attributes (Mitsuba's reserved names).
_RESERVED = {"vertex": {"x", "y", "z", "nx", "ny", "nz", "u", "v"}, "face": set()}


def _ply_property_values(column: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """A PLY property's values as Mitsuba 3.9.1's struct converter gives them (measured):
    floating point as it is; ``uchar`` (``uint8``) as the integer it is (not divided by
    255); every other integer type divided by its type's largest value and decoded from
    sRGB (the ``Normalized | Gamma`` flags its header parser gives integer fields)."""
    if dtype.kind == "f":
        return column.astype(np.float64)
    if dtype == np.uint8:
        return column.astype(np.float64)
    return srgb_to_linear(column.astype(np.float64) / float(np.iinfo(dtype).max)).astype(np.float64)


def _ply_element_attributes(kind: str, properties: list, data, rows: int, name: str) -> dict:
    """One element's attributes, grouped as Mitsuba's ``find_other_fields`` groups them."""
    names = [p for p, _ in properties]
    rename = {}
    if not {"r", "g", "b"} <= set(names) and {"red", "green", "blue"} <= set(names):
        rename = {"red": "r", "green": "g", "blue": "b", "alpha": "a"}
    fields = [(rename.get(p, p), p, t) for p, t in properties]
    by_name = {f: (p, t) for f, p, t in fields}
    groups = []  # (attribute name, [source property, ...])
    if {"r", "g", "b"} <= set(by_name):
        groups.append((kind + "_color", [by_name[c][0] for c in ("r", "g", "b", "a") if c in by_name]))
    reserved = _RESERVED[kind] | {"r", "g", "b", "a"}
    encountered: set = set()
    prefix, column, level, reading = "", 0, 0, False

    def flush():
        nonlocal prefix, column, level, reading
        if level in (1, 3):
            fields_of = [by_name[f"{prefix}_{_POSTFIXES[k][column]}"][0] for k in range(level)]
            groups.append((f"{kind}_{prefix}{'_color' if column == 1 else ''}", fields_of))
            encountered.add(prefix)
        prefix, column, level, reading = "", 0, 0, False

    i = 0
    while i < len(fields):
        f = fields[i][0]
        if f in reserved:
            i += 1
            continue
        pos = f.rfind("_")
        if pos < 0 or len(f) - pos - 1 != 1:
            if reading:
                flush()
            i += 1
            continue
        pre, post = f[:pos], f[pos + 1]
        if reading and pre != prefix:
            flush()
        if not reading and pre in encountered:
            # Mitsuba skips the fields starting with the prefix, then one more
            while i < len(fields) and fields[i][0].startswith(pre):
                i += 1
            i += 1
            continue
        if not reading:
            if post not in _POSTFIXES[0]:
                i += 1
                continue
            reading, column, prefix = True, _POSTFIXES[0].index(post), pre
        elif level >= 4 or post != _POSTFIXES[level][column]:
            prefix, column, level, reading = "", 0, 0, False
            while i < len(fields) and fields[i][0].startswith(pre):
                i += 1
            if i >= len(fields):
                break
            f = fields[i][0]
        level += 1
        i += 1
    if reading:
        flush()
    out = {}
    for attr, props in groups:
        columns = []
        for p in props:
            dtype = np.dtype(dict(properties)[p])
            column = np.asarray(data[p])
            if column.shape == (rows, 1):  # trimesh reads an ASCII file's scalar property as a column
                column = column[:, 0]
            if column.shape != (rows,):
                raise ValueError(f"{name}: PLY property {kind} {p!r} holds {column.shape} values for {rows} "
                                 f"{kind}s: a mesh attribute needs one number per {kind}")
            columns.append(_ply_property_values(column, dtype))
        a = np.stack(columns, axis=1)
        bad = ~np.all(np.isfinite(a), axis=1)
        if bad.any():
            j = int(np.argmax(bad))
            raise ValueError(f"{name}: mesh attribute {attr!r} of {kind} {j} is {a[j].tolist()}: not finite")
        out[attr] = a
    return out


def ply_attributes(tm, n_vertices: int, n_faces: int, *, name: str = "PLY") -> dict:
    """The mesh attributes of a PLY that trimesh read (its raw elements), as Mitsuba 3.9.1's
    ``ply`` makes them (src/shapes/ply.h, ``find_other_fields``): in each of the ``vertex``
    and ``face`` elements, ``r g b`` (else ``red green blue``), with ``a`` (``alpha``) a
    fourth channel, become ``{vertex|face}_color``; then the other properties in the file's
    order, runs of one or three named ``{prefix}_{x y z}`` (or ``r g b``, ``0 1 2``, ``1 2
    3``) become ``{vertex|face}_{prefix}`` (``{prefix}_color`` for ``r g b``); others are
    ignored, as Mitsuba ignores them. Values: :func:`_ply_property_values`.

    Raises
    ------
    ValueError
        A property of an attribute that is a list or not one number per element, face
        attributes on faces that are not all triangles, a value not finite.

    Examples
    --------
    >>> class T: metadata = {"_ply_raw": {"vertex": {"properties": {"x": "<f4", "red": "<f4", "green": "<f4",
    ...     "blue": "<f4"}, "data": {"x": np.zeros(1), "red": np.ones(1), "green": np.zeros(1), "blue": np.ones(1)}}}}
    >>> ply_attributes(T(), 1, 0)["vertex_color"].tolist()
    [[1.0, 0.0, 1.0]]
    """
    raw = (tm.metadata or {}).get("_ply_raw", {}) or {}
    out = {}
    for kind, rows in (("vertex", n_vertices), ("face", n_faces)):
        element = raw.get(kind) or {}
        properties, data = element.get("properties"), element.get("data")
        if not properties or data is None:
            continue
        scalar = []
        for p, t in properties.items():
            try:
                dtype = np.dtype(t)
            except (TypeError, ValueError):  # a list property: trimesh's "<u1, ($LIST,)<i4", no numpy type
                dtype = None
            if dtype is None or dtype.shape != ():
                if kind == "face" and p in ("vertex_indices", "vertex_index"):
                    continue  # the faces' vertex indices: never an attribute
                raise ValueError(f"{name}: PLY property {kind} {p!r} is a list: Mitsuba's ply reads a list only "
                                 f"as a face's vertex_indices")
            if dtype.kind not in "fiu":
                continue
            scalar.append((str(p), dtype.str))
        count = int(element.get("length", rows) or 0)
        attrs = _ply_element_attributes(kind, scalar, data, count, name)
        if attrs and count != rows:  # faces split into triangles: a face's values would not be a triangle's
            raise ValueError(f"{name}: face attributes on {count} faces that are not all triangles "
                             f"({rows} triangles): Mitsuba's ply reads triangles only")
        out.update(attrs)
    return out


def _ply_texcoords(tm) -> np.ndarray | None:
    """A PLY's vertex texture coordinates under Mitsuba's names (``u v``, else ``texture_u
    texture_v``, else ``s t``), or None."""
    raw = (tm.metadata or {}).get("_ply_raw", {}).get("vertex", {})
    data = raw.get("data")
    for names in (("u", "v"), ("texture_u", "texture_v"), ("s", "t")):
        try:
            columns = [np.asarray(data[k], dtype=np.float64).reshape(-1) for k in names]
        except (KeyError, ValueError, TypeError, IndexError):
            continue
        return np.stack(columns, axis=1)
    return None
