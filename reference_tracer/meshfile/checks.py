"""A mesh file is untrusted input: checked here before any parser allocates for it.
:func:`check_mesh_file` refuses what is not a regular file (``/dev/zero``, a FIFO), a PLY
whose header declares more elements than its bytes can hold, and a mesh that would not fit
in the memory available (``MemoryError``); :func:`check_serialized_file` does the same for a
Mitsuba ``.serialized`` mesh, whose compressed arrays may declare a huge mesh in a few bytes.
:func:`check_ply_faces` and :func:`check_serialized_file` also read a file's triangles as
Mitsuba's loader lays them out and refuse a vertex index past the vertices: Mitsuba does not
check them, and computes vertex normals (and reads positions) through them, outside its buffers.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..validation import check_face_indices, open_regular_file
from .serialized import serialized_faces, serialized_header

__all__ = ["check_mesh_file", "check_serialized_file", "check_ply_faces", "ply_faces", "ply_header_counts"]

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
#: memory per byte of a serialized mesh's decompressed data: Mitsuba's buffers, then ours in
#: float64 with their copies (an upper estimate).
_SERIALIZED_MEMORY_PER_BYTE = 6


def _header_lines(head: bytes):
    """``(header_bytes, [words of each line])`` of a PLY header, the first line (``ply``),
    comments and empty lines left out; None where no ``end_header`` is found."""
    end = head.find(b"end_header")
    if end < 0:
        return None
    nl = head.find(b"\n", end)
    lines = [raw.split() for raw in head[:end].decode("ascii", "replace").splitlines()[1:]]
    return (len(head) if nl < 0 else nl + 1), [w for w in lines if w and w[0] not in ("comment", "obj_info")]


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
    split = _header_lines(head)
    if split is None:
        raise ValueError(f"{name} is not a PLY mesh: no end_header in its first {_PLY_HEADER_MAX} bytes")
    size, lines = split
    fmt, elements = None, []
    for words in lines:
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
            raise ValueError(f"{name} is not a PLY mesh: header line {' '.join(words)[:80]!r} does not parse") from None
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
    check_face_indices(serialized_faces(path, header), header["vertices"], f"{path}: mesh {shape_index}")
    return header


#: numpy types of the PLY scalar types Mitsuba's ``ply`` plugin reads (src/shapes/ply.h).
_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
              "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
              "int32": "i4", "uint32": "u4", "long": "i8", "ulong": "u8", "half": "f2", "float16": "f2",
              "float32": "f4", "float64": "f8"}


def _ply_layout(head: bytes):
    """``(format, header_bytes, [(element, count, [(field, numpy type), ...]), ...])`` of a PLY
    header as Mitsuba's ``ply`` plugin lays its records out: a scalar property is one field, a
    list property its count (which must be 3) and three items, ``<name>.count`` and
    ``<name>.0``-``.2``. None where Mitsuba's parser would refuse the header (it says why)."""
    split = _header_lines(head)
    if split is None:
        return None
    size, lines = split
    fmt, elements = None, []
    for words in lines:
        if words[0] == "format" and len(words) > 1:
            fmt = words[1]
        elif words[0] == "element" and len(words) > 2 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements:
            if words[1:2] == ["list"] and len(words) == 5 and {words[2], words[3]} <= _PLY_TYPES.keys():
                elements[-1][2].extend([(f"{words[4]}.count", _PLY_TYPES[words[2]])]
                                       + [(f"{words[4]}.{k}", _PLY_TYPES[words[3]]) for k in range(3)])
            elif len(words) == 3 and words[1] in _PLY_TYPES:
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]]))
            else:
                return None
        else:
            return None
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        return None
    return fmt, size, elements


#: bytes of an ASCII PLY body tokenised at a time: the body's tokens (Python objects of
#: several times a token's bytes) are never all held at once.
_ASCII_CHUNK = 1 << 18
#: the bytes ``bytes.split()`` separates tokens at (ASCII whitespace), as a lookup table.
_WHITESPACE = np.zeros(256, dtype=bool)
_WHITESPACE[list(b" \t\n\r\x0b\x0c")] = True
_WHITESPACE_RE = re.compile(rb"[ \t\n\r\x0b\x0c]")


def _chunk_end(data: bytes, pos: int) -> int:
    """End of the chunk of ``data`` from ``pos``: about :data:`_ASCII_CHUNK` bytes on, at a
    whitespace byte (or the end), so that no token is cut in two."""
    end = pos + _ASCII_CHUNK
    if end >= len(data):
        return len(data)
    found = _WHITESPACE_RE.search(data, end)
    return len(data) if found is None else found.start()


def _token_start(data: bytes, pos: int, skip: int):
    """Offset in ``data`` of token ``skip`` (from 0) of ``data[pos:].split()``, counted a chunk
    at a time without making the tokens; None where there are no more than ``skip``."""
    while pos < len(data):
        end = _chunk_end(data, pos)
        space = _WHITESPACE[np.frombuffer(data, dtype=np.uint8, count=end - pos, offset=pos)]
        # a token begins at a byte that is not whitespace after one that is (or at the
        # chunk's start, which is the body's start or a whitespace byte)
        begins = ~space
        begins[1:] &= space[:-1]
        starts = np.flatnonzero(begins)
        if skip < len(starts):
            return pos + int(starts[skip])
        skip -= len(starts)
        pos = end
    return None


