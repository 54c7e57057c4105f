"""Mitsuba shapes as ours: ``sphere``, ``rectangle``, ``cube``, ``obj``, ``ply`` and mesh objects
of a dict, with the vertex normals Mitsuba's loaders give.
"""
from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np

import reference_tracer as rt
from reference_tracer.material_textures import textures_of
from reference_tracer.meshfile import (check_mesh_file, check_ply_faces, check_serialized_file, decode_obj,
                                      obj_undefined_normal)
from reference_tracer.validation import face_index_problem

from .bsdfs import read_bsdf
from .emitters import read_area_emitter
from .textures import mesh_attributes
from .values import check_params, located, read_matrix, read_scalar, rigid_scale


@located
def read_shape(ctx, node, bsdf_node, emitter_node, mesh_obj=None):
    """Our shape for the shape ``node`` with its BSDF and area emitter nodes (None after
    recording a problem; a value our shape refuses is recorded at the node by
    :func:`~.values.located`, one of its emitter or BSDF at theirs)."""
    name = node.props.plugin_name() if node is not None else "mesh"
    emitter = None
    if emitter_node is not None:
        ename = emitter_node.props.plugin_name()
        if ename != "area":
            ctx.bad(emitter_node, f"emitter '{ename}' attached to a shape (only 'area')")
            return None
        emitter = read_area_emitter(ctx, emitter_node)
        if emitter is None:
            return None
    mat = read_bsdf(ctx, bsdf_node, emitter=emitter)
    if mat is None:
        return None
    # a textured shape keeps what its texture coordinates follow: a sphere's rotation, a
    # rectangle's own axes, a mesh's coordinates
    textured = bool(textures_of(mat))
    if name not in ("ply", "obj", "serialized") and mesh_obj is None and any(
            isinstance(t, rt.MeshAttribute) for t in textures_of(mat)):
        ctx.bad(node, f"a mesh_attribute texture on a '{name}' shape (only meshes have attributes)")
        return None
    flip = bool(node.props["flip_normals"]) if "flip_normals" in node.props.keys() else False
    m = read_matrix(ctx, node)
    if name == "sphere":
        check_params(ctx, node, {"center", "radius", "to_world", "flip_normals", "bsdf", "emitter"}, "shape")
        c = np.array(node.props["center"], dtype=np.float64) if "center" in node.props.keys() else np.zeros(3)
        r = read_scalar(ctx, node, "radius", 1.0)
        rs = rigid_scale(m)
        if rs is None or not np.allclose(rs[1], rs[1][0], rtol=1e-5):
            ctx.bad(node, "sphere to_world is not a similarity (rotation, uniform scale, translation)")
            return None
        if textured:
            return rt.Sphere(c, r, mat, flip_normals=flip, transform=tuple(map(tuple, m)))
        return rt.Sphere(m[:3, :3] @ c + m[:3, 3], r * rs[1][0], mat, flip_normals=flip)
    if name == "rectangle":
        check_params(ctx, node, {"to_world", "flip_normals", "bsdf", "emitter"}, "shape")
        lin, t = m[:3, :3], m[:3, 3]
        Q, u, v = t - lin[:, 0] - lin[:, 1], 2 * lin[:, 0], 2 * lin[:, 1]
        det = np.linalg.det(lin)
        if det == 0:
            ctx.bad(node, "rectangle to_world is singular")
            return None
        if det < 0:   # Mitsuba's normal is to_world's inverse transpose of +z: -(u x v) here
            if textured:
                flip = not flip   # the same quad, keeping u and v (its texture coordinates)
            else:
                u, v = v, u
        return rt.Quad(Q, u, v, mat, flip_normals=flip)
    if name == "cube":
        check_params(ctx, node, {"to_world", "flip_normals", "bsdf", "emitter"}, "shape")
        rs = rigid_scale(m)
        if rs is None:
            ctx.bad(node, "cube to_world has shear or a reflection (only rotation, per-axis scale, translation)")
            return None
        R, s = rs
        tf = np.eye(4)
        tf[:3, :3], tf[:3, 3] = R, m[:3, 3]
        return rt.Box(-s, s, mat, flip_normals=flip, transform=tuple(map(tuple, tf)))
    if name in ("ply", "obj", "serialized") or mesh_obj is not None:
        if mesh_obj is None:
            check_params(ctx, node, {"filename", "to_world", "flip_normals", "bsdf", "emitter", "face_normals",
                               "flip_tex_coords", "shape_index"}, "shape")
            fname = ctx.resolve(str(node.props["filename"]))
            extra = {}
            try:  # before Mitsuba allocates what a header declares: a regular file, counts it can hold;
                # and before it computes normals through the faces: every vertex index in range
                # (Mitsuba's obj loader checks its indices, its ply and serialized loaders do not)
                if name == "serialized":
                    index = read_scalar(ctx, node, "shape_index", 0)
                    if isinstance(index, str) or not float(index).is_integer() or index < 0:
                        raise ValueError(f"shape_index must be a whole number >= 0, got {index!r}")
                    extra = {"shape_index": int(index)}
                    check_serialized_file(fname, int(index))
                else:
                    if "shape_index" in node.props.keys():
                        ctx.bad(node, f"{name} parameter 'shape_index' (serialized meshes only)")
                    if "flip_tex_coords" in node.props.keys():
                        extra = {"flip_tex_coords": bool(node.props["flip_tex_coords"])}
                    check_mesh_file(fname)
                    if name == "ply":
                        check_ply_faces(fname)
            except (ValueError, OSError) as exc:
                ctx.bad(node, f"{name} mesh {fname} cannot be used: {exc}")
                return None
            face_normals = bool(node.props["face_normals"]) if "face_normals" in node.props.keys() else False
            if name == "obj" and not face_normals:
                line = _obj_undefined_normal(fname)
                if line is not None:
                    ctx.bad(node, f"obj mesh {fname} line {line}: a face whose first corner has no normal index, in "
                                  "a file with vertex normals (Mitsuba leaves that vertex's normal undefined)")
                    return None
            if name == "obj" and textured:
                line = _obj_undefined_normal(fname, texcoords=True)
                if line is not None:
                    ctx.bad(node, f"obj mesh {fname} line {line}: a face whose first corner has no texture "
                                  "coordinate index, in a file with texture coordinates (Mitsuba leaves that "
                                  "vertex's coordinates undefined)")
                    return None
            try:
                with _one_thread():
                    mesh_obj = ctx.mi.load_dict({"type": name, "filename": fname,
                                                 "to_world": ctx.mi.ScalarTransform4f(m.tolist()),
                                                 "face_normals": face_normals, **extra})
            except Exception as exc:  # Mitsuba raises RuntimeError with the reason
                ctx.bad(node, f"{name} mesh could not be loaded: {exc}")
                return None
        params = ctx.mi.traverse(mesh_obj)
        v = np.array(params["vertex_positions"], dtype=np.float64).reshape(-1, 3)
        f = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
        if len(f) == 0:
            ctx.bad(node, f"{name} mesh {node.props['filename'] if 'filename' in node.props.keys() else ''} "
                          "holds no triangles")
            return None
        normals = _mesh_normals(params, mesh_obj, v, f)
        if isinstance(normals, str):
            source = f" {node.props['filename']}:" if "filename" in node.props.keys() else ""
            ctx.bad(node, f"{name} mesh{source} {normals}")
            return None
        uv = None
        if textured and mesh_obj.has_vertex_texcoords():  # else Mitsuba's: each triangle's barycentrics
            uv = np.array(params["vertex_texcoords"], dtype=np.float64).reshape(-1, 2)
            if uv.shape != (len(v), 2) or not np.all(np.isfinite(uv[np.unique(f)])):
                ctx.bad(node, f"{name} mesh: texture coordinates that are not one finite pair per vertex")
                return None
            uv = np.where(np.isfinite(uv), uv, 0.0)   # vertices of no face: never looked up
        attributes = mesh_attributes(params, mat)
        if attributes is not None:
            for key, a in list(attributes.items()):
                rows = len(v) if key.startswith("vertex_") else len(f)
                if a.size % rows:
                    ctx.bad(node, f"{name} mesh: attribute {key!r} of {a.size} values for {rows} rows")
                    return None
                attributes[key] = a.reshape(rows, -1)
        try:
            mesh = rt.Mesh(v, f, mat, flip_normals=flip, normals=normals, uv=uv, attributes=attributes)
            for t in textures_of(mat):
                if isinstance(t, rt.MeshAttribute):
                    t.values(mesh)
        except ValueError as exc:
            ctx.bad(node, f"{name} mesh: {exc}")
            return None
        return mesh
    ctx.bad(node, f"shape '{name}'")
    return None


