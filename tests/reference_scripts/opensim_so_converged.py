# Re-run a validation case's setup_SO.xml with OpenSim 4.6 (pip install opensim==4.6) and
# optimizer_convergence_criterion 1e-10, writing to /tmp/os_tight/<case>. Produced
# tests/data/opensim46_converged/arm26_SO_tol1e-10_*.sto (arm26 converges on every frame;
# leg6dof9musc and gait10dof18musc report OPTIMIZATION FAILED at such tolerances).
# tests/data/opensim46_converged/walk3d_StaticOptimization_tol1e-10_activation.sto comes from
# moco_walk3d the same way (see tests/validation_static_optimization.rs).
# Usage: python opensim_so_converged.py arm26
import opensim as osim, re, sys, os, time
case = sys.argv[1]
d = f"/work/shared/validation/{case}"
s = open(f"{d}/setup_SO.xml").read()
s = s.replace(">inputs/", f">{d}/inputs/").replace(" inputs/", f" {d}/inputs/")
s = re.sub(r"<results_directory>.*?</results_directory>", f"<results_directory>/tmp/os_tight/{case}</results_directory>", s)
s = re.sub(r"<output_precision>.*?</output_precision>", "<output_precision>10</output_precision>", s)
# The setup's own criterion and iteration limit are replaced (moco_walk3d gives both);
# setups without them get them after use_muscle_physiology.
s = re.sub(r"<optimizer_convergence_criterion>.*?</optimizer_convergence_criterion>", "", s)
s = re.sub(r"<optimizer_max_iterations>.*?</optimizer_max_iterations>", "", s)
s = s.replace("<use_muscle_physiology>true</use_muscle_physiology>", "<use_muscle_physiology>true</use_muscle_physiology><optimizer_convergence_criterion>1e-10</optimizer_convergence_criterion><optimizer_max_iterations>2000</optimizer_max_iterations>")
open(f"/tmp/os_tight/setup_{case}.xml","w").write(s)
t=time.time()
osim.AnalyzeTool(f"/tmp/os_tight/setup_{case}.xml").run()
print(case, "done", time.time()-t)
