"""from_mitsuba: Mitsuba's own Cornell box, XML round trips, and the unsupported listing."""
from __future__ import annotations

import re

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import from_mitsuba, get_scene, render_mitsuba, to_mitsuba, to_xml
from mitsuba_scenes.variants import import_mitsuba
from mitsuba_stats import compare


@pytest.fixture(scope="module")
def mi():
    return import_mitsuba()


def _mitsuba_cornell(mi, size=16):
    d = mi.cornell_box()
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["sensor"]["film"]["width"] = d["sensor"]["film"]["height"] = size
    return d


def test_mitsuba_cornell_box_imports_and_agrees(mi):
    d = _mitsuba_cornell(mi)
    scene = from_mitsuba(d)
    assert len(scene.shapes) == 8 and scene.max_depth == 8 and scene.rr_depth == 5
    assert sum(isinstance(s, rt.Box) for s in scene.shapes) == 2
    light = [s for s in scene.shapes if s.material.emits]
    assert len(light) == 1 and light[0].material.albedo is not None
    spp = 64
    ours = rt.render(scene, spp=spp, strategy="mis", seed=3, threads=2)
    mit = render_mitsuba(d, spp=spp, seed=3, batches=spp, threads=2)
    res = compare(ours.mean, ours.variance, spp, mit.mean, mit.variance, spp)
    assert res.ok, res.message


@pytest.mark.parametrize("name", ["cornell_mesh", "cornell_glass", "glossy_plates", "furnace"])
def test_xml_round_trip(name, mi, tmp_path):
    scene = get_scene(name, width=10, height=8)
    path = to_xml(scene, tmp_path / "scene.xml")
    back = from_mitsuba(path)
    assert [type(s) for s in back.shapes] == [type(s) for s in scene.shapes]
    assert (back.max_depth, back.rr_depth) == (scene.max_depth, scene.rr_depth)
    for a, b in zip(scene.shapes, back.shapes):
        assert type(a.material) is type(b.material)
    np.testing.assert_allclose(back.camera.vfov, scene.camera.vfov, rtol=1e-6)
    # The re-exported scene renders as the original in Mitsuba (same seed).
    img = lambda s: np.array(mi.render(mi.load_dict(to_mitsuba(s)), spp=8, seed=5))  # noqa: E731
    np.testing.assert_allclose(img(back), img(scene), rtol=1e-4, atol=1e-5)


def test_fov_axis_variants_import(mi):
    d = _mitsuba_cornell(mi)
    d["sensor"]["film"]["width"], d["sensor"]["film"]["height"] = 32, 16
    vf = {}
    for axis in ("x", "y", "smaller", "larger", "diagonal"):
        d["sensor"]["fov_axis"] = axis
        vf[axis] = from_mitsuba(d).camera.vfov
    assert vf["y"] == pytest.approx(39.3077) and vf["smaller"] == pytest.approx(39.3077)
    assert vf["x"] == pytest.approx(vf["larger"]) and vf["x"] < vf["diagonal"] < vf["y"] or vf["diagonal"] < vf["x"]
    t = np.tan(np.radians(39.3077) / 2)
    assert np.tan(np.radians(vf["x"]) / 2) == pytest.approx(t / 2)


def test_unsupported_scene_lists_everything(mi):
    d = mi.cornell_box()
    d["white"] = {"type": "roughdielectric"}
    d["integrator"] = {"type": "volpath"}
    d["env"] = {"type": "envmap", "filename": "sky.exr"}
    d["red"] = {"type": "plastic", "specular_reflectance": {"type": "checkerboard"}}  # a texture not read there
    with pytest.raises(ValueError) as err:
        from_mitsuba(d)
    msg = str(err.value)
    for needle in ("roughdielectric", "volpath", "envmap", "checkerboard", 'dictionary node "white"',
                   'dictionary node "env"'):
        assert needle in msg, (needle, msg)


