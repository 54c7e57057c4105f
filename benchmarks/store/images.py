"""The store's EXR images: written atomically under the store, read only from inside it."""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from reference_tracer import imageio

from ..errors import InputError
from ..files import confined_file, open_regular


def write_image(store, relpath, image) -> str:
    """Write an EXR image under the store atomically; return the store-relative path."""
    rel = Path(relpath)
    if rel.is_absolute() or ".." in rel.parts:
        raise ValueError(f"image path must be relative to the store, got {relpath}")
    imageio.write_exr(Path(store) / rel, np.asarray(image, dtype=np.float32))
    return rel.as_posix()


def file_sha256(path) -> str:
    """Hex SHA-256 of a regular file's bytes (the checksum ``meta.json`` keeps of the store's references)."""
    h = hashlib.sha256()
    with open_regular(path) as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def image_path(store, relpath) -> Path:
    """The file a record's image field names, confined to the store (:func:`benchmarks.files.confined_file`)."""
    return confined_file(store, relpath, what="image")


def read_image(store, relpath, *, rgb: bool = False, sha256: str | None = None) -> np.ndarray:
    """An EXR image of the store (:func:`image_path`) as (H, W, C) float32; (H, W, 3) with ``rgb``.

    A record names the image, so a missing file is a store that is not what it should be
    (copied without its images, pruned by hand): :class:`benchmarks.errors.InputError` (exit 2),
    as is a file that is no readable EXR. With ``sha256``, a file whose bytes do not match
    raises ``InputError`` too instead of being decoded (flipped bytes can decode to finite garbage).
    """
    path = image_path(store, relpath)
    if not path.exists():
        raise InputError(f"{path}: missing, though the store names it (a store copied without its images?)")
    if sha256 is not None and file_sha256(path) != sha256:
        raise InputError(f"{path}: checksum mismatch, the file is corrupt (not used)")
    try:
        a = imageio.read_exr(path)
    except (OSError, RuntimeError) as exc:  # the EXR library cannot decode it
        raise InputError(f"{path}: not a readable EXR image ({exc})") from exc
    if rgb:
        if a.shape[2] == 1:
            a = np.repeat(a, 3, axis=2)
        a = np.asarray(a[..., :3], dtype=np.float32)
    return a
