"""The triangle mesh shape, :class:`Mesh`: its vertex, face, normal, texture coordinate and
attribute arrays checked on construction, loaded from a mesh file (:meth:`Mesh.load`, through
:mod:`reference_tracer.meshfile`), and the vertex normals Mitsuba computes for a file without
any (:func:`vertex_normals`).
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from .material_textures import textures_of
from .materials import Material
from .meshfile import read_mesh
from .shapes import IDENTITY, Shape, spans_area
from .validation import check_face_indices, not_directions

__all__ = ["Mesh", "vertex_normals"]


@dataclass(frozen=True, eq=False)
class Mesh(Shape):
    """Triangle mesh from an (N, 3) vertex array and an (M, 3) integer face array.

    Faces are counter-clockwise seen from the front, as in OBJ and PLY. Degenerate
    (zero-area) faces are allowed and never hit, but a mesh with no face of non-zero area
    is refused.

    Shading: without ``normals`` the mesh is shaded flat (each triangle's own normal).
    With ``normals``, an (N, 3) array of per-vertex normals (object space, any non-zero
    length), it is shaded smooth as Mitsuba shades a mesh with vertex normals: the
    shading normal at a point is the normalised interpolation of its triangle's vertex
    normals (barycentric weights); it sets the BSDF's frame, which side of a surface
    emits and reflects, and the cosine of light sampling on an emitting mesh, while rays
    still leave along the geometric normal. Like Mitsuba, nothing reconciles the two
    normals: where they disagree, light may leak through or a region go black
    (docs/conventions.md). The normals follow the transform as normals do (its inverse transpose)
    and flip with ``flip_normals``.

    Texture coordinates: ``uv``, an (N, 2) array of per-vertex coordinates, interpolated
    by the barycentrics as Mitsuba's mesh does (a file's: :meth:`load`); without it a
    triangle's coordinates are its barycentrics, ``(0, 0)``, ``(1, 0)`` and ``(0, 1)`` at
    its corners in the face's order, as Mitsuba's mesh without texture coordinates.

    Attributes: ``attributes``, Mitsuba's mesh attributes, a dict from names to arrays:
    ``vertex_*`` ones (N, C), one row per vertex, ``face_*`` ones (M, C), one row per face,
    C from 1 to 4 channels, finite; what a :class:`reference_tracer.MeshAttribute` texture
    reads (a file's: :meth:`load`).

    Examples
    --------
    >>> import numpy as np
    >>> from reference_tracer import Lambertian
    >>> m = Mesh(np.eye(3), [[0, 1, 2]], Lambertian(0.5))
    >>> m.world_vertices().shape
    (3, 3)
    >>> s = Mesh(np.eye(3), [[0, 1, 2]], Lambertian(0.5), normals=[[1, 1, 1], [1, 1, 2], [2, 1, 1]])
    >>> s.world_normals().round(3).tolist()[0]
    [0.577, 0.577, 0.577]
    """

    vertices: np.ndarray
    faces: np.ndarray
    material: Material
    flip_normals: bool = False
    transform: tuple = field(default=IDENTITY, repr=False)
    normals: np.ndarray | None = field(default=None, repr=False)
    uv: np.ndarray | None = field(default=None, repr=False, kw_only=True)
    attributes: dict | None = field(default=None, repr=False, kw_only=True)

    def __post_init__(self):
        try:
            v = np.array(self.vertices, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("Mesh.vertices must be an (N, 3) array of numbers") from None
        if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
            raise ValueError(f"Mesh.vertices must have shape (N, 3) with N > 0, got {v.shape}")
        if not np.all(np.isfinite(v)):
            bad = int(np.argwhere(~np.isfinite(v))[0][0])
            raise ValueError(f"Mesh.vertices must be finite; vertex {bad} is {v[bad].tolist()}")
        f = np.asarray(self.faces)
        if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] == 0:
            raise ValueError(f"Mesh.faces must have shape (M, 3) with M > 0, got {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            if np.issubdtype(f.dtype, np.floating) and np.all(np.isfinite(f)) and np.all(f == np.round(f)):
                f = f.astype(np.int64)
            else:
                raise ValueError(f"Mesh.faces must hold integer vertex indices, got dtype {f.dtype}")
        f = f.astype(np.int64)
        check_face_indices(f, v.shape[0], "Mesh.faces")
        v.setflags(write=False)
        f.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)
        if self.normals is not None:
            object.__setattr__(self, "normals", _check_normals(self.normals, v.shape[0]))
        if self.uv is not None:
            object.__setattr__(self, "uv", _check_uv(self.uv, v.shape[0]))
        if self.attributes is not None:
            object.__setattr__(self, "attributes", _check_attributes(self.attributes, v.shape[0], f.shape[0]))
        self._post()

    @classmethod
    def load(cls, path, material: Material, *, flip_normals: bool = False, face_normals: bool = False,
             flip_tex_coords: bool | None = None) -> "Mesh":
        """Read an OBJ or PLY file, with its normals as Mitsuba's ``obj`` and ``ply`` read them.

        Shading follows Mitsuba's loaders: the file's vertex normals (OBJ ``vn``, PLY
        ``nx ny nz``) where it has them; where it has none, normals computed from the faces
        (each vertex: the sum of its faces' unit normals weighted by the face's angle
        there, normalised), so a mesh file without normals is shaded smooth; with
        ``face_normals=True`` no normals at all (flat shading), whatever the file holds.
        An OBJ's vertices are one per distinct (position, texture, normal) index triple of
        its faces, in the order the faces first use them, and polygons are split into fans,
        as Mitsuba does.

        Attributes (:attr:`attributes`): a PLY's other vertex and face properties, as
        Mitsuba's ``ply`` groups them (:func:`reference_tracer.meshfile.ply_attributes`):
        ``r g b`` or ``red green blue`` (``a``/``alpha`` a fourth channel) become
        ``vertex_color`` / ``face_color``, ``{prefix}_x y z`` (or ``r g b``, ``0 1 2``,
        ``1 2 3``) ``vertex_{prefix}`` (``_color`` after a prefix of ``r g b`` fields).

        Texture coordinates, where the material has a texture: the file's (OBJ ``vt``,
        PLY ``u v``, ``texture_u texture_v`` or ``s t``), with ``v`` replaced by ``1 - v``
        when ``flip_tex_coords`` (Mitsuba's default: True for OBJ, False for PLY); where the
        file has none, each triangle's barycentrics (Mitsuba's). A face corner without a
        texture coordinate in a file with them (Mitsuba would leave it undefined) raises
        ``ValueError``.

        An OBJ's text may be UTF-8 or Latin-1 (a comment with an accented name); an OBJ
        face index 0 (indices start at 1), a normal that is zero or not a number, a face
        corner without a normal in a file that has normals (Mitsuba would leave that
        normal undefined) and a file that is neither OBJ nor PLY raise ``ValueError``
        (:func:`reference_tracer.meshfile.read_mesh`).

        Examples
        --------
        >>> Mesh.load("bunny.ply", Lambertian(0.5))  # doctest: +SKIP
        """
        m = read_mesh(path, normals=not face_normals)
        if len(m.faces) == 0:
            raise ValueError(f"Mesh.load: {path!s} holds no triangles")
        check_face_indices(m.faces, len(m.vertices), f"Mesh.load: {path!s}")  # before normals use them
        normals = None
        if not face_normals:
            normals = m.normals if m.normals is not None else vertex_normals(m.vertices, m.faces)
            try:
                normals = _check_normals(normals, len(m.vertices))
            except ValueError as exc:
                raise ValueError(f"{path!s}: {exc}") from None
        uv = None
        if textures_of(material) and m.uv is not None:
            used = np.zeros(len(m.vertices), dtype=bool)
            used[m.faces.ravel()] = True
            if np.isnan(m.uv[used]).any():
                raise ValueError(f"Mesh.load: {path!s}: a face corner without a texture coordinate, in a file with "
                                 "them (Mitsuba leaves that vertex's coordinates undefined)")
            if flip_tex_coords is None:   # Mitsuba's defaults: OBJ flips, PLY does not
                with open(path, "rb") as fh:
                    flip = fh.read(3) != b"ply"
            else:
                flip = bool(flip_tex_coords)
            uv = np.where(used[:, None], m.uv, 0.0)
            if flip:
                uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])
        attributes = m.attributes or None
        return cls(m.vertices, m.faces, material, flip_normals=flip_normals, normals=normals, uv=uv,
                   attributes=attributes)

    def _check_world(self) -> None:
        w = self.world_vertices()

        def any_area(faces) -> bool:
            t = w[faces]
            return bool(np.any(spans_area(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])))

        # the first faces almost always decide it: the whole mesh only when they are all degenerate
        if not any_area(self.faces[:1024]) and not any_area(self.faces):
            raise ValueError(f"Mesh has zero area{' after its transform' if self.transform != IDENTITY else ''}: "
                             f"all {len(self.faces)} triangles are degenerate (collinear or repeated vertices)")
        if self.normals is not None:
            n = self._normal_directions()
            bad = not_directions(n)
            if bad.any():
                i = int(np.argmax(bad))
                raise ValueError(f"Mesh.normals[{i}] = {self.normals[i].tolist()} vanishes under Mesh.transform "
                                 "(singular in its direction): its shading normal would be undefined")

    def world_vertices(self) -> np.ndarray:
        m = self.matrix
        return self.vertices @ m[:3, :3].T + m[:3, 3]

    def world_triangles(self) -> np.ndarray:
        """(M, 3, 3) world-space triangles, winding reversed when the normals are flipped."""
        f = self.faces[:, [0, 2, 1]] if self.flip_normals else self.faces
        return self.world_vertices()[f]

    def _normal_directions(self) -> np.ndarray:
        """The vertex normals through the transform's inverse transpose, unnormalised: the
        transpose of the cofactor matrix, signed by the determinant (defined where the
        linear part is singular too, for the normals it does not collapse)."""
        lin = self.matrix[:3, :3]
        # rows: the cross products of the columns, cyclically (= det * inv(lin)); n @ rows is
        # det * inv(lin).T @ n for each normal n
        rows = np.cross(lin[:, [1, 2, 0]].T, lin[:, [2, 0, 1]].T)
        sign = -1.0 if np.linalg.det(lin) < 0 else 1.0
        # normals scaled to a largest component of 1 first: no overflow or underflow on the way
        n = self.normals / np.max(np.abs(self.normals), axis=1, keepdims=True)
        return sign * (n @ rows)

    def world_normals(self) -> np.ndarray | None:
        """(N, 3) unit world-space vertex normals (negated when the normals are flipped), or
        None for a flat-shaded mesh."""
        if self.normals is None:
            return None
        n = self._normal_directions()
        n = n / np.max(np.abs(n), axis=1, keepdims=True)
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        return -n if self.flip_normals else n

    def world_triangle_normals(self) -> np.ndarray | None:
        """(M, 3, 3) unit world-space normals at each triangle's corners, in the order of
        :meth:`world_triangles` (None when flat)."""
        n = self.world_normals()
        if n is None:
            return None
        f = self.faces[:, [0, 2, 1]] if self.flip_normals else self.faces
        return n[f]

    def _describe_geometry(self):
        data = self.vertices.tobytes() + self.faces.tobytes()
        if self.normals is not None:  # flat meshes keep the hashes they always had
            data += b"normals" + self.normals.tobytes()
        if self.uv is not None:  # and meshes without texture coordinates theirs
            data += b"uv" + self.uv.tobytes()
        for name in sorted(self.attributes or {}):  # and meshes without attributes theirs
            a = self.attributes[name]
            data += b"attribute" + name.encode() + str(a.shape).encode() + a.tobytes()
        h = hashlib.sha256(data).hexdigest()
        return {"mesh_sha256": h, "n_vertices": int(len(self.vertices)), "n_faces": int(len(self.faces))}


def _per_vertex(field_name: str, value, n_vertices: int, width: int, bad_rows, requirement: str) -> np.ndarray:
    """``Mesh.<field_name>`` as a read-only (N, ``width``) float64 array, one row per vertex;
    ``ValueError`` at the first row that ``bad_rows`` (array -> one bool a row) marks, saying
    ``requirement``. The one reading of :func:`_check_uv` and :func:`_check_normals`."""
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"Mesh.{field_name} must be an (N, {width}) array of numbers") from None
    if a.shape != (n_vertices, width):
        raise ValueError(f"Mesh.{field_name} must have one row per vertex, shape ({n_vertices}, {width}), "
                         f"got {a.shape}")
    bad = bad_rows(a)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"Mesh.{field_name}[{i}] is {a[i].tolist()}: {requirement}")
    a.setflags(write=False)
    return a


def _check_uv(uv, n_vertices: int) -> np.ndarray:
    """Per-vertex texture coordinates as a read-only (N, 2) float64 array, finite.

    Examples
    --------
    >>> _check_uv([[0, 1]], 1).tolist()
    [[0.0, 1.0]]
    >>> _check_uv([[0, np.nan]], 1)
    Traceback (most recent call last):
    ...
    ValueError: Mesh.uv[0] is [0.0, nan]: texture coordinates must be finite
    """
    return _per_vertex("uv", uv, n_vertices, 2, lambda a: ~np.all(np.isfinite(a), axis=1),
                       "texture coordinates must be finite")


def _check_attributes(attributes, n_vertices: int, n_faces: int) -> dict:
    """Mesh attributes as a dict of read-only (rows, C) float32 arrays (Mitsuba stores them in
    single precision): ``vertex_*`` one row per vertex, ``face_*`` one per face, 1 to 4
    channels, finite.

    Examples
    --------
    >>> _check_attributes({"face_color": [[0.5, 0.25, 1.0]]}, 3, 1)["face_color"].tolist()
    [[0.5, 0.25, 1.0]]
    >>> _check_attributes({"vertex_color": [[0.5], [np.nan], [1.0]]}, 3, 1)
    Traceback (most recent call last):
    ...
    ValueError: Mesh.attributes['vertex_color'][1] is [nan]: attribute values must be finite
    """
    if not isinstance(attributes, dict):
        raise ValueError(f"Mesh.attributes must be a dict of arrays, got {type(attributes).__name__}")
    out = {}
    for name, value in attributes.items():
        if not isinstance(name, str) or not name.startswith(("vertex_", "face_")) or name in ("vertex_", "face_"):
            raise ValueError(f"Mesh.attributes: a name must start with 'vertex_' or 'face_', got {name!r}")
        rows = n_vertices if name.startswith("vertex_") else n_faces
        try:
            a = np.array(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"Mesh.attributes[{name!r}] must be an array of numbers") from None
        if a.ndim == 1:
            a = a.reshape(-1, 1)
        if a.ndim != 2 or a.shape[0] != rows or not 1 <= a.shape[1] <= 4:
            raise ValueError(f"Mesh.attributes[{name!r}] must have one row per {name.split('_')[0]} and 1 to 4 "
                             f"channels, shape ({rows}, C), got {a.shape}")
        bad = ~np.all(np.isfinite(a), axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"Mesh.attributes[{name!r}][{i}] is {a[i].tolist()}: attribute values must be finite")
        a = a.astype(np.float32)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"Mesh.attributes[{name!r}]: values beyond single precision")
        a.setflags(write=False)
        out[name] = a
    return out


def _check_normals(normals, n_vertices: int) -> np.ndarray:
    """Per-vertex normals as a read-only (N, 3) float64 array: finite and non-zero.

    Examples
    --------
    >>> _check_normals([[0, 0, 2]], 1).tolist()
    [[0.0, 0.0, 2.0]]
    >>> _check_normals([[0, 0, 0]], 1)
    Traceback (most recent call last):
    ...
    ValueError: Mesh.normals[0] is [0.0, 0.0, 0.0]: a vertex normal must be finite and non-zero
    """
    return _per_vertex("normals", normals, n_vertices, 3, not_directions,
                       "a vertex normal must be finite and non-zero")


def _unit_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles between unit vectors (rows), stably near 0 and pi (Mitsuba's unit_angle)."""
    d = np.einsum("ij,ij->i", a, b)
    plus = np.linalg.norm(a + b, axis=1)
    minus = np.linalg.norm(a - b, axis=1)
    return np.where(d < 0, np.pi - 2.0 * np.arcsin(np.minimum(plus / 2, 1.0)), 2.0 * np.arcsin(np.minimum(minus / 2, 1.0)))


