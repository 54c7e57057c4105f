"""Reading OBJ and PLY files for :meth:`reference_tracer.Mesh.load`, robustly.

trimesh parses the files; this module decides what reaches it. The file is read as bytes
and its kind checked first, so that a file that is not a mesh gets a clear ``ValueError``
("not an OBJ or PLY mesh") instead of whatever trimesh's guess produces (it tries an
optional character-set detector on undecodable text). OBJ text is decoded here (UTF-8,
else Latin-1, where every byte is a character: a stray accented byte in a comment is
harmless) and checked for face index 0, which OBJ does not allow (indices start at 1;
negative ones count back from the last vertex) and trimesh would silently read as 1.
"""
from __future__ import annotations

import io
import re
from pathlib import Path

__all__ = ["read_mesh", "decode_obj", "check_obj_faces"]

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


def read_mesh(path):
    """A ``trimesh.Trimesh`` from an OBJ or PLY file (no processing: vertex order kept).

    Raises ``ValueError`` naming the file for anything that is not a readable OBJ or PLY
    mesh (missing file, binary junk, a face index 0, trimesh's own errors).
    """
    import trimesh

    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"Mesh.load could not read {path}: {exc.strerror or exc}") from exc
    suffix = path.suffix.lower()
    if data.startswith(b"ply"):
        kind, file_obj = "ply", io.BytesIO(data)
    elif suffix == ".ply":
        raise ValueError(f"{path} is not an OBJ or PLY mesh: a PLY file starts with 'ply'")
    elif suffix == ".obj":
        text = decode_obj(data, name=str(path))
        check_obj_faces(text, name=str(path))
        kind, file_obj = "obj", io.BytesIO(text.encode("utf-8"))
    else:
        raise ValueError(f"{path} is not an OBJ or PLY mesh (its name should end in .obj or .ply)")
    try:  # the resolver finds files an OBJ names (mtllib) beside it
        return trimesh.load(file_obj, file_type=kind, process=False, force="mesh",
                            resolver=trimesh.resolvers.FilePathResolver(str(path)))
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types; name the file in all cases
        raise ValueError(f"{path} is not an OBJ or PLY mesh trimesh can read: {type(exc).__name__}: {exc}") from exc
