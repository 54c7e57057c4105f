"""``MeshData``: what reading a mesh file gives, whatever its format (the vertices, faces, and
the normals, texture coordinates and attributes the file holds).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MeshData"]


@dataclass(frozen=True)
class MeshData:
    """A mesh file's contents: ``vertices`` (N, 3) and ``faces`` (M, 3) int64, the file's
    vertex ``normals`` (N, 3), or None where it has none (or they were not read), and its
    texture coordinates ``uv`` (N, 2) as the file holds them (NaN for a vertex a face gives
    none), or None where it has none."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uv: np.ndarray | None = None
    attributes: dict | None = None
