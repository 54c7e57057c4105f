"""Shared helpers of the harness tests (``tests/benchmarks/**/test_harness_*.py`` and others that run ``rtbench``)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

from repo_paths import ROOT


def cache_root(tmp_path_factory) -> Path:
    """One reference cache for the whole test session (references are the expensive part)."""
    path = tmp_path_factory.getbasetemp() / "rtbench-cache"
    path.mkdir(exist_ok=True)
    return path


def strict_json(text: str):
    """``json.loads`` of a strict parser (``jq``, JavaScript's ``JSON.parse``): the tokens
    ``NaN``, ``Infinity`` and ``-Infinity`` that Python's own parser takes are refused."""
    def refuse(token):
        raise ValueError(f"not JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def comparable(record: dict, *, ignore=()) -> dict:
    """A job record without its timing/machine fields, for run-to-run comparison."""
    from benchmarks.sweep import TIMING_FIELDS

    skip = set(TIMING_FIELDS) | set(ignore)
    return {k: v for k, v in record.items() if k not in skip}


def rtbench(*args, cache, check=True, timeout=600, **kw) -> subprocess.CompletedProcess:
    """Run the ``rtbench`` CLI in a subprocess with the test cache."""
    env = dict(os.environ, RTBENCH_CACHE=str(cache), PYTHONUNBUFFERED="1")
    proc = subprocess.run([sys.executable, "-m", "benchmarks.cli", *map(str, args)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout, **kw)
    if check and proc.returncode != 0:
        raise AssertionError(f"rtbench {' '.join(map(str, args))} exited {proc.returncode}:\n"
                             f"{proc.stdout}\n{proc.stderr}")
    return proc


def default_sigint() -> None:
    """``preexec_fn`` for a child that must see Ctrl-C: SIGINT at its default disposition
    and unblocked before exec. In the full test suite something leaves SIGINT ignored at
    the C level in this process, exec keeps an ignored signal ignored, and Python then
    installs no handler: the child would run through every SIGINT to the end."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
