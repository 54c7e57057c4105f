"""Reading mesh files defensively: OBJ and PLY for :meth:`reference_tracer.Mesh.load`, and the
checks Mitsuba ``.serialized`` meshes pass before Mitsuba loads them. One module a job:
``checks`` (a file refused before any parser allocates for it: not a regular file, a PLY
header that declares more than its bytes hold, a mesh too large for the memory available; and
before Mitsuba loads it, a triangle whose vertex index is past the vertices),
``obj`` (OBJ text parsed as Mitsuba's ``obj`` plugin reads it), ``ply`` (PLY through trimesh,
with normals, texture coordinates and attributes as Mitsuba's ``ply`` reads them),
``serialized`` (a ``.serialized`` file's header), ``data`` (``MeshData``, what a file holds)
and ``reader`` (:func:`read_mesh`: a file's kind told from its bytes and name, then parsed).
The names other code uses are exported here.
"""
from .checks import check_mesh_file, check_ply_faces, check_serialized_file, ply_faces, ply_header_counts
from .data import MeshData
from .obj import check_obj_faces, decode_obj, obj_undefined_normal, parse_obj
from .ply import ply_attributes
from .reader import read_mesh
from .serialized import serialized_faces, serialized_header

__all__ = ["read_mesh", "ply_attributes", "decode_obj", "check_obj_faces", "check_mesh_file", "ply_header_counts",
           "parse_obj", "obj_undefined_normal", "MeshData", "check_serialized_file", "serialized_header",
           "check_ply_faces", "ply_faces", "serialized_faces"]
