"""The sweep's progress bar (rich) over the estimated cost of its jobs."""
from __future__ import annotations

__all__ = ["Progress"]


class Progress:
    """A rich progress bar over estimated job cost: jobs done, current job, time left.

    Disabled (every method a no-op) when ``enabled`` is false or there is no job.
    """

    def __init__(self, total_cost: float, total_jobs: int, *, enabled: bool, console=None):
        self.enabled = enabled and total_jobs > 0
        self.jobs_total = total_jobs
        self.jobs_done = 0
        if not self.enabled:
            return
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
        from rich.table import Column

        self.progress = Progress(TextColumn("[bold]{task.fields[jobs]}[/] jobs", table_column=Column(no_wrap=True)),
                                 BarColumn(bar_width=24), TimeElapsedColumn(table_column=Column(no_wrap=True)),
                                 TextColumn("left", table_column=Column(no_wrap=True)),
                                 TimeRemainingColumn(table_column=Column(no_wrap=True)),
                                 TextColumn("{task.description}", table_column=Column(
                                     ratio=1, no_wrap=True, overflow="ellipsis")),
                                 console=console, transient=False, speed_estimate_period=120)
        self.task = self.progress.add_task("", total=total_cost, jobs=f"0/{total_jobs}")
        self.progress.start()

    def current(self, label: str):
        if self.enabled:
            self.progress.update(self.task, description=label)

    def advance(self, cost: float):
        self.jobs_done += 1
        if self.enabled:
            self.progress.update(self.task, advance=cost, jobs=f"{self.jobs_done}/{self.jobs_total}")

    def log(self, text: str):
        if self.enabled:
            self.progress.console.print(text, highlight=False, markup=False)

    def stop(self):
        if self.enabled:
            self.progress.stop()
