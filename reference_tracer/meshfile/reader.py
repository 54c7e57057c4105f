"""``read_mesh``: a mesh file checked (:mod:`.checks`), its kind told from its first bytes and
its name, and handed to the parser of its format (:mod:`.obj`, :mod:`.ply`), so that a file
that is not a mesh gets a clear ``ValueError`` ("not an OBJ or PLY mesh") instead of whatever
a parser's guess produces (trimesh tries an optional character-set detector on undecodable
text).
"""
from __future__ import annotations

from pathlib import Path

from .checks import check_mesh_file
from .data import MeshData
from .obj import check_obj_faces, decode_obj, parse_obj
from .ply import parse_ply

__all__ = ["read_mesh"]


def read_mesh(path, *, normals: bool = True) -> MeshData:
    """The vertices, faces and (with ``normals``) vertex normals of an OBJ or PLY file.

    PLY: :func:`~reference_tracer.meshfile.ply.parse_ply`, through trimesh (no processing:
    vertex order kept), normals from ``nx ny nz``; OBJ: :func:`parse_obj`.

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
        return parse_ply(data, name=str(path), normals=normals)
    if suffix == ".ply":
        raise ValueError(f"{path} is not an OBJ or PLY mesh: a PLY file starts with 'ply'")
    if suffix == ".obj":
        text = decode_obj(data, name=str(path))
        check_obj_faces(text, name=str(path))
        return parse_obj(text, name=str(path), normals=normals)
    raise ValueError(f"{path} is not an OBJ or PLY mesh (its name should end in .obj or .ply)")
