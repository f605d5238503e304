#!/usr/bin/env bash
# Regenerates the speed/accuracy charts and tables of docs/speed_accuracy.md:
# `statopt-tool bench SETUP --grid` on the leg extension study (cam 1, w0 = 1 and 1000) and on the
# OpenSim validation cases in ../shared/validation (skipped when absent), and gait2392 when
# ../shared/models/gait2392 is there. Each writes bench_grid.csv, .png and .svg into
# docs/figures/speed_accuracy/<case>/. OpenSim 4.6's per-frame times (reference lines) are the
# validation READMEs' measurements (run / frames) and, for the leg extension human,
# tests/reference_scripts/opensim_so_timing.py.
#
#   scripts/speed_accuracy.sh [repeats]        (default 3; takes about half a minute on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
repeat="${1:-3}"
cargo build --release --quiet
tool=target/release/statopt-tool
out=docs/figures/speed_accuracy
mkdir -p "$out"
# OpenSim 4.6, static optimization, ms per frame (see above).
opensim_leg_extension=59
"$tool" bench setups/leg_extension_cam1.xml --grid --repeat "$repeat" --contact-weight 1000 \
  --opensim-ms "$opensim_leg_extension" --out "$out/leg_extension_cam1_w0_1000"
"$tool" bench setups/leg_extension_cam1.xml --grid --repeat "$repeat" --contact-weight 1 \
  --opensim-ms "$opensim_leg_extension" --out "$out/leg_extension_cam1_w0_1"
v=../shared/validation
for c in arm26:5.4 leg6dof9musc_stance:35 gait10dof18musc_walk:15.5; do
  name="${c%%:*}"; ms="${c##*:}"
  if [ ! -f "$v/$name/setup_SO.xml" ]; then
    echo "SKIP: $v/$name absent"
    continue
  fi
  act=$(ls "$v/$name"/results/*_StaticOptimization_activation.sto)
  "$tool" bench "$v/$name/setup_SO.xml" --grid --repeat "$repeat" --opensim-ms "$ms" \
    --opensim-activations "$act" --out "$out/$name"
done
g=../shared/models/gait2392/subject01_walk/setup_SO.xml
if [ -f "$g" ]; then
  "$tool" bench "$g" --grid --repeat "$repeat" --opensim-ms 115 --out "$out/gait2392"
else
  echo "SKIP: $g absent"
fi
python3 scripts/speed_accuracy_tables.py > "$out/tables.md"
echo "wrote $out/tables.md"
