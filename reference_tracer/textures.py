"""Textures of reflectances, as Mitsuba 3 defines them: the base :class:`Texture`,
``checkerboard`` and ``mesh_attribute``.

A texture gives a material's reflectance per surface point, looked up at the point's
texture coordinates ``(u, v)`` after the texture's ``to_uv`` transform. The coordinates are
Mitsuba's parameterisation of each shape (docs/conventions.md, Geometry): a sphere's spherical
angles, a quad's ``(s, t)`` along its edges, each face of a box the unit square (Mitsuba's
``cube``), a mesh's per-vertex coordinates interpolated by the barycentrics (or the
barycentrics themselves where it has none).

:class:`Checkerboard` is Mitsuba's ``checkerboard`` (``color0`` where the fractional parts of
u and v are both above one half or both not, else ``color1``). :class:`MeshAttribute` is
Mitsuba's ``mesh_attribute``: the values of a mesh's named
attribute (:attr:`reference_tracer.Mesh.attributes`), per vertex interpolated by the hit's
barycentrics or per face constant, times ``scale``; it has no texture coordinates. (Mitsuba's
``bitmap``, an image texture, is :mod:`reference_tracer.bitmap`; image files are read by
:mod:`reference_tracer.image_files`.)
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .validation import colour

__all__ = ["Texture", "Checkerboard", "MeshAttribute", "LUMINANCE", "texture_uv", "is_texture", "check_to_uv",
           "check_reflectance"]

#: the identity ``to_uv``: rows ``(a, b, c)`` and ``(d, e, f)`` of ``u' = a u + b v + c``, ``v' = d u + e v + f``.
_IDENTITY_UV = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
#: Mitsuba's luminance weights of linear sRGB (``include/mitsuba/core/spectrum.h``).
LUMINANCE = (0.212671, 0.715160, 0.072169)


def check_to_uv(owner: str, value) -> tuple:
    """A ``to_uv`` transform as the two rows of a 2-D affine map.

    Accepted: None (identity); a (2, 3) or (3, 3) affine matrix (last row ``0 0 1``); a
    (4, 4) matrix, of which Mitsuba keeps rows and columns 0 and 1 and the translation
    column 3 (``Transform::extract``: what ``<transform name="to_uv">`` gives).

    Examples
    --------
    >>> check_to_uv("t", np.diag([5.0, 5.0, 1.0, 1.0]))
    ((5.0, 0.0, 0.0), (0.0, 5.0, 0.0))
    """
    if value is None:
        return _IDENTITY_UV
    try:
        m = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}.to_uv must be a (3, 3) or (4, 4) matrix, got {value!r}") from None
    if m.shape == (4, 4):
        m = m[[0, 1]][:, [0, 1, 3]]
    elif m.shape == (3, 3):
        if not np.array_equal(m[2], [0.0, 0.0, 1.0]):
            raise ValueError(f"{owner}.to_uv must be affine (last row 0 0 1), got {m[2].tolist()}")
        m = m[:2]
    elif m.shape != (2, 3):
        raise ValueError(f"{owner}.to_uv must be a (3, 3) or (4, 4) matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError(f"{owner}.to_uv must be finite, got {m.tolist()}")
    return tuple(tuple(float(x) for x in row) for row in m)


def texture_uv(to_uv: tuple, uv) -> np.ndarray:
    """``to_uv`` (two rows of a 2-D affine map) applied to (N, 2) texture coordinates.

    Examples
    --------
    >>> texture_uv(((2.0, 0.0, 0.5), (0.0, 3.0, 0.0)), [[0.25, 0.5]]).tolist()
    [[1.0, 1.5]]
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    m = np.asarray(to_uv, dtype=np.float64)
    return uv @ m[:, :2].T + m[:, 2]


class Texture:
    """Base of the textures (not instantiated directly)."""

    to_uv: tuple

    def eval(self, uv) -> np.ndarray:
        """The texture's RGB values at (N, 2) texture coordinates (before ``to_uv``), (N, 3)."""
        raise NotImplementedError

    def mean(self) -> float:
        """Mitsuba's ``Texture::mean()``: what a plastic's lobe choice takes of it."""
        raise NotImplementedError

    def value_range(self) -> tuple:
        """The smallest and the largest value the texture takes, any channel."""
        raise NotImplementedError

    def eval_1(self, uv) -> np.ndarray:
        """Mitsuba's ``eval_1``: the texture's single value at (N, 2) texture coordinates
        (before ``to_uv``), (N,); what a ``mask``'s opacity reads."""
        return self.scalar().eval(uv)[:, 0]

    def scalar(self) -> "Texture":
        """A one-valued texture (equal channels) whose lookups are this texture's
        :meth:`eval_1`: what the core looks up for an opacity."""
        raise NotImplementedError

    def describe(self) -> dict:
        """A JSON-able description (hashed with the scene)."""
        raise NotImplementedError


