//! Gait events found on the raw (unfiltered) kinematics, and the
//! step-to-step transition they set for the foot contacts (issue 36;
//! docs/grf_prediction.md, "The step-to-step transition").
//!
//! **Why the raw kinematics.** The coordinates the static optimization
//! runs on are low-passed by a zero-phase (acausal) filter: it spreads the
//! collision of the landing heel back in time, so the force the filtered
//! motion requires rises before the heel lands, and a per-frame effort
//! minimum puts it on the landing foot as soon as the foot is within reach
//! of the floor, 10-40 ms before the plates see load. The unfiltered
//! motion is causal: nothing in it moves before the foot lands.
//!
//! **Foot strike and foot off** (Zeni, Richards & Higginson 2008, Gait
//! Posture 27:710, the coordinate-based method): per foot, the foot strikes
//! where its heel is farthest ahead of the pelvis along the walking
//! direction (a local maximum of (heel − pelvis)·h), and comes off where
//! its toe is farthest behind it (a local minimum of (toe − pelvis)·h). The
//! method has no threshold, works on a treadmill and overground, at every
//! speed, and was the most accurate kinematic method over 588 subjects
//! (Zhang et al. 2025, arXiv 2503.00794). An extremum counts when it is the
//! extremum over [`EVENT_WINDOW`] either side (a foot cannot strike twice
//! within 0.2 s: the shortest swing of a sprint is longer), and when it is
//! not at the first or last sample (an extremum at the edge is the trial's,
//! not the foot's).
//!
//! **The transition.** A foot's contacts carry nothing from its foot-off
//! (or [`SWING_BEFORE_STRIKE`] before its strike, when no foot-off precedes
//! it in the trial) until its strike ([`off_intervals`]): in swing the foot
//! is off the floor anyway, and at its end the filter's early force cannot
//! be put on it. After the strike the effort minimum shares the load.

use nalgebra::Vector3;

use crate::dynamics::{kinematics, Data};
use crate::model::Model;
use crate::motion::states::States;

use super::feet::{FootContactSet, FootPoint};

/// Half-width of the window over which an event must be the extremum (s).
pub const EVENT_WINDOW: f64 = 0.1;

/// Without a foot-off before a strike, the foot's contacts are off for
/// this long before it (s): shorter than any swing (walking 0.35-0.45 s,
/// running 0.3-0.4 s; Novacheck 1998, Gait Posture 7:77), longer than the
/// filter's spread of the collision (10-40 ms at 6 Hz).
pub const SWING_BEFORE_STRIKE: f64 = 0.2;

/// A foot can carry when one of its points has at least this contact
/// weight w(d)·(slip gate) on the filtered motion: half strength, where
/// the contact band and the slip gate are halfway (docs/grf_prediction.md,
/// steps 4 and 7).
pub const CARRY_WEIGHT: f64 = 0.5;

/// The events of one foot (times in s, ascending).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FootEvents {
    pub strikes: Vec<f64>,
    pub offs: Vec<f64>,
    /// Per strike: whether the other foot can carry at that instant (one of
    /// its points within reach of the floor, [`CARRY_WEIGHT`]): a
    /// step-to-step transition of walking, where the effort minimum could
    /// load the landing foot before it lands. In running the other foot is
    /// in swing when one lands, and nothing is changed.
    pub transitions: Vec<bool>,
}

/// Per foot (0 right, 1 left).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GaitEvents {
    pub feet: [FootEvents; 2],
    /// The last time of the kinematics the events were found on (s): a
    /// foot whose foot-off is not found before it is still on the floor.
    pub end: f64,
}

/// Double support (s) when the trailing foot's foot-off is not in the
/// trial: the initial double support of walking, 0-10 % of a gait cycle of
/// about 1.1 s (Perry & Burnfield 2010, Gait Analysis, 2nd ed.).
pub const DEFAULT_DOUBLE_SUPPORT: f64 = 0.11;

/// Spacing of the knots of the transition's weights (s).
pub const TRANSITION_KNOT_STEP: f64 = 0.005;

/// The heel-strike impact (s after a strike): while it lasts the landing
/// foot's force has no part along the walking direction. At heel strike the
/// ground reaction vector is almost vertical at first, the AP shear briefly
/// zero, and passes about through the ankle, before it flips backwards;
/// with it comes the vertical force's heel-strike transient (Baker,
/// clinicalgaitanalysis.com, Teach-in '97, "The heel strike transient").
/// The horizontal impact force follows the heel's horizontal velocity at
/// contact, which is about zero (Lanshammar & Strandberg 1982, Biomechanics
/// VIII-B:1123: a forward force peak in 82 of 111 steps, with a backward
/// heel velocity in 69 of them). The transient peaks 11–16 ms after ground
/// contact in walking (the Radin and modified Hunt methods, "Comparison of
/// three methods for identifying the heelstrike transient during walking
/// gait", abstract); the impact lasts to the later of these.
pub const HEEL_STRIKE_IMPACT: f64 = 0.016;

/// Ren, Jones & Howard's smooth transition (2008, J Biomech 41:2750, the
/// smooth transition assumption) at time tau after the strike, over a
/// double support of `t_ds`: exp(−(2 tau / T_ds)³), 1 at the strike, 0.37
/// halfway, 3e-4 at the foot-off. A muscle-driven model's trailing foot's
/// mediolateral force follows it ([`trailing_line_targets`]); the vertical
/// force follows [`trailing_vertical_share`].
pub fn trailing_share(tau: f64, t_ds: f64) -> f64 {
    if tau <= 0.0 {
        1.0
    } else {
        (-(2.0 * tau / t_ds).powi(3)).exp()
    }
}

/// The generalized logistic A + K / (C + Q e^(−B (u − m)))^v of the
/// trailing foot's vertical force over double support, u = τ / T_ds, fitted
/// by OpenSimRT's authors to their own treadmill plates (Stanev et al. 2021,
/// Sensors 21:1804; github.com/mitkof6/OpenSimRT, `GRFMPrediction.cpp`,
/// `verticalForceTransition`, and its fitting script, which divides each
/// double support's trailing force by its value at the strike and fixes
/// T_ds = 0.12 s): their B = 61.30 s⁻¹ times that 0.12 s, so that the curve
/// scales with the double support as Ren's does.
const VERTICAL_LOGISTIC: [f64; 7] = [
    1.119_368_182_649_245_2,      // A
    -1.603_821_267_061_337_7,     // K
    3.037_706_815_056_258,        // C
    61.295_348_914_235_34 * 0.12, // B T_ds
    0.506_763_999_601_545_7,      // Q
    0.939_645_552_156_475_4,      // m
    0.423_061_837_267_674_93,     // v
];

/// The trailing foot's share of its vertical force at the strike, τ after
/// it over a double support of `t_ds`: [`VERTICAL_LOGISTIC`] divided by its
/// value at the strike, within [0, 1]. 1 at the strike, 0.87 at a quarter
/// of the double support, 0.62 halfway, 0.31 at three quarters, 0.16 at the
/// foot-off (Ren's exp(−(2τ/T_ds)³), [`trailing_share`], gives 0.98, 0.37,
/// 0.03 and 3e-4). Measured on the six development one-step trials' plates
/// the share is 0.57–0.74 halfway and 0.27–0.37 at three quarters
/// (docs/grf_prediction.md, step 8).
pub fn trailing_vertical_share(tau: f64, t_ds: f64) -> f64 {
    let [a, k, c, b, q, m, v] = VERTICAL_LOGISTIC;
    let f = |u: f64| a + k / (c + q * (-b * (u - m)).exp()).powf(v);
    if tau <= 0.0 {
        1.0
    } else {
        (f(tau / t_ds) / f(0.0)).clamp(0.0, 1.0)
    }
}

