"""OBJ files as Mitsuba's ``obj`` plugin reads them, parsed here (:func:`parse_obj`: trimesh
merges and reorders an OBJ's vertices and drops its normals, where Mitsuba's loader keeps one
vertex per distinct index triple and the file's normals). The text is decoded here (UTF-8,
else Latin-1, where every byte is a character: a stray accented byte in a comment is harmless)
and checked for binary data (not an OBJ) and for face index 0, which OBJ does not allow
(indices start at 1; negative ones count back from the last vertex). Vertex normals are input
like the rest: a normal that is zero or not a number, and a face corner without a normal in
an OBJ that has normals (Mitsuba leaves that vertex's normal undefined), are refused with the
file and line.
"""
from __future__ import annotations

import io
import math
import re
from array import array

import numpy as np

from .data import MeshData

__all__ = ["decode_obj", "check_obj_faces", "parse_obj", "obj_undefined_normal"]

#: bytes that never occur in OBJ text (control characters other than tab, CR, LF, FF).
_BINARY = re.compile(rb"[\x00-\x08\x0e-\x1f]")
#: an OBJ element line that indexes vertices.
_FACE = re.compile(r"^\s*(f|l|p)\s+(.*)$")


def decode_obj(data: bytes, *, name: str = "OBJ") -> str:
    """OBJ bytes as text: UTF-8 if they decode, else Latin-1; ``ValueError`` for binary data.

    Examples
    --------
    >>> decode_obj(b"# caf\\xe9\\nv 0 0 0\\n").splitlines()[0]
    '# café'
    >>> decode_obj(b"\\x00\\x01\\x02", name="x.obj")
    Traceback (most recent call last):
    ...
    ValueError: x.obj is not an OBJ or PLY mesh: it holds binary data
    """
    if _BINARY.search(data[: 1 << 20]):
        raise ValueError(f"{name} is not an OBJ or PLY mesh: it holds binary data")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def check_obj_faces(text: str, *, name: str = "OBJ") -> None:
    """Raise ``ValueError`` at the first face (or line, point) with vertex index 0.

    Examples
    --------
    >>> check_obj_faces("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n")
    >>> check_obj_faces("v 0 0 0\\nf 0/1 2 3\\n", name="m.obj")
    Traceback (most recent call last):
    ...
    ValueError: m.obj line 2: vertex index 0 in 'f 0/1 2 3' (OBJ indices start at 1)
    """
    for number, line in enumerate(text.splitlines(), 1):
        m = _FACE.match(line)
        if not m:
            continue
        for token in m.group(2).split():
            if token.startswith("#"):
                break
            first = token.split("/")[0]
            if first.lstrip("+-").isdigit() and int(first) == 0:
                raise ValueError(f"{name} line {number}: vertex index 0 in {line.strip()!r} "
                                 "(OBJ indices start at 1)")


def _floats(words, count: int, what: str, where: str) -> list:
    try:
        values = [float(w) for w in words[1:1 + count]]
    except ValueError:
        values = []
    if len(values) != count:
        raise ValueError(f"{where}: {what} needs {count} numbers, got {' '.join(words)[:80]!r}")
    return values


