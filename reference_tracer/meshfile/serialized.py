"""Mitsuba's ``.serialized`` mesh format: the header of one of a file's sub-meshes
(:func:`serialized_header`), read without decompressing its arrays, so that
:func:`reference_tracer.meshfile.check_serialized_file` can size the mesh before Mitsuba
loads it, and its triangles (:func:`serialized_faces`), whose vertex indices it checks.
"""
from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np

__all__ = ["serialized_header", "serialized_faces"]

#: Mitsuba's serialized format: identifier, versions, flags (src/shapes/serialized.cpp).
_SERIALIZED_ID, _SERIALIZED_VERSIONS = 0x041C, (3, 4)
_SER_NORMALS, _SER_TEXCOORDS, _SER_COLORS, _SER_DOUBLE = 0x0001, 0x0002, 0x0008, 0x2000


def serialized_header(path, shape_index: int = 0) -> dict:
    """The header of sub-mesh ``shape_index`` of a Mitsuba ``.serialized`` file, read without
    decompressing its arrays: ``flags``, ``name``, ``vertices``, ``triangles``,
    ``data_bytes`` (the size of its decompressed arrays), ``offset`` (where its compressed
    stream starts in the file), ``header_bytes`` (the decompressed bytes before its arrays)
    and ``index_bytes`` (the size of one vertex index).

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
        offset, start = 0, 4
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
            start = offset + 4
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
            "data_bytes": vertices * per_vertex * real + triangles * 3 * index, "offset": start,
            "header_bytes": end + 17, "index_bytes": index}


def serialized_faces(path, header: dict) -> np.ndarray:
    """The (M, 3) int64 vertex indices of the sub-mesh of ``header`` (:func:`serialized_header`
    of the same file), decompressed: the last array of its stream, little-endian. Size the
    mesh first (``header["data_bytes"]`` are decompressed here).

    Raises
    ------
    ValueError
        A stream that does not decompress, or ends before its indices (Mitsuba's loader
        refuses both too).
    """
    path = Path(path)
    need = header["header_bytes"] + header["data_bytes"]
    inflate, parts, got = zlib.decompressobj(), [], 0
    try:
        with open(path, "rb") as f:
            f.seek(header["offset"])
            while got < need and not inflate.eof:
                chunk = inflate.unconsumed_tail or f.read(1 << 20)
                if not chunk:
                    break
                parts.append(inflate.decompress(chunk, need - got))
                got += len(parts[-1])
    except zlib.error as exc:
        raise ValueError(f"{path}: a mesh's arrays do not decompress ({exc})") from None
    raw = b"".join(parts)
    if len(raw) < need:
        raise ValueError(f"{path}: a mesh's stream ends after {len(raw)} of its {need} bytes (truncated)")
    count = header["triangles"] * 3
    dtype = "<u8" if header["index_bytes"] == 8 else "<u4"
    faces = np.frombuffer(raw, dtype=dtype, count=count, offset=need - count * header["index_bytes"])
    return faces.astype(np.int64).reshape(-1, 3)
