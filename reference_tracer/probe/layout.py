"""Layout of the compiled core, read from it on first access: its constants (``PACK_WIDTH``,
``PACKET_RAYS``, ``RAY_CHUNK``, ``CACHED_TREE_BYTES``, ``LANE_WIDTHS``, served as attributes of
:mod:`reference_tracer.probe`) and the order in which the BVH traversals visit a node's children;
and :func:`core`, the one place the probes load the compiled core.
"""
from __future__ import annotations

__all__ = ["CORE_CONSTANTS", "core", "core_constant", "child_visit_order"]

#: The layout constants that :mod:`reference_tracer.probe` reads from the compiled core.
CORE_CONSTANTS = ("PACK_WIDTH", "PACKET_RAYS", "RAY_CHUNK", "CACHED_TREE_BYTES", "LANE_WIDTHS")


def core():
    """The compiled core, ``reference_tracer._core``, loaded on first use."""
    from .. import _core  # the C++ core loads on first use, as for render: importing the probes does not need it

    return _core


def core_constant(name: str):
    """The layout constant ``name``, one of :data:`CORE_CONSTANTS`, read from the compiled core (loading it).

    ``LANE_WIDTHS`` is a tuple of int, the others an int.
    """
    if name == "LANE_WIDTHS":
        return tuple(int(w) for w in core().LANE_WIDTHS)
    return int(getattr(core(), name))


def child_visit_order(t_near, met) -> tuple:
    """The order in which the BVH traversals visit the children a ray meets in a node of the wide tree.

    Parameters
    ----------
    t_near : sequence of float, length 8
        The children's entry distances (>= 0, not NaN).
    met : sequence of bool, length 8
        Which children the ray meets.

    Returns
    -------
    network, insertion : list of int
        The slots met, nearest first, as the interleaved traversal's sorting network orders
        them and as the single-ray traversal's insertion sort does (the two must agree).

    Examples
    --------
    >>> child_visit_order([3.0, 1.0, 2.0, 0, 0, 0, 0, 0], [True, True, True] + [False] * 5)
    ([1, 2, 0], [1, 2, 0])
    """
    return core().child_visit_order(list(t_near), list(met))