/// The double support after a strike at `ts` while foot `trailing` stands
/// (s): to the trailing foot's first foot-off after the strike, within
/// 0.3 s; without one, [`DEFAULT_DOUBLE_SUPPORT`], or to the end of the
/// kinematics when that is later (within 0.3 s): a foot-off is an extremum
/// inside the trial, so a trailing foot with none is still on the floor at
/// its end.
pub fn double_support(events: &GaitEvents, trailing: usize, ts: f64) -> f64 {
    events.feet[trailing]
        .offs
        .iter()
        .copied()
        .find(|&x| x > ts && x <= ts + 0.3)
        .map(|x| x - ts)
        .unwrap_or_else(|| {
            let rest = events.end - ts;
            if rest > DEFAULT_DOUBLE_SUPPORT && rest <= 0.3 {
                rest
            } else {
                DEFAULT_DOUBLE_SUPPORT
            }
        })
}

/// Per foot (0 right, 1 left), the double supports it trails through
/// (`held_intervals`): from each transition strike t_s of the other foot to
/// t_s + T_ds ([`double_support`]), merged where they overlap. The raw
/// kinematics say the trailing foot is on the floor until its foot-off, but
/// in pre-swing it rolls over its toes (Perry & Burnfield 2010, the forefoot
/// and toe rockers), and a point fixed on the model's rigid foot moves as
/// it rolls, although the foot does not slide: on 2014001 C5_01 the hallux
/// point moved 0.7–1.2 m/s over the floor in the raw kinematics over the
/// last 20 ms of the trial while the plate under it measured 320–460 N. Its
/// slip is the roll's, so through double support the trailing foot's slip
/// gate is not applied and its friction regime is static (a sliding regime
/// would put kinetic friction against the roll, braking the push-off).
pub fn held_intervals(events: &GaitEvents) -> [Vec<(f64, f64)>; 2] {
    let mut out: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    for s in 0..2 {
        let o = 1 - s;
        let f = &events.feet[s];
        for (k, &ts) in f.strikes.iter().enumerate() {
            if f.transitions.get(k).copied().unwrap_or(false) {
                out[o].push((ts, ts + double_support(events, o, ts)));
            }
        }
    }
    for v in out.iter_mut() {
        *v = merged(std::mem::take(v));
    }
    out
}

