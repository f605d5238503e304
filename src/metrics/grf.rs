//! predict-grf's statistics and acceptance rules (docs/grf_prediction.md):
//! agreement with the measured plates per foot and axis, centre-of-pressure
//! and event-timing errors over stance, and the physics' judgement of a
//! prediction (the root residual frame by frame, the feet's mean support).

use crate::contacts::ground::FootLoads;
use crate::metrics::EXIT_FRAMES_FAILED;

/// Agreement of the prediction with the measured loads, per foot and axis.
#[derive(Debug, Clone)]
pub struct AxisMetrics {
    pub side: char,
    pub axis: char,
    pub rho: f64,
    pub rmse_n: f64,
    pub rmse_bw: f64,
    pub peak_error_n: f64,
}

/// A root residual above this share of body weight means the contacts did
/// not carry the body on that frame (issue 27).
pub const REJECT_ROOT_RESIDUAL: f64 = 0.25;
/// More than this share of the frames with such a root residual: the
/// prediction is not a result (exit status 3).
pub const REJECT_FRAME_SHARE: f64 = 0.05;

/// The frames whose root residual exceeds [`REJECT_ROOT_RESIDUAL`] of
/// `body_weight`, and the line that rejects the prediction when they are more
/// than [`REJECT_FRAME_SHARE`] of all frames (None: accepted). Every frame is
/// judged, flight included: in free fall the body needs no force, so a root
/// residual there means the motion asks for a force no contact can give (a
/// low-pass filter smears the stance's acceleration into the flight), and a
/// trial whose pelvis carries a quarter of body weight on more than 5 % of
/// its frames is not a result, whatever the cause (issue 27's bar).
/// `flight[i]`: no foot point of frame i is within reach of the floor; it
/// only splits the count in the message.
pub fn judge_root_residual(
    series: &[(f64, f64)],
    flight: &[bool],
    body_weight: f64,
) -> (Vec<f64>, Option<String>) {
    let judged = series;
    let over: Vec<(f64, f64)> = judged
        .iter()
        .copied()
        .filter(|&(_, f)| !(f <= REJECT_ROOT_RESIDUAL * body_weight))
        .collect();
    let over_in_flight = judged
        .iter()
        .enumerate()
        .filter(|&(i, &(_, f))| {
            flight.get(i).copied().unwrap_or(false) && !(f <= REJECT_ROOT_RESIDUAL * body_weight)
        })
        .count();
    let times: Vec<f64> = over.iter().map(|x| x.0).collect();
    if judged.is_empty() || (over.len() as f64) <= REJECT_FRAME_SHARE * judged.len() as f64 {
        return (times, None);
    }
    let worst = over.iter().copied().fold((f64::NAN, 0.0f64), |m, x| {
        if x.1 > m.1 || m.0.is_nan() {
            x
        } else {
            m
        }
    });
    let line = format!(
        "the prediction is rejected by the physics: on {} of {} frames ({:.0} %, more than {:.0} %) the root residual (every actuator on the pelvis translations) carried more than {:.0} % of body weight, up to {:.0} % at t = {:.3} s (first at t = {:.3} s, last at t = {:.3} s): {}; the comparison is written, but these forces are not a result; exit status {}",
        over.len(),
        judged.len(),
        100.0 * over.len() as f64 / judged.len() as f64,
        100.0 * REJECT_FRAME_SHARE,
        100.0 * REJECT_ROOT_RESIDUAL,
        100.0 * worst.1 / body_weight,
        worst.0,
        times[0],
        times[times.len() - 1],
        if 2 * over_in_flight > over.len() {
            format!(
                "the kinematics, not the contacts: {over_in_flight} of them are in flight, where no foot is within reach of the floor and a body in free fall needs no force, yet the filtered motion asks for it (its whole-body acceleration is not free fall there)"
            )
        } else if over_in_flight > 0 {
            format!(
                "the foot contacts did not carry the body there ({over_in_flight} of them in flight, where no foot is within reach of the floor: the filtered motion asks for force the body cannot get in free fall)"
            )
        } else {
            "the foot contacts did not carry the body there".to_string()
        },
        EXIT_FRAMES_FAILED
    );
    (times, Some(line))
}

pub fn n_flight_of(flight: &[bool]) -> usize {
    flight.iter().filter(|&&f| f).count()
}

