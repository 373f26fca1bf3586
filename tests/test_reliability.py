"""Issue 18, "Reliability at the seams": one regression test (or more) per item of the issue,
named ``test_item<k>_...`` after it.

Item 2: two processes on one study store; item 3: a read-only store or a failed write; item 4:
silent NaN; item 1 (and "memory is planned"): a run that would need more memory than allowed;
item 6: foreign exceptions; item 7: cosmetics.
"""

from __future__ import annotations

import errno
import json
import os
import platform
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import flexclear
import numpy as np
import pandas as pd
import pytest
from flexclear import study as study_mod
from flexclear.study import LogNormal, Study, Uniform, load, open_store
from flexclear.study import store as store_mod

PYTHON_DIR = str(Path(flexclear.__file__).resolve().parent.parent)


def small_study(**kw) -> Study:
    args = dict(
        vary={"clearance": Uniform(0.0, 1e-3), "bearing_stiffness": LogNormal(1.2e6, 0.3)},
        samples=12,
        seed=5,
        t_end=0.01,
        dt=1e-5,
    )
    args.update(kw)
    return Study("slider_yoke", **args)


def same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Identical results: every column but the wall-clock time, bit for bit."""
    pd.testing.assert_frame_equal(a.drop(columns="wall_time"), b.drop(columns="wall_time"), check_exact=True)


def env() -> dict:
    e = dict(os.environ)
    e["PYTHONPATH"] = PYTHON_DIR + os.pathsep + e.get("PYTHONPATH", "")
    return e


# -- item 2: two processes on one store -------------------------------------------------------------

HOLD_LOCK = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    from flexclear.study import load
    from flexclear.study.store import _Store
    store = _Store(Path(sys.argv[1]), load(sys.argv[2]))
    print("locked", flush=True)
    time.sleep(60)
    """
)


def test_item2_two_writers_second_is_refused_and_a_dead_writers_lock_is_taken_over(tmp_path):
    s = small_study()
    definition = tmp_path / "study.json"
    definition.write_text(json.dumps({"study": s.to_dict()}))
    out = tmp_path / "store"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD_LOCK, str(out), str(definition)],
        stdout=subprocess.PIPE,
        text=True,
        env=env(),
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        seen = []
        with pytest.raises(flexclear.StoreLockedError, match=f"process {holder.pid} on host") as exc:
            s.run(store=out, progress=lambda d, t: seen.append(d))
        assert seen == []  # refused before any sample ran
        assert exc.value.owner["pid"] == holder.pid
        assert isinstance(exc.value, flexclear.StoreError) and isinstance(exc.value, OSError)
        assert (out / study_mod.LOCK_FILE).exists()
    finally:
        holder.kill()  # SIGKILL: the lock file stays behind
        holder.wait()
        holder.stdout.close()
    assert json.loads((out / study_mod.LOCK_FILE).read_text())["pid"] == holder.pid
    res = s.run(store=out, progress=False)  # the stale lock (dead pid) is taken over
    assert len(res.frame) == 12 and res.frame.index.is_unique
    assert not (out / study_mod.LOCK_FILE).exists()  # released at the end
    # a process killed right after start (a pid that is gone) leaves a stale lock too
    (out / study_mod.LOCK_FILE).write_text(json.dumps({"pid": 2**22 + 12345, "host": store_mod._host()}))
    assert len(s.run(store=out, progress=False).frame) == 12


def test_item2_part_files_are_named_by_their_samples_and_reads_deduplicate(tmp_path):
    s = small_study()
    ref = s.run(store=tmp_path, progress=False, chunk_size=5)
    parts = sorted(tmp_path.glob("part-*.parquet"))
    assert [p.name[:24] for p in parts] == [
        "part-000000000-000000004",
        "part-000000005-000000009",
        "part-000000010-000000011",
    ]
    # the same samples written again go to the same name: no duplicate
    frame = pd.read_parquet(parts[0])
    writer = store_mod._Store(tmp_path, s)
    writer.write(frame)
    writer.close()
    assert len(list(tmp_path.glob("part-*.parquet"))) == 3
    # a duplicate under another name (an older writer, a copy) is read once
    (tmp_path / "part-copy.parquet").write_bytes(parts[1].read_bytes())
    back = open_store(tmp_path).frame
    assert back.index.is_unique and len(back) == 12
    same(back, ref.frame)
    # two different results for one sample: refused loudly, naming it
    bad = pd.read_parquet(parts[1])
    bad.loc[7, "bearing.max_force"] += 1.0
    bad.to_parquet(tmp_path / "part-copy.parquet")
    with pytest.raises(flexclear.StoreError, match="sample 7 has two different results: bearing.max_force"):
        open_store(tmp_path)
    with pytest.raises(flexclear.StoreError, match="part-copy.parquet"):
        s.run(store=tmp_path, progress=False)


