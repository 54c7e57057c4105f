"""Where the jobs run: one at a time here, or one per worker on a Dask cluster. Each finished
job is stored at once (images, then its record); a failed job is reported, never fatal."""
from __future__ import annotations

import collections
import inspect
import time
from pathlib import Path

from mitsuba_scenes.scene_files import scene_file

from ..external import external
from ..store import append_record, write_image
from .execute import execute_job

#: how long to try to reach a Dask scheduler before giving up.
DASK_CONNECT_TIMEOUT = "20s"


def store_result(store: Path, result: dict) -> None:
    """Write a job's images, then append its record (last: a record always has its images)."""
    for rel, img in result["images"].items():
        write_image(store, rel, img)
    append_record(store, result["record"])


def _failed(job, exc, *, failures, say) -> None:
    failures.append((job.label, f"{type(exc).__name__}: {exc}"))
    say(f"FAILED {job.label}: {type(exc).__name__}: {exc}")


def run_local(todo, refs, store, *, threads, variant, keep, bar, say, failures, tally) -> None:
    """Run ``todo`` here, one job at a time, counting the jobs stored in ``tally.done``.

    ``refs``: (scene, width, height) -> reference; ``keep(job)``: ``execute_job``'s ``keep_*``
    keywords; ``failures`` gets (label, error text) pairs.
    """
    for job in todo:
        bar.current(job.label)
        try:
            res = execute_job(job, refs[(job.scene, job.width, job.height)], threads=threads, variant=variant,
                              **keep(job))
        except Exception as exc:  # noqa: BLE001 - one failed job must not sink the sweep
            _failed(job, exc, failures=failures, say=say)
        else:
            store_result(store, res)
            tally.done += 1
        bar.advance(job.cost)


def run_dask(todo, refs, store, *, address, variant, keep, bar, say, failures, tally, poll=2.0) -> None:
    """One job per worker, pinned to an idle one; ``address``: a scheduler address or a
    ``distributed.Client``; the rest as :func:`run_local`."""
    from distributed import Client  # deferred: Dask's distributed takes about 1.5 s to import

    client = address if not isinstance(address, str) else None
    own = client is None
    if own:
        try:
            client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from exc
    try:
        _DaskQueue(client, store, address=address, variant=variant, keep=keep, bar=bar, say=say,
                   failures=failures, poll=poll, tally=tally).run(todo, refs)
    finally:
        if own:
            client.close()


class _DaskQueue:
    """The jobs of one :func:`run_dask` call: pending, running (future -> (job, worker)), done."""

    def __init__(self, client, store, *, address, variant, keep, bar, say, failures, poll, tally):
        self.client, self.store, self.address = client, store, address
        self.variant, self.keep, self.bar, self.say, self.failures, self.poll = variant, keep, bar, say, failures, poll
        self.running, self.tally = {}, tally

    def workers(self) -> dict:
        """{worker address: its thread count}."""
        try:  # newer distributed lists only a few workers unless told
            accepts = "n_workers" in inspect.signature(self.client.scheduler_info).parameters
        except (TypeError, ValueError):
            accepts = False
        info = self.client.scheduler_info(**({"n_workers": -1} if accepts else {}))
        return {addr: int(w.get("nthreads", 1) or 1) for addr, w in info.get("workers", {}).items()}

    def run(self, todo, refs) -> None:
        from distributed import wait  # deferred: Dask's distributed takes about 1.5 s to import

        pending = collections.deque(todo)
        try:
            pool = self._wait_for_workers()
            self.say(f"dask: {len(pool)} worker(s) at {self.client.scheduler.address}, one job per worker")
            scattered = {k: self.client.scatter(ref, broadcast=True) for k, ref in refs.items()}
            while pending or self.running:
                self._submit(pending, pool, scattered)
                if not self.running:
                    time.sleep(self.poll)
                    pool = self.workers()
                    continue
                try:
                    finished, _ = wait(list(self.running), timeout=self.poll, return_when="FIRST_COMPLETED")
                except TimeoutError:  # nothing finished within `poll`: look at the workers again
                    finished = []
                for fut in finished:
                    self._collect(fut)
                pool = self.workers()
                self._requeue_lost(pool, pending)
        finally:
            for fut in self.running:
                fut.cancel()

    def _wait_for_workers(self) -> dict:
        pool = self.workers()
        t_wait = time.monotonic()
        while not pool:
            if time.monotonic() - t_wait > 60:
                raise ValueError(f"the Dask cluster at {self.address!r} has no workers")
            time.sleep(1.0)
            pool = self.workers()
        return pool

    def _submit(self, pending, pool, scattered) -> None:
        """Give each idle worker the next pending job, pinned to it."""
        busy = {addr for _, addr in self.running.values()}
        for addr in list(pool):
            if addr in busy or not pending:
                continue
            job = pending.popleft()
            fut = self.client.submit(execute_job, job, scattered[(job.scene, job.width, job.height)],
                                     threads=pool[addr], variant=self.variant, **self.keep(job),
                                     scene_file=scene_file(job.scene), external=external(job.renderer),
                                     workers=[addr], allow_other_workers=False, pure=False,
                                     key=f"rtbench-{job.scene}-{job.renderer}-{job.strategy}-{job.spp}-"
                                         f"{job.seed}-{job.width}x{job.height}-{time.monotonic_ns()}")
            self.running[fut] = (job, addr)
            self.bar.current(job.label)

    def _collect(self, fut) -> None:
        job, _ = self.running.pop(fut)
        if fut.status == "finished":
            store_result(self.store, fut.result())
            self.tally.done += 1
        else:
            try:
                exc = fut.exception()
            except Exception as e:  # noqa: BLE001
                exc = e
            _failed(job, exc, failures=self.failures, say=self.say)
        self.bar.advance(job.cost)

    def _requeue_lost(self, pool, pending) -> None:
        """A worker that left: requeue its job (its task would wait for it forever)."""
        for fut, (job, addr) in list(self.running.items()):
            if addr not in pool:
                fut.cancel()
                self.running.pop(fut)
                pending.appendleft(job)
                self.say(f"dask: worker {addr} left; requeued {job.label}")

