"""Textures of reflectances, as Mitsuba 3 defines them: ``checkerboard``, ``bitmap`` and
``mesh_attribute``.

A texture gives a material's reflectance per surface point, looked up at the point's
texture coordinates ``(u, v)`` after the texture's ``to_uv`` transform. The coordinates are
Mitsuba's parameterisation of each shape (docs/conventions.md, Geometry): a sphere's spherical
angles, a quad's ``(s, t)`` along its edges, each face of a box the unit square (Mitsuba's
``cube``), a mesh's per-vertex coordinates interpolated by the barycentrics (or the
barycentrics themselves where it has none).

:class:`Checkerboard` is Mitsuba's ``checkerboard`` (``color0`` where the fractional parts of
u and v are both above one half or both not, else ``color1``). :class:`Bitmap` is Mitsuba's
``bitmap``: an image, from a file or an array, looked up with bilinear interpolation or the
nearest texel, repeated, mirrored or clamped beyond the unit square; 8-bit images are sRGB
encoded and decoded to linear values texel by texel (unless ``raw``), EXR images are linear.
:class:`MeshAttribute` is Mitsuba's ``mesh_attribute``: the values of a mesh's named
attribute (:attr:`reference_tracer.Mesh.attributes`), per vertex interpolated by the hit's
barycentrics or per face constant, times ``scale``; it has no texture coordinates.

Image files are untrusted input (SECURITY.md): :func:`read_image` checks that the path is a
regular file and reads the image's size from its header before anything is decoded or
allocated for its pixels.
"""
from __future__ import annotations

import hashlib
import math
import os
import struct
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .imageio import read_exr
from .validation import colour, open_regular_file

__all__ = ["Texture", "Checkerboard", "Bitmap", "MeshAttribute", "read_image", "srgb_to_linear", "FILTER_TYPES", "WRAP_MODES",
           "MAX_TEXTURE_PIXELS", "texture_uv", "is_texture"]

#: Mitsuba's ``filter_type`` values of a bitmap, in the core's order.
FILTER_TYPES = ("bilinear", "nearest")
#: Mitsuba's ``wrap_mode`` values of a bitmap, in the core's order.
WRAP_MODES = ("repeat", "mirror", "clamp")
#: the most pixels an image file may declare (64 Mi, as :func:`reference_tracer.read_exr`).
MAX_TEXTURE_PIXELS = 1 << 26
#: the identity ``to_uv``: rows ``(a, b, c)`` and ``(d, e, f)`` of ``u' = a u + b v + c``, ``v' = d u + e v + f``.
_IDENTITY_UV = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
#: Mitsuba's luminance weights of linear sRGB (``include/mitsuba/core/spectrum.h``).
LUMINANCE = (0.212671, 0.715160, 0.072169)


def _to_uv(owner: str, value) -> tuple:
    """A ``to_uv`` transform as the two rows of a 2-D affine map.

    Accepted: None (identity); a (2, 3) or (3, 3) affine matrix (last row ``0 0 1``); a
    (4, 4) matrix, of which Mitsuba keeps rows and columns 0 and 1 and the translation
    column 3 (``Transform::extract``: what ``<transform name="to_uv">`` gives).

    Examples
    --------
    >>> _to_uv("t", np.diag([5.0, 5.0, 1.0, 1.0]))
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
        object.__setattr__(self, "to_uv", _to_uv("Checkerboard", self.to_uv))

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


# ------------------------------------------------------------------------------------- images

def srgb_to_linear(x) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear ones, as Mitsuba decodes an 8-bit texel
    (Dr.Jit's ``srgb_to_linear``: ``x / 12.92`` up to 0.04045, above it its single-precision
    rational fit of ``((x + 0.055) / 1.055)^2.4``, within 4e-7 of the exact curve), in float32.

    Examples
    --------
    >>> srgb_to_linear([0.0, 0.5, 1.0]).astype(float).round(6).tolist()
    [0.0, 0.214041, 1.0]
    """
    x = np.asarray(x, dtype=np.float64)
    p = np.polynomial.polynomial.polyval(x, [-0.0163933279112946, -0.7386328024653209, -11.199318357635072,
                                             -47.46726633009393, -36.04572663838034])
    q = np.polynomial.polynomial.polyval(x, [-0.004261480793199332, -19.140923959601675, -59.096406619244426,
                                             -18.225745396846637, 1.0])
    r = np.where(x > 0.04045, p / np.where(q == 0, 1.0, q), float(np.float32(1.0 / 12.92)))
    return (r * x).astype(np.float32)


