"""The base :class:`Shape` and the shapes given by a few points: Sphere, Quad, Box, Triangle.

Each shape is immutable and carries a similarity transform (rotation, uniform scale,
translation) that the transform methods compose; ``world_*`` methods return the
geometry after the transform, which is what both renderers consume. (The triangle mesh,
built on :class:`Shape`, is :mod:`reference_tracer.mesh`; distance queries over shapes,
:mod:`reference_tracer.distances`.)

Orientation conventions (docs/conventions.md): a quad's normal is
``u x v``; a triangle's front face is counter-clockwise (``(b - a) x (c - a)``);
a box's faces point outward; ``flip_normals=True`` reverses the front side.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .validation import finite_scalar, vector3
from .materials import Material
from .textures import Texture

__all__ = ["Shape", "Sphere", "Quad", "Box", "Triangle", "rotation_matrix", "IDENTITY", "spans_area"]

#: the identity transform, every shape's default.
IDENTITY = tuple(map(tuple, np.eye(4)))


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
    transform: tuple = field(default=IDENTITY, repr=False)

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


def spans_area(u, v):
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
    transform: tuple = field(default=IDENTITY, repr=False)

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
        if not spans_area(u, v):
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
    transform: tuple = field(default=IDENTITY, repr=False)

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
        if any(not spans_area(u, v) for _, u, v in self.world_quads()):
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
    transform: tuple = field(default=IDENTITY, repr=False)

    def __post_init__(self):
        self._set_vectors("a", "b", "c")
        n = np.cross(np.subtract(self.b, self.a), np.subtract(self.c, self.a))
        if np.linalg.norm(n) == 0.0:
            raise ValueError(f"Triangle has zero area (collinear or repeated vertices): {self.a}, {self.b}, {self.c}")
        self._post()

    def _check_world(self) -> None:
        a, b, c = self.world_vertices()
        if not spans_area(b - a, c - a):
            raise self._collapsed("area")

    def world_vertices(self) -> np.ndarray:
        a, b, c = (self._point(p) for p in (self.a, self.b, self.c))
        return np.array([a, c, b] if self.flip_normals else [a, b, c])

    def _describe_geometry(self):
        return {"a": self.a, "b": self.b, "c": self.c}

