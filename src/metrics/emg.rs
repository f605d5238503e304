//! How well static optimization's activations agree with measured EMG
//! (`statopt-tool emg-compare`, docs/emg_compare.md): the statistics; the
//! tool reads the files and `writers::emg` writes the table and figure.
//!
//! Per EMG channel, the activation of the muscle it records (or the mean of
//! a group of muscles: one electrode over the three heads of the gluteus
//! maximus) is compared at the activation file's frames with the EMG
//! envelope, linearly interpolated at `t − delay`:
//!
//! - **Pearson r** of the two time courses (shape, not magnitude: EMG
//!   envelopes are normalised to a peak of their own, activations are not);
//! - **on/off agreement**: the fraction of frames where both signals are on
//!   or both off, a signal being on where it reaches `on_fraction` of its
//!   peak over the compared frames (a single-threshold onset criterion, the
//!   most used kind, Carvalho et al. 2023, doi:10.1186/s12984-023-01268-8);
//! - the delay in [0, [`MAX_DELAY_MS`]] ms that maximises r, and that r: EMG
//!   precedes the force it causes by the electromechanical delay, tens of
//!   milliseconds (Cavanagh & Komi 1979, Eur J Appl Physiol 42:159; EMG-driven
//!   models fit 10–100 ms, Lloyd & Besier 2003, J Biomech 36:765). The
//!   comparison itself uses the delay the user gives (`--delay-ms`, default
//!   0); the best delay is reported, never applied.
//!
//! The channel → muscle map is a text file ([`parse_map`]), or the default
//! for the Rajagopal et al. (2016) model's muscle names and the ten channels
//! of its gait EMG ([`default_map`]).
use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::storage::Storage;

/// The fraction of a signal's peak (over the compared frames) at and above
/// which it counts as on, unless `--on-fraction` says otherwise.
pub const DEFAULT_ON_FRACTION: f64 = 0.25;

/// The longest electromechanical delay searched for the best r (ms).
pub const MAX_DELAY_MS: f64 = 100.0;

/// The step of that search (ms).
pub const DELAY_STEP_MS: f64 = 5.0;

/// One EMG channel and the muscles (activation columns) it records.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelMap {
    pub channel: String,
    pub muscles: Vec<String>,
    /// Where the map gave it (file and line), for messages.
    pub from: Option<Location>,
}

/// The default map: the ten channels of the Rajagopal et al. (2016) gait
/// EMG (as in OpenSim Moco's example3DWalking `electromyography.sto`) to
/// that model's muscles on `side` (`r` or `l`). One muscle per channel, or
/// the mean of the heads one surface electrode records: gluteus maximus
/// 1–3, gluteus medius 1–3, semimembranosus with semitendinosus. The
/// gastrocnemius channel is the medial head, the biceps femoris channel the
/// long head (the surface electrode's usual sites).
pub fn default_map(side: char) -> Vec<ChannelMap> {
    let table: [(&str, &[&str]); 10] = [
        ("soleus", &["soleus"]),
        ("gastrocnemius", &["gasmed"]),
        ("tibialis_anterior", &["tibant"]),
        ("medial_hamstrings", &["semimem", "semiten"]),
        ("biceps_femoris", &["bflh"]),
        ("vastus_lateralis", &["vaslat"]),
        ("vastus_medius", &["vasmed"]),
        ("rectus_femoris", &["recfem"]),
        ("gluteus_maximus", &["glmax1", "glmax2", "glmax3"]),
        ("gluteus_medius", &["glmed1", "glmed2", "glmed3"]),
    ];
    table
        .iter()
        .map(|(c, ms)| ChannelMap {
            channel: c.to_string(),
            muscles: ms.iter().map(|m| format!("{m}_{side}")).collect(),
            from: None,
        })
        .collect()
}