#: 8-bit texel values decoded to linear (sRGB) and unscaled (raw), float32.
_SRGB_TABLE = srgb_to_linear(np.arange(256, dtype=np.float32) * np.float32(1.0 / 255.0))
_RAW_TABLE = (np.arange(256, dtype=np.float32) * np.float32(1.0 / 255.0)).astype(np.float32)


def _check_size(path, width: int, height: int, max_pixels: int) -> None:
    if width <= 0 or height <= 0:
        raise ValueError(f"{path}: its header declares a {width}x{height} image")
    if width * height > max_pixels:
        raise ValueError(f"{path}: its header declares a {width}x{height} image, {width * height} pixels, more "
                         f"than the {max_pixels} read at most")


def _format_of(head: bytes) -> str:
    """The image format of a file's first bytes, as Mitsuba detects it (by content, not name)."""
    if head[:2] == b"BM":
        return "BMP"
    if head[:2] == b"#?":
        return "RGBE"
    if head[:2] in (b"PF", b"Pf"):
        return "PFM"
    if head[:2] == b"P6":
        return "PPM"
    if head[:2] == b"\xff\xd8":
        return "JPEG"
    if head[:8] == b"\x89PNG\r\n\x1a\n":
        return "PNG"
    if head[:4] == b"\x76\x2f\x31\x01":
        return "EXR"
    return "unknown"


def _decode_8bit(pixels: np.ndarray, raw: bool) -> np.ndarray:
    return (_RAW_TABLE if raw else _SRGB_TABLE)[pixels]


def _read_bmp(f, path, head: bytes, raw: bool, max_pixels: int) -> np.ndarray:
    """An uncompressed 8- or 24-bit BMP as Mitsuba's ``read_bmp`` takes it: 8 bits a grey
    level (the palette is not applied), 24 bits BGR; rows bottom-up unless the height is
    negative; sRGB."""
    if len(head) < 34:
        raise ValueError(f"{path}: a BMP header needs 34 bytes, the file holds {len(head)}")
    offset, header_size, width, height, planes, bpp, compression = struct.unpack("<IIiiHHI", head[10:34])
    if header_size != 40 or planes != 1 or width <= 0:
        raise ValueError(f"{path}: an unsupported BMP header (Mitsuba reads the 40-byte Windows header only)")
    if compression != 0:
        raise ValueError(f"{path}: a compressed BMP (Mitsuba reads uncompressed ones only)")
    if bpp not in (8, 24):
        raise ValueError(f"{path}: a {bpp}-bit BMP; 8-bit (grey) and 24-bit (RGB) ones are read (Mitsuba's "
                         "16- and 32-bit ones carry alpha, which a reflectance texture does not use)")
    h = abs(height)
    _check_size(path, width, h, max_pixels)
    channels = bpp // 8
    row = width * channels
    padded = row + (-row % 4)
    f.seek(offset)
    data = f.read(padded * h)
    if len(data) < padded * (h - 1) + row:
        raise ValueError(f"{path}: the BMP declares {width}x{h} pixels, more than its {len(data)} bytes of pixels")
    rows = np.frombuffer(data.ljust(padded * h, b"\0"), dtype=np.uint8).reshape(h, padded)[:, :row]
    px = rows.reshape(h, width, channels)
    if height > 0:
        px = px[::-1]
    if channels == 3:
        px = px[..., ::-1]
    return _decode_8bit(np.ascontiguousarray(px), raw)