/// Intervals [t0, t1) in time order, those that overlap or touch merged.
pub fn merged(mut v: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (a, b) in v {
        match out.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}

/// Per contact point (in the order of `points`), the times [t0, t1) over
/// which it carries nothing because its foot lands on its heel (issue 36):
/// over each double support a foot lands into (the other foot's `held`,
/// [`held_intervals`]) it is in loading response, on the heel rocker
/// (Perry & Burnfield 2010), so its points but the heel's (names without
/// "heel") carry nothing, and its centre of pressure stays at its heel, the
/// point its leg line starts from ([`landing_targets`]). Without it the
/// moments the filtered motion asks for put the landing foot's centre of
/// pressure up to 17 cm ahead, on its forefoot, in loading response. (The
/// trailing foot's forefoot rocker needs no such rule: its force already
/// acts there.)
pub fn heel_rocker_intervals(
    points: &[FootPoint],
    held: &[Vec<(f64, f64)>; 2],
) -> Vec<Vec<(f64, f64)>> {
    points
        .iter()
        .map(|p| {
            let s = usize::from(p.side != 'r');
            if p.name.contains("heel") {
                Vec::new()
            } else {
                held[1 - s].clone()
            }
        })
        .collect()
}

/// A knot of a foot's force target ([`super::targets::Knot`]).
pub type TargetKnot = super::targets::Knot;

/// The knots of one double support from `ts` over `t_ds`: every
/// [`TRANSITION_KNOT_STEP`] (at least the two ends) the rows `rows(τ)`
/// gives, then a last knot just after the double support that switches the
/// target off. None from `rows` at any knot (a lean or a requirement not
/// known there) gives no knots at all.
fn double_support_knots(
    ts: f64,
    t_ds: f64,
    mut rows: impl FnMut(f64) -> Option<Vec<(Vector3<f64>, f64)>>,
) -> Vec<TargetKnot> {
    let steps = (t_ds / TRANSITION_KNOT_STEP).ceil().max(1.0) as usize;
    let mut knots = Vec::with_capacity(steps + 2);
    for i in 0..=steps {
        let tau = t_ds * i as f64 / steps as f64;
        let Some(r) = rows(tau) else {
            return Vec::new();
        };
        knots.push((ts + tau, true, r));
    }
    if let Some(last) = knots.last() {
        let r = last.2.clone();
        knots.push((ts + t_ds + 1e-6, false, r));
    }
    knots
}

/// The unit direction across a leg whose line is `lean`: in the plane of
/// the walking direction h and the floor normal n, perpendicular to the
/// line.
fn across_leg(lean: Vector3<f64>, h: Vector3<f64>, n: Vector3<f64>) -> Vector3<f64> {
    (h * lean.dot(&n) - n * lean.dot(&h)).normalize()
}

/// Per foot (0 right, 1 left), the knots `knots(o, t_s, T_ds)` gives the
/// trailing foot o over each double support: from each transition strike
/// t_s of the other foot, T_ds long ([`double_support`]).
fn per_double_support(
    events: &GaitEvents,
    mut knots: impl FnMut(usize, f64, f64) -> Vec<TargetKnot>,
) -> [Vec<TargetKnot>; 2] {
    let mut out: [Vec<TargetKnot>; 2] = [Vec::new(), Vec::new()];
    for s in 0..2 {
        let o = 1 - s;
        let f = &events.feet[s];
        for (k, &ts) in f.strikes.iter().enumerate() {
            if f.transitions.get(k).copied().unwrap_or(false) {
                out[o].extend(knots(o, ts, double_support(events, o, ts)));
            }
        }
    }
    out
}

/// Knots in time order, one per time (the first kept).
fn time_ordered(knots: &mut Vec<TargetKnot>) {
    knots.sort_by(|a, b| a.0.total_cmp(&b.0));
    knots.dedup_by(|b, a| b.0 <= a.0);
}

/// The axis across a trailing leg τ after the other foot's strike: none
/// over the landing heel's impact ([`HEEL_STRIKE_IMPACT`]; the row holds
/// nothing then, since the impact's row fixes the landing foot's
/// horizontal force and the two would fix both feet's by geometry alone),
/// then across the leg's line `lean()` ([`across_leg`]); None where the
/// line is not known.
fn across_after_impact(
    tau: f64,
    lean: impl FnOnce() -> Option<Vector3<f64>>,
    h: Vector3<f64>,
    n: Vector3<f64>,
) -> Option<Vector3<f64>> {
    if tau <= HEEL_STRIKE_IMPACT + 1e-9 {
        Some(Vector3::zeros())
    } else {
        Some(across_leg(lean()?, h, n))
    }
}

/// The smooth transition of double support (Ren, Jones & Howard 2008, J
/// Biomech 41:2750) as force targets of the **trailing** foot, with its
/// force along its leg: over the double support T_ds after each transition
/// strike at t_s of the other foot,
/// - its force along the floor normal n is F(t_s + τ) = F(t_s) · s(τ), s
///   the share measured on plates ([`trailing_vertical_share`]), F(t_s)
///   the force the motion requires of the floor at the strike
///   (`required(t_s)`, all of it on the trailing foot then: the landing
///   foot has carried nothing before it), and at most what the motion
///   requires then (`required(t)`: the landing foot cannot pull);
/// - its force has no part across `lean(t, foot)`, the line from its toe
///   (hallux point) to the body's mass centre, in the plane of the walking
///   direction h and n: a leg pushes along itself (the compliant leg of
///   walking, Geyer, Seyfarth & Blickhan 2006, Proc R Soc B 273:2861), and
///   in pre-swing the trailing foot rolls over its toes (Perry & Burnfield
///   2010), so its force acts there;
/// - its mediolateral force, along m = n × h, falls on Ren's
///   [`trailing_share`] from what the motion requires at the strike, as a
///   muscle-driven model's does ([`trailing_line_targets`]): without it the
///   feet pushed against each other sideways.
///
/// The landing foot takes the rest, R(t) − F(t), through the equations of
/// motion. Knots every [`TRANSITION_KNOT_STEP`], rows (n, F), (across, 0)
/// and (m, F_m); the target ends just after the double support. Per foot
/// (0 right, 1 left), the knots of the feet that trail; a transition whose
/// requirement or lean is not known (at the first or last row) gets none.
pub fn trailing_targets(
    events: &GaitEvents,
    h: Vector3<f64>,
    n: Vector3<f64>,
    required: impl FnMut(f64) -> Option<Vector3<f64>>,
    lean: impl FnMut(f64, usize) -> Option<Vector3<f64>>,
) -> [Vec<TargetKnot>; 2] {
    let mut out = trailing_knots(events, h, n, required, lean, true);
    out.iter_mut().for_each(time_ordered);
    out
}

/// The trailing foot's knots over each double support: its line row
/// (across its leg after the impact, [`across_after_impact`]) and its
/// mediolateral row on Ren's [`trailing_share`] of the strike's lateral
/// requirement, in that order; `with_vertical` puts its vertical row on
/// [`trailing_vertical_share`] first ([`trailing_targets`]), without it
/// the rows are a muscle-driven model's ([`trailing_line_targets`]).
fn trailing_knots(
    events: &GaitEvents,
    h: Vector3<f64>,
    n: Vector3<f64>,
    mut required: impl FnMut(f64) -> Option<Vector3<f64>>,
    mut lean: impl FnMut(f64, usize) -> Option<Vector3<f64>>,
    with_vertical: bool,
) -> [Vec<TargetKnot>; 2] {
    let m = n.cross(&h).normalize();
    per_double_support(events, |o, ts, t_ds| {
        let Some(r) = required(ts) else {
            return Vec::new();
        };
        double_support_knots(ts, t_ds, |tau| {
            let across = (across_after_impact(tau, || lean(ts + tau, o), h, n)?, 0.0);
            let lateral = (m, r.dot(&m) * trailing_share(tau, t_ds));
            if !with_vertical {
                return Some(vec![across, lateral]);
            }
            // A foot cannot pull: the trailing foot carries at most what
            // the motion requires of the floor then.
            let now = required(ts + tau).map_or(f64::INFINITY, |x| x.dot(&n));
            let vertical = (r.dot(&n) * trailing_vertical_share(tau, t_ds)).min(now.max(0.0));
            Some(vec![(n, vertical), across, lateral])
        })
    })
}

/// The step-to-step transition of walking written into the contact set
/// `set` (a torque-driven model's; docs/grf_prediction.md, step 8): per
/// foot, its contacts carry nothing from its foot-off until each
/// transition strike ([`off_intervals`]; a force there costs what one on
/// the root residual of optimal force `root_optimal_force` costs,
/// [`off_weight`] at contact weight `w0`), and the trailing foot's force is
/// held through double support ([`trailing_targets`] on `states`, the
/// filtered motion; a newton off it costs what one on the root residual
/// costs).
pub fn apply_transition(
    model: &Model,
    states: &States,
    events: &GaitEvents,
    set: &mut FootContactSet,
    w0: f64,
    root_optimal_force: f64,
) {
    for s in 0..2 {
        set.off_intervals[s] = off_intervals(&events.feet[s]);
    }
    set.held_intervals = held_intervals(events);
    set.heel_rocker_intervals = heel_rocker_intervals(&set.points, &set.held_intervals);
    set.off_weight = off_weight(set.parameters.optimal_force, w0, root_optimal_force);
    let (n, h) = floor_axes(set);
    set.target_optimal_force = vec![root_optimal_force; 3];
    let points = set.points.clone();
    let trailing = trailing_targets(
        events,
        h,
        n,
        |t| required_force(model, states, t),
        |t, side| toe_to_com(model, states, &points, t, side),
    );
    let landing = landing_targets(events, h, n, |t, side| {
        point_to_com(model, states, &points, t, side, "heel")
    });
    set.force_target = merge_targets(trailing, landing, &set.held_intervals);
}

/// The **landing** foot's force along its leg over each double support
/// (issue 36): the compliant leg (Geyer, Seyfarth & Blickhan 2006) for both
/// legs, as in the dynamic-walking account of the step-to-step transition,
/// where the trailing leg's push-off and the leading leg's collision each
/// act along the leg (Kuo, Donelan & Ruina 2005, Exerc Sport Sci Rev
/// 33:88; Donelan, Kram & Kuo 2002, J Exp Biol 205:3717). Over the double
/// support T_ds after each transition strike at t_s of foot s, foot s's
/// force has no part across `lean(t, s)`, the line from its heel (the
/// midpoint of its heel points: the loading response's centre of pressure,
/// Perry & Burnfield 2010) to the body's mass centre, in the plane of the
/// walking direction h and the floor normal n. A leading leg then brakes in
/// proportion to its load. Over the heel-strike impact, the first
/// [`HEEL_STRIKE_IMPACT`] after the strike, the line is the floor normal n
/// instead: the impact's force is vertical. Knots every [`TRANSITION_KNOT_STEP`], rows
/// (across, 0) and two zero rows (the trailing target's second and third
/// rows; they hold nothing, [`super::targets`]); the target ends just after
/// the double support. A transition whose lean is not known gets none.
pub fn landing_targets(
    events: &GaitEvents,
    h: Vector3<f64>,
    n: Vector3<f64>,
    mut lean: impl FnMut(f64, usize) -> Option<Vector3<f64>>,
) -> [Vec<TargetKnot>; 2] {
    let mut out: [Vec<TargetKnot>; 2] = [Vec::new(), Vec::new()];
    for s in 0..2 {
        let f = &events.feet[s];
        for (k, &ts) in f.strikes.iter().enumerate() {
            if !f.transitions.get(k).copied().unwrap_or(false) {
                continue;
            }
            let t_ds = double_support(events, 1 - s, ts);
            out[s].extend(double_support_knots(ts, t_ds, |tau| {
                let line = if tau <= HEEL_STRIKE_IMPACT + 1e-9 {
                    n
                } else {
                    lean(ts + tau, s)?
                };
                let across = across_leg(line, h, n);
                Some(vec![
                    (across, 0.0),
                    (Vector3::zeros(), 0.0),
                    (Vector3::zeros(), 0.0),
                ])
            }));
        }
    }
    out
}

/// The floor normal n of `set` and its walking direction h in the floor's
/// plane (the heading its decision found, with its part along n removed).
fn floor_axes(set: &FootContactSet) -> (Vector3<f64>, Vector3<f64>) {
    let n = set.floor_normal();
    let h = set.decision.evidence.heading;
    (n, (h - n * h.dot(&n)).normalize())
}

/// The heel-strike impact alone (a muscle-driven model's walking,
/// docs/grf_prediction.md, step 8): over the first [`HEEL_STRIKE_IMPACT`]
/// after each transition strike of foot s, foot s's force has no part along
/// the walking direction h; the rows of [`landing_targets`] over its impact
/// (the line is the floor normal, so the row's axis is h), knots every
/// [`TRANSITION_KNOT_STEP`] at most, the target off just after the impact.
/// A strike in running takes over from no foot on the floor (not a
/// transition) and gets none. Per foot (0 right, 1 left).
pub fn impact_targets(events: &GaitEvents, h: Vector3<f64>) -> [Vec<TargetKnot>; 2] {
    let mut out: [Vec<TargetKnot>; 2] = [Vec::new(), Vec::new()];
    for (f, knots) in events.feet.iter().zip(out.iter_mut()) {
        for (k, &ts) in f.strikes.iter().enumerate() {
            if f.transitions.get(k).copied().unwrap_or(false) {
                knots.extend(double_support_knots(ts, HEEL_STRIKE_IMPACT, |_| {
                    Some(vec![(h, 0.0), (Vector3::zeros(), 0.0)])
                }));
            }
        }
        time_ordered(knots);
    }
    out
}

/// The **trailing** foot of a muscle-driven model's double support: over
/// T_ds after each transition strike at t_s of the other foot, its force
/// has no part across `lean(t, foot)` (its toe to the mass centre, in the
/// plane of h and n: [`trailing_targets`]' second row) once the landing
/// heel's impact is over ([`HEEL_STRIKE_IMPACT`]; over the impact that row
/// holds nothing), and its force along the lateral axis m (n × h) follows
/// Ren, Jones & Howard's smooth transition (2008), F_m(t_s + τ) = F_m(t_s)
/// exp(−(2τ/T_ds)³), F_m(t_s) the motion's lateral requirement at the
/// strike (`required(t_s)`, all of it the trailing foot's then). How much
/// it carries vertically is left to the effort minimum. Rows (across, 0)
/// and (m, F_m).
pub fn trailing_line_targets(
    events: &GaitEvents,
    h: Vector3<f64>,
    n: Vector3<f64>,
    required: impl FnMut(f64) -> Option<Vector3<f64>>,
    lean: impl FnMut(f64, usize) -> Option<Vector3<f64>>,
) -> [Vec<TargetKnot>; 2] {
    trailing_knots(events, h, n, required, lean, false)
}

/// The step-to-step transition of a muscle-driven model's walking
/// (docs/grf_prediction.md, step 8), written into its contact set `set`:
/// the landing foot's heel-strike impact ([`impact_targets`], the same soft
/// rows as [`apply_transition`]'s landing foot over its impact) and the
/// trailing foot's force along its leg, its mediolateral force on Ren's
/// transition ([`trailing_line_targets`]); a newton off a row costs what
/// one on the root residual of optimal force `root_optimal_force` costs.
/// How the vertical load passes from foot to foot is left to the effort
/// minimum.
pub fn apply_muscle_transition(
    model: &Model,
    states: &States,
    events: &GaitEvents,
    set: &mut FootContactSet,
    root_optimal_force: f64,
) {
    let (n, h) = floor_axes(set);
    let points = set.points.clone();
    let trailing = trailing_line_targets(
        events,
        h,
        n,
        |t| required_force(model, states, t),
        |t, side| toe_to_com(model, states, &points, t, side),
    );
    set.force_target = impact_targets(events, h);
    for (knots, trail) in set.force_target.iter_mut().zip(trailing) {
        knots.extend(trail);
        time_ordered(knots);
    }
    if set.force_target.iter().any(|k| !k.is_empty()) {
        set.target_optimal_force = vec![root_optimal_force; 2];
    }
}

/// Whether a knot is a landing foot's ([`landing_targets`]: its second row
/// holds nothing and its first holds 0 N along an axis). A torque-driven
/// model's trailing knot over the impact also has a second row that holds
/// nothing, but its first holds the foot's vertical force, which is
/// positive wherever a foot lands while the other stands.
pub fn is_landing_knot(k: &TargetKnot) -> bool {
    k.2.get(1).is_some_and(|r| r.0 == Vector3::zeros())
        && k.2
            .first()
            .is_some_and(|r| r.1 == 0.0 && r.0 != Vector3::zeros())
}

/// Per foot, its trailing and landing knots in one target (the contacts of
/// a foot share one group): time-ordered; a landing knot inside a double
/// support the foot trails through (`held`, [`held_intervals`]) is dropped,
/// so that the two never interleave.
pub fn merge_targets(
    trailing: [Vec<TargetKnot>; 2],
    landing: [Vec<TargetKnot>; 2],
    held: &[Vec<(f64, f64)>; 2],
) -> [Vec<TargetKnot>; 2] {
    let mut out = trailing;
    for ((knots, land), held) in out.iter_mut().zip(landing).zip(held) {
        let inside = |t: f64| held.iter().any(|&(a, b)| t >= a - 1e-9 && t <= b + 1e-6);
        knots.extend(land.into_iter().filter(|k| !inside(k.0)));
        time_ordered(knots);
    }
    out
}

/// The summary's line on the force targets of foot `side` (None without
/// any): each double support it trails through or lands into, and each
/// heel-strike impact held alone ([`impact_targets`]).
pub fn targets_note(side: char, knots: &[TargetKnot], torque_driven: bool) -> Option<String> {
    let mut spans = Vec::new();
    let mut landing = Vec::new();
    let mut impact = Vec::new();
    let mut start: Option<&TargetKnot> = None;
    for (i, k) in knots.iter().enumerate() {
        if k.1 && start.is_none() {
            start = Some(k);
        }
        let ends = !k.1 || i + 1 == knots.len();
        if let (true, Some(a)) = (ends, start) {
            let last = if k.1 { k } else { &knots[i - 1] };
            if is_landing_knot(a) && last.0 - a.0 <= HEEL_STRIKE_IMPACT + 1e-9 {
                // The impact alone ([`impact_targets`]).
                impact.push(format!("[{:.3}, {:.3}] s", a.0, last.0));
            } else if is_landing_knot(a) {
                landing.push(format!("[{:.3}, {:.3}] s", a.0, last.0));
            } else {
                // The force the target starts from: vertical (a torque-driven
                // model's first row), mediolateral (a muscle-driven model's
                // second, [`trailing_line_targets`]).
                let row = usize::from(!torque_driven);
                spans.push(format!(
                    "[{:.3}, {:.3}] s from {:.0} N{}",
                    a.0,
                    last.0,
                    a.2.get(row).map_or(0.0, |r| r.1),
                    if torque_driven { "" } else { " mediolateral" }
                ));
            }
            start = None;
        }
    }
    let lands = (!landing.is_empty()).then(|| {
        format!(
            "foot {side} lands into double support over {}: it stands on its heel, and its force points along the line from its heel to the body's mass centre (a leading leg brakes in proportion to its load), but over the heel-strike impact, its first {:.0} ms, it has none along the walking direction",
            landing.join(", "),
            HEEL_STRIKE_IMPACT * 1000.0
        )
    });
    let trails = (!spans.is_empty()).then(|| {
        if torque_driven {
            format!(
                "foot {side} trails through double support over {}: its vertical force falls as the trailing foot's measured in double support (OpenSimRT's logistic, 0.62 of the strike's halfway) and its mediolateral force as Ren et al. 2008's smooth transition, exp(-(2t/T)^3), its force points along the line from its toe to the body's mass centre, and its contacts stay on the floor whatever their slip (it rolls over its toes, it does not slide); the landing foot carries the rest",
                spans.join(", ")
            )
        } else {
            format!(
                "foot {side} trails through double support over {}: its force points along the line from its toe to the body's mass centre, and its mediolateral force falls as Ren et al. 2008's smooth transition, exp(-(2t/T)^3); how much it carries is the effort minimum's",
                spans.join(", ")
            )
        }
    });
    let impacts = (!impact.is_empty()).then(|| {
        format!(
            "foot {side}'s heel-strike impact over {}: no force along the walking direction",
            impact.join(", ")
        )
    });
    let parts: Vec<String> = [trails, lands, impacts].into_iter().flatten().collect();
    (!parts.is_empty()).then(|| parts.join("; "))
}

/// The line from foot `side`'s toe (its hallux point, the mean of them if
/// several) to the body's mass centre at the row of `states` nearest `t`
/// (ground).
pub fn toe_to_com(
    model: &Model,
    states: &States,
    points: &[FootPoint],
    t: f64,
    side: usize,
) -> Option<Vector3<f64>> {
    point_to_com(model, states, points, t, side, "hallux")
}

/// The line from the mean of foot `side`'s points whose name contains
/// `stem` to the body's mass centre at the row of `states` nearest `t`
/// (ground); None without such points.
pub fn point_to_com(
    model: &Model,
    states: &States,
    points: &[FootPoint],
    t: f64,
    side: usize,
    stem: &str,
) -> Option<Vector3<f64>> {
    let i = (0..states.time.len()).min_by(|&a, &b| {
        (states.time[a] - t)
            .abs()
            .total_cmp(&(states.time[b] - t).abs())
    })?;
    let mut data = Data::new(model);
    data.q.copy_from_slice(&states.q[i]);
    kinematics::positions(model, &mut data);
    let c = if side == 0 { 'r' } else { 'l' };
    let (sum, k) = points
        .iter()
        .filter(|p| p.side == c && p.name.contains(stem))
        .fold((Vector3::zeros(), 0usize), |(s, k), p| {
            (s + data.station_position(p.body, &p.local), k + 1)
        });
    if k == 0 {
        return None;
    }
    let mass: f64 = model.bodies.iter().map(|b| b.mass).sum();
    let com = model
        .bodies
        .iter()
        .enumerate()
        .map(|(b, body)| data.station_position(b, &body.mass_center) * body.mass)
        .sum::<Vector3<f64>>()
        / mass;
    Some(com - sum / k as f64)
}

/// The force (N, ground) the motion in `states` requires of the floor at
/// the row nearest `t`: M (a − g), a the whole-body mass centre's
/// acceleration by the three-point second difference over that row and its
/// neighbours (None at the first or last row).
pub fn required_force(model: &Model, states: &States, t: f64) -> Option<Vector3<f64>> {
    let n = states.time.len();
    let i = (0..n).min_by(|&a, &b| {
        (states.time[a] - t)
            .abs()
            .total_cmp(&(states.time[b] - t).abs())
    })?;
    if i == 0 || i + 1 >= n {
        return None;
    }
    let mut data = Data::new(model);
    let mass: f64 = model.bodies.iter().map(|b| b.mass).sum();
    let mut com = |row: usize| {
        data.q.copy_from_slice(&states.q[row]);
        kinematics::positions(model, &mut data);
        model
            .bodies
            .iter()
            .enumerate()
            .map(|(b, body)| data.station_position(b, &body.mass_center) * body.mass)
            .sum::<Vector3<f64>>()
            / mass
    };
    let (c0, c1, c2) = (com(i - 1), com(i), com(i + 1));
    let (h1, h2) = (
        states.time[i] - states.time[i - 1],
        states.time[i + 1] - states.time[i],
    );
    let a = ((c2 - c1) / h2 - (c1 - c0) / h1) * (2.0 / (h1 + h2));
    Some((a - model.gravity) * mass)
}

/// The factor on a contact's weight before its foot's strike
/// (`off_weight`): such that a newton on the contact costs what a newton on
/// the root residual costs. A contact's force f = w F0 λ costs λ²/w0, i.e.
/// f² / (w² F0² w0); a root residual of optimal force S costs (f/S)²; equal
/// when w = S / (F0 √w0). Clamped to [0, 1).
pub fn off_weight(optimal_force: f64, w0: f64, root_optimal_force: f64) -> f64 {
    let w = root_optimal_force / (optimal_force * w0.sqrt());
    if w.is_finite() {
        w.clamp(0.0, 0.999)
    } else {
        0.0
    }
}

/// Indices of the local extrema of `x` (maxima when `max`, else minima)
/// that are the extremum of `x` over `window` seconds either side (the
/// window clipped to the series) and not at its first or last sample. Of
/// equal values the first counts.
pub fn extrema(time: &[f64], x: &[f64], window: f64, max: bool) -> Vec<usize> {
    let n = x.len().min(time.len());
    let better = |a: f64, b: f64| if max { a > b } else { a < b };
    let mut out = Vec::new();
    for i in 1..n.saturating_sub(1) {
        if !x[i].is_finite() {
            continue;
        }
        let mut ok = true;
        let mut j = i;
        while j > 0 && time[i] - time[j - 1] <= window + 1e-12 {
            j -= 1;
            if !better(x[i], x[j]) {
                ok = false;
                break;
            }
        }
        if !ok {
            continue;
        }
        let mut k = i;
        while k + 1 < n && time[k + 1] - time[i] <= window + 1e-12 {
            k += 1;
            // Ties after: this one (the first) counts.
            if better(x[k], x[i]) {
                ok = false;
                break;
            }
        }
        if ok {
            out.push(i);
        }
    }
    out
}

/// Zeni's coordinate-based events of one foot: `heel` and `toe` positions
/// (ground), `pelvis` positions, `heading` the walking direction (unit,
/// horizontal), at `time`.
pub fn zeni_events(
    time: &[f64],
    heel: &[Vector3<f64>],
    toe: &[Vector3<f64>],
    pelvis: &[Vector3<f64>],
    heading: &Vector3<f64>,
) -> FootEvents {
    let heel_ap: Vec<f64> = heel
        .iter()
        .zip(pelvis)
        .map(|(h, p)| (h - p).dot(heading))
        .collect();
    let toe_ap: Vec<f64> = toe
        .iter()
        .zip(pelvis)
        .map(|(t, p)| (t - p).dot(heading))
        .collect();
    FootEvents {
        strikes: extrema(time, &heel_ap, EVENT_WINDOW, true)
            .into_iter()
            .map(|i| time[i])
            .collect(),
        offs: extrema(time, &toe_ap, EVENT_WINDOW, false)
            .into_iter()
            .map(|i| time[i])
            .collect(),
        transitions: Vec::new(),
    }
}

/// The intervals (s) over which a foot's contacts carry nothing: from each
/// strike's preceding foot-off (the latest one after the previous strike),
/// or [`SWING_BEFORE_STRIKE`] before the strike when there is none, to the
/// strike.
pub fn off_intervals(foot: &FootEvents) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut prev_strike = f64::NEG_INFINITY;
    for (k, &s) in foot.strikes.iter().enumerate() {
        if !foot.transitions.get(k).copied().unwrap_or(false) {
            prev_strike = s;
            continue;
        }
        let off = foot
            .offs
            .iter()
            .copied()
            .filter(|&o| o < s && o > prev_strike)
            .fold(f64::NAN, f64::max);
        let from = if off.is_finite() {
            off
        } else {
            s - SWING_BEFORE_STRIKE
        };
        out.push((from, s));
        prev_strike = s;
    }
    out
}

