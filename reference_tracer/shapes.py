"""Shapes of the scene model: Sphere, Quad, Box, Triangle, Mesh.

Each shape is immutable and carries a similarity transform (rotation, uniform scale,
translation) that the transform methods compose; ``world_*`` methods return the
geometry after the transform, which is what both renderers consume.

Orientation conventions (docs/conventions.md): a quad's normal is
``u x v``; a triangle's front face is counter-clockwise (``(b - a) x (c - a)``);
a box's faces point outward; ``flip_normals=True`` reverses the front side.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace

import numpy as np

from .validation import finite_scalar, vector3
from .materials import Material, textures_of
from .meshfile import read_mesh
from .textures import Texture

__all__ = ["Shape", "Sphere", "Quad", "Box", "Triangle", "Mesh", "rotation_matrix", "vertex_normals", "surface_within",
           "farthest_distance"]

_IDENTITY = tuple(map(tuple, np.eye(4)))


def rotation_matrix(axis, degrees: float) -> np.ndarray:
    """4x4 rotation about ``axis`` (through the origin) by ``degrees``, right-handed."""
    a = np.asarray(vector3("rotate.axis", axis))
    n = np.linalg.norm(a)
    if n == 0:
        raise ValueError("rotate.axis must be a non-zero vector")
    x, y, z = a / n
    t = math.radians(finite_scalar("rotate.degrees", degrees))
    c, s, C = math.cos(t), math.sin(t), 1.0 - math.cos(t)
    m = np.eye(4)
    m[:3, :3] = [[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                 [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                 [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]
    return m


def _check_material(owner: str, material) -> Material:
    if not isinstance(material, Material):
        raise ValueError(f"{owner}.material must be a reference_tracer material, got {material!r}")
    return material


@dataclass(frozen=True, eq=False)
class Shape:
    """Base of all shapes: a material, a front-side flag and a similarity transform."""

    def _post(self):
        name = type(self).__name__
        object.__setattr__(self, "material", _check_material(name, self.material))
        object.__setattr__(self, "flip_normals", bool(self.flip_normals))
        m = np.asarray(self.transform, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise ValueError(f"{name}.transform must be a finite 4x4 matrix")
        if np.any(m[3, :3] != 0.0) or m[3, 3] != 1.0:
            # a projective row is not an affine map: Mitsuba would divide by w, we would not
            raise ValueError(f"{name}.transform must be affine (last row 0 0 0 1), got {m[3].tolist()}")
        object.__setattr__(self, "transform", tuple(map(tuple, m)))
        self._check_world()

    def _set_vectors(self, *names) -> None:
        """Each field of ``names`` as a finite 3-vector (:func:`vector3`), named ``Class.field`` in errors."""
        for name in names:
            object.__setattr__(self, name, vector3(f"{type(self).__name__}.{name}", getattr(self, name)))

    def _check_world(self) -> None:
        """Refuse geometry that the transform collapsed (zero area or volume): it would never
        be hit, and a light of it would render black. Shapes override it."""

    def _collapsed(self, what: str) -> ValueError:
        kind = " light" if self.material.emits else ""
        rows = "; ".join(" ".join(f"{x:g}" for x in r) for r in self.transform)
        return ValueError(f"{type(self).__name__}{kind} has zero {what} after its transform: "
                          f"{type(self).__name__}.transform [{rows}] is singular in the shape's plane")

    # -- transforms ---------------------------------------------------------
    @property
    def matrix(self) -> np.ndarray:
        """The object-to-world 4x4 matrix."""
        return np.array(self.transform)

    @property
    def scale_factor(self) -> float:
        """The uniform scale of the transform (cube root of the linear part's determinant)."""
        return float(np.cbrt(np.linalg.det(self.matrix[:3, :3])))

    def _compose(self, m: np.ndarray):
        return replace(self, transform=tuple(map(tuple, m @ self.matrix)))

    def translate(self, offset):
        """Return a copy moved by ``offset`` (applied after the existing transform)."""
        m = np.eye(4)
        m[:3, 3] = vector3("translate.offset", offset)
        return self._compose(m)

    def rotate(self, axis, degrees: float):
        """Return a copy rotated by ``degrees`` about ``axis`` through the origin."""
        return self._compose(rotation_matrix(axis, degrees))

    def rotate_x(self, degrees: float):
        return self.rotate((1, 0, 0), degrees)

    def rotate_y(self, degrees: float):
        return self.rotate((0, 1, 0), degrees)

    def rotate_z(self, degrees: float):
        return self.rotate((0, 0, 1), degrees)

    def scale(self, factor: float):
        """Return a copy scaled uniformly by ``factor`` > 0 about the origin."""
        f = finite_scalar("scale.factor", factor, lo=0.0, lo_open=True)
        m = np.eye(4)
        m[:3, :3] *= f
        return self._compose(m)

    def _point(self, p) -> np.ndarray:
        m = self.matrix
        return m[:3, :3] @ np.asarray(p, dtype=np.float64) + m[:3, 3]

    def _vector(self, v) -> np.ndarray:
        return self.matrix[:3, :3] @ np.asarray(v, dtype=np.float64)

    def describe(self) -> dict:
        """A JSON-able description (used for hashing scenes)."""
        d = {"type": type(self).__name__, "material": _describe_material(self.material),
             "flip_normals": self.flip_normals, "transform": [list(r) for r in self.transform]}
        d.update(self._describe_geometry())
        return d


def _describe_material(m: Material) -> dict:
    d = {"type": type(m).__name__}
    d.update({k: (v.describe() if isinstance(v, Texture) else _describe_material(v) if isinstance(v, Material)
                  else v) for k, v in m.__dict__.items()})
    return d


@dataclass(frozen=True, eq=False)
class Sphere(Shape):
    """Sphere of ``radius`` > 0 about ``center``; outward normals unless flipped.

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> Sphere((0, 0, 0), 1.0, Lambertian(0.5)).translate((0, 1, 0)).world_center().tolist()
    [0.0, 1.0, 0.0]
    """

    center: tuple
    radius: float
    material: Material
    flip_normals: bool = False
    transform: tuple = field(default=_IDENTITY, repr=False)

    def __post_init__(self):
        self._set_vectors("center")
        object.__setattr__(self, "radius", finite_scalar("Sphere.radius", self.radius, lo=0.0, lo_open=True))
        self._post()
        _check_similarity("Sphere.transform", self.matrix)

    def world_center(self) -> np.ndarray:
        return self._point(self.center)

    def world_radius(self) -> float:
        return self.radius * self.scale_factor

    def _describe_geometry(self):
        return {"center": self.center, "radius": self.radius}


def _spans_area(u, v):
    """Whether edges ``u`` and ``v`` (3-vectors, or arrays of them) span a non-zero area,
    relative to their lengths (a relative test: the scale of a scene does not matter)."""
    u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
    cross = np.linalg.norm(np.cross(u, v), axis=-1)
    return cross > 1e-12 * np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1)


