"""External renderers: any program that renders a Mitsuba XML scene to an EXR, given as a
command template with the placeholders of :data:`PLACEHOLDERS` (the protocol:
docs/rtbench.md, "External renderers"). Its records carry renderer ``ext-<name>``, strategy
``external`` and build ``ext-<hash of the template>``.
"""
from __future__ import annotations

import hashlib
import os
import re
import shlex
import string
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import to_xml
from mitsuba_scenes.render import batch_estimate, batch_seeds, split_spp

__all__ = ["PLACEHOLDERS", "STRATEGY", "ExternalRenderer", "register_external", "external", "registered_externals",
           "restore_externals", "clear_externals", "render_external", "render_external_batches"]

PLACEHOLDERS = ("scene_xml", "spp", "seed", "width", "height", "out")
#: the strategy field of external renderers' records.
STRATEGY = "external"
#: seconds an external render may take before it is stopped.
TIMEOUT = 3600

_REGISTRY: dict = {}


@dataclass(frozen=True)
class ExternalRenderer:
    """A command template (see the module docstring) and the renderer name it records."""

    name: str
    template: str

    @property
    def build(self) -> str:
        """``ext-`` and 12 hex digits of the template: another command is another build."""
        return "ext-" + hashlib.sha256(self.template.encode()).hexdigest()[:12]


def register_external(template: str) -> ExternalRenderer:
    """Check a command template and register it under ``ext-`` and the program's file name (a
    number added for another template of the same program); returns the :class:`ExternalRenderer`.

    >>> register_external("mitsuba -D spp={spp} -o {out} {scene_xml}").name
    'ext-mitsuba'
    >>> register_external("x {bogus} {out} {scene_xml}")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: --renderer 'x {bogus} {out} {scene_xml}': unknown placeholder(s) bogus; use scene_xml, spp, ...
    """
    try:
        fields = {f for _, f, _, _ in string.Formatter().parse(template) if f is not None}
    except ValueError as exc:
        raise ValueError(f"--renderer {template!r}: {exc}") from None
    unknown = sorted(fields - set(PLACEHOLDERS))
    if unknown:
        raise ValueError(f"--renderer {template!r}: unknown placeholder(s) {', '.join(unknown)}; use "
                         f"{', '.join(PLACEHOLDERS)}")
    missing = [f for f in ("scene_xml", "out") if f not in fields]
    if missing:
        raise ValueError(f"--renderer {template!r} must contain {', '.join('{' + m + '}' for m in missing)}")
    words = shlex.split(template)
    if not words:
        raise ValueError("--renderer is empty")
    base = "ext-" + re.sub(r"[^A-Za-z0-9_.-]+", "_", os.path.basename(words[0]))
    entry = ExternalRenderer(base, template)
    k = 2
    while entry.name in _REGISTRY and _REGISTRY[entry.name].template != template:
        entry = ExternalRenderer(f"{base}-{k}", template)
        k += 1
    _REGISTRY[entry.name] = entry
    return entry


def external(name: str):
    """The registered :class:`ExternalRenderer` called ``name``, or None."""
    return _REGISTRY.get(name)


def registered_externals() -> list:
    return list(_REGISTRY.values())


def restore_externals(entries) -> None:
    """Register ``entries`` as they are (Dask workers get the client's renderers this way)."""
    _REGISTRY.update((e.name, e) for e in entries)


def clear_externals() -> None:
    _REGISTRY.clear()


def render_external(renderer: ExternalRenderer, scene, *, spp: int, seed: int) -> tuple:
    """Render ``scene`` with the external command: ``(mean (H, W, 3) float32, seconds)``;
    ``RuntimeError`` when it failed, timed out, or wrote no or a wrongly sized image."""
    w, h = scene.camera.width, scene.camera.height
    with tempfile.TemporaryDirectory(prefix="rtbench-ext-") as tmp:
        xml, out = Path(tmp) / "scene.xml", Path(tmp) / "out.exr"
        to_xml(scene, xml, spp=spp, seed=seed)
        values = {"scene_xml": xml, "spp": spp, "seed": seed, "width": w, "height": h, "out": out}
        cmd = renderer.template.format(**{k: shlex.quote(str(v)) for k, v in values.items()})
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, shell=True, cwd=tmp, capture_output=True, text=True, timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"{renderer.name}: no result after {TIMEOUT} s: {cmd}") from None
        seconds = time.perf_counter() - t0
        if proc.returncode != 0:
            tail = " | ".join((proc.stderr or proc.stdout or "").strip().splitlines()[-3:])
            raise RuntimeError(f"{renderer.name} exited with status {proc.returncode}: {cmd}: {tail}")
        if not out.is_file():
            raise RuntimeError(f"{renderer.name} wrote no image at {{out}}: {cmd}")
        img = rt.read_exr(out)
    if img.shape[:2] != (h, w) or img.shape[2] < 3:
        raise RuntimeError(f"{renderer.name} wrote a {img.shape} image, expected ({h}, {w}, 3)")
    return np.ascontiguousarray(img[..., :3], dtype=np.float32), seconds


def render_external_batches(renderer: ExternalRenderer, scene, *, spp: int, seed: int, batches: int = 16) -> tuple:
    """``(mean, per-sample variance, seconds)`` from ``batches`` runs of the command with their
    own seeds (:func:`mitsuba_scenes.render.batch_estimate`, as for Mitsuba)."""
    sizes = split_spp(int(spp), int(batches))
    if len(sizes) < 2:
        raise ValueError(f"{renderer.name}: a variance needs at least 2 batches (spp {spp}, batches {batches})")
    means, seconds = [], 0.0
    for n, s in zip(sizes, batch_seeds(int(seed), len(sizes))):
        img, sec = render_external(renderer, scene, spp=n, seed=s)
        means.append(img)
        seconds += sec
    return (*batch_estimate(means, sizes), seconds)
