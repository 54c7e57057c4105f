"""Which of a material's inputs a texture may give: :func:`reflectance_of` (its reflectance, seen
through a mask) and :func:`textures_of` (every texture it looks up at a hit, a mask's opacity too),
for the scene compiler, the meshes' checks, the probes and the Mitsuba bridge.
"""
from __future__ import annotations

from .mask import Mask
from .materials import Material
from .plastics import Coated
from .textures import Texture

__all__ = ["reflectance_of", "textures_of"]


def textures_of(material: Material) -> list:
    """The textures ``material`` looks up at a hit: its reflectance's, a mask's opacity's.

    Examples
    --------
    >>> from reference_tracer import Checkerboard, Lambertian
    >>> len(textures_of(Mask(Lambertian(Checkerboard()), Checkerboard())))
    2
    """
    out = [t for t in (reflectance_of(material),) if isinstance(t, Texture)]
    if isinstance(material, Mask) and isinstance(material.opacity, Texture):
        out.append(material.opacity)
    return out


def reflectance_of(material: Material):
    """The reflectance of ``material`` that a texture may give: a plastic's
    ``diffuse_reflectance``, else its ``albedo`` (a Lambertian's, a conductor's
    ``specular_reflectance``, a reflecting light's); None for a material without one.

    Returns
    -------
    tuple, Texture or None
        An RGB triple, a :class:`~reference_tracer.Texture`, or None (a dielectric, a light
        that reflects nothing).

    Examples
    --------
    >>> from reference_tracer import Dielectric, Plastic
    >>> reflectance_of(Plastic(0.3)), reflectance_of(Dielectric(1.5))
    ((0.3, 0.3, 0.3), None)
    """
    if isinstance(material, Mask):
        return reflectance_of(material.material)
    if isinstance(material, Coated):
        return material.diffuse_reflectance
    return getattr(material, "albedo", None)