/// A map file: one channel per line, `channel: muscle [muscle ...]` (the
/// muscles' activations are averaged); `#` starts a comment; blank lines
/// are skipped. Errors name the file and line.
pub fn parse_map(text: &str, path: &Path) -> Result<Vec<ChannelMap>> {
    let mut out: Vec<ChannelMap> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let loc = Location::file(path).with_line(i + 1);
        let body = line.split('#').next().unwrap_or("").trim();
        if body.is_empty() {
            continue;
        }
        let Some((channel, muscles)) = body.split_once(':') else {
            return Err(Error::input(
                loc,
                format!("expected 'channel: muscle [muscle ...]', found '{body}'"),
            ));
        };
        let channel = channel.trim();
        let muscles: Vec<String> = muscles.split_whitespace().map(String::from).collect();
        if channel.is_empty() || muscles.is_empty() {
            return Err(Error::input(
                loc,
                format!("a channel needs a name and at least one muscle, found '{body}'"),
            ));
        }
        if out.iter().any(|c| c.channel == channel) {
            return Err(Error::input(
                loc,
                format!("channel '{channel}' is mapped twice"),
            ));
        }
        out.push(ChannelMap {
            channel: channel.to_string(),
            muscles,
            from: Some(loc),
        });
    }
    if out.is_empty() {
        return Err(Error::input(
            Location::file(path),
            "the map names no channel",
        ));
    }
    Ok(out)
}

/// [`parse_map`] of a file.
pub fn read_map(path: &Path) -> Result<Vec<ChannelMap>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_map(&text, path)
}

/// How the signals are compared.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// The EMG at `t − delay` is compared with the activation at `t` (s).
    pub delay: f64,
    /// A signal is on at and above this fraction of its peak.
    pub on_fraction: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            delay: 0.0,
            on_fraction: DEFAULT_ON_FRACTION,
        }
    }
}

/// One channel's agreement.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelResult {
    pub channel: String,
    pub muscles: Vec<String>,
    /// Pearson r at the given delay; None when a signal is constant.
    pub r: Option<f64>,
    /// Fraction of frames where both are on or both off.
    pub on_off: f64,
    /// The delay in [0, MAX_DELAY_MS] (ms) that maximises r, and that r.
    pub best_delay_ms: Option<f64>,
    pub best_r: Option<f64>,
    /// The compared time courses: the (group mean) activation and the EMG.
    pub activation: Vec<f64>,
    pub emg: Vec<f64>,
}

/// The agreement of one activation file with the EMG.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    pub label: String,
    pub time: Vec<f64>,
    pub channels: Vec<ChannelResult>,
}

impl Comparison {
    /// Mean Pearson r over the channels that have one.
    pub fn mean_r(&self) -> Option<f64> {
        let v: Vec<f64> = self.channels.iter().filter_map(|c| c.r).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }
    /// Mean on/off agreement over the channels.
    pub fn mean_on_off(&self) -> f64 {
        self.channels.iter().map(|c| c.on_off).sum::<f64>() / self.channels.len().max(1) as f64
    }
}

/// Pearson's correlation coefficient; None when either signal is constant
/// (or the lengths differ or are below 2).
pub fn pearson(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 2 {
        return None;
    }
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    let d = (saa * sbb).sqrt();
    (d > 0.0 && d.is_finite()).then(|| (sab / d).clamp(-1.0, 1.0))
}

/// Where `x` is at or above `fraction` of its peak.
pub fn on(x: &[f64], fraction: f64) -> Vec<bool> {
    let peak = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    x.iter()
        .map(|v| peak > 0.0 && *v >= fraction * peak)
        .collect()
}

/// The fraction of samples where `a` and `b` are both on or both off.
pub fn on_off_agreement(a: &[f64], b: &[f64], fraction: f64) -> f64 {
    let (oa, ob) = (on(a, fraction), on(b, fraction));
    let same = oa.iter().zip(&ob).filter(|(x, y)| x == y).count();
    same as f64 / a.len().max(1) as f64
}

