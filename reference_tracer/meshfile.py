"""Reading OBJ and PLY files for :meth:`reference_tracer.Mesh.load`, robustly.

PLY files are parsed by trimesh, OBJ files here (:func:`parse_obj`: trimesh merges and
reorders an OBJ's vertices and drops its normals, where Mitsuba's loader keeps one vertex
per distinct index triple and the file's normals). The file is read as bytes and its kind
checked first, so that a file that is not a mesh gets a clear ``ValueError`` ("not an OBJ
or PLY mesh") instead of whatever a parser's guess produces (trimesh tries an optional
character-set detector on undecodable text). OBJ text is decoded here (UTF-8, else
Latin-1, where every byte is a character: a stray accented byte in a comment is harmless)
and checked for face index 0, which OBJ does not allow (indices start at 1; negative ones
count back from the last vertex).

Vertex normals are input like the rest: a normal that is zero or not a number, and a face
corner without a normal in an OBJ that has normals (Mitsuba leaves that vertex's normal
undefined), are refused with the file and line.

A mesh file is untrusted input: before any parser allocates for it,
:func:`check_mesh_file` refuses what is not a regular file (``/dev/zero``, a FIFO), a PLY
whose header declares more elements than its bytes can hold, and a mesh that would not
fit in the memory available (``MemoryError``).
"""
from __future__ import annotations

import io
import math
import os
import re
import struct
import zlib
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .textures import srgb_to_linear
from .validation import open_regular_file

__all__ = ["read_mesh", "ply_attributes", "decode_obj", "check_obj_faces", "check_mesh_file", "ply_header_counts", "parse_obj",
           "obj_undefined_normal", "MeshData", "check_serialized_file", "serialized_header"]

#: bytes a PLY scalar type takes in a binary file.
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
#: the most bytes of a PLY header read (real headers are a few hundred bytes).
_PLY_HEADER_MAX = 1 << 16
#: bytes of memory per byte of an OBJ file that parsing it may take at most (text split
#: into lines and tokens, then float64 arrays): an upper estimate, measured with trimesh.
_OBJ_MEMORY_PER_BYTE = 16
#: bytes of memory per declared PLY vertex and per face (float64 arrays and their copies).
_PLY_MEMORY_PER_ELEMENT = 96
#: Mitsuba's serialized format: identifier, versions, flags (src/shapes/serialized.cpp).
_SERIALIZED_ID, _SERIALIZED_VERSIONS = 0x041C, (3, 4)
_SER_NORMALS, _SER_TEXCOORDS, _SER_COLORS, _SER_DOUBLE = 0x0001, 0x0002, 0x0008, 0x2000
#: memory per byte of a serialized mesh's decompressed data: Mitsuba's buffers, then ours in
#: float64 with their copies (an upper estimate).
_SERIALIZED_MEMORY_PER_BYTE = 6


def ply_header_counts(head: bytes, *, name: str = "PLY") -> tuple:
    """``(format, header_bytes, [(element, count, min_bytes_each), ...])`` of a PLY header.

    ``min_bytes_each`` is the fewest bytes one element can take in the file: the sum of its
    fixed-size properties (binary) or two bytes a property (ASCII: a digit and a separator);
    a list property counts its length field only.

    Raises
    ------
    ValueError
        The header does not end within 64 KiB, or a line of it does not parse.

    Examples
    --------
    >>> ply_header_counts(b"ply\\nformat binary_little_endian 1.0\\nelement vertex 3\\n"
    ...                   b"property float x\\nproperty float y\\nproperty float z\\nend_header\\n")
    ('binary_little_endian', 115, [('vertex', 3, 12)])
    """
    end = head.find(b"end_header")
    if end < 0:
        raise ValueError(f"{name} is not a PLY mesh: no end_header in its first {_PLY_HEADER_MAX} bytes")
    nl = head.find(b"\n", end)
    size = len(head) if nl < 0 else nl + 1
    fmt, elements = None, []
    for raw in head[:end].decode("ascii", "replace").splitlines()[1:]:
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        try:
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append([words[1], int(words[2]), 0])
            elif words[0] == "property" and elements:
                binary = fmt is not None and fmt.startswith("binary")
                kind = words[2] if words[1] == "list" else words[1]
                elements[-1][2] += _PLY_SIZES.get(kind, 1) if binary else 2
        except (IndexError, ValueError):
            raise ValueError(f"{name} is not a PLY mesh: header line {raw.strip()[:80]!r} does not parse") from None
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{name} is not a PLY mesh: format {fmt!r}")
    for e in elements:
        if e[1] < 0:
            raise ValueError(f"{name}: element {e[0]!r} declares a negative count {e[1]}")
    return fmt, size, [tuple(e) for e in elements]


def _available_memory() -> int:
    """Bytes of memory this process can still use: ``MemAvailable`` (Linux), else physical memory."""
    try:
        with open("/proc/meminfo", "rb") as f:
            for line in f:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 62