WRITE_SLOWLY = textwrap.dedent(
    """
    import io, sys, time
    import pandas as pd
    from flexclear import study as study_mod
    from flexclear.study import store as store_mod
    store_mod.FLUSH_SECONDS = 0.0  # a part after every call of the engine (one sample, threads=1)
    to_parquet = pd.DataFrame.to_parquet

    def slowly(frame, path, *a, **k):  # every file half written for 20 ms
        buf = io.BytesIO()
        to_parquet(frame, buf, *a, **k)
        data = buf.getvalue()
        with open(path, "wb") as f:
            f.write(data[: len(data) // 2])
            f.flush()
            time.sleep(0.02)
            f.write(data[len(data) // 2 :])

    pd.DataFrame.to_parquet = slowly
    study_mod.load(sys.argv[1]).run(store=sys.argv[2], progress=False, threads=1)
    """
)


def test_item2_a_reader_while_a_writer_runs_sees_whole_parts_only(tmp_path):
    """open_store takes no lock (it is how a running study is watched): a reader polling a store
    while another process writes it part by part, each file half written for 20 ms, sees at
    every read a subset of the samples, each once and bitwise equal to an uninterrupted run
    (parts are written to a temporary name and renamed whole), never a damaged part or an
    error. (Written in place, the same test reads a half-written part: StoreError.)"""
    s = small_study(samples=24, t_end=0.2)
    reference = s.run(progress=False)
    definition = tmp_path / "study.json"
    definition.write_text(json.dumps({"study": s.to_dict()}))
    out = tmp_path / "store"
    writer = subprocess.Popen([sys.executable, "-c", WRITE_SLOWLY, str(definition), str(out)], env=env())
    sizes = []
    try:
        while writer.poll() is None:
            if not (out / "study.json").exists():
                continue
            frame = open_store(out).frame
            if len(frame):
                assert frame.index.is_unique
                same(frame, reference.frame.loc[frame.index])
            sizes.append(len(frame))
    finally:
        writer.kill()
        writer.wait()
    assert writer.returncode == 0
    assert any(0 < n < 24 for n in sizes), sizes  # it did read while the study was half done
    assert sizes == sorted(sizes)  # what was read once stays
    same(open_store(out).frame, reference.frame)


def test_item2_parts_reach_the_disk_before_their_name(tmp_path, monkeypatch):
    """A part (and study.json) is flushed to the disk under its temporary name before the rename
    that makes it visible, and the folder after it: a crash of the machine cannot leave a named
    but empty part, which every later read would refuse."""
    events = []
    real_fsync, real_replace = store_mod._fsync, os.replace

    def fsync(p):
        events.append(("fsync", Path(p).name))
        real_fsync(p)

    def replace(a, b):
        events.append(("rename", Path(a).name, Path(b).name))
        real_replace(a, b)

    monkeypatch.setattr(store_mod, "_fsync", fsync)
    monkeypatch.setattr(store_mod.os, "replace", replace)
    small_study(samples=2).run(store=tmp_path, progress=False, chunk_size=2)
    renames = [e for e in events if e[0] == "rename"]
    assert {e[2] for e in renames} >= {"study.json", "inputs.parquet"}
    assert any(e[2].startswith("part-") for e in renames)
    for e in renames:
        k = events.index(e)
        assert events[k - 1] == ("fsync", e[1]) and events[k + 1] == ("fsync", tmp_path.name), events[
            k - 1 : k + 2
        ]


def test_item2_temporary_files_of_a_live_writer_are_kept(tmp_path):
    s = small_study(samples=2)
    s.run(store=tmp_path, progress=False)
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = store_mod._host()
    try:
        mine = tmp_path / f"part-000000000-000000001-x.parquet.{live.pid}@{host}.tmp"
        gone = tmp_path / f"part-000000000-000000001-y.parquet.{dead.pid}@{host}.tmp"
        other_host = tmp_path / f"part-000000000-000000001-z.parquet.{dead.pid}@elsewhere.tmp"
        for f in (mine, gone, other_host):
            f.write_bytes(b"half a part")
        s.run(store=tmp_path, progress=False)
        assert mine.exists() and other_host.exists()
        assert not gone.exists()
    finally:
        live.kill()
        live.wait()


WRITER = textwrap.dedent(
    """
    import sys
    import flexclear
    from flexclear.study import load
    try:
        load(sys.argv[1]).run(store=sys.argv[2], threads=1, chunk_size=int(sys.argv[3]), progress=False)
    except flexclear.StoreLockedError as e:
        print(e, file=sys.stderr)
        sys.exit(2)
    """
)