def _check_similarity(name: str, m: np.ndarray) -> None:
    """Refuse a transform that does not keep a sphere a sphere of positive radius.

    Only rotation, uniform scale and translation (a similarity) are allowed: a
    non-uniform scale would need an ellipsoid, a mirror (negative determinant) turns the
    normals inside out, a singular matrix collapses the sphere, and a projective last row
    is not an affine map. ``to_mitsuba`` refuses the same transforms.

    Examples
    --------
    >>> _check_similarity("t", np.diag([2.0, 2.0, 2.0, 1.0]))
    >>> _check_similarity("t", np.diag([1.0, 5.0, 1.0, 1.0]))
    Traceback (most recent call last):
    ...
    ValueError: t must be a similarity (rotation, uniform scale, translation): its linear part scales unequally along different axes (singular values 1, 1, 5); a sphere cannot become an ellipsoid
    """
    if np.any(m[3, :3] != 0.0) or m[3, 3] != 1.0:
        raise ValueError(f"{name} must be affine (last row 0 0 0 1), got {m[3].tolist()}")
    lin = m[:3, :3]
    sv = np.linalg.svd(lin, compute_uv=False)
    det = float(np.linalg.det(lin))
    if not sv[-1] > 1e-12 * max(sv[0], 1e-300):
        raise ValueError(f"{name} is singular (determinant {det:.6g}): it collapses the sphere")
    if not det > 0:
        raise ValueError(f"{name} is a mirror (determinant {det:.6g} < 0): it turns the sphere inside out; "
                         "use flip_normals instead")
    if sv[0] - sv[-1] > 1e-6 * sv[0]:
        raise ValueError(f"{name} must be a similarity (rotation, uniform scale, translation): its linear part "
                         f"scales unequally along different axes (singular values "
                         f"{', '.join(f'{v:.6g}' for v in sorted(sv))}); a sphere cannot become an ellipsoid")


