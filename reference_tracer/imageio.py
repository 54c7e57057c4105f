"""Image and file output: linear EXR (OpenEXR), display PNG (sRGB transfer, Pillow), atomic writes.

Every file the project writes goes through :func:`atomic_write`: a reader (or a crash)
sees the old file or the new one, never a partial file, and nothing stray is left behind
when a write fails (a full disk, an interrupt).
"""
from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from pathlib import Path

import numpy as np

from .validation import finite_scalar, open_regular_file

__all__ = ["write_exr", "read_exr", "read_hdr", "write_png", "to_display", "atomic_write", "check_writable",
           "new_file_mode"]


def new_file_mode() -> int:
    """The permissions of a newly created file: ``0o666`` less the process's umask.

    Examples
    --------
    >>> old = os.umask(0o022); oct(new_file_mode()); _ = os.umask(old)
    '0o644'
    """
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _check_target(path: Path) -> None:
    """Refuse to replace anything but a regular file (a symbolic link, a folder, a FIFO, a device)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    if not stat.S_ISREG(st.st_mode):
        what = ("a symbolic link" if stat.S_ISLNK(st.st_mode) else "a folder" if stat.S_ISDIR(st.st_mode)
                else "a special file")
        raise ValueError(f"{path} is {what}; refusing to replace it (write to a regular file path)")


def atomic_write(path, data) -> Path:
    """Write a file atomically: a unique temporary file in the same folder, fsync, rename.

    A reader sees the old file or the new one, never a partial write; on any error
    (a full disk, an interrupt) the temporary file is removed and the old file, if any,
    is left as it was. The new file gets :func:`new_file_mode` (0644 under the usual
    umask), not the 0600 of a temporary file. A path that is a symbolic link, a folder or
    a special file is refused (``ValueError``): it is never replaced or written through.

    Parameters
    ----------
    path : str or Path
        The file to write (its folder is created if needed).
    data : bytes, str or callable
        The content (``str`` is encoded as UTF-8), or a function ``data(tmp_path)`` that
        writes the file at ``tmp_path`` itself (an image writer).

    Returns
    -------
    Path

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "a.txt"
    >>> atomic_write(p, "hello").read_text()
    'hello'
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _check_target(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:200]}.", suffix=".tmp")
    try:
        if callable(data):
            os.close(fd)
            fd = -1
            data(tmp)
            fd = os.open(tmp, os.O_RDONLY)
        else:
            blob = data.encode("utf-8") if isinstance(data, str) else bytes(data)
            view = memoryview(blob)
            while view:
                view = view[os.write(fd, view):]
        os.fsync(fd)
        os.close(fd)
        fd = -1
        os.chmod(tmp, new_file_mode())
        _check_target(path)  # again: the path may have changed while we wrote
        os.replace(tmp, path)
    except BaseException:
        if fd >= 0:
            os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def check_writable(path) -> Path:
    """Raise now what :func:`atomic_write` would raise for ``path``, without writing it: its
    folder is created if needed, a path that is a symbolic link, a folder or a special file
    is refused (``ValueError``), and a temporary file is made in the folder and removed
    (``OSError`` where the folder cannot be written). The path itself is never opened: a
    FIFO would block, and a link would be written through.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> check_writable(folder / "a.json") == folder / "a.json", (folder / "a.json").exists()
    (True, False)
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _check_target(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:200]}.", suffix=".tmp")
    os.close(fd)
    os.unlink(tmp)
    return path


def _check_image(name: str, array) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4) or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"{name}: expected an (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) array, got {a.shape}")
    if not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"{name}: expected a numeric array, got dtype {a.dtype}")
    return a


def write_exr(path, array) -> Path:
    """Write a linear float32 image as OpenEXR (channels R, G, B[, A] or Y), atomically (:func:`atomic_write`).

    Examples
    --------
    >>> write_exr("/tmp/out.exr", np.zeros((4, 4, 3)))  # doctest: +SKIP
    """
    import OpenEXR  # deferred: OpenEXR only when an EXR file is read or written

    a = _check_image("write_exr", array).astype(np.float32)
    names = {1: "Y", 3: "RGB", 4: "RGBA"}[a.shape[2]]
    channels = {names: a if a.shape[2] > 1 else a[..., 0]}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}

    def write(tmp):
        try:
            with OpenEXR.File(header, channels) as f:
                f.write(str(tmp))
        except RuntimeError as exc:  # OpenEXR reports I/O errors as RuntimeError with strerror's text
            raise _os_error(exc, path) from exc

    return atomic_write(path, write)


def _os_error(exc: Exception, path) -> Exception:
    """An ``OSError`` naming ``path`` for a library error that quotes an OS error's text (a
    full disk, a read-only folder), so the caller reports it as an I/O error of that file;
    ``exc`` itself otherwise."""
    text = str(exc)
    for code in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EIO):
        if os.strerror(code) in text:
            return OSError(code, os.strerror(code), str(path))
    return exc


#: most pixels :func:`read_exr` decodes by default: a file may declare any size in its header.
MAX_READ_PIXELS = 1 << 26
#: the first four bytes of every OpenEXR file.
EXR_MAGIC = b"\x76\x2f\x31\x01"


def read_exr(path, *, max_pixels: int = MAX_READ_PIXELS) -> np.ndarray:
    """Read an EXR written by :func:`write_exr` (or Mitsuba) as an (H, W, C) float32 array.

    The file is opened and its magic number checked here, before the EXR library sees it
    (which would print its own error line on stderr and raise a bare ``RuntimeError``). The
    header is read first: an image of more than ``max_pixels`` pixels (64 Mi by default) is
    refused with ``ValueError`` before its pixels are decoded, so a small compressed file
    cannot make the reader allocate gigabytes.

    Raises
    ------
    FileNotFoundError, PermissionError (OSError)
        The file cannot be opened (``filename``: the path).
    ValueError
        Not a regular file, not an OpenEXR file (by its first bytes), or too large an image.
    RuntimeError
        The EXR library cannot decode it (a truncated or corrupt file).

    Examples
    --------
    >>> read_exr("/nonexistent/x.exr")
    Traceback (most recent call last):
    ...
    FileNotFoundError: [Errno 2] No such file or directory: '/nonexistent/x.exr'
    """
    import OpenEXR  # deferred: OpenEXR only when an EXR file is read or written

    with open_regular_file(path, "an OpenEXR file") as fh:
        head = fh.read(len(EXR_MAGIC))
    if head != EXR_MAGIC:
        raise ValueError(f"{Path(path)}: not an OpenEXR file ({'empty' if not head else 'no EXR magic number'})")
    with OpenEXR.File(str(path), header_only=True) as f:
        lo, hi = (np.asarray(v, dtype=np.int64) for v in f.header()["dataWindow"])
    pixels = int(np.prod(hi - lo + 1))
    if pixels > max_pixels:
        raise ValueError(f"{path}: an EXR image of {pixels} pixels, more than the {max_pixels} read at most")
    with OpenEXR.File(str(path), separate_channels=False) as f:
        channels = f.channels()
        for key in ("RGB", "RGBA", "Y"):
            if key in channels:
                px = np.asarray(channels[key].pixels, dtype=np.float32)
                return px if px.ndim == 3 else px[..., None]
        key = next(iter(channels))
        px = np.asarray(channels[key].pixels, dtype=np.float32)
        return px if px.ndim == 3 else px[..., None]


#: the longest header line :func:`read_hdr` reads before its resolution line, and how many lines.
_HDR_LINE_MAX, _HDR_LINES_MAX = 4096, 1024


def read_hdr(path, *, max_pixels: int = MAX_READ_PIXELS) -> np.ndarray:
    """Read a Radiance RGBE file (``.hdr``, ``.rgbe``) as an (H, W, 3) float32 array, as
    Mitsuba 3 reads one (``Bitmap::read_rgbe``).

    The header (``#?`` first, a ``FORMAT=32-bit_rle_rgbe`` line, then the resolution line
    ``-Y H +X W``, the only orientation Mitsuba reads) is read first: an image of more than
    ``max_pixels`` pixels, another format or orientation, or a truncated or malformed file
    is refused with ``ValueError`` before anything is allocated for its pixels. Scanlines
    are run-length encoded (the "new" scheme) or flat, as Mitsuba decodes them; each pixel
    is ``mantissa * 2^(exponent - 136)`` (0 for exponent 0), Mitsuba's conversion (no
    ``EXPOSURE`` applied, as there).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "grey.hdr")   # two pixels of radiance 1
    >>> with open(path, "wb") as f:
    ...     _ = f.write(b"#?RADIANCE\\nFORMAT=32-bit_rle_rgbe\\n\\n-Y 1 +X 2\\n" + bytes([128, 128, 128, 129]) * 2)
    >>> read_hdr(path).tolist()
    [[[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]]
    """
    path = Path(path)
    with open(path, "rb") as fh:
        first = fh.readline(_HDR_LINE_MAX)
        if not first.startswith(b"#?"):
            raise ValueError(f"{path}: not a Radiance RGBE file (no '#?' header)")
        fmt = None
        for _ in range(_HDR_LINES_MAX):
            line = fh.readline(_HDR_LINE_MAX)
            if not line:
                raise ValueError(f"{path}: RGBE header without a resolution line")
            text = line.decode("latin-1").strip()
            if text.startswith("FORMAT="):
                fmt = text[len("FORMAT="):]
                continue
            tokens = text.split()
            if len(tokens) == 4 and tokens[0] in ("-Y", "+Y") and tokens[2] in ("+X", "-X"):
                if (tokens[0], tokens[2]) != ("-Y", "+X"):
                    raise ValueError(f"{path}: RGBE orientation {tokens[0]} {tokens[2]} (Mitsuba reads -Y +X only)")
                try:
                    h, w = int(tokens[1]), int(tokens[3])
                except ValueError:
                    raise ValueError(f"{path}: bad RGBE resolution line {text!r}") from None
                break
        else:
            raise ValueError(f"{path}: RGBE header longer than {_HDR_LINES_MAX} lines")
        if fmt != "32-bit_rle_rgbe":
            raise ValueError(f"{path}: RGBE format {fmt!r} (only 32-bit_rle_rgbe is read)")
        if not (h >= 1 and w >= 1):
            raise ValueError(f"{path}: RGBE image of {w}x{h} pixels")
        if h * w > max_pixels:
            raise ValueError(f"{path}: an RGBE image of {h * w} pixels, more than the {max_pixels} read at most")
        data = fh.read(4 * h * w * 2 + 4 * h + 1)  # flat pixels, or RLE at worst twice as long
    rgbe = _rgbe_pixels(data, h, w, path)
    mant = rgbe[..., :3].astype(np.float32)
    exp = rgbe[..., 3].astype(np.int32)
    scale = np.where(exp > 0, np.ldexp(np.float32(1.0), exp - 136).astype(np.float32), np.float32(0.0))
    return (mant * scale[..., None]).astype(np.float32)


def _rgbe_pixels(data: bytes, h: int, w: int, path) -> np.ndarray:
    """The (h, w, 4) bytes of an RGBE file's pixel data: flat, or new-style run-length encoded."""
    def flat(offset: int) -> np.ndarray:
        need = 4 * h * w
        if len(data) - offset < need:
            raise ValueError(f"{path}: RGBE pixel data truncated ({len(data) - offset} of {need} bytes)")
        return np.frombuffer(data, dtype=np.uint8, count=need, offset=offset).reshape(h, w, 4)

    if w < 8 or w > 0x7FFF or len(data) < 4:
        return flat(0)
    first = data[:4]
    if first[0] != 2 or first[1] != 2 or first[2] & 0x80:
        return flat(0)  # not run-length encoded (Mitsuba decides on the first scanline)
    out = np.empty((h, 4, w), dtype=np.uint8)
    pos, n = 0, len(data)
    for y in range(h):
        if pos + 4 > n:
            raise ValueError(f"{path}: RGBE data truncated at scanline {y}")
        head = data[pos:pos + 4]
        pos += 4
        if head[0] != 2 or head[1] != 2 or head[2] & 0x80 or ((head[2] << 8) | head[3]) != w:
            raise ValueError(f"{path}: RGBE scanline {y} has a bad header")
        for c in range(4):
            row = out[y, c]
            x = 0
            while x < w:
                if pos + 2 > n:
                    raise ValueError(f"{path}: RGBE data truncated at scanline {y}")
                count = data[pos]
                if count > 128:
                    count -= 128
                    if count > w - x:
                        raise ValueError(f"{path}: RGBE scanline {y}: a run past the line's end")
                    row[x:x + count] = data[pos + 1]
                    pos += 2
                else:
                    if count == 0 or count > w - x or pos + 1 + count > n:
                        raise ValueError(f"{path}: RGBE scanline {y}: bad run")
                    row[x:x + count] = np.frombuffer(data, dtype=np.uint8, count=count, offset=pos + 1)
                    pos += 1 + count
                x += count
    return np.ascontiguousarray(out.transpose(0, 2, 1))


#: largest exposure (in stops, either sign) of :func:`to_display`: 2**1000 is still a finite double.
MAX_EXPOSURE_STOPS = 1000.0


def check_exposure(exposure) -> float:
    """An exposure in stops as a float, or ``ValueError``: it must be finite and within
    +-:data:`MAX_EXPOSURE_STOPS` (2**1024 overflows a double).

    Examples
    --------
    >>> check_exposure(2000)
    Traceback (most recent call last):
    ...
    ValueError: exposure (stops) must be <= 1000.0, got 2000.0
    """
    return finite_scalar("exposure (stops)", exposure, lo=-MAX_EXPOSURE_STOPS, hi=MAX_EXPOSURE_STOPS)


def to_display(array, exposure: float = 0.0, *, scale: float | None = None,
               keep_nan: bool = False) -> np.ndarray:
    """Linear radiance -> display values in [0, 1]: scale by 2**exposure, clip, sRGB transfer.

    Uses colour-science's sRGB inverse EOTF (the piecewise sRGB curve, not gamma 2.2).
    This is the one tone curve of the project: ``benchmarks.display`` (the SSIM metric and
    the report) builds on it.

    Parameters
    ----------
    array : array_like
        Linear radiance, any shape.
    exposure : float
        Exposure in stops: the image is scaled by ``2**exposure``.
    scale : float, optional
        A linear scale factor used instead of ``2**exposure`` (no round trip through log2,
        so a scale computed from a reference is applied exactly).
    keep_nan : bool
        False (default): non-finite values display as 0. True: NaN stays NaN (so a metric
        can see it) and infinities clip like any out-of-range value (+inf -> 1, -inf -> 0).

    Examples
    --------
    >>> to_display(np.array([0.0, 0.25, 4.0, np.nan]), 1.0).round(4).tolist()
    [0.0, 0.7354, 1.0, 0.0]
    >>> to_display(np.array([0.5, np.nan, np.inf]), scale=0.5, keep_nan=True).round(4).tolist()
    [0.5371, nan, 1.0]
    """
    import colour  # deferred: colour-science takes seconds to import

    if scale is None:
        k = 2.0 ** check_exposure(exposure)
    else:
        k = float(scale)
    a = np.asarray(array, dtype=np.float64)
    if not keep_nan:
        a = np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)
    a = np.clip(a * k, 0.0, 1.0)
    return np.clip(colour.models.eotf_inverse_sRGB(a), 0.0, 1.0)


def write_png(path, array, exposure: float = 0.0) -> Path:
    """Write linear radiance as an 8-bit sRGB PNG after scaling by ``2**exposure``, atomically.

    Examples
    --------
    >>> write_png("/tmp/out.png", np.full((4, 4, 3), 0.5), exposure=0.0)  # doctest: +SKIP
    """
    from PIL import Image  # deferred: Pillow only when an 8-bit image is read or written

    a = _check_image("write_png", array)
    d = to_display(a[..., :3] if a.shape[2] >= 3 else np.repeat(a, 3, axis=2), exposure)
    image = Image.fromarray(np.round(d * 255.0).astype(np.uint8), mode="RGB")
    return atomic_write(path, lambda tmp: image.save(tmp, format="PNG"))
