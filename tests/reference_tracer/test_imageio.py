"""``reference_tracer.read_exr`` on files that are not EXR images: Python's own errors, naming the
path, and nothing printed by the EXR library (it printed ``(EXR_ERR_FILE_ACCESS) Unable to open file``
on stderr and raised a bare ``RuntimeError`` for a missing file and for a PNG alike)."""
from __future__ import annotations

import re

import numpy as np
import pytest

import reference_tracer as rt


def test_read_exr_of_a_missing_file_is_file_not_found(tmp_path, capfd):
    path = tmp_path / "nothere.exr"
    with pytest.raises(FileNotFoundError) as exc:
        rt.read_exr(path)
    assert exc.value.filename == str(path)
    assert capfd.readouterr().err == ""   # the C library's line went to file descriptor 2


@pytest.mark.parametrize("make, why", [
    (lambda p: rt.write_png(p, np.zeros((2, 2, 3))), "no EXR magic number"),
    (lambda p: p.write_bytes(b""), "empty"),
    (lambda p: p.write_text("v/1 is almost the magic number"), "no EXR magic number"),
])
def test_read_exr_of_another_file_is_a_value_error(tmp_path, capfd, make, why):
    path = tmp_path / "image.exr"
    make(path)
    with pytest.raises(ValueError, match=re.escape(f"{path}: not an OpenEXR file ({why})")):
        rt.read_exr(path)
    assert capfd.readouterr().err == ""


def test_read_exr_of_a_folder_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="not a regular file"):
        rt.read_exr(tmp_path)


def test_read_exr_still_reads_an_exr(tmp_path):
    img = np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3)
    rt.write_exr(tmp_path / "a.exr", img)
    np.testing.assert_array_equal(rt.read_exr(tmp_path / "a.exr"), img)
