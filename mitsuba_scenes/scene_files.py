"""Scenes from files: a Mitsuba 3 XML file or a Python file, registered beside the suite.

A user scene is a :class:`SceneFile`: its name (the file's stem), the path, the
parameters (``$name`` defaults of the XML overridden by ``--param name=value``, or keyword
arguments of the Python file's ``build``) and a content hash (the file's bytes, the
parameters and, for XML, every file it names: meshes and includes are hashed by their
resolved scene instead). :func:`register_scene_file` loads the file once (so unsupported
features are refused at once, with file:line, by :func:`mitsuba_scenes.from_mitsuba`) and
registers it, after which :func:`mitsuba_scenes.get_scene` builds it by name like any
suite scene, with the same ``width`` / ``height`` overrides.

Python files define ``build(width, height, **params)`` returning a
:class:`reference_tracer.Scene`; ``width`` and ``height`` are passed when a size is asked
for, else ``build``'s own defaults apply.
"""
from __future__ import annotations

import ast
import hashlib
import importlib.util
import inspect
import re
from dataclasses import dataclass, field
from pathlib import Path

import reference_tracer as rt

from .importer import from_mitsuba
from .scenes import SUITE

__all__ = ["SceneFile", "params_used", "register_scene_file", "registered", "scene_file", "restore_registry", "clear_registry",
           "parse_params", "load_scene_file"]

#: registered user scenes by name (this process; Dask workers get them from the client).
_REGISTRY: dict = {}

_NAME_OK = re.compile(r"[^A-Za-z0-9_.-]+")


@dataclass(frozen=True)
class SceneFile:
    """A scene read from a file.

    Attributes
    ----------
    name : str
        The name it is known by in records, references and the report.
    path : str
        Absolute path of the file.
    kind : str
        ``'xml'`` (Mitsuba 3, through :func:`mitsuba_scenes.from_mitsuba`) or ``'python'``.
    params : dict
        Parameters given (``--param``): XML ``$name`` values or ``build`` keyword arguments.
    content_hash : str
        16 hex digits over the file's bytes, the parameters and the imported scene.
    """

    name: str
    path: str
    kind: str
    params: dict = field(default_factory=dict)
    content_hash: str = ""

    def build(self, width: int | None = None, height: int | None = None) -> rt.Scene:
        """The scene, resized to ``width`` x ``height`` when given (height defaults to width).

        An XML file is imported at that film size, so that its field of view follows its
        ``fov_axis`` as in Mitsuba (resizing our camera afterwards keeps the vertical one).
        """
        if height is not None and width is None:
            raise ValueError("height needs width")
        if width is not None and height is None:
            height = width
        if self.kind == "xml":
            size = None if width is None else (int(width), int(height))
            return from_mitsuba(self.path, params=self.params, film_size=size)
        return _build_python(self.path, self.params, width, height)

    def describe(self) -> str:
        extra = ", ".join(f"{k}={v}" for k, v in sorted(self.params.items()))
        return f"{self.kind} scene file {self.path}" + (f" ({extra})" if extra else "")

    def to_dict(self) -> dict:
        """What records and ``meta.json`` say of the scene."""
        return {"name": self.name, "source": self.path, "kind": self.kind, "params": dict(self.params),
                "hash": self.content_hash}


def parse_params(items) -> dict:
    """``['a=1', 'b=x']`` (``--param`` values) -> ``{'a': '1', 'b': 'x'}``.

    Examples
    --------
    >>> parse_params(["spp=4", "fov_axis=y"])
    {'spp': '4', 'fov_axis': 'y'}
    >>> parse_params(["oops"])
    Traceback (most recent call last):
    ...
    ValueError: --param must be name=value, got 'oops'
    """
    out = {}
    for item in items or ():
        name, sep, value = str(item).partition("=")
        if not sep or not name.strip():
            raise ValueError(f"--param must be name=value, got {item!r}")
        out[name.strip()] = value.strip()
    return out


def params_used(path, params: dict) -> dict:
    """The entries of ``params`` that scene file ``path`` takes: the ``$name`` values an XML
    file uses, or the keyword arguments ``build`` of a Python file accepts.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "s.xml")
    >>> _ = open(p, "w").write('<scene version="3.0.0"><default name="spp" value="4"/>'
    ...                        '<integer name="n" value="$spp"/></scene>')
    >>> params_used(p, {"spp": "8", "res": "16"})
    {'spp': '8'}
    """
    path = Path(path)
    if path.suffix.lower() == ".xml":
        text = path.read_text(errors="replace")
        return {k: v for k, v in params.items() if f"${k}" in text}
    if path.suffix.lower() == ".py":
        build = getattr(_load_module(str(path)), "build", None)
        if not callable(build):
            return {}
        accepted = inspect.signature(build).parameters
        if any(p.kind == p.VAR_KEYWORD for p in accepted.values()):
            return dict(params)
        return {k: v for k, v in params.items() if k in accepted}
    return {}


