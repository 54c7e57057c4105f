"""reference_tracer: a from-scratch BRDF path tracer with a Python API over a C++17 core.

Examples
--------
>>> import reference_tracer as rt
>>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=16, height=16)
>>> scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))],
...                  background=1.0)
>>> result = rt.render(scene, spp=4, strategy="mis", seed=0)
>>> result.mean.shape
(16, 16, 3)
"""
from .bitmap import Bitmap
from .build import build_id
from .estimate import ImageEstimate, SampleMoments
from .imageio import write_exr, write_png, read_exr, read_hdr, to_display
from .envmap import EnvMap
from .lights import DirectionalLight, Light, PointLight, SpotLight
from .conductors import Metal, RoughConductor
from .dielectrics import Dielectric, RoughDielectric, ThinDielectric
from .mask import Mask
from .materials import DISTRIBUTIONS, DiffuseLight, Lambertian, Material
from .plastics import Plastic, RoughPlastic
from .mesh import Mesh
from .projector import ProjectorLight
from .render import INTEGRATORS, STRATEGIES, TRIANGLE_TESTS, RenderResult, render
from .scene import FILTERS, MAX_DEPTH_CAP, Camera, Direct, Filter, Scene
from .shapes import Box, Quad, Shape, Sphere, Triangle
from .textures import Checkerboard, MeshAttribute, Texture

__version__ = "0.1.0"

__all__ = [
    "Camera", "Direct", "Filter", "FILTERS", "Scene", "Shape", "Sphere", "Quad", "Box", "Triangle", "Mesh",
    "Material", "Lambertian", "Metal", "Dielectric", "RoughConductor", "Plastic", "RoughPlastic", "ThinDielectric",
    "RoughDielectric", "DiffuseLight", "Mask",
    "DISTRIBUTIONS", "Light", "EnvMap", "PointLight", "SpotLight", "DirectionalLight", "ProjectorLight", "Texture",
    "Checkerboard", "MeshAttribute",
    "Bitmap",
    "render", "RenderResult", "ImageEstimate", "SampleMoments", "STRATEGIES", "TRIANGLE_TESTS", "INTEGRATORS", "MAX_DEPTH_CAP",
    "build_id", "write_exr", "read_exr", "read_hdr", "write_png", "to_display", "__version__",
]
