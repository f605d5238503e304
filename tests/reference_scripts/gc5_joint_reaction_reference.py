# OpenSim 4.6's JointReaction of walker_knee_l on the GC5 trial ss1 (../shared/models/knee_gc5), fed
# statopt's static-optimization forces, on a motion whose knee_angle_*_beta columns hold radians.
#
# Why radians: GC5_ss1.mot is a degrees file, and its beta columns hold degrees too. Their
# coordinates are Coupled, not Rotational, so OpenSim does not convert them; its assembler then
# corrects the positions through the coupler but keeps the speeds it splined from the unconverted
# column (57.3x too large), and the patella's velocity forces reach the knee through the coupler
# (docs/opensim_semantics_notes.md). Written in radians, the column agrees with the coupler and
# both tools see the same state.
#
# Produces tests/data/gc5_ss1_jr_opensim46.sto (used by tests/gc5_joint_reaction_reference.rs).
# Usage (OpenSim 4.6 in a venv: python3 -m venv V && V/bin/pip install opensim==4.6):
#   cargo build --release --bin statopt-tool
#   V/bin/python tests/reference_scripts/gc5_joint_reaction_reference.py [--store] [--degrees]
# --degrees also runs OpenSim on the shipped motion (beta columns in degrees) and prints how far its
# reaction lies from statopt's.
import math, os, re, subprocess, sys

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GC5 = os.path.normpath(os.path.join(REPO, "..", "shared", "models", "knee_gc5"))
OUT = "/tmp/gc5_jr_reference"
STORE = os.path.join(REPO, "tests", "data", "gc5_ss1_jr_opensim46.sto")


def radian_motion(src, dst):
    """GC5_ss1.mot with its *_beta columns converted from degrees to radians (the header still
    says inDegrees=yes: OpenSim converts only Rotational coordinates' columns, statopt too)."""
    lines = open(src).read().splitlines()
    end = next(i for i, l in enumerate(lines) if l.strip() == "endheader")
    labels = lines[end + 1].split("\t")
    beta = [i for i, l in enumerate(labels) if l.endswith("_beta")]
    out = lines[: end + 2]
    for l in lines[end + 2:]:
        v = l.split()
        for i in beta:
            v[i] = "%.12f" % math.radians(float(v[i]))
        out.append("\t".join(v))
    open(dst, "w").write("\n".join(out) + "\n")


def setup(name, analyses, results, motion):
    s = open(os.path.join(GC5, "setup_ss1.xml")).read()
    s = s.replace('name="GC5_ss1"', f'name="{name}"')
    s = s.replace(">Rajagopal2015-scaled.osim<", f">{GC5}/Rajagopal2015-scaled.osim<")
    s = s.replace("ForceSet.xml residuals.xml", f"{GC5}/ForceSet.xml {GC5}/residuals.xml")
    s = s.replace(">GC5_ss1_loads.xml<", f">{GC5}/GC5_ss1_loads.xml<")
    s = s.replace(">GC5_ss1.mot<", f">{motion}<")
    s = re.sub(r"<results_directory>.*?</results_directory>",
               f"<results_directory>{results}</results_directory>", s)
    s = re.sub(r"<objects>.*</objects>", "<objects>" + analyses + "</objects>", s, flags=re.S)
    path = os.path.join(OUT, f"setup_{name}.xml")
    open(path, "w").write(s)
    return path


def read_sto(path):
    lines = open(path).read().splitlines()
    end = next(i for i, l in enumerate(lines) if l.strip() == "endheader")
    labels = lines[end + 1].split("\t")
    rows = [[float(x) for x in l.split()] for l in lines[end + 2:] if l.strip()]
    return labels, rows


def main():
    os.makedirs(OUT, exist_ok=True)
    motion = os.path.join(OUT, "GC5_ss1_beta_radians.mot")
    radian_motion(os.path.join(GC5, "GC5_ss1.mot"), motion)
    so = open(os.path.join(GC5, "setup_ss1.xml")).read()
    analyses = re.search(r"<objects>(.*)</objects>", so, re.S).group(1)
    # statopt: static optimization + JointReaction (its forces file: the SO's own forces).
    sp = setup("GC5_ss1_rad", analyses, os.path.join(OUT, "statopt"), motion)
    subprocess.run([os.path.join(REPO, "target", "release", "statopt-tool"), sp, "--quiet",
                    "--precision", "12"], check=True)
    forces = os.path.join(OUT, "statopt", "GC5_ss1_rad_SO_force.sto")
    # OpenSim: JointReaction alone, fed statopt's forces.
    jr = re.search(r"<JointReaction.*?</JointReaction>", analyses, re.S).group(0)
    jr = jr.replace("<forces_file />", f"<forces_file>{forces}</forces_file>")
    op = setup("GC5_ss1_rad", jr, os.path.join(OUT, "opensim"), motion)
    import opensim as osim
    tool = osim.AnalyzeTool(op)
    tool.run()
    ours = os.path.join(OUT, "statopt", "GC5_ss1_rad_JR_ReactionLoads.sto")
    theirs = os.path.join(OUT, "opensim", "GC5_ss1_rad_JR_ReactionLoads.sto")
    la, ra = read_sto(ours)
    lb, rb = read_sto(theirs)
    worst = 0.0
    for j, lab in enumerate(lb[1:], 1):
        k = la.index(lab)
        peak = max(abs(r[j]) for r in rb)
        d = max(abs(r[j] - s[k]) for r, s in zip(rb, ra))
        worst = max(worst, d / peak if peak > 0 else 0)
        print(f"{lab:40s} peak {peak:10.3f}  max|diff| {d:.4g}  ({100 * d / peak if peak else 0:.4f} % of peak)")
    print(f"worst: {100 * worst:.4f} % of a column's peak")
    if "--degrees" in sys.argv:
        # The same JointReaction on the shipped motion (beta columns in degrees): OpenSim's
        # positions agree (the coupler), its coupled speeds do not.
        opd = setup("GC5_ss1_deg", jr, os.path.join(OUT, "opensim_degrees"), os.path.join(GC5, "GC5_ss1.mot"))
        osim.AnalyzeTool(opd).run()
        ld, rd = read_sto(os.path.join(OUT, "opensim_degrees", "GC5_ss1_deg_JR_ReactionLoads.sto"))
        for j, lab in enumerate(ld[1:4], 1):
            k = la.index(lab)
            d, t = max((abs(r[j] - s[k]), r[0]) for r, s in zip(rd, ra))
            print(f"degrees file: {lab} max|OpenSim - statopt| {d:.1f} N at t = {t:.4f}")
    if "--store" in sys.argv:
        # The force and moment columns only (the point columns are the joint centre).
        keep = [0] + [j for j, l in enumerate(lb) if l.endswith(("_fx", "_fy", "_fz", "_mx", "_my", "_mz"))]
        with open(STORE, "w") as f:
            f.write("Joint Reaction Loads (OpenSim 4.6, fed statopt's forces; "
                    "tests/reference_scripts/gc5_joint_reaction_reference.py)\nversion=1\n")
            f.write(f"nRows={len(rb)}\nnColumns={len(keep)}\ninDegrees=no\nendheader\n")
            f.write("\t".join(lb[j] for j in keep) + "\n")
            for r in rb:
                f.write("\t".join(("%.8f" if j == 0 else "%.6f") % r[j] for j in keep) + "\n")
        print("stored", STORE)


if __name__ == "__main__":
    main()