def _read_pillow(f, path, fmt: str, head: bytes, raw: bool, max_pixels: int) -> np.ndarray:
    """A PNG or JPEG through Pillow, as Mitsuba's libpng and libjpeg readers give it: 8 bits
    a channel, sRGB; grey (with or without alpha) one channel, colour three (palettes
    expanded, alpha dropped: Mitsuba's texture keeps Y or RGB)."""
    from PIL import Image  # deferred: Pillow only when an 8-bit image is read or written

    if fmt == "PNG":
        if len(head) < 26 or head[12:16] != b"IHDR":
            raise ValueError(f"{path}: a PNG without its IHDR header")
        width, height, depth, kind = struct.unpack(">IIBB", head[16:26])
        _check_size(path, width, height, max_pixels)
        if depth == 16:
            raise ValueError(f"{path}: a 16-bit PNG is not supported (Mitsuba keeps it at half precision); "
                             "convert it to 8 bits or to a linear EXR")
    with warnings.catch_warnings():
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        try:
            image = Image.open(f, formats=[fmt])
        except Image.DecompressionBombWarning as exc:
            raise ValueError(f"{path}: {exc}") from None
        _check_size(path, image.width, image.height, max_pixels)
        mode = image.mode
        if mode in ("1", "L", "LA", "La"):
            image = image.convert("L")
        elif mode in ("RGB", "RGBA", "RGBa", "P", "PA"):
            image = image.convert("RGB")
        else:
            raise ValueError(f"{path}: a {fmt} image of Pillow mode {mode!r} (grey or RGB, 8 bits a channel, are "
                             "read)")
        px = np.asarray(image, dtype=np.uint8)
    if px.ndim == 2:
        px = px[..., None]
    return _decode_8bit(px, raw)


def read_image(path, *, raw: bool = False, max_pixels: int = MAX_TEXTURE_PIXELS) -> np.ndarray:
    """An image file as the (H, W, C) float32 linear values Mitsuba's ``bitmap`` texture
    stores (C = 1 for grey, 3 for colour; alpha dropped; row 0 the image's top).

    Formats, detected by content as Mitsuba does: PNG (8 bits a channel: grey, grey and
    alpha, RGB, RGBA, palette), JPEG (grey or RGB) and BMP (uncompressed 8-bit grey or
    24-bit RGB), all sRGB encoded, decoded to linear values texel by texel unless ``raw``
    (then ``value / 255``); OpenEXR (Y, RGB or RGBA channels), linear. Refused with
    ``ValueError``: 16-bit PNGs, Radiance RGBE, PFM, PPM, TGA and other files.

    The file must be a regular file, and its header's size at most ``max_pixels`` pixels
    (64 Mi by default): both are checked before any pixel is decoded.

    Raises
    ------
    ValueError
        Not a regular file, an unsupported format or layout, a header declaring too large
        an image, or a corrupt file.
    OSError
        The file cannot be opened.

    Examples
    --------
    >>> import tempfile
    >>> from PIL import Image
    >>> folder = Path(tempfile.mkdtemp())
    >>> Image.fromarray(np.full((2, 3), 128, dtype=np.uint8)).save(folder / "grey.png")
    >>> px = read_image(folder / "grey.png")
    >>> px.shape, round(float(px[0, 0, 0]), 6), float(read_image(folder / "grey.png", raw=True)[0, 0, 0])
    ((2, 3, 1), 0.21586, 0.501960813999176)
    """
    path = Path(path)
    with open_regular_file(path, "an image file") as f:
        head = f.read(64)
        fmt = _format_of(head)
        try:
            if fmt == "BMP":
                return _read_bmp(f, path, head, raw, max_pixels)
            if fmt in ("PNG", "JPEG"):
                f.seek(0)
                return _read_pillow(f, path, fmt, head, raw, max_pixels)
        except (OSError, SyntaxError, struct.error) as exc:  # Pillow's and struct's words for a corrupt file
            if isinstance(exc, (FileNotFoundError, PermissionError)):
                raise
            raise ValueError(f"{path}: not a readable {fmt} image ({exc})") from None
    if fmt == "EXR":
        return _read_exr(path, max_pixels)
    if fmt in ("RGBE", "PFM", "PPM"):
        raise ValueError(f"{path}: a {fmt} image is not supported as a texture (PNG, JPEG, BMP and EXR are read)")
    raise ValueError(f"{path}: not an image of a supported format (PNG, JPEG, BMP, EXR; detected by content)")


