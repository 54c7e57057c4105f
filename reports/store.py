"""Read a results store (``meta.json``, ``results.jsonl``, ``summary.json``, EXR images).

The store layout is fixed by the harness (DESIGN.md section 5, issue 5). Everything here
tolerates an interrupted run: a missing ``meta.json`` or ``summary.json``, a truncated last
line in ``results.jsonl``, missing keys and ``null`` values. What cannot be understood at
all (not a folder, nothing in it, a record without its identifying keys) is an error.
"""
from __future__ import annotations

import importlib.util
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Store", "load_store", "record_key", "read_image", "imageio"]

#: the fields that identify a job; duplicates (a resumed run) are resolved by "last wins".
KEY_FIELDS = ("scene", "renderer", "strategy", "spp", "seed", "width", "height")

#: our strategies in the order the report shows them; unknown strategies follow, sorted.
STRATEGY_ORDER = ("uniform", "cosine", "light", "mixture", "mis")

_IMAGEIO = None


def imageio():
    """Return the ``reference_tracer.imageio`` module, imported without the C++ core if need be.

    ``import reference_tracer`` loads the compiled ``_core`` extension. The report only needs
    the EXR and display helpers, which are pure Python, so when the package import fails
    (core not built on this machine) the module file is loaded on its own.
    """
    global _IMAGEIO
    if _IMAGEIO is not None:
        return _IMAGEIO
    try:
        from reference_tracer import imageio as mod  # noqa: PLC0415
    except ImportError:
        spec = importlib.util.find_spec("reference_tracer")
        if spec is None or not spec.submodule_search_locations:
            raise
        path = Path(next(iter(spec.submodule_search_locations))) / "imageio.py"
        mspec = importlib.util.spec_from_file_location("_rtbench_report_imageio", path)
        mod = importlib.util.module_from_spec(mspec)
        sys.modules.setdefault("_rtbench_report_imageio", mod)
        mspec.loader.exec_module(mod)
    _IMAGEIO = mod
    return mod


def record_key(record: dict) -> tuple:
    """The identity of a job record: (scene, renderer, strategy, spp, seed, width, height)."""
    return tuple(record.get(k) for k in KEY_FIELDS)


def _num(value) -> float:
    """A JSON value as float; ``None``, strings and non-finite values become NaN."""
    if isinstance(value, bool) or value is None:
        return math.nan
    try:
        v = float(value)
    except (TypeError, ValueError):
        return math.nan
    return v


@dataclass
class Store:
    """A loaded results store.

    Attributes
    ----------
    path : Path
        The store folder.
    meta : dict
        ``meta.json`` (empty when missing).
    records : list of dict
        ``results.jsonl`` records, deduplicated by :data:`KEY_FIELDS` (last wins), in
        first-appearance order of their key.
    rows : list of dict
        ``summary.json`` rows (empty when missing).
    problems : list of str
        What was missing or unreadable; the report lists these.
    """

    path: Path
    meta: dict = field(default_factory=dict)
    records: list = field(default_factory=list)
    rows: list = field(default_factory=list)
    problems: list = field(default_factory=list)
    n_raw_records: int = 0

    def sections(self) -> list[tuple[str, int, int]]:
        """(scene, width, height) groups in records or summary rows: by scene, the fullest sweep first."""
        seen: dict[tuple, None] = {}
        for r in list(self.records) + list(self.rows):
            if r.get("scene") is None:
                continue
            seen.setdefault((str(r["scene"]), _int_or_none(r.get("width")), _int_or_none(r.get("height"))), None)
        # rows or records without a size join their scene's only sized section, when there is one
        for k in list(seen):
            if (k[1] is None or k[2] is None) and self._only_size(k[0]) is not None:
                del seen[k]
        ncurves = {k: len({(r["renderer"], r["strategy"]) for r in self.records + self.rows
                           if r.get("scene") == k[0] and self._size(r) == (k[1], k[2])}) for k in seen}
        # per scene: the section with the most curves (the main sweep) first, then by size
        return sorted(seen, key=lambda k: (k[0], -ncurves[k], (k[1] or 0) * (k[2] or 0)))

    def _only_size(self, scene: str):
        sizes = {(_int_or_none(r.get("width")), _int_or_none(r.get("height"))) for r in self.records + self.rows
                 if r.get("scene") == scene}
        sizes = {sz for sz in sizes if None not in sz}
        return next(iter(sizes)) if len(sizes) == 1 else None

    def _size(self, r: dict) -> tuple:
        size = (_int_or_none(r.get("width")), _int_or_none(r.get("height")))
        if None in size:
            return self._only_size(r["scene"]) or size
        return size

    def section_records(self, scene: str, width, height) -> list[dict]:
        """Records of one (scene, width, height) section."""
        return [r for r in self.records if r.get("scene") == scene and self._size(r) == (width, height)]

    def section_rows(self, scene: str, width, height) -> list[dict]:
        """Summary rows of one (scene, width, height) section, ours in strategy order, then Mitsuba.

        A row without a size belongs to its scene's only sized section, when there is one.
        """
        rows = [r for r in self.rows if r.get("scene") == scene and self._size(r) == (width, height)]
        return sorted(rows, key=lambda r: curve_order((r.get("renderer"), r.get("strategy"))))

    def resolve(self, relpath) -> Path | None:
        """A store-relative path as an absolute path (``None`` stays ``None``)."""
        if not relpath:
            return None
        p = Path(relpath)
        return p if p.is_absolute() else self.path / p


