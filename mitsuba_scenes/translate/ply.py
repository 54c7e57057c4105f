""":func:`write_ply`: a mesh as a binary PLY file, as Mitsuba's ``ply`` plugin reads it."""
from __future__ import annotations

import numpy as np


def _ply_attribute_properties(name: str, channels: int) -> list:
    """The float properties under which Mitsuba's ``ply`` reads attribute ``name`` back:
    ``{p}_x [_y _z]`` for ``vertex_{p}`` / ``face_{p}``, ``{q}_r _g _b`` for a three-channel
    ``{q}_color`` (its grouping turns ``_r _g _b`` into ``{q}_color``)."""
    p = name.split("_", 1)[1]
    if channels == 3 and p.endswith("_color"):
        return [f"{p[:-6]}_{c}" for c in "rgb"]
    return [f"{p}_{c}" for c in "xyz"[:channels]]


def write_ply(path, vertices, faces, normals=None, *, uv=None, attributes=None) -> None:
    """Write a binary little-endian PLY with float32 positions (and ``normals``, as
    ``nx ny nz``, texture coordinates ``uv``, as ``u v``, and mesh ``attributes`` (a dict,
    ``vertex_*`` and ``face_*``, 1 or 3 channels), as float properties Mitsuba groups back
    into them, where given) and int32 faces.

    Without normals, Mitsuba shades it flat when loaded with ``face_normals=true`` (and
    computes smooth normals without it); with them, Mitsuba's ``ply`` shades it smooth.

    Examples
    --------
    >>> write_ply("tri.ply", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])  # doctest: +SKIP
    """
    v = np.ascontiguousarray(vertices, dtype="<f4")
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"write_ply needs (N, 3) vertices and (M, 3) faces, got {v.shape} and {f.shape}")
    props = "property float x\nproperty float y\nproperty float z\n"
    if normals is not None:
        n = np.ascontiguousarray(normals, dtype="<f4")
        if n.shape != v.shape:
            raise ValueError(f"write_ply needs one normal per vertex, got {n.shape} for {v.shape}")
        v = np.ascontiguousarray(np.concatenate([v, n], axis=1))
        props += "property float nx\nproperty float ny\nproperty float nz\n"
    if uv is not None:
        t = np.ascontiguousarray(uv, dtype="<f4")
        if t.shape != (len(v), 2):
            raise ValueError(f"write_ply needs one (u, v) per vertex, got {t.shape} for {len(v)} vertices")
        v = np.ascontiguousarray(np.concatenate([v, t], axis=1))
        props += "property float u\nproperty float v\n"
    face_fields, face_values = [], []
    for name, values in (attributes or {}).items():
        a = np.ascontiguousarray(values, dtype="<f4")
        rows = len(v) if name.startswith("vertex_") else len(f)
        if a.ndim != 2 or a.shape[0] != rows or a.shape[1] not in (1, 3) or not name.startswith(("vertex_", "face_")):
            raise ValueError(f"write_ply: attribute {name!r} needs one row of 1 or 3 values per "
                             f"{'vertex' if name.startswith('vertex_') else 'face'}, got {a.shape}")
        fields = _ply_attribute_properties(name, a.shape[1])
        if name.startswith("vertex_"):
            v = np.ascontiguousarray(np.concatenate([v, a], axis=1))
            props += "".join(f"property float {p}\n" for p in fields)
        else:
            face_fields += fields
            face_values.append(a)
    header = (f"ply\nformat binary_little_endian 1.0\ncomment written by mitsuba_scenes\n"
              f"element vertex {len(v)}\n{props}"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\n"
              + "".join(f"property float {p}\n" for p in face_fields) + "end_header\n")
    rec = np.zeros(len(f), dtype=[("n", "u1"), ("idx", "<i4", (3,))] + [(p, "<f4") for p in face_fields])
    rec["n"], rec["idx"] = 3, f
    if face_fields:
        flat = np.concatenate(face_values, axis=1)
        for k, p in enumerate(face_fields):
            rec[p] = flat[:, k]
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(v.tobytes())
        fh.write(rec.tobytes())
