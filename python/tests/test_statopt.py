"""The statopt Python package against the CLI (bit for bit), its errors,
tables, overrides and sweeps."""

import subprocess
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import statopt

# Columns that are timings, not results.
TIMING = {"solve_time_ms"}


def bits(df: pd.DataFrame) -> np.ndarray:
    """The values as raw bits: equality is bit for bit (NaN and -0 too)."""
    return np.ascontiguousarray(df.to_numpy(dtype=np.float64)).view(np.int64)


def assert_same(a: pd.DataFrame, b: pd.DataFrame):
    a = a.drop(columns=[c for c in a.columns if c in TIMING])
    b = b.drop(columns=[c for c in b.columns if c in TIMING])
    assert list(a.columns) == list(b.columns)
    assert np.array_equal(a.index.to_numpy().view(np.int64), b.index.to_numpy().view(np.int64))
    assert np.array_equal(bits(a), bits(b))


def parse_sto(path: Path) -> pd.DataFrame:
    """An independent reader (Python's correctly rounded float())."""
    lines = path.read_text().splitlines()
    k = lines.index("endheader")
    labels = lines[k + 1].split("\t")
    rows = [[float(x) for x in line.split()] for line in lines[k + 2:] if line.strip()]
    a = np.array(rows, dtype=np.float64).reshape(len(rows), len(labels))
    return pd.DataFrame(a[:, 1:], index=pd.Index(a[:, 0], name="time"), columns=labels[1:])


# -- run() against the CLI ---------------------------------------------------

def test_run_tables_equal_cli_bit_for_bit(cam1_py, cam1_cli):
    cli_tables = {p.stem: p for p in cam1_cli.iterdir() if p.suffix in (".sto", ".mot")}
    assert set(cam1_py.tables) == set(cli_tables)
    for key, df in cam1_py.tables.items():
        assert_same(df, statopt.read_table(cli_tables[key]))
    # ... and with a reader that is not the crate's
    for key in ["leg_extension_cam1_SO_w0_500_activation", "leg_extension_cam1_JR_w0_mean_ReactionLoads",
                "leg_extension_cam1_SO_w0_1_ContactForces"]:
        assert_same(cam1_py.tables[key], parse_sto(cli_tables[key]))
    assert cam1_py.frames == 101 and cam1_py.failed == 0 and cam1_py.ok
    assert cam1_py.files == []  # nothing written without results_dir
    assert cam1_py.metrics["quadriceps_work_J"] == pytest.approx(115.767148)  # the roller pad (issue 15)


def test_named_tables(cam1_py):
    a = cam1_py.activations
    assert a.index.names == ["w0", "time"]
    assert sorted(set(a.index.get_level_values("w0"))) == [1.0, 500.0, 1000.0]
    assert_same(a.xs(500.0, level="w0"), cam1_py.table("activation", w0=500))
    assert "knee_r_on_tibia_r_in_tibia_r_fx" in cam1_py.reactions.columns
    assert cam1_py.table("ReactionLoads", stat="mean").shape == (101, 18)
    for name in ["forces", "diagnostics", "contact_forces", "contact_body_forces",
                 "generalized_forces", "muscle_power"]:
        assert len(getattr(cam1_py, name)) == 3 * 101
    with pytest.raises(KeyError, match="no Length table"):
        cam1_py.table("Length")


def test_results_dir_files_equal_cli(repo, cam1_cli, tmp_path):
    out = tmp_path / "py"
    res = statopt.run(str(repo / "setups" / "leg_extension_cam1.xml"), results_dir=out, progress=False)
    assert sorted(Path(f).name for f in res.files) == sorted(p.name for p in cam1_cli.iterdir())
    assert all(Path(f).parent == out for f in res.files)
    for p in cam1_cli.glob("*.sto"):
        if "diagnostics" in p.name:  # solve times differ
            continue
        assert (out / p.name).read_bytes() == p.read_bytes(), p.name


def test_overrides_single_w0_equals_sweep_member(repo, cam1_py):
    res = statopt.run(repo / "setups" / "leg_extension_cam1.xml", contact_weight=500, progress=False)
    assert "leg_extension_cam1_SO_activation" in res.tables
    assert res.activations.index.name == "time"
    assert_same(res.activations, cam1_py.table("activation", w0=500))
    assert_same(res.reactions, cam1_py.table("ReactionLoads", w0=500))
    # the setup's metrics follow the single-w0 table names
    assert set(res.metrics) == set(cam1_py.metrics)


def test_overrides_time_range_friction_motion(repo, cam1_py):
    setup = repo / "setups" / "leg_extension_cam1.xml"
    res = statopt.run(setup, contact_weight=1, time_range=(1.0, 2.0), friction="pyramid8", progress=False)
    a = res.activations
    assert a.index[0] == 1.0 and a.index[-1] == 2.0 and len(a) == 21
    motion = statopt.read_table(repo / "motions" / "leg_extension.mot")
    res2 = statopt.run(setup, contact_weight=1, motion=motion, progress=False)
    assert_same(res2.activations, cam1_py.table("activation", w0=1))
    res3 = statopt.run(setup, contact_weight=1, motion=motion.iloc[:50], progress=False)
    assert len(res3.activations) == 50


