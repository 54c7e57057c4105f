"""The report's view of a results store: records and summary rows grouped into sections.

Reading is :mod:`benchmarks.store`'s, the sole owner of the results format (records,
keys, dedupe, torn lines, images, ``meta.json`` and ``summary.json``). This module adds
only the report's side: it tolerates an interrupted run (a missing ``meta.json`` or
``summary.json``, a truncated last line in ``results.jsonl``, missing keys and ``null``
values) and lists what it skipped in :attr:`Store.problems` for the page, instead of
warning; it groups records into (scene, width, height) sections and orders curves. What
cannot be understood at all (not a folder, nothing in it, a record without its
identifying keys) is an error.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks import store as results
from benchmarks.constants import STRATEGIES
from benchmarks.numbers import as_float as num

__all__ = ["Store", "load_store", "curve_order", "num"]


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
        ``results.jsonl`` records, deduplicated by job key (last wins, in file order;
        :func:`benchmarks.store.dedupe_records`), each curve's latest build only.
    rows : list of dict
        ``summary.json`` rows (empty when missing).
    headline : list of dict
        ``summary.json``'s headline entries, one per scene and size (empty when missing).
    problems : list of str
        What was missing or unreadable; the report lists these.
    n_raw_records : int
        Records before deduplication.
    """

    path: Path
    meta: dict = field(default_factory=dict)
    records: list = field(default_factory=list)
    rows: list = field(default_factory=list)
    headline: list = field(default_factory=list)
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

    def read_image(self, relpath, *, sha256: str | None = None) -> np.ndarray | None:
        """An EXR image of the store as (H, W, 3) float32, or ``None`` when the file is missing.

        :func:`benchmarks.store.read_image`: the path is confined to the store and must be a
        regular file; a path that leaves the store, a special file or (with ``sha256``) a
        file whose checksum does not match raises ``ValueError``.
        """
        if not results.image_path(self.path, relpath).exists():
            return None
        return results.read_image(self.path, relpath, rgb=True, sha256=sha256)


def _int_or_none(v):
    if v is None or isinstance(v, bool):
        return None
    try:
        return int(v)
    except (TypeError, ValueError):
        return None


def curve_order(curve: tuple) -> tuple:
    """Sort key for a (renderer, strategy) curve: ours in ``STRATEGIES`` order, then Mitsuba.

    Examples
    --------
    >>> sorted([("mitsuba", "path"), ("ours", "mis"), ("ours", "uniform")], key=curve_order)
    [('ours', 'uniform'), ('ours', 'mis'), ('mitsuba', 'path')]
    """
    renderer, strategy = curve
    if renderer == "ours":
        idx = STRATEGIES.index(strategy) if strategy in STRATEGIES else len(STRATEGIES)
        return (0, idx, str(strategy))
    return (1, 0, f"{renderer}:{strategy}")


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
        If ``store`` is not a folder or holds neither ``results.jsonl`` nor ``summary.json``.
        A summary row without ``scene``, ``renderer`` or ``strategy``
        (:func:`benchmarks.store.read_summary_rows`) and a line of ``results.jsonl`` that is not
        a job record (:func:`benchmarks.store.skipped_line`) are skipped and listed in
        :attr:`Store.problems` (the page shows them), as the harness's own reader skips it.
    """
    path = Path(store).expanduser()
    if not path.is_dir():
        raise ValueError(f"results store {str(path)!r} is not a folder")
    if not (path / results.RESULTS).exists() and not (path / results.SUMMARY).exists():
        if (path / results.META).exists():
            raise ValueError(f"results store {str(path)!r} holds no finished job yet (a run that has just "
                             f"started writes {results.META} first): report it once a job is recorded")
        raise ValueError(f"{str(path)!r} is not a results store: it holds neither "
                         f"{results.RESULTS} nor {results.SUMMARY}")
    out = Store(path=path.resolve())
    out.meta = results.read_meta(path, problems=out.problems)
    raw = _records(path, out.problems)
    out.n_raw_records = len(raw)
    deduped = results.dedupe_records(raw)
    out.records = results.latest_builds(deduped)
    if out.n_raw_records > len(deduped):
        out.problems.append(f"{results.RESULTS}: {out.n_raw_records - len(deduped)} duplicate job "
                            "record(s) (resumed run or a new build); the last of each was kept")
    if len(deduped) > len(out.records):
        old = sorted({str(r.get(results.BUILD_FIELD)) for r in deduped} - {str(r.get(results.BUILD_FIELD))
                                                                             for r in out.records})
        out.problems.append(f"{results.RESULTS}: {len(deduped) - len(out.records)} record(s) of older build(s) "
                            f"({', '.join(old)}) not shown: each curve shows its latest build only")
    out.rows = results.read_summary_rows(path, problems=out.problems)
    out.headline = results.read_headline(path, problems=out.problems)
    return out


def _records(path: Path, problems: list) -> list[dict]:
    """Every job record of ``results.jsonl`` in file order; the lines skipped go to ``problems``.

    The harness's rule (:func:`benchmarks.store.skipped_line`): a line that is not a job
    record is skipped and listed, never fatal, as ``rtbench run`` skips it with a warning.
    """
    if not (path / results.RESULTS).exists():
        problems.append(f"{results.RESULTS} is missing: no curves or images")
        return []
    out, skipped = results.job_records(path, partial=True)
    problems.extend(f"{results.RESULTS}: {why}; skipped" for _, why in skipped)
    return out