def is_texture(value) -> bool:
    """Whether ``value`` is a texture (else a constant colour).

    Examples
    --------
    >>> is_texture(Checkerboard()), is_texture((0.5, 0.5, 0.5))
    (True, False)
    """
    return isinstance(value, Texture)


def check_reflectance(name: str, value):
    """``value`` as an RGB triple in [0, 1] (``validation.colour``), or a texture whose values
    lie there: a reflectance above 1 would make light.

    Raises
    ------
    ValueError
        A value outside [0, 1], not finite, or not a colour.

    Examples
    --------
    >>> check_reflectance("albedo", 0.25)
    (0.25, 0.25, 0.25)
    >>> check_reflectance("albedo", Checkerboard(0.2, 1.5))
    Traceback (most recent call last):
    ...
    ValueError: albedo: a Checkerboard texture with values in [0.2, 1.5]; a reflectance must lie in [0, 1]
    """
    if isinstance(value, MeshAttribute):  # its values are its mesh's: checked where bound to it
        return value
    if isinstance(value, Texture):
        lo, hi = value.value_range()
        if not (lo >= 0.0 and hi <= 1.0):
            raise ValueError(f"{name}: a {type(value).__name__} texture with values in [{lo:.6g}, {hi:.6g}]; a "
                             "reflectance must lie in [0, 1]")
        return value
    return colour(name, value, upper=1.0)


@dataclass(frozen=True, eq=False)
class Checkerboard(Texture):
    """Mitsuba's ``checkerboard``: two colours in a checker pattern of unit period in uv.

    At texture coordinates ``(u', v') = to_uv (u, v)`` the texture is ``color0`` where the
    fractional parts of ``u'`` and ``v'`` are both above 0.5 or both not, else ``color1``:
    cells half a unit wide, ``color0`` in the unit square's corner at the origin.

    Parameters
    ----------
    color0, color1 : float or (3,) array_like
        The two colours, each channel in [0, 1] (Mitsuba's defaults: 0.4 and 0.2).
    to_uv : array_like or None, keyword-only
        A (3, 3) affine or (4, 4) matrix applied to the coordinates first (Mitsuba's
        ``to_uv``; of a 4x4 matrix rows and columns 0, 1 and the translation are used).

    Examples
    --------
    >>> c = Checkerboard((0.1, 0.1, 0.1), 0.5, to_uv=np.diag([4.0, 4.0, 1.0]))
    >>> c.eval([[0.1, 0.1], [0.2, 0.05]]).tolist()
    [[0.1, 0.1, 0.1], [0.5, 0.5, 0.5]]
    >>> round(c.mean(), 6)
    0.3
    """

    color0: tuple = 0.4
    color1: tuple = 0.2
    to_uv: tuple | None = field(default=None, kw_only=True)

    def __post_init__(self):
        object.__setattr__(self, "color0", colour("Checkerboard.color0", self.color0, upper=None))
        object.__setattr__(self, "color1", colour("Checkerboard.color1", self.color1, upper=None))
        object.__setattr__(self, "to_uv", check_to_uv("Checkerboard", self.to_uv))

    def eval(self, uv) -> np.ndarray:
        p = texture_uv(self.to_uv, uv)
        upper = (p - np.floor(p)) > 0.5
        first = upper[:, 0] == upper[:, 1]
        return np.where(first[:, None], np.asarray(self.color0), np.asarray(self.color1))

    def mean(self) -> float:
        return 0.5 * (sum(self.color0) / 3.0 + sum(self.color1) / 3.0)

    def value_range(self) -> tuple:
        return min(self.color0 + self.color1), max(self.color0 + self.color1)

    def scalar(self) -> "Checkerboard":
        """Mitsuba 3.9.1's ``eval_1`` of a checkerboard: each colour's ``eval_1`` (the mean of
        its channels: an ``rgb`` value's, or a ``float``'s value), with ``color0`` where the
        fractional parts of u and v are one above 0.5 and one not, the opposite of its
        ``eval`` (reproduced as Mitsuba has it: an opacity checkerboard's cells are swapped
        against the same texture as a reflectance).

        Examples
        --------
        >>> c = Checkerboard((0.0, 0.3, 0.6), 1.0)
        >>> c.eval_1([[0.1, 0.1], [0.6, 0.1]]).round(6).tolist()
        [1.0, 0.3]
        """
        return Checkerboard(sum(self.color1) / 3.0, sum(self.color0) / 3.0, to_uv=self.to_uv)

    def describe(self) -> dict:
        return {"type": "Checkerboard", "color0": self.color0, "color1": self.color1, "to_uv": self.to_uv}