/// The feet must carry the body over the trial: the mean over its frames of
/// the predicted vertical force of both feet is body weight (over a gait
/// cycle the body's mean vertical acceleration is nil; over one step within
/// a few %). Below (1 − [`REJECT_ROOT_RESIDUAL`]) of it the contacts did not
/// carry the body, whatever the frames judged one by one say (a floor put
/// too low makes every frame look like flight): the line that rejects the
/// prediction, else None.
pub fn judge_support(pred: &FootLoads, body_weight: f64, flight_frames: usize) -> Option<String> {
    let n = pred.time.len();
    if n == 0 || body_weight <= 0.0 {
        return None;
    }
    let mean = (0..n)
        .map(|i| pred.force[0][i].y + pred.force[1][i].y)
        .sum::<f64>()
        / n as f64;
    let share = mean / body_weight;
    (!(share >= 1.0 - REJECT_ROOT_RESIDUAL)).then(|| {
        format!(
            "the prediction is rejected by the physics: over the trial the feet carried {:.0} % of body weight on average (less than {:.0} %; {} of {} frames had no foot within reach of the floor): the foot contacts did not carry the body, the pelvis did; the comparison is written, but these forces are not a result; exit status {}",
            100.0 * share,
            100.0 * (1.0 - REJECT_ROOT_RESIDUAL),
            flight_frames,
            n,
            EXIT_FRAMES_FAILED
        )
    })
}

/// Stance: vertical force above this (N).
pub const STANCE_THRESHOLD: f64 = 20.0;

/// Per foot, over stance: mean centre-of-pressure error in the floor plane
/// (mm, frames where both vertical forces exceed [`STANCE_THRESHOLD`]) and
/// mean timing error of heel strikes and toe-offs (ms, each measured event
/// matched to the nearest predicted one of the same kind).
#[derive(Debug, Clone)]
pub struct StanceMetrics {
    pub side: char,
    /// NaN when no frame has both feet's forces over the threshold.
    pub cop_error_mm: f64,
    /// NaN unless both the plates and the prediction have one.
    pub heel_strike_error_ms: f64,
    pub toe_off_error_ms: f64,
    /// How many heel strikes (toe-offs) the plates and the prediction show
    /// in the trial: (measured, predicted).
    pub heel_strikes: (usize, usize),
    pub toe_offs: (usize, usize),
}

impl StanceMetrics {
    /// The run's line for this foot, saying in words what has no number
    /// (e.g. a heel strike before the trial's first frame).
    pub fn summary(&self) -> String {
        let event = |what: &str, ms: f64, (measured, predicted): (usize, usize)| match (
            measured, predicted,
        ) {
            (0, 0) => format!("no {what} in the trial"),
            (0, n) => format!("{what}: none on the plates, {n} predicted"),
            (n, 0) => format!("{what}: {n} on the plates, none predicted"),
            _ => format!("{what} {ms:.0} ms"),
        };
        let cop = if self.cop_error_mm.is_finite() {
            format!(
                "centre of pressure off by {:.0} mm over stance",
                self.cop_error_mm
            )
        } else {
            "centre of pressure: no frame where both the plates and the prediction load the foot"
                .to_string()
        };
        format!(
            "foot {}: {cop}; {}, {}",
            self.side,
            event("heel strike", self.heel_strike_error_ms, self.heel_strikes),
            event("toe-off", self.toe_off_error_ms, self.toe_offs)
        )
    }
}

/// Times where the vertical force crosses the stance threshold upwards
/// (heel strike) and downwards (toe-off).
fn events(time: &[f64], fy: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut on, mut off) = (Vec::new(), Vec::new());
    for i in 1..fy.len() {
        let (a, b) = (fy[i - 1] > STANCE_THRESHOLD, fy[i] > STANCE_THRESHOLD);
        if !a && b {
            on.push(time[i]);
        } else if a && !b {
            off.push(time[i]);
        }
    }
    (on, off)
}

fn event_error_ms(measured: &[f64], predicted: &[f64]) -> f64 {
    if measured.is_empty() || predicted.is_empty() {
        return f64::NAN;
    }
    let sum: f64 = measured
        .iter()
        .map(|m| {
            predicted
                .iter()
                .map(|p| (p - m).abs())
                .fold(f64::INFINITY, f64::min)
        })
        .sum();
    1000.0 * sum / measured.len() as f64
}

