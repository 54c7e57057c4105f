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
    from distributed import Client, wait  # deferred: Dask's distributed takes about 1.5 s to import

    client = address if not isinstance(address, str) else None
    own = client is None
    if own:
        try:
            client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from exc
    pending = collections.deque(todo)
    running = {}  # future -> (job, worker)
    try:
        pool = _workers(client)
        t_wait = time.monotonic()
        while not pool:
            if time.monotonic() - t_wait > 60:
                raise ValueError(f"the Dask cluster at {address!r} has no workers")
            time.sleep(1.0)
            pool = _workers(client)
        say(f"dask: {len(pool)} worker(s) at {client.scheduler.address}, one job per worker")
        scattered = {k: client.scatter(ref, broadcast=True) for k, ref in refs.items()}
        while pending or running:
            busy = {addr for _, addr in running.values()}
            for addr in [a for a in pool if a not in busy][:len(pending)]:  # the next job, pinned to an idle worker
                job = pending.popleft()
                fut = client.submit(execute_job, job, scattered[(job.scene, job.width, job.height)],
                                    threads=pool[addr], variant=variant, **keep(job), scene_file=scene_file(job.scene),
                                    external=external(job.renderer), workers=[addr], allow_other_workers=False,
                                    pure=False, key=f"rtbench-{job.scene}-{job.renderer}-{job.strategy}-{job.spp}-"
                                                    f"{job.seed}-{job.width}x{job.height}-{time.monotonic_ns()}")
                running[fut] = (job, addr)
                bar.current(job.label)
            if not running:
                time.sleep(poll)
                pool = _workers(client)
                continue
            try:
                finished, _ = wait(list(running), timeout=poll, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished within `poll`: look at the workers again
                finished = []
            for fut in finished:
                _collect(fut, running.pop(fut)[0], store, bar=bar, say=say, failures=failures, tally=tally)
            pool = _workers(client)
            for fut, (job, addr) in list(running.items()):  # a worker left: requeue its job (else it waits forever)
                if addr not in pool:
                    fut.cancel()
                    running.pop(fut)
                    pending.appendleft(job)
                    say(f"dask: worker {addr} left; requeued {job.label}")
    finally:
        for fut in running:
            fut.cancel()
        if own:
            client.close()


def _workers(client) -> dict:
    """{worker address: its thread count}."""
    try:  # newer distributed lists only a few workers unless told
        accepts = "n_workers" in inspect.signature(client.scheduler_info).parameters
    except (TypeError, ValueError):
        accepts = False
    info = client.scheduler_info(**({"n_workers": -1} if accepts else {}))
    return {addr: int(w.get("nthreads", 1) or 1) for addr, w in info.get("workers", {}).items()}


def _collect(fut, job, store, *, bar, say, failures, tally) -> None:
    if fut.status == "finished":
        store_result(store, fut.result())
        tally.done += 1
    else:
        try:
            exc = fut.exception()
        except Exception as e:  # noqa: BLE001
            exc = e
        _failed(job, exc, failures=failures, say=say)
    bar.advance(job.cost)