CONCURRENT_STUDY = textwrap.dedent(
    """
    build = "slider_yoke"
    samples = 240
    seed = 18
    outputs = ["max_penetration", "max_force", "impacts", "rms_force"]

    [run]
    t_end = 2.0
    dt = 1e-5

    [vary.clearance]
    distribution = "uniform"
    low = 0.0
    high = 1e-3
    """
)


def test_item2_two_writers_killed_at_random_and_restarted_end_with_one_row_per_sample(tmp_path):
    """Two processes (chunk sizes 2 and 3) on one store, one of them SIGKILLed every 0.2-1.0 s
    and both restarted, 20 kills; then run to the end. The store has each sample exactly once,
    bitwise equal to an uninterrupted run, and no temporary file is left."""
    definition = tmp_path / "study.toml"
    definition.write_text(CONCURRENT_STUDY)
    writer = tmp_path / "writer.py"
    writer.write_text(WRITER)
    out = tmp_path / "store"

    def start(k: int) -> subprocess.Popen:
        cmd = [sys.executable, str(writer), str(definition), str(out), str(2 + k)]
        return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env())

    rng = random.Random(18)
    t0 = time.monotonic()
    procs = [start(0), start(1)]
    kills, refused, finished = 0, 0, 0
    progress = []
    try:
        while kills < 20:
            assert time.monotonic() - t0 < 110, f"too slow: {kills} kills"
            time.sleep(rng.uniform(0.2, 1.0))
            for k, p in enumerate(procs):
                if p.poll() is not None:  # refused (the other holds the lock) or done
                    err = p.stderr.read()
                    p.stderr.close()
                    assert p.returncode in (0, 2), err
                    if p.returncode == 2:
                        assert "another writer holds it" in err
                        refused += 1
                    else:
                        finished += 1
                    procs[k] = start(k)
            # kill only once the store has grown since the last kill (at most 10 s): on a loaded
            # machine a writer may need longer than the sleep to import and run a chunk, and a
            # kill before any progress tests nothing
            last = progress[-1] if progress else 0
            wait_until = time.monotonic() + 10.0
            while time.monotonic() < wait_until:
                if (out / "study.json").exists() and len(open_store(out).frame) > last:
                    break
                time.sleep(0.05)
            victim = rng.randrange(2)
            if (out / "study.json").exists():
                progress.append(len(open_store(out).frame))
            procs[victim].kill()
            procs[victim].wait()
            procs[victim].stderr.close()
            kills += 1
            procs[victim] = start(victim)
    finally:
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGKILL)
            p.wait()
            p.stderr.close()
    killed_at = len(open_store(out).frame)
    for k in (0, 1):  # both run to the end, one after the other
        p = start(k)
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    final = open_store(out).frame
    reference = load(definition).run(threads=2, progress=False)
    assert final.index.is_unique
    assert list(final.index) == list(range(240))
    same(final, reference.frame)
    assert not list(out.glob("*.tmp"))
    assert not (out / study_mod.LOCK_FILE).exists()
    # the kills landed mid-study: the store grew between kills, and most kills found it unfinished
    mid = sum(0 < n < 240 for n in progress)
    assert mid >= 15 and progress[-1] > progress[0], progress
    # `refused` counts the restarts that found the lock held: usually several, but none when load
    # staggers the writers' starts; the refusal itself is tested deterministically above
    # (test_item2_two_writers_second_is_refused_and_a_dead_writers_lock_is_taken_over), so here
    # it is reported, not asserted.
    took = time.monotonic() - t0
    print(f"20 kills in {took:.1f} s, {mid} mid-study; refused {refused}; {killed_at}/240 then")


# -- item 3: a read-only store, a failed write ------------------------------------------------------


def test_item3_readonly_store_fails_before_any_sample_runs(tmp_path, monkeypatch):
    s = small_study()
    s.run(store=tmp_path, progress=False, chunk_size=4)
    for p in tmp_path.glob("part-*.parquet"):
        if "000000004" in p.name:
            p.unlink()  # four samples left to do
    seen = []
    if os.geteuid() == 0:  # root writes anywhere: refuse the writes as a read-only mount would
        real_open = os.open

        def readonly(path, flags, *a, **k):
            if str(path).startswith(str(tmp_path)) and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
                raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
            return real_open(path, flags, *a, **k)

        monkeypatch.setattr(os, "open", readonly)
    else:
        os.chmod(tmp_path, 0o555)
    try:
        t0 = time.perf_counter()
        with pytest.raises(flexclear.StoreError, match="not writable") as exc:
            s.run(store=tmp_path, progress=lambda d, t: seen.append(d))
        assert time.perf_counter() - t0 < 5.0
    finally:
        monkeypatch.undo()
        os.chmod(tmp_path, 0o755)
    assert seen == []
    assert exc.value.path == str(tmp_path)
    # the store is untouched and reads back
    assert len(open_store(tmp_path).frame) == 8


