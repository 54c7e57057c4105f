"""The preamble of the small Mitsuba 3 XML scenes that tests write inline.

``scene_xml(body, ...)`` is the whole ``<scene>``: an integrator, a perspective sensor
(``hdrfilm``, a box filter) and then ``body`` as given. ``diffuse_floor()`` is the floor
rectangle several of those bodies start with; ``path_integrator(n)`` the usual integrator.
"""
from __future__ import annotations


def path_integrator(max_depth: int) -> str:
    """``<integrator type="path">`` with ``max_depth``."""
    return f'<integrator type="path"><integer name="max_depth" value="{max_depth}"/></integrator>'


def diffuse_floor(scale: float = 3, reflectance: str = "0.7, 0.6, 0.5") -> str:
    """A diffuse floor at y = 0 facing +y: Mitsuba's rectangle (the square [-1, 1]^2 at z = 0)
    scaled by ``scale`` and turned -90 degrees about x; ``reflectance`` as Mitsuba's rgb text."""
    return (f'    <shape type="rectangle"><transform name="to_world"><scale value="{scale}"/>'
            f'<rotate x="1" angle="-90"/></transform>\n'
            f'        <bsdf type="diffuse"><rgb name="reflectance" value="{reflectance}"/></bsdf></shape>\n')


def scene_xml(body: str = "", *, width: int, height: int, fov: float | None = None, origin: str | None = None,
              target: str | None = None, up: str = "0, 1, 0", integrator: str = "", sampler: str = "",
              rfilter: str | None = "box") -> str:
    """The text of ``<scene version="3.0.0">`` holding, in this order:

    * ``integrator``: XML written as given (usually :func:`path_integrator` or a
      ``<integrator type="direct">``); none by default (Mitsuba's path integrator);
    * ``<sensor type="perspective">`` with ``<float name="fov">`` when ``fov`` is given (else
      Mitsuba's 50 mm lens), a ``to_world`` ``<lookat origin target up>`` when ``origin`` and
      ``target`` are given ("x, y, z" text as in the XML; else Mitsuba's camera at the origin
      looking down +z), ``sampler`` XML as given, and ``<film type="hdrfilm">`` of ``width`` x
      ``height`` with an ``<rfilter>`` of type ``rfilter`` (``None``: none, Mitsuba's gaussian);
    * ``body`` as given: the shapes, emitters and anything else, in their order.
    """
    if (origin is None) != (target is None):
        raise ValueError("scene_xml: give both origin and target, or neither")
    sensor = ['    <sensor type="perspective">']
    if fov is not None:
        sensor.append(f'        <float name="fov" value="{fov}"/>')
    if origin is not None:
        sensor.append(f'        <transform name="to_world"><lookat origin="{origin}" target="{target}" up="{up}"/>'
                      '</transform>')
    if sampler:
        sensor.append(f"        {sampler}")
    film = f'<integer name="width" value="{width}"/><integer name="height" value="{height}"/>'
    if rfilter is not None:
        film += f'\n            <rfilter type="{rfilter}"/>'
    sensor += [f'        <film type="hdrfilm">{film}</film>', "    </sensor>"]
    head = ['<scene version="3.0.0">'] + ([f"    {integrator}"] if integrator else []) + sensor
    return "\n".join(head) + "\n" + body.strip("\n") + "\n</scene>\n"
