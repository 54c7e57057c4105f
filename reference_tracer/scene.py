"""Camera and Scene: the description that both renderers consume."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field

import numpy as np

from .envmap import EnvMap
from .lights import Light
from .validation import colour, finite_scalar, integrator_depths, positive_int, vector3
from .shapes import Shape

__all__ = ["Camera", "Direct", "Filter", "FILTERS", "PROJECTIONS", "Scene", "MAX_DEPTH_CAP"]

#: Safety cap on path length when ``max_depth=-1`` (unlimited). A path that survives
#: this many segments carries a throughput so small (or Russian roulette has long ended
#: it) that truncating it changes no pixel at float32 precision in the suite scenes.
MAX_DEPTH_CAP = 1024


@dataclass(frozen=True)
class Filter:
    """Pixel reconstruction filter, as Mitsuba's ``rfilter``.

    Samples are drawn uniformly inside their pixel (Mitsuba's independent sampler). With
    ``"box"`` (the default) each pixel is the plain mean of its own samples. With
    ``"tent"`` (``radius``, default 1) or ``"gaussian"`` (``stddev``, default 0.5,
    truncated at 4 standard deviations and shifted to reach zero there) every sample is
    splatted to each pixel the filter covers, weighted by the filter at the offset of that
    pixel's centre, and a pixel is its weighted sum over its summed weights: Mitsuba's
    ``hdrfilm``. A filtered pixel is a ratio of correlated sums; :func:`reference_tracer.render`
    estimates its variance from independent batches (see there).

    Examples
    --------
    >>> Filter("gaussian").radius
    2.0
    """

    kind: str = "box"
    radius: float | None = None
    stddev: float | None = None

    def __post_init__(self):
        if self.kind not in FILTERS:
            raise ValueError(f"Filter.kind must be one of {FILTERS}, got {self.kind!r}")
        if self.kind == "gaussian":
            if self.radius is not None:
                raise ValueError("Filter('gaussian') takes stddev (its radius is 4 stddev), not radius")
            sd = finite_scalar("Filter.stddev", 0.5 if self.stddev is None else self.stddev, lo=0.0, lo_open=True,
                               hi=16.0)
            object.__setattr__(self, "stddev", sd)
            object.__setattr__(self, "radius", 4.0 * sd)
        else:
            if self.stddev is not None:
                raise ValueError(f"Filter({self.kind!r}) takes no stddev")
            r = 0.5 if self.kind == "box" else finite_scalar("Filter.radius", 1.0 if self.radius is None
                                                             else self.radius, lo=0.0, lo_open=True, hi=64.0)
            if self.kind == "box" and self.radius not in (None, 0.5):
                raise ValueError("Filter('box') has radius 0.5 (the pixel itself)")
            object.__setattr__(self, "radius", r)

    @property
    def is_box(self) -> bool:
        return self.kind == "box"

    def describe(self) -> dict:
        return {"kind": self.kind, "radius": self.radius, "stddev": self.stddev}


#: reconstruction filters of :class:`Filter`, in the core's order.
FILTERS = ("box", "tent", "gaussian")


#: projections of :class:`Camera`, in the core's order.
PROJECTIONS = ("perspective", "orthographic")

#: ``Camera.vfov`` when none is given (perspective cameras).
DEFAULT_VFOV = 40.0


@dataclass(frozen=True)
class Camera:
    """Camera: a pinhole by default, a thin lens or an orthographic view by option.

    ``vfov`` is the vertical field of view in degrees. Pixel (0, 0) is the top-left corner
    of the image. Samples are jittered uniformly inside their pixel (Mitsuba's independent
    sampler); ``filter`` decides how they make the pixels (:class:`Filter`; the default box:
    each pixel the plain mean of its own).

    The keyword-only options are Mitsuba 3's ``thinlens`` and ``orthographic`` sensors:

    * ``aperture_radius > 0`` (perspective only) makes a thin lens (Mitsuba's ``thinlens``):
      each camera ray leaves a point drawn uniformly on a disk of that radius about
      ``lookfrom``, perpendicular to the view, and passes through the point the pinhole's ray
      of the same film point meets at distance ``focus_distance`` along the view direction
      (the plane in focus). ``focus_distance`` is then required.
    * ``projection="orthographic"`` (Mitsuba's ``orthographic``): parallel rays along the
      view direction from a ``view_width`` x ``view_height`` rectangle (world units) centred
      on ``lookfrom``; ``view_width`` defaults to ``view_height`` times the image's aspect
      (square pixels). It takes no ``vfov``.
    * ``near_clip`` and ``far_clip``: distances along the view direction. A camera ray starts
      on the near plane (nothing nearer is seen) and a hit at or beyond the far plane is a
      miss, as in Mitsuba. The defaults (0 and infinity) clip nothing; Mitsuba's own defaults
      are 0.01 and 10000.

    Parameters
    ----------
    lookfrom, lookat, vup : (3,) array_like
        Eye (lens centre, or the view's centre), a point it looks at, the image's up.
    vfov : float, optional
        Vertical field of view in degrees, in (0, 179] (default 40); perspective only.
    width, height : int
        Image size in pixels.
    filter : Filter, optional
    aperture_radius : float, optional
        Lens radius, >= 0 (default 0: the pinhole).
    focus_distance : float, optional
        Distance of the plane in focus, > 0; only with ``aperture_radius > 0``.
    projection : {"perspective", "orthographic"}, optional
    view_height, view_width : float, optional
        The orthographic view's extent in world units (``view_height`` required there).
    near_clip, far_clip : float, optional
        Clip planes, ``0 <= near_clip < far_clip <= inf``.

    Raises
    ------
    ValueError
        For a value out of range or an option the projection does not take (a thin-lens
        orthographic camera, ``vfov`` with ``projection="orthographic"``, ...).

    Examples
    --------
    >>> Camera(lookfrom=(278, 278, -800), lookat=(278, 278, 0), vup=(0, 1, 0),
    ...        vfov=40.0, width=64, height=64).aspect
    1.0
    >>> lens = Camera(lookfrom=(0, 1, -5), lookat=(0, 1, 0), vfov=30, width=64, height=48,
    ...               aperture_radius=0.1, focus_distance=5.0)
    >>> lens.is_thin_lens
    True
    >>> ortho = Camera(lookfrom=(0, 0, -5), lookat=(0, 0, 0), width=64, height=32,
    ...                projection="orthographic", view_height=2.0)
    >>> ortho.view_size
    (4.0, 2.0)
    >>> Camera(lookfrom=(0, 0, -5), lookat=(0, 0, 0), vfov=40, projection="orthographic", view_height=2.0)
    Traceback (most recent call last):
    ...
    ValueError: Camera.vfov is a perspective camera's; an orthographic one's extent is view_height (and view_width)
    """

    lookfrom: tuple
    lookat: tuple
    vup: tuple = (0.0, 1.0, 0.0)
    vfov: float | None = None
    width: int = 400
    height: int = 400
    filter: Filter = field(default_factory=Filter, kw_only=True)
    aperture_radius: float = field(default=0.0, kw_only=True)
    focus_distance: float | None = field(default=None, kw_only=True)
    projection: str = field(default="perspective", kw_only=True)
    view_height: float | None = field(default=None, kw_only=True)
    view_width: float | None = field(default=None, kw_only=True)
    near_clip: float = field(default=0.0, kw_only=True)
    far_clip: float = field(default=math.inf, kw_only=True)

    def __post_init__(self):
        if not isinstance(self.filter, Filter):
            raise ValueError(f"Camera.filter must be a reference_tracer.Filter, got {self.filter!r}")
        for name in ("lookfrom", "lookat", "vup"):
            object.__setattr__(self, name, vector3(f"Camera.{name}", getattr(self, name)))
        if not isinstance(self.projection, str) or self.projection not in PROJECTIONS:
            raise ValueError(f"Camera.projection must be one of {PROJECTIONS}, got {self.projection!r}")
        ortho = self.projection == "orthographic"
        if ortho:
            if self.vfov is not None:
                raise ValueError("Camera.vfov is a perspective camera's; an orthographic one's extent is "
                                 "view_height (and view_width)")
            if self.view_height is None:
                raise ValueError("Camera(projection='orthographic') needs view_height (the view's height in "
                                 "world units)")
            object.__setattr__(self, "view_height", finite_scalar("Camera.view_height", self.view_height, lo=0.0,
                                                                  lo_open=True))
            if self.view_width is not None:
                object.__setattr__(self, "view_width", finite_scalar("Camera.view_width", self.view_width,
                                                                     lo=0.0, lo_open=True))
        else:
            for name in ("view_height", "view_width"):
                if getattr(self, name) is not None:
                    raise ValueError(f"Camera.{name} is an orthographic camera's (projection='orthographic'); "
                                     f"a perspective one's extent is vfov")
            vfov = DEFAULT_VFOV if self.vfov is None else self.vfov
            object.__setattr__(self, "vfov", finite_scalar("Camera.vfov", vfov, lo=0.0, lo_open=True, hi=179.0))
        object.__setattr__(self, "width", positive_int("Camera.width", self.width))
        object.__setattr__(self, "height", positive_int("Camera.height", self.height))
        r = finite_scalar("Camera.aperture_radius", self.aperture_radius, lo=0.0)
        object.__setattr__(self, "aperture_radius", r)
        if r > 0.0:
            if ortho:
                raise ValueError("Camera.aperture_radius: an orthographic camera has no lens (Mitsuba's thinlens "
                                 "is a perspective camera)")
            if self.focus_distance is None:
                raise ValueError("Camera.aperture_radius > 0 (a thin lens) needs focus_distance, the distance "
                                 "of the plane in focus")
            object.__setattr__(self, "focus_distance", finite_scalar("Camera.focus_distance", self.focus_distance,
                                                                     lo=0.0, lo_open=True))
        elif self.focus_distance is not None:
            raise ValueError("Camera.focus_distance is a thin lens's: give aperture_radius > 0 with it (a pinhole "
                             "is in focus everywhere)")
        near = finite_scalar("Camera.near_clip", self.near_clip, lo=0.0)
        object.__setattr__(self, "near_clip", near)
        try:
            far = float(self.far_clip)
        except (TypeError, ValueError):
            raise ValueError(f"Camera.far_clip must be a number, got {self.far_clip!r}") from None
        if not far > near:  # NaN too
            raise ValueError(f"Camera.far_clip must exceed near_clip ({near}), got {self.far_clip!r}")
        object.__setattr__(self, "far_clip", far)
        d = np.subtract(self.lookat, self.lookfrom)
        if np.linalg.norm(d) == 0:
            raise ValueError("Camera.lookat must differ from Camera.lookfrom")
        if np.linalg.norm(np.cross(d / np.linalg.norm(d), self.vup)) < 1e-9 * max(np.linalg.norm(self.vup), 1e-300):
            raise ValueError("Camera.vup must not be parallel to the viewing direction (lookat - lookfrom)")

    @property
    def aspect(self) -> float:
        return self.width / self.height

    @property
    def is_thin_lens(self) -> bool:
        return self.aperture_radius > 0.0

    @property
    def is_orthographic(self) -> bool:
        return self.projection == "orthographic"

    @property
    def is_pinhole(self) -> bool:
        """The plain pinhole: perspective, no lens, no clip planes (the camera of every scene before options)."""
        return (not self.is_orthographic and not self.is_thin_lens and self.near_clip == 0.0
                and self.far_clip == math.inf)

    @property
    def view_size(self) -> tuple[float, float] | None:
        """``(width, height)`` of an orthographic view in world units (None for perspective)."""
        if not self.is_orthographic:
            return None
        w = self.view_height * self.aspect if self.view_width is None else self.view_width
        return (float(w), float(self.view_height))

    def basis(self):
        """(forward, right, up) unit vectors of the camera in world space."""
        w = np.subtract(self.lookat, self.lookfrom)
        w = w / np.linalg.norm(w)
        right = np.cross(w, self.vup)
        right /= np.linalg.norm(right)
        up = np.cross(right, w)
        return w, right, up

    def with_size(self, width: int, height: int) -> "Camera":
        return dataclasses.replace(self, width=width, height=height)

    def describe(self) -> dict:
        """The camera's part of :meth:`Scene.describe`: options only where they differ from the defaults."""
        out = {"lookfrom": self.lookfrom, "lookat": self.lookat, "vup": self.vup, "vfov": self.vfov,
               "width": self.width, "height": self.height}
        # pinhole box-filtered scenes keep the hash they always had (cached references stay valid)
        if not self.filter.is_box:
            out["filter"] = self.filter.describe()
        if self.is_orthographic:
            out["projection"] = self.projection
            out["view_height"] = self.view_height
            if self.view_width is not None:
                out["view_width"] = self.view_width
        if self.is_thin_lens:
            out["aperture_radius"] = self.aperture_radius
            out["focus_distance"] = self.focus_distance
        if self.near_clip != 0.0:
            out["near_clip"] = self.near_clip
        if self.far_clip != math.inf:
            out["far_clip"] = self.far_clip
        return out


#: Largest sample count of either kind of :class:`Direct`.
MAX_DIRECT_SAMPLES = 4096


@dataclass(frozen=True)
class Direct:
    """Mitsuba's ``direct`` integrator: direct light only, by light and BSDF samples.

    A camera ray adds the emission of what it hits (emitters emit from their front only) and,
    at that surface, ``emitter_samples`` samples toward the emitters (with a shadow ray) and
    ``bsdf_samples`` directions sampled from the material, each kind averaged over its own
    count. With both kinds each sample is weighted by the power heuristic on densities scaled
    by the kind's share of the samples (``n_e / (n_e + n_b)`` and ``n_b / (n_e + n_b)``), as
    Mitsuba does. Nothing is traced beyond the first surface: a mirror shows only emitters
    seen in it, and only through BSDF samples.

    The render's ``strategy`` picks the techniques (:meth:`counts`): ``mis`` uses both counts
    as given; ``light`` only light samples and ``cosine`` only material samples, as many as
    the integrator gives that kind (or the other kind's count where it gives none);
    ``uniform`` and ``mixture`` draw the directions uniformly on the hemisphere or from the
    half-and-half mixture of light and material sampling. Mitsuba's own ``direct`` with
    ``emitter_samples=0`` is our ``cosine``, with ``bsdf_samples=0`` our ``light``.

    Parameters
    ----------
    emitter_samples, bsdf_samples : int
        Samples of each kind per camera ray, 0 to 4096, not both 0 (Mitsuba's defaults: 1).

    Examples
    --------
    >>> Direct(emitter_samples=1, bsdf_samples=0).counts("light")
    (1, 0)
    >>> Direct(1, 1).counts("cosine")
    (0, 1)
    """

    emitter_samples: int = 1
    bsdf_samples: int = 1

    def __post_init__(self):
        for name in ("emitter_samples", "bsdf_samples"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 <= v <= MAX_DIRECT_SAMPLES:
                raise ValueError(f"Direct.{name} must be an integer in [0, {MAX_DIRECT_SAMPLES}], got {v!r}")
            object.__setattr__(self, name, int(v))
        if self.emitter_samples + self.bsdf_samples == 0:
            raise ValueError("Direct needs at least one emitter or BSDF sample (Mitsuba refuses 0 and 0 too)")

    def counts(self, strategy: str) -> tuple[int, int]:
        """``(emitter, bsdf)`` samples per camera ray that ``strategy`` takes."""
        ne, nb = self.emitter_samples, self.bsdf_samples
        if strategy == "mis":
            return ne, nb
        if strategy == "light":
            return ne or nb, 0
        return 0, nb or ne

    def describe(self) -> dict:
        return {"emitter_samples": self.emitter_samples, "bsdf_samples": self.bsdf_samples}


def _sequence_of(name: str, value, kind: type, what: str, examples: str = "") -> tuple:
    """``value`` as a tuple of ``kind`` instances; ``ValueError`` naming ``name`` and the first
    item that is not one (``what``: the kind in words, ``examples`` after it in that message)."""
    try:
        items = tuple(value)
    except TypeError:
        raise ValueError(f"{name} must be a sequence of {what}s") from None
    for i, item in enumerate(items):
        if not isinstance(item, kind):
            raise ValueError(f"{name}[{i}] must be a reference_tracer {what}{examples}, got {item!r}")
    return items


@dataclass(frozen=True, eq=False)
class Scene:
    """A camera, a list of shapes and the integrator settings.

    Parameters
    ----------
    camera : Camera
    shapes : sequence of Shape
    max_depth : int
        Path segments as Mitsuba's ``path`` counts them: 1 = only directly visible
        emitters, 2 = direct lighting, -1 = unlimited (capped at ``MAX_DEPTH_CAP``).
    rr_depth : int or None
        Depth from which Russian roulette runs (Mitsuba's rule); None disables it.
    background : float or (3,) array_like
        Constant radiance of every ray that escapes (Mitsuba ``constant`` emitter).
    direct : Direct or None
        Mitsuba's ``direct`` integrator instead of ``path`` (``max_depth`` and ``rr_depth``
        then play no part).
    lights : sequence of Light
        Lights that are not shapes: at most one :class:`~reference_tracer.EnvMap` (the
        scene's environment, in place of ``background``, which must then be black: Mitsuba
        allows one environment emitter), and any number of
        :class:`~reference_tracer.PointLight`, :class:`~reference_tracer.SpotLight`,
        :class:`~reference_tracer.DirectionalLight` and
        :class:`~reference_tracer.ProjectorLight` (delta lights: only the ``mis`` and
        ``light`` strategies can see them).

    Examples
    --------
    >>> import reference_tracer as rt
    >>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=8, height=8)
    >>> scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))],
    ...                  background=1.0)
    >>> scene.max_depth
    50
    """

    camera: Camera
    shapes: tuple = ()
    max_depth: int = 50
    rr_depth: int | None = None
    background: tuple = (0.0, 0.0, 0.0)
    direct: Direct | None = None
    lights: tuple = ()
    # The compiled C++ scene, per triangle test. Not an __init__ field, so that
    # dataclasses.replace(scene, ...) gives the new scene an empty cache of its own rather
    # than the original's compiled core (which rendered the old scene: issue 15, case 0).
    _core_cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self):
        if not isinstance(self.camera, Camera):
            raise ValueError(f"Scene.camera must be a reference_tracer.Camera, got {self.camera!r}")
        object.__setattr__(self, "shapes", _sequence_of("Scene.shapes", self.shapes, Shape, "shape"))
        max_depth, rr_depth = integrator_depths(self.max_depth, self.rr_depth)
        object.__setattr__(self, "max_depth", max_depth)
        object.__setattr__(self, "rr_depth", rr_depth)
        object.__setattr__(self, "background", colour("Scene.background", self.background, upper=None))
        if self.direct is not None and not isinstance(self.direct, Direct):
            raise ValueError(f"Scene.direct must be a reference_tracer.Direct or None, got {self.direct!r}")
        if isinstance(self.lights, (Light, str, bytes)):
            raise ValueError("Scene.lights must be a sequence of lights (EnvMap, PointLight, SpotLight, "
                             "DirectionalLight, ProjectorLight), not one")
        lights = _sequence_of("Scene.lights", self.lights, Light, "light",
                              " (EnvMap, PointLight, SpotLight, DirectionalLight, ProjectorLight)")
        envs = [i for i, light in enumerate(lights) if isinstance(light, EnvMap)]
        if len(envs) > 1:
            raise ValueError(f"Scene.lights holds {len(envs)} EnvMaps (at {envs}): a scene has one environment "
                             "(as in Mitsuba)")
        if envs and max(self.background) > 0.0:
            raise ValueError("Scene.background must be black when Scene.lights holds an EnvMap: a scene has one "
                             "environment, a constant or a map (as in Mitsuba)")
        object.__setattr__(self, "lights", lights)

    @property
    def effective_max_depth(self) -> int:
        return MAX_DEPTH_CAP if self.max_depth == -1 else min(self.max_depth, MAX_DEPTH_CAP)

    def describe(self) -> dict:
        """A JSON-able description of everything that determines the image."""
        return {
            "camera": self.camera.describe(),
            "shapes": [s.describe() for s in self.shapes],
            "max_depth": self.max_depth, "rr_depth": self.rr_depth,
            "background": self.background,
            # path scenes keep the hash they always had
            **({} if self.direct is None else {"direct": self.direct.describe()}),
            **({"lights": [light.describe() for light in self.lights]} if self.lights else {}),
        }

    def content_hash(self) -> str:
        """SHA-256 of :meth:`describe` (stable across runs; used as a cache key)."""
        text = json.dumps(self.describe(), sort_keys=True, default=_json_default)
        return hashlib.sha256(text.encode()).hexdigest()

    def with_camera_size(self, width: int, height: int) -> "Scene":
        return Scene(self.camera.with_size(width, height), self.shapes, self.max_depth,
                     self.rr_depth, self.background, self.direct, self.lights)

    @property
    def emitters(self):
        return [s for s in self.shapes if s.material.emits]

    @property
    def has_background(self) -> bool:
        """Whether the constant ``background`` is lit (an EnvMap is :attr:`environment`)."""
        return max(self.background) > 0.0

    @property
    def environment(self):
        """The scene's :class:`~reference_tracer.EnvMap`, or None."""
        return next((light for light in self.lights if isinstance(light, EnvMap)), None)

    @property
    def delta_lights(self) -> list:
        """The point, spot and directional lights of ``lights``."""
        return [light for light in self.lights if light.delta]


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    raise TypeError(f"not JSON-serialisable: {type(x)}")
