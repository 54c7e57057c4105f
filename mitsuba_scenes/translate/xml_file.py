""":func:`to_xml`: the records as a Mitsuba 3 XML file, its meshes as PLY files and its images as
OpenEXR files beside it.
"""
from __future__ import annotations

import contextlib
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

import reference_tracer as rt
from reference_tracer.imageio import atomic_write, write_exr
from reference_tracer.material_textures import textures_of

from .ply import write_ply
from .records import lower, sensor_params


def _num(x) -> str:
    """Exact decimal of a float32 value (parses back to the same float32 bits)."""
    return repr(float(np.float32(x)))


def _xml_escape(s: str) -> str:
    return quoteattr(str(s))


_CHILD_TAG = {"diffuse": "bsdf", "conductor": "bsdf", "roughconductor": "bsdf", "dielectric": "bsdf",
              "thindielectric": "bsdf", "roughdielectric": "bsdf", "plastic": "bsdf", "roughplastic": "bsdf",
              "twosided": "bsdf", "mask": "bsdf", "area": "emitter", "constant": "emitter", "checkerboard": "texture",
              "bitmap": "texture", "mesh_attribute": "texture"}


def _xml_props(rec: dict, indent: str) -> list:
    """XML lines for the properties of a Mitsuba-dict-syntax record (without 'type')."""
    lines = []
    for key, val in rec.items():
        if key == "type":
            continue
        if key == "to_uv":
            vals = " ".join(_num(x) for x in np.asarray(val).ravel())
            lines += [f'{indent}<transform name="to_uv">', f'{indent}    <matrix value="{vals}"/>',
                      f"{indent}</transform>"]
        elif isinstance(val, dict) and val.get("type") == "rgb":
            lines.append(f'{indent}<rgb name="{key}" value="{", ".join(_num(c) for c in val["value"])}"/>')
        elif isinstance(val, dict):
            tag = _CHILD_TAG[val["type"]]
            name = "" if tag in ("bsdf", "emitter") else f' name="{key}"'
            lines.append(f'{indent}<{tag} type="{val["type"]}"{name}>')
            lines.extend(_xml_props(val, indent + "    "))
            lines.append(f"{indent}</{tag}>")
        elif isinstance(val, bool):
            lines.append(f'{indent}<boolean name="{key}" value="{str(val).lower()}"/>')
        elif isinstance(val, (int, np.integer)):
            lines.append(f'{indent}<integer name="{key}" value="{int(val)}"/>')
        elif isinstance(val, (float, np.floating)):
            lines.append(f'{indent}<float name="{key}" value="{_num(val)}"/>')
        elif isinstance(val, str):
            lines.append(f'{indent}<string name="{key}" value={_xml_escape(val)}/>')
        else:  # pragma: no cover - the neutral form holds only the above
            raise TypeError(f"cannot write {key}={val!r} to XML")
    return lines


def _xml_rfilter(rf: dict) -> list:
    params = [f'                <float name="{k}" value="{_num(v)}"/>' for k, v in rf.items() if k != "type"]
    if not params:
        return [f'            <rfilter type="{rf["type"]}"/>']
    return [f'            <rfilter type="{rf["type"]}">', *params, "            </rfilter>"]


def _xml_matrix(m: np.ndarray, indent: str) -> list:
    vals = " ".join(_num(x) for x in np.asarray(m).ravel())
    return [f'{indent}<transform name="to_world">', f'{indent}    <matrix value="{vals}"/>',
            f"{indent}</transform>"]