@dataclass(frozen=True, eq=False)
class Quad(Shape):
    """Parallelogram ``Q + s u + t v`` for s, t in [0, 1]; normal ``u x v``.

    Examples
    --------
    >>> from reference_tracer import DiffuseLight
    >>> q = Quad((213, 554, 227), (130, 0, 0), (0, 0, 105), DiffuseLight(15))
    >>> q.world_normal().tolist()
    [0.0, -1.0, 0.0]
    """

    Q: tuple
    u: tuple
    v: tuple
    material: Material
    flip_normals: bool = False
    transform: tuple = field(default=_IDENTITY, repr=False)

    def __post_init__(self):
        self._set_vectors("Q", "u", "v")
        n = np.cross(self.u, self.v)
        scale = max(np.linalg.norm(self.u) * np.linalg.norm(self.v), 1e-300)
        if np.linalg.norm(n) <= 1e-12 * scale:
            kind = "light " if isinstance(self.material, Material) and self.material.emits else ""
            raise ValueError(f"Quad {kind}has zero area: Quad.u x Quad.v is zero (u={self.u}, v={self.v})")
        self._post()

    def _check_world(self) -> None:
        _, u, v = self.world_corners()
        if not _spans_area(u, v):
            raise self._collapsed("area")

    def world_corners(self):
        """(Q, u, v) in world space, with u and v swapped when the normal is flipped."""
        Q, u, v = self._point(self.Q), self._vector(self.u), self._vector(self.v)
        return (Q, v, u) if self.flip_normals else (Q, u, v)

    def world_normal(self) -> np.ndarray:
        _, u, v = self.world_corners()
        n = np.cross(u, v)
        return n / np.linalg.norm(n)

    def area(self) -> float:
        _, u, v = self.world_corners()
        return float(np.linalg.norm(np.cross(u, v)))

    def _describe_geometry(self):
        return {"Q": self.Q, "u": self.u, "v": self.v}


@dataclass(frozen=True, eq=False)
class Box(Shape):
    """Axis-aligned box ``[pmin, pmax]`` (before its transform) of six outward quads.

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> b = Box((0, 0, 0), (165, 330, 165), Lambertian(0.73)).rotate_y(15).translate((265, 0, 295))
    >>> len(b.world_quads())
    6
    """

    pmin: tuple
    pmax: tuple
    material: Material
    flip_normals: bool = False
    transform: tuple = field(default=_IDENTITY, repr=False)

    def __post_init__(self):
        self._set_vectors("pmin", "pmax")
        if any(a >= b for a, b in zip(self.pmin, self.pmax)):
            raise ValueError(f"Box.pmin must be < Box.pmax in every axis, got {self.pmin} and {self.pmax}")
        self._post()

    def local_quads(self):
        """The six faces as (Q, u, v) in object space, each with an outward normal u x v."""
        (x0, y0, z0), (x1, y1, z1) = self.pmin, self.pmax
        dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
        return [
            ((x0, y0, z1), (dx, 0, 0), (0, dy, 0)),    # +z
            ((x1, y0, z0), (-dx, 0, 0), (0, dy, 0)),   # -z
            ((x1, y0, z1), (0, 0, -dz), (0, dy, 0)),   # +x
            ((x0, y0, z0), (0, 0, dz), (0, dy, 0)),    # -x
            ((x0, y1, z1), (dx, 0, 0), (0, 0, -dz)),   # +y
            ((x0, y0, z0), (dx, 0, 0), (0, 0, dz)),    # -y
        ]

    def _check_world(self) -> None:
        if any(not _spans_area(u, v) for _, u, v in self.world_quads()):
            raise self._collapsed("volume")

    def world_quads(self):
        out = []
        for Q, u, v in self.local_quads():
            Qw, uw, vw = self._point(Q), self._vector(u), self._vector(v)
            out.append((Qw, vw, uw) if self.flip_normals else (Qw, uw, vw))
        return out

    def _describe_geometry(self):
        return {"pmin": self.pmin, "pmax": self.pmax}


