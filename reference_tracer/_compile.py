"""Flatten a :class:`Scene` into the world-space arrays the C++ core consumes.

Boxes become six quads, meshes become triangles, transforms are applied and
``flip_normals`` is baked into the winding (quads: u and v swapped; triangles: b and c
swapped; spheres: a flag). Materials are deduplicated into a table. A mesh with vertex
normals adds its triangles' corner normals (``triangle_normals``, world space, negated
when flipped) and their indices (``smooth_triangles``); a scene shaded flat passes
neither, and the core then stores nothing for normals. A scene with textures passes them
(``textures``: their table, each material's texture, each masked material's opacity
texture, and every primitive's texture coordinates in Mitsuba's parameterisation of its
shape); a scene without passes nothing. A mesh attribute texture is bound to its mesh: the
mesh gets a material row of its own, whose texture holds that mesh's values per triangle.
"""
from __future__ import annotations

import math

import numpy as np

from .bitmap import FILTER_TYPES, WRAP_MODES, Bitmap
from .conductors import Metal, RoughConductor
from .dielectrics import Dielectric, RoughDielectric, ThinDielectric
from .mask import Mask
from .material_textures import reflectance_of, textures_of
from .materials import DISTRIBUTIONS, DiffuseLight, Lambertian
from .plastics import Plastic, RoughPlastic
from .lights import DirectionalLight, PointLight, SpotLight
from .mesh import Mesh
from .projector import ProjectorLight
from .scene import DEFAULT_VFOV, PROJECTIONS, Scene
from .shapes import Box, Quad, Sphere, Triangle
from .textures import Checkerboard, MeshAttribute, Texture

# Material table columns; must match MaterialType and the material rows read in cpp/bindings.cpp.
MATERIAL_CODES = {Lambertian: 0, Metal: 1, Dielectric: 2, RoughConductor: 3, DiffuseLight: 4, Plastic: 5,
                  RoughPlastic: 6, ThinDielectric: 7, RoughDielectric: 8}
# type, albedo rgb, radiance rgb, param, two_sided, reflects, variant, distribution, fresnel, eta rgb, k rgb,
# plastic: int_ior / ext_ior, specular_reflectance rgb, nonlinear (rough dielectric: its int_ior / ext_ior in
# the first of these), masked (a Mask around the material the row describes), opacity (a Mask's constant; its
# texture's, where it has one, replaces it at each hit)
MATERIAL_COLUMNS = 26


def _material_row(m) -> list:
    if isinstance(m, Mask):
        opacity = m.opacity if not isinstance(m.opacity, Texture) else 1.0
        return _material_row(m.material)[:-2] + [1.0, float(opacity)]
    code = MATERIAL_CODES[type(m)]
    plastic = isinstance(m, (Plastic, RoughPlastic))
    # a plastic's albedo column is its base's reflectance; a texture's is its mean (what a
    # plastic's lobe choice takes; the core replaces it by the texture's value at each hit)
    albedo = reflectance_of(m) or (0.0, 0.0, 0.0)
    if isinstance(albedo, MeshAttribute) and not plastic:
        albedo = (0.0, 0.0, 0.0)  # a lobe choice's mean is a plastic's only; mean() refuses it there
    elif isinstance(albedo, Texture):
        albedo = (albedo.mean(),) * 3
    radiance = m.radiance if isinstance(m, DiffuseLight) else (0.0, 0.0, 0.0)
    param = {Metal: lambda: m.fuzz, Dielectric: lambda: m.ior, RoughConductor: lambda: m.alpha,
             RoughPlastic: lambda: m.alpha, ThinDielectric: lambda: m.ior,
             RoughDielectric: lambda: m.alpha}.get(type(m), lambda: 0.0)()
    # a thin pane is the same from both sides
    two_sided = float(isinstance(m, ThinDielectric) or getattr(m, "two_sided", False))
    reflects = 0.0 if isinstance(m, DiffuseLight) and m.albedo is None else 1.0
    variant = 1.0 if isinstance(m, Dielectric) and m.fresnel == "schlick" else 0.0
    distribution = (float(DISTRIBUTIONS.index(m.distribution))
                    if isinstance(m, (RoughConductor, RoughPlastic, RoughDielectric)) else 0.0)
    eta, k = (None, None) if plastic else (getattr(m, "eta", None), getattr(m, "k", None))
    fresnel = 0.0 if eta is None else 1.0
    coating = ([m.relative_ior, *m.specular_reflectance, float(m.nonlinear)] if plastic
               else [m.ior, 0.0, 0.0, 0.0, 0.0] if isinstance(m, RoughDielectric)
               else [1.0, 0.0, 0.0, 0.0, 0.0])
    return [code, *albedo, *radiance, param, two_sided, reflects, variant, distribution, fresnel,
            *(eta or (0.0, 0.0, 0.0)), *(k or (0.0, 0.0, 0.0)), *coating, 0.0, 1.0]


