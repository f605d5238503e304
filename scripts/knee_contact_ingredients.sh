#!/bin/sh
# The ingredient table of docs/knee_contact.md: GC5 trial ss1 (../shared/models/knee_gc5) run as OpenSim's
# static optimization + JointReaction, with one axial contact per knee, with the knee contact method (two
# compartments, default capacity 1.73 BW each) and over the compartment capacity; each compared with the
# eTibia by scripts/knee_contact_etibia.py.
# Usage: cargo build --release --bin statopt-tool && scripts/knee_contact_ingredients.sh [OUT]
set -e
cd "$(dirname "$0")/.."
G=$(cd ../shared/models/knee_gc5 && pwd)
OUT=${1:-/tmp/knee_contact_ingredients}
mkdir -p "$OUT"
variant() { # name extra-StaticOptimization-properties
  sed -e "s#>Rajagopal2015-scaled.osim<#>$G/Rajagopal2015-scaled.osim<#" \
      -e "s#ForceSet.xml residuals.xml#$G/ForceSet.xml $G/residuals.xml#" \
      -e "s#>GC5_ss1_loads.xml<#>$G/GC5_ss1_loads.xml<#" -e "s#>GC5_ss1.mot<#>$G/GC5_ss1.mot<#" \
      -e "s#<use_muscle_physiology>true</use_muscle_physiology>#<use_muscle_physiology>true</use_muscle_physiology>$2#" \
      "$G/setup_ss1.xml" > "$OUT/setup_$1.xml"
  target/release/statopt-tool "$OUT/setup_$1.xml" -o "$OUT/$1" -q
}
variant plain ""
variant axial "<knee_contact>axial</knee_contact>"
variant method "<knee_contact>all</knee_contact>"
CAPS="0.5 1 1.25 1.5 2 2.5 3 3.46 5 10"
for c in $CAPS; do
  variant "capacity_$c" "<knee_contact>all</knee_contact><knee_contact_capacity>$c</knee_contact_capacity>"
done
python3 scripts/knee_contact_etibia.py "$OUT/plain/GC5_ss1_JR_ReactionLoads.sto" "$OUT/axial/GC5_ss1_KneeContact.sto" \
  "$OUT/method/GC5_ss1_KneeContact.sto" $(for c in $CAPS; do echo "$OUT/capacity_$c/GC5_ss1_KneeContact.sto"; done)