def test_overrides_model_properties_and_artifact(repo, cam1_py):
    setup = repo / "setups" / "leg_extension_cam1.xml"
    base = cam1_py.table("ContactForces", w0=1)
    moved = statopt.run(setup, contact_weight=1, progress=False,
                        model_properties={"pelvis_seat_r/plane_origin": [0, 0.005, 0]})
    assert moved.contact_forces.shape == base.shape
    assert not np.array_equal(bits(moved.contact_forces), bits(base))
    same = statopt.run(setup, contact_weight=1, progress=False,
                       model_properties={"/forceset/pelvis_seat_r/plane_origin": [0, 0.005, 0]})
    assert_same(same.contact_forces, moved.contact_forces)
    cam2 = statopt.run(setup, contact_weight=1, progress=False,
                       artifact_files=repo / "models" / "leg_extension" / "machine_cam2.osim")
    assert not np.array_equal(bits(cam2.forces), bits(cam1_py.table("force", w0=1)))
    with pytest.raises(statopt.InputError, match="no component 'nope'"):
        statopt.run(setup, model_properties={"nope/plane_origin": [0, 0, 0]})
    with pytest.raises(TypeError, match="unknown override 'no_such_thing'"):
        statopt.run(setup, no_such_thing=3)


def test_overrides_expression_in_artifact_file(repo):
    # cam 2's elliptical cam torque turned into cam 1's constant one: the same
    # forces as the cam 1 machine, bit for bit (the files differ only there)
    cam2 = repo / "setups" / "leg_extension_rajagopal_cam2.xml"
    cam1 = repo / "setups" / "leg_extension_rajagopal_cam1.xml"
    flat = statopt.run(cam2, contact_weight=500, progress=False,
                       model_properties={"cam_torque/expression": "-50"})
    assert (flat.forces["cam_torque"] == -50).all()
    assert_same(flat.forces, statopt.run(cam1, contact_weight=500, progress=False).forces)
    assert flat.metrics["quadriceps_work_J"] > statopt.run(cam2, contact_weight=500, progress=False,
                                                           tables=False).metrics["quadriceps_work_J"]
    with pytest.raises(statopt.InputError, match="cam_torque"):
        statopt.run(cam2, contact_weight=500, progress=False,
                    model_properties={"cam_torque/expression": "-50*sqrt(1-0.75*sin(q"})


