"""Compare two sets of first-hit AOVs with float tolerances (Mitsuba works in float32), name
what differs and draw the mismatch maps. A pixel at an edge of a shape or of a texture, where
rounding alone may change what a ray sees, is forgiven when a ray a hundredth of a pixel away
in one renderer sees what the other saw at the centre.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import diffuse_albedo, first_hit_aovs

from ..display import pyplot
from ..files import slug

__all__ = ["AOVS", "ParityReport", "compare_aovs", "shape_bounds", "write_mismatch_maps"]

#: the AOVs compared, in report order.
AOVS = ("shape", "t", "normal", "albedo", "emitted")
T_RTOL = 1e-3
NORMAL_COS = 0.999
VALUE_RTOL, VALUE_ATOL = 1e-3, 1e-4
#: above this fraction of pixels seeing other shapes or distances, the camera is blamed.
CAMERA_FRACTION = 0.2
#: offsets (in pixels) of the rays that decide whether a shape mismatch is an edge.
_EDGE_OFFSETS = ((0.49, 0.5), (0.51, 0.5), (0.5, 0.49), (0.5, 0.51))


@dataclass
class ParityReport:
    """What :func:`compare_aovs` found for one scene: per AOV an (H, W) mismatch mask
    (``masks``) and its pixel count (``counts``), one-line diagnoses (``findings``), both
    renderers' AOVs, and the pixels forgiven as edges (``edge_pixels``)."""

    scene: str
    width: int
    height: int
    masks: dict
    findings: list
    ours: dict = field(repr=False)
    theirs: dict = field(repr=False)
    edge_pixels: int = 0

    @property
    def counts(self) -> dict:
        return {k: int(m.sum()) for k, m in self.masks.items()}

    @property
    def passed(self) -> bool:
        return not any(self.counts.values())

    def summary(self) -> str:
        """One line: pass, or the mismatch counts per AOV."""
        n = self.width * self.height
        if self.passed:
            return (f"{self.scene}: parity ok ({self.width}x{self.height} pixel centres, {n} rays; "
                    f"{self.edge_pixels} edge pixel(s) forgiven)")
        bad = ", ".join(f"{k} {c}" for k, c in self.counts.items() if c)
        return f"{self.scene}: parity FAILED: mismatching pixels of {n}: {bad}"

    def to_dict(self) -> dict:
        return {"scene": self.scene, "width": self.width, "height": self.height, "passed": self.passed,
                "counts": self.counts, "findings": list(self.findings), "edge_pixels": self.edge_pixels}


def _points(shape) -> np.ndarray:
    if isinstance(shape, rt.Sphere):
        c, r = shape.world_center(), shape.world_radius()
        return np.array([c - r, c + r])
    if isinstance(shape, rt.Quad):
        Q, u, v = shape.world_corners()
        return np.array([Q, Q + u, Q + v, Q + u + v])
    if isinstance(shape, rt.Box):
        return np.array([p for Q, u, v in shape.world_quads() for p in (Q, Q + u, Q + v, Q + u + v)])
    if isinstance(shape, rt.Triangle):
        return shape.world_vertices()
    return shape.world_triangles().reshape(-1, 3)


def shape_bounds(scene: rt.Scene) -> np.ndarray:
    """(N, 6) world bounding boxes ``(min, max)`` of the scene's shapes."""
    out = [np.concatenate([p.min(axis=0), p.max(axis=0)]) for p in (_points(s) for s in scene.shapes)]
    return np.array(out, dtype=np.float64).reshape(-1, 6)


def _close(a, b, rtol=VALUE_RTOL, atol=VALUE_ATOL) -> np.ndarray:
    return np.all(np.abs(a - b) <= atol + rtol * np.maximum(np.abs(a), np.abs(b)), axis=-1)


def _classes(scene: rt.Scene) -> np.ndarray:
    """Class of each shape: shapes with the same bounding box are indistinguishable to the match."""
    b = shape_bounds(scene)
    extent = max(float(np.abs(b).max()) if b.size else 1.0, 1e-6)
    cls = np.arange(len(b))
    for i in range(len(b)):  # the class of the first shape with the same box (i itself if none before)
        cls[i] = cls[np.argmax(np.abs(b - b[i]).max(axis=1) / extent <= 1e-4)]
    return cls