def test_item3_a_failed_write_keeps_the_computed_rows_in_the_exception(tmp_path, monkeypatch):
    s = small_study()
    reference = s.run(progress=False)
    real = pd.DataFrame.to_parquet
    calls = []

    def disk_full_after_one_part(self, path, *a, **k):
        if Path(path).name.startswith("part-"):
            calls.append(path)
            if len(calls) >= 2:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(self, path, *a, **k)

    monkeypatch.setattr(pd.DataFrame, "to_parquet", disk_full_after_one_part)
    with pytest.raises(flexclear.StoreError, match="No space left on device") as exc:
        s.run(store=tmp_path, progress=False, chunk_size=4)
    monkeypatch.undo()
    assert isinstance(exc.value.__cause__, OSError)
    partial = exc.value.partial.frame
    assert len(partial) == 8  # the written part and the one whose write failed
    same(partial, reference.frame.loc[partial.index])
    assert len(open_store(tmp_path).frame) == 4
    assert not list(tmp_path.glob("*.tmp"))
    assert not (tmp_path / study_mod.LOCK_FILE).exists()
    same(s.run(store=tmp_path, progress=False).frame, reference.frame)


def test_item3_parts_are_written_as_samples_finish_within_a_chunk(tmp_path, monkeypatch):
    """With one chunk of every sample, finished samples still reach the store every
    FLUSH_SECONDS (here 0: after every call of the engine), not only at the chunk's end."""
    monkeypatch.setattr(store_mod, "FLUSH_SECONDS", 0.0)
    s = small_study()
    stored_while_running = []

    def progress(done, total):
        stored_while_running.append((done, len(list(tmp_path.glob("part-*.parquet")))))

    res = s.run(store=tmp_path, progress=progress, chunk_size=12, threads=1)
    assert max(n for d, n in stored_while_running if d < 12) >= 5
    assert len(list(tmp_path.glob("part-*.parquet"))) == 12
    same(res.frame, s.run(progress=False).frame)
    same(open_store(tmp_path).frame, res.frame)


def test_item3_on_dask_parts_are_written_as_samples_finish_within_a_chunk(tmp_path, monkeypatch):
    """On Dask too, one chunk of every sample does not wait for its end: tasks are cut to last
    about FLUSH_SECONDS (here 0: one sample per task) and finished samples reach the store as
    their tasks end; results bitwise those of the local run."""
    distributed = pytest.importorskip("distributed")
    monkeypatch.setattr(store_mod, "FLUSH_SECONDS", 0.0)
    s = small_study()
    stored_while_running = []

    def progress(done, total):
        stored_while_running.append((done, len(list(tmp_path.glob("part-*.parquet")))))

    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        res = s.run(store=tmp_path, client=client, chunk_size=12, progress=progress)
    assert max(n for d, n in stored_while_running if d < 12) >= 5
    assert len(list(tmp_path.glob("part-*.parquet"))) == 12
    same(res.frame, s.run(progress=False).frame)
    same(open_store(tmp_path).frame, res.frame)


# -- item 4: no silent NaN ----------------------------------------------------------------------


@pytest.mark.parametrize("start", [0.01, 0.02, 1.0])
def test_item4_record_start_at_or_after_t_end_is_refused(start):
    model = flexclear.scenes.slider_yoke()
    with pytest.raises(flexclear.InvalidParameterError, match=r"record.start.*t_end = 0.01 s") as exc:
        model.simulate(0.01, 1e-5, record=flexclear.Record(start=start), progress=False)
    assert exc.value.parameter == "record.start"
    crank = flexclear.scenes.slider_crank(clearance_at="crank_pin")
    with pytest.raises(flexclear.InvalidParameterError, match="record.start"):
        crank.simulate(0.01, 1e-5, record={"start": start}, progress=False)