def check_mesh_file(path) -> int:
    """Check a mesh file before any parser allocates for it; return its size in bytes.

    Raises
    ------
    ValueError
        Not a regular file (a device such as ``/dev/zero``, a FIFO, a folder), or a PLY
        whose header declares more vertices or faces than the file's bytes can hold
        (a corrupt or hostile header): bad input.
    MemoryError
        The mesh would need more memory than is available (an honest but huge mesh).
    OSError
        The file cannot be opened.
    """
    path = Path(path)
    with open_regular_file(path, "a mesh file") as f:
        size = os.fstat(f.fileno()).st_size
        head = f.read(_PLY_HEADER_MAX)
    if head.startswith(b"ply"):
        _, header, elements = ply_header_counts(head, name=str(path))
        need = sum(count * each for _, count, each in elements)
        if need > size - header:
            declared = ", ".join(f"{count} {name}" for name, count, _ in elements)
            raise ValueError(f"{path}: its header declares {declared}, at least {need} bytes, but the file "
                             f"holds {size - header} bytes after its header (corrupt or truncated)")
        memory = _PLY_MEMORY_PER_ELEMENT * sum(count for _, count, _ in elements)
    else:
        memory = _OBJ_MEMORY_PER_BYTE * size
    available = _available_memory()
    if memory > available:
        raise MemoryError(f"{path}: reading this mesh needs about {memory / 2**30:.1f} GiB, "
                          f"{available / 2**30:.1f} GiB of memory is available")
    return size

def serialized_header(path, shape_index: int = 0) -> dict:
    """The header of sub-mesh ``shape_index`` of a Mitsuba ``.serialized`` file, read without
    decompressing its arrays: ``flags``, ``name``, ``vertices``, ``triangles`` and
    ``data_bytes`` (the size of its decompressed arrays).

    Raises
    ------
    ValueError
        Not a serialized mesh, an unknown version, a shape index beyond the file's count,
        an offset outside the file, or a header that does not decompress.

    Examples
    --------
    >>> import struct, zlib, tempfile, os
    >>> body = struct.pack("<I", 0x1000) + b"tri\\x00" + struct.pack("<QQ", 3, 1) + bytes(36 + 12)
    >>> data = struct.pack("<HH", 0x041C, 4) + zlib.compress(body) + struct.pack("<QI", 0, 1)
    >>> f = tempfile.NamedTemporaryFile(suffix=".serialized", delete=False); _ = f.write(data); f.close()
    >>> h = serialized_header(f.name); os.unlink(f.name)
    >>> h["vertices"], h["triangles"], h["data_bytes"]
    (3, 1, 48)
    """
    path = Path(path)
    if isinstance(shape_index, bool) or not isinstance(shape_index, int) or shape_index < 0:
        raise ValueError(f"{path}: shape_index must be an integer >= 0, got {shape_index!r}")
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        head = f.read(4)
        if len(head) < 4 or struct.unpack("<H", head[:2])[0] != _SERIALIZED_ID:
            raise ValueError(f"{path} is not a Mitsuba serialized mesh (no 0x041C identifier)")
        version = struct.unpack("<H", head[2:4])[0]
        if version not in _SERIALIZED_VERSIONS:
            raise ValueError(f"{path}: serialized format version {version} (Mitsuba reads 3 and 4)")
        offset = 0
        if shape_index > 0:
            wide = 8 if version == 4 else 4
            if size < 4 + wide:
                raise ValueError(f"{path}: too short for its end-of-file dictionary")
            f.seek(size - 4)
            count = struct.unpack("<I", f.read(4))[0]
            if shape_index >= count:
                raise ValueError(f"{path}: shape_index {shape_index}, but the file holds {count} mesh(es)")
            f.seek(size - 4 - wide * (count - shape_index))
            offset = struct.unpack("<Q" if wide == 8 else "<I", f.read(wide))[0]
            if not 0 <= offset <= size - 4:
                raise ValueError(f"{path}: mesh {shape_index} starts at byte {offset}, outside the file")
            f.seek(offset)
            if struct.unpack("<H", f.read(2))[0] != _SERIALIZED_ID:
                raise ValueError(f"{path}: mesh {shape_index} has no 0x041C identifier at byte {offset}")
            f.read(2)
        compressed = f.read(1 << 16)
    inflate = zlib.decompressobj()
    try:
        raw = inflate.decompress(compressed, 4 + 4096 + 16)
    except zlib.error as exc:
        raise ValueError(f"{path}: mesh {shape_index}'s header does not decompress ({exc})") from None
    end = raw.find(b"\0", 4) if version == 4 else 3
    if len(raw) < 4 or end < 0 or len(raw) < end + 17:
        raise ValueError(f"{path}: mesh {shape_index}'s header is truncated")
    flags = struct.unpack("<I", raw[:4])[0]
    name = raw[4:end].decode("utf-8", "replace") if version == 4 else ""
    vertices, triangles = struct.unpack("<QQ", raw[end + 1:end + 17])
    real = 8 if flags & _SER_DOUBLE else 4
    per_vertex = 3 + 3 * bool(flags & _SER_NORMALS) + 2 * bool(flags & _SER_TEXCOORDS) + 3 * bool(flags & _SER_COLORS)
    index = 8 if vertices > 0xFFFFFFFF else 4
    return {"flags": flags, "name": name, "vertices": vertices, "triangles": triangles,
            "data_bytes": vertices * per_vertex * real + triangles * 3 * index}


