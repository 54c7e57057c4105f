"""The opacity mask: :class:`Mask`, Mitsuba's ``mask``, a material around another that lets
light pass straight through where the surface is not opaque.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .materials import DiffuseLight, Material
from .textures import MeshAttribute, Texture
from .validation import flag

__all__ = ["Mask"]


@dataclass(frozen=True)
class Mask(Material):
    """Mitsuba's ``mask``: ``material`` where the surface is opaque, nothing where it is not.

    At a hit the surface is present with probability ``opacity`` (alpha): there it
    scatters as ``material`` (its BSDF times alpha; a sample of it has its own weight and
    its density times alpha), and with probability ``1 - alpha`` the ray goes straight on
    (Mitsuba's null lobe: a Dirac lobe of weight 1). The null lobe passes from both sides,
    also where ``material`` is one-sided (black from the back). As in Mitsuba's ``path``
    integrator, a pass through the mask is a vertex of the path (``max_depth`` counts it),
    an emitter met right after it is not MIS-weighted, and shadow rays treat the surface as
    opaque.

    Parameters
    ----------
    material : Material
        The nested material: any but a :class:`DiffuseLight` (a mask around an emitter is
        not supported) or another :class:`Mask`.
    opacity : float or Texture
        alpha, a constant in [0, 1] (Mitsuba's default 0.5), or a texture
        (:class:`~reference_tracer.Checkerboard`, :class:`~reference_tracer.Bitmap`) read as
        Mitsuba's ``eval_1`` reads it (:meth:`~reference_tracer.Texture.eval_1`: a colour
        bitmap's luminance, a checkerboard's colour means with its cells swapped) at the
        hit's texture coordinates.
    clip : bool, keyword-only
        False (default): an opacity outside [0, 1] (a constant, or a texture's values) is
        refused. True: it is clipped to [0, 1] as Mitsuba's ``eval_opacity`` does (a
        constant here, a texture after each lookup): what the Mitsuba importer passes. NaN
        is refused either way.

    Raises
    ------
    ValueError
        ``material`` not a material, an emitter or a mask; ``opacity`` not a number or a
        texture, NaN or infinite, or outside [0, 1] without ``clip``.

    Examples
    --------
    >>> from reference_tracer import Lambertian
    >>> m = Mask(Lambertian(0.5), 0.25)
    >>> m.opacity, m.material.albedo
    (0.25, (0.5, 0.5, 0.5))
    >>> Mask(Lambertian(0.5), 1.5, clip=True).opacity
    1.0
    >>> Mask(Lambertian(0.5), 1.5)
    Traceback (most recent call last):
    ...
    ValueError: Mask.opacity must lie in [0, 1], got 1.5 (clip=True clips it, as Mitsuba does)
    """

    material: Material
    opacity: object = 0.5
    clip: bool = field(default=False, kw_only=True)

    def __post_init__(self):
        set_ = object.__setattr__
        if not isinstance(self.material, Material):
            raise ValueError(f"Mask.material must be a material, got {self.material!r}")
        if isinstance(self.material, DiffuseLight):
            raise ValueError("Mask around a DiffuseLight: a mask around an emitter is not supported")
        if isinstance(self.material, Mask):
            raise ValueError("Mask around a Mask: nest one mask only (its opacity the product of both, for "
                             "constants)")
        set_(self, "clip", flag("Mask.clip", self.clip))
        if isinstance(self.opacity, MeshAttribute):
            return  # its values are its mesh's, clipped at each hit as Mitsuba's eval_opacity clips them
        if isinstance(self.opacity, Texture):
            lo, hi = self.opacity.scalar().value_range()
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise ValueError(f"Mask.opacity: a {type(self.opacity).__name__} texture with values that are not "
                                 "finite")
            if not self.clip and not (lo >= 0.0 and hi <= 1.0):
                raise ValueError(f"Mask.opacity: a {type(self.opacity).__name__} texture with values in "
                                 f"[{lo:.6g}, {hi:.6g}]; an opacity must lie in [0, 1] (clip=True clips it, as "
                                 "Mitsuba does)")
            return
        if isinstance(self.opacity, (bool, np.bool_)) or not isinstance(self.opacity, (int, float, np.integer,
                                                                                         np.floating)):
            raise ValueError(f"Mask.opacity must be a number in [0, 1] or a texture, got {self.opacity!r}")
        a = float(self.opacity)
        if not np.isfinite(a):
            raise ValueError(f"Mask.opacity must be finite, got {a}")
        if not self.clip and not 0.0 <= a <= 1.0:
            raise ValueError(f"Mask.opacity must lie in [0, 1], got {a} (clip=True clips it, as Mitsuba does)")
        set_(self, "opacity", min(1.0, max(0.0, a)))

    @property
    def is_specular(self) -> bool:
        return self.material.is_specular