def _obj_undefined_normal(fname, *, texcoords: bool = False):
    """:func:`reference_tracer.meshfile.obj_undefined_normal` of an OBJ file (None if unreadable:
    Mitsuba's loader then says why); of its texture coordinates with ``texcoords``."""
    try:
        return obj_undefined_normal(decode_obj(Path(fname).read_bytes()), texcoords=texcoords)
    except (OSError, ValueError):
        return None


@contextlib.contextmanager
def _one_thread():
    """Dr.Jit on one thread for the block: Mitsuba computes a mesh's missing vertex normals
    with a parallel scatter-add, whose order of float32 additions (so the last bits of the
    normals, and the scene's content hash) varies from run to run on several threads."""
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)

    threads = dr.thread_count()
    dr.set_thread_count(1)
    try:
        yield
    finally:
        dr.set_thread_count(threads)


def _mesh_normals(params, mesh, v, f):
    """The vertex normals Mitsuba shades ``mesh`` with (world space, as its loader stored
    them: the file's, or computed), None where it shades flat, or a sentence saying why
    they cannot be used.

    Flat also where every vertex normal equals its triangle's own normal (a quad of two
    coplanar triangles, a box stored with a vertex per face corner): Mitsuba's shading is
    then the flat one (to 1e-5), and the mesh keeps the flat fast path. A normal that is
    not a unit vector is refused: Mitsuba normalises every normal it reads or computes, so
    another value is one it left undefined (an OBJ face corner without a normal index in a
    file with normals) or a zero or non-number normal of a PLY file (Mitsuba's shading
    there is NaN). A face whose vertex index is outside the vertices is refused first (a
    mesh object of a dict: files are checked before Mitsuba loads them)."""
    problem = face_index_problem(f, len(v))
    if problem is not None:
        return problem
    if not mesh.has_vertex_normals():
        return None
    n = np.array(params["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    if n.shape != v.shape:
        return f"has {len(n)} vertex normals for {len(v)} vertices"
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    length = np.linalg.norm(n, axis=1)
    bad = used & ~(np.abs(length - 1.0) <= 1e-3)
    if bad.any():
        i = int(np.argmax(bad))
        return (f"vertex normal {i} is {n[i].tolist()}, not a unit vector: undefined in Mitsuba (a zero or "
                "non-number normal in the file, or an OBJ face corner without a normal index in a file "
                "with normals)")
    if _normals_are_flat(params, v, f):
        return None
    n[~used] = (1.0, 0.0, 0.0)   # vertices of no face: never shaded
    return n


def _normals_are_flat(params, v, f, *, tol: float = 1e-5) -> bool:
    """Whether every vertex normal of every triangle is that triangle's own normal: Mitsuba then
    shades the mesh exactly as a flat one (a quad of two coplanar triangles, a box stored with
    a vertex per face corner), and the vertex normals change nothing."""
    n = np.array(params["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    if len(f) == 0 or n.shape != v.shape:
        return False
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(e, axis=1, keepdims=True)
    ok = length[:, 0] > 0
    fn = np.where(length > 0, e / np.where(length > 0, length, 1.0), 0.0)
    for j in range(3):
        vn = n[f[:, j]]
        vn = vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
        if np.any(np.abs(vn[ok] - fn[ok]) > tol):
            return False
    return True


@located
def mesh_object(ctx, where, mesh):
    """A ``mi.Mesh`` given as an object in the dict (as :func:`to_mitsuba` makes them), at
    ``where`` (``dictionary node "key"``: it has no node of its own); None after recording a
    problem."""
    params = ctx.mi.traverse(mesh)
    keys = set(params.keys())
    bsdf = mesh.bsdf()
    cls = type(bsdf).__name__ if bsdf is not None else None
    refl = [k for k in keys if k.startswith("bsdf.") and k.endswith("reflectance.value")]
    if bsdf is None or refl != ["bsdf.reflectance.value"] or any(
            k.startswith("bsdf.") and k != "bsdf.reflectance.value" for k in keys):
        ctx.bad(where, f"mesh object whose BSDF is not a plain diffuse ({cls}); write the scene with to_xml and "
                       "import the XML instead")
        return None
    albedo = tuple(float(x) for x in np.array(params["bsdf.reflectance.value"]).ravel()[:3])
    if len(albedo) == 1:
        albedo = albedo * 3
    em = mesh.emitter()
    if em is not None:
        rad = [k for k in keys if k.startswith("emitter.")]
        if rad != ["emitter.radiance.value"]:
            ctx.bad(where, "mesh object with an emitter other than a constant area light")
            return None
        L = tuple(float(x) for x in np.array(params["emitter.radiance.value"]).ravel()[:3])
        mat = rt.DiffuseLight(L * (3 if len(L) == 1 else 1), albedo=None if max(albedo) == 0 else albedo)
    else:
        mat = rt.Lambertian(albedo)
    v = np.array(params["vertex_positions"], dtype=np.float64).reshape(-1, 3)
    f = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
    normals = _mesh_normals(params, mesh, v, f)
    if isinstance(normals, str):
        ctx.bad(where, f"mesh object whose {normals}")
        return None
    flip = bool(mesh.has_flipped_normals())
    return rt.Mesh(v, f, mat, flip_normals=flip, normals=normals)