def check_serialized_file(path, shape_index: int = 0) -> dict:
    """:func:`check_mesh_file` for a Mitsuba ``.serialized`` mesh: a regular file whose
    sub-mesh ``shape_index`` declares no more data than the memory available can hold
    (its arrays are compressed: a small file may declare a huge mesh). Returns its header.

    Raises
    ------
    ValueError
        Not a regular file or not a readable serialized mesh (:func:`serialized_header`).
    MemoryError
        The mesh would need more memory than is available.
    """
    path = Path(path)
    open_regular_file(path, "a mesh file").close()
    header = serialized_header(path, shape_index)
    memory, available = _SERIALIZED_MEMORY_PER_BYTE * header["data_bytes"], _available_memory()
    if memory > available:
        raise MemoryError(f"{path}: mesh {shape_index} declares {header['vertices']} vertices and "
                          f"{header['triangles']} triangles, about {memory / 2**30:.1f} GiB to read; "
                          f"{available / 2**30:.1f} GiB of memory is available")
    return header


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


@dataclass(frozen=True)
class MeshData:
    """A mesh file's contents: ``vertices`` (N, 3) and ``faces`` (M, 3) int64, the file's
    vertex ``normals`` (N, 3), or None where it has none (or they were not read), and its
    texture coordinates ``uv`` (N, 2) as the file holds them (NaN for a vertex a face gives
    none), or None where it has none."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uv: np.ndarray | None = None
    attributes: dict | None = None


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
    bad = ~(np.all(np.isfinite(n), axis=1) & np.any(n != 0.0, axis=1))
    if bad.any():
        used = np.zeros(len(n), dtype=bool)
        used[faces[(faces >= 0) & (faces < len(n))]] = True
        if (bad & used).any():
            i = int(np.argmax(bad & used))
            raise ValueError(f"{name}: vertex normal {i} is {n[i].tolist()}: zero or not finite")
        n[bad] = (1.0, 0.0, 0.0)
    return n


def read_mesh(path, *, normals: bool = True) -> MeshData:
    """The vertices, faces and (with ``normals``) vertex normals of an OBJ or PLY file.

    PLY: through trimesh (no processing: vertex order kept), normals from ``nx ny nz``;
    OBJ: :func:`parse_obj`.

    Raises ``ValueError`` naming the file for anything that is not a readable OBJ or PLY
    mesh (missing file, not a regular file, binary junk, a PLY header that declares more
    than the file holds, a face index 0, a bad normal, trimesh's own errors),
    ``MemoryError`` for a mesh too large for the memory available (:func:`check_mesh_file`).
    """
    path = Path(path)
    try:
        check_mesh_file(path)
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"Mesh.load could not read {path}: {exc.strerror or exc}") from exc
    suffix = path.suffix.lower()
    if data.startswith(b"ply"):
        file_obj = io.BytesIO(data)
    elif suffix == ".ply":
        raise ValueError(f"{path} is not an OBJ or PLY mesh: a PLY file starts with 'ply'")
    elif suffix == ".obj":
        text = decode_obj(data, name=str(path))
        check_obj_faces(text, name=str(path))
        return parse_obj(text, name=str(path), normals=normals)
    else:
        raise ValueError(f"{path} is not an OBJ or PLY mesh (its name should end in .obj or .ply)")
    import trimesh  # deferred: trimesh takes about 1.5 s to import

    try:
        tm = trimesh.load(file_obj, file_type="ply", process=False, force="mesh")
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types; name the file in all cases
        raise ValueError(f"{path} is not an OBJ or PLY mesh trimesh can read: {type(exc).__name__}: {exc}") from exc
    vertices = np.asarray(tm.vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(tm.faces, dtype=np.int64).reshape(-1, 3)
    n = _ply_normals(tm, faces, str(path)) if normals else None
    if n is not None and n.shape != vertices.shape:  # trimesh changed the vertices: not the file's
        raise ValueError(f"{path}: {len(n)} vertex normals for {len(vertices)} vertices")
    uv = _ply_texcoords(tm)
    if uv is not None and len(uv) != len(vertices):
        raise ValueError(f"{path}: {len(uv)} texture coordinates for {len(vertices)} vertices")
    attributes = ply_attributes(tm, len(vertices), len(faces), name=str(path))
    return MeshData(vertices, faces, n, uv, attributes)


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
            except TypeError:
                dtype = None
            if dtype is None or dtype.kind not in "fiu" or dtype.shape != ():
                continue  # a list (the faces' vertex indices): never an attribute
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
