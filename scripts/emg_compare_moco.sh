#!/bin/sh
# The EMG table of docs/emg_compare.md and docs/knee_contact.md: OpenSim Moco's 3-D walk
# (../shared/validation/moco_walk3d, EMG in ../shared/models/moco_walk3d/electromyography.sto, right leg)
# solved by plain static optimization, by the knee contact method (defaults: the knee's capacity 3.46 BW,
# 65 % of it medial, the gastrocnemius heads at one activation), by the method before issue 39 (equal
# compartments, free heads), with free heads, and by the method's variants of docs/knee_contact.md (medial share 0.5, 0.6, 0.7, 0.75, 0.8;
# capacity 2 and 2.5 BW per compartment on average); each compared with the EMG by statopt-tool emg-compare
# (default map, no delay), the first two also drawn (OUT/emg_compare.png).
# Usage: cargo build --release --bin statopt-tool && scripts/emg_compare_moco.sh [OUT]
set -e
cd "$(dirname "$0")/.."
V=$(cd ../shared/validation/moco_walk3d && pwd)
EMG=$(cd ../shared/models/moco_walk3d && pwd)/electromyography.sto
OUT=${1:-/tmp/emg_compare_moco}
T=target/release/statopt-tool
[ -n "$CARGO_TARGET_DIR" ] && T=$CARGO_TARGET_DIR/release/statopt-tool
mkdir -p "$OUT"
variant() { # name extra-StaticOptimization-properties
  sed -e "s#inputs/#$V/inputs/#g" \
      -e "s#<use_muscle_physiology>true</use_muscle_physiology>#<use_muscle_physiology>true</use_muscle_physiology>$2#" \
      "$V/setup_SO.xml" > "$OUT/setup_$1.xml"
  $T "$OUT/setup_$1.xml" -o "$OUT/$1" -q
}
variant plain ""
variant method "<knee_contact>all</knee_contact>"
variant before "<knee_contact>all</knee_contact><knee_contact_medial_share>0.5</knee_contact_medial_share><knee_contact_equal_activation>none</knee_contact_equal_activation>"
variant heads_free "<knee_contact>all</knee_contact><knee_contact_equal_activation>none</knee_contact_equal_activation>"
variant share_0.5 "<knee_contact>all</knee_contact><knee_contact_medial_share>0.5</knee_contact_medial_share>"
variant share_0.6 "<knee_contact>all</knee_contact><knee_contact_medial_share>0.6</knee_contact_medial_share>"
variant share_0.7 "<knee_contact>all</knee_contact><knee_contact_medial_share>0.7</knee_contact_medial_share>"
variant share_0.75 "<knee_contact>all</knee_contact><knee_contact_medial_share>0.75</knee_contact_medial_share>"
variant share_0.8 "<knee_contact>all</knee_contact><knee_contact_medial_share>0.8</knee_contact_medial_share>"
variant capacity_2 "<knee_contact>all</knee_contact><knee_contact_capacity>2</knee_contact_capacity>"
variant capacity_2.5 "<knee_contact>all</knee_contact><knee_contact_capacity>2.5</knee_contact_capacity>"
A=walk3d_StaticOptimization_activation.sto
$T emg-compare "$EMG" "$OUT/plain/$A" "$OUT/method/$A" --label "plain SO" --label "knee method" -o "$OUT/emg_compare"
$T emg-compare "$EMG" "$OUT/plain/$A" "$OUT/method/$A" --label "plain SO" --label "knee method" --delay-ms 50 \
  -o "$OUT/emg_compare_delay50" | grep -E "^[a-z]|mean|gastro|vastus_medius"
for v in before heads_free share_0.5 share_0.6 share_0.7 share_0.75 share_0.8 capacity_2 capacity_2.5; do
  $T emg-compare "$EMG" "$OUT/$v/$A" --label "$v" -o "$OUT/emg_compare_$v" | grep -E "^[a-z]|mean|gastro|vastus_"
done