def test_mesh_without_face_normals_gets_mitsubas_computed_normals(mi, tmp_path):
    """A PLY without normals and face_normals=false: Mitsuba computes vertex normals (the
    angle-weighted face normals) and shades it smooth; the import takes the same normals."""
    from reference_tracer.mesh import vertex_normals

    scene = get_scene("cornell_mesh", width=8, height=8)
    path = to_xml(scene, tmp_path / "m.xml")
    path.write_text(path.read_text().replace('name="face_normals" value="true"', 'name="face_normals" value="false"'))
    imported = [s for s in from_mitsuba(path).shapes if isinstance(s, rt.Mesh)]
    assert len(imported) == 1 and imported[0].normals is not None
    # Mitsuba's shapes() order is not the file's, and other shapes may carry normals too:
    # the mesh is the one with the PLY's vertex count.
    (mesh,) = [s for s in mi.load_file(str(path)).shapes()
               if s.is_mesh() and s.has_vertex_normals() and s.vertex_count() == len(imported[0].vertices)]
    theirs = np.array(mi.traverse(mesh)["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    np.testing.assert_allclose(imported[0].world_normals(), theirs, atol=1e-6)
    np.testing.assert_allclose(vertex_normals(imported[0].vertices, imported[0].faces), theirs, atol=1e-5)


def test_mesh_normals_mitsuba_computes_are_computed_on_one_thread(mi, tmp_path, monkeypatch):
    """Mitsuba computes missing vertex normals with a parallel scatter-add: on several threads
    the float32 sums, so the imported normals and the scene's content hash, vary from run to
    run (a PLY bunny of mitsuba-data gave two hashes in four runs). The import loads each mesh
    on one thread, then gives Dr.Jit its thread count back, also where the load fails."""
    import drjit as dr

    scene = get_scene("cornell_mesh", width=8, height=8)
    path = to_xml(scene, tmp_path / "m.xml")
    path.write_text(path.read_text().replace('name="face_normals" value="true"', 'name="face_normals" value="false"'))
    threads_seen, load_dict = [], mi.load_dict

    def spy(d, *args, **kwargs):
        if isinstance(d, dict) and d.get("type") in ("ply", "obj"):
            threads_seen.append(dr.thread_count())
        return load_dict(d, *args, **kwargs)

    monkeypatch.setattr(mi, "load_dict", spy)
    before = dr.thread_count()
    dr.set_thread_count(2)
    try:
        first, again = from_mitsuba(path), from_mitsuba(path)
        assert threads_seen == [1, 1] and dr.thread_count() == 2
        assert first.content_hash() == again.content_hash()

        def fails(d, *args, **kwargs):
            raise RuntimeError("a mesh Mitsuba cannot read")

        monkeypatch.setattr(mi, "load_dict", fails)
        with pytest.raises(ValueError, match="ply mesh could not be loaded: a mesh Mitsuba cannot read"):
            from_mitsuba(path)
        assert dr.thread_count() == 2
    finally:
        dr.set_thread_count(before)


def test_dielectric_ior_ratio_and_defaults(mi):
    d = _mitsuba_cornell(mi)
    d["glass"] = {"type": "sphere", "radius": 0.3, "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.25}}
    d["plain"] = {"type": "sphere", "center": [0.5, 0.5, 0], "radius": 0.1}
    s = from_mitsuba(d)
    glass, plain = s.shapes[-2:]
    assert glass.material.ior == pytest.approx(1.2)
    assert plain.material == rt.Lambertian(0.5)


def _scene_xml(body: str, film: str = '<rfilter type="box"/>') -> str:
    return (f'<scene version="3.0.0">{body}<sensor type="perspective"><film type="hdrfilm">'
            f'<integer name="width" value="4"/><integer name="height" value="4"/>{film}</film></sensor></scene>')


@pytest.mark.parametrize("shape,ours,theirs", [
    ('<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.2, 500:0.4, 600:0.6, '
     '700:0.8"/></bsdf></shape>', "albedo", "reflectance.value"),
    ('<shape type="rectangle"><emitter type="area"><spectrum name="radiance" value="400:2, 550:3, 700:1"/>'
     '</emitter></shape>', "radiance", "radiance.value"),
    ('<shape type="rectangle"><emitter type="area"><spectrum name="radiance" value="2"/></emitter></shape>',
     "radiance", "radiance.value"),
    ('<shape type="rectangle"><bsdf type="conductor"><spectrum name="eta" value="400:1.8, 600:0.2, 800:0.18"/>'
     '<spectrum name="k" value="3"/></bsdf></shape>', "eta", "eta.value"),
])
def test_spectra_become_the_rgb_mitsubas_rgb_variants_use(mi, tmp_path, shape, ours, theirs):
    """Wavelength:value lists and uniform spectra, as Mitsuba's own RGB variant converts them
    (read back from the loaded scene): a reflectance, an unbounded index and an emitter's
    radiance (a uniform one is not grey: RGB variants match the spectral ones)."""
    path = tmp_path / "spectra.xml"
    path.write_text(_scene_xml(shape))
    (got,) = from_mitsuba(path).shapes
    (mine,) = mi.load_file(str(path)).shapes()
    obj = mine.emitter() if "radiance" in theirs else mine.bsdf()
    want = np.ravel(np.array(mi.traverse(obj)[theirs]))
    # Mitsuba holds the spectrum in single precision: agreement to float32's rounding of the sums
    np.testing.assert_allclose(getattr(got.material, ours), np.broadcast_to(want, 3) if want.size == 1 else want[:3],
                               rtol=2e-4)


def test_moment_integrator_is_the_integrator_it_wraps(tmp_path):
    path = tmp_path / "moment.xml"
    path.write_text(_scene_xml('<integrator type="moment"><integrator type="path"><integer name="max_depth" '
                               'value="7"/></integrator></integrator><shape type="sphere"><emitter type="area"/>'
                               '</shape>'))
    assert from_mitsuba(path).max_depth == 7


def test_mitsuba_renders_a_moment_file_as_its_image(tmp_path):
    # Mitsuba's `moment` appends six AOV channels (the mean and second moment in XYZ) after
    # R, G, B: render_mitsuba keeps the image, which equals the wrapped integrator's.
    from mitsuba_scenes import render_mitsuba

    scene = ('<scene version="3.0.0">{}<shape type="sphere"><emitter type="area"><rgb name="radiance" '
             'value="0.3, 0.6, 0.9"/></emitter></shape><shape type="rectangle"><transform name="to_world">'
             '<scale value="4"/><translate z="-2"/></transform></shape><sensor type="perspective"><transform '
             'name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform><film '
             'type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/><rfilter '
             'type="box"/></film></sensor></scene>')
    plain, moment = tmp_path / "plain.xml", tmp_path / "moment.xml"
    plain.write_text(scene.format('<integrator type="path"/>'))
    moment.write_text(scene.format('<integrator type="moment"><integrator type="path"/></integrator>'))
    a = render_mitsuba(plain, spp=8, seed=3, batches=2, variant="scalar_rgb")
    b = render_mitsuba(moment, spp=8, seed=3, batches=2, variant="scalar_rgb")
    assert a.mean.shape == b.mean.shape == (4, 4, 3)
    np.testing.assert_array_equal(a.mean, b.mean)


def test_path_elements_find_meshes_as_mitsuba_does_and_leave_no_trace(mi, tmp_path):
    """A mesh named relative to a ``<path>`` folder is found there; the folder is not left in
    Mitsuba's global resolver, where it would serve a later scene's files."""
    common = tmp_path / "common" / "meshes"
    common.mkdir(parents=True)
    (common / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    scene_dir = tmp_path / "scenes" / "a"
    scene_dir.mkdir(parents=True)
    path = scene_dir / "s.xml"
    path.write_text(_scene_xml('<path value="../../common"/><shape type="obj"><string name="filename" '
                               'value="meshes/tri.obj"/><emitter type="area"/></shape>'))
    before = [str(p) for p in mi.file_resolver()]
    scene = from_mitsuba(path)
    assert len(scene.shapes) == 1 and [str(p) for p in mi.file_resolver()] == before
    from mitsuba_scenes.render import file_resolver_scope

    with file_resolver_scope():  # Mitsuba's own loading leaves the folder in its resolver
        mi.load_file(str(path))
        assert len(from_mitsuba(path).shapes) == 1
    other = tmp_path / "scenes" / "b.xml"  # no <path>: the same name is not found
    other.write_text(_scene_xml('<shape type="obj"><string name="filename" value="meshes/tri.obj"/>'
                                '<emitter type="area"/></shape>'))
    with pytest.raises(ValueError, match="tri.obj"):
        from_mitsuba(other)


def test_a_sampler_declared_at_the_top_level_and_referenced(tmp_path):
    path = tmp_path / "s.xml"
    body = ('<sampler type="{t}" id="smp"><integer name="sample_count" value="16"/></sampler>'
            '<sensor type="perspective"><ref id="smp"/><film type="hdrfilm"><integer name="width" value="4"/>'
            '<integer name="height" value="4"/><rfilter type="box"/></film></sensor>'
            '<shape type="sphere"><emitter type="area"/></shape>')
    path.write_text(f'<scene version="3.0.0">{body.format(t="independent")}</scene>')
    assert len(from_mitsuba(path).shapes) == 1
    path.write_text(f'<scene version="3.0.0">{body.format(t="halton")}</scene>')
    with pytest.raises(ValueError, match="sampler 'halton'"):
        from_mitsuba(path)


@pytest.mark.parametrize("sampler", ["stratified", "multijitter", "orthogonal", "ldsampler", "sobol", "pmj02"])
def test_randomised_samplers_read_as_independent(tmp_path, sampler):
    # Each places every sample uniformly over its pixel: the same expected image.
    path = tmp_path / "s.xml"
    path.write_text(_scene_xml('<shape type="sphere"><emitter type="area"/></shape>').replace(
        "<film", f'<sampler type="{sampler}"><integer name="sample_count" value="16"/></sampler><film', 1))
    assert len(from_mitsuba(path).shapes) == 1


@pytest.mark.parametrize("sampler", ["stratified", "multijitter"])
def test_samplers_without_jitter_are_refused(tmp_path, sampler):
    # jitter=false puts the samples at cell centres: another image than the independent one
    path = tmp_path / "s.xml"
    path.write_text(_scene_xml('<shape type="sphere"><emitter type="area"/></shape>').replace(
        "<film", f'<sampler type="{sampler}"><boolean name="jitter" value="false"/></sampler><film', 1))
    with pytest.raises(ValueError, match="jitter=false"):
        from_mitsuba(path)


@pytest.mark.parametrize("body, inner", [
    ('<bsdf type="twosided"><bsdf type="dielectric"/></bsdf>', "dielectric"),
    ('<bsdf type="twosided"><bsdf type="thindielectric"><float name="int_ior" value="1.33"/></bsdf></bsdf>',
     "thindielectric"),
    ('<bsdf type="twosided"><bsdf type="roughdielectric"/></bsdf>', "roughdielectric"),
    ('<bsdf type="twosided"><bsdf type="null"/></bsdf>', "null"),
    ('<bsdf type="twosided"><bsdf type="dielectric"/><bsdf type="dielectric"/></bsdf>', "dielectric"),
    ('<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="thindielectric"/></bsdf>', "thindielectric"),
    ('<bsdf type="mask"><bsdf type="twosided"><bsdf type="dielectric"/></bsdf></bsdf>', "dielectric"),
    ("REF", "dielectric"),
])
def test_twosided_around_a_bsdf_that_transmits_is_refused_as_by_mitsuba(mi, tmp_path, body, inner):
    """Mitsuba's twosided nests no BSDF with a transmission component (mi.load_file fails);
    the importer refuses it too, naming the file, the element's line and why."""
    if body == "REF":  # declared at the top level, referenced inside the twosided
        shape = ('<bsdf type="dielectric" id="glass"/><shape type="sphere"><bsdf type="twosided">'
                 '<ref id="glass"/></bsdf></shape>')
    else:
        shape = f'<shape type="sphere">{body}</shape>'
    path = tmp_path / "twosided.xml"
    path.write_text(_scene_xml(shape))
    with pytest.raises(RuntimeError, match="Only materials without a transmission component can be nested"):
        mi.load_file(str(path))
    with pytest.raises(ValueError, match=rf"twosided around a {inner}, a BSDF that transmits: Mitsuba refuses it "
                                         rf"too .*\({re.escape(str(path))} \(line 1, col \d+\)\)"):
        from_mitsuba(path)


@pytest.mark.parametrize("inner, kind", [
    ('<bsdf type="diffuse"/>', rt.Lambertian),
    ('<bsdf type="conductor"/>', rt.Metal),
    ('<bsdf type="roughconductor"/>', rt.RoughConductor),
    ('<bsdf type="plastic"/>', rt.Plastic),
    ('<bsdf type="roughplastic"/>', rt.RoughPlastic),
    ('<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>', rt.Lambertian),
])
def test_twosided_around_a_bsdf_that_only_reflects_imports(mi, tmp_path, inner, kind):
    path = tmp_path / "twosided.xml"
    path.write_text(_scene_xml(f'<shape type="sphere"><bsdf type="twosided">{inner}</bsdf></shape>'))
    mi.load_file(str(path))
    (shape,) = from_mitsuba(path).shapes
    assert type(shape.material) is kind and shape.material.two_sided


@pytest.mark.parametrize("body, element, message", [
    ('<shape type="sphere">\n<float name="radius" value="-1"/>\n</shape>', '<shape type="sphere">',
     "sphere: Sphere.radius must be > 0.0, got -1.0"),
    ('<shape type="sphere">\n<emitter type="area">\n<rgb name="radiance" value="-5"/>\n</emitter>\n</shape>',
     '<emitter type="area">', "area: DiffuseLight.radiance must be >= 0, got (-5.0, -5.0, -5.0)"),
    ('<shape type="sphere">\n<bsdf type="dielectric">\n<float name="int_ior" value="-1"/>\n</bsdf>\n</shape>',
     '<bsdf type="dielectric">', "dielectric: Dielectric.ior must be >= 0.001"),
    ('<integrator type="path">\n<integer name="max_depth" value="-5"/>\n</integrator>\n<shape type="sphere"/>',
     '<integrator type="path">', "path: Scene.max_depth must be an integer >= 1 or -1 (unlimited), got -5"),
    ('<integrator type="path">\n<integer name="rr_depth" value="-3"/>\n</integrator>\n<shape type="sphere"/>',
     '<integrator type="path">', "path: Scene.rr_depth must be >= 1, got -3"),
    ('<emitter type="constant">\n<rgb name="radiance" value="-1"/>\n</emitter>\n<shape type="sphere"/>',
     '<emitter type="constant">', "constant: Scene.background must be >= 0"),
    ('<shape type="sphere"/>\n<sensor type="perspective">\n<float name="fov" value="-10"/>\n<film type="hdrfilm">'
     '<rfilter type="box"/></film>\n</sensor>', '<sensor type="perspective">', "perspective: Camera.vfov must be > 0.0"),
    ('<shape type="sphere"/>\n<sensor type="perspective">\n<film type="hdrfilm">\n<rfilter type="tent">\n'
     '<float name="radius" value="-1"/>\n</rfilter>\n</film>\n</sensor>', '<rfilter type="tent">',
     "tent: Filter.radius must be > 0.0, got -1.0"),
])
def test_a_value_our_objects_refuse_is_placed_at_its_element(tmp_path, body, element, message):
    """Every ValueError of a reference_tracer constructor (or of the scene's own checks) is one
    problem of the listing, with the file and line of the element whose value it refuses (was
    a bare ValueError without either). Mitsuba itself takes the negative radius and radiances,
    and refuses the index of refraction, the depths and the field of view."""
    path = tmp_path / "bad.xml"
    text = f'<scene version="3.0.0">\n{body}\n</scene>' if "<sensor" in body else _scene_xml(f"\n{body}\n")
    path.write_text(text)
    line = next(i for i, x in enumerate(text.splitlines(), 1) if x.startswith(element))
    with pytest.raises(ValueError, match=rf"values and files it refuses \(1 found\):\n  - {re.escape(message)}.* "
                                         rf"\({re.escape(str(path))} \(line {line}, col \d+\)\)$"):
        from_mitsuba(path)


def test_a_directory_or_params_that_are_no_mapping_are_said_to_be_so(tmp_path):
    path = tmp_path / "s.xml"
    path.write_text(_scene_xml('<shape type="sphere"/>'))
    with pytest.raises(ValueError, match=rf"^from_mitsuba: {re.escape(str(tmp_path))} is not a file but a directory"):
        from_mitsuba(tmp_path)
    with pytest.raises(ValueError, match=r"^from_mitsuba: no such file"):
        from_mitsuba(tmp_path / "none.xml")
    for params in ([1, 2], "spp=4", 3):
        with pytest.raises(ValueError, match=r"^from_mitsuba: params must be a mapping of \$name names to values "
                                             rf".*got {type(params).__name__}$"):
            from_mitsuba(path, params=params)
    assert len(from_mitsuba(path, params={}).shapes) == 1


def test_every_reference_tracer_object_the_importer_builds_is_built_under_located():
    """The one mechanism that gives a constructor's ValueError its file and line: each call of a
    reference_tracer class (``rt.Name(...)``) in the importer lies in a reader decorated with
    ``located``, or in a helper that only such readers call (a new reader cannot forget it)."""
    import ast

    from repo_paths import ROOT

    functions, calls = {}, {}
    for path in sorted((ROOT / "mitsuba_scenes" / "importer").glob("*.py")):
        for fn in ast.parse(path.read_text()).body:
            if isinstance(fn, ast.FunctionDef):
                functions[fn.name] = (path.name, fn)
    for name, (_, fn) in functions.items():
        for node in ast.walk(fn):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in functions:
                calls.setdefault(node.func.id, set()).add(name)

    def covered(name, seen=frozenset()):
        fn = functions[name][1]
        if any(isinstance(d, ast.Name) and d.id == "located" for d in fn.decorator_list):
            return True
        callers = calls.get(name, set()) - seen
        return bool(callers) and all(covered(c, seen | {name}) for c in callers)

    builders = {name for name, (_, fn) in functions.items() for node in ast.walk(fn)
                if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "rt" and node.func.attr[0].isupper()}
    assert builders >= {"read_shape", "read_bsdf", "read_emitter", "read_camera", "_scene"}, builders
    bare = sorted(f"{functions[n][0]}:{n}" for n in builders if not covered(n))
    assert not bare, f"reference_tracer objects built outside a located reader: {bare}"


@pytest.mark.parametrize("light, placement", [("point", '<point name="position" value="0, 1, 0"/>'),
                                              ("directional", '<vector name="direction" value="0, -1, 0"/>')])
def test_a_light_placed_twice_is_refused_at_its_element(tmp_path, light, placement):
    """A point light's position (a directional light's direction) and a to_world besides: Mitsuba refuses both."""
    path = tmp_path / "twice.xml"
    path.write_text('<scene version="3.0.0">\n<sensor type="perspective"><film type="hdrfilm">'
                    '<integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>\n'
                    f'<emitter type="{light}">{placement}<transform name="to_world"><translate x="1"/></transform>'
                    '</emitter>\n</scene>\n')
    key = "position" if light == "point" else "direction"
    with pytest.raises(ValueError, match=rf"{light} light with both {key} and to_world \(Mitsuba refuses it too\) "
                                         rf"\(.*twice\.xml \(line 3, col \d+\)\)"):
        from_mitsuba(path)
