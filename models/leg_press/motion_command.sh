#!/bin/sh
# The shipped leg press motion, made by statopt's own motion tool. Written by
# scripts/make_leg_press_models.py (the link constants follow from the machine's dimensions).
# Run from the repository root after `cargo build --release`.
set -e
STATOPT=${STATOPT:-target/release/statopt-tool}
$STATOPT motion \
  --model models/leg_extension/human_seated_rajagopal.osim \
  --artifact models/leg_press/machine_leg_press.osim \
  --force-set models/leg_press/contacts_leg_press.xml \
  --coordinate knee_angle_r --also knee_angle_l --from 95 --to 5 --duration 5 --rate 20 \
  --link pelvis_tilt=0*knee_angle_r+20.000000 \
  --link lumbar_extension=0*knee_angle_r+0.000000 \
  --link hip_flexion_r=0.485113*knee_angle_r+70.503808 \
  --link hip_flexion_l=0.485113*knee_angle_r+70.503808 \
  --link hip_adduction_r=-0.015383*knee_angle_r+1.461423 \
  --link hip_adduction_l=-0.015383*knee_angle_r+1.461423 \
  --link hip_rotation_r=0.017457*knee_angle_r-1.658451 \
  --link hip_rotation_l=0.017457*knee_angle_r-1.658451 \
  --link ankle_angle_r=0.528231*knee_angle_r-15.836396 \
  --link ankle_angle_l=0.528231*knee_angle_r-15.836396 \
  --touch heel_r=sled_x --touch forefoot_r=ankle_angle_r --touch forefoot_l=ankle_angle_l \
  -o motions/leg_press_rajagopal.mot
