"""phys2d.sweep and `phys2d sweep`: grids, one deterministic row per run, Parquet, resume, pool and Dask.

Expected values come from a second method: the verdict of a run stepped here by
hand, Gauss-Seidel on the 1D column written out here, the weight a resting column
carries, and the product of the axes for the number of runs.
"""

from __future__ import annotations

import logging
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.csv as pcsv
import pyarrow.parquet as pq
import pytest

import phys2d
from phys2d.sweeps import Grid, Task, build, metrics_equal, run_task
from phys2d.sweeps.runner import check_scheduler
from tests.test_lessons import gauss_seidel_count

ROOT = Path(__file__).resolve().parents[1]


def cli(*args: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("PHYS2D_DEBUG", None)
    return subprocess.run(
        [sys.executable, "-m", "phys2d", "sweep", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def task(**kw) -> Task:
    base = dict(
        scene="circle_stack",
        size=2,
        mass_ratio=1.0,
        responder="pgs-cold",
        iterations=5,
        substeps=None,
        dt=1 / 60,
        steps=10,
        friction=None,
        seed=None,
        jitter=None,
    )
    return Task(**{**base, **kw})


def gauss_seidel_error(masses, sweeps, dt=1 / 60, g=10.0) -> float:
    """The largest relative error of a resting 1D column's impulses after ``sweeps`` Gauss-Seidel sweeps
    from lambda = 0, bottom contact first (A = J M^-1 J^T solved row by row, written out here)."""
    m = np.asarray(masses, float)
    n = m.size
    J = np.eye(n) - np.eye(n, k=-1)
    A = J @ np.diag(1 / m) @ J.T
    b = np.zeros(n)
    b[0] = g * dt
    lam = np.zeros(n)
    for _ in range(sweeps):
        for k in range(n):
            lam[k] = max(0.0, lam[k] + (b[k] - A[k] @ lam) / A[k, k])
    exact = g * dt * np.cumsum(m[::-1])[::-1]
    return float(np.max(np.abs(lam - exact) / exact))


# -- grids -------------------------------------------------------------------------------------------
def test_a_grid_expands_to_the_product_of_the_axes_that_apply():
    g = Grid(
        scenes=["vertical_stack", "mass_ratio"],
        responders=["naive", "pgs", "soft-step"],
        iterations=[5, 10, 20],
        substeps="1..2",
        size=[3, 4],
        mass_ratio=[2, 10],
        seed=[0, 1],
        friction=[0.2, 0.6],
    )
    tasks = g.tasks()
    # vertical_stack: 2 sizes; mass_ratio: 2 ratios; naive 1 + pgs 3 + soft-step 2 counts; 2 seeds x 2 frictions
    assert len(tasks) == (2 + 2) * (1 + 3 + 2) * 2 * 2
    assert len({t.run_id for t in tasks}) == len(tasks)
    naive = [t for t in tasks if t.responder == "naive"]
    assert all(t.iterations is None and t.substeps is None for t in naive)
    assert all(t.size is None for t in tasks if t.scene == "mass_ratio")
    assert all(t.mass_ratio is None for t in tasks if t.scene == "vertical_stack")
    assert {t.substeps for t in tasks if t.responder == "soft-step"} == {1, 2}
    assert Grid(scenes="pyramid", dt="1/60").dt == (1 / 60,)
    assert Grid(scenes="pyramid", size=[4, 4.0, 4]).size == (4,)  # duplicates go, 4.0 is the count 4
    assert task().run_id == task().run_id != task(iterations=6).run_id


@pytest.mark.parametrize(
    "spec, kind, words",
    [
        ({"scenes": "pyramd"}, ValueError, "did you mean 'pyramid'"),
        ({"scenes": "pyramid", "responders": "pgss"}, ValueError, "responders"),
        ({"scenes": "pyramid", "iteration": 5}, ValueError, "did you mean 'iterations'"),
        ({"scenes": "pyramid", "iterations": 1.5}, TypeError, "iterations"),
        ({"scenes": "pyramid", "iterations": 0}, ValueError, "iterations"),
        ({"scenes": "pyramid", "iterations": []}, ValueError, "at least one"),
        ({"scenes": "pyramid", "dt": -0.1}, ValueError, "dt"),
        ({"scenes": "pyramid", "dt": float("nan")}, ValueError, "dt"),
        ({"scenes": "pyramid", "friction": -1}, ValueError, "friction"),
        ({"scenes": "pyramid", "seed": -1}, ValueError, "seed"),
        ({"scenes": "pyramid", "steps": True}, TypeError, "steps"),
        ({"scenes": "pyramid", "iterations": "5..1"}, ValueError, "range"),
        ({"scenes": "pyramid", "substeps": 4}, ValueError, "substeps applies only"),
        ({"scenes": "pyramid", "mass_ratio": 4}, ValueError, "mass_ratio applies only"),
        ({"scenes": "mass_ratio", "size": 4}, ValueError, "size applies only"),
        ({"responders": "pgs"}, ValueError, "scenes must be given"),
    ],
)
def test_bad_grids_are_refused_by_name(spec, kind, words):
    with pytest.raises(kind, match=words):
        phys2d.sweeps.as_grids(spec)[0].tasks()


def test_a_toml_file_holds_several_grids_with_shared_defaults(tmp_path):
    f = tmp_path / "g.toml"
    f.write_text(
        'scenes = "circle_stack"\nsteps = 7\n[[grid]]\nsize = 2\nmass_ratio = [1, 10]\n'
        '[[grid]]\nsize = 4\nsteps = 3\nresponders = ["pgs", "soft-step"]\nsubsteps = "1..2"\n'
    )
    a, b = phys2d.sweeps.load_toml(f)
    assert a.steps == (7,) and a.mass_ratio == (1.0, 10.0) and b.steps == (3,) and b.substeps == (1, 2)
    assert len(phys2d.sweeps.expand([a, b])) == 2 + 1 + 2
    # a default a table does not use is fine there, as long as some table uses it
    f.write_text(
        'scenes = "circle_stack"\nsubsteps = [1, 2]\n[[grid]]\nresponders = "pgs"\n[[grid]]\nresponders = "soft-step"\n'
    )
    pgs, soft = phys2d.sweeps.load_toml(f)
    assert [t.substeps for t in pgs.tasks()] == [None] and [t.substeps for t in soft.tasks()] == [1, 2]
    f.write_text('scenes = "circle_stack"\nsubsteps = [1, 2]\n[[grid]]\nresponders = "pgs"\n')
    with pytest.raises(ValueError, match="substeps applies only to the soft-step responder, and no"):
        phys2d.sweeps.load_toml(f)
    f.write_text('scenes = "circle_stack"\n[[grid]]\nresponders = "pgs"\nsubsteps = 3\n')
    with pytest.raises(ValueError, match="table 1: substeps applies only"):
        phys2d.sweeps.load_toml(f)[0].tasks()
    f.write_text("scenes = [\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        phys2d.sweeps.load_toml(f)
    with pytest.raises(FileNotFoundError, match="missing.toml"):
        phys2d.sweeps.load_toml(tmp_path / "missing.toml")


def test_bad_combinations_fail_before_anything_runs(tmp_path):
    with pytest.raises(ValueError, match="pendulum_chain.*naive.*joints"):
        phys2d.sweep({"scenes": "pendulum_chain", "responders": "naive", "size": 2}, tmp_path / "t.parquet")
    with pytest.raises(TypeError, match="rows must be an integer"):
        phys2d.sweep({"scenes": "pyramid", "size": 2.5}, tmp_path / "t.parquet")
    assert not (tmp_path / "t.parquet").exists()


@pytest.mark.parametrize(
    "kwargs, kind, words",
    [
        ({"out": "t.csv"}, ValueError, "out must name a .parquet"),
        ({"workers": 0}, ValueError, "workers"),
        ({"scheduler": "localhost:8786"}, ValueError, "tcp://HOST:PORT"),
        ({"scheduler": "tcp://host:99999"}, ValueError, "port"),
        ({"scheduler": 8786}, TypeError, "scheduler"),
        ({"csv": 3}, TypeError, "csv"),
        ({"resume": "yes"}, TypeError, "resume"),
    ],
)
def test_bad_sweep_arguments_are_refused_by_name(tmp_path, kwargs, kind, words):
    kwargs = {"out": tmp_path / "t.parquet", **kwargs}
    with pytest.raises(kind, match=words):
        phys2d.sweep({"scenes": "vertical_stack", "size": 2, "steps": 2}, **kwargs)
    assert check_scheduler("tcp://10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert check_scheduler("tcp://[::1]:8786") == "tcp://[::1]:8786"


# -- one run -------------------------------------------------------------------------------------------
def test_a_row_is_the_verdict_of_the_same_run_stepped_by_hand():
    t = task(scene="vertical_stack", size=5, mass_ratio=None, responder="pgs", iterations=8, steps=40)
    row = run_task(t)
    w = phys2d.scenes.vertical_stack(5, phys2d.PGS(iterations=8))
    watch = phys2d.Watch(w)
    for _ in range(40):
        w.step(1 / 60)
        watch.observe()
    v = watch.verdict().as_row()
    assert row["outcome"] == v["outcome"] == "stood" and row["steps_run"] == v["steps"] == 40
    for k in ("max_displacement", "max_overlap", "final_residual", "final_kinetic_energy", "max_turn"):
        assert row[k] == v[k], k  # bit for bit: the same deterministic run
    assert math.isnan(row["load_error_first_tick"]) is False  # a column scene: its load error is measured
    assert row["ms_per_step"] > 0 and row["error"] == "" and row["recording"] is None
    assert list(row) == list(phys2d.sweeps.ROW_COLUMNS)
    assert metrics_equal(row, run_task(t))


@pytest.mark.parametrize(
    "masses, sweeps", [([1, 1], 1), ([1, 1], 4), ([1, 0.5], 2), ([1, 10], 7), ([1, 10], 31), ([1, 1, 1, 1], 9)]
)
def test_the_first_tick_load_error_is_that_of_gauss_seidel_on_the_column(masses, sweeps):
    row = run_task(task(size=len(masses), mass_ratio=float(masses[-1]), iterations=sweeps, steps=1))
    assert row["load_error_first_tick"] == pytest.approx(gauss_seidel_error(masses, sweeps), abs=1e-9)


def test_a_converged_first_tick_carries_exactly_the_weight_above_each_contact():
    # the exact impulse of a resting column is the weight it carries: a converged solve must give it
    row = run_task(task(size=4, mass_ratio=3.0, iterations=400, steps=1))
    assert row["load_error_first_tick"] < 1e-9
    row = run_task(task(scene="pyramid", size=3, mass_ratio=None, responder="pgs", steps=2))
    assert math.isnan(row["load_error_first_tick"])  # not one column: no load error claimed


def test_friction_and_the_seeded_start_are_applied_to_the_built_world():
    t = task(scene="vertical_stack", size=4, mass_ratio=None, responder="pgs", friction=0.25, seed=7, jitter=0.01)
    w, again, other = (
        build(t),
        build(t),
        build(
            task(scene="vertical_stack", size=4, mass_ratio=None, responder="pgs", friction=0.25, seed=8, jitter=0.01)
        ),
    )
    plain = phys2d.scenes.vertical_stack(4)
    assert all(b.friction == 0.25 for b in w.bodies)
    dx = w.x[1:, 0] - plain.x[1:, 0]
    assert np.all(np.abs(dx) <= 0.01) and np.ptp(dx) > 0 and np.array_equal(w.x[:, 1], plain.x[:, 1])
    assert np.array_equal(w.x, again.x) and not np.array_equal(w.x, other.x)
    assert np.array_equal(w.x[0], plain.x[0])  # the ground stays


def test_a_run_that_blows_up_is_a_row_with_its_error(monkeypatch):
    real = phys2d.World.step

    def step(self, dt):
        if self.tick == 3:
            raise phys2d.SimulationError("too fast")
        return real(self, dt)

    monkeypatch.setattr(phys2d.World, "step", step)
    row = run_task(task(steps=10))
    assert row["outcome"] == "error" and row["stood"] is False and row["steps_run"] == 3
    assert row["error"] == "step 4: too fast"


# -- sweeps -----------------------------------------------------------------------------------------------
SMALL = {
    "scenes": ["vertical_stack", "circle_stack"],
    "responders": ["pgs", "soft-step"],
    "iterations": [2, 6],
    "substeps": [1, 2],
    "size": [2, 3],
    "steps": 20,
}


def test_a_sweep_writes_one_table_and_resumes_where_it_stopped(tmp_path):
    out = tmp_path / "s" / "t.parquet"
    full = phys2d.sweep(SMALL, out, workers=1, csv=True)
    assert full.ran == 16 and full.skipped == 0 and full.failed == 0
    rows = pq.read_table(out).to_pylist()
    assert [r["run_id"] for r in rows] == [t.run_id for t in phys2d.sweeps.expand(phys2d.sweeps.as_grids(SMALL))]
    assert pcsv.read_csv(full.csv).num_rows == 16 and full.csv == str(tmp_path / "s" / "t.csv")
    again = phys2d.sweep(SMALL, out, workers=1)
    assert again.ran == 0 and again.skipped == 16
    assert all(metrics_equal(a, b) for a, b in zip(rows, pq.read_table(out).to_pylist()))
    # an interrupted sweep: only part of the table was written; the rest runs, the rest only
    pq.write_table(pq.read_table(out).slice(0, 5), out)
    seen = []
    resumed = phys2d.sweep(SMALL, out, workers=1, on_row=seen.append)
    assert resumed.ran == 11 and resumed.skipped == 5 and len(seen) == 11
    assert all(metrics_equal(a, b) for a, b in zip(rows, pq.read_table(out).to_pylist()))
    # rows of another grid stay; a fresh start replaces the table
    other = phys2d.sweep({"scenes": "mass_ratio", "steps": 5}, out, workers=1)
    assert other.table.num_rows == 17 and other.rows[0]["scene"] == "mass_ratio"  # this grid's rows first
    assert [r["run_id"] for r in other.rows[1:]] == [r["run_id"] for r in rows]
    assert phys2d.sweep({"scenes": "mass_ratio", "steps": 5}, out, workers=1, resume=False).table.num_rows == 1
    (tmp_path / "bad.parquet").write_text("not parquet")
    with pytest.raises(ValueError, match="not a readable Parquet"):
        phys2d.sweep(SMALL, tmp_path / "bad.parquet", workers=1)


def test_an_interrupted_pool_keeps_its_finished_rows_and_resumes(tmp_path):
    out = tmp_path / "t.parquet"
    seen = []

    def stop(row):
        seen.append(row["run_id"])
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        phys2d.sweep(SMALL, out, workers=2, on_row=stop)
    kept = [r["run_id"] for r in pq.read_table(out).to_pylist()]
    assert kept == [i for i in (t.run_id for t in phys2d.sweeps.expand(phys2d.sweeps.as_grids(SMALL))) if i in seen]
    again = phys2d.sweep(SMALL, out, workers=1)
    assert again.skipped == 3 and again.ran == 13 and again.table.num_rows == 16


def test_recordings_on_request(tmp_path):
    r = phys2d.sweep(
        {"scenes": "vertical_stack", "size": 2, "steps": 12, "responders": ["pgs", "naive"]},
        tmp_path / "t.parquet",
        workers=1,
        record=tmp_path / "rec",
    )
    for row in r.rows:
        assert row["recording"] == str(tmp_path / "rec" / f"{row['run_id']}.rrd")
        back = phys2d.playback.load(row["recording"])
        assert list(back.tick) == list(range(13))


def test_lesson_11_table_on_the_local_pool_and_a_local_dask_cluster(tmp_path):
    """`phys2d sweep lessons/11_catto.toml` (first tick only), on 2 local processes, on a LocalCluster and in
    this process: the same rows in the same order, the same metrics bit for bit."""
    from dask.distributed import LocalCluster

    args = [
        "lessons/11_catto.toml",
        "--steps",
        "1",
        "--responders",
        "pgs-cold,soft-step",
        "--iterations",
        "1..33",
        "--substeps",
        "1,2",
    ]
    t0 = time.perf_counter()
    local = cli(*args, "--workers", "2", "--out", str(tmp_path / "local.parquet"), cwd=ROOT)
    t_local = time.perf_counter() - t0
    assert local.returncode == 0, local.stderr
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR
    ) as cluster:
        t0 = time.perf_counter()
        dask = cli(*args, "--scheduler", cluster.scheduler_address, "--out", str(tmp_path / "dask.parquet"), cwd=ROOT)
        t_dask = time.perf_counter() - t0
    assert dask.returncode == 0, dask.stderr
    assert f"on Dask at {cluster.scheduler_address}" in dask.stdout and "on 2 local processes" in local.stdout
    a = pq.read_table(tmp_path / "local.parquet").to_pylist()
    b = pq.read_table(tmp_path / "dask.parquet").to_pylist()
    assert len(a) == len(b) > 200 and [r["run_id"] for r in a] == [r["run_id"] for r in b]
    assert all(metrics_equal(x, y) for x, y in zip(a, b))  # bit for bit, timings aside
    grids = [
        Grid(
            **{
                **{f: getattr(g, f) for f in phys2d.sweeps.AXES},
                "steps": 1,
                "responders": ("pgs-cold", "soft-step"),
                "iterations": tuple(range(1, 34)),
                "substeps": (1, 2),
            }
        )
        for g in phys2d.sweeps.load_toml(ROOT / "lessons" / "11_catto.toml")
    ]
    here = phys2d.sweep(grids, tmp_path / "here.parquet", workers=1)
    assert here.where == "this process" and [r["run_id"] for r in here.rows] == [r["run_id"] for r in a]
    assert all(metrics_equal(x, y) for x, y in zip(a, here.rows))
    # and the table is Catto's: sweeps to 95 % on the first tick, as Gauss-Seidel on the column says
    for masses in ([1, 1], [1, 0.5], [1, 10], [1, 1, 1, 1], [1, 2], [1, 5]):
        rows = [
            r for r in a if r["responder"] == "pgs-cold" and r["size"] == len(masses) and r["mass_ratio"] == masses[-1]
        ]
        ok = min(r["iterations"] for r in rows if r["load_error_first_tick"] <= 0.05)
        assert ok == gauss_seidel_count(masses)
    print(
        f"lesson 11 first-tick grid, {len(a)} runs: 2 local processes {t_local:.1f} s, "
        f"LocalCluster (2 workers) {t_dask:.1f} s (both through the command, cluster start-up excluded)"
    )


# -- the command line -----------------------------------------------------------------------------------
# four small runs: two scenes under two responders, on this process
SMALL_SWEEP = (
    "--scenes", "vertical_stack,mass_ratio", "--responders", "pgs,naive", "--size", "2", "--steps", "30",
    "--mass-ratio", "10", "--workers", "1",
)  # fmt: skip


def test_the_command_prints_a_summary_and_refuses_bad_input_in_one_line(tmp_path, capsys, monkeypatch):
    ok = cli(*SMALL_SWEEP, "--csv", cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
    assert "sweep: 4 runs, 4 run now on this process" in ok.stdout
    assert "table: sweeps/sweep.parquet (4 rows); csv: sweeps/sweep.csv" in ok.stdout
    assert pq.read_table(tmp_path / "sweeps" / "sweep.parquet").num_rows == 4
    bad = cli("--scenes", "pyramd", cwd=tmp_path)
    assert bad.returncode == 1 and bad.stderr == (
        "phys2d sweep: error: command line: scenes: unknown scene 'pyramd'; did you mean 'pyramid'? (choose from: "
        f"{', '.join(phys2d.sweeps.all_scenes())})\n"
    )
    # the rest in this process: the same main() the command runs
    from phys2d.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["sweep", *SMALL_SWEEP]) == 0
    out = capsys.readouterr().out
    assert "0 run now" in out and "4 already in the table" in out
    for args, code, words in (
        (["--scenes", "pyramid", "--iterations", "1..x"], 2, "--iterations"),
        (["--scenes", "pyramid", "--scheduler", "host:1"], 2, "tcp://HOST:PORT"),
        ([], 2, "give a grid file or --scenes"),
        (["nofile.toml"], 1, "grid file not found"),
        (["--scenes", "pyramid", "--substeps", "2"], 1, "substeps applies only"),
        (["--scenes", "pyramid", "--workers", "0"], 2, "--workers"),
    ):
        try:
            got = main(["sweep", *args])
        except SystemExit as e:
            got = e.code
        err = capsys.readouterr().err
        assert got == code, (args, err)
        assert err.count("\n") == 1 and words in err and err.startswith("phys2d sweep: error: "), err


@pytest.mark.parametrize("missing, args", [("tqdm", []), ("dask.distributed", ["--scheduler", "tcp://127.0.0.1:1"])])
def test_a_missing_extra_is_named_with_its_install_line(tmp_path, capsys, monkeypatch, missing, args):
    from phys2d.cli import main

    monkeypatch.setitem(sys.modules, missing, None)  # as if not installed: importing it raises ImportError
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "--scenes", "vertical_stack", "--size", "2", "--steps", "2", *args]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'phys2d[sweep]'" in err and missing.split(".")[0] in err
    assert not (tmp_path / "sweeps").exists()  # nothing written


def test_import_phys2d_loads_no_dask_pyarrow_or_matplotlib():
    code = (
        "import sys, phys2d; phys2d.World(); "
        "print(sorted(m for m in ('dask', 'distributed', 'pyarrow', 'matplotlib', 'jupytext', 'tqdm') "
        "if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=120,
    )
    assert out.stdout.strip() == "[]", out.stderr


def test_the_base_install_leaves_dask_jupyter_and_matplotlib_to_extras():
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    base = " ".join(meta["dependencies"]).lower()
    for heavy in ("dask", "jupyter", "matplotlib", "notebook", "nbclient"):
        assert heavy not in base
    extras = {k: " ".join(v).lower() for k, v in meta["optional-dependencies"].items()}
    assert "dask[distributed]" in extras["sweep"] and "pyarrow" in extras["sweep"] and "tqdm" in extras["sweep"]
    assert "rerun-notebook==0.41" in extras["notebook"] and "jupytext" in extras["notebook"]
    assert "matplotlib" in extras["plots"]
    # the test extra may take other extras by reference (phys2d[sweep,plots]): follow them
    test = extras["test"] + "".join(
        " " + extras[e] for ref in re.findall(r"phys2d\[([^\]]*)\]", extras["test"]) for e in ref.split(",")
    )
    for need in ("dask", "matplotlib", "nbclient", "ipykernel", "jupytext", "rerun-notebook"):
        assert need in test, need  # the test command installs what the tests import