def _ascii_records(data: bytes, pos: int, count: int, width: int, columns: list):
    """The ``columns`` of ``count`` records of ``width`` tokens each from ``data[pos:]`` as a
    float64 table, tokenised a chunk at a time; None where there are too few tokens, a
    selected token is no number or a record's list count (its first selected column) is not 3."""
    need, got, pending, parts = count * width, 0, [], []
    while got < need and pos < len(data):
        end = _chunk_end(data, pos)
        tokens = data[pos:end].split()[:need - got]
        pos = end
        got += len(tokens)
        tokens = pending + tokens
        whole = len(tokens) // width * width
        pending = tokens[whole:]
        if whole:
            try:
                block = np.array(tokens[:whole], dtype=np.bytes_).reshape(-1, width)[:, columns].astype(np.float64)
            except ValueError:
                return None
            if np.any(block[:, 0] != 3):
                return None
            parts.append(block)
    if got < need:
        return None
    return np.concatenate(parts) if parts else np.zeros((0, len(columns)))


def ply_faces(data: bytes):
    """``(vertices, faces)`` of a PLY file's bytes as Mitsuba's ``ply`` plugin reads them: the
    count of its last ``vertex`` element and the (M, 3) vertex indices of its last ``face``
    element (``vertex_indices`` or ``vertex_index``), every face a triangle: int64, or float64
    where a list of floats holds one that is not a whole number. Records
    are of fixed size there (a list's count must be 3), token by token in an ASCII file.
    None where Mitsuba's loader refuses the file itself (a header it does not parse, no face
    list, a face that is not a triangle, too few bytes or tokens, a token that is no number).
    An ASCII body is tokenised a chunk at a time: the tokens before the face element are
    counted without being made, so the memory taken is that of a chunk and the faces.

    Examples
    --------
    >>> head = (b"ply\\nformat ascii 1.0\\nelement vertex 3\\nproperty float x\\nproperty float y\\n"
    ...         b"property float z\\nelement face 1\\nproperty list uchar int vertex_indices\\nend_header\\n")
    >>> n, f = ply_faces(head + b"0 0 0\\n1 0 0\\n0 1 0\\n3 0 1 7\\n")
    >>> n, f.tolist()
    (3, [[0, 1, 7]])
    >>> ply_faces(head + b"0 0 0\\n1 0 0\\n0 1 0\\n4 0 1 2 1\\n") is None   # a quad: Mitsuba refuses it
    True
    """
    layout = _ply_layout(data[:_PLY_HEADER_MAX])
    if layout is None:
        return None
    fmt, size, elements = layout
    vertices = next((count for name, count, _ in reversed(elements) if name == "vertex"), 0)
    last = next((i for i in reversed(range(len(elements))) if elements[i][0] == "face"), None)
    if last is None:
        return vertices, np.zeros((0, 3), dtype=np.int64)
    _, count, fields = elements[last]
    names = [f for f, _ in fields]
    key = next((k for k in ("vertex_index", "vertex_indices") if f"{k}.count" in names), None)
    if key is None:
        return None
    columns = [names.index(f"{key}.{k}") for k in ("count", 0, 1, 2)]
    if fmt == "ascii":
        need = count * len(fields)
        start = _token_start(data, size, sum(n * len(f) for _, n, f in elements[:last])) if need else size
        table = None if start is None else _ascii_records(data, start, count, len(fields), columns)
        if table is None:
            return None
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        dtypes = [np.dtype([(f"f{j}", order + t) for j, (_, t) in enumerate(f)]) for _, _, f in elements]
        offset = size + sum(n * dt.itemsize for (_, n, _), dt in zip(elements[:last], dtypes[:last]))
        if offset + count * dtypes[last].itemsize > len(data):
            return None
        records = np.frombuffer(data, dtype=dtypes[last], count=count, offset=offset)
        table = np.stack([records[f"f{j}"].astype(np.float64) for j in columns], axis=1) if count else \
            np.zeros((0, 4))
    if np.any(table[:, 0] != 3):
        return None
    faces = table[:, 1:]
    whole = np.all(np.isfinite(faces) & (faces == np.round(faces)))
    return vertices, faces.astype(np.int64) if whole else faces


def check_ply_faces(path) -> None:
    """Refuse a PLY file (after :func:`check_mesh_file`) whose triangles, as Mitsuba's ``ply``
    plugin reads them (:func:`ply_faces`), use a vertex index outside its vertices: Mitsuba's
    loader takes such an index as it comes and computes vertex normals through it, writing
    outside its buffers (a crash or a corrupted process). A file Mitsuba refuses itself, or
    one that is not a PLY file, passes: its loader says why.

    Raises
    ------
    ValueError
        The first such face, its index in the file and the vertex count.
    OSError
        The file cannot be read.
    """
    path = Path(path)
    with open_regular_file(path, "a mesh file") as f:
        data = f.read()
    if not data.startswith(b"ply"):
        return
    found = ply_faces(data)
    if found is not None:
        check_face_indices(found[1], found[0], str(path))