/// `y(t)` of a table column, linearly interpolated; None outside its time range.
fn interpolate(time: &[f64], y: &[f64], t: f64) -> Option<f64> {
    let (t0, t1) = (*time.first()?, *time.last()?);
    let eps = 1e-9 * (t1 - t0).abs().max(1.0);
    if t < t0 - eps || t > t1 + eps {
        return None;
    }
    let i = time.partition_point(|&x| x <= t).clamp(1, time.len() - 1);
    let w = ((t - time[i - 1]) / (time[i] - time[i - 1])).clamp(0.0, 1.0);
    Some(y[i - 1] + w * (y[i] - y[i - 1]))
}

/// The EMG column `j` at `times − delay`, or an error naming the file and
/// the first time outside its range.
fn emg_at(emg: &Storage, emg_path: &Path, j: usize, times: &[f64], delay: f64) -> Result<Vec<f64>> {
    let y = emg.column(j);
    times
        .iter()
        .map(|&t| {
            interpolate(&emg.time, &y, t - delay).ok_or_else(|| {
                Error::input(
                    Location::file(emg_path).with_element(emg.labels[j].clone()),
                    format!(
                        "the EMG is needed at t = {:.4} s (activation frame {t:.4} s less a delay of {:.1} ms) but covers {:.4}–{:.4} s",
                        t - delay,
                        1e3 * delay,
                        emg.time.first().copied().unwrap_or(f64::NAN),
                        emg.time.last().copied().unwrap_or(f64::NAN)
                    ),
                )
            })
        })
        .collect()
}