def test_item4_a_window_without_a_step_is_refused_and_a_valid_one_is_finite():
    model = flexclear.scenes.slider_yoke()
    # t_end = 1.04e-5 rounds to one step of 1e-5: nothing at or after 1.02e-5
    with pytest.raises(flexclear.InvalidParameterError, match="last step is at 1e-05 s"):
        model.simulate(1.04e-5, 1e-5, record=flexclear.Record(start=1.02e-5), progress=False)
    rec = flexclear.Record(start=0.00199, contact_modes=True)  # every output of a study
    j = model.simulate(0.002, 1e-5, record=rec, progress=False).joint("bearing")
    for o in study_mod.OUTPUTS:
        if o == "contact_period":
            # no impact ends in the 10 us window (the bearing stays closed): undefined, NaN
            assert j.impacts == 0 and np.isnan(j.contact_period)
            continue
        assert np.isfinite(getattr(j, o)), o


def test_item4_study_start_at_or_after_t_end_is_refused():
    with pytest.raises(flexclear.InvalidParameterError, match=r"`start` = 0.5.*t_end = 0.5 s"):
        small_study(start=0.5, t_end=0.5)
    # with a varied t_end the samples whose window is empty are invalid rows, not NaN outputs
    s = small_study(vary={"t_end": [0.002, 0.004]}, design="grid", start=0.003)
    f = s.run(progress=False).frame
    assert list(f["status"]) == ["invalid", "ok"]
    assert "start" in f["message"].iloc[0]
    assert np.isfinite(f.iloc[1][s.output_columns].to_numpy(dtype=float)).all()


def test_item4_exceedance_over_no_completed_sample_is_refused():
    s = small_study(vary={"clearance": [-1e-5]}, design="grid")
    res = s.run(progress=False)
    assert list(res.frame["status"]) == ["invalid"]
    with pytest.raises(flexclear.InvalidParameterError, match="no completed sample"):
        res.exceedance("max_force", 1.0)


# -- item 1 / "memory is planned" ----------------------------------------------------------------


def _history_bytes(res: flexclear.Result) -> int:
    raw = res._raw
    n = res.time.nbytes
    n += sum(getattr(h, k).nbytes for h in raw.joints for k in ("penetration", "force", "qx", "qy"))
    n += sum(getattr(h, k).nbytes for h in raw.nodes for k in ("u", "v", "theta"))
    channels = ("frame", "displacements", "axial_force", "midspan", "kinetic", "strain", "momentum")
    n += sum(getattr(lk, k).nbytes for lk in raw.links for k in channels)
    n += sum(getattr(h, k).nbytes for h in raw.sliders for k in ("position", "velocity", "acceleration"))
    return n


def test_item1_a_run_too_long_for_memory_is_refused_before_anything_is_reserved():
    import resource

    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    with pytest.raises(flexclear.ResourceError) as exc:
        flexclear.scenes.slider_yoke().simulate(1e4, 1e-6)
    assert time.perf_counter() - t0 < 1.0
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 100_000  # kB: nothing reserved
    e = exc.value
    assert isinstance(e, flexclear.FlexclearError) and isinstance(e, MemoryError)
    assert e.estimate == 8 * 3 * (10**10 + 2) > e.limit  # time, penetration, force every step
    msg = str(e)
    for way in ("224 GiB", "Record(every=", "Record(histories=False)", "Record(start=", "shorter t_end"):
        assert way in msg, way
    # the way out it names works: every=k fits the limit
    k = int(msg.split("Record(every=")[1].split(")")[0])
    assert flexclear.scenes.slider_yoke().memory_estimate(1e4, 1e-6, {"every": k}) <= e.limit


def test_item1_moving_frame_histories_are_planned_too(monkeypatch):
    crank = flexclear.scenes.slider_crank(elements=200)
    est = crank.memory_estimate(0.5, 1e-6)
    assert est > 2e9  # every node of 200 elements, every step: 603 values per step
    monkeypatch.setenv("FLEXCLEAR_MEMORY_LIMIT", "1G")
    with pytest.raises(flexclear.ResourceError, match=r"FLEXCLEAR_MEMORY_LIMIT=1G.*displacements=False"):
        crank.simulate(0.5, 1e-6)
    monkeypatch.setenv("FLEXCLEAR_MEMORY_LIMIT", "lots")
    with pytest.raises(flexclear.InvalidParameterError, match="FLEXCLEAR_MEMORY_LIMIT"):
        crank.simulate(0.5, 1e-6)
    monkeypatch.delenv("FLEXCLEAR_MEMORY_LIMIT")
    with pytest.raises(flexclear.InvalidParameterError, match="memory_limit"):
        crank.simulate(0.5, 1e-6, memory_limit=-1.0)


