"""Property tests of two small parsers: OBJ files (``reference_tracer.meshfile.parse_obj``)
and the CLI's comma-separated lists (``benchmarks.commands._args.int_list`` / ``name_list``).

A generated well-formed OBJ must come back as the mesh it describes (Mitsuba's reading: one
vertex per distinct index pair in first-use order, polygons split into fans, negative
indices counting back); a mutated file, loaded as a ``Mesh``, must give a valid mesh or a
``ValueError``, never another exception. Lists must round-trip. Inputs come from hypothesis with a fixed seed
(``derandomize``), so a failure reproduces; ``RTBENCH_FUZZ_EXAMPLES`` sets the number of
inputs (default 150, as tests/test_fuzz_inputs.py).
"""
from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import reference_tracer as rt
from benchmarks.commands._args import int_list, name_list
from reference_tracer.meshfile import parse_obj

EXAMPLES = int(os.environ.get("RTBENCH_FUZZ_EXAMPLES", "150"))
PROPERTY = settings(max_examples=EXAMPLES, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

COORD = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False).map(lambda x: round(x, 3))


@st.composite
def obj_meshes(draw):
    """An OBJ text and what it means: positions, polygons (each a list of 0-based indices),
    whether each corner is written as a negative (relative) index."""
    n = draw(st.integers(3, 12))
    positions = [tuple(draw(COORD) for _ in range(3)) for _ in range(n)]
    polygons = draw(st.lists(st.lists(st.integers(0, n - 1), min_size=3, max_size=6, unique=True),
                             min_size=1, max_size=8))
    relative = draw(st.booleans())
    lines = [f"v {x} {y} {z}" for x, y, z in positions]
    for poly in polygons:
        corners = [str(i - n) if relative else str(i + 1) for i in poly]  # -1 is the last vertex
        lines.append("f " + " ".join(corners))
    return "\n".join(lines) + "\n", np.array(positions, dtype=np.float64), polygons


def _expected(positions, polygons):
    """Mitsuba's reading: fans (0, k, k+1), vertices renumbered in first-use order."""
    order, faces = {}, []
    for poly in polygons:
        for k in range(1, len(poly) - 1):
            tri = (poly[0], poly[k], poly[k + 1])
            faces.append([order.setdefault(i, len(order)) for i in tri])
    used = sorted(order, key=order.get)
    return positions[used], np.array(faces, dtype=np.int64)


@PROPERTY
@given(mesh=obj_meshes())
def test_a_well_formed_obj_is_the_mesh_it_describes(mesh):
    text, positions, polygons = mesh
    got = parse_obj(text, name="m.obj")
    vertices, faces = _expected(positions, polygons)
    np.testing.assert_array_equal(got.faces, faces)
    np.testing.assert_allclose(got.vertices, vertices, rtol=0, atol=1e-12)
    assert got.normals is None and got.uv is None


JUNK = st.sampled_from(["0", "-0", "999", "-999", "1/", "1//", "/1", "x", "1e3", "nan", "inf", "", "#", "1/2/3/4",
                        "\x00", "f", "v", "1.5"])


@PROPERTY
@given(mesh=obj_meshes(), where=st.integers(0, 10_000), junk=JUNK)
def test_a_mutated_obj_file_gives_a_mesh_or_a_value_error(tmp_path_factory, mesh, where, junk):
    # Through the file loader: parse_obj reads the text, Mesh validates what it read (finite
    # vertices, faces in range); together, a mesh or a ValueError naming the file.
    words = mesh[0].split(" ")
    words[where % len(words)] = junk
    path = tmp_path_factory.mktemp("obj") / "m.obj"
    path.write_text(" ".join(words))
    try:
        got = rt.Mesh.load(path, rt.Lambertian(0.5), face_normals=True)
    except ValueError as err:
        assert "m.obj" in str(err) or "Mesh" in str(err), err
        return
    assert got.faces.ndim == 2 and got.faces.shape[1] == 3
    assert got.faces.min() >= 0 and got.faces.max() < len(got.vertices)
    assert np.all(np.isfinite(got.vertices))


@PROPERTY
@given(values=st.lists(st.integers(1, 2**40), min_size=1, max_size=8), spaces=st.booleans())
def test_int_lists_round_trip(values, spaces):
    text = (", " if spaces else ",").join(map(str, values))
    assert int_list(text, option="--spps") == tuple(values)
    assert int_list(list(values), option="--spps") == tuple(values)


@PROPERTY
@given(text=st.text(max_size=30))
def test_int_list_gives_integers_or_a_value_error_naming_the_option(text):
    try:
        values = int_list(text, option="--spps")
    except ValueError as err:
        assert "--spps" in str(err)
        return
    assert values and all(isinstance(v, int) and v >= 1 for v in values)


NAME = st.text(st.characters(blacklist_characters=",", blacklist_categories=("Zs", "Zl", "Zp", "Cc")), min_size=1, max_size=10)


@PROPERTY
@given(names=st.lists(NAME, min_size=1, max_size=6))
def test_name_lists_round_trip(names):
    assert name_list(",".join(names)) == tuple(names)
    assert name_list(" , ".join(names)) == tuple(names)
    assert name_list(names) == tuple(names)


@pytest.mark.parametrize("text", ["", ",", " , ", [], [" "]])
def test_empty_name_lists_are_refused(text):
    with pytest.raises(ValueError, match="--strategies is an empty list"):
        name_list(text, option="--strategies")


@pytest.mark.parametrize("text", ["0", "1,0", "-3", "1,,x", ",", ""])
def test_bad_int_lists_are_refused(text):
    with pytest.raises(ValueError, match="--spps"):
        int_list(text, option="--spps")
