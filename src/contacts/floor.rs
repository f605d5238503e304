//! Is the floor a treadmill belt or the ground, and how fast does the belt
//! run? Decided from the motion by a stated test (issue 27), or given.
//!
//! **Evidence** (over the analysed frames only: a low-pass filter pads the
//! motion before and after the trial with reflected copies, in which the
//! feet swing *below* the floor; those frames are no evidence):
//! - the walking direction h: the root body's (pelvis's) x axis, projected
//!   on the floor and averaged (OpenSim's models face +x);
//! - the pelvis's mean horizontal velocity over the trial (its displacement
//!   over the time);
//! - per foot, its **stance frames**: the foot's lowest point within
//!   [`STANCE_BAND`] of the floor level (each foot's level is the
//!   [`LEVEL_QUANTILE`] quantile of its lowest point's height; the floor the
//!   lower of the two) and moving vertically slower than
//!   [`STANCE_VERTICAL_SPEED`]; the foot's stance velocity is the median
//!   horizontal velocity of its lowest point over them. A foot rolling over
//!   its sole pivots about its lowest point, so that point moves with the
//!   floor whatever the foot does.
//!
//! **The test.** On a treadmill the body stays in place and the stance feet
//! move back with the belt; overground the body moves forward and the stance
//! feet stand still. With s the stance feet's velocity along h (the mean of
//! the two feet) and p the pelvis's, the body moves over its stance feet at
//! w = p − s, and the belt's share of that is r = −s / w: 1 on a treadmill,
//! 0 overground. The floor is a **treadmill** when every one of these holds:
//! both feet have at least [`MIN_STANCE_SECONDS`] of stance; w > 0.2 m/s;
//! r ≥ [`TREADMILL_SHARE`]; the two feet's stance velocities agree within
//! [`FEET_AGREE`] (or 0.3 m/s); the belt points backward, within
//! [`BELT_MAX_ANGLE_DEG`] of −h; and it is slower than [`BELT_MAX_SPEED`].
//! It is **overground** when the stance feet stand still (|s| below
//! [`crate::contacts::feet::BELT_THRESHOLD`]) or r ≤ 1 − [`TREADMILL_SHARE`].
//! Anything else (no stance, a trial shorter than a stance, the feet
//! disagreeing, a belt running forward or faster than 7 m/s) is weak or
//! contradictory evidence: the floor is taken as the ground (overground)
//! and the decision says why.

use nalgebra::Vector3;

/// How the floor moves: decided from the motion, or given by the user
/// (`--overground`, `--treadmill SPEED|VX,VY,VZ`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FloorMotion {
    /// Decide from the motion ([`decide`]).
    Auto,
    /// The ground: the floor does not move.
    Overground,
    /// A treadmill whose belt runs backward at this speed (m/s) along the
    /// walking direction (positive: backward, as a treadmill is set).
    TreadmillSpeed(f64),
    /// A treadmill belt with this velocity (ground frame, m/s).
    TreadmillVelocity(Vector3<f64>),
}

/// Where a decision came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecisionSource {
    /// The user gave it.
    Given,
    /// The motion's evidence decided it.
    Evidence,
    /// The evidence was weak or contradictory: overground by default.
    Fallback,
}

/// The evidence the decision is made from (see the module doc).
#[derive(Debug, Clone, Default)]
pub struct MotionEvidence {
    /// Walking direction (unit, horizontal; ground).
    pub heading: Vector3<f64>,
    /// The pelvis's mean horizontal velocity over the trial (m/s).
    pub pelvis_velocity: Vector3<f64>,
    /// Per foot (right, left): median horizontal velocity of its lowest
    /// point over its stance frames (None: no stance), their number and
    /// their time (s).
    pub stance_velocity: [Option<Vector3<f64>>; 2],
    pub stance_frames: [usize; 2],
    pub stance_seconds: [f64; 2],
    /// Height of the floor the stance frames were found against (m).
    pub floor_level: f64,
    /// Length of the analysed trial (s).
    pub duration: f64,
}

/// The floor used: treadmill or ground, the belt's velocity, and why.
#[derive(Debug, Clone)]
pub struct FloorDecision {
    pub treadmill: bool,
    /// Horizontal belt velocity (zero overground; ground frame, m/s).
    pub belt_velocity: Vector3<f64>,
    pub source: DecisionSource,
    /// One sentence: what was chosen and why (for the run's summary).
    pub reason: String,
    pub evidence: MotionEvidence,
}