def _int_or_none(v):
    if v is None or isinstance(v, bool):
        return None
    try:
        return int(v)
    except (TypeError, ValueError):
        return None


def curve_order(curve: tuple) -> tuple:
    """Sort key for a (renderer, strategy) curve: ours by :data:`STRATEGY_ORDER`, Mitsuba last."""
    renderer, strategy = curve
    if renderer == "ours":
        idx = STRATEGY_ORDER.index(strategy) if strategy in STRATEGY_ORDER else len(STRATEGY_ORDER)
        return (0, idx, str(strategy))
    return (1, 0, f"{renderer}:{strategy}")


def _read_json(path: Path, problems: list, what: str):
    if not path.exists():
        problems.append(f"{what} is missing ({path.name})")
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        problems.append(f"{what} could not be read: {exc}")
        return None


def load_store(store) -> Store:
    """Load a results store folder.

    Parameters
    ----------
    store : str or Path
        Folder holding ``results.jsonl`` and/or ``summary.json`` (and ``meta.json``).

    Returns
    -------
    Store

    Raises
    ------
    ValueError
        If ``store`` is not a folder, holds neither ``results.jsonl`` nor ``summary.json``,
        or a record or row lacks ``scene``, ``renderer`` or ``strategy`` or has a bad ``spp``.
        A line of ``results.jsonl`` that is not JSON at all is skipped and listed in
        :attr:`Store.problems` (the page shows them), as the harness's own reader skips it.
    """
    path = Path(store).expanduser()
    if not path.is_dir():
        raise ValueError(f"results store {str(path)!r} is not a folder")
    results = path / "results.jsonl"
    summary = path / "summary.json"
    if not results.exists() and not summary.exists():
        raise ValueError(f"{str(path)!r} is not a results store: it holds neither results.jsonl nor summary.json")
    out = Store(path=path.resolve())

    meta = _read_json(path / "meta.json", out.problems, "meta.json")
    if meta is not None and not isinstance(meta, dict):
        out.problems.append("meta.json is not a JSON object; ignored")
        meta = None
    out.meta = meta or {}

    by_key: dict[tuple, dict] = {}
    if results.exists():
        lines = results.read_text().splitlines()
        for lineno, line in enumerate(lines, 1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                if lineno == len(lines):
                    out.problems.append(f"results.jsonl: last line {lineno} is truncated (interrupted run?); skipped")
                else:  # as the harness's reader does: skip it, but the report lists it
                    out.problems.append(f"results.jsonl: line {lineno} is not valid JSON; skipped")
                continue
            if not isinstance(rec, dict):
                raise ValueError(f"{results}: line {lineno} is not a JSON object")
            _validate(rec, f"{results.name} line {lineno}")
            out.n_raw_records += 1
            key = record_key(rec)
            by_key.pop(key, None)  # last wins, and keeps the order of the last write
            by_key[key] = rec
    else:
        out.problems.append("results.jsonl is missing: no curves or images")
    out.records = list(by_key.values())
    if out.n_raw_records > len(out.records):
        out.problems.append(f"results.jsonl: {out.n_raw_records - len(out.records)} duplicate job record(s) "
                            "(resumed run); the last of each was kept")

    summ = _read_json(summary, out.problems, "summary.json")
    if summ is not None:
        rows = summ.get("rows") if isinstance(summ, dict) else None
        if not isinstance(rows, list):
            out.problems.append("summary.json has no 'rows' list; ignored")
            rows = []
        for i, row in enumerate(rows):
            if not isinstance(row, dict):
                raise ValueError(f"{summary}: row {i} is not a JSON object")
            _validate(row, f"summary.json row {i}", need_spp=False)
        out.rows = rows
    return out


def _validate(rec: dict, where: str, *, need_spp: bool = True) -> None:
    for k in ("scene", "renderer", "strategy"):
        if not isinstance(rec.get(k), str) or not rec[k]:
            raise ValueError(f"{where}: missing or non-string {k!r}")
    if need_spp:
        spp = rec.get("spp")
        if isinstance(spp, bool) or not isinstance(spp, (int, float)) or not spp > 0:
            raise ValueError(f"{where}: 'spp' must be a positive number, got {spp!r}")


def read_image(path: Path) -> np.ndarray:
    """Read an EXR as an (H, W, 3) float32 array (grey images are repeated to RGB, alpha dropped)."""
    a = imageio().read_exr(path)
    if a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    return np.asarray(a[..., :3], dtype=np.float32)


num = _num