@pytest.mark.parametrize(
    ("scene", "record"),
    [
        ("slider_yoke", {}),
        ("slider_yoke", {"nodes": [("slider", 3)], "position": True, "every": 7, "start": 0.004}),
        ("slider_yoke", {"displacements": True, "midspan": True, "axial_force": True}),
        ("slider_crank", {}),
        ("slider_crank", {"axial_force": True, "midspan": True, "energy": True, "every": 3}),
        ("slider_crank", {"histories": False, "displacements": False, "sliders": True}),
        ("slider_crank", {"histories": False}),
    ],
)
def test_item1_the_estimate_is_what_the_run_keeps_and_the_limit_is_exact(scene, record):
    model = getattr(flexclear.scenes, scene)(elements=4)
    est = model.memory_estimate(0.01, 1e-5, record)
    res = model.simulate(0.01, 1e-5, record=record, progress=False, memory_limit=max(est, 1))
    kept = _history_bytes(res)
    assert kept <= est <= kept + 8 * 2 * (est // (8 * max(res.time.size, 1)))  # within two records
    if est == 0:  # histories=False in moving frames: nothing per output point, no limit to hit
        return
    with pytest.raises(flexclear.ResourceError):
        model.simulate(0.01, 1e-5, record=record, progress=False, memory_limit=est - 1)


def test_item1_a_study_with_histories_is_planned_before_it_runs(tmp_path):
    s = small_study(samples=1000, t_end=10.0, dt=1e-6, history_every=1)
    assert s.memory_estimate() == 1000 * (10**7 + 2) * 2 * 8
    with pytest.raises(flexclear.ResourceError, match="history_every"):
        s.run(store=tmp_path / "store", progress=False)
    assert not (tmp_path / "store").exists()
    with pytest.raises(flexclear.InvalidParameterError, match=r"run_options: unknown \['tolerance'\]"):
        small_study(run_options={"tolerance": 1e-9})


# -- item 5: meshes the API allows run on the Newton stepper ---------------------------------------


def _rod_midspan(elements: int) -> float:
    """Midspan deflection (m) of Simeon's slider-crank rod after 2 ms (dt 1e-5 s), from rest."""
    run = flexclear.scenes.slider_crank(elements=elements).simulate(
        0.002, 1e-5, record=flexclear.Record(midspan=True, every=50)
    )
    assert run.stats["stepper"] == "newton"
    return float(run.link("rod").midspan[-1])


def test_item5_a_5000_element_rod_runs_and_agrees_with_coarser_meshes():
    # The band LU's pivot test was relative to the largest diagonal of the whole matrix: the
    # slider's mass (0.076 kg) against the rotary inertia of a 60 um element (4e-15 kg m^2) made
    # the mass matrix "singular" at 5000 elements. Now a pivot is singular only when it is
    # rounding noise of the terms that formed it (a test invariant under scaling the unknowns).
    w1, w3, w5 = (_rod_midspan(n) for n in (1000, 3000, 5000))
    # discretization: converged to 1e-4 by 1000 elements (1000 vs 3000: 7.9e-5 measured)
    assert w3 == pytest.approx(w1, rel=2e-4)
    # at 5000 elements (element 60 um long) round-off in the unpivoted band LU of a matrix whose
    # conditioning grows with the element count adds about 1e-3 (1.03e-3 measured)
    assert w5 == pytest.approx(w3, rel=3e-3)


def test_item5_a_tolerance_below_round_off_does_not_fail_the_run():
    # 200 elements with the geometric terms: Newton's relative correction stalls at 1e-13..2e-12,
    # its round-off floor; a tolerance of 1e-14 used to end the run with ConvergenceError.
    model = flexclear.scenes.slider_crank(elements=200, geometric=True)
    rec = flexclear.Record(midspan=True)
    loose = model.simulate(0.002, 1e-5, iter_tol=1e-8, record=rec)
    fine = model.simulate(0.002, 1e-5, iter_tol=1e-14, max_iter=50, record=rec)
    assert loose.stats["roundoff_steps"] == 0 and fine.stats["roundoff_steps"] > 0
    a, b = loose.link("rod").midspan, fine.link("rod").midspan
    # the loose run is within its own tolerance (1e-8 of the displacement scale per step) of the
    # fine one, summed over its 200 steps with a margin: what each step's iterations leave (up to
    # the tolerance) carries into the next (measured 9.1e-8 with a Jacobian factor kept for up to 8
    # steps, 1.1e-7 with 20)
    assert np.max(np.abs(a - b)) <= 2e-7 * np.max(np.abs(b))


def test_item5_a_singular_pivot_names_the_unknown():
    # a massless slider held by a clearance joint only: no mass and, with the contact open, no
    # stiffness on its coordinate
    massless = flexclear.scenes.slider_crank(clearance_at="slider_pin", slider_mass=0.0)
    with pytest.raises(flexclear.SingularMatrixError, match='at slider "slider"') as exc:
        massless.simulate(0.001, 1e-5)
    assert exc.value.dof == 'slider "slider"' and "mass matrix" in exc.value.matrix


def test_item5_runaway_iterates_are_a_convergence_error_that_step_halving_mends():
    # 600 rad/s at dt 1e-4 s (0.06 rad a step) with the geometric terms: the iterates run away.
    # That used to surface as a "singular" matrix (non-finite entries) or as a NaN state accepted
    # as converged (f64::max skips NaN); now it is non-convergence, which halving can mend.
    model = flexclear.scenes.slider_crank(elements=200, crank_speed=600.0)
    with pytest.raises(flexclear.ConvergenceError, match="relative correction inf"):
        model.simulate(0.01, 1e-4)
    run = model.simulate(0.01, 1e-4, step_halving=3)
    assert run.complete and run.stats["halved_substeps"] > 0
    assert np.isfinite(run.link("rod").midspan).all()


# -- item 6: a flexclear error for every mistake -------------------------------------------------


def test_item6_static_state_and_frequencies_of_a_free_link_are_finite_or_a_flexclear_error():
    crank = flexclear.scenes.slider_crank(clearance_at="slider_pin")
    assert np.isfinite(crank.static_state(0.0)).all()
    assert np.isfinite(crank.natural_frequencies(3)).all()
    massless = flexclear.scenes.slider_crank(clearance_at="slider_pin", slider_mass=0.0)
    with pytest.raises(flexclear.SingularMatrixError, match="mass matrix.*singular") as exc:
        massless.natural_frequencies(3)
    assert exc.value.matrix == "mass"


@pytest.mark.parametrize("node", [-1, -(2**70), 2.5, 13, "3", None])
def test_item6_a_bad_node_index_is_an_invalid_parameter_naming_it(node):
    yoke = flexclear.scenes.slider_yoke()
    allowed = 'allowed a node of link "slider": an integer 0 ..= 12'
    with pytest.raises(flexclear.InvalidParameterError, match=allowed) as exc:
        yoke.add_joint("stop", "slider", node, body="yoke", clearance=1e-4, stiffness=1e6, damping=0.0)
    assert exc.value.parameter == "node"
    with pytest.raises(flexclear.InvalidParameterError, match="record.nodes"):
        yoke.simulate(0.001, 1e-5, record={"nodes": [("slider", node)]}, progress=False)
    crank = flexclear.scenes.slider_crank()
    for add in (
        lambda: crank.add_mass("rod", node, 1.0),
        lambda: crank.add_load("rod", node, fv=1.0),
        lambda: crank.add_support("rod", node),
        lambda: crank.add_pin("p", "rod", node, body="crank"),
    ):
        with pytest.raises(flexclear.InvalidParameterError, match='link "rod": an integer 0 ..= 8'):
            add()
    # an integral float is the integer
    assert yoke.simulate(0.001, 1e-5, record={"nodes": [("slider", 3.0)]}, progress=False).node("slider", 3)


def test_item6_float_elements_in_a_study_and_a_scene():
    s = Study("slider_yoke", fixed={"elements": 8.0}, samples=2, t_end=0.002)
    assert s.fixed == {"elements": 8}
    assert (s.run(progress=False).frame["status"] == "ok").all()
    with pytest.raises(flexclear.InvalidParameterError, match=r"fixed.elements = 8.5"):
        Study("slider_yoke", fixed={"elements": 8.5})
    with pytest.raises(flexclear.InvalidParameterError, match="`elements` = 8.0"):
        flexclear.scenes.slider_yoke(elements=8.0)
    with pytest.raises(flexclear.InvalidParameterError, match="`elements` = 2.5"):
        flexclear.Model().add_link(
            "l", length=1.0, elements=2.5, youngs_modulus=1e9, density=1e3, area=1e-4, inertia=1e-8
        )


def test_item6_a_bad_run_options_key_is_refused_at_study():
    with pytest.raises(flexclear.InvalidParameterError, match=r"run_options: unknown \['itrate'\]"):
        small_study(run_options={"itrate": True})
    # every simulate keyword is accepted, and the batch engine's `tol` too
    s = small_study(samples=2, t_end=0.002, run_options={"iter_tol": 1e-9, "max_iter": 40, "step_halving": 0})
    assert (s.run(progress=False).frame["status"] == "ok").all()
    assert (
        small_study(samples=2, t_end=0.002, run_options={"tol": 1e-9}).run(progress=False).frame["status"]
        == "ok"
    ).all()
    # step halving asked of a translating sample: an invalid row saying why, not a TypeError
    f = small_study(samples=2, t_end=0.002, run_options={"step_halving": 2}).run(progress=False).frame
    assert (f["status"] == "invalid").all() and f["message"].str.contains("step_halving").all()


# -- item 7: cosmetics -----------------------------------------------------------------------------


def test_item7_numbers_in_error_messages_are_short():
    with pytest.raises(flexclear.InvalidParameterError) as exc:
        flexclear.scenes.slider_yoke(clearance=-1e-300)
    assert "= -1e-300: allowed" in str(exc.value) and len(str(exc.value)) < 100
    with pytest.raises(flexclear.ResourceError) as exc:
        flexclear.scenes.slider_yoke().simulate(0.01, 1e-300)
    assert len(str(exc.value)) < 800 and "1e+298 records" in str(exc.value)


def _cpu_flags() -> set:
    """The first processor's flags in /proc/cpuinfo (Linux), read independently of the core."""
    with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith("flags"):
                return set(line.partition(":")[2].split())
    return set()


@pytest.mark.skipif(
    not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")),
    reason="/proc/cpuinfo's x86 flags",
)
def test_the_simd_paths_are_those_the_cpu_flags_allow():
    # the core detects the CPU's features itself (std::arch); /proc/cpuinfo is the kernel's view
    flags = _cpu_flags()
    if {"avx512f", "avx2", "fma"} <= flags:
        expected = "avx512"
    elif {"avx2", "fma"} <= flags:
        expected = "avx2"
    else:
        expected = "baseline"
    assert flexclear._core.SIMD_PATHS == expected


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "flexclear.cli", *args], capture_output=True, text=True, timeout=120, env=env()
    )