def to_xml(scene: rt.Scene, path, *, spp: int = 4, seed: int = 0) -> Path:
    """Write ``scene`` as a Mitsuba 3 XML file; meshes go beside it as PLY files.

    The file holds exactly what :func:`to_mitsuba` gives (every number is written as
    the exact float32 value Mitsuba stores), so ``mi.load_file(path)`` renders the same
    image as ``mi.load_dict(to_mitsuba(scene))`` for the same seed. Meshes are written
    as ``<stem>_<shape name>.ply`` in the same folder, referenced by relative path: with
    their vertex normals where they have them (smooth shading), else with
    ``face_normals=true`` (flat, as our tracer shades them).

    Parameters
    ----------
    scene : reference_tracer.Scene
    path : str or os.PathLike
        The XML file to write (its folder must exist).
    spp, seed : int, keyword-only
        Defaults of the file's ``$spp`` and ``$seed`` parameters, the sampler's
        ``sample_count`` and ``seed`` (``mitsuba -D spp=64 -D seed=7 file.xml``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> from mitsuba_scenes import get_scene, to_xml
    >>> to_xml(get_scene("cornell_mesh", width=32, height=32), "cornell_mesh.xml")  # doctest: +SKIP
    PosixPath('cornell_mesh.xml')
    """
    low = lower(scene)
    path = Path(path)
    if not path.parent.is_dir():
        raise ValueError(f"to_xml: folder {path.parent} does not exist")
    cam, integ = low["camera"], low["integrator"]
    (o, t, u) = cam["lookat"]
    plys = []  # (path, vertices, faces, normals, uv, attributes): written with the XML, by _write_all
    images = []  # (path, array): OpenEXR files written beside the XML: bitmaps' and envmaps' texels

    def bsdf_with_files(bsdf, textures):
        """The BSDF record with its bitmaps (a reflectance's, a mask's opacity's: of
        ``textures``) named relative to the XML: each one's own file where that lies in the
        XML's folder (an importer of the XML reads no file outside it), else its linear
        texels written to an EXR beside the XML."""
        if not isinstance(bsdf, dict):
            return bsdf
        if bsdf.get("type") == "bitmap":
            rest = {k: v for k, v in bsdf.items() if k not in ("data", "filename", "raw")}
            own = Path(bsdf["filename"]).resolve() if "filename" in bsdf else None
            if own is not None and own.parent == path.parent.resolve():
                return rest | {"filename": own.name, "raw": bsdf["raw"]}
            if "data" in bsdf:
                data = bsdf["data"]
            else:
                data = next(t.data for t in textures if isinstance(t, rt.Bitmap)
                            and t.filename == bsdf["filename"] and t.raw == bsdf["raw"])
            name = f"{path.stem}_texture_{len(images)}.exr"
            images.append((path.parent / name, data))
            return rest | {"filename": name}
        return {k: bsdf_with_files(v, textures) for k, v in bsdf.items()}

    L = ['<?xml version="1.0" encoding="utf-8"?>',
         "<!-- Written by mitsuba_scenes.to_xml: the reference_tracer scene, translated to",
         "     Mitsuba's conventions (fov_axis y, ext_ior 1, one-sided emitters). -->",
         '<scene version="3.0.0">',
         f'    <default name="spp" value="{int(spp)}"/>',
         f'    <default name="seed" value="{int(seed)}"/>',
         f'    <integrator type="{integ["type"]}">',
         *(f'        <integer name="{k}" value="{v}"/>' for k, v in integ.items()
           if k not in ("type", "hide_emitters")),
         '        <boolean name="hide_emitters" value="false"/>',
         "    </integrator>",
         f'    <sensor type="{cam["type"]}">',
         *(f'        <string name="{k}" value="{v}"/>' if isinstance(v, str) else
           f'        <float name="{k}" value="{_num(v)}"/>' for k, v in sensor_params(cam).items()),
         f"        <!-- look_at origin={tuple(o)} target={tuple(t)} up={tuple(u)} -->",
         *_xml_matrix(cam["to_world"], "        "),
         '        <sampler type="independent">',
         '            <integer name="sample_count" value="$spp"/>',
         '            <integer name="seed" value="$seed"/>',
         "        </sampler>",
         '        <film type="hdrfilm">',
         f'            <integer name="width" value="{cam["width"]}"/>',
         f'            <integer name="height" value="{cam["height"]}"/>',
         '            <string name="pixel_format" value="rgb"/>',
         '            <string name="component_format" value="float32"/>',
         '            <boolean name="sample_border" value="false"/>',
         *_xml_rfilter(cam["rfilter"]),
         "        </film>",
         "    </sensor>"]
    if low["background"] is not None:
        L += ['    <emitter type="constant">',
              f'        <rgb name="radiance" value="{", ".join(_num(c) for c in low["background"])}"/>',
              "    </emitter>"]
    for i, rec in enumerate(low["lights"]):
        rec = dict(rec)
        L.append(f'    <emitter type="{rec.pop("type")}" id="light_{i:03d}">')
        ind = "        "
        if "pixels" in rec:
            exr = f"{path.stem}_light_{i:03d}.exr"
            images.append((path.parent / exr, rec.pop("pixels")))
            L.append(f"{ind}<string name=\"filename\" value={_xml_escape(exr)}/>")
        if "to_world" in rec:
            L += _xml_matrix(rec.pop("to_world"), ind)
        for key in ("position", "direction"):
            if key in rec:
                x, y, z = rec.pop(key)
                tag = "point" if key == "position" else "vector"
                L.append(f'{ind}<{tag} name="{key}" x="{_num(x)}" y="{_num(y)}" z="{_num(z)}"/>')
        light = scene.lights[i]
        light_textures = [t for t in (getattr(light, "texture", None), getattr(light, "irradiance", None))
                          if isinstance(t, rt.Texture)]
        L += _xml_props(bsdf_with_files(rec, light_textures), ind)
        L.append("    </emitter>")
    for shape, rec in zip(scene.shapes, low["shapes"]):
        kind = "ply" if rec["type"] == "mesh" else rec["type"]
        L.append(f'    <shape type="{kind}" id="{rec["name"]}">')
        ind = "        "
        if rec["type"] == "mesh":
            ply = f"{path.stem}_{rec['name']}.ply"
            plys.append((path.parent / ply, rec["vertices"], rec["faces"], rec.get("normals"), rec.get("uv"),
                         rec.get("attributes")))
            L.append(f"{ind}<string name=\"filename\" value={_xml_escape(ply)}/>")
            if rec.get("normals") is None:
                L.append(f'{ind}<boolean name="face_normals" value="true"/>')
        elif "center" in rec:
            c = rec["center"]
            L += [f'{ind}<point name="center" x="{_num(c[0])}" y="{_num(c[1])}" z="{_num(c[2])}"/>',
                  f'{ind}<float name="radius" value="{_num(rec["radius"])}"/>']
        else:
            L += _xml_matrix(rec["to_world"], ind)
        if rec["flip_normals"]:
            L.append(f'{ind}<boolean name="flip_normals" value="true"/>')
        L += _xml_props({"bsdf": bsdf_with_files(rec["bsdf"], textures_of(shape.material))}, ind)
        if "emitter" in rec:
            L += _xml_props({"emitter": {"type": "area", "radiance": {"type": "rgb", "value": rec["emitter"]}}},
                            ind)
        L.append("    </shape>")
    L.append("</scene>")
    _write_all(path, "\n".join(L) + "\n", plys, images)
    return path