#: Largest world-space coordinate magnitude a scene may reach. The BVH tests boxes in
#: single precision (floats end at 3.4e38) and rounds boxes and ray origins outward;
#: this leaves that rounding, and the distances it computes, far from overflow.
MAX_COORDINATE = 1e30


def _check_extent(what: str, points) -> None:
    points = np.asarray(points, dtype=np.float64)
    if points.size == 0:
        return
    reach = float(np.max(np.abs(points)))
    if not reach <= MAX_COORDINATE:
        raise ValueError(f"{what} reaches |coordinate| = {reach:.3g}, beyond {MAX_COORDINATE:g}: the BVH tests "
                         "boxes in single precision; rescale the scene")


#: Columns of a delta light's row (cpp/bindings.cpp): kind (0 point, 1 spot, 2 directional,
#: 3 projector), position (3), direction (3), intensity or irradiance (3), a spot's cutoff and
#: beam angles (radians); a textured spot's or a projector's texture (index into the
#: ``light_textures`` table, -1 none) and its mean, world to the light's frame (9, row-major),
#: the uv factor (tan(cutoff), tan(x_fov / 2)) and a projector's aspect ratio.
DELTA_LIGHT_COLUMNS = 25
_NO_TEXTURE = [-1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]


def _delta_light_row(light, texture_id) -> list:
    if isinstance(light, PointLight):
        return [0.0, *light.position, 0.0, 0.0, 0.0, *light.intensity, 0.0, 0.0, *_NO_TEXTURE]
    if isinstance(light, SpotLight):
        row = [1.0, *light.position, *light.direction, *light.intensity,
               math.radians(light.cutoff_angle), math.radians(light.beam_width)]
        if light.texture is None:
            return row + _NO_TEXTURE
        frame = [x for r in light.to_local for x in r]
        return row + [float(texture_id(light.texture)), float(light.texture.mean()), *frame,
                      math.tan(math.radians(light.cutoff_angle)), 1.0]
    if isinstance(light, DirectionalLight):
        return [2.0, 0.0, 0.0, 0.0, *light.direction, *light.irradiance, 0.0, 0.0, *_NO_TEXTURE]
    if isinstance(light, ProjectorLight):
        e = (1.0, 1.0, 1.0) if light.textured else light.irradiance
        row = [3.0, *light.position, *light.direction, *(light.scale * c for c in e), 0.0, 0.0]
        tex, mean = (float(texture_id(light.irradiance)), float(light.irradiance.mean())) if light.textured \
            else (-1.0, 1.0)
        return row + [tex, mean, *(x for r in light.to_local for x in r),
                      math.tan(math.radians(light.x_fov) / 2.0), light.aspect]
    raise ValueError(f"unsupported light {type(light).__name__}")  # pragma: no cover - Scene admits only these