def test_inverse_dynamics_setup(repo, cli, tmp_path):
    setup = repo / "setups" / "double_pendulum_ID.xml"
    r = subprocess.run([str(cli), str(setup), "-o", str(tmp_path), "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = statopt.run(setup, progress=False)
    (key, df), = res.tables.items()
    assert_same(df, statopt.read_table(tmp_path / (key + ".sto")))
    # Keyed by the engine as its setup's table, whatever the file's name.
    assert res._keys[key] == {"setup": "double_pendulum", "analysis": None, "w0": None,
                              "stat": None, "table": "inverse_dynamics"}
    assert res.inverse_dynamics is df
    part = statopt.run(setup, time_range=(0.5, 1.0), progress=False)
    assert_same(part.tables[key], df.loc[0.5:1.0])


# -- errors ------------------------------------------------------------------

def test_input_error_names_file_line_element_like_cli(repo, cli, tmp_path):
    text = (repo / "setups" / "leg_extension_cam1.xml").read_text()
    text = text.replace("../models", str(repo / "models")).replace("../motions", str(repo / "motions"))
    bad = tmp_path / "bad_setup.xml"
    bad.write_text(text.replace("<contact_weight>1 500 1000</contact_weight>",
                                "<contact_weight>-1</contact_weight>"))
    r = subprocess.run([str(cli), str(bad)], capture_output=True, text=True)
    assert r.returncode == 2
    with pytest.raises(statopt.InputError) as e:
        statopt.run(bad)
    assert isinstance(e.value, statopt.StatoptError)
    assert r.stderr.strip() == f"error: {e.value}"
    assert str(bad) in str(e.value)
    assert e.value.file == str(bad) and e.value.element == "<contact_weight>"
    assert e.value.line == 25
    # an override is checked as the file would be, and the message names the file
    with pytest.raises(statopt.InputError, match=r"leg_extension_cam1.xml, line \d+, <friction_cone>"):
        statopt.run(repo / "setups" / "leg_extension_cam1.xml", friction="round")
    # nothing was written next to the setup
    assert not (tmp_path.parent / "output").exists()
    # not XML at all, and a missing file
    broken = tmp_path / "broken.xml"
    broken.write_text("<OpenSimDocument><AnalyzeTool>")
    with pytest.raises(statopt.InputError, match="broken.xml"):
        statopt.run(broken)
    with pytest.raises(statopt.InputError, match="missing.xml"):
        statopt.run(tmp_path / "missing.xml")
    # ... with overrides too (the setup is read in Python first)
    with pytest.raises(statopt.InputError, match="missing.xml"):
        statopt.run(tmp_path / "missing.xml", contact_weight=1)
    with pytest.raises(statopt.InputError, match=r"broken.xml, line 1: not well-formed"):
        statopt.run(broken, contact_weight=1)


# -- tables ------------------------------------------------------------------

def test_read_write_table_round_trip(cam1_cli, tmp_path):
    src = cam1_cli / "leg_extension_cam1_SO_w0_500_activation.sto"
    df = statopt.read_table(src)
    assert df.index.name == "time" and df.attrs["in_degrees"] is False
    out = tmp_path / "copy.sto"
    statopt.write_table(df, out)
    back = statopt.read_table(out)
    assert_same(df, back)
    assert back.attrs == df.attrs
    # the engine's writer: the same bytes as the CLI's file
    assert out.read_bytes() == src.read_bytes()
    # a plain DataFrame, 16 digits: exact
    plain = pd.DataFrame({"time": [0.0, 0.1, 0.2], "a": [1.0, -2.5e-3, np.pi], "b": [0.0, 1e6, -7.0]})
    statopt.write_table(plain, tmp_path / "plain.mot", precision=16, in_degrees=True)
    got = statopt.read_table(tmp_path / "plain.mot")
    assert got.attrs["in_degrees"] is True and got.attrs["name"] == "plain"
    assert np.array_equal(got.to_numpy(), plain[["a", "b"]].to_numpy())
    with pytest.raises(statopt.InputError, match="nope.sto"):
        statopt.read_table(tmp_path / "nope.sto")


# -- progress, GIL -----------------------------------------------------------

def test_progress_callback_and_gil_released(repo):
    calls = []
    ticks = 0
    done = threading.Event()

    def work():
        statopt.run(repo / "setups" / "leg_extension_cam1.xml", progress=lambda *a: calls.append(a))
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    # The main thread ran while the engine did: with the GIL held it would
    # tick once or twice (before and after). Not a time bound: the run takes
    # some 40 ms now (about 40 ticks of >= 1 ms), and was asserted > 50
    # when it was slower.
    assert ticks > 10, ticks
    labels = [c[0] for c in calls]
    # one pass over the frames serves every w0 of the sweep
    assert "leg_extension_cam1_SO" in labels
    last = {}
    for label, d, total in calls:
        last[label] = (d, total)
    assert all(d == total == 101 for d, total in last.values())


def test_frames_failed_warning_relative_setup_path(repo, monkeypatch):
    monkeypatch.chdir(repo)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        statopt.run("setups/leg_extension_cam1.xml", contact_weight=1, progress=False)
    # quadriceps of 1 N: no frame can be solved; the result is complete
    weak = {f"{m}/max_isometric_force": 1.0 for m in ["vas_int_r", "vas_lat_r", "vas_med_r", "rect_fem_r"]}
    with pytest.warns(statopt.FramesFailedWarning, match=r"could not solve 101 of 101 .*see leg_extension_cam1_SO_diagnostics.sto"):
        res = statopt.run("setups/leg_extension_cam1.xml", contact_weight=1, progress=False,
                          model_properties=weak)
    assert res.failed == 101 and not res.ok
    assert (res.diagnostics.status == -1).all() and len(res.activations) == 101


# -- sweep -------------------------------------------------------------------

def test_sweep_on_local_cluster_reports_failures(repo):
    from dask.distributed import Client, LocalCluster

    setup = repo / "setups" / "leg_extension_cam1.xml"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        df = statopt.sweep(setup, {"contact_weight": [1, 500], "friction": ["cone", "round"]}, client=client)
        assert len(df) == 4
        assert list(df.columns[:2]) == ["contact_weight", "friction"]
        ok = df[df.error.isna()]
        bad = df[df.error.notna()]
        assert list(ok.friction) == ["cone", "cone"] and list(bad.friction) == ["round", "round"]
        assert all("InputError" in e and "friction_cone" in e for e in bad.error)
        # the setup's <Metric>s, from single-w0 tables
        single = statopt.run(setup, contact_weight=500, progress=False)
        row = ok[ok.contact_weight == 500].iloc[0]
        # (points that differ only in w0 run as one force sweep: unrounded
        # metrics; the run's metrics.csv has 6 decimals)
        assert row["quadriceps_work_J"] == pytest.approx(single.metrics["quadriceps_work_J"], abs=6e-7, rel=0)
        assert row["failed"] == 0

        # setups as points, the summary metrics
        df2 = statopt.sweep(None, [setup, repo / "setups" / "double_pendulum_ID.xml", repo / "no_such.xml"],
                            client=client, metrics=statopt.summary_metrics)
        assert len(df2) == 3 and df2.columns[0] == "setup"
        assert df2.error.isna().tolist() == [True, True, False]
        assert "no_such.xml" in df2.error.iloc[2]
        assert df2.solved.iloc[0] == 303 and df2.failed.iloc[0] == 0
        assert df2["peak_knee_r_on_tibia_r_in_tibia_r_force_N"].iloc[0] > 500


def test_sweep_batches_points_that_differ_only_in_forces(repo):
    setup = repo / "setups" / "leg_extension_rajagopal_cam2.xml"
    cam2 = "-50*sqrt(1-0.75*sin(q+0.08726646259971647)^2)"
    grid = {"contact_weight": [1, 1000],
            "model_properties": [{"cam_torque/expression": e} for e in ("-50", cam2)]}
    df = statopt.sweep(setup, grid, time_range=(0.0, 1.0), progress=False)
    assert len(df) == 4 and df.error.isna().all() and (df.frames == 21).all() and (df.failed == 0).all()
    # one force sweep: no cluster, one compiled scene, one timing for all
    assert df.seconds.nunique() == 1
    for _, row in df.iterrows():
        own = statopt.run(setup, contact_weight=row.contact_weight, time_range=(0.0, 1.0), progress=False,
                          tables=False, model_properties=row.model_properties)
        for k, v in own.metrics.items():
            assert row[k] == pytest.approx(v, abs=6e-7, rel=0), k
    # the engine's call, and an input error naming the candidate
    rows = statopt.force_sweep(setup, [{"w0": 500, "expressions": {"cam_torque": "-50"}}], time_range=(0.0, 1.0))
    assert rows[0]["frames"] == 21
    with pytest.raises(statopt.InputError, match="candidate 0: the model has no passive force 'cam'"):
        statopt.force_sweep(setup, [{"w0": 500, "expressions": {"cam": "-50"}}])


def test_force_sweep_writes_tables_on_request(repo, tmp_path):
    setup = repo / "setups" / "leg_extension_rajagopal_cam2.xml"
    cands = [{"w0": 500, "expressions": {"cam_torque": "-50"}}, {"w0": 1, "expressions": {"cam_torque": "-40"}}]
    rows = statopt.force_sweep(setup, cands, time_range=(0.0, 1.0), write_tables=tmp_path / "t")
    own = statopt.run(setup, contact_weight=1, time_range=(0.0, 1.0), progress=False,
                      model_properties={"cam_torque/expression": "-40"})
    assert rows[1]["tables"] == str(tmp_path / "t" / "candidate_1")
    mine = statopt.read_table(tmp_path / "t" / "candidate_1" / "leg_extension_rajagopal_cam2_JR_KneeLoads.sto")
    theirs = own.table("KneeLoads")
    assert list(mine.columns) == list(theirs.columns) and len(mine) == 21
    assert np.allclose(mine.to_numpy(), theirs.to_numpy(), rtol=1e-7, atol=1e-6)
    # metrics only by default
    assert "tables" not in statopt.force_sweep(setup, cands[:1], time_range=(0.0, 1.0))[0]
    # a sweep: each point's tables in its folder, batched (w0 1, 500) or not (an artifact override)
    grid = [{"contact_weight": 1, "model_properties": {"cam_torque/expression": "-40"}},
            {"contact_weight": 500},
            {"contact_weight": 1, "artifact_files": str(repo / "models" / "leg_extension" / "machine_cam1_rajagopal.osim")}]
    df = statopt.sweep(setup, grid, time_range=(0.0, 1.0), progress=False, write_tables=tmp_path / "s")
    assert df.error.isna().all(), df.error
    assert df.tables.tolist() == [str(tmp_path / "s" / f"point_{i}") for i in range(3)]
    first = statopt.read_table(tmp_path / "s" / "point_0" / "leg_extension_rajagopal_cam2_JR_KneeLoads.sto")
    assert np.allclose(first.to_numpy(), theirs.to_numpy(), rtol=1e-7, atol=1e-6)
    for i in (1, 2):
        assert (tmp_path / "s" / f"point_{i}" / "leg_extension_rajagopal_cam2_SO_activation.sto").is_file()
    # a point run on its own (batch=False) writes its run's tables there too
    df = statopt.sweep(setup, [grid[0]], time_range=(0.0, 1.0), progress=False, batch=False,
                       write_tables=tmp_path / "u")
    assert df.error.isna().all() and df.tables[0] == str(tmp_path / "u" / "point_0")
    own_run = statopt.read_table(tmp_path / "u" / "point_0" / "leg_extension_rajagopal_cam2_JR_KneeLoads.sto")
    assert np.allclose(own_run.to_numpy(), first.to_numpy(), rtol=1e-7, atol=1e-6)


def test_sweep_batches_external_load_scales(repo, tmp_path):
    """external_load_scale points of the GC5 trial (../shared; skipped
    without it) run as one force sweep and equal runs of the scaled data."""
    gc5 = repo.parent / "shared" / "models" / "knee_gc5"
    if not (gc5 / "setup_ss1.xml").exists():
        pytest.skip(f"SKIP {gc5} is absent")
    text = (gc5 / "setup_ss1.xml").read_text()
    for f in ("Rajagopal2015-scaled.osim", "ForceSet.xml", "residuals.xml", "GC5_ss1_loads.xml", "GC5_ss1.mot"):
        text = text.replace(f">{f}", f">{gc5 / f}").replace(f" {f}<", f" {gc5 / f}<")
    text = text.replace("<external_loads_file>", '<Metric name="peak_knee_fy" file="GC5_ss1_JR_ReactionLoads.sto" '
                        'columns="walker_knee_l_on_tibia_l_in_tibia_l_fy" op="min"/>'
                        '<Metric name="mean_vasint" file="GC5_ss1_SO_force.sto" columns="vasint_l" op="mean"/>'
                        '<external_loads_file>')
    setup = tmp_path / "setup_ss1.xml"
    setup.write_text(text)
    grid = {"external_load_scale": [0.8, {"plate1_left": 1.2}]}
    df = statopt.sweep(setup, grid, contact_weight=1000, time_range=(0.0, 0.05), progress=False)
    assert df.error.isna().all() and (df.frames == 7).all() and df.seconds.nunique() == 1, df
    for _, row in df.iterrows():
        own = statopt.run(setup, contact_weight=1000, time_range=(0.0, 0.05), progress=False, tables=False,
                          external_load_scale=row.external_load_scale)
        for k, v in own.metrics.items():
            assert row[k] == pytest.approx(v, abs=6e-7, rel=0), k
    assert df.peak_knee_fy.nunique() == 2
    # The engine scales the loads as it reads them: no scaled copy of the
    # data file, and an unknown load is an InputError naming the file.
    with pytest.raises(statopt.InputError, match="no ExternalForce 'plate9'"):
        statopt.run(setup, external_load_scale={"plate9": 2.0}, time_range=(0.0, 0.05), progress=False)
    import statopt._setup as setup_module
    assert "scaled_" not in open(setup_module.__file__).read()


# -- studies, Ctrl-C ----------------------------------------------------------

def test_study_and_ctrl_c(repo, tmp_path):
    import os
    import signal

    study = repo / "setups" / "leg_extension_study.xml"
    res = statopt.run(study, progress=False)
    assert res.summary["solves"] == 2121 and res.failed == 0  # 7 setups x 3 w0 x 101 frames
    # metrics of each setup and of the study, named after their files
    assert res.metrics["leg_extension.gait2392_cam1_quadriceps_work_J"] == res.metrics["leg_extension_cam1.quadriceps_work_J"]
    assert res.activations.index.names == ["table", "time"]

    # Ctrl-C stops the engine cleanly: KeyboardInterrupt, tables closed
    # with the frames solved, and the next run is not stopped.
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        statopt.run(study, results_dir=tmp_path / "stopped", progress=False)
        time.sleep(5)  # (if the run ended before the signal)
    timer.join()
    res = statopt.run(repo / "setups" / "leg_extension_cam1.xml", contact_weight=1, progress=False)
    assert res.frames == 101 and len(res.activations) == 101


def test_temporary_folders_removed(repo, tmp_path, monkeypatch):
    import gc
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    setup = repo / "setups" / "leg_extension_cam1.xml"
    res = statopt.run(setup, contact_weight=1, progress=False,
                      model_properties={"pelvis_seat_r/plane_origin": [0, 0.005, 0]})
    assert list(tmp_path.iterdir()) == []  # the edited inputs are gone, the tables in memory
    assert len(res.activations) == 101
    res = statopt.run(setup, contact_weight=1, progress=False)
    del res
    gc.collect()
    assert list(tmp_path.iterdir()) == []


def _listing(d: Path):
    return sorted(str(p.relative_to(d)) for p in d.rglob("*")) if d.exists() else None


def test_run_without_results_dir_creates_no_file(repo, tmp_path, monkeypatch):
    """statopt.run(setup) without results_dir creates no file (issue 37): not
    in the working directory, the setup's folder, its results folder or the
    temporary folder (the engine's and Python's, made private here), and
    returns the DataFrames a run with results_dir reads back from its files."""
    import tempfile

    tmp = tmp_path / "tmp"
    tmp.mkdir()
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    monkeypatch.chdir(cwd)
    setup = repo / "setups" / "leg_extension_cam1.xml"
    watched = [tmp, cwd, setup.parent, repo / "output" / "leg_extension_cam1"]
    before = [_listing(d) for d in watched]
    res = statopt.run(setup, progress=False, contact_weight=[1, 500, 1000])
    assert [_listing(d) for d in watched] == before
    tables = res.tables
    assert [_listing(d) for d in watched] == before
    assert res.files == [] and res.summary["files"] == []
    ref = statopt.run(setup, results_dir=tmp_path / "out", progress=False)
    assert set(tables) == set(ref.tables)
    # the sweep's statistics and the knee loads are among them
    assert "leg_extension_cam1_JR_w0_mean_KneeLoads" in tables
    for key, df in tables.items():
        assert_same(df, ref.tables[key])
    assert res.metrics == ref.metrics and res.metrics
    assert res.summary["frames"] == ref.summary["frames"] == 101


def test_check(repo, tmp_path):
    ok = statopt.check(repo / "setups" / "leg_extension_cam1.xml")
    assert ok["errors"] == [] and ok["checked"]
    bad = tmp_path / "bad.xml"
    text = (repo / "setups" / "leg_extension_cam1.xml").read_text()
    text = text.replace("../models", str(repo / "models")).replace("../motions", str(repo / "motions"))
    bad.write_text(text.replace("<friction_cone>cone</friction_cone>", "<friction_cone>round</friction_cone>"))
    r = statopt.check(bad)
    assert any("bad.xml" in e and "friction_cone" in e for e in r["errors"]), r



def test_allow_unknown(repo, tmp_path):
    # The CLI's --allow-unknown: a misspelled property is an error naming
    # the element, file, line and nearest name; allowed, a warning.
    bad = tmp_path / "misspelled.xml"
    text = (repo / "setups" / "leg_extension_cam1.xml").read_text()
    text = text.replace("../models", str(repo / "models")).replace("../motions", str(repo / "motions"))
    assert "<contact_weight>" in text
    # (An extra, misspelled element: the run itself stays the shipped one.)
    bad.write_text(text.replace("<contact_weight>", "<contact_wieght>1</contact_wieght><contact_weight>", 1))
    with pytest.raises(statopt.InputError, match="did you mean contact_weight"):
        statopt.run(bad, progress=False, tables=False)
    strict = statopt.check(bad)
    assert any("contact_wieght" in e and "misspelled.xml" in e for e in strict["errors"]), strict
    lenient = statopt.check(bad, allow_unknown=True)
    assert not any("contact_wieght" in e for e in lenient["errors"]), lenient
    assert any("contact_wieght" in w for w in lenient["warnings"]), lenient
    res = statopt.run(bad, progress=False, tables=False, allow_unknown=True, time_range=(0.0, 0.05))
    # In Python's words: the option is allow_unknown=True, not --allow-unknown.
    assert any("contact_wieght" in w and "allow_unknown=True" in w for w in res.summary["warnings"])
    assert not any("--allow-unknown" in w for w in res.summary["warnings"])


def test_messages_in_python_words(repo, tmp_path):
    # An unknown element: the InputError names allow_unknown=True (it named
    # the CLI's --allow-unknown), in its message and its reason.
    bad = tmp_path / "misspelled.xml"
    text = (repo / "setups" / "leg_extension_cam1.xml").read_text()
    text = text.replace("../models", str(repo / "models")).replace("../motions", str(repo / "motions"))
    bad.write_text(text.replace("<contact_weight>", "<contact_wieght>1</contact_wieght><contact_weight>", 1))
    with pytest.raises(statopt.InputError) as e:
        statopt.run(bad, progress=False, tables=False)
    assert "allow_unknown=True" in str(e.value) and "--allow-unknown" not in str(e.value), str(e.value)
    assert "allow_unknown=True" in e.value.reason
    # A missing setup says it is the setup.
    with pytest.raises(statopt.InputError, match="nowhere.xml: no such setup file"):
        statopt.run(tmp_path / "nowhere.xml", progress=False)
    # check() takes the run's results_dir: a file there is an error naming it.
    afile = tmp_path / "a_file"
    afile.write_text("not a folder")
    setup = repo / "setups" / "leg_extension_cam1.xml"
    r = statopt.check(setup, results_dir=afile)
    assert r["errors"] == [f"results_dir='{afile}': the results folder is a file, not a folder"], r
    r = statopt.check(setup, results_dir=afile / "sub", reduce=True)
    assert len(r["errors"]) == 1 and "results_dir=" in r["errors"][0] and "-o " not in r["errors"][0], r
    assert statopt.check(setup, results_dir=tmp_path / "new")["errors"] == []
    # The misspelt contact_weight itself: one error, the root cause, and a
    # note on what was not checked because of it.
    typo = tmp_path / "typo.xml"
    typo.write_text(text.replace("contact_weight>", "contact_wieght>"))
    r = statopt.check(typo)
    assert len(r["errors"]) == 1 and "contact_wieght" in r["errors"][0], r
    assert r["notes"] and "not checked" in r["notes"][0], r


def test_summary_names_only_what_exists(repo):
    # Without results_dir the tables go to a temporary folder that is
    # removed: the report names no folder (it named the deleted one).
    res = statopt.run(repo / "setups" / "leg_extension_cam1.xml", progress=False,
                      contact_weight=1, time_range=(0.0, 0.05))
    last = res.summary["report"][-1]
    assert "statopt-results-" not in " ".join(res.summary["report"]), res.summary["report"]
    assert "read into the result's tables" in last, last
    assert len(res.activations) > 0

# -- predict-grf (reads ../shared in place; skipped without it) ---------------

def test_predict_grf_equals_cli(repo, cli, tmp_path):
    import csv

    setup = repo.parent / "shared" / "models" / "gait2392" / "subject01_walk" / "setup_SO.xml"
    if not setup.exists():
        pytest.skip(f"SKIP {setup} is absent")
    r = subprocess.run([str(cli), "predict-grf", str(setup), "-o", str(tmp_path), "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    res = statopt.predict_grf(setup, progress=False)
    assert_same(res.predicted_grf, statopt.read_table(tmp_path / "subject01_predicted_grf.sto"))
    for key in ("subject01_StaticOptimization_activation", "subject01_StaticOptimization_ContactForces"):
        assert_same(res.tables[key], statopt.read_table(tmp_path / (key + ".sto")))
    with open(tmp_path / "subject01_grf_comparison.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            f, a = row["foot"], row["axis"]
            assert f"{res.metrics[f'{f}_{a}_rho']:.4f}" == row["rho"]
            assert f"{res.metrics[f'{f}_{a}_rmse_N']:.2f}" == row["rmse_N"]
            assert f"{res.metrics[f'{f}_cop_error_mm']:.1f}" == row["cop_error_mm"]
    assert res.summary["prediction"]["contact_points"] > 0


def test_predict_grf_without_results_dir_creates_no_file(repo, tmp_path, monkeypatch):
    """statopt.predict_grf(setup) without results_dir creates no file, as
    run() (issue 37): no temporary folder, nothing beside the setup."""
    import tempfile

    setup = repo.parent / "shared" / "models" / "gait2392" / "subject01_walk" / "setup_SO.xml"
    if not setup.exists():
        pytest.skip(f"SKIP {setup} is absent")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    monkeypatch.chdir(cwd)
    watched = [tmp, cwd, setup.parent]
    before = [_listing(d) for d in watched]

    def no_folder(*a, **k):
        raise AssertionError("predict_grf made a temporary results folder")

    # (A folder made and removed again would leave the listings alike.)
    monkeypatch.setattr(tempfile, "mkdtemp", no_folder)
    res = statopt.predict_grf(setup, progress=False)
    assert len(res.predicted_grf) > 0 and res.metrics
    assert [_listing(d) for d in watched] == before
    assert res.files == [] and res.summary["files"] == []


def test_sweep_own_local_cluster_of_processes(repo):
    # no client: a LocalCluster of worker processes is started and closed
    df = statopt.sweep(repo / "setups" / "leg_extension_cam1.xml", {"contact_weight": [1, 500]},
                       progress=False)
    assert df.error.isna().all(), df.error.tolist()
    assert df.contact_weight.tolist() == [1, 500] and (df.failed == 0).all()
    assert df.quadriceps_work_J.iloc[0] != df.quadriceps_work_J.iloc[1]


def test_table_names_come_from_the_engine(repo):
    """The package names tables through the binding (the engine's
    writers::names); a table's kind and w0 come from the key the run hands
    over with it (test_table_keys_come_from_the_run), never from its name."""
    from statopt import _native

    assert _native.output_name("cam1", "force", analysis="SO", w0=500) == "cam1_SO_w0_500_force.sto"
    assert _native.output_name("cam1", "KneeLoads", analysis="JR", stat="mean") == "cam1_JR_w0_mean_KneeLoads.sto"
    assert _native.output_name("cam1", "KneeContact") == "cam1_KneeContact.sto"
    assert "GeneralizedForcesBySource" in _native.output_tables()
    setup = repo / "setups" / "leg_extension_cam1.xml"
    text = setup.read_text()
    assert _native.single_w0_references(str(setup), text, ["../o/leg_extension_cam1_SO_w0_1_force.sto",
                                                           "leg_extension_cam1_JR_w0_mean_KneeLoads.sto",
                                                           "other.sto"]) == [
        "../o/leg_extension_cam1_SO_force.sto", "leg_extension_cam1_JR_KneeLoads.sto", "other.sto"]
    import statopt._run as run_module
    import statopt._setup as setup_module
    import statopt._sweep as sweep_module
    for m in (run_module, setup_module, sweep_module):
        src = open(m.__file__).read()
        for parse in ("_W0_PREFIX", 're.compile(r"_w0_', "split_table_stem", "without_w0", "_split_key"):
            assert parse not in src, (parse, m.__file__)


def test_table_keys_come_from_the_run(repo, tmp_path):
    """Each table's key (setup, analysis, w0, stat, table) is the run's own,
    handed over by the binding with the table's path (the run's capture
    knows the typed key each output's name was made from), in memory and
    with results_dir. It used to be found by re-reading the setup after the
    run and matching the file names against its plan's (``output_keys``):
    a setup edited meanwhile (here its tool renamed, as a script preparing
    the next run would) left every table without a key, and
    ``res.activations`` raised KeyError."""
    from statopt import _native

    assert not hasattr(_native, "output_keys")
    for d in ("models", "motions"):
        (tmp_path / d).symlink_to(repo / d)
    (tmp_path / "setups").mkdir()
    setup = tmp_path / "setups" / "leg_extension_cam1.xml"
    text = (repo / "setups" / "leg_extension_cam1.xml").read_text()
    tool = '<AnalyzeTool name="leg_extension_cam1">'
    assert tool in text

    def edit(label, done, total):
        setup.write_text(text.replace(tool, '<AnalyzeTool name="renamed">'))

    for results_dir in (None, tmp_path / "out"):
        setup.write_text(text)
        res = statopt.run(setup, results_dir=results_dir, progress=edit)
        assert "renamed" in setup.read_text()
        keys = [res._keys[k] for k in res.tables]
        assert len(keys) == 54 and None not in keys, [k for k in res.tables if res._keys[k] is None]
        assert res._keys["leg_extension_cam1_SO_w0_500_force"] == {
            "setup": "leg_extension_cam1", "analysis": "SO", "w0": 500.0, "stat": None, "table": "force"}
        assert res._keys["leg_extension_cam1_JR_w0_mean_KneeLoads"] == {
            "setup": "leg_extension_cam1", "analysis": "JR", "w0": None, "stat": "mean",
            "table": "KneeLoads"}
        assert res.activations.index.names == ["w0", "time"]
        assert sorted(set(res.activations.index.get_level_values("w0"))) == [1.0, 500.0, 1000.0]
        assert len(res.table("ReactionLoads", stat="max")) == 101
    # The binding's own word: one key per file (None for a file no key
    # names: the figures), and each output kept in memory with its key.
    setup.write_text(text)
    s = _native.run(str(setup), in_memory=True)
    by_path = dict(zip(s["files"], s["keys"]))
    assert len(s["outputs"]) == len(s["files"])
    for path, key, _ in s["outputs"]:
        assert by_path[path] == key
        name = Path(path).name
        if name.endswith((".png", ".svg")):
            assert key is None, name
        else:
            assert key is not None and key["setup"] == "leg_extension_cam1", name
            if key["table"] in _native.output_tables():
                assert name == _native.output_name(key["setup"], key["table"], analysis=key["analysis"],
                                                   w0=key["w0"], stat=key["stat"]), (name, key)


def _long_motion(repo, rows: int) -> pd.DataFrame:
    """The leg extension's motion resampled to ``rows`` rows (a long run)."""
    m = statopt.read_table(repo / "motions" / "leg_extension.mot")
    t = np.linspace(m.index[0], m.index[-1], rows)
    df = pd.DataFrame({c: np.interp(t, m.index, m[c]) for c in m.columns}, index=pd.Index(t, name="time"))
    df.attrs = dict(m.attrs)
    return df


def test_ctrl_c_stops_a_run_on_two_threads_and_keeps_its_frames(repo, tmp_path):
    """Ctrl-C stops a run with threads=2 as it stops one on the caller's
    thread: within a fraction of a second, KeyboardInterrupt noted with
    where it stopped, every table holding the same frames, each frame the
    progress counted as solved, bit for bit an uninterrupted run's; resume
    then completes it. (With threads=N the frame loop runs on a pool, where
    Python sees no signal: the run went on to its end before.)"""
    import os
    import signal

    setup = repo / "setups" / "leg_extension_cam1.xml"
    motion = _long_motion(repo, 6001)
    kw = dict(contact_weight=1, motion=motion, threads=2)
    out = tmp_path / "stopped"
    seen = []
    sent = []

    def progress(label, done, total):
        seen.append(done)
        if done > 0 and not sent:
            sent.append(time.monotonic())
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt) as stop:
        statopt.run(setup, results_dir=out, progress=progress, **kw)
        time.sleep(5)  # (the signal is handled on return at the latest)
    stopped_in = time.monotonic() - sent[0]
    assert stopped_in < 2.0, f"took {stopped_in:.2f} s to stop"
    notes = getattr(stop.value, "__notes__", [])
    assert len(notes) == 1 and "stopped by a signal after the frame at t = " in notes[0], notes
    assert "resume=True" in notes[0], notes
    tables = {p.name: statopt.read_table(p) for p in sorted(out.glob("*.sto"))}
    n = len(tables["leg_extension_cam1_SO_activation.sto"])
    assert 0 < n < len(motion), n
    assert f"hold the {n} frames solved so far" in notes[0], notes
    # Every frame the run counted as solved is in every table, and no more.
    assert seen[-1] == n, (seen[-3:], n)
    for name, df in tables.items():
        assert len(df) == n, name
    t_last = tables["leg_extension_cam1_SO_activation.sto"].index[-1]
    # (The note's time unrounded, the table's to its 8 decimals.)
    t_note = float(notes[0].split("after the frame at t = ")[1].split(";")[0])
    assert abs(t_note - t_last) <= 5e-9, (t_note, t_last)
    # The next run is not stopped: resumed, it completes, and equals an
    # uninterrupted run bit for bit.
    res = statopt.run(setup, results_dir=out, resume=True, progress=False, **kw)
    full = statopt.run(setup, progress=False, **kw)
    for kind in ("activation", "force", "ContactForces", "ReactionLoads"):
        a, b = res.table(kind), full.table(kind)
        assert len(a) == len(motion)
        assert_same(a, b)
        assert_same(tables[f"leg_extension_cam1_{'JR' if kind == 'ReactionLoads' else 'SO'}_{kind}.sto"],
                    b.iloc[:n])


def test_ctrl_c_stops_a_force_sweep_on_two_threads(repo):
    """Ctrl-C stops statopt.force_sweep with threads=2 within a fraction of a
    second (its frame loop runs on a pool of two threads, where Python sees
    no signal): KeyboardInterrupt, and the next sweep runs."""
    import os
    import signal

    setup = repo / "setups" / "leg_extension_cam1.xml"
    motion = _long_motion(repo, 20001)
    sent = []

    def kill():
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Timer(1.0, kill)
    timer.start()
    start = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            statopt.force_sweep(setup, [{"w0": 1}, {"w0": 500}, {"w0": 1000}, {"w0": 2}],
                                threads=2, motion=motion)
            time.sleep(5)
    finally:
        timer.join()
    # (Not stopped before the signal, and soon after it.)
    assert sent and sent[0] - start >= 0.9
    stopped_in = time.monotonic() - sent[0]
    assert stopped_in < 2.0, f"took {stopped_in:.2f} s to stop"
    rows = statopt.force_sweep(setup, [{"w0": 1}], threads=2)
    assert rows[0]["frames"] == 101 and rows[0]["failed"] == 0


def test_summary_names_the_contacts_its_tables_show(repo):
    """summary["contacts"] names a contact exactly when its ContactForces
    table shows it sliding or more than 1 mm deep while carrying more than
    10 N, or carrying at most 1 N on every frame (docs/contact_model.md)."""
    res = statopt.run(repo / "setups" / "leg_extension_rajagopal_cam1.xml", progress=False)
    found = {(f["run"], f["contact"], f["kind"]): f for f in res.summary["contacts"]}
    for f in res.summary["contacts"]:
        # Said as it is, or, for a contact idle at every w0, once for all of
        # them with the largest force of any w0 (which bounds this one's).
        assert any(
            w.endswith(f["message"])
            or (
                f["kind"] == "carried_nothing"
                and w.startswith("every w0 (1, 500, 1000): ")
                and f"contact {f['contact']} carried nothing: at most " in w
            )
            for w in res.summary["warnings"]
        ), f
    for w0 in (1, 500, 1000):
        cf = res.table("ContactForces", w0=w0)
        names = sorted({c[:-3] for c in cf.columns if c.endswith("_fx")})
        for c in names:
            force = np.sqrt(cf[c + "_fx"] ** 2 + cf[c + "_fy"] ** 2 + cf[c + "_fz"] ** 2)
            loaded = force > 10
            slid = int((loaded & (cf[c + "_regime"] > 0)).sum())
            deep = int((loaded & (cf[c + "_distance"] < -1e-3)).sum())
            run = f"w0 = {w0}"
            assert found.get((run, c, "slid"), {"frames": 0})["frames"] == slid
            assert found.get((run, c, "too_deep"), {"frames": 0})["frames"] == deep
            assert ((run, c, "carried_nothing") in found) == bool(force.max() <= 1), (run, c)
    # The grip's hold side carries nothing on this motion (the hand pushes).
    assert ("w0 = 1000", "handle_hold_r", "carried_nothing") in found