/// [`StanceMetrics`] of foot `s`.
pub fn stance_metrics(side: char, pred: &FootLoads, meas: &FootLoads, s: usize) -> StanceMetrics {
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..pred.time.len() {
        if pred.force[s][i].y > STANCE_THRESHOLD && meas.force[s][i].y > STANCE_THRESHOLD {
            let (a, b) = (pred.cop[s][i], meas.cop[s][i]);
            let d = ((a.x - b.x).powi(2) + (a.z - b.z).powi(2)).sqrt();
            if d.is_finite() {
                sum += d;
                n += 1;
            }
        }
    }
    let fy = |l: &FootLoads| l.force[s].iter().map(|f| f.y).collect::<Vec<f64>>();
    let (pon, poff) = events(&pred.time, &fy(pred));
    let (mon, moff) = events(&meas.time, &fy(meas));
    StanceMetrics {
        side,
        cop_error_mm: if n > 0 {
            1000.0 * sum / n as f64
        } else {
            f64::NAN
        },
        heel_strike_error_ms: event_error_ms(&mon, &pon),
        toe_off_error_ms: event_error_ms(&moff, &poff),
        heel_strikes: (mon.len(), pon.len()),
        toe_offs: (moff.len(), poff.len()),
    }
}

/// Pearson rho, RMSE (N and % body weight) and peak error per foot and axis.
pub fn compare(pred: &FootLoads, meas: &FootLoads, body_weight: f64) -> Vec<AxisMetrics> {
    let mut out = Vec::new();
    for (s, side) in ['r', 'l'].into_iter().enumerate() {
        for (k, axis) in ['x', 'y', 'z'].into_iter().enumerate() {
            let a: Vec<f64> = pred.force[s].iter().map(|v| v[k]).collect();
            let b: Vec<f64> = meas.force[s].iter().map(|v| v[k]).collect();
            let n = a.len().max(1) as f64;
            let rmse = (a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n).sqrt();
            let peak = |v: &[f64]| {
                v.iter()
                    .fold(0.0f64, |m, x| if x.abs() > m.abs() { *x } else { m })
            };
            out.push(AxisMetrics {
                side,
                axis,
                rho: pearson(&a, &b),
                rmse_n: rmse,
                rmse_bw: 100.0 * rmse / body_weight,
                peak_error_n: peak(&a) - peak(&b),
            });
        }
    }
    out
}