/// Ground positions of the heel (the midpoint of each foot's heel
/// points), the toe (its hallux point) and the metatarsal heads' midpoint
/// of both feet, and the pelvis (the root body's origin; the heels'
/// midpoint for a model without one), at every row of `states`.
struct Landmarks {
    heel: [Vec<Vector3<f64>>; 2],
    toe: [Vec<Vector3<f64>>; 2],
    meta: [Vec<Vector3<f64>>; 2],
    pelvis: Vec<Vector3<f64>>,
}

fn landmarks(model: &Model, states: &States, points: &[FootPoint]) -> Landmarks {
    let mut data = Data::new(model);
    let root = (0..model.nq())
        .find(|&c| model.is_root_coordinate(c))
        .map(|c| model.coordinates[c].body);
    let n = states.time.len();
    let mut out = Landmarks {
        heel: [Vec::with_capacity(n), Vec::with_capacity(n)],
        toe: [Vec::with_capacity(n), Vec::with_capacity(n)],
        meta: [Vec::with_capacity(n), Vec::with_capacity(n)],
        pelvis: Vec::with_capacity(n),
    };
    let mean_of = |data: &Data, side: char, stem: &str| {
        let (sum, k) = points
            .iter()
            .filter(|p| p.side == side && p.name.contains(stem))
            .fold((Vector3::zeros(), 0usize), |(s, k), p| {
                (s + data.station_position(p.body, &p.local), k + 1)
            });
        (k > 0).then(|| sum / k as f64)
    };
    for i in 0..n {
        data.q.copy_from_slice(&states.q[i]);
        data.u.copy_from_slice(&states.u[i]);
        data.udot.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(model, &mut data);
        for (s, side) in ['r', 'l'].into_iter().enumerate() {
            let heel = mean_of(&data, side, "heel").unwrap_or_else(Vector3::zeros);
            out.heel[s].push(heel);
            out.toe[s].push(mean_of(&data, side, "hallux").unwrap_or(heel));
            out.meta[s].push(mean_of(&data, side, "meta").unwrap_or(heel));
        }
        out.pelvis.push(match root {
            Some(b) => data.station_position(b, &Vector3::zeros()),
            None => 0.5 * (out.heel[0][i] + out.heel[1][i]),
        });
    }
    out
}

