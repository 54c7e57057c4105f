"""The XML files of a folder: scenes, fragments (files another one ``<include>``s, or whose root
is not ``<scene>``) and each scene's content hash over every file it names (resolved as
Mitsuba does). Files are only read, with ``xml.etree`` (no external entities), special files
and files over :data:`MAX_XML_BYTES` skipped.

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "a.xml").write_text('<scene version="3.0.0"><include filename="inc/b.xml"/></scene>')
>>> (d / "inc").mkdir(); _ = (d / "inc/b.xml").write_text('<scene version="3.0.0"/>')
>>> found = scan(d)
>>> [p.name for p in found.scenes], {p.name: [q.name for q in by] for p, by in found.fragments.items()}
(['a.xml'], {'b.xml': ['a.xml']})
"""
from __future__ import annotations

import hashlib
import os
import re
import stat
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from ..files import open_regular
from ..store import file_sha256

__all__ = ["MAX_XML_BYTES", "Scan", "scan", "xml_files", "content_hash", "display_path", "printable"]

#: larger XML files are not parsed here (Mitsuba still judges them as scenes).
MAX_XML_BYTES = 16 << 20
#: include chains deeper than this are not followed (Mitsuba's own limit is 15).
MAX_INCLUDE_DEPTH = 16

_PARAM = re.compile(r"\$(\w+)")


@dataclass
class Scan:
    """``scenes`` to judge (sorted), ``fragments`` (path -> the files that include it, ``[]`` when
    its root is not a scene) and ``roots`` (path -> a root tag other than ``scene``)."""

    scenes: list = field(default_factory=list)
    fragments: dict = field(default_factory=dict)
    roots: dict = field(default_factory=dict)


def printable(path) -> str:
    """A path as text that encodes to UTF-8 (bytes that are not UTF-8 shown as ``\\udcNN``)."""
    return os.fspath(path).encode("utf-8", "backslashreplace").decode("utf-8")


def display_path(path, root) -> str:
    """``path`` relative to ``root``, :func:`printable`.

    >>> display_path("/data/scenes/a b.xml", "/data")
    'scenes/a b.xml'
    """
    return printable(os.path.relpath(os.fspath(path), os.fspath(root)))


def xml_files(root) -> list:
    """Every regular ``*.xml`` file under ``root`` (recursive, symbolic links not followed), sorted."""
    out = []
    for folder, _, files in os.walk(root, followlinks=False):
        for path in (Path(folder) / name for name in files if name.lower().endswith(".xml")):
            try:
                if stat.S_ISREG(os.lstat(path).st_mode):
                    out.append(path)
            except OSError:
                continue
    return sorted(out)


def _parse(path: Path):
    """The root element of ``path``, or None when it cannot be read or parsed here."""
    try:
        with open_regular(path, max_bytes=MAX_XML_BYTES) as f:
            return ET.fromstring(f.read())
    except (OSError, ValueError, ET.ParseError, RecursionError):
        return None


def _subst(text, defaults: dict):
    if text is None:
        return None
    return _PARAM.sub(lambda m: str(defaults.get(m.group(1), m.group(0))), text)


def _find(name, folders) -> Path | None:
    if not name or "\x00" in name:
        return None
    for folder in folders:
        cand = Path(folder) / name
        try:
            if cand.is_file():
                return cand.resolve()
        except (OSError, ValueError):
            continue
    return None


def _references(path) -> tuple:
    """``(includes, files)`` of ``path``: the files it includes and every file it names that can
    be found (includes first met first), each once."""
    path = Path(path).resolve()
    includes, files, seen = [], [], set()

    def walk(p: Path, search: list, defaults: dict, depth: int) -> None:
        p = p.resolve()
        if p in seen or depth > MAX_INCLUDE_DEPTH:
            return
        seen.add(p)
        root = _parse(p)
        if root is None:
            return
        defaults = {**{d.get("name"): d.get("value") for d in root.iter("default")}, **defaults}
        values = (_subst(e.get("value"), defaults) for e in root.iter("path"))
        search = [p.parent / v for v in values if v][::-1] + search
        for el in root.iter():
            if el.tag == "include" or el.get("name") == "filename":
                name = el.get("filename") if el.tag == "include" else el.get("value")
                found = _find(_subst(name, defaults), [p.parent, path.parent] + search)
                if found is not None:
                    files.append(found)
                    if el.tag == "include":
                        includes.append(found)
                        walk(found, search, defaults, depth + 1)

    walk(path, [], {}, 0)
    return list(dict.fromkeys(includes)), list(dict.fromkeys(files))


def scan(root) -> Scan:
    """The scenes and fragments among the XML files under ``root`` (see the module docstring)."""
    root = Path(root).resolve()
    found = Scan()
    files = xml_files(root)
    included_by: dict = {}
    for path in files:
        top = _parse(path)
        if top is not None and top.tag != "scene":
            found.roots[path] = str(top.tag)
        for inc in _references(path)[0]:
            included_by.setdefault(inc, []).append(path)
    for path in files:
        by = included_by.get(path.resolve())
        if by:
            found.fragments[path] = sorted(by)
        elif path in found.roots:
            found.fragments[path] = []
        else:
            found.scenes.append(path)
    return found


def _file_digest(path: Path, cache: dict) -> str:
    if path not in cache:
        try:
            cache[path] = file_sha256(path)
        except (OSError, ValueError) as exc:
            cache[path] = f"unreadable: {type(exc).__name__}"
    return cache[path]


def content_hash(path, root, *, cache: dict | None = None) -> str:
    """SHA-256 over scene ``path`` and every file it names, each with its path relative to
    ``root``; ``cache`` (path -> digest) spares re-reading shared files."""
    cache = {} if cache is None else cache
    path = Path(path).resolve()
    h = hashlib.sha256()
    for f in [path] + sorted(set(_references(path)[1]) - {path}):
        h.update(os.path.relpath(f, Path(root).resolve()).encode("utf-8", "surrogateescape"))
        h.update(b"\0" + _file_digest(f, cache).encode() + b"\n")
    return h.hexdigest()
