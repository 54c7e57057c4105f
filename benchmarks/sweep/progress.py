"""One progress bar (rich) for a whole run, every step planned up front with a rough cost in
seconds (:func:`render_cost`; rich's rate estimate adapts it), and :class:`Phases`, the wall
time of each phase for the run's time breakdown."""
from __future__ import annotations

import contextlib
import os
import time

from rich import progress as rich_progress
from rich.console import Console
from rich.table import Column

_IMPORTED = time.time()


def process_seconds() -> float:
    """Wall seconds since this process started (``/proc``; elsewhere since this module was
    imported): a run's total as ``time`` gives it, start-up included."""
    try:
        with open("/proc/self/stat") as f:
            start_ticks = int(f.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(0.0, uptime - start_ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return time.time() - _IMPORTED


#: rough microseconds per sample of a suite scene on two cores (the bar's rate adapts).
OURS_US_PER_SAMPLE = 0.2
MITSUBA_US_PER_SAMPLE = 0.35


def render_cost(pixels: int, spp: int, *, renderer: str = "ours", overhead: float = 0.03) -> float:
    """Estimated seconds of one render of ``pixels`` x ``spp`` samples.

    >>> round(render_cost(32 * 32, 16384), 2)
    3.39
    """
    us = MITSUBA_US_PER_SAMPLE if renderer == "mitsuba" else OURS_US_PER_SAMPLE
    return pixels * spp * us * 1e-6 + overhead


class Progress:
    """A rich bar over the planned cost of a run's steps (:meth:`plan` adds steps, :meth:`advance`
    marks one done); every method but the counts a no-op unless ``enabled``."""

    def __init__(self, *, enabled: bool, console=None):
        self.enabled = enabled
        self.steps_total = 0
        self.steps_done = 0
        self.cost_total = 0.0
        self._started = False
        self._console = console

    def _start(self):
        rp = rich_progress
        self.progress = rp.Progress(rp.TextColumn("[bold]{task.fields[steps]}[/] steps",
                                                  table_column=Column(no_wrap=True)),
                                    rp.BarColumn(bar_width=24), rp.TimeElapsedColumn(table_column=Column(no_wrap=True)),
                                    rp.TextColumn("left", table_column=Column(no_wrap=True)),
                                    rp.TimeRemainingColumn(table_column=Column(no_wrap=True)),
                                    rp.TextColumn("{task.description}", table_column=Column(
                                        ratio=1, no_wrap=True, overflow="ellipsis")),
                                    console=self._console, transient=False, speed_estimate_period=120)
        self.task = self.progress.add_task("", total=max(self.cost_total, 1e-9), steps="")
        self.progress.start()
        self._started = True

    def _update(self, **fields) -> None:
        if self.enabled:
            if not self._started:
                self._start()
            self.progress.update(self.task, steps=f"{self.steps_done}/{self.steps_total}", **fields)

    def plan(self, cost: float, steps: int = 1) -> None:
        """Add ``steps`` steps of total estimated ``cost`` seconds to the run."""
        self.steps_total += int(steps)
        self.cost_total += float(cost)
        if self._started:
            self._update(total=self.cost_total)

    def current(self, label: str) -> None:
        self._update(description=label)

    def advance(self, cost: float) -> None:
        self.steps_done += 1
        self._update(advance=cost)

    def log(self, text: str) -> None:
        if self.enabled:
            console = self.progress.console if self._started else (self._console or Console(stderr=True))
            console.print(text, highlight=False, markup=False, soft_wrap=True)

    def stop(self) -> None:
        if self.enabled and self._started:
            self.progress.stop()
            self._started = False


class Phases:
    """Wall seconds per phase of a run, in the order they ran.

    >>> ph = Phases()
    >>> with ph("references"):
    ...     pass
    >>> list(ph.seconds)
    ['references']
    """

    def __init__(self):
        self.seconds: dict = {}

    @contextlib.contextmanager
    def __call__(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0

    def line(self, total: float | None = None) -> str:
        """``references 16 s, jobs 25 s, ... (total 140 s)``."""
        parts = ", ".join(f"{k} {v:.0f} s" for k, v in self.seconds.items())
        return parts + (f" (total {total:.0f} s)" if total is not None else "")