def _read_exr(path: Path, max_pixels: int) -> np.ndarray:
    try:
        px = read_exr(path, max_pixels=max_pixels)
    except ValueError:
        raise
    except Exception as exc:  # OpenEXR raises RuntimeError for a corrupt file
        raise ValueError(f"{path}: not a readable EXR image ({exc})") from None
    if px.ndim != 3 or px.shape[2] not in (1, 3, 4):
        raise ValueError(f"{path}: an EXR image of {px.shape[-1]} channels (Y, RGB or RGBA are read)")
    px = px[..., :3] if px.shape[2] == 4 else px   # alpha: not part of a reflectance
    bad = int(np.count_nonzero(~np.isfinite(px)))
    if bad:   # Mitsuba would look them up; a NaN reflectance has no meaning
        raise ValueError(f"{path}: {bad} texel value(s) of the EXR image not finite (NaN or infinite)")
    return np.ascontiguousarray(px, dtype=np.float32)


@dataclass(frozen=True, eq=False)
class Bitmap(Texture):
    """Mitsuba's ``bitmap``: an image looked up at the texture coordinates.

    Texel ``(i, j)`` (column i, row j, row 0 the image's top) covers
    ``[i / W, (i + 1) / W] x [j / H, (j + 1) / H]`` of the unit square: ``v`` grows down
    the image, as Mitsuba reads it (an OBJ's ``vt`` is flipped on loading, so its
    ``v = 0`` is the image's bottom).

    Parameters
    ----------
    image : str, os.PathLike or array_like
        An image file (:func:`read_image`: PNG, JPEG, BMP or EXR; 8-bit images are sRGB
        and decoded to linear values unless ``raw``), or an (H, W), (H, W, 1) or (H, W, 3)
        array of linear values. An image smaller than 2x2 is padded to it by repeating
        its last row and column, as Mitsuba does.
    filter : {'bilinear', 'nearest'}, keyword-only
        Mitsuba's ``filter_type``: bilinear interpolation between the four texels around
        the point (texel centres at half-integers), or the texel under it.
    wrap : {'repeat', 'mirror', 'clamp'}, keyword-only
        Mitsuba's ``wrap_mode`` beyond the unit square.
    raw : bool, keyword-only
        Mitsuba's ``raw``: an 8-bit file's values are taken as they are (``value / 255``),
        not decoded from sRGB.
    to_uv : array_like or None, keyword-only
        As :class:`Checkerboard`'s.

    Attributes
    ----------
    data : numpy.ndarray
        The (H, W, C) float32 linear values looked up (C = 1 or 3), read-only.
    filename : str or None
        The file read, or None for an array.

    Examples
    --------
    >>> b = Bitmap(np.array([[0.0, 1.0], [1.0, 0.0]]), filter="nearest")
    >>> b.eval([[0.25, 0.25], [0.75, 0.25]])[:, 0].tolist()
    [0.0, 1.0]
    >>> float(Bitmap(np.array([[0.0, 1.0], [1.0, 0.0]])).eval([[0.5, 0.5]])[0, 0])
    0.5
    """

    image: object
    filter: str = field(default="bilinear", kw_only=True)
    wrap: str = field(default="repeat", kw_only=True)
    raw: bool = field(default=False, kw_only=True)
    to_uv: tuple | None = field(default=None, kw_only=True)
    data: np.ndarray = field(init=False, repr=False)
    filename: str | None = field(init=False, default=None)

    def __post_init__(self):
        if self.filter not in FILTER_TYPES:
            raise ValueError(f"Bitmap.filter must be one of {FILTER_TYPES}, got {self.filter!r}")
        if self.wrap not in WRAP_MODES:
            raise ValueError(f"Bitmap.wrap must be one of {WRAP_MODES}, got {self.wrap!r}")
        if not isinstance(self.raw, (bool, np.bool_)):
            raise ValueError(f"Bitmap.raw must be True or False, got {self.raw!r}")
        object.__setattr__(self, "raw", bool(self.raw))
        object.__setattr__(self, "to_uv", _to_uv("Bitmap", self.to_uv))
        source = self.image
        if isinstance(source, (str, os.PathLike)):
            object.__setattr__(self, "filename", str(Path(source).resolve()))
            data = read_image(source, raw=self.raw)
        else:
            data = _image_array(source)
        # Mitsuba's bitmap texture needs 2x2 texels at least: it repeats the last row and column.
        if data.shape[0] < 2 or data.shape[1] < 2:
            data = np.pad(data, ((0, max(0, 2 - data.shape[0])), (0, max(0, 2 - data.shape[1])), (0, 0)),
                          mode="edge")
        data = np.ascontiguousarray(data, dtype=np.float32)
        data.setflags(write=False)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "image", self.filename if self.filename is not None else data)

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def channels(self) -> int:
        return int(self.data.shape[2])

    def mean(self) -> float:
        """Mitsuba's ``mean()`` of a bitmap: the mean over texels of their luminance
        (Mitsuba's weights of linear sRGB), or of their value for a grey image."""
        d = self.data.astype(np.float64)
        if d.shape[2] == 3:
            return float(np.mean(d @ np.asarray(LUMINANCE)))
        return float(np.mean(d))

    def value_range(self) -> tuple:
        return float(self.data.min()), float(self.data.max())

    def scalar(self) -> "Bitmap":
        """Mitsuba's ``eval_1`` of a bitmap: a grey image's value, a colour image's luminance
        (Mitsuba's weights of linear sRGB; of the interpolated colour there, of each texel
        here: the same up to rounding, the interpolation being linear).

        Examples
        --------
        >>> b = Bitmap(np.array([[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]), filter="nearest")
        >>> b.eval_1([[0.25, 0.5], [0.75, 0.5]]).round(6).tolist()
        [0.212671, 0.71516]
        """
        if self.channels == 1:
            return self
        lum = self.data.astype(np.float64) @ np.asarray(LUMINANCE)
        return Bitmap(lum, filter=self.filter, wrap=self.wrap, to_uv=self.to_uv)

    def _wrap(self, i: np.ndarray, res: int) -> np.ndarray:
        if self.wrap == "clamp":
            return np.clip(i, 0, res - 1)
        m = np.mod(i, res)
        if self.wrap == "mirror":
            period = np.floor_divide(i, res)
            m = np.where(period % 2 == 0, m, res - 1 - m)
        return m

    def eval(self, uv) -> np.ndarray:
        p = texture_uv(self.to_uv, uv)
        h, w, _ = self.data.shape
        d = self.data.astype(np.float64)
        out = np.zeros((len(p), 3))
        finite = np.all(np.isfinite(p), axis=1)
        p = np.where(finite[:, None], p, 0.0)
        if self.filter == "nearest":
            ix = self._wrap(np.floor(p[:, 0] * w).astype(np.int64), w)
            iy = self._wrap(np.floor(p[:, 1] * h).astype(np.int64), h)
            val = d[iy, ix]
        else:
            x, y = p[:, 0] * w - 0.5, p[:, 1] * h - 0.5
            x0, y0 = np.floor(x), np.floor(y)
            fx, fy = x - x0, y - y0
            x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
            val = 0.0
            for bx, by, wt in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy),
                               (1, 1, fx * fy)):
                val = val + d[self._wrap(y0 + by, h), self._wrap(x0 + bx, w)] * wt[:, None]
        out[:] = np.broadcast_to(val, (len(p), 3)) if val.shape[1] == 1 else val
        out[~finite] = 0.0
        return out

    def describe(self) -> dict:
        return {"type": "Bitmap", "data_sha256": hashlib.sha256(self.data.tobytes()).hexdigest(),
                "shape": list(self.data.shape), "filter": self.filter, "wrap": self.wrap, "raw": self.raw,
                "to_uv": self.to_uv}


def _image_array(value) -> np.ndarray:
    """An array image as (H, W, C) float32, C = 1 or 3, finite."""
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"Bitmap.image must be a file name or an (H, W[, C]) array of numbers, got {value!r}") \
            from None
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 3) or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"Bitmap.image must have shape (H, W), (H, W, 1) or (H, W, 3), got {a.shape}")
    if a.shape[0] * a.shape[1] > MAX_TEXTURE_PIXELS:
        raise ValueError(f"Bitmap.image has {a.shape[0] * a.shape[1]} pixels, more than {MAX_TEXTURE_PIXELS}")
    if not np.all(np.isfinite(a)):
        raise ValueError("Bitmap.image must be finite (no NaN/Inf)")
    if np.any(np.abs(a) > np.finfo(np.float32).max):
        raise ValueError("Bitmap.image values must fit in float32")
    return a.astype(np.float32)
