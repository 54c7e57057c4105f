"""The corpus worker: a spawned process that judges scenes one at a time (C++ that Python cannot
interrupt, and that a scene may crash). Past a scene's time limit it is killed (``timeout``);
one that dies gives ``render-error``; the next scene starts a fresh one. Its output goes to
a log file; it ignores Ctrl-C, which the parent handles by stopping it.
"""
from __future__ import annotations

import multiprocessing
import os
import signal
import time

from .judge import judge_scene, setup

__all__ = ["SceneWorker"]

#: seconds a fresh worker may take to import Mitsuba and choose its variant.
START_TIMEOUT_S = 600


def _serve(conn, log_path: str, variant, threads) -> None:
    """The worker's main loop (in the child process)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops the worker
    fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)

    try:
        conn.send(("ready", setup(variant, threads)))
    except Exception as exc:  # noqa: BLE001 - reported to the parent, which stops the run
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        try:
            conn.send(("done", judge_scene(job)))
        except Exception as exc:  # noqa: BLE001 - judge_scene records scene errors; this is a bug
            conn.send(("done", {"status": "render-error", "reasons": [f"{type(exc).__name__}: {exc}"]}))


class SceneWorker:
    """One worker process at a time, started when needed."""

    def __init__(self, *, log_path, variant=None, threads=None):
        self.log_path, self.variant, self.threads = str(log_path), variant, threads
        self.proc = self.conn = None
        self.active_variant = self._exitcode = None

    def _start(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe()
        self.proc = ctx.Process(target=_serve, args=(child, self.log_path, self.variant, self.threads), daemon=True)
        self.proc.start()
        child.close()
        self.conn = parent
        try:
            if not self.conn.poll(START_TIMEOUT_S):
                raise RuntimeError(f"the corpus worker did not start within {START_TIMEOUT_S} s (log: {self.log_path})")
            try:
                kind, value = self.conn.recv()
            except EOFError:
                raise RuntimeError(f"the corpus worker exited while starting (exit code {self.proc.exitcode}; "
                                   f"log: {self.log_path})") from None
            if kind != "ready":
                raise RuntimeError(f"the corpus worker could not set up Mitsuba: {value}")
        except RuntimeError:
            self.close()
            raise
        self.active_variant = value

    def judge(self, job: dict, *, timeout: float) -> dict:
        """The record of ``job`` (``timeout`` / ``render-error`` when the worker ran out of time or
        died); ``RuntimeError`` when no worker can start."""
        if self.proc is None or not self.proc.is_alive():
            self.close()
            self._start()
        t0 = time.perf_counter()
        self.conn.send(job)
        if self.conn.poll(timeout):
            try:
                return self.conn.recv()[1]
            except (EOFError, OSError):
                pass
        elapsed = round(time.perf_counter() - t0, 3)
        alive = self.proc.is_alive()
        self.close()
        if alive:
            return {"status": "timeout", "reasons": [f"no verdict within the time limit of {timeout:g} s"],
                    "seconds": elapsed, "timeout_s": timeout}
        return {"status": "render-error", "seconds": elapsed, "reasons": [
            f"the worker process died (exit code {self._exitcode}); see {os.path.basename(self.log_path)}"]}

    def close(self) -> None:
        """Stop the worker (politely, then by force)."""
        if self.proc is not None:
            try:
                if self.proc.is_alive() and self.conn is not None:
                    try:
                        self.conn.send(None)
                    except (OSError, ValueError):
                        pass
                    self.proc.join(0.5)
                if self.proc.is_alive():
                    self.proc.kill()
                self.proc.join(5)
                self._exitcode = self.proc.exitcode
            finally:
                self.proc = None
        if self.conn is not None:
            self.conn.close()
            self.conn = None