/// The events of both feet: found on `raw`, the unfiltered motion (every
/// row), along the walking direction of `set`; each strike then marked a
/// transition when the other foot can carry at that instant on `filtered`,
/// the motion the static optimization runs on (its contact weights with
/// the contact set's floor, belt and parameters).
pub fn detect(model: &Model, raw: &States, filtered: &States, set: &FootContactSet) -> GaitEvents {
    let heading = set.decision.evidence.heading;
    let l = landmarks(model, raw, &set.points);
    let mut out = GaitEvents {
        end: raw.time.last().copied().unwrap_or(0.0),
        ..GaitEvents::default()
    };
    for s in 0..2 {
        out.feet[s] = zeni_events(&raw.time, &l.heel[s], &l.toe[s], &l.pelvis, &heading);
        // O'Connor's foot-velocity refinement: the foot centre (heel and
        // metatarsal heads' midpoint) descends fastest where the heel lands.
        let centre: Vec<Vector3<f64>> = l.heel[s]
            .iter()
            .zip(&l.meta[s])
            .map(|(h, m)| 0.5 * (h + m))
            .collect();
        let vy = vertical_velocity(&raw.time, &centre);
        out.feet[s].strikes = out.feet[s]
            .strikes
            .iter()
            .map(|&z| fastest_descent(&raw.time, &vy, z))
            .collect();
    }
    for s in 0..2 {
        let (side, other) = if s == 0 { ('r', 'l') } else { ('l', 'r') };
        // A strike is where the foot is on the floor: within reach by its
        // distance (it may still slide); else the extremum was the swing's.
        let f = &mut out.feet[s];
        f.strikes
            .retain(|&t| foot_reaches(model, filtered, set, side, t, false));
        f.transitions = f
            .strikes
            .iter()
            .map(|&t| foot_reaches(model, filtered, set, other, t, true))
            .collect();
        for t in f.strikes.iter_mut().chain(f.offs.iter_mut()) {
            *t = on_frames(*t, &filtered.time);
        }
    }
    out
}