def parse_obj(text: str, *, name: str = "OBJ", normals: bool = True) -> MeshData:
    """An OBJ's triangles as Mitsuba's ``obj`` plugin reads them (src/shapes/obj.cpp).

    One vertex per distinct (position, texture coordinate, normal) index triple of the
    faces, numbered in the order the faces first use them (positions no face uses are
    left out); polygons split into fans (0, 1, 2), (0, 2, 3), ...; ``vn`` lines are the
    vertex normals, read only with ``normals`` (Mitsuba's ``face_normals=false``). As in
    Mitsuba's parser, an index a face corner leaves out is the previous corner's on the
    same line (``f 1//1 2 3`` gives all three corners normal 1). Negative indices count
    back from the last element read (the OBJ convention; Mitsuba refuses them). Raises
    ``ValueError`` with the line for an index out of range, a number that does not parse,
    a normal that is zero or not finite, and a face whose first corner has no normal
    index in a file with normals (Mitsuba leaves that normal undefined).

    Examples
    --------
    >>> m = parse_obj("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nv 1 1 0\\nvn 0 0 2\\nf 1//1 2//1 4//1 3//1\\n")
    >>> m.faces.tolist(), m.normals.tolist()[0]
    ([[0, 1, 2], [0, 2, 3]], [0.0, 0.0, 2.0])
    >>> parse_obj("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nvn 0 0 0\\nf 1//1 2//1 3//1\\n", name="m.obj")
    Traceback (most recent call last):
    ...
    ValueError: m.obj line 4: vertex normal 'vn 0 0 0' is zero or not finite
    """
    # Flat arrays of doubles and indices, not lists of lists: a few times the file's bytes
    # at most (check_mesh_file's budget), whatever its lines hold.
    positions, vn, vt, faces = array("d"), array("d"), array("d"), array("q")
    n_v = n_vn = n_vt = 0
    ids: dict = {}          # (v, vt, vn) -> vertex id
    missing_vn = 0          # first line with a face corner that has no normal index (0: none)
    for number, line in enumerate(io.StringIO(text), 1):   # lines end at "\n", as Mitsuba's
        words = line.split()
        if not words:
            continue
        head = words[0]
        if head == "v":
            positions.extend(_floats(words, 3, "a vertex", f"{name} line {number}"))
            n_v += 1
        elif head == "vn":
            if normals:
                n = _floats(words, 3, "a vertex normal", f"{name} line {number}")
                if not (all(map(math.isfinite, n)) and any(n)):
                    raise ValueError(f"{name} line {number}: vertex normal {line.strip()[:80]!r} is zero or not finite")
                vn.extend(n)
                n_vn += 1
        elif head == "vt":
            vt.extend(_floats(words, 2, "a texture coordinate", f"{name} line {number}"))
            n_vt += 1
        elif head == "f":
            first = previous = corners = 0
            idx = [0, 0, 0]   # Mitsuba keeps a line's indices from corner to corner
            for token in words[1:]:
                if token.startswith("#"):
                    break
                parts = token.split("/")[:3]
                for k, part in enumerate(parts):
                    if not part:
                        continue
                    try:
                        idx[k] = int(part)
                    except ValueError:
                        raise ValueError(f"{name} line {number}: face corner {token!r} does not parse") from None
                    count = (n_v, n_vt, n_vn if normals else None)[k]
                    if count is None:          # normals not read: the index only splits vertices
                        continue
                    if idx[k] < 0:
                        idx[k] += count + 1
                    if not 1 <= idx[k] <= count:
                        what = ("vertex", "texture coordinate", "normal")[k]
                        raise ValueError(f"{name} line {number}: {what} index in {token!r} out of range "
                                         f"(the file has {count} so far)")
                if not parts[0]:
                    raise ValueError(f"{name} line {number}: face corner {token!r} has no vertex index")
                if not (idx[0] < 1 << 32 and 0 <= idx[1] < 1 << 32):
                    raise ValueError(f"{name} line {number}: face corner {token!r} out of range")
                key = idx[0] | idx[1] << 32 | idx[2] << 64   # one int: a third of a tuple's memory
                vid = ids.get(key)
                if vid is None:
                    vid = ids[key] = len(ids)
                    if idx[2] == 0 and not missing_vn:
                        missing_vn = number
                if corners >= 2:          # a fan around the first corner
                    faces.extend((first, previous, vid))
                elif corners == 0:
                    first = vid
                previous = vid
                corners += 1
    v_index = np.fromiter((k & 0xFFFFFFFF for k in ids), dtype=np.int64, count=len(ids))
    vertices = np.frombuffer(positions, dtype=np.float64).reshape(-1, 3)[v_index - 1]
    out_normals = None
    if normals and n_vn:
        if missing_vn:
            raise ValueError(f"{name} line {missing_vn}: a face corner without a normal index, in a file with "
                             "vertex normals (Mitsuba leaves that vertex's normal undefined); give the face's "
                             "first corner one, or load with face_normals=True")
        vn_index = np.fromiter((k >> 64 for k in ids), dtype=np.int64, count=len(ids))
        out_normals = np.frombuffer(vn, dtype=np.float64).reshape(-1, 3)[vn_index - 1]
    out_uv = None
    if n_vt:
        vt_index = np.fromiter(((k >> 32) & 0xFFFFFFFF for k in ids), dtype=np.int64, count=len(ids))
        table = np.concatenate([np.full((1, 2), np.nan), np.frombuffer(vt, dtype=np.float64).reshape(-1, 2)])
        out_uv = table[vt_index]   # index 0 (a corner without one): NaN, undefined in Mitsuba
    return MeshData(vertices, np.frombuffer(faces, dtype=np.int64).reshape(-1, 3), out_normals, out_uv)


def obj_undefined_normal(text: str, *, texcoords: bool = False) -> int | None:
    """The first line of an OBJ with ``vn`` lines whose face leaves a vertex normal undefined
    in Mitsuba's loader (its first corner has no normal index; later corners keep the
    previous one's), or None; with ``texcoords`` the same for ``vt`` lines and texture
    coordinate indices.

    Examples
    --------
    >>> obj_undefined_normal("v 0 0 0\\nvn 0 0 1\\nf 1//1 1 1\\nf 1 1//1 1\\n")
    4
    >>> obj_undefined_normal("v 0 0 0\\nf 1 1 1\\n") is None
    True
    >>> obj_undefined_normal("v 0 0 0\\nvt 0 0\\nf 1/1 1 1\\nf 1//1 1 1\\n", texcoords=True)
    4
    """
    slot, tag = (1, "vt") if texcoords else (2, "vn")
    if not re.search(rf"^\s*{tag}\s", text, re.MULTILINE):
        return None
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split()
        if len(words) > 1 and words[0] == "f" and not words[1].startswith("#"):
            parts = words[1].split("/")
            if len(parts) <= slot or not parts[slot]:
                return number
    return None