def test_item7_cli_errors_are_usage_errors_and_version_is_known(tmp_path):
    r = run_cli("--version")
    expected = f"flexclear {flexclear.__version__} (SIMD paths on this CPU: {flexclear._core.SIMD_PATHS})"
    assert r.returncode == 0 and r.stdout.strip() == expected
    for args, what in [
        (("frequencies", "--elements", "0"), "`elements` = 0"),
        (("frequencies", "--count", "-3"), "`count` = -3"),
        (("montecarlo", str(tmp_path / "missing.toml")), "does not exist"),
        (("spin-up", "--dt", "-1", "--out", str(tmp_path)), "`dt` = -1"),
    ]:
        r = run_cli(*args)
        assert r.returncode == 2, r.stderr
        assert r.stderr.startswith(f"usage: flexclear {args[0]}")
        assert f"flexclear {args[0]}: error: " in r.stderr and what in r.stderr
        assert "Traceback" not in r.stderr


def test_item7_conditionally_stable_newmark_parameters_warn_with_the_step_limit():
    yoke = flexclear.scenes.slider_yoke()
    with pytest.warns(flexclear.NewmarkStabilityWarning, match=r"dt_crit = 1.21e-06 s.*will diverge"):
        with pytest.raises(flexclear.SimulationDivergedError):
            yoke.simulate(0.002, 1e-5, beta=0.1, gamma=0.5, progress=False)
    with pytest.warns(flexclear.NewmarkStabilityWarning, match="below it"):
        res = yoke.simulate(2e-5, 1e-6, beta=0.1, gamma=0.5, progress=False)
    assert res.complete
    # unconditionally stable choices do not warn (warnings are errors in this suite)
    yoke.simulate(2e-4, 1e-5, beta=0.3025, gamma=0.6, progress=False)