@dataclass(frozen=True, eq=False)
class MeshAttribute(Texture):
    """Mitsuba's ``mesh_attribute``: the value of the hit mesh's attribute ``name`` times ``scale``.

    A ``vertex_*`` attribute is interpolated by the hit's barycentrics, a ``face_*``
    attribute is constant over each face (Mitsuba's ``Mesh::eval_attribute``); it must have
    1 channel (a grey value) or 3 (RGB), as Mitsuba's RGB variants evaluate no other. The
    values are the mesh's (:attr:`reference_tracer.Mesh.attributes`), so the texture can
    only be used on a :class:`reference_tracer.Mesh` that has the attribute; as a
    reflectance, its values times ``scale`` must lie in [0, 1]. It has no mean (Mitsuba's
    ``Texture::mean`` is not implemented for it), so a plastic cannot take it.

    Examples
    --------
    >>> MeshAttribute("vertex_color", scale=0.5).describe()
    {'type': 'MeshAttribute', 'name': 'vertex_color', 'scale': 0.5}
    >>> MeshAttribute("color")
    Traceback (most recent call last):
    ...
    ValueError: MeshAttribute.name must start with 'vertex_' or 'face_', got 'color'
    """

    name: str
    scale: float = 1.0
    to_uv: tuple | None = field(default=None, kw_only=True, repr=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.startswith(("vertex_", "face_")):
            raise ValueError(f"MeshAttribute.name must start with 'vertex_' or 'face_', got {self.name!r}")
        try:
            scale = float(self.scale)
        except (TypeError, ValueError):
            raise ValueError(f"MeshAttribute.scale must be a number, got {self.scale!r}") from None
        if not math.isfinite(scale):
            raise ValueError(f"MeshAttribute.scale must be finite, got {scale}")
        object.__setattr__(self, "scale", scale)
        object.__setattr__(self, "to_uv", _IDENTITY_UV)

    @property
    def per_vertex(self) -> bool:
        return self.name.startswith("vertex_")

    def values(self, mesh) -> np.ndarray:
        """The attribute's values on ``mesh`` times ``scale``: (N, channels) per vertex or face.

        Raises
        ------
        ValueError
            The mesh has no attribute of that name, or it has other than 1 or 3 channels.
        """
        attributes = getattr(mesh, "attributes", None) or {}
        if self.name not in attributes:
            have = ", ".join(sorted(attributes)) or "none"
            raise ValueError(f"MeshAttribute: the mesh has no attribute {self.name!r} (it has: {have})")
        a = attributes[self.name]
        if a.shape[1] not in (1, 3):
            raise ValueError(f"MeshAttribute: attribute {self.name!r} has {a.shape[1]} channels; Mitsuba's "
                             "eval_attribute reads 1 or 3")
        return a * self.scale

    def _unbound(self, what: str):
        raise ValueError(f"MeshAttribute {self.name!r} has no {what} of its own: its values are its mesh's")

    def eval(self, uv) -> np.ndarray:
        self._unbound("values at texture coordinates")

    def mean(self) -> float:
        raise ValueError(f"MeshAttribute {self.name!r}: a plastic's reflectance cannot be a mesh attribute "
                         "(Mitsuba's mesh_attribute has no mean(), which a plastic's lobe choice takes)")

    def value_range(self) -> tuple:
        self._unbound("value range")

    def scalar(self) -> "MeshAttribute":
        """Mitsuba's ``eval_1`` reads a one-channel attribute as it is (a three-channel one
        is refused where the texture is bound to its mesh)."""
        return self

    def describe(self) -> dict:
        return {"type": "MeshAttribute", "name": self.name, "scale": self.scale}