/// Compare the activations `act` (read from `act_path`) with the EMG `emg`
/// (from `emg_path`) channel by channel through `map`. Every mapped channel
/// must be in the EMG and every mapped muscle in the activations.
pub fn compare(
    label: &str,
    act: &Storage,
    act_path: &Path,
    emg: &Storage,
    emg_path: &Path,
    map: &[ChannelMap],
    opts: Options,
) -> Result<Comparison> {
    if !(opts.on_fraction > 0.0 && opts.on_fraction < 1.0) {
        return Err(Error::msg(format!(
            "the on fraction must lie in (0, 1), found {}",
            opts.on_fraction
        )));
    }
    if !(opts.delay.is_finite() && opts.delay >= 0.0) {
        return Err(Error::msg(format!(
            "the electromechanical delay must be a number of milliseconds >= 0 (EMG precedes the force it causes), found {} ms",
            1e3 * opts.delay
        )));
    }
    if act.time.len() < 2 {
        return Err(Error::input(
            Location::file(act_path),
            "needs at least two frames to compare",
        ));
    }
    let mut channels = Vec::with_capacity(map.len());
    for c in map {
        let here = || c.from.clone().unwrap_or_default();
        let j = emg.column_index(&c.channel).ok_or_else(|| {
            let mut m = format!(
                "{}: no EMG channel '{}' (it has: {})",
                emg_path.display(),
                c.channel,
                emg.labels.join(", ")
            );
            if c.from.is_none() {
                m.push_str("; give a map with --map");
            }
            Error::input(here(), m)
        })?;
        let cols: Vec<usize> = c
            .muscles
            .iter()
            .map(|m| {
                act.column_index(m).ok_or_else(|| {
                    let mut msg = format!(
                        "{}: no activation column '{m}' (channel '{}')",
                        act_path.display(),
                        c.channel
                    );
                    if c.from.is_none() {
                        msg.push_str("; the default map names the Rajagopal model's muscles: give a map with --map, or --side");
                    }
                    Error::input(here(), msg)
                })
            })
            .collect::<Result<_>>()?;
        let activation: Vec<f64> = act
            .rows
            .iter()
            .map(|r| cols.iter().map(|&k| r[k]).sum::<f64>() / cols.len() as f64)
            .collect();
        let e = emg_at(emg, emg_path, j, &act.time, opts.delay)?;
        let r = pearson(&activation, &e);
        let on_off = on_off_agreement(&activation, &e, opts.on_fraction);
        // The best electromechanical delay, where the EMG covers it.
        let mut best: Option<(f64, f64)> = None;
        let steps = (MAX_DELAY_MS / DELAY_STEP_MS).round() as usize;
        for k in 0..=steps {
            let d = k as f64 * DELAY_STEP_MS;
            if let Ok(ed) = emg_at(emg, emg_path, j, &act.time, 1e-3 * d) {
                if let Some(rd) = pearson(&activation, &ed) {
                    if best.is_none_or(|(_, b)| rd > b) {
                        best = Some((d, rd));
                    }
                }
            }
        }
        channels.push(ChannelResult {
            channel: c.channel.clone(),
            muscles: c.muscles.clone(),
            r,
            on_off,
            best_delay_ms: best.map(|b| b.0),
            best_r: best.map(|b| b.1),
            activation,
            emg: e,
        });
    }
    Ok(Comparison {
        label: label.to_string(),
        time: act.time.clone(),
        channels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pearson r of known signals: a line with itself scaled and shifted
    /// is 1, with its mirror −1; sin and cos over whole periods are
    /// uncorrelated; a constant has none.
    #[test]
    fn pearson_of_known_signals() {
        let x: Vec<f64> = (0..200).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 * v + 7.0).collect();
        let z: Vec<f64> = x.iter().map(|v| -0.5 * v).collect();
        assert!((pearson(&x, &y).unwrap() - 1.0).abs() < 1e-12);
        assert!((pearson(&x, &z).unwrap() + 1.0).abs() < 1e-12);
        let n = 400;
        let s: Vec<f64> = (0..n)
            .map(|i| (2.0 * std::f64::consts::PI * i as f64 / n as f64).sin())
            .collect();
        let c: Vec<f64> = (0..n)
            .map(|i| (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
            .collect();
        assert!(pearson(&s, &c).unwrap().abs() < 1e-12);
        // sin(θ) with sin(θ + φ) over whole periods: r = cos φ.
        let phi: f64 = 1.0;
        let p: Vec<f64> = (0..n)
            .map(|i| (2.0 * std::f64::consts::PI * i as f64 / n as f64 + phi).sin())
            .collect();
        assert!((pearson(&s, &p).unwrap() - phi.cos()).abs() < 1e-12);
        assert_eq!(pearson(&x, &vec![2.0; 200]), None);
    }

    /// On/off agreement of two bursts: frames where exactly one is on
    /// disagree.
    #[test]
    fn on_off_of_known_bursts() {
        // 100 frames; a on at 20..60, b on at 30..70 (peaks 1 and 0.5, off
        // levels 0.1, below 25 % of either peak): they disagree on 20..30
        // and 60..70, 20 of 100 frames.
        let a: Vec<f64> = (0..100)
            .map(|i| if (20..60).contains(&i) { 1.0 } else { 0.1 })
            .collect();
        let b: Vec<f64> = (0..100)
            .map(|i| if (30..70).contains(&i) { 0.5 } else { 0.1 })
            .collect();
        assert!((on_off_agreement(&a, &b, 0.25) - 0.8).abs() < 1e-12);
        // At 15 % b's off level (0.1 ≥ 0.075) is on everywhere, a's (0.1 <
        // 0.15) is not: they agree on a's on frames, 40 %.
        assert!((on_off_agreement(&a, &b, 0.15) - 0.4).abs() < 1e-12);
        assert!((on_off_agreement(&a, &a, 0.25) - 1.0).abs() < 1e-12);
    }

    fn table(time: Vec<f64>, labels: &[&str], cols: Vec<Vec<f64>>) -> Storage {
        let rows = (0..time.len())
            .map(|i| cols.iter().map(|c| c[i]).collect())
            .collect();
        Storage {
            labels: labels.iter().map(|s| s.to_string()).collect(),
            time,
            rows,
            ..Default::default()
        }
    }

    /// A group channel compares the mean of its muscles; a delayed EMG is
    /// found at its delay and, given that delay, agrees perfectly.
    #[test]
    fn compare_groups_and_delays() {
        let burst = |t: f64| (-((t - 0.5) / 0.08).powi(2)).exp();
        // EMG at 1 kHz over 0–1.2 s leads the activations by 40 ms.
        let et: Vec<f64> = (0..=1200).map(|i| i as f64 * 1e-3).collect();
        let emg = table(
            et.clone(),
            &["glmax"],
            vec![et.iter().map(|&t| burst(t + 0.04)).collect()],
        );
        // Activations at 100 Hz over 0.2–1.0 s: two heads whose mean is the burst.
        let at: Vec<f64> = (20..=100).map(|i| i as f64 * 1e-2).collect();
        let a1: Vec<f64> = at.iter().map(|&t| 0.5 * burst(t)).collect();
        let a2: Vec<f64> = at.iter().map(|&t| 1.5 * burst(t)).collect();
        let act = table(at, &["g1", "g2"], vec![a1, a2]);
        let map = parse_map("# one electrode\nglmax: g1 g2\n", Path::new("map.txt")).unwrap();
        let p = Path::new("x.sto");
        let c0 = compare("so", &act, p, &emg, p, &map, Options::default()).unwrap();
        let ch = &c0.channels[0];
        assert_eq!(ch.best_delay_ms, Some(40.0));
        assert!((ch.best_r.unwrap() - 1.0).abs() < 1e-6);
        assert!(ch.r.unwrap() < 0.99, "{:?}", ch.r);
        let opts = Options {
            delay: 0.04,
            ..Default::default()
        };
        let c1 = compare("so", &act, p, &emg, p, &map, opts).unwrap();
        assert!((c1.channels[0].r.unwrap() - 1.0).abs() < 1e-6);
        assert!((c1.channels[0].on_off - 1.0).abs() < 1e-12);
        assert_eq!(c1.mean_r(), c1.channels[0].r);
    }

    /// Bad maps and missing columns are errors naming file, line and column.
    #[test]
    fn errors_name_file_line_and_column() {
        let p = Path::new("map.txt");
        let e = parse_map("soleus soleus_r\n", p).unwrap_err().to_string();
        assert!(
            e.contains("map.txt, line 1") && e.contains("channel: muscle"),
            "{e}"
        );
        let e = parse_map("a: x\n\na: y\n", p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("mapped twice"), "{e}");
        let e = parse_map("# nothing\n", p).unwrap_err().to_string();
        assert!(e.contains("no channel"), "{e}");
        let t: Vec<f64> = (0..10).map(|i| i as f64 * 0.1).collect();
        let emg = table(t.clone(), &["soleus"], vec![t.clone()]);
        let act = table(t.clone(), &["soleus_r"], vec![t.clone()]);
        // The error of comparing `act.sto` with `emg.sto` through `map`.
        let err = |map: &[ChannelMap], opts: Options| {
            compare(
                "x",
                &act,
                Path::new("act.sto"),
                &emg,
                Path::new("emg.sto"),
                map,
                opts,
            )
            .unwrap_err()
            .to_string()
        };
        let map = parse_map("soleus: soleus_l\n", p).unwrap();
        let e = err(&map, Options::default());
        assert!(
            e.contains("act.sto") && e.contains("soleus_l") && e.contains("map.txt"),
            "{e}"
        );
        let map = parse_map("gastrocnemius: soleus_r\n", p).unwrap();
        let e = err(&map, Options::default());
        assert!(e.contains("emg.sto") && e.contains("gastrocnemius"), "{e}");
        let neg = Options {
            delay: -0.01,
            ..Default::default()
        };
        let e = err(&map, neg);
        assert!(e.contains(">= 0"), "{e}");
        // Activations beyond the EMG's time range.
        let map = parse_map("soleus: soleus_r\n", p).unwrap();
        let opts = Options {
            delay: 0.05,
            ..Default::default()
        };
        let e = err(&map, opts);
        assert!(e.contains("emg.sto") && e.contains("covers"), "{e}");
    }
}