def test_item7_a_history_that_was_not_recorded_says_so():
    res = flexclear.scenes.slider_yoke().simulate(0.002, 1e-5, record={"histories": False}, progress=False)
    j = res.joint("bearing")
    assert np.isfinite(j.max_penetration)
    with pytest.raises(flexclear.RecordingError, match=r"Record\(histories=False\)"):
        _ = j.penetration
    assert not hasattr(j, "force")  # an AttributeError
    kept = flexclear.scenes.slider_yoke().simulate(0.002, 1e-5, progress=False).joint("bearing")
    assert kept.penetration.size == 201
    with pytest.raises(flexclear.RecordingError, match=r"Record\(position=True\)"):
        _ = kept.qx
    assert "not recorded" in repr(j)


def test_item7_a_refused_resume_names_the_changed_field(tmp_path):
    small_study(samples=2).run(store=tmp_path, progress=False)
    with pytest.raises(
        flexclear.InvalidParameterError, match=r"different study.*changed: samples \(stored 2, now 3\)"
    ):
        small_study(samples=3).run(store=tmp_path, progress=False)
    with pytest.raises(flexclear.InvalidParameterError, match=r"changed: dt \(stored 1e-05, now 2e-05\)"):
        small_study(samples=2, dt=2e-5).run(store=tmp_path, progress=False)
