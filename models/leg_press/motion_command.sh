#!/bin/sh
# The shipped leg press motion, made by statopt's own motion tool. Written by
# scripts/make_leg_press_models.py (the --link constants, starting values of the solve, follow
# from the machine's dimensions). Run from the repository root after `cargo build --release`.
# One repetition: from near full extension down to the bottom of the press (eccentric), a
# 0.5 s pause, and back up (concentric), 2 s each way (minimum jerk).
# Each foot is planted on the plate: heel and forefoot keep their place on it (--plant),
# solved together with the sled's slide, the hips (3 each) and the ankles.
set -e
STATOPT=${STATOPT:-target/release/statopt-tool}
$STATOPT motion --setup setups/leg_press_rajagopal.xml \
  --coordinate knee_angle_r --also knee_angle_l --from 5 --to 95 --duration 2 \
  --hold-end 0.5 --return --rate 20 \
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
  --plant heel_r=sled_x,hip_flexion_r,hip_adduction_r,hip_rotation_r --plant forefoot_r=ankle_angle_r \
  --plant heel_l=hip_flexion_l,hip_adduction_l,hip_rotation_l --plant forefoot_l=ankle_angle_l \
  -o motions/leg_press_rajagopal.mot