def vertex_normals(vertices, faces) -> np.ndarray:
    """Vertex normals as Mitsuba computes them for a mesh file without any
    (``Mesh::recompute_vertex_normals``): each vertex gets the sum, over the faces using it,
    of the face's unit normal times the face's angle at that vertex (Thuermer and Wuethrich
    1998), normalised; a vertex of no face of non-zero area gets (1, 0, 0).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> vertex_normals(v, [[0, 1, 2]]).tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(p1 - p0, p2 - p0)
    length = np.linalg.norm(n, axis=1)
    ok = length > 0
    n, f, p0, p1, p2 = n[ok] / length[ok, None], f[ok], p0[ok], p1[ok], p2[ok]

    def unit(x):
        norm = np.linalg.norm(x, axis=1, keepdims=True)
        return x / np.where(norm > 0, norm, 1.0)

    angles = (_unit_angle(unit(p1 - p0), unit(p2 - p0)),
              _unit_angle(unit(p2 - p1), unit(p0 - p1)),
              _unit_angle(unit(p0 - p2), unit(p1 - p2)))
    out = np.zeros_like(v)
    for j in range(3):
        np.add.at(out, f[:, j], n * angles[j][:, None])
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return np.where(norm > 0, out / np.where(norm > 0, norm, 1.0), np.array([1.0, 0.0, 0.0]))