@dataclass(frozen=True, eq=False)
class Triangle(Shape):
    """Triangle ``a, b, c``; counter-clockwise (``(b-a) x (c-a)``) is the front face.

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0), Lambertian(0.5)).world_vertices()[2].tolist()
    [0.0, 1.0, 0.0]
    """

    a: tuple
    b: tuple
    c: tuple
    material: Material
    flip_normals: bool = False
    transform: tuple = field(default=_IDENTITY, repr=False)

    def __post_init__(self):
        self._set_vectors("a", "b", "c")
        n = np.cross(np.subtract(self.b, self.a), np.subtract(self.c, self.a))
        if np.linalg.norm(n) == 0.0:
            raise ValueError(f"Triangle has zero area (collinear or repeated vertices): {self.a}, {self.b}, {self.c}")
        self._post()

    def _check_world(self) -> None:
        a, b, c = self.world_vertices()
        if not _spans_area(b - a, c - a):
            raise self._collapsed("area")

    def world_vertices(self) -> np.ndarray:
        a, b, c = (self._point(p) for p in (self.a, self.b, self.c))
        return np.array([a, c, b] if self.flip_normals else [a, b, c])

    def _describe_geometry(self):
        return {"a": self.a, "b": self.b, "c": self.c}


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
    transform: tuple = field(default=_IDENTITY, repr=False)
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
        if f.min() < 0 or f.max() >= v.shape[0]:
            bad = int(np.argwhere((f < 0) | (f >= v.shape[0]))[0][0])
            raise ValueError(f"Mesh.faces index out of range [0, {v.shape[0]}): face {bad} is {f[bad].tolist()}")
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
            return bool(np.any(_spans_area(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])))

        # the first faces almost always decide it: the whole mesh only when they are all degenerate
        if not any_area(self.faces[:1024]) and not any_area(self.faces):
            raise ValueError(f"Mesh has zero area{' after its transform' if self.transform != _IDENTITY else ''}: "
                             f"all {len(self.faces)} triangles are degenerate (collinear or repeated vertices)")
        if self.normals is not None:
            n = self._normal_directions()
            bad = ~(np.all(np.isfinite(n), axis=1) & np.any(n != 0.0, axis=1))
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
    try:
        a = np.array(uv, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("Mesh.uv must be an (N, 2) array of numbers") from None
    if a.shape != (n_vertices, 2):
        raise ValueError(f"Mesh.uv must have one row per vertex, shape ({n_vertices}, 2), got {a.shape}")
    bad = ~np.all(np.isfinite(a), axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"Mesh.uv[{i}] is {a[i].tolist()}: texture coordinates must be finite")
    a.setflags(write=False)
    return a


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
    try:
        n = np.array(normals, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("Mesh.normals must be an (N, 3) array of numbers") from None
    if n.shape != (n_vertices, 3):
        raise ValueError(f"Mesh.normals must have one row per vertex, shape ({n_vertices}, 3), got {n.shape}")
    bad = ~(np.all(np.isfinite(n), axis=1) & np.any(n != 0.0, axis=1))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"Mesh.normals[{i}] is {n[i].tolist()}: a vertex normal must be finite and non-zero")
    n.setflags(write=False)
    return n


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


# --------------------------------------------------------------------------- distances
#: triangles a distance query holds in memory at once (a mesh file may have millions).
_CHUNK = 1 << 16


def _triangles(shape):
    """The world-space triangles of a shape other than a sphere, as chunks of (K, 3, 3) arrays."""
    if isinstance(shape, Mesh):
        v = shape.world_vertices()
        for start in range(0, len(shape.faces), _CHUNK):
            yield v[shape.faces[start:start + _CHUNK]]
        return
    if isinstance(shape, Triangle):
        yield shape.world_vertices()[None]
        return
    quads = [shape.world_corners()] if isinstance(shape, Quad) else shape.world_quads()
    yield np.array([t for Q, u, v in quads for t in ((Q, Q + u, Q + u + v), (Q, Q + u + v, Q + v))])


def _point_triangle_distances(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distances from point ``p`` to each triangle of ``tri`` (K, 3, 3): to its plane where
    the foot of the perpendicular lies inside it, else to its nearest edge; infinite for a
    triangle of zero area (a mesh may hold some: they are never hit)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    area = nn > 0.0
    nn = np.where(area, nn, 1.0)
    offset = np.einsum("ij,ij->i", p - a, n) / nn
    foot = p - offset[:, None] * n
    inside = np.ones(len(tri), dtype=bool)
    edge = np.full(len(tri), np.inf)
    for s, e in ((a, b), (b, c), (c, a)):
        d = e - s
        dd = np.einsum("ij,ij->i", d, d)
        inside &= np.einsum("ij,ij->i", np.cross(d, foot - s), n) >= 0.0
        t = np.clip(np.einsum("ij,ij->i", p - s, d) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
        edge = np.minimum(edge, np.linalg.norm(p - (s + t[:, None] * d), axis=1))
    return np.where(area, np.where(inside, np.abs(offset) * np.sqrt(nn), edge), np.inf)


def surface_within(shapes, point, radius: float) -> bool:
    """Whether a surface of ``shapes`` (after their transforms) has a point within ``radius``
    of ``point``.

    Exact up to rounding: a sphere's surface by its centre and radius, every other shape by
    its triangles (a quad and each face of a box as two), each triangle's distance to the
    point; boxes around a mesh and its triangles skip what lies farther.

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> floor = Quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), Lambertian(0.5))
    >>> surface_within([floor], (0.5, 3.0, 0.2), 2.01), surface_within([floor], (0.5, 3.0, 0.2), 1.9)
    (True, False)
    """
    p = np.asarray(point, dtype=np.float64)
    r = float(radius)
    for shape in shapes:
        if isinstance(shape, Sphere):
            if abs(np.linalg.norm(shape.world_center() - p) - shape.world_radius()) <= r:
                return True
            continue
        if isinstance(shape, Mesh):
            v = shape.world_vertices()
            if np.linalg.norm(np.maximum(np.maximum(v.min(axis=0) - p, p - v.max(axis=0)), 0.0)) > r:
                continue
        for tri in _triangles(shape):
            gap = np.maximum(np.maximum(tri.min(axis=1) - p, p - tri.max(axis=1)), 0.0)
            near = tri[np.linalg.norm(gap, axis=1) <= r]
            if len(near) and (_point_triangle_distances(p, near) <= r).any():
                return True
    return False


def farthest_distance(shapes, point) -> float:
    """The largest distance from ``point`` to a point of the surfaces of ``shapes`` (after
    their transforms; 0 for none): a sphere's far side, every other shape's farthest vertex
    (a mesh's unused vertices count too).

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> farthest_distance([Sphere((3, 4, 0), 1.0, Lambertian(0.5))], (0, 0, 0))
    6.0
    """
    p = np.asarray(point, dtype=np.float64)
    far = 0.0
    for shape in shapes:
        if isinstance(shape, Sphere):
            far = max(far, float(np.linalg.norm(shape.world_center() - p)) + shape.world_radius())
        elif isinstance(shape, (Mesh, Triangle)):
            far = max(far, float(np.linalg.norm(shape.world_vertices() - p, axis=1).max()))
        else:
            quads = [shape.world_corners()] if isinstance(shape, Quad) else shape.world_quads()
            corners = np.array([c for Q, u, v in quads for c in (Q, Q + u, Q + v, Q + u + v)])
            far = max(far, float(np.linalg.norm(corners - p, axis=1).max()))
    return far
