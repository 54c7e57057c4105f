"""``reference_tracer.meshfile.ply_faces`` on ASCII PLY files: Mitsuba reads such a body token
by token, so the face element's records are found by counting tokens, whatever the lines.
The body is tokenised a chunk at a time: the tokens before the face element are counted,
never made, and only the face element's tokens are made. Its answers are those of splitting
the whole body at once (the oracle here), on generated files with comments, blank lines,
records across lines, odd whitespace and chunk boundaries anywhere.
"""
from __future__ import annotations

import random
import tracemalloc

import numpy as np
import pytest

from reference_tracer.meshfile import checks, ply_faces

HEADER = ("ply\nformat ascii 1.0\ncomment {comment}\nelement vertex {vertices}\nproperty float x\n"
          "property float y\nproperty float z\n{between}element face {faces}\n"
          "property list uchar int vertex_indices\n{after}end_header\n")


def _split_all(data: bytes):
    """The oracle: the whole body split into tokens at once, the face element's sliced out."""
    fmt, size, elements = checks._ply_layout(data[:checks._PLY_HEADER_MAX])
    assert fmt == "ascii"
    vertices = next((count for name, count, _ in reversed(elements) if name == "vertex"), 0)
    last = max(i for i, e in enumerate(elements) if e[0] == "face")
    _, count, fields = elements[last]
    names = [f for f, _ in fields]
    columns = [names.index(f"vertex_indices.{k}") for k in ("count", 0, 1, 2)]
    before = sum(n * len(f) for _, n, f in elements[:last])
    tokens = data[size:].split()[before:before + count * len(fields)]
    if len(tokens) < count * len(fields):
        return None
    try:
        table = np.array(tokens, dtype=np.bytes_).reshape(count, len(fields))[:, columns].astype(np.float64)
    except ValueError:
        return None
    if np.any(table[:, 0] != 3):
        return None
    faces = table[:, 1:]
    whole = np.all(np.isfinite(faces) & (faces == np.round(faces)))
    return vertices, faces.astype(np.int64) if whole else faces


SPACES = [b" ", b"  ", b"\t", b"\n", b"\r\n", b"\n\n", b" \x0b ", b"\x0c", b" \n \n "]


def _ply(rng: random.Random, case: str) -> bytes:
    """A generated ASCII PLY: the body's tokens joined by random whitespace, so that records
    run across lines and lines hold several records; ``case`` says what is wrong in it."""
    vertices, faces = rng.randint(1, 40), rng.randint(0, 30)
    extra = rng.random() < 0.5   # an element between the vertices and the faces
    between = "element normal 2\nproperty float nx\nproperty float ny\n" if extra else ""
    after = "element tail 1\nproperty int t\n" if rng.random() < 0.5 else ""
    head = HEADER.format(comment="made by a test", vertices=vertices, between=between, faces=faces, after=after)
    body = [f"{rng.uniform(-5, 5):.4g}".encode() for _ in range(3 * vertices)]
    if extra:
        body += [b"0.5", b"-1e3", b"2", b"3"]
    if case == "bad vertex token":   # no number, but not part of the faces: the file is read
        body[rng.randrange(len(body))] = b"x#"
    records = [[b"3"] + [str(rng.randrange(vertices + 3)).encode() for _ in range(3)] for _ in range(faces)]
    if case == "float index" and faces:
        records[-1][2] = b"1.5"
    if case == "bad face token" and faces:
        records[rng.randrange(faces)][rng.randrange(4)] = b"one"
    if case == "quad" and faces:
        records[rng.randrange(faces)][0] = b"4"
    body += [t for r in records for t in r]
    if after:
        body.append(b"7")
    if case == "too few tokens" and faces:
        body = body[:-rng.randint(1, 4) - bool(after)]
    out = bytearray(head.encode() + rng.choice([b"", b"\n", b"  "]))
    for token in body:
        out += token + rng.choice(SPACES)
    return bytes(out)


CASES = ["fine", "bad vertex token", "float index", "bad face token", "quad", "too few tokens"]


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is b
    return a[0] == b[0] and a[1].dtype == b[1].dtype and np.array_equal(a[1], b[1])


@pytest.mark.parametrize("chunk", [1, 5, 64, 1 << 18])
def test_ascii_faces_are_those_of_splitting_the_whole_body(monkeypatch, chunk):
    """Every generated file, with the chunk boundaries falling anywhere (down to every token
    a chunk of its own), gives what splitting the whole body gives: the same counts, faces
    and dtypes, and None in the same cases."""
    monkeypatch.setattr(checks, "_ASCII_CHUNK", chunk)
    rng = random.Random(1234)
    outcomes = set()
    for k in range(240):
        case = CASES[k % len(CASES)]
        data = _ply(rng, case)
        expected = _split_all(data)
        assert _same(ply_faces(data), expected), (case, data)
        outcomes.add((case, expected is None))
    # the generator reaches both answers where it should
    assert {("fine", False), ("bad vertex token", False), ("quad", True), ("bad face token", True),
            ("too few tokens", True), ("float index", False)} <= outcomes


def test_only_the_face_elements_tokens_are_read():
    """A vertex section full of tokens that are no numbers does not matter (they are counted,
    not read); the same token in the face section makes the file one Mitsuba refuses."""
    head = HEADER.format(comment="c", vertices=4, between="", faces=2, after="").encode()
    faces = b"3 0 1 2\n3 \t 2 1\n3\n"
    n, f = ply_faces(head + b"a b c d e f\n\n g h i\nj k l\n" + faces)
    assert n == 4 and f.tolist() == [[0, 1, 2], [2, 1, 3]] and f.dtype == np.int64
    assert ply_faces(head + b"0 0 0 1 0 0 0 1 0 1 1\n" + faces) is None   # a token short: records shift
    assert ply_faces(head + b"0 0 0 1 0 0 0 1 0 1 1 0\n3 0 1 2 3 2 1 x\n") is None


def test_a_large_ascii_body_is_read_in_bounded_memory():
    """A 20 MB ASCII PLY, almost all of it vertices, is read in a small fraction of its size
    (splitting it whole took about five times its size in token objects)."""
    vertices = 1_250_000
    head = HEADER.format(comment="c", vertices=vertices, between="", faces=3, after="").encode()
    data = head + b"0.125 -1.5 2.75\n" * vertices + b"3 0 1 2\n3 2 1 0\n3 1249999 0 1\n"
    assert len(data) > 20_000_000
    tracemalloc.start()
    try:
        n, f = ply_faces(data)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert n == vertices and f.tolist() == [[0, 1, 2], [2, 1, 0], [1249999, 0, 1]]
    assert peak < len(data) // 8, peak