/// Pearson's correlation coefficient (NaN for a constant series).
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}
#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// A foot already on the plate at the trial's first frame has no heel
    /// strike to time: the line says so in words, never "NaN ms".
    #[test]
    fn stance_line_says_what_has_no_number() {
        let time: Vec<f64> = (0..10).map(|i| 0.01 * i as f64).collect();
        let fy = |on: &dyn Fn(usize) -> bool| -> Vec<Vector3<f64>> {
            (0..10)
                .map(|i| Vector3::new(0.0, if on(i) { 500.0 } else { 0.0 }, 0.0))
                .collect()
        };
        let loads = |off_at: usize| FootLoads {
            time: time.clone(),
            force: [fy(&|i| i < off_at), fy(&|i| i >= 3)],
            cop: [vec![Vector3::zeros(); 10], vec![Vector3::zeros(); 10]],
            free_moment: [vec![0.0; 10], vec![0.0; 10]],
        };
        let (meas, pred) = (loads(6), loads(5));
        let right = stance_metrics('r', &pred, &meas, 0);
        assert_eq!(right.heel_strikes, (0, 0));
        assert_eq!(right.toe_offs, (1, 1));
        let line = right.summary();
        assert!(!line.contains("NaN"), "{line}");
        assert!(line.contains("no heel strike in the trial"), "{line}");
        assert!(line.contains("toe-off 10 ms"), "{line}");
        let left = stance_metrics('l', &pred, &meas, 1).summary();
        assert!(
            left.contains("heel strike 0 ms") && left.contains("no toe-off in the trial"),
            "{left}"
        );
        // Predicted but not measured.
        let mut late = loads(6);
        late.force[0] = fy(&|i| (2..6).contains(&i));
        let line = stance_metrics('r', &late, &meas, 0).summary();
        assert!(
            line.contains("heel strike: none on the plates, 1 predicted"),
            "{line}"
        );
    }

    /// The honesty bar: more than 5 % of the frames with a root residual
    /// above 25 % body weight rejects the prediction and names times of the
    /// trial; flight frames, where nothing is required, pass; so do a few
    /// bad frames.
    #[test]
    fn root_residual_judgement() {
        let bw = 700.0;
        // Running: stance carried by the feet, flight in free fall.
        let ok: Vec<(f64, f64)> = (0..100)
            .map(|i| (0.17 + 0.01 * i as f64, if i % 3 == 0 { 0.0 } else { 20.0 }))
            .collect();
        let none = vec![false; 100];
        let (over, rejected) = judge_root_residual(&ok, &none, bw);
        assert!(over.is_empty() && rejected.is_none());
        // Five bad frames in 100: accepted, the frames named.
        let mut few = ok.clone();
        for f in few.iter_mut().take(5) {
            f.1 = 300.0;
        }
        let (over, rejected) = judge_root_residual(&few, &none, bw);
        assert_eq!(over.len(), 5);
        assert!(rejected.is_none());
        // Six: rejected, and the line names times inside the trial.
        let mut bad = few.clone();
        bad[50].1 = 2000.0;
        let (_, rejected) = judge_root_residual(&bad, &none, bw);
        let line = rejected.expect("rejected");
        assert!(line.contains("6 of 100"), "{line}");
        assert!(line.contains("at t = 0.670 s"), "{line}");
        assert!(line.contains("first at t = 0.170 s"), "{line}");
        // A NaN residual counts as over.
        let mut nan = ok.clone();
        for f in nan.iter_mut().take(6) {
            f.1 = f64::NAN;
        }
        assert!(judge_root_residual(&nan, &none, bw).1.is_some());
        // Flight frames (no foot within reach of the floor) are judged too:
        // a filtered motion that asks 40 % of body weight there is not a
        // body in free fall, and the message says how many were in flight.
        let flight: Vec<bool> = (0..100).map(|i| i % 3 == 0).collect();
        let mut run = ok.clone();
        for (f, &fl) in run.iter_mut().zip(&flight) {
            if fl {
                f.1 = 0.4 * bw;
            }
        }
        assert!(judge_root_residual(&run, &none, bw).1.is_some());
        let line = judge_root_residual(&run, &flight, bw).1.expect("rejected");
        assert!(line.contains("34 of them are in flight"), "{line}");
        // Most of the frames over the line are in flight: the message
        // blames the kinematics, not the contacts (issue 36).
        assert!(line.contains("the kinematics, not the contacts"), "{line}");
        assert!(!line.contains("the foot contacts did not carry"), "{line}");
        // Flight frames asking nothing pass.
        assert!(judge_root_residual(&ok, &flight, bw).1.is_none());
        // A prediction with no force on feet that stand on the floor is
        // judged (those frames are not flight), and rejected.
        let collapsed: Vec<(f64, f64)> = (0..100).map(|i| (0.01 * i as f64, bw)).collect();
        let line = judge_root_residual(&collapsed, &none, bw)
            .1
            .expect("rejected");
        assert!(line.contains("100 of 100"), "{line}");
        assert!(
            line.contains("the foot contacts did not carry the body"),
            "{line}"
        );
    }

    /// Feet that carry the body on average pass; a prediction whose every
    /// frame looks like flight (a floor put too low: no contact reaches it)
    /// is rejected by the mean support.
    #[test]
    fn the_feet_must_carry_the_body_on_average() {
        let bw = 700.0;
        let loads = |fy: f64| FootLoads {
            time: vec![0.0, 0.01, 0.02, 0.03],
            force: [
                vec![
                    Vector3::new(0.0, fy, 0.0),
                    Vector3::zeros(),
                    Vector3::new(0.0, 2.0 * fy, 0.0),
                    Vector3::zeros(),
                ],
                vec![
                    Vector3::new(0.0, fy, 0.0),
                    Vector3::new(0.0, fy, 0.0),
                    Vector3::zeros(),
                    Vector3::zeros(),
                ],
            ],
            ..Default::default()
        };
        // Mean (2 + 1 + 2 + 0) fy / 4 = 1.25 fy.
        assert!(judge_support(&loads(bw / 1.25), bw, 1).is_none());
        assert!(judge_support(&loads(0.8 * bw / 1.25), bw, 1).is_none());
        let line = judge_support(&loads(0.0), bw, 4).expect("rejected");
        assert!(
            line.contains("carried 0 %") && line.contains("4 of 4 frames"),
            "{line}"
        );
        // Everything in flight with the pelvis carrying the body: rejected
        // frame by frame as well.
        let series: Vec<(f64, f64)> = (0..4).map(|i| (0.01 * i as f64, bw)).collect();
        assert!(judge_root_residual(&series, &[true; 4], bw).1.is_some());
    }
}