def _write_all(path: Path, text: str, plys: list, images=()) -> None:
    """The meshes' PLY files and the envmaps' and bitmaps' OpenEXR files, then the XML, each
    written atomically (never a partial file); on any error the files this call created are
    removed (nothing stray is left)."""
    for target in (path, *(p[0] for p in plys), *(p for p, _ in images)):
        _check_target(target)
    created = []
    try:
        for ply, vertices, faces, normals, uv, attributes in plys:
            existed = ply.exists()
            atomic_write(ply, lambda tmp, v=vertices, f=faces, n=normals, t=uv, a=attributes: write_ply(
                tmp, v, f, n, uv=t, attributes=a))
            if not existed:
                created.append(ply)
        for exr, data in images:
            existed = exr.exists()
            write_exr(exr, data)
            if not existed:
                created.append(exr)
        atomic_write(path, text)
    except BaseException:
        for done in created:
            with contextlib.suppress(OSError):
                done.unlink()
        raise


def _check_target(path: Path) -> None:
    """Refuse to replace anything but a regular file: a symlink, a device, a FIFO, a folder."""
    if path.is_symlink() or (path.exists() and not path.is_file()):
        what = "a symbolic link" if path.is_symlink() else "a folder" if path.is_dir() else "a special file"
        raise ValueError(f"to_xml: {path} is {what}; refusing to replace it (write to a regular file path)")
