#!/bin/sh
# The ingredient table of docs/knee_contact.md: GC5 trial ss1 (../shared/models/knee_gc5) run as OpenSim's
# static optimization + JointReaction, with one axial contact per knee, with the knee contact method (two
# compartments; defaults: the knee's capacity 3.46 BW, 65 % of it medial), with equal compartments and free
# gastrocnemius heads (the method before issue 39), with free heads, at medial shares 0.5 to 0.8, and over the capacity (a compartment's at an
# even split, BW; the knee's is twice that); each compared with the eTibia by scripts/knee_contact_etibia.py.
# Usage: cargo build --release --bin statopt-tool && scripts/knee_contact_ingredients.sh [OUT]
set -e
cd "$(dirname "$0")/.."
G=$(cd ../shared/models/knee_gc5 && pwd)
OUT=${1:-/tmp/knee_contact_ingredients}
T=target/release/statopt-tool
[ -n "$CARGO_TARGET_DIR" ] && T=$CARGO_TARGET_DIR/release/statopt-tool
mkdir -p "$OUT"
variant() { # name extra-StaticOptimization-properties
  sed -e "s#>Rajagopal2015-scaled.osim<#>$G/Rajagopal2015-scaled.osim<#" \
      -e "s#ForceSet.xml residuals.xml#$G/ForceSet.xml $G/residuals.xml#" \
      -e "s#>GC5_ss1_loads.xml<#>$G/GC5_ss1_loads.xml<#" -e "s#>GC5_ss1.mot<#>$G/GC5_ss1.mot<#" \
      -e "s#<use_muscle_physiology>true</use_muscle_physiology>#<use_muscle_physiology>true</use_muscle_physiology>$2#" \
      "$G/setup_ss1.xml" > "$OUT/setup_$1.xml"
  "$T" "$OUT/setup_$1.xml" -o "$OUT/$1" -q
}
variant plain ""
variant axial "<knee_contact>axial</knee_contact>"
variant method "<knee_contact>all</knee_contact>"
variant before "<knee_contact>all</knee_contact><knee_contact_medial_share>0.5</knee_contact_medial_share><knee_contact_equal_activation>none</knee_contact_equal_activation>"
variant heads_free "<knee_contact>all</knee_contact><knee_contact_equal_activation>none</knee_contact_equal_activation>"
SHARES="0.5 0.6 0.7 0.75 0.8"
for s in $SHARES; do
  variant "share_$s" "<knee_contact>all</knee_contact><knee_contact_medial_share>$s</knee_contact_medial_share>"
done
CAPS="0.5 1 1.25 1.5 2 2.5 3 3.46 5 10"
for c in $CAPS; do
  variant "capacity_$c" "<knee_contact>all</knee_contact><knee_contact_capacity>$c</knee_contact_capacity>"
done
python3 scripts/knee_contact_etibia.py "$OUT/plain/GC5_ss1_JR_ReactionLoads.sto" "$OUT/axial/GC5_ss1_KneeContact.sto" \
  "$OUT/method/GC5_ss1_KneeContact.sto" "$OUT/before/GC5_ss1_KneeContact.sto" "$OUT/heads_free/GC5_ss1_KneeContact.sto" \
  $(for s in $SHARES; do echo "$OUT/share_$s/GC5_ss1_KneeContact.sto"; done) \
  $(for c in $CAPS; do echo "$OUT/capacity_$c/GC5_ss1_KneeContact.sto"; done)