def _forgiven(scene, ours, theirs, suspect, theirs_at, same) -> np.ndarray:
    """Suspect pixels where a ray a hundredth of a pixel away in one renderer sees what the
    other saw at the centre (``same(aovs_a, aovs_b)``: per-pixel agreement)."""
    ok = np.zeros_like(suspect)
    for off in _EDGE_OFFSETS if suspect.any() else ():
        ok |= suspect & same(first_hit_aovs(scene, offset=off), theirs)
        if theirs_at is not None and not ok[suspect].all():
            ok |= suspect & same(theirs_at(off), ours)
    return ok


def _describe(scene, i: int) -> str:
    if i < 0:
        return "nothing" if i == -1 else "an unmatched Mitsuba shape"
    s = scene.shapes[i]
    return f"shape {i} ({type(s).__name__}, {type(s.material).__name__})"


def compare_aovs(scene: rt.Scene, ours: dict, theirs: dict, *, name: str = "scene", theirs_at=None) -> ParityReport:
    """Mismatch masks of every AOV of ``ours`` and ``theirs`` (the AOVs of
    :func:`reference_tracer.probe.first_hit_aovs` and :func:`.mitsuba.mitsuba_aovs`) and the
    findings that explain them; ``theirs_at((dx, dy))``, Mitsuba's AOVs through
    ``pixel + (dx, dy)``, tells an edge from a real difference from Mitsuba's side too."""
    h, w = ours["t"].shape
    if theirs["t"].shape != (h, w):
        masks = dict.fromkeys(AOVS, np.ones((h, w), dtype=bool))
        return ParityReport(name, w, h, masks, [f"camera: image size {w}x{h} (ours) vs "
                                                f"{theirs['t'].shape[1]}x{theirs['t'].shape[0]} (Mitsuba)"],
                            ours, theirs)
    cls = _classes(scene) if scene.shapes else np.zeros(0, dtype=np.int64)

    def klass(s):
        return np.where(s >= 0, cls[np.maximum(s, 0)] if len(cls) else s, s)

    def same_shape(a, b):
        return klass(a["shape"]) == klass(b["shape"])

    shape_bad = ~same_shape(ours, theirs)
    forgiven = _forgiven(scene, ours, theirs, shape_bad, theirs_at, same_shape)
    shape_bad &= ~forgiven
    same = ~shape_bad & ~forgiven & (ours["shape"] >= 0)
    with np.errstate(invalid="ignore"):  # inf - inf where both miss (not in `same`)
        t_bad = same & ~(np.abs(ours["t"] - theirs["t"]) <= T_RTOL * np.maximum(ours["t"], theirs["t"]))
    cos = np.einsum("hwc,hwc->hw", ours["normal"], theirs["normal"])
    n_bad = same & (cos < NORMAL_COS)
    a_bad = same & ~_close(ours["albedo"], theirs["albedo"])
    textured = np.array([isinstance(diffuse_albedo(s.material), rt.Texture) for s in scene.shapes] + [False])
    texture_edges = _forgiven(scene, ours, theirs, a_bad & textured[np.where(ours["shape"] >= 0, ours["shape"], -1)],
                              theirs_at, lambda a, b: _close(a["albedo"], b["albedo"]))
    a_bad &= ~texture_edges
    forgiven_pixels = int(forgiven.sum() + texture_edges.sum())
    e_bad = (~shape_bad & ~forgiven) & ~_close(ours["emitted"], theirs["emitted"])
    masks = {"shape": shape_bad, "t": t_bad, "normal": n_bad, "albedo": a_bad, "emitted": e_bad}
    findings = _findings(scene, ours, theirs, masks, cos)
    return ParityReport(name, w, h, masks, findings, ours, theirs, edge_pixels=forgiven_pixels)


