"""``meta.json`` and ``summary.json``, each checked once where it is read: after that a reader
may index what it reads."""
from __future__ import annotations

from .jsonio import read_json, store_path, write_json
from .records import check_identity

META = "meta.json"
SUMMARY = "summary.json"


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _is_scalar(v) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


#: the type of each field of a reference entry of ``meta.json`` (STORE.md).
_REFERENCE_FIELDS = {"path": str, "variance_path": str, "sha256": str, "variance_sha256": str, "variant": str,
                     "key": str, "scene_hash": str, "scene_source": str, "spp": "number", "seed": "number",
                     "width": "number", "height": "number", "render_seconds": "number"}
_SCENE_FILE_FIELDS = {"name": str, "source": str, "kind": str, "hash": str, "params": "scalars"}


def _fits(value, kind) -> bool:
    if value is None:
        return True
    if kind == "number":
        return _is_number(value)
    if kind == "scalars":
        return isinstance(value, dict) and all(_is_scalar(v) for v in value.values())
    return isinstance(value, kind)


def _clean_entry(entry: dict, fields: dict) -> dict:
    """The known fields of ``entry`` that have the right type."""
    return {k: v for k, v in entry.items() if k in fields and _fits(v, fields[k])}


def _plain(v) -> bool:  # a plain value, or one level of them (llvm_target)
    return _is_scalar(v) or _fits(v, "scalars")


def _is_dict(v) -> bool:
    return isinstance(v, dict)


#: the type of each known key of ``meta.json`` (others: a plain value).
_META_TYPES = {"date": str, "preset": str, "total_seconds": "number", "threads": "number", "runs": list,
               "groups": list, **dict.fromkeys(("machine", "versions", "references", "references_by_size",
                                               "scene_files", "target_rmse"), dict)}
#: per dict-valued key: which entries are kept (the others dropped and said) and the fields kept of each.
_ENTRIES = {"machine": (_plain, None), "versions": (_plain, None), "target_rmse": (_is_number, None),
            "references": (_is_dict, _REFERENCE_FIELDS), "references_by_size": (_is_dict, _REFERENCE_FIELDS),
            "scene_files": (_is_dict, _SCENE_FILE_FIELDS)}


def _clean_meta(meta: dict, problems: list | None) -> dict:
    """``meta.json`` as STORE.md gives it: each known key with its type, entries of the wrong
    shape dropped (and said in ``problems``), unknown keys kept only as plain values.

    >>> _clean_meta({"references": {"a": [1], "b": {"spp": 4, "path": 7}}, "threads": "x"}, None)
    {'references': {'b': {'spp': 4}}}
    >>> _clean_meta({"versions": {"mitsuba": "3.9.1", "llvm_target": {"cpu": "x"}}, "groups": [{"seeds": 4}]}, [])
    {'versions': {'mitsuba': '3.9.1', 'llvm_target': {'cpu': 'x'}}, 'groups': [{'seeds': 4}]}
    """
    out, dropped = {}, []
    for key, value in meta.items():
        kind = _META_TYPES.get(key)
        if not (_is_scalar(value) if kind is None else value is not None and _fits(value, kind)):
            dropped.append(key)
            continue
        out[key] = value
        if key in _ENTRIES:
            keep, fields = _ENTRIES[key]
            dropped += [f"{key}.{k}" for k, v in value.items() if not keep(v)]
            out[key] = {str(k): _clean_entry(v, fields) if fields else v for k, v in value.items() if keep(v)}
        elif key == "runs":
            out[key] = [r for r in value if _is_dict(r) and _fits(r, "scalars")]
        elif key == "groups":  # the run's sweep groups, as written (nobody indexes them)
            out[key] = [g for g in value if _is_dict(g)]
    if dropped and problems is not None:
        problems.append(f"{META}: {len(dropped)} field(s) of the wrong type ignored: {', '.join(dropped[:8])}"
                        + (", ..." if len(dropped) > 8 else ""))
    return out


def read_meta(store, *, problems: list | None = None) -> dict:
    """A store's ``meta.json`` checked by :func:`_clean_meta` (empty when missing or no object)."""
    meta = read_json(META, problems=problems, store=store)
    if meta is not None and not isinstance(meta, dict):
        if problems is not None:
            problems.append(f"{META} is not a JSON object; ignored")
        meta = None
    return _clean_meta(meta or {}, problems)


def read_summary_rows(store, *, problems: list | None = None) -> list:
    """The ``rows`` of a store's ``summary.json`` (empty when missing): each a JSON object with
    ``scene``, ``renderer`` and ``strategy`` (:func:`benchmarks.store.check_identity`); any other row
    (STORE.md: any value may be null) is skipped and said in ``problems``, never fatal."""
    summ = read_json(SUMMARY, problems=problems, store=store)
    if summ is None:
        return []
    rows = summ.get("rows") if isinstance(summ, dict) else None
    if not isinstance(rows, list):
        if problems is not None:
            problems.append(f"{SUMMARY} has no 'rows' list; ignored")
        return []
    good = []
    for i, row in enumerate(rows):
        try:
            if not isinstance(row, dict):
                raise ValueError(f"{SUMMARY} row {i} is not a JSON object")
            check_identity(row, f"{SUMMARY} row {i}", need_spp=False)
        except ValueError as exc:
            if problems is not None:
                problems.append(f"{exc}; skipped")
            continue
        good.append(row)
    return good


def read_headline(store, *, problems: list | None = None) -> list:
    """The ``headline`` entries of a store's ``summary.json`` (one per scene and size; empty
    when missing): each a JSON object with a string ``scene``; others are dropped and said."""
    summ = read_json(SUMMARY, store=store)
    entries = summ.get("headline") if isinstance(summ, dict) else None
    if not isinstance(entries, list):
        return []
    good = [e for e in entries if isinstance(e, dict) and isinstance(e.get("scene"), str)
            and isinstance(e.get("curves", []), list)]
    for e in good:
        e["curves"] = [c for c in e.get("curves") or [] if isinstance(c, dict)]
    if len(good) < len(entries) and problems is not None:
        problems.append(f"{SUMMARY}: {len(entries) - len(good)} headline entr(ies) that are not scene entries ignored")
    return good


def update_meta(store, **fields) -> dict:
    """Merge ``fields`` into ``meta.json`` (dicts one level deep); returns the new metadata.

    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> _ = update_meta(d, preset="quick", references={"a": {"spp": 4}})
    >>> update_meta(d, references={"b": {"spp": 8}})["references"]
    {'a': {'spp': 4}, 'b': {'spp': 8}}
    """
    path = store_path(store) / META
    meta = read_json(META, default={}, store=store)
    if not isinstance(meta, dict):
        meta = {}
    for k, v in fields.items():
        if isinstance(v, dict) and isinstance(meta.get(k), dict):
            meta[k] = {**meta[k], **v}
        else:
            meta[k] = v
    write_json(path, meta)
    return meta