impl FloorDecision {
    /// "treadmill 3.02 m/s" or "overground", and where the choice came
    /// from when it was not the evidence ("given", "by default").
    pub fn label(&self) -> String {
        let how = match self.source {
            DecisionSource::Given => " (given)",
            DecisionSource::Evidence => "",
            DecisionSource::Fallback => " (by default)",
        };
        if self.treadmill {
            format!("treadmill {:.2} m/s{how}", self.belt_velocity.norm())
        } else {
            format!("overground{how}")
        }
    }
}

/// Stance: the foot's lowest point within this height of the floor (m).
pub const STANCE_BAND: f64 = 0.02;
/// Stance: the lowest point moves vertically slower than this (m/s).
pub const STANCE_VERTICAL_SPEED: f64 = 0.2;
/// A foot's floor level: this quantile of its lowest point's height over
/// the trial (a few frames sinking below the floor do not move it).
pub const LEVEL_QUANTILE: f64 = 0.1;
/// Least stance per foot (s) for evidence of a belt: the shortest stance of
/// sprinting is about 0.1 s; half of it must be seen on each foot.
pub const MIN_STANCE_SECONDS: f64 = 0.05;
/// Belt share r of the body's speed over its stance feet at or above which
/// the floor is a treadmill (at or below 1 − this: overground).
pub const TREADMILL_SHARE: f64 = 0.75;
/// The two feet's stance velocities agree within this share of the belt speed.
pub const FEET_AGREE: f64 = 0.25;
/// A belt is never faster than this (m/s): faster than a sprinter's top
/// speed on a treadmill is not a belt.
pub const BELT_MAX_SPEED: f64 = 7.0;
/// The belt runs backward, within this angle of −h (degrees).
pub const BELT_MAX_ANGLE_DEG: f64 = 30.0;

/// One foot point's track: its side ('r' or 'l'), ground positions and
/// velocities per frame.
pub struct PointTrack<'a> {
    pub side: char,
    pub positions: &'a [Vector3<f64>],
    pub velocities: &'a [Vector3<f64>],
}

fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The evidence over the frames `frames` (indices into the tracks, in time
/// order): `time` per frame, the pelvis's origin and a point one unit along
/// its x axis (ground) per frame, and the foot points' tracks.
pub fn evidence(
    time: &[f64],
    frames: &[usize],
    pelvis: &[Vector3<f64>],
    pelvis_x: &[Vector3<f64>],
    points: &[PointTrack],
) -> MotionEvidence {
    let mut ev = MotionEvidence::default();
    let (Some(&first), Some(&last)) = (frames.first(), frames.last()) else {
        return ev;
    };
    ev.duration = time[last] - time[first];
    let horizontal = |v: Vector3<f64>| Vector3::new(v.x, 0.0, v.z);
    let mut h = Vector3::zeros();
    for &i in frames {
        let d = horizontal(pelvis_x[i] - pelvis[i]);
        if d.norm() > 1e-9 {
            h += d.normalize();
        }
    }
    ev.heading = if h.norm() > 1e-9 {
        h.normalize()
    } else {
        Vector3::x()
    };
    if ev.duration > 0.0 {
        ev.pelvis_velocity = horizontal(pelvis[last] - pelvis[first]) / ev.duration;
    }
    // Per foot and frame: the lowest point (its height, velocity).
    let mut lowest: [Vec<(f64, Vector3<f64>)>; 2] = [Vec::new(), Vec::new()];
    for (s, side) in ['r', 'l'].into_iter().enumerate() {
        let tracks: Vec<&PointTrack> = points.iter().filter(|p| p.side == side).collect();
        if tracks.is_empty() {
            continue;
        }
        for &i in frames {
            let k = (0..tracks.len())
                .min_by(|&a, &b| {
                    tracks[a].positions[i]
                        .y
                        .total_cmp(&tracks[b].positions[i].y)
                })
                .expect("not empty");
            lowest[s].push((tracks[k].positions[i].y, tracks[k].velocities[i]));
        }
    }
    let level = |l: &[(f64, Vector3<f64>)]| {
        let mut h: Vec<f64> = l.iter().map(|x| x.0).collect();
        quantile(&mut h, LEVEL_QUANTILE)
    };
    let floor = lowest
        .iter()
        .filter(|l| !l.is_empty())
        .map(|l| level(l))
        .fold(f64::INFINITY, f64::min);
    ev.floor_level = floor;
    let dt = if frames.len() > 1 {
        ev.duration / (frames.len() - 1) as f64
    } else {
        0.0
    };
    for s in 0..2 {
        let stance: Vec<Vector3<f64>> = lowest[s]
            .iter()
            .filter(|(y, v)| *y < floor + STANCE_BAND && v.y.abs() < STANCE_VERTICAL_SPEED)
            .map(|(_, v)| horizontal(*v))
            .collect();
        ev.stance_frames[s] = stance.len();
        ev.stance_seconds[s] = stance.len() as f64 * dt;
        if !stance.is_empty() {
            let mut x: Vec<f64> = stance.iter().map(|v| v.x).collect();
            let mut z: Vec<f64> = stance.iter().map(|v| v.z).collect();
            ev.stance_velocity[s] = Some(Vector3::new(
                quantile(&mut x, 0.5),
                0.0,
                quantile(&mut z, 0.5),
            ));
        }
    }
    ev
}

/// Decide the floor from `ev` (the test of the module doc), or take the
/// user's `given` choice.
pub fn decide(ev: MotionEvidence, given: FloorMotion) -> FloorDecision {
    let h = ev.heading;
    let fixed = |source, reason: String, ev: MotionEvidence| FloorDecision {
        treadmill: false,
        belt_velocity: Vector3::zeros(),
        source,
        reason,
        evidence: ev,
    };
    match given {
        FloorMotion::Overground => {
            return fixed(
                DecisionSource::Given,
                "overground: given (--overground)".into(),
                ev,
            )
        }
        FloorMotion::TreadmillSpeed(v) => {
            let belt = -v * h;
            return FloorDecision {
                treadmill: true,
                belt_velocity: belt,
                source: DecisionSource::Given,
                reason: format!(
                    "treadmill: given (--treadmill {v}), belt {v:.3} m/s backward along the walking direction ({:.3}, {:.3}, {:.3})",
                    h.x, h.y, h.z
                ),
                evidence: ev,
            };
        }
        FloorMotion::TreadmillVelocity(v) => {
            return FloorDecision {
                treadmill: true,
                belt_velocity: v,
                source: DecisionSource::Given,
                reason: format!(
                    "treadmill: given (--treadmill), belt velocity ({:.3}, {:.3}, {:.3}) m/s",
                    v.x, v.y, v.z
                ),
                evidence: ev,
            };
        }
        FloorMotion::Auto => {}
    }
    let p = ev.pelvis_velocity.dot(&h);
    let feet: Vec<Vector3<f64>> = ev.stance_velocity.iter().flatten().copied().collect();
    let facts = {
        let foot = |s: usize| match ev.stance_velocity[s] {
            Some(v) => format!(
                "{:.2} m/s along it over {:.2} s of stance",
                v.dot(&h),
                ev.stance_seconds[s]
            ),
            None => "no stance".into(),
        };
        format!(
            "pelvis {p:.2} m/s along the walking direction, right foot {}, left foot {}",
            foot(0),
            foot(1)
        )
    };
    if feet.is_empty() {
        return fixed(
            DecisionSource::Fallback,
            format!("overground by default: no foot was seen in stance over the {:.2} s analysed, so nothing shows a belt ({facts})", ev.duration),
            ev,
        );
    }
    let belt = feet.iter().sum::<Vector3<f64>>() / feet.len() as f64;
    let s = belt.dot(&h);
    let speed = belt.norm();
    if speed < super::feet::BELT_THRESHOLD {
        return fixed(
            DecisionSource::Evidence,
            format!("overground: the stance feet stand still ({facts})"),
            ev,
        );
    }
    let w = p - s;
    let r = if w > 0.2 { -s / w } else { f64::NAN };
    let both = ev.stance_seconds.iter().all(|&t| t >= MIN_STANCE_SECONDS)
        && ev.stance_velocity.iter().all(Option::is_some);
    let agree = both && {
        let (a, b) = (
            ev.stance_velocity[0].expect("both"),
            ev.stance_velocity[1].expect("both"),
        );
        (a - b).norm() <= (FEET_AGREE * speed).max(0.3)
    };
    let angle = (-s / speed).clamp(-1.0, 1.0).acos().to_degrees();
    if r <= 1.0 - TREADMILL_SHARE {
        return fixed(
            DecisionSource::Evidence,
            format!("overground: the body moves over still stance feet (belt share {r:.2} <= {:.2}; {facts})", 1.0 - TREADMILL_SHARE),
            ev,
        );
    }
    let mut against = Vec::new();
    if !both {
        against.push(format!(
            "not both feet show {MIN_STANCE_SECONDS} s of stance"
        ));
    } else if !agree {
        against.push("the two stance feet move at different velocities".to_string());
    }
    if w.is_nan() || w <= 0.2 {
        against.push("the body does not move forward over its stance feet".into());
    } else if r < TREADMILL_SHARE {
        against.push(format!(
            "the belt's share of the body's speed over its feet is {r:.2}, neither treadmill (>= {TREADMILL_SHARE}) nor overground (<= {:.2})",
            1.0 - TREADMILL_SHARE
        ));
    }
    if angle > BELT_MAX_ANGLE_DEG {
        against.push(format!(
            "the belt found points {angle:.0} deg away from backward (the walking direction is ({:.2}, {:.2}, {:.2}))",
            h.x, h.y, h.z
        ));
    }
    if speed > BELT_MAX_SPEED {
        against.push(format!(
            "the belt found runs at {speed:.2} m/s, faster than {BELT_MAX_SPEED} m/s"
        ));
    }
    if against.is_empty() {
        FloorDecision {
            treadmill: true,
            belt_velocity: belt,
            source: DecisionSource::Evidence,
            reason: format!(
                "treadmill: the pelvis stays in place while both stance feet move back together at {:.2} m/s (belt share {r:.2} >= {TREADMILL_SHARE}; {facts})",
                -s
            ),
            evidence: ev,
        }
    } else {
        fixed(
            DecisionSource::Fallback,
            format!(
                "overground by default: the stance feet move ({:.2}, {:.2}) m/s, but {}; a belt is not accepted on this evidence ({facts}); give --treadmill SPEED if there is one",
                belt.x,
                belt.z,
                against.join("; ")
            ),
            ev,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::filter::pad_signal;

    /// A synthetic gait: per foot two points (heel, toe 0.15 m ahead) on a
    /// floor at y = 0; stance for `duty` of each `period`, the left foot half
    /// a period behind; in stance the foot moves with the floor at `floor_v`
    /// (m/s along x); in swing it lifts 0.15 m (running) and comes forward.
    /// The pelvis moves at `pelvis_v`. Sampled at `rate` Hz over `duration`
    /// s, then padded on both sides by half its length with reflected copies
    /// (as the low-pass filter does) and differentiated: what predict-grf
    /// sees. Returns (time, analysed frames, pelvis, pelvis + x, tracks as
    /// (side, positions, velocities)).
    #[allow(clippy::type_complexity)]
    fn gait(
        pelvis_v: f64,
        floor_v: f64,
        period: f64,
        duty: f64,
        duration: f64,
        rate: f64,
        lift: f64,
    ) -> (
        Vec<f64>,
        Vec<usize>,
        Vec<Vector3<f64>>,
        Vec<Vector3<f64>>,
        Vec<(char, Vec<Vector3<f64>>, Vec<Vector3<f64>>)>,
    ) {
        let n = (duration * rate).round() as usize + 1;
        let t: Vec<f64> = (0..n).map(|i| 0.17 + i as f64 / rate).collect();
        let stance = duty * period;
        // Foot x over one cycle: in stance it travels floor_v * stance (with
        // the floor) from where it landed; in swing it comes forward to land
        // where the cycle's motion of the body (pelvis_v * period) puts it.
        let foot = |tt: f64, offset: f64| -> (f64, f64) {
            let c = ((tt - 0.17) / period + offset).floor();
            let ph = (tt - 0.17) / period + offset - c;
            let t_in = ph * period;
            let land = c * pelvis_v * period + 0.3 - 0.5 * floor_v * stance;
            if t_in < stance {
                (land + floor_v * t_in, 0.0)
            } else {
                let a = (t_in - stance) / (period - stance);
                let from = land + floor_v * stance;
                let to = land + pelvis_v * period;
                let blend = 0.5 - 0.5 * (std::f64::consts::PI * a).cos();
                (
                    from + (to - from) * blend,
                    lift * (std::f64::consts::PI * a).sin(),
                )
            }
        };
        let pad = n / 2;
        let tp = pad_signal(pad, &t);
        let dt = 1.0 / rate;
        let deriv = |v: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
            (0..v.len())
                .map(|i| {
                    let (a, b) = (i.saturating_sub(1), (i + 1).min(v.len() - 1));
                    (v[b] - v[a]) / ((b - a) as f64 * dt)
                })
                .collect()
        };
        let padded = |f: &dyn Fn(f64) -> Vector3<f64>| -> Vec<Vector3<f64>> {
            let raw: Vec<Vector3<f64>> = t.iter().map(|&tt| f(tt)).collect();
            let c = |k: usize| pad_signal(pad, &raw.iter().map(|v| v[k]).collect::<Vec<f64>>());
            let (x, y, z) = (c(0), c(1), c(2));
            (0..x.len())
                .map(|i| Vector3::new(x[i], y[i], z[i]))
                .collect()
        };
        let pelvis = padded(&|tt| Vector3::new(pelvis_v * (tt - 0.17), 1.0, 0.0));
        let pelvis_x = padded(&|tt| Vector3::new(pelvis_v * (tt - 0.17) + 1.0, 1.0, 0.0));
        let mut tracks = Vec::new();
        for (side, offset, z) in [('r', 0.0, 0.1), ('l', 0.5, -0.1)] {
            for dx in [0.0, 0.15] {
                let p = padded(&|tt| {
                    let (x, y) = foot(tt, offset);
                    Vector3::new(x + dx, y, z)
                });
                let v = deriv(&p);
                tracks.push((side, p, v));
            }
        }
        let frames: Vec<usize> = (pad..pad + n).collect();
        (tp, frames, pelvis, pelvis_x, tracks)
    }

    fn run(
        g: &(
            Vec<f64>,
            Vec<usize>,
            Vec<Vector3<f64>>,
            Vec<Vector3<f64>>,
            Vec<(char, Vec<Vector3<f64>>, Vec<Vector3<f64>>)>,
        ),
    ) -> FloorDecision {
        let tracks: Vec<PointTrack> =
            g.4.iter()
                .map(|(s, p, v)| PointTrack {
                    side: *s,
                    positions: p,
                    velocities: v,
                })
                .collect();
        decide(evidence(&g.0, &g.1, &g.2, &g.3, &tracks), FloorMotion::Auto)
    }

    /// The method before issue 27, for contrast: over every frame the
    /// motion holds, the floor at the median of the points' lowest heights,
    /// the belt the median horizontal velocity of the points within 1 cm of
    /// it (a fixed floor below 0.2 m/s).
    fn old_median_belt(
        g: &(
            Vec<f64>,
            Vec<usize>,
            Vec<Vector3<f64>>,
            Vec<Vector3<f64>>,
            Vec<(char, Vec<Vector3<f64>>, Vec<Vector3<f64>>)>,
        ),
    ) -> f64 {
        let mut lowest: Vec<f64> =
            g.4.iter()
                .map(|(_, p, _)| p.iter().map(|q| q.y).fold(f64::INFINITY, f64::min))
                .collect();
        let floor = quantile(&mut lowest, 0.5);
        let mut vx: Vec<f64> =
            g.4.iter()
                .flat_map(|(_, p, v)| {
                    p.iter()
                        .zip(v)
                        .filter(|(q, _)| q.y < floor + 0.01)
                        .map(|(_, v)| v.x)
                })
                .collect();
        let b = quantile(&mut vx, 0.5);
        if b.abs() > 0.2 {
            b
        } else {
            0.0
        }
    }

    /// Treadmill running at 3 m/s (120 Hz, 4 s, flight phases): the belt
    /// comes back at 3 m/s backward. The old median over every frame, the
    /// filter's reflected padding included, found something else.
    #[test]
    fn treadmill_running_is_found_at_its_speed() {
        let g = gait(0.0, -3.0, 0.7, 0.33, 4.0, 120.0, 0.15);
        let d = run(&g);
        assert!(
            d.treadmill && d.source == DecisionSource::Evidence,
            "{}",
            d.reason
        );
        assert!(
            (d.belt_velocity.x + 3.0).abs() < 0.05,
            "{:?}",
            d.belt_velocity
        );
        assert!(d.belt_velocity.z.abs() < 0.05);
        let old = old_median_belt(&g);
        assert!((old + 3.0).abs() > 0.5, "the old median found {old}");
    }

    /// Treadmill walking at 1.2 m/s (100 Hz, 3 s).
    #[test]
    fn treadmill_walking_is_found_at_its_speed() {
        let g = gait(0.0, -1.2, 1.1, 0.6, 3.0, 100.0, 0.05);
        let d = run(&g);
        assert!(d.treadmill, "{}", d.reason);
        assert!(
            (d.belt_velocity.x + 1.2).abs() < 0.05,
            "{:?}",
            d.belt_velocity
        );
    }

    /// One overground gait cycle of 1.4 s at 1.3 m/s: overground, no belt.
    /// The old median found a belt.
    #[test]
    fn short_overground_walking_has_no_belt() {
        let g = gait(1.3, 0.0, 1.1, 0.6, 1.4, 100.0, 0.05);
        let d = run(&g);
        assert!(
            !d.treadmill && d.source == DecisionSource::Evidence,
            "{}",
            d.reason
        );
        assert_eq!(d.belt_velocity, Vector3::zeros());
        let old = old_median_belt(&g);
        assert!(old.abs() > 0.2, "the old median found {old}");
    }

    /// One overground step of 0.5 s at 1.3 m/s: overground.
    #[test]
    fn one_overground_step_has_no_belt() {
        let g = gait(1.3, 0.0, 1.1, 0.6, 0.5, 100.0, 0.05);
        let d = run(&g);
        assert!(!d.treadmill, "{}", d.reason);
    }

    /// Feet that move forward in stance while the pelvis stays: not a belt
    /// (belts run backward); overground, said so.
    #[test]
    fn a_belt_running_forward_is_not_accepted() {
        let g = gait(0.0, 2.0, 0.7, 0.33, 3.0, 120.0, 0.15);
        let d = run(&g);
        assert!(
            !d.treadmill && d.source == DecisionSource::Fallback,
            "{}",
            d.reason
        );
        assert!(d.reason.contains("backward"), "{}", d.reason);
    }

    /// A "belt" of 8 m/s is faster than anyone runs on one: refused.
    #[test]
    fn a_belt_faster_than_7_m_per_s_is_not_accepted() {
        let g = gait(0.0, -8.0, 0.5, 0.3, 3.0, 200.0, 0.15);
        let d = run(&g);
        assert!(
            !d.treadmill && d.source == DecisionSource::Fallback,
            "{}",
            d.reason
        );
        assert!(d.reason.contains("faster than 7"), "{}", d.reason);
    }

    /// A trial shorter than a stance, both feet in the air: weak evidence,
    /// overground by default.
    #[test]
    fn no_stance_falls_back_to_overground() {
        let g = gait(0.0, -3.0, 0.7, 0.33, 4.0, 120.0, 0.15);
        // Only frames in flight: feet off the floor.
        let tracks: Vec<PointTrack> =
            g.4.iter()
                .map(|(s, p, v)| PointTrack {
                    side: *s,
                    positions: p,
                    velocities: v,
                })
                .collect();
        let ev = evidence(&g.0, &g.1[..0], &g.2, &g.3, &tracks);
        let d = decide(ev, FloorMotion::Auto);
        assert!(
            !d.treadmill && d.source == DecisionSource::Fallback,
            "{}",
            d.reason
        );
        assert!(d.reason.contains("no foot"), "{}", d.reason);
    }

    /// The user's choice is taken as given; a speed is along the walking
    /// direction, backward.
    #[test]
    fn given_choices_are_used() {
        let g = gait(1.3, 0.0, 1.1, 0.6, 1.4, 100.0, 0.05);
        let tracks: Vec<PointTrack> =
            g.4.iter()
                .map(|(s, p, v)| PointTrack {
                    side: *s,
                    positions: p,
                    velocities: v,
                })
                .collect();
        let ev = evidence(&g.0, &g.1, &g.2, &g.3, &tracks);
        let d = decide(ev.clone(), FloorMotion::TreadmillSpeed(2.5));
        assert!(d.treadmill && d.source == DecisionSource::Given);
        assert!((d.belt_velocity - Vector3::new(-2.5, 0.0, 0.0)).norm() < 1e-12);
        let d = decide(
            ev.clone(),
            FloorMotion::TreadmillVelocity(Vector3::new(-1.0, 0.0, 0.1)),
        );
        assert_eq!(d.belt_velocity, Vector3::new(-1.0, 0.0, 0.1));
        let g2 = gait(0.0, -3.0, 0.7, 0.33, 4.0, 120.0, 0.15);
        let tracks: Vec<PointTrack> =
            g2.4.iter()
                .map(|(s, p, v)| PointTrack {
                    side: *s,
                    positions: p,
                    velocities: v,
                })
                .collect();
        let ev = evidence(&g2.0, &g2.1, &g2.2, &g2.3, &tracks);
        let d = decide(ev, FloorMotion::Overground);
        assert!(!d.treadmill && d.source == DecisionSource::Given);
    }
}