def _findings(scene, ours, theirs, masks, cos) -> list:
    out = []
    h, w = ours["t"].shape
    geo = masks["shape"] | masks["t"]
    if geo.sum() > CAMERA_FRACTION * h * w:
        out.append(f"camera: {geo.mean():.0%} of the pixel centres see another shape or distance in Mitsuba: "
                   "check fov and fov_axis, the look-at frame and the film size")
    for i in range(len(scene.shapes)):
        mine = ours["shape"] == i
        flipped = mine & masks["normal"] & (cos < -NORMAL_COS)
        if flipped.any():
            out.append(f"{_describe(scene, i)}: normal reversed at {int(flipped.sum())} pixel(s) (winding, "
                       "flip_normals or the sign of to_world)")
        other = mine & masks["normal"] & ~flipped
        if other.any():
            out.append(f"{_describe(scene, i)}: normal differs at {int(other.sum())} pixel(s)")
        for aov in ("albedo", "emitted", "t"):
            bad = mine & masks[aov]
            if bad.any():
                y, x = np.argwhere(bad)[0]
                out.append(f"{_describe(scene, i)}: {aov} ours {np.round(ours[aov][y, x], 4).tolist()} vs Mitsuba "
                           f"{np.round(theirs[aov][y, x], 4).tolist()} at {int(bad.sum())} pixel(s), "
                           f"first at row {y}, col {x}")
    miss = (ours["shape"] < 0) & masks["emitted"]
    if miss.any():
        y, x = np.argwhere(miss)[0]
        out.append(f"background: ours {np.round(ours['emitted'][y, x], 4).tolist()} vs Mitsuba "
                   f"{np.round(theirs['emitted'][y, x], 4).tolist()} at {int(miss.sum())} pixel(s)")
    if masks["shape"].any() and not (out and out[0].startswith("camera")):
        pairs = collections.Counter((int(ours["shape"][y, x]), int(theirs["shape"][y, x]))
                                    for y, x in np.argwhere(masks["shape"]))
        for (a, b), c in pairs.most_common(5):
            out.append(f"{c} pixel(s) hit {_describe(scene, a)} in ours but {_describe(scene, b)} in Mitsuba")
    if any(s == -2 for s in np.unique(theirs["shape"])):
        out.append("Mitsuba has shape(s) with no counterpart among ours (by bounding box)")
    return out


def _grey(report: ParityReport) -> np.ndarray:
    """Our hit distance as a grey backdrop (near bright, misses dark)."""
    t = report.ours["t"]
    fin = np.isfinite(t)
    if not fin.any():
        return np.zeros(t.shape)
    lo, hi = float(t[fin].min()), float(t[fin].max())
    return 0.25 + 0.5 * np.where(fin, 1.0 - (t - lo) / (hi - lo + 1e-12), 0.0)


def write_mismatch_maps(report: ParityReport, out) -> list:
    """Write ``<scene>_parity.png`` (per AOV: mismatching pixels in red over our depth) and
    ``<scene>_parity.exr`` (R: shape or distance, G: normal, B: albedo or emitted mismatch).
    Returns the paths written."""
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    png, exr = out / f"{slug(report.scene)}_parity.png", out / f"{slug(report.scene)}_parity.exr"
    m = report.masks
    rt.write_exr(exr, np.stack([m["shape"] | m["t"], m["normal"], m["albedo"] | m["emitted"]], axis=-1)
                 .astype(np.float32))
    grey = _grey(report)
    fig, axes = plt.subplots(1, len(AOVS), figsize=(2.6 * len(AOVS), 2.6 * report.height / report.width + 0.7), dpi=100)
    for ax, aov in zip(np.atleast_1d(axes), AOVS):
        img = np.repeat(grey[..., None], 3, axis=-1)
        img[m[aov]] = (1.0, 0.1, 0.1)
        ax.imshow(img, interpolation="nearest")
        ax.set_title(f"{aov}: {int(m[aov].sum())}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"{report.scene}: pixel centres that differ from Mitsuba (red)", fontsize=9)
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)
    return [png, exr]
