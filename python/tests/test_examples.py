"""The examples in python/examples/ run as users run them (a process of their
own, a LocalCluster of worker processes) and write their tables and figures."""

import subprocess
import sys

import pandas as pd
import pytest

import statopt

PNG = b"\x89PNG\r\n\x1a\n"


def run_example(repo, name, *args):
    r = subprocess.run([sys.executable, str(repo / "python" / "examples" / name), *map(str, args)],
                       cwd=repo, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_leg_extension_sweep(repo, tmp_path):
    out = tmp_path / "sweep.png"
    stdout = run_example(repo, "leg_extension_sweep.py", out)
    assert out.read_bytes().startswith(PNG)
    df = pd.read_csv(out.with_suffix(".csv"))
    assert len(df) == 14 and df.error.isna().all() and (df.failed == 0).all()
    assert set(df.cam) == {"cam 1 (circular)", "cam 2 (elliptical)"}
    work = df.groupby("cam").quadriceps_work_J.mean()
    assert work["cam 2 (elliptical)"] < work["cam 1 (circular)"]
    assert "wrote" in stdout


def test_cam_design_sweep(repo, cli, tmp_path):
    stdout = run_example(repo, "cam_design_sweep.py", "--out", tmp_path,
                         "--ratios", 0.3, 0.5, 0.7, 1.0, "--w0", 1, 500, 1000)
    assert (tmp_path / "cam_design.png").read_bytes().startswith(PNG)
    df = pd.read_csv(tmp_path / "cam_design.csv")
    # one row per (b/a, w0): a w0 column and the sweep's columns
    assert list(df.columns[:4]) == ["b_over_a", "w0", "expression", "work_vs_circular"]
    assert len(df) == 12 and sorted(set(df.w0)) == [1, 500, 1000]
    assert df.error.isna().all() and (df.failed == 0).all()
    for w0, g in df.groupby("w0"):
        # a rounder cam resists more in flexion: more work, more compression
        assert g.b_over_a.tolist() == [0.3, 0.5, 0.7, 1.0]
        assert g.quadriceps_work_J.is_monotonic_increasing, w0
        assert g.work_vs_circular.iloc[-1] == 1.0
        assert g.peak_tf_compression_N.iloc[0] < g.peak_tf_compression_N.iloc[-1]
    assert "choice: b/a = " in stdout
    # b/a = 0.5 is the machine file's own cam 2: the override wrote the same expression
    row = df[(df.b_over_a == 0.5) & (df.w0 == 500)].iloc[0]
    assert row.expression == "-50*sqrt(1-0.75*sin(q+0.08726646259971647)^2)"
    # b/a = 1 at w0 = 500 is cam 1: the CLI's run of the cam 1 setup, its
    # w0 = 500 KneeLoads table (8 decimals)
    out = tmp_path / "cli_cam1"
    r = subprocess.run([str(cli), str(repo / "setups" / "leg_extension_rajagopal_cam1.xml"), "-o", str(out), "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    knee = statopt.read_table(out / "leg_extension_rajagopal_cam1_JR_w0_500_KneeLoads.sto")
    circ = df[(df.b_over_a == 1.0) & (df.w0 == 500)].iloc[0]
    assert circ.peak_tf_compression_N == pytest.approx(knee.tf_compression_r.max(), rel=1e-6, abs=0)
    cam2 = statopt.run(repo / "setups" / "leg_extension_rajagopal_cam2.xml", contact_weight=500,
                       progress=False, tables=False)
    for k in ("quadriceps_work_J", "peak_tf_compression_N", "peak_pcl_shear_N", "peak_pf_compression_N"):
        # the setup's metrics.csv has 6 decimals
        assert row[k] == pytest.approx(cam2.metrics[k], abs=6e-7, rel=0), k


def test_cam_design_sweep_knee_contact(repo, cli, tmp_path):
    """--knee-contact: the knee contact method's total tibiofemoral force is
    the goal; the circular cam at w0 = 500 equals the CLI's run of the cam 1
    setup with the method (its w0 = 500 KneeContact table, 8 decimals)."""
    stdout = run_example(repo, "cam_design_sweep.py", "--out", tmp_path, "--ratios", 0.5, 1.0,
                         "--w0", 1, 500, "--knee-contact", "--no-figure")
    df = pd.read_csv(tmp_path / "cam_design.csv")
    assert len(df) == 4 and df.error.isna().all() and (df.failed == 0).all()
    assert {"peak_tf_total_N", "peak_tf_compression_N", "work_vs_circular"} <= set(df.columns)
    assert "lowest worst-case peak total tibiofemoral force (knee contact method)" in stdout
    out = tmp_path / "cli_cam1_kc"
    r = subprocess.run([str(cli), str(repo / "setups" / "leg_extension_rajagopal_cam1_kc.xml"), "-o", str(out),
                        "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    kc = statopt.read_table(out / "leg_extension_rajagopal_cam1_kc_w0_500_KneeContact.sto")
    circ = df[(df.b_over_a == 1.0) & (df.w0 == 500)].iloc[0]
    assert circ.peak_tf_total_N == pytest.approx(kc.walker_knee_r_total_N.max(), rel=1e-6, abs=0)


def test_cam_design_optimize(repo, tmp_path):
    stdout = run_example(repo, "cam_design_optimize.py", "--out", tmp_path, "--ratios", 15)
    assert (tmp_path / "cam_optimum.png").read_bytes().startswith(PNG)
    df = pd.read_csv(tmp_path / "cam_optimum.csv")
    assert df.w0.tolist() == [1, 500, 1000]
    assert {"peak_tf_compression_N", "work_vs_circular", "knot0_torque_Nm", "knot4_flexion_deg"} <= set(df.columns)
    # the work requirement holds at every w0 and the optimum beats the grid's best ellipse
    assert (df.work_vs_circular >= 0.9).all()
    assert df.knot0_torque_Nm.iloc[0] <= 50 + 1e-9
    assert "work constraint (>= 90% of circular at every w0): met" in stdout
    best = float(stdout.split("best feasible ellipse (b/a = ")[1].split(") ")[1].split(" N")[0])
    assert df.peak_tf_compression_N.max() < best


def test_cam_design_optimize_knee_contact(repo, tmp_path):
    """--knee-contact: the knee contact method's total tibiofemoral force
    is the goal; the optimum meets the work requirement at every w0 and
    beats the grid's best feasible ellipse on it."""
    stdout = run_example(repo, "cam_design_optimize.py", "--out", tmp_path, "--ratios", 15, "--knee-contact")
    df = pd.read_csv(tmp_path / "cam_optimum.csv")
    assert df.w0.tolist() == [1, 500, 1000]
    assert {"peak_tf_total_N", "peak_tf_compression_N", "work_vs_circular"} <= set(df.columns)
    assert (df.work_vs_circular >= 0.9).all()
    assert "work constraint (>= 90% of circular at every w0): met" in stdout
    assert "worst-case peak total tibiofemoral force (knee contact)" in stdout
    best = float(stdout.split("best feasible ellipse (b/a = ")[1].split(") ")[1].split(" N")[0])
    assert df.peak_tf_total_N.max() < best