def _lights(scene: Scene) -> dict:
    """The core's arguments for the scene's lights that are not shapes (none without them:
    a scene's arguments stay what they always were)."""
    out = {}
    textures, index = [], {}

    def texture_id(t) -> int:
        if id(t) not in index:
            index[id(t)] = len(textures)
            textures.append(t)
        return index[id(t)]

    deltas = [_delta_light_row(light, texture_id) for light in scene.lights if light.delta]
    if deltas:
        for light in scene.delta_lights:
            if isinstance(light, (PointLight, SpotLight, ProjectorLight)):
                _check_extent(f"{type(light).__name__}.position", [light.position])
        out["delta_lights"] = np.asarray(deltas, dtype=np.float64).reshape(-1, DELTA_LIGHT_COLUMNS)
    if textures:
        table, texels = _texture_table(textures)
        out["light_textures"] = dict(table=table, texels=texels)
    env = scene.environment
    if env is not None:
        out.update(environment=env.pixels, environment_scale=float(env.scale),
                   environment_to_world=np.ascontiguousarray(env.to_world, dtype=np.float64))
    return out


def compile_scene(scene: Scene) -> dict:
    """Return the keyword arguments of ``_core.Scene`` for ``scene``.

    Raises
    ------
    ValueError
        When a shape or the camera lies beyond :data:`MAX_COORDINATE` in world space.
    """
    materials: list = []
    index: dict = {}

    material_objects: list = []

    bound: dict = {}  # material row -> (mesh, its first triangle): rows with mesh attribute textures

    def mat_id(m, mesh=None, first_triangle=0) -> int:
        key = (type(m), tuple(sorted(m.__dict__.items())))
        if mesh is not None:  # its texture's values are this mesh's: a row of its own
            key = (key, id(mesh))
        if key not in index:
            index[key] = len(materials)
            materials.append(_material_row(m))
            material_objects.append(m)
            if mesh is not None:
                bound[index[key]] = (mesh, first_triangle)
        return index[key]

    spheres, quads, tris, tri_mats = [], [], [], []
    smooth, smooth_normals = [], []   # indices of smooth triangles, their (k, 9) corner normals
    n_tris = 0
    for i, s in enumerate(scene.shapes):
        attribute_textures = [t for t in textures_of(s.material) if isinstance(t, MeshAttribute)]
        if attribute_textures and not isinstance(s, Mesh):
            raise ValueError(f"shapes[{i}] ({type(s).__name__}): a MeshAttribute texture "
                             f"({attribute_textures[0].name!r}) reads a mesh's attributes; only a Mesh has them")
        mid = mat_id(s.material, s, n_tris) if attribute_textures else mat_id(s.material)
        n_rows = (len(spheres), len(quads), len(tris))
        if isinstance(s, Sphere):
            spheres.append([*s.world_center(), s.world_radius(), mid, float(s.flip_normals)])
        elif isinstance(s, Quad):
            Q, u, v = s.world_corners()
            quads.append([*Q, *u, *v, mid])
        elif isinstance(s, Box):
            for Q, u, v in s.world_quads():
                quads.append([*Q, *u, *v, mid])
        elif isinstance(s, Triangle):
            tris.append(s.world_vertices().reshape(1, 9))
            tri_mats.append(np.array([mid], dtype=np.int32))
            n_tris += 1
        elif isinstance(s, Mesh):
            t = s.world_triangles().reshape(-1, 9)
            tris.append(t)
            tri_mats.append(np.full(len(t), mid, dtype=np.int32))
            corner_normals = s.world_triangle_normals()
            if corner_normals is not None:
                smooth.append(np.arange(n_tris, n_tris + len(t), dtype=np.int32))
                smooth_normals.append(corner_normals.reshape(-1, 9))
            n_tris += len(t)
        else:  # pragma: no cover - Scene validation admits only these
            raise ValueError(f"unsupported shape {type(s).__name__}")
        what = f"shapes[{i}] ({type(s).__name__})"
        for row in spheres[n_rows[0]:]:
            _check_extent(what, [abs(x) + row[3] for x in row[:3]])
        for Q0, Q1, Q2, u0, u1, u2, v0, v1, v2, _ in quads[n_rows[1]:]:
            Q, u, v = np.array([Q0, Q1, Q2]), np.array([u0, u1, u2]), np.array([v0, v1, v2])
            _check_extent(what, [Q, Q + u, Q + v, Q + u + v])
        for t in tris[n_rows[2]:]:
            _check_extent(what, t)

    c = scene.camera
    _check_extent("the camera", [c.lookfrom])
    textures = _textures(scene, material_objects, bound)
    normals = {}
    if smooth:  # only then: a flat scene's arguments are what they always were
        if n_tris >= 2**31:
            raise ValueError(f"{n_tris} triangles: smooth shading indexes at most 2^31 - 1 of them")
        normals = dict(smooth_triangles=np.concatenate(smooth),
                       triangle_normals=np.ascontiguousarray(np.concatenate(smooth_normals), dtype=np.float64))
    camera = {}
    if not c.is_pinhole:  # only then: a pinhole's arguments are what they always were
        view_w, view_h = c.view_size or (0.0, 0.0)
        focus = 1.0 if c.focus_distance is None else float(c.focus_distance)  # (a pinhole's is unused)
        camera = dict(projection=PROJECTIONS.index(c.projection), view_width=float(view_w),
                      view_height=float(view_h), aperture_radius=float(c.aperture_radius),
                      focus_distance=focus, near_clip=float(c.near_clip), far_clip=float(c.far_clip))
    return dict(
        lookfrom=np.asarray(c.lookfrom), lookat=np.asarray(c.lookat), vup=np.asarray(c.vup),
        # an orthographic camera has no field of view; the core's perspective set-up reads one
        vfov=float(c.vfov) if c.vfov is not None else DEFAULT_VFOV, width=int(c.width), height=int(c.height),
        materials=np.asarray(materials, dtype=np.float64).reshape(-1, MATERIAL_COLUMNS),
        spheres=np.asarray(spheres, dtype=np.float64).reshape(-1, 6),
        quads=np.asarray(quads, dtype=np.float64).reshape(-1, 10),
        triangles=(np.concatenate(tris) if tris else np.zeros((0, 9))).astype(np.float64),
        triangle_materials=(np.concatenate(tri_mats) if tri_mats else np.zeros(0, np.int32)),
        background=np.asarray(scene.background, dtype=np.float64),
        max_depth=int(scene.effective_max_depth),
        rr_depth=int(scene.rr_depth) if scene.rr_depth is not None else -1,
        **normals,
        **_lights(scene),
        **camera,
        **({"textures": textures} if textures is not None else {}),
    )


