#!/usr/bin/env python3
"""Write predict-grf setups for the development trials of issue 27.

The trials in ../shared/models/running_hamner2013 (treadmill running, 92
muscles), ../shared/models/walk_schreiber2019 (one overground step,
torque-driven models) and ../shared/models/knee_gc5 (one overground gait
cycle, 80 muscles, three plates) come without predict-grf setups. Each is run as the issue's "Bar"
says: an AnalyzeTool with StaticOptimization, <reserve_actuators> 10 on the
muscle-driven models and 100 on the torque-driven ones, coordinates low-passed
at 12 Hz (running) or 6 Hz (walking), the IK's time range less 0.1 s (running)
or 0.03 s (walking) at each end, and the measured ExternalLoads file (which
predict-grf keeps as the reference and does not apply).

The setups name the shared files by absolute path (nothing is copied):

    python3 scripts/grf_dev_setups.py [--shared ../shared] [--out DIR]

prints one line per setup written: kind, trial, setup path.
"""

import argparse
import os
import sys


SETUP = """<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
\t<AnalyzeTool name="{name}">
\t\t<model_file>{model}</model_file>
\t\t<replace_force_set>false</replace_force_set>
\t\t<force_set_files />
\t\t<results_directory>{results}</results_directory>
\t\t<initial_time>{t0:.6f}</initial_time>
\t\t<final_time>{t1:.6f}</final_time>
\t\t<AnalysisSet name="Analyses">
\t\t\t<objects>
\t\t\t\t<StaticOptimization name="StaticOptimization">
\t\t\t\t\t<on>true</on>
\t\t\t\t\t<start_time>{t0:.6f}</start_time>
\t\t\t\t\t<end_time>{t1:.6f}</end_time>
\t\t\t\t\t<step_interval>1</step_interval>
\t\t\t\t\t<in_degrees>true</in_degrees>
\t\t\t\t\t<use_model_force_set>true</use_model_force_set>
\t\t\t\t\t<activation_exponent>2</activation_exponent>
\t\t\t\t\t<use_muscle_physiology>true</use_muscle_physiology>
\t\t\t\t\t<reserve_actuators>{reserve}</reserve_actuators>
\t\t\t\t</StaticOptimization>
\t\t\t</objects>
\t\t\t<groups />
\t\t</AnalysisSet>
\t\t<external_loads_file>{loads}</external_loads_file>
\t\t<coordinates_file>{ik}</coordinates_file>
\t\t<lowpass_cutoff_frequency_for_coordinates>{cutoff}</lowpass_cutoff_frequency_for_coordinates>
\t</AnalyzeTool>
</OpenSimDocument>
"""


def time_range(path):
    """First and last time of a .mot/.sto (statopt's reader)."""
    import statopt

    t = statopt.read_table(path).index
    return (float(t[0]), float(t[-1])) if len(t) else (None, None)


def trials(shared):
    """(kind, name, model, ik, loads) of every development trial present."""
    run = os.path.join(shared, "models", "running_hamner2013")
    if os.path.isdir(run):
        for subject in sorted(os.listdir(run)):
            d = os.path.join(run, subject)
            if not os.path.isdir(d):
                continue
            model = os.path.join(d, "model", f"{subject}_adjusted_scaled.osim")
            for ik in sorted(os.listdir(os.path.join(d, "ik"))):
                stem = ik[:-4]
                yield ("running", f"{subject}_{stem}", model,
                       os.path.join(d, "ik", ik),
                       os.path.join(d, "expData", f"{stem}_grf.xml"))
    gc5 = os.path.join(shared, "models", "knee_gc5")
    if os.path.isfile(os.path.join(gc5, "GC5_ss1.mot")):
        # Overground walking, one gait cycle, three plates, 80 muscles.
        yield ("walking_muscle", "knee_gc5_ss1",
               os.path.join(gc5, "Rajagopal2015-scaled.osim"),
               os.path.join(gc5, "GC5_ss1.mot"),
               os.path.join(gc5, "GC5_ss1_loads.xml"))
    walk = os.path.join(shared, "models", "walk_schreiber2019")
    if os.path.isdir(walk):
        for subject in sorted(os.listdir(walk)):
            d = os.path.join(walk, subject)
            if not os.path.isdir(d):
                continue
            model = os.path.join(d, "scaling", f"{subject}_scaledModelAdjusted.osim")
            for trial in sorted(os.listdir(os.path.join(d, "ik"))):
                yield ("walking_torque", f"{subject}_{trial}", model,
                       os.path.join(d, "ik", trial, f"{trial}_ik.mot"),
                       os.path.join(d, "dynamic", f"{subject}_{trial}_grf.xml"))


# The issue's bar: per kind, (trim at each end s, low-pass Hz, reserves' optimal force).
RULES = {"running": (0.1, 12, 10), "walking_torque": (0.03, 6, 100),
         "walking_muscle": (0.03, 6, 10)}


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", default=os.path.join(here, "..", "..", "shared"))
    ap.add_argument("--out", default="target/grf_dev_setups")
    a = ap.parse_args()
    shared = os.path.abspath(a.shared)
    if not os.path.isdir(os.path.join(shared, "models")):
        print(f"SKIP: {shared}/models is absent", file=sys.stderr)
        return 0
    os.makedirs(a.out, exist_ok=True)
    for kind, name, model, ik, loads in trials(shared):
        trim, cutoff, reserve = RULES[kind]
        t0, t1 = time_range(ik)
        path = os.path.join(a.out, f"{name}.xml")
        with open(path, "w") as f:
            f.write(SETUP.format(name=name, model=model, ik=ik, loads=loads,
                                 t0=t0 + trim, t1=t1 - trim, cutoff=cutoff,
                                 reserve=reserve,
                                 results=os.path.join(a.out, "out", name)))
        print(f"{kind}\t{name}\t{path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