def load_scene_file(path, params=None) -> rt.Scene:
    """The scene of an XML or Python file at its own size (a Python file's ``build`` defaults, else
    :data:`PYTHON_DEFAULT_SIZE`); ``ValueError`` if unsupported."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"no such scene file: {path}")
    if not path.is_file():
        raise ValueError(f"scene file {path} is not {'a file but a directory' if path.is_dir() else 'a regular file'}")
    if path.suffix.lower() == ".xml":
        return from_mitsuba(path, params=params or {})
    if path.suffix.lower() == ".py":
        return _build_python(str(path), params or {}, None, None)
    raise ValueError(f"scene file {path} must be a Mitsuba XML (.xml) or a Python file (.py) defining build()")


def _python_value(text: str):
    """A ``--param`` string as a Python literal when it is one (``'3'`` -> 3), else the string."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _load_module(path: str):
    """The Python scene file as a module (``ValueError`` when it does not import)."""
    spec = importlib.util.spec_from_file_location(f"rtbench_user_scene_{_digest(path.encode())}", path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # the user's file: any error is bad input
        raise ValueError(f"{path}: cannot load: {type(exc).__name__}: {exc}") from exc
    return module


#: the size a Python scene file's ``build`` gets where neither the caller nor its defaults give one
#: (that of the suite's scenes).
PYTHON_DEFAULT_SIZE = (64, 64)


def _build_python(path: str, params: dict, width, height) -> rt.Scene:
    build = getattr(_load_module(path), "build", None)
    if not callable(build):
        raise ValueError(f"{path}: defines no build(width, height) function")
    accepted = inspect.signature(build).parameters
    var_keyword = any(p.kind == p.VAR_KEYWORD for p in accepted.values())
    if not var_keyword and not {"width", "height"} <= set(accepted):
        raise ValueError(f"{path}: build() must accept (width, height); it accepts {list(accepted)}")
    kwargs = {k: _python_value(v) for k, v in params.items()}
    unknown = sorted(k for k in kwargs if k not in accepted and not var_keyword)
    if unknown:
        raise ValueError(f"{path}: build() takes no parameter(s) {unknown}; it accepts {sorted(accepted)}")
    if width is None:  # the file's own size: its defaults, else the suite's
        width, height = (None, None) if all(
            k in accepted and accepted[k].default is not inspect.Parameter.empty for k in ("width", "height")
        ) else PYTHON_DEFAULT_SIZE
    if width is not None:
        kwargs.update(width=int(width), height=int(height))
    try:
        scene = build(**kwargs)
    except Exception as exc:  # the user's file: any error is bad input
        raise ValueError(f"{path}: build(): {type(exc).__name__}: {exc}") from exc
    if not isinstance(scene, rt.Scene):
        raise ValueError(f"{path}: build() returned {type(scene).__name__}, not a reference_tracer.Scene")
    if width is not None and (scene.camera.width, scene.camera.height) != (int(width), int(height)):
        scene = scene.with_camera_size(int(width), int(height))
    return scene


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def _content_hash(path: Path, params: dict, scene: rt.Scene) -> str:
    h = hashlib.sha256(path.read_bytes())
    h.update(repr(sorted(params.items())).encode())
    h.update(scene.content_hash().encode())  # meshes and includes the file names: their content too
    return h.hexdigest()[:16]


#: longest scene name: it names files (images, references, plots) with more beside it.
MAX_NAME = 80


def _scene_name(path: Path, params: dict) -> str:
    """The file's stem, plus the parameters when any are given (``box+res=8+spp=4``).

    A name longer than :data:`MAX_NAME` is cut and ends with 8 hex digits of a hash of the
    whole, so that files named after it stay within a file system's limits.

    Examples
    --------
    >>> _scene_name(Path("box.xml"), {"spp": "4"})
    'box+spp=4'
    >>> len(_scene_name(Path("s" * 240 + ".xml"), {}))
    80
    """
    name = _NAME_OK.sub("_", path.stem) + "".join(f"+{k}={_NAME_OK.sub('_', v)}" for k, v in sorted(params.items()))
    if len(name) > MAX_NAME:
        name = f"{name[:MAX_NAME - 9]}-{_digest(name.encode())[:8]}"
    return name


def register_scene_file(path, params=None, *, name: str | None = None) -> SceneFile:
    """Load a scene file, check it, and register it under its name; returns its :class:`SceneFile`.

    Parameters
    ----------
    path : str or Path
        A Mitsuba 3 XML file or a Python file defining ``build(width, height)``.
    params : dict, optional
        XML ``$name`` values or ``build`` keyword arguments (strings; literals are parsed
        for Python files).
    name : str, optional
        The name to register (default: the file's stem, with the parameters).

    Raises
    ------
    ValueError
        The file is missing, not a scene, uses unsupported features (with file:line), or
        its name is a suite scene's or another registered file's.
    """
    path = Path(path).resolve()
    params = {str(k): str(v) for k, v in (params or {}).items()}
    scene = load_scene_file(path, params)
    name = name or _scene_name(path, params)
    if name in SUITE:
        raise ValueError(f"scene file {path} is named {name!r} like a suite scene; rename the file")
    entry = SceneFile(name=name, path=str(path), kind="xml" if path.suffix.lower() == ".xml" else "python",
                      params=params, content_hash=_content_hash(path, params, scene))
    old = _REGISTRY.get(name)
    if old is not None and (old.path, old.params) != (entry.path, entry.params):
        raise ValueError(f"two scene files are named {name!r}: {old.path} and {entry.path}; rename one")
    _REGISTRY[name] = entry
    return entry


def registered() -> list:
    """The registered :class:`SceneFile` entries, in registration order."""
    return list(_REGISTRY.values())


def scene_file(name: str):
    """The registered :class:`SceneFile` called ``name``, or None."""
    return _REGISTRY.get(name)


def restore_registry(entries) -> None:
    """Register ``entries`` (:class:`SceneFile`) as they are: how Dask workers learn the client's scenes."""
    for e in entries:
        _REGISTRY[e.name] = e


def clear_registry() -> None:
    """Forget every registered scene file (tests)."""
    _REGISTRY.clear()