/// An event found at a sample of the raw motion, put at the time of the
/// frame that stands for the same sample. A motion whose time column is not
/// uniform is resampled at its smallest step before it is filtered, as
/// OpenSim does, and that grid drifts from the file's rounded times (knee_gc5:
/// a frame at 0.54999956 s for the sample at 0.55 s), so a strike's own frame
/// fell just before the strike and none of the knots that start at it held
/// there. Moved only when a frame lies within a hundredth of the grid's step
/// of it: the same sample, never a neighbouring one.
fn on_frames(t: f64, frames: &[f64]) -> f64 {
    if frames.len() < 2 {
        return t;
    }
    let i = frames.partition_point(|&f| f < t);
    let k = i.clamp(1, frames.len() - 1);
    let step = frames[k] - frames[k - 1];
    [k - 1, k]
        .into_iter()
        .map(|j| frames[j])
        .filter(|f| (f - t).abs() <= 0.01 * step)
        .min_by(|a, b| (a - t).abs().total_cmp(&(b - t).abs()))
        .unwrap_or(t)
}

/// Whether a point of foot `side` has a contact weight of at least
/// [`CARRY_WEIGHT`] at the row of `states` nearest time `t`: w(d), times
/// its slip gate when `gated` (the weight the contacts would have).
fn foot_reaches(
    model: &Model,
    states: &States,
    set: &FootContactSet,
    side: char,
    t: f64,
    gated: bool,
) -> bool {
    let Some(i) = (0..states.time.len()).min_by(|&a, &b| {
        (states.time[a] - t)
            .abs()
            .total_cmp(&(states.time[b] - t).abs())
    }) else {
        return false;
    };
    let mut data = Data::new(model);
    data.q.copy_from_slice(&states.q[i]);
    data.u.copy_from_slice(&states.u[i]);
    data.udot.iter_mut().for_each(|x| *x = 0.0);
    kinematics::full(model, &mut data);
    let p = &set.parameters;
    let n = set.floor_normal();
    set.points.iter().filter(|pt| pt.side == side).any(|pt| {
        let g = data.station_position(pt.body, &pt.local);
        let v = data.station_velocity(pt.body, &pt.local) - set.belt_velocity;
        let d = (g.y - set.floor_height_under(pt, g.x, g.z)) * n.y;
        let slip = (v - n * v.dot(&n)).norm();
        let x = ((slip - p.speed_weight.0) / (p.speed_weight.1 - p.speed_weight.0)).clamp(0.0, 1.0);
        let gate = if gated {
            1.0 - x * x * (3.0 - 2.0 * x)
        } else {
            1.0
        };
        super::kinematics::weight(d, p.contact_tolerance, p.transition_zone) * gate >= CARRY_WEIGHT
    })
}

/// Vertical velocity of `x` (m/s) by central differences on the samples'
/// own spacing; NaN at the ends.
pub fn vertical_velocity(time: &[f64], x: &[Vector3<f64>]) -> Vec<f64> {
    let n = x.len().min(time.len());
    (0..n)
        .map(|i| {
            if i == 0 || i + 1 >= n {
                f64::NAN
            } else {
                (x[i + 1].y - x[i - 1].y) / (time[i + 1] - time[i - 1])
            }
        })
        .collect()
}

