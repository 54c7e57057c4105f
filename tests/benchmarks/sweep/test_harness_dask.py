"""``scheduler=``: jobs on a Dask LocalCluster (processes, 1 thread per worker), one job per worker."""
from __future__ import annotations

import pytest

from benchmarks.store import read_records, record_key
from benchmarks.sweep import Group, run_sweep
from harness_util import cache_root, comparable
from repo_paths import FIXTURES

distributed = pytest.importorskip("distributed")

TINY = Group(scenes=("cornell_box",), strategies=("light", "mis"), spps=(1, 4), seeds=2, width=8, height=8,
             reference_spp=256, name="tiny")


def test_dask_local_cluster_gives_the_local_records(tmp_path_factory):
    cache = cache_root(tmp_path_factory)
    local = tmp_path_factory.mktemp("dask-local")
    remote = tmp_path_factory.mktemp("dask-remote")
    run_sweep([TINY], out=local, progress=False, cache=cache, threads=1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster:
        result = run_sweep([TINY], out=remote, progress=False, cache=cache, scheduler=cluster.scheduler_address)
    assert not result.failed, result.failed
    assert result.done == result.jobs == 3 * 2 * 2
    got = read_records(remote)
    assert {r["threads"] for r in got} == {1}  # each job used its worker's one thread
    want = {record_key(r): comparable(r) for r in read_records(local)}
    have = {record_key(r): comparable(r) for r in got}
    assert want == have  # same renders, same metrics, whichever machine ran them
    for r in got:
        if r["image"]:
            assert (remote / r["image"]).exists()  # images come back to the client's store
    rows = {(r["renderer"], r["strategy"]) for r in result.rows}
    assert rows == {("ours", "light"), ("ours", "mis"), ("mitsuba", "path")}


def test_unreachable_scheduler_is_a_clear_error(tmp_path_factory, monkeypatch):
    import benchmarks.sweep.runners

    monkeypatch.setattr(benchmarks.sweep.runners, "DASK_CONNECT_TIMEOUT", "2s")
    with pytest.raises(ValueError, match="Dask scheduler"):
        run_sweep([TINY], out=tmp_path_factory.mktemp("dask-bad"), progress=False,
                  cache=cache_root(tmp_path_factory), scheduler="tcp://127.0.0.1:9")


def test_dask_workers_learn_scene_files_and_external_renderers_with_each_job(tmp_path_factory, fresh_registries):
    """A worker process never saw the client's ``--scene`` and ``--renderer`` registrations:
    each job carries its scene file and external renderer entries, so workers that join at
    any time render them (before, only the workers present at the start were told)."""
    import shutil
    import sys
    from pathlib import Path

    from benchmarks.external import register_external
    from mitsuba_scenes.scene_files import register_scene_file

    cli = shutil.which("mitsuba", path=str(Path(sys.executable).parent)) or shutil.which("mitsuba")
    entry = register_scene_file(FIXTURES / "xml" / "sphere_constant.xml")
    externals = ()
    if cli is not None:
        externals = (register_external(f"{cli} -m scalar_rgb -D spp={{spp}} -D seed={{seed}} -o {{out}} "
                                       f"{{scene_xml}}").name,)
    group = Group(scenes=(entry.name,), strategies=("mis",), spps=(4,), seeds=2, width=8, height=6,
                  mitsuba=False, reference_spp=256, name="files", externals=externals)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster:
        result = run_sweep([group], out=tmp_path_factory.mktemp("dask-files"), progress=False,
                           cache=cache_root(tmp_path_factory), scheduler=cluster.scheduler_address)
    assert not result.failed, result.failed
    assert result.done == result.jobs == 2 * (1 + len(externals))
    got = read_records(result.store)
    assert {r["scene"] for r in got} == {entry.name}
    assert {r["scene_source"] for r in got} == {entry.path}
