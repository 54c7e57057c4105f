"""The camera's rays through film points, as the core generates them: pinhole, thin lens and
orthographic, each ray with its reach (the far clip plane), for the first-hit AOVs and the checks
that trace their own rays.
"""
from __future__ import annotations

import numpy as np

from ..scene import Camera

__all__ = ["camera_rays", "camera_rays_with_reach"]


def camera_rays(camera: Camera, px, py, lens=None) -> tuple:
    """The camera's rays through film points ``(px, py)``, in pixels.

    The formulas of ``Camera::generate`` in ``reference_tracer/cpp/scene.h``: pixel (0, 0)
    is top left, ``vfov`` vertical, pixel centres at ``x + 0.5``. Rays start on the near
    clip plane (at the eye or the aperture point where there is none); an orthographic
    camera's are parallel, from its view rectangle.

    Parameters
    ----------
    camera : Camera
    px, py : array_like
        Film coordinates in pixels, one entry per ray.
    lens : array_like, shape (N, 2), optional
        A thin lens's aperture numbers in [0, 1)^2, one pair per ray (required for a thin
        lens, which has no single ray per film point; refused otherwise).

    Returns
    -------
    origins, directions : ndarray
        C-contiguous float64 arrays of shape (N, 3), directions of unit length.

    Raises
    ------
    ValueError
        A thin lens without ``lens``, or ``lens`` for any other camera.

    Examples
    --------
    >>> import reference_tracer as rt
    >>> cam = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), vfov=90, width=2, height=2)
    >>> o, d = camera_rays(cam, [1.0], [1.0])
    >>> d.round(6).tolist()
    [[0.0, 0.0, -1.0]]
    >>> ortho = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), width=2, height=2,
    ...                   projection="orthographic", view_height=4.0, near_clip=0.5)
    >>> o, d = camera_rays(ortho, [0.0], [0.0])
    >>> o.tolist(), d.tolist()
    ([[-2.0, 2.0, 0.5]], [[0.0, 0.0, -1.0]])
    """
    o, d, _ = camera_rays_with_reach(camera, px, py, lens)
    return o, d


def camera_rays_with_reach(camera: Camera, px, py, lens=None) -> tuple:
    """:func:`camera_rays` and each ray's reach: a hit at or beyond it (the far clip plane) is a miss.

    Returns
    -------
    origins, directions : ndarray, shape (N, 3)
    reach : ndarray, shape (N,)
        ``inf`` where the camera has no far clip plane.

    Examples
    --------
    >>> import reference_tracer as rt
    >>> cam = rt.Camera(lookfrom=(0, 0, 1), lookat=(0, 0, 0), vfov=90, width=2, height=2, far_clip=3.0)
    >>> camera_rays_with_reach(cam, [1.0], [1.0])[2].tolist()
    [3.0]
    """
    if camera.is_thin_lens and lens is None:
        raise ValueError("a thin lens has no single ray per film point: give lens, the aperture's uniform "
                         "numbers (N, 2)")
    if lens is not None and not camera.is_thin_lens:
        raise ValueError("lens is a thin lens's (Camera.aperture_radius > 0)")
    eye = np.asarray(camera.lookfrom, dtype=np.float64)
    fwd, right, up = (np.asarray(v, dtype=np.float64) for v in camera.basis())
    px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
    if camera.is_orthographic:
        vw, vh = camera.view_size
        sx = (2.0 * px / camera.width - 1.0) * (0.5 * vw)
        sy = (1.0 - 2.0 * py / camera.height) * (0.5 * vh)
        o = eye[None, :] + sx[:, None] * right + sy[:, None] * up + camera.near_clip * fwd
        d = np.broadcast_to(fwd, o.shape)
        reach = np.full(len(o), camera.far_clip - camera.near_clip)
        return np.ascontiguousarray(o), np.ascontiguousarray(d), reach
    hh = np.tan(0.5 * np.radians(camera.vfov))
    hw = hh * camera.width / camera.height
    sx = (2.0 * px / camera.width - 1.0) * hw
    sy = (1.0 - 2.0 * py / camera.height) * hh
    if camera.is_pinhole:  # the plain pinhole's arithmetic (Camera::direction)
        d = fwd[None, :] + sx[:, None] * right[None, :] + sy[:, None] * up[None, :]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return (np.ascontiguousarray(np.broadcast_to(eye, d.shape)), np.ascontiguousarray(d),
                np.full(len(d), np.inf))
    ar = au = np.zeros_like(sx)
    f = 1.0
    if camera.is_thin_lens:
        u = np.asarray(lens, dtype=np.float64).reshape(-1, 2)
        if len(u) != len(sx):
            raise ValueError(f"lens: one pair per ray expected, got {len(u)} for {len(sx)} rays")
        dx, dy = _disk_concentric(u[:, 0], u[:, 1])
        ar, au = -camera.aperture_radius * dx, camera.aperture_radius * dy  # Mitsuba's x is our -right
        f = camera.focus_distance
    local = np.stack([f * sx - ar, f * sy - au, np.full_like(sx, f)], axis=1)
    length = np.linalg.norm(local, axis=1)
    d = local[:, :1] * right + local[:, 1:2] * up + local[:, 2:] * fwd
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    inv_z = length / f
    near_t = camera.near_clip * inv_z
    reach = camera.far_clip * inv_z - near_t if np.isfinite(camera.far_clip) else np.full(len(d), np.inf)
    o = eye[None, :] + ar[:, None] * right + au[:, None] * up + near_t[:, None] * d
    return np.ascontiguousarray(o), np.ascontiguousarray(d), reach


def _disk_concentric(u1, u2):
    """Mitsuba's ``warp::square_to_uniform_disk_concentric``, vectorised."""
    a, b = 2.0 * u1 - 1.0, 2.0 * u2 - 1.0
    q13 = np.abs(a) < np.abs(b)
    r, rp = np.where(q13, b, a), np.where(q13, a, b)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = 0.25 * np.pi * rp / r
    phi = np.where(q13, 0.5 * np.pi - phi, phi)
    phi = np.where((a == 0) & (b == 0), 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)