/// The time of the foot centre's fastest descent (most negative `vy`)
/// within [`EVENT_WINDOW`] of the pre-detected strike `z` (O'Connor et al.
/// 2007); `z` itself when the window holds no finite velocity.
pub fn fastest_descent(time: &[f64], vy: &[f64], z: f64) -> f64 {
    let mut best = (f64::INFINITY, z);
    for (&t, &v) in time.iter().zip(vy) {
        if (t - z).abs() <= EVENT_WINDOW + 1e-9 && v < best.0 {
            best = (v, t);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A noisy plateau does not make two events; an extremum at the edge is
    /// none.
    #[test]
    fn extrema_need_the_window_and_no_edge() {
        let time: Vec<f64> = (0..101).map(|i| i as f64 * 0.01).collect();
        // Rises to a maximum at 0.5 s with a small ripple, and is highest at
        // the last sample.
        let x: Vec<f64> = time
            .iter()
            .map(|&t| {
                -(t - 0.5f64).powi(2) + 0.001 * (40.0 * t).sin() + if t > 0.99 { 9.0 } else { 0.0 }
            })
            .collect();
        let m = extrema(&time, &x, 0.1, true);
        assert_eq!(m.len(), 1, "{m:?}");
        assert!((time[m[0]] - 0.5).abs() <= 0.03, "{}", time[m[0]]);
    }

    /// An event at a raw sample goes to the frame of that sample when the
    /// resampled grid drifted from it (knee_gc5: 0.54999956 s for 0.55 s),
    /// and never to a neighbouring frame.
    #[test]
    fn events_are_put_on_the_frame_of_their_sample() {
        // A 120 Hz grid that drifted 0.44 µs by 0.55 s, as OpenSim's
        // resampling at the smallest rounded step makes it.
        let dt = 1.0 / 120.0 - 6.7e-9;
        let frames: Vec<f64> = (0..200).map(|i| i as f64 * dt).collect();
        let at = |t: f64| frames[frames.iter().position(|f| (f - t).abs() < 1e-5).unwrap()];
        assert!(at(0.55) < 0.55, "{}", at(0.55));
        assert_eq!(on_frames(0.55, &frames), at(0.55));
        assert_eq!(on_frames(0.0, &frames), 0.0);
        assert_eq!(on_frames(frames[199] + 1e-7, &frames), frames[199]);
        // Between two frames (a sample of a finer raw motion): unchanged.
        assert_eq!(on_frames(0.5542, &frames), 0.5542);
        assert_eq!(on_frames(0.5, &[0.5]), 0.5);
        // On the frame itself: itself.
        assert_eq!(on_frames(frames[7], &frames), frames[7]);
    }

    /// The landing foot's force along its leg: over the double support
    /// after its strike (to the other foot's foot-off), no force across the
    /// line from its heel to the mass centre, but over the heel-strike
    /// impact (its first 16 ms) no force along the walking direction; a
    /// second row that holds nothing; the trailing foot's own target
    /// unchanged. Merged per foot
    /// in time order, a landing knot inside a double support the foot
    /// trails through dropped; the summary names both roles.
    #[test]
    fn the_landing_foot_pushes_along_its_leg() {
        let mut ev = GaitEvents::default();
        ev.feet[0] = FootEvents {
            strikes: vec![0.5],
            offs: vec![],
            transitions: vec![true],
        };
        ev.feet[1].offs = vec![0.62];
        let (h, n) = (Vector3::x(), Vector3::y());
        // The mass centre 0.35 m behind the landing heel and 0.9 m above.
        let lean = Vector3::new(-0.35, 0.9, 0.0);
        let k = landing_targets(&ev, h, n, |_, _| Some(lean));
        assert!(k[1].is_empty(), "the trailing foot gets no landing target");
        let t = &k[0];
        assert_eq!(t.first().unwrap().0, 0.5);
        assert!(t.windows(2).all(|w| w[0].0 < w[1].0));
        let last = t.last().unwrap();
        assert!(!last.1 && (last.0 - 0.62).abs() < 1e-5, "{last:?}");
        let mut impact = 0;
        for knot in &t[..t.len() - 1] {
            assert!(knot.1 && is_landing_knot(knot));
            let (across, f) = knot.2[0];
            assert_eq!(f, 0.0);
            if knot.0 - 0.5 <= HEEL_STRIKE_IMPACT + 1e-9 {
                // The impact: the row holds the force along h to zero.
                assert!((across - h).norm() < 1e-12, "{}: {across:?}", knot.0);
                impact += 1;
            } else {
                assert!(across.dot(&lean).abs() < 1e-12 && across.z == 0.0);
            }
            assert!((across.norm() - 1.0).abs() < 1e-12);
        }
        // Knots at 0, 5, 10 and 15 ms (0.12 s in 24 steps).
        assert_eq!(impact, 4, "{t:?}");
        // Merged with the trailing foot's target: foot 0 lands at 0.5 and
        // trails from 0.9; its landing knots after 0.9 (a second strike of
        // its own inside that span) are dropped.
        let trailing_knot = |t: f64, on: bool| (t, on, vec![(n, 300.0), (h, 0.0)]);
        let trailing = [
            vec![trailing_knot(0.9, true), trailing_knot(1.0, false)],
            Vec::new(),
        ];
        let mut landing = k.clone();
        landing[0].push((0.95, true, vec![(h, 0.0), (Vector3::zeros(), 0.0)]));
        let held = [vec![(0.9, 1.0)], Vec::new()];
        let m = merge_targets(trailing, landing, &held);
        assert_eq!(m[0].len(), t.len() + 2, "{:?}", m[0]);
        assert!(m[0].windows(2).all(|w| w[0].0 < w[1].0));
        assert!(m[0].iter().all(|k| k.0 < 0.9 || !is_landing_knot(k)));
        let note = targets_note('r', &m[0], true).unwrap();
        assert!(
            note.contains("trails through double support over [0.900, 0.900] s")
                && note.contains("lands into double support over [0.500, 0.620] s")
                && note.contains("its first 16 ms, it has none along the walking direction"),
            "{note}"
        );
    }

    /// A muscle-driven model's trailing foot (step 8): over the double
    /// support after the other foot's transition strike (to its own
    /// foot-off), no force across the line from its toe to the mass centre
    /// (in the plane of h and n), and its mediolateral force (along n × h)
    /// on Ren's decay from the motion's lateral requirement at the strike;
    /// then off. No vertical row. The landing foot gets none of it, a strike
    /// that takes over from no foot none at all, and the summary says so.
    #[test]
    fn a_muscle_models_trailing_foot_pushes_along_its_leg() {
        let mut ev = GaitEvents::default();
        ev.feet[0] = FootEvents {
            strikes: vec![0.5, 1.6],
            offs: vec![],
            transitions: vec![true, false],
        };
        ev.feet[1].offs = vec![0.62];
        let (h, n) = (Vector3::x(), Vector3::y());
        let m = n.cross(&h);
        // The requirement at the strike: 700 N up, 40 N along m, 90 N ahead.
        let r = n * 700.0 + m * 40.0 + h * 90.0;
        let lean = Vector3::new(0.3, 0.9, 0.05);
        let k = trailing_line_targets(&ev, h, n, |_| Some(r), |_, _| Some(lean));
        assert!(k[0].is_empty(), "the landing foot trails through nothing");
        let t = &k[1];
        assert_eq!(t.first().unwrap().0, 0.5);
        let last = t.last().unwrap();
        assert!(!last.1 && (last.0 - 0.62).abs() < 1e-5, "{last:?}");
        for knot in &t[..t.len() - 1] {
            assert!(knot.1 && !is_landing_knot(knot));
            let [(across, f0), (axis, f1)] = knot.2[..] else {
                panic!("two rows: {knot:?}");
            };
            assert_eq!(f0, 0.0);
            if knot.0 - 0.5 <= HEEL_STRIKE_IMPACT + 1e-9 {
                // Over the landing heel's impact the line holds nothing.
                assert_eq!(across, Vector3::zeros(), "{}", knot.0);
            } else {
                assert!((across.norm() - 1.0).abs() < 1e-12);
                assert!(across.dot(&n.cross(&h)).abs() < 1e-12);
                assert!(across.dot(&Vector3::new(0.3, 0.9, 0.0)).abs() < 1e-12);
            }
            assert!((axis - m).norm() < 1e-12);
            let share = trailing_share(knot.0 - 0.5, 0.12);
            assert!((f1 - 40.0 * share).abs() < 1e-9, "{}: {f1}", knot.0);
        }
        assert_eq!(t[0].2[1].1, 40.0);
        let note = targets_note('l', t, false).unwrap();
        assert_eq!(
            note,
            "foot l trails through double support over [0.500, 0.620] s from 40 N mediolateral: its force points along the line from its toe to the body's mass centre, and its mediolateral force falls as Ren et al. 2008's smooth transition, exp(-(2t/T)^3); how much it carries is the effort minimum's"
        );
    }

    /// The impact alone (muscle-driven walking): per transition strike,
    /// knots from the strike to 16 ms after it, each holding the force
    /// along the walking direction h to zero (the landing target's impact
    /// rows), then off; a strike that takes over from no foot (running)
    /// gets none; the summary names the impact, not a landing along the leg.
    #[test]
    fn the_impact_alone_holds_the_landing_heels_ap_force() {
        let mut ev = GaitEvents::default();
        ev.feet[0] = FootEvents {
            strikes: vec![0.5, 1.6],
            offs: vec![],
            transitions: vec![true, false],
        };
        ev.feet[1] = FootEvents {
            strikes: vec![1.05],
            offs: vec![0.62],
            transitions: vec![true],
        };
        let h = Vector3::new(0.0, 0.0, -1.0);
        let k = impact_targets(&ev, h);
        for (foot, ts) in [(0, 0.5), (1, 1.05)] {
            let t = &k[foot];
            assert_eq!(t.first().unwrap().0, ts);
            assert!(t.windows(2).all(|w| w[0].0 < w[1].0));
            let last = t.last().unwrap();
            assert!(
                !last.1 && (last.0 - ts - HEEL_STRIKE_IMPACT).abs() < 1e-5,
                "{t:?}"
            );
            // Knots every 4 ms (16 ms in 4 steps), both ends on.
            assert_eq!(t.len(), 6, "{t:?}");
            for knot in &t[..5] {
                assert!(knot.1 && is_landing_knot(knot));
                assert_eq!(knot.2[0], (h, 0.0));
            }
            // The same rows as the landing target's over its impact (whose
            // third row, the trailing target's mediolateral one, holds
            // nothing).
            let landing = landing_targets(&ev, h, Vector3::y(), |_, _| {
                Some(Vector3::new(0.0, 0.9, 0.3))
            });
            assert_eq!(landing[foot][0].2[..2], t[0].2[..]);
            assert_eq!(landing[foot][0].2[2], (Vector3::zeros(), 0.0));
        }
        let note = targets_note('r', &k[0], false).unwrap();
        assert_eq!(
            note,
            "foot r's heel-strike impact over [0.500, 0.516] s: no force along the walking direction"
        );
        assert!(impact_targets(&GaitEvents::default(), h)
            .iter()
            .all(|t| t.is_empty()));
    }

    /// The vertical share is OpenSimRT's fitted logistic: at their double
    /// support of 0.12 s it is their function of time (B in 1/s, the
    /// midpoint at m T_ds) divided by its value at the strike, and it
    /// scales with T_ds; 1 at the strike, falling, 0.62 halfway (the
    /// development plates 0.57–0.74, Ren 0.37), within [0, 1].
    #[test]
    fn the_vertical_share_is_the_measured_logistic_scaled_to_the_double_support() {
        let their = |t: f64| {
            let (a, k, c, b, q, m, v) = (
                1.1193681826492452,
                -1.6038212670613377,
                3.037706815056258,
                61.29534891423534,
                0.5067639996015457,
                0.9396455521564754,
                0.42306183726767493,
            );
            a + k / (c + q * (-b * (t - m * 0.12f64)).exp()).powf(v)
        };
        assert_eq!(trailing_vertical_share(0.0, 0.12), 1.0);
        for i in 1..=24 {
            let t = 0.005 * i as f64;
            let s = trailing_vertical_share(t, 0.12);
            assert!((s - their(t) / their(0.0)).abs() < 1e-12, "{t}: {s}");
            // Scaled: the same share at the same fraction of any T_ds.
            assert!((trailing_vertical_share(t * 0.5, 0.06) - s).abs() < 1e-12);
            assert!(s < trailing_vertical_share(t - 0.005, 0.12) && (0.0..=1.0).contains(&s));
        }
        let half = trailing_vertical_share(0.06, 0.12);
        assert!((half - 0.62).abs() < 0.01, "halfway {half}");
        assert!(half > trailing_share(0.06, 0.12) + 0.2);
    }

    /// Over the double support a foot lands into (the other foot's held
    /// interval), its points but the heel's carry nothing; over the one it
    /// trails through, none is switched off.
    #[test]
    fn a_landing_foot_stands_on_its_heel() {
        let point = |name: &str, side: char| FootPoint {
            name: format!("foot_{name}_{side}"),
            side,
            body: 0,
            body_name: String::new(),
            local: Vector3::zeros(),
            contact_level: 0.0,
            dwell_xz: (0.0, 0.0),
        };
        let points = [
            point("heel_med", 'r'),
            point("midfoot_lat", 'r'),
            point("meta1", 'r'),
            point("hallux", 'r'),
            point("heel_lat", 'l'),
            point("meta5", 'l'),
        ];
        // The left foot trails through [0.5, 0.6) (the right lands), the
        // right through [1.0, 1.12) (the left lands).
        let held = [vec![(1.0, 1.12)], vec![(0.5, 0.6)]];
        let off = heel_rocker_intervals(&points, &held);
        assert_eq!(off[0], Vec::<(f64, f64)>::new());
        for k in 1..4 {
            assert_eq!(off[k], vec![(0.5, 0.6)], "{}", points[k].name);
        }
        assert_eq!(off[4], Vec::<(f64, f64)>::new());
        assert_eq!(off[5], vec![(1.0, 1.12)]);
    }

    /// The trailing foot's targets span the double support to its foot-off
    /// (else to the end of the kinematics, or 0.11 s), hold its vertical
    /// force to the requirement at the strike times the share, and its
    /// force along its leg (no part across the line from its toe to the
    /// mass centre); the landing foot gets none.
    #[test]
    fn the_trailing_foot_follows_its_transition_along_its_leg() {
        assert_eq!(trailing_share(0.0, 0.12), 1.0);
        assert!((trailing_share(0.06, 0.12) - (-1.0f64).exp()).abs() < 1e-12);
        assert!(trailing_share(0.12, 0.12) < 1e-3);
        let mut ev = GaitEvents::default();
        ev.feet[0] = FootEvents {
            strikes: vec![0.5],
            offs: vec![],
            transitions: vec![true],
        };
        ev.feet[1].offs = vec![0.62];
        let (h, n) = (Vector3::x(), Vector3::y());
        let r = Vector3::new(40.0, 700.0, 3.0);
        // The mass centre 0.3 m ahead of the toe and 0.9 m above it.
        let lean = Vector3::new(0.3, 0.9, 0.0);
        let k = trailing_targets(&ev, h, n, |_| Some(r), |_, _| Some(lean));
        assert!(k[0].is_empty(), "the landing foot has no target");
        let t = &k[1];
        assert!(t.windows(2).all(|w| w[0].0 < w[1].0));
        assert_eq!(t.first().unwrap().0, 0.5);
        let last = t.last().unwrap();
        assert!(!last.1 && (last.0 - 0.62).abs() < 1e-5, "{last:?}");
        for (tk, on, rows) in &t[..t.len() - 1] {
            assert!(*on);
            let want = 700.0 * trailing_vertical_share(tk - 0.5, 0.12);
            assert_eq!(rows[0].0, n);
            assert!((rows[0].1 - want).abs() < 1e-9, "{tk}: {rows:?}");
            assert!(!is_landing_knot(&(*tk, *on, rows.clone())));
            // The mediolateral force on Ren's share of the strike's.
            let m = n.cross(&h).normalize();
            assert_eq!(rows[2].0, m);
            let ml = r.dot(&m) * trailing_share(tk - 0.5, 0.12);
            assert!((rows[2].1 - ml).abs() < 1e-9, "{tk}: {rows:?}");
            if tk - 0.5 <= HEEL_STRIKE_IMPACT + 1e-9 {
                // Over the landing heel's impact the line holds nothing.
                assert_eq!(rows[1], (Vector3::zeros(), 0.0), "{tk}");
                continue;
            }
            // A force along the leg has no part across it.
            assert!(rows[1].0.dot(&lean).abs() < 1e-12 && rows[1].1 == 0.0);
            assert!((rows[1].0.norm() - 1.0).abs() < 1e-12);
        }
        // Without the trailing foot's foot-off: to the end of the
        // kinematics when that is within 0.3 s, else 0.11 s.
        ev.feet[1].offs.clear();
        ev.end = 0.68;
        let t = &trailing_targets(&ev, h, n, |_| Some(r), |_, _| Some(lean))[1];
        assert!((t.last().unwrap().0 - 0.68).abs() < 1e-5);
        ev.end = 0.9;
        let t = &trailing_targets(&ev, h, n, |_| Some(r), |_, _| Some(lean))[1];
        assert!((t.last().unwrap().0 - 0.5 - DEFAULT_DOUBLE_SUPPORT).abs() < 1e-5);
        // No requirement known at the strike: no target.
        let t = trailing_targets(&ev, h, n, |_| None, |_, _| Some(lean));
        assert!(t[1].is_empty());
    }

    /// The trailing foot is held through each double support it trails
    /// through (from the other foot's transition strike to its foot-off,
    /// else as [`double_support`]); the landing foot and running's strikes
    /// (no transition) hold nothing.
    #[test]
    fn the_trailing_foot_is_held_through_double_support() {
        let mut ev = GaitEvents {
            end: 2.0,
            ..GaitEvents::default()
        };
        ev.feet[0] = FootEvents {
            strikes: vec![0.5, 1.6],
            offs: vec![],
            transitions: vec![true, false],
        };
        ev.feet[1] = FootEvents {
            strikes: vec![1.05],
            offs: vec![0.62],
            transitions: vec![true],
        };
        let h = held_intervals(&ev);
        assert_eq!(h[1].len(), 1, "{h:?}");
        assert!((h[1][0].0 - 0.5).abs() < 1e-12 && (h[1][0].1 - 0.62).abs() < 1e-12);
        // The right foot trails after the left's strike at 1.05, with no
        // foot-off of its own: 0.11 s (the trial goes on for 0.95 s).
        assert_eq!(h[0].len(), 1, "{h:?}");
        assert!((h[0][0].1 - 1.05 - DEFAULT_DOUBLE_SUPPORT).abs() < 1e-12);
        for f in ev.feet.iter_mut() {
            f.transitions.iter_mut().for_each(|x| *x = false);
        }
        assert!(held_intervals(&ev).iter().all(|v| v.is_empty()));
    }

    #[test]
    fn off_intervals_run_from_the_foot_off_or_a_swing_before() {
        let mut f = FootEvents {
            strikes: vec![0.3, 1.4, 2.5],
            offs: vec![0.9, 2.0],
            transitions: vec![true, true, false],
        };
        assert_eq!(
            off_intervals(&f),
            vec![(0.3 - SWING_BEFORE_STRIKE, 0.3), (0.9, 1.4)]
        );
        // Running: no other foot on the floor at the strikes, nothing off.
        f.transitions = vec![false; 3];
        assert!(off_intervals(&f).is_empty());
    }
}
