"""Image files read as a texture's texels: :func:`read_image` gives what Mitsuba's ``bitmap``
stores of a PNG, JPEG or BMP file (8 bits a channel, sRGB encoded, decoded to linear values
by :func:`srgb_to_linear` unless ``raw``) or an OpenEXR file (linear), detected by content as
Mitsuba does. Image files are untrusted input (SECURITY.md): :func:`read_image` checks that
the path is a regular file and reads the image's size from its header before anything is
decoded or allocated for its pixels.
"""
from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np

from .imageio import read_exr
from .validation import open_regular_file

__all__ = ["read_image", "srgb_to_linear", "pad_to", "MAX_TEXTURE_PIXELS"]

#: the most pixels an image file may declare (64 Mi, as :func:`reference_tracer.read_exr`).
MAX_TEXTURE_PIXELS = 1 << 26


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


def pad_to(image: np.ndarray, rows: int, columns: int) -> np.ndarray:
    """``image`` (H, W, C) grown to at least ``rows`` x ``columns`` texels by repeating its last
    row and column, as Mitsuba's ``Bitmap::pad_to``; itself where it is large enough.

    >>> pad_to(np.arange(3.0).reshape(1, 3, 1), 2, 2)[..., 0].tolist()
    [[0.0, 1.0, 2.0], [0.0, 1.0, 2.0]]
    """
    h, w = image.shape[:2]
    if h >= rows and w >= columns:
        return image
    return np.pad(image, ((0, max(0, rows - h)), (0, max(0, columns - w)), (0, 0)), mode="edge")


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