#: columns of a row of the texture table; must match kTextureColumns in cpp/bindings.cpp.
TEXTURE_COLUMNS = 19

#: Mitsuba's cube (src/shapes/cube.cpp): each face's corners in [-1, 1]^3 and their texture
#: coordinates, four a face, in Mitsuba's order.
_CUBE_VERTICES = np.array([
    (1, -1, -1), (1, -1, 1), (-1, -1, 1), (-1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, 1, 1), (1, 1, 1),
    (1, -1, -1), (1, 1, -1), (1, 1, 1), (1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1), (-1, -1, 1),
    (-1, -1, 1), (-1, 1, 1), (-1, 1, -1), (-1, -1, -1), (1, 1, -1), (1, -1, -1), (-1, -1, -1), (-1, 1, -1)],
    dtype=np.float64)
_CUBE_UV = np.array([(0, 1), (1, 1), (1, 0), (0, 0)] * 6, dtype=np.float64)


def _cube_face_uv(normal: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Mitsuba's texture coordinates of ``points`` (in [-1, 1]^3) on the cube's face of
    outward ``normal``: the affine map of that face's corners to theirs."""
    for f in range(6):
        p = _CUBE_VERTICES[4 * f:4 * f + 4]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        if np.dot(n, normal) > 0.5 * np.linalg.norm(n) * np.linalg.norm(normal):
            uv = _CUBE_UV[4 * f:4 * f + 4]
            # points = p0 + a (p1 - p0) + b (p3 - p0): the face's two edges from its corner 0
            e = np.stack([p[1] - p[0], p[3] - p[0]], axis=1)
            ab = np.linalg.lstsq(e, (points - p[0]).T, rcond=None)[0].T
            return uv[0] + ab[:, :1] * (uv[1] - uv[0]) + ab[:, 1:] * (uv[3] - uv[0])
    raise AssertionError("a box face of no axis")  # pragma: no cover


def _quad_uv(a, b, c, flipped: bool) -> list:
    """``uv = a + s b + t c`` of a quad's own ``Q + s u + t v`` as the core's record: the
    core's u and v are swapped when the normals are flipped."""
    return [*a, *(c if flipped else b), *(b if flipped else c)]


def _bound_attribute(t: MeshAttribute, mesh: Mesh, first_triangle: int, opacity: bool) -> tuple:
    """A mesh attribute texture bound to ``mesh``: (its values per triangle in the core's
    corner order, as float32, channels); an opacity's one channel (Mitsuba's eval_1 reads no
    other), a reflectance's values in [0, 1]."""
    values = t.values(mesh)
    channels = values.shape[1]
    if opacity and channels != 1:
        raise ValueError(f"MeshAttribute {t.name!r} as an opacity: {channels} channels; Mitsuba's eval_1 reads "
                         "a one-channel attribute only")
    if not opacity:
        lo, hi = float(values.min()), float(values.max())
        if not (lo >= 0.0 and hi <= 1.0):
            raise ValueError(f"MeshAttribute {t.name!r} (scale {t.scale:g}) gives reflectances in [{lo:.6g}, "
                             f"{hi:.6g}]; a reflectance must lie in [0, 1] (Mitsuba reads a PLY's uchar colours as "
                             "0 to 255: a scale of 1/255 brings them there)")
    if t.per_vertex:
        f = mesh.faces[:, [0, 2, 1]] if mesh.flip_normals else mesh.faces
        values = values[f]
    return np.ascontiguousarray(values, dtype=np.float32).ravel(), channels


def _texture_table(textures: list) -> tuple:
    """The core's table of ``textures`` (TEXTURE_COLUMNS a row) and their values: bitmaps'
    texels, and mesh attributes bound to their mesh (``(attribute, mesh, first triangle,
    opacity)`` tuples) as values per triangle."""
    table, texels, offset = [], [], 0
    for t in textures:
        if isinstance(t, tuple):  # a mesh attribute bound to its mesh
            attribute, mesh, first, opacity = t
            values, channels = _bound_attribute(attribute, mesh, first, opacity)
            table.append([2, float(attribute.per_vertex), 0, *np.asarray(attribute.to_uv).ravel().tolist(),
                          0, 0, 0, 0, 0, 0, len(mesh.faces), first, channels, offset])
            texels.append(values)
            offset += values.size
            continue
        m = np.asarray(t.to_uv, dtype=np.float64).ravel().tolist()
        if isinstance(t, Checkerboard):
            table.append([0, 0, 0, *m, *t.color0, *t.color1, 0, 0, 0, 0])
        else:
            assert isinstance(t, Bitmap)
            h, w, ch = t.data.shape
            table.append([1, FILTER_TYPES.index(t.filter), WRAP_MODES.index(t.wrap), *m, 0, 0, 0, 0, 0, 0,
                          w, h, ch, offset])
            texels.append(t.data.ravel())
            offset += t.data.size
    return (np.asarray(table, dtype=np.float64).reshape(-1, TEXTURE_COLUMNS),
            np.ascontiguousarray(np.concatenate(texels) if texels else np.zeros(0), dtype=np.float32))


def _textures(scene: Scene, materials: list, bound: dict | None = None):
    """The core's ``textures`` argument, or None for a scene without textures. ``bound``:
    the material rows whose mesh attribute textures are bound to a mesh (and its first
    triangle in the scene)."""
    bound = bound or {}
    textures, tex_index, material_textures = [], {}, [-1] * len(materials)
    opacities = [-1] * len(materials)

    def texture_id(key, make) -> int:
        if key not in tex_index:
            tex_index[key] = len(textures)
            textures.append(make())
        return tex_index[key]

    for row, m in enumerate(materials):
        rho = reflectance_of(m)
        mesh = bound.get(row)
        if isinstance(rho, MeshAttribute):
            material_textures[row] = texture_id((id(rho), id(mesh[0])), lambda: (rho, *mesh, False))
        elif isinstance(rho, Texture):
            material_textures[row] = texture_id(id(rho), lambda: rho)
        if isinstance(m, Mask) and isinstance(m.opacity, MeshAttribute):
            opacities[row] = texture_id(("opacity", id(m.opacity), id(mesh[0])), lambda: (m.opacity, *mesh, True))
        elif isinstance(m, Mask) and isinstance(m.opacity, Texture):
            # the texture of eval_1's values (one channel), which the core's lookup reads
            opacities[row] = texture_id(("opacity", id(m.opacity)), m.opacity.scalar)
    if not textures:
        return None
    table, texels = _texture_table(textures)
    spheres, quads, tris = [], [], []
    for s in scene.shapes:
        if isinstance(s, Sphere):
            lin = s.matrix[:3, :3]
            rotation = lin / s.scale_factor
            spheres.append((rotation.T / s.world_radius()).ravel())
        elif isinstance(s, Quad):  # (s, t) themselves, as Mitsuba's rectangle
            quads.append(_quad_uv((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), s.flip_normals))
        elif isinstance(s, Box):  # each face the unit square, as Mitsuba's cube
            lo, hi = np.asarray(s.pmin), np.asarray(s.pmax)
            centre, half = (lo + hi) / 2, (hi - lo) / 2
            for Q, u, v in s.local_quads():
                Q, u, v = (np.asarray(x, dtype=np.float64) for x in (Q, u, v))
                a, au, av = _cube_face_uv(np.sign(np.cross(u, v)), (np.array([Q, Q + u, Q + v]) - centre) / half)
                quads.append(_quad_uv(a, au - a, av - a, s.flip_normals))
        elif isinstance(s, Triangle):
            corners = np.array([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)])
            tris.append((corners[[0, 2, 1]] if s.flip_normals else corners).reshape(1, 6))
        elif isinstance(s, Mesh):
            f = s.faces[:, [0, 2, 1]] if s.flip_normals else s.faces
            if s.uv is not None:
                tris.append(s.uv[f].reshape(-1, 6))
            else:  # Mitsuba's mesh without texture coordinates: the barycentrics (b1, b2)
                corners = np.array([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)])
                rows = (corners[[0, 2, 1]] if s.flip_normals else corners).reshape(1, 6)
                tris.append(np.repeat(rows, len(f), axis=0))
    return dict(
        table=table,
        texels=texels,
        materials=np.asarray(material_textures, dtype=np.int32),
        # only where a mask has an opacity texture: other scenes' arguments are what they were
        **({"opacities": np.asarray(opacities, dtype=np.int32)} if max(opacities) >= 0 else {}),
        spheres=np.asarray(spheres, dtype=np.float64).reshape(-1, 9),
        quads=np.asarray(quads, dtype=np.float64).reshape(-1, 6),
        triangles=np.ascontiguousarray(np.concatenate(tris) if tris else np.zeros((0, 6)), dtype=np.float64),
    )
