"""Adapters from the tracer's sampling routines (:mod:`reference_tracer.probe`, a compiled scene's
``sample_lights`` / ``light_pdf``) to ``sample(u)`` / ``pdf(points)`` callables; a failed sample is a
row of NaN. Schlick's formula and Snell's law here are independent statements, not the tracer's code.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

import reference_tracer as rt
from reference_tracer import probe

from ..optics import fresnel_dielectric

__all__ = ["direction", "frame", "warp", "BsdfProbe", "LightProbe", "fresnel_schlick", "refract_expected"]


def _c(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _directions(s: dict) -> np.ndarray:
    """Sampled directions, NaN rows for failed samples and for Dirac ones (no density to test)."""
    return np.where((s["valid"].astype(bool) & ~s["delta"].astype(bool))[:, None], s["wi"], np.nan)


def direction(theta_deg: float, phi_deg: float = 0.0) -> np.ndarray:
    """Unit vector at polar angle theta from +z and azimuth phi (degrees)."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def frame(axis) -> np.ndarray:
    """A rotation whose rows are an orthonormal basis with ``axis`` (normalised) last: ``world @
    R.T`` gives coordinates in which ``axis`` is +z; ``local @ R`` maps back."""
    n = np.asarray(axis, dtype=np.float64)
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    s = np.cross(helper, n)
    s /= np.linalg.norm(s)
    return np.stack([s, np.cross(n, s), n])


def warp(name: str, param: float = 0.0):
    """``(sample, pdf)`` of the warp ``name`` of sampling/warp.h (see sampling_probe.cpp)."""
    return (lambda u: probe.warp_sample(name, _c(u), float(param)),
            lambda points: probe.warp_pdf(name, _c(points), float(param)))


@dataclass
class BsdfProbe:
    """One material at one outgoing direction ``wo`` (local frame): ``param`` is a rough
    material's alpha or a dielectric's index; ``albedo`` a diffuse reflectance; ``coating``
    a plastic's ``eta``, ``specular`` and ``nonlinear`` or a rough dielectric's ``eta``."""

    material: str
    wo: np.ndarray
    param: float = 0.0
    albedo: tuple = (0.8, 0.6, 0.4)
    coating: dict = field(default_factory=dict)

    def __post_init__(self):
        self.wo = _c(self.wo) / np.linalg.norm(self.wo)
        self._options = {k: (_c(v) if k == "specular" else v) for k, v in self.coating.items()}

    def sample_full(self, u) -> dict:
        """Every field of the samples of (n, 3) uniforms: wi, weight, pdf, eta, delta, valid."""
        return probe.bsdf_sample(self.material, self.wo, _c(u), _c(self.albedo), float(self.param), **self._options)

    def sample(self, u) -> np.ndarray:
        """Directions of (n, 3) uniforms, NaN rows where the sampler failed or drew a Dirac lobe."""
        return _directions(self.sample_full(u))

    def eval_pdf(self, wi) -> dict:
        """``value`` (f * cos, (n, 3)) and ``pdf`` ((n,)) at directions wi."""
        return probe.bsdf_eval_pdf(self.material, self.wo, _c(wi), _c(self.albedo), float(self.param), **self._options)

    def pdf(self, wi) -> np.ndarray:
        return self.eval_pdf(wi)["pdf"]


@dataclass
class LightProbe:
    """Light sampling from the point ``ref`` of a scene of ``shapes``, a constant ``background``
    and ``lights``. ``sample`` returns and ``pdf`` takes directions in the frame of
    ``rotation`` (:func:`frame`: e.g. +z toward a small light); a delta light's sample is
    returned as a failed one."""

    shapes: list
    ref: np.ndarray
    background: float = 0.0
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    lights: tuple = ()

    @functools.cached_property
    def core(self):
        cam = rt.Camera(lookfrom=(0.0, 0.0, -10.0), lookat=(0.0, 0.0, 0.0), vup=(0, 1, 0), vfov=60.0, width=2, height=2)
        return probe.core_scene(rt.Scene(camera=cam, shapes=list(self.shapes), background=self.background,
                                         lights=tuple(self.lights)))

    def _refs(self, m: int) -> np.ndarray:
        return _c(np.broadcast_to(np.asarray(self.ref, dtype=np.float64), (m, 3)))

    def sample_full(self, u) -> dict:
        """Every field of ``sample_lights`` for (n, 3) uniforms (wi in world space)."""
        u = _c(u)
        return self.core.sample_lights(self._refs(len(u)), u)

    def sample(self, u) -> np.ndarray:
        return _directions(self.sample_full(u)) @ self.rotation.T

    def pdf(self, dirs) -> np.ndarray:
        world = _c(np.asarray(dirs) @ self.rotation)
        return self.core.light_pdf(self._refs(len(world)), world)


def fresnel_schlick(cos_i: float, ior: float) -> float:
    """Schlick's approximation R0 + (1 - R0)(1 - |cos_i|)^5, total internal reflection exact."""
    if fresnel_dielectric(cos_i, ior) == 1.0:
        return 1.0
    r0 = ((1.0 - ior) / (1.0 + ior)) ** 2
    return r0 + (1.0 - r0) * (1.0 - abs(cos_i)) ** 5


def refract_expected(wo: np.ndarray, ior: float):
    """Snell's law for ``wo`` (+z the outside normal): the transmitted direction (None under
    total internal reflection) and the relative index n_t / n_i."""
    n1, n2 = (1.0, ior) if wo[2] >= 0 else (ior, 1.0)
    eta = n2 / n1
    tangent = -np.array([wo[0], wo[1], 0.0]) / eta
    t2 = float(tangent @ tangent)
    if t2 >= 1.0:
        return None, eta
    return tangent + np.array([0.0, 0.0, -math.copysign(math.sqrt(1.0 - t2), wo[2])]), eta
