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


class _Tally:
    done = 0


def run_local(todo, refs, store, *, threads, variant, keep, bar, say, failures, tally=None) -> int:
    """Run ``todo`` here, one job at a time; returns the jobs stored (also counted in ``tally.done``).

    ``refs``: (scene, width, height) -> reference; ``keep(job)``: ``(keep_image, keep_stats)``;
    ``failures`` gets (label, error text) pairs.
    """
    tally = _Tally() if tally is None else tally
    for job in todo:
        bar.current(job.label)
        ki, ks = keep(job)
        try:
            res = execute_job(job, refs[(job.scene, job.width, job.height)], threads=threads, variant=variant,
                              keep_image=ki, keep_stats=ks)
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # noqa: BLE001 - one failed job must not sink the sweep
            _failed(job, exc, failures=failures, say=say)
            bar.advance(job.cost)
            continue
        store_result(store, res)
        tally.done += 1
        bar.advance(job.cost)
    return tally.done


def run_dask(todo, refs, store, *, address, variant, keep, bar, say, failures, poll=2.0, tally=None) -> int:
    """One job per worker, pinned to an idle one; ``address``: a scheduler address or a
    ``distributed.Client``; the rest as :func:`run_local`."""
    from distributed import Client

    client = address if not isinstance(address, str) else None
    own = client is None
    if own:
        try:
            client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from exc
    try:
        queue = _DaskQueue(client, store, address=address, variant=variant, keep=keep, bar=bar, say=say,
                           failures=failures, poll=poll, tally=_Tally() if tally is None else tally)
        return queue.run(todo, refs)
    finally:
        if own:
            client.close()


class _DaskQueue:
    """The jobs of one :func:`run_dask` call: pending, running (future -> (job, worker)), done."""

    def __init__(self, client, store, *, address, variant, keep, bar, say, failures, poll, tally):
        self.client, self.store, self.address = client, store, address
        self.variant, self.keep, self.bar, self.say, self.failures, self.poll = variant, keep, bar, say, failures, poll
        self.running = {}
        self.busy = set()
        self.tally = tally

    def workers(self) -> dict:
        """{worker address: its thread count}."""
        c = self.client
        info = c.scheduler_info(n_workers=-1) if _accepts_n_workers(c) else c.scheduler_info()
        return {addr: int(w.get("nthreads", 1) or 1) for addr, w in info.get("workers", {}).items()}

    def run(self, todo, refs) -> int:
        from distributed import wait

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
        return self.tally.done

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
        for addr in list(pool):
            if addr in self.busy or not pending:
                continue
            job = pending.popleft()
            ki, ks = self.keep(job)
            fut = self.client.submit(execute_job, job, scattered[(job.scene, job.width, job.height)],
                                     threads=pool[addr], variant=self.variant, keep_image=ki, keep_stats=ks,
                                     scene_file=scene_file(job.scene), external=external(job.renderer),
                                     workers=[addr], allow_other_workers=False, pure=False,
                                     key=f"rtbench-{job.scene}-{job.renderer}-{job.strategy}-{job.spp}-"
                                         f"{job.seed}-{job.width}x{job.height}-{time.monotonic_ns()}")
            self.running[fut] = (job, addr)
            self.busy.add(addr)
            self.bar.current(job.label)

    def _collect(self, fut) -> None:
        job, addr = self.running.pop(fut)
        self.busy.discard(addr)
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
                self.busy.discard(addr)
                pending.appendleft(job)
                self.say(f"dask: worker {addr} left; requeued {job.label}")


def _accepts_n_workers(client) -> bool:
    try:
        return "n_workers" in inspect.signature(client.scheduler_info).parameters
    except (TypeError, ValueError):
        return False
