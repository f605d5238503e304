# OpenSim 4.6 per-frame time of static optimization on the leg extension study's human, the reference
# line of the speed/accuracy chart (docs/speed_accuracy.md). OpenSim has no point-on-plane contact
# model, so this runs the seated human alone (models/leg_extension/human_seated.osim, 23 DOF, 86
# muscles) on the study's motion (motions/leg_extension.mot), with OpenSim's default SO settings.
# Without the seat and the machine nothing could hold the pelvis and the hips, so every coordinate
# but the two knees is locked (the knees extend against gravity; all 86 muscles stay in the
# problem, so OpenSim still perturbs 86 actuators per frame). The machine's lever column of the
# motion is not a coordinate of this model and is ignored.
#
#   /work/venv/bin/python tests/reference_scripts/opensim_so_timing.py [repeats]
#
# Prints frames, best wall time of AnalyzeTool.run() and the time per frame.
import os
import sys
import tempfile
import time

import opensim as osim

osim.Logger.removeFileSink()
osim.Logger.setLevelString("error")
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 3

SETUP = """<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
  <AnalyzeTool name="leg_extension_human">
    <model_file>{model}</model_file>
    <results_directory>{out}</results_directory>
    <initial_time>0</initial_time>
    <final_time>5</final_time>
    <AnalysisSet name="Analyses"><objects>
      <StaticOptimization name="StaticOptimization"><on>true</on><step_interval>1</step_interval>
        <use_model_force_set>true</use_model_force_set></StaticOptimization>
    </objects><groups /></AnalysisSet>
    <coordinates_file>{motion}</coordinates_file>
  </AnalyzeTool>
</OpenSimDocument>
"""

best = float("inf")
for _ in range(repeats):
    out = tempfile.mkdtemp()
    model = osim.Model(os.path.join(REPO, "models", "leg_extension", "human_seated.osim"))
    for i in range(model.getCoordinateSet().getSize()):
        c = model.getCoordinateSet().get(i)
        if c.getName() not in ("knee_angle_r", "knee_angle_l"):
            c.setDefaultLocked(True)
    model_file = os.path.join(out, "human_seated_knees_free.osim")
    model.printToXML(model_file)
    setup = os.path.join(out, "setup.xml")
    with open(setup, "w") as fh:
        fh.write(SETUP.format(model=model_file,
                              out=out, motion=os.path.join(REPO, "motions", "leg_extension.mot")))
    tool = osim.AnalyzeTool(setup)
    start = time.perf_counter()
    tool.run()
    best = min(best, time.perf_counter() - start)
    act = [f for f in os.listdir(out) if f.endswith("activation.sto")]
    rows = 0
    if act:
        with open(os.path.join(out, act[0])) as fh:
            lines = fh.read().splitlines()
        rows = len(lines) - lines.index("endheader") - 2
print(f"frames {rows}, best run {best:.3f} s, {1000 * best / max(rows, 1):.2f} ms per frame")
