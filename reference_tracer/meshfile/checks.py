"""A mesh file is untrusted input: checked here before any parser allocates for it.
:func:`check_mesh_file` refuses what is not a regular file (``/dev/zero``, a FIFO), a PLY
whose header declares more elements than its bytes can hold, and a mesh that would not fit
in the memory available (``MemoryError``); :func:`check_serialized_file` does the same for a
Mitsuba ``.serialized`` mesh, whose compressed arrays may declare a huge mesh in a few bytes.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..validation import open_regular_file
from .serialized import serialized_header

__all__ = ["check_mesh_file", "check_serialized_file", "ply_header_counts"]

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
