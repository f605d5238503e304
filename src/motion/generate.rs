//! Synthetic motions (`statopt-tool motion`): what to generate and its
//! time profile. One coordinate, optionally several, moving from A to B
//! along a minimum-jerk profile (Flash & Hogan 1985: bell-shaped velocity,
//! zero velocity and acceleration at both ends), every other coordinate at
//! its default value, plus linked coordinates that follow a linear relation
//! and coupler-dependent coordinates that follow their constraint;
//! optionally back again and repeated, with holds ([`profile`]). The table
//! itself, with contacts kept closed or planted by coordinates solved
//! together on every row, is made by `contacts::motion::generate` (a later
//! stage: it compiles the contacts). See docs/composition.md.
//!
//! Values are in OpenSim's motion-file convention: `inDegrees=yes`,
//! rotational coordinates in degrees, all others (translational, coupled) in
//! their model units, as OpenSim converts only rotational columns
//! (opensim-semantics.md §1.3).

use crate::error::{Error, Result};

/// `target = scale * source + offset`, in file units.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    pub target: String,
    pub scale: f64,
    pub source: String,
    pub offset: f64,
}

/// What to generate.
#[derive(Debug, Clone)]
pub struct MinJerkMotion {
    /// The driven coordinate.
    pub coordinate: String,
    /// Further coordinates following the same profile.
    pub also: Vec<String>,
    /// Start and end values in file units (degrees for rotational coordinates).
    pub from: f64,
    pub to: f64,
    /// Seconds of the movement from `from` to `to`.
    pub duration: f64,
    /// Rows per second (each segment's last row is at exactly its end).
    pub rate: f64,
    /// Applied in order, after the driven coordinates.
    pub links: Vec<Link>,
    /// `(contact, coordinate)`: on every row, the contact's point lies on
    /// its plane. All contacts of `touch` and `plant` are closed together,
    /// solving all their coordinates as one system
    /// (`contacts::closure::Chain`), each coordinate starting from its
    /// `--link` value on every row when it has one, else from the previous
    /// row's solution (first row: the default), so the solution followed
    /// is the one nearest that start. A contact or a coordinate may be
    /// named more than once.
    pub touch: Vec<(String, String)>,
    /// `(contact, coordinates)`: the contact is closed as with `touch` and
    /// its point is also kept where it was on the first row, in the plane
    /// body's frame (two in-plane residuals); the coordinates, if any, are
    /// solved too.
    pub plant: Vec<(String, Vec<String>)>,
    /// Repetitions (≥ 1; more than one needs `back`).
    pub repeat: usize,
    /// Seconds held at `from` before each movement, and at `to` after it.
    pub hold_start: f64,
    pub hold_end: f64,
    /// After the movement (and its hold), move back to `from`.
    pub back: bool,
    /// Seconds of the way back; None: `duration`.
    pub return_duration: Option<f64>,
    /// Decimals the file will be written with: the values are rounded to
    /// them, and contacts are checked closed on the rounded values. None:
    /// values are not rounded.
    pub precision: Option<usize>,
}

impl Default for MinJerkMotion {
    fn default() -> Self {
        MinJerkMotion {
            coordinate: String::new(),
            also: Vec::new(),
            from: 0.0,
            to: 0.0,
            duration: 1.0,
            rate: 100.0,
            links: Vec::new(),
            touch: Vec::new(),
            plant: Vec::new(),
            repeat: 1,
            hold_start: 0.0,
            hold_end: 0.0,
            back: false,
            return_duration: None,
            precision: None,
        }
    }
}

/// Parse `CONTACT` or `CONTACT=COORDINATE[,COORDINATE...]` for `--plant`.
pub fn parse_plant(s: &str) -> Result<(String, Vec<String>)> {
    let (c, qs) = match s.split_once('=') {
        Some((c, qs)) => (c.trim(), qs.trim()),
        None => (s.trim(), ""),
    };
    let coordinates: Vec<String> = if qs.is_empty() {
        Vec::new()
    } else {
        qs.split(',').map(|q| q.trim().to_string()).collect()
    };
    if c.is_empty()
        || (s.contains('=') && coordinates.is_empty())
        || coordinates.iter().any(|q| q.is_empty())
    {
        return Err(Error::msg(format!(
            "--plant '{s}': expected CONTACT or CONTACT=COORDINATE[,COORDINATE...]"
        )));
    }
    Ok((c.to_string(), coordinates))
}

/// The rows' times (s) and the driven value on each (file units): for each
/// repetition, a hold at `from` (`hold_start`), the minimum-jerk movement
/// to `to` (`duration`), a hold at `to` (`hold_end`) and, with `back`, the
/// minimum-jerk movement back to `from` (`return_duration`). Each segment of
/// D seconds has round(D · rate) intervals (at least one) of equal length;
/// consecutive segments share their boundary row, so times strictly increase.
pub fn profile(m: &MinJerkMotion) -> Result<Vec<(f64, f64)>> {
    let positive = |v: f64, what: &str, unit: &str| -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(Error::msg(format!(
                "{what} must be a positive number of {unit}, found {v}"
            )))
        }
    };
    positive(m.duration, "--duration", "seconds")?;
    positive(m.rate, "--rate", "rows per second")?;
    let back = match m.return_duration {
        Some(r) if !m.back => {
            return Err(Error::msg(format!(
                "--return-duration {r} given without --return"
            )))
        }
        Some(r) => positive(r, "--return-duration", "seconds")?,
        None => m.duration,
    };
    for (v, what) in [(m.hold_start, "--hold-start"), (m.hold_end, "--hold-end")] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::msg(format!(
                "{what} must be zero or a positive number of seconds, found {v}"
            )));
        }
    }
    if !(m.from.is_finite() && m.to.is_finite()) {
        return Err(Error::msg("--from and --to must be finite numbers"));
    }
    if m.repeat == 0 {
        return Err(Error::msg("--repeat must be at least 1"));
    }
    if m.repeat > 1 && !m.back {
        return Err(Error::msg(format!(
            "--repeat {} needs --return: each repetition must end where the next begins",
            m.repeat
        )));
    }
    let (a, b) = (m.from, m.to);
    let mut segments: Vec<(f64, f64, f64)> = Vec::new();
    for _ in 0..m.repeat {
        if m.hold_start > 0.0 {
            segments.push((m.hold_start, a, a));
        }
        segments.push((m.duration, a, b));
        if m.hold_end > 0.0 {
            segments.push((m.hold_end, b, b));
        }
        if m.back {
            segments.push((back, b, a));
        }
    }
    let intervals: Vec<f64> = segments
        .iter()
        .map(|s| (s.0 * m.rate).round().max(1.0))
        .collect();
    let total: f64 = intervals.iter().sum();
    if total > 1e7 {
        return Err(Error::msg(format!(
            "{total} rows requested; use a lower --rate, --duration or --repeat"
        )));
    }
    let mut rows = Vec::with_capacity(total as usize + 1);
    rows.push((0.0, a));
    let mut t0 = 0.0;
    for (&(d, from, to), &n) in segments.iter().zip(&intervals) {
        let n = n as usize;
        for k in 1..=n {
            let s = k as f64 / n as f64;
            rows.push((t0 + d * s, from + (to - from) * min_jerk(s)));
        }
        t0 += d;
    }
    Ok(rows)
}

/// Parse `CONTACT=COORDINATE` for `--touch`.
pub fn parse_touch(s: &str) -> Result<(String, String)> {
    match s.split_once('=') {
        Some((c, q)) if !c.trim().is_empty() && !q.trim().is_empty() => {
            Ok((c.trim().to_string(), q.trim().to_string()))
        }
        _ => Err(Error::msg(format!(
            "--touch '{s}': expected CONTACT=COORDINATE"
        ))),
    }
}

/// The normalised minimum-jerk position `10 s³ − 15 s⁴ + 6 s⁵` for s in [0, 1].
pub fn min_jerk(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 + s * (-15.0 + 6.0 * s))
}

fn number(t: &str, whole: &str) -> Result<f64> {
    t.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| Error::msg(format!("--link '{whole}': '{t}' is not a number")))
}

/// Parse `target=a*source+b`: the right side is a sum of terms, exactly one
/// of which names a coordinate (`source`, `a*source`, `source*a`, `-source`),
/// the others numbers. Examples: `lever=knee`, `lever=-1*knee+90`,
/// `lever = 0.5*knee - 3`.
pub fn parse_link(s: &str) -> Result<Link> {
    let compact: String = s.chars().filter(|c| !c.is_whitespace()).collect();
    let (target, rhs) = compact
        .split_once('=')
        .ok_or_else(|| Error::msg(format!("--link '{s}': expected target=a*source+b")))?;
    if target.is_empty() || rhs.is_empty() {
        return Err(Error::msg(format!(
            "--link '{s}': expected target=a*source+b"
        )));
    }
    // Split into signed terms at + and - that are not part of an exponent.
    let mut terms: Vec<(f64, String)> = Vec::new();
    let mut cur = String::new();
    let mut sign = 1.0;
    let chars: Vec<char> = rhs.chars().collect();
    for (i, &c) in chars.iter().enumerate() {
        let last = cur.rsplit('*').next().unwrap_or("");
        let exponent = (last.ends_with('e') || last.ends_with('E'))
            && last[..last.len() - 1].parse::<f64>().is_ok();
        if (c == '+' || c == '-') && !exponent && !cur.ends_with('*') {
            if !cur.is_empty() {
                terms.push((sign, std::mem::take(&mut cur)));
            } else if !terms.is_empty() || i > 0 {
                return Err(Error::msg(format!("--link '{s}': misplaced '{c}'")));
            }
            sign = if c == '-' { -1.0 } else { 1.0 };
        } else {
            cur.push(c);
        }
    }
    if cur.is_empty() {
        return Err(Error::msg(format!("--link '{s}': ends with an operator")));
    }
    terms.push((sign, cur));
    let mut source: Option<(f64, String)> = None;
    let mut offset = 0.0;
    for (sign, t) in terms {
        if let Ok(v) = t.parse::<f64>() {
            offset += sign * v;
            continue;
        }
        let (scale, name) = match t.split_once('*') {
            Some((a, b)) if a.parse::<f64>().is_ok() => (number(a, s)?, b.to_string()),
            Some((a, b)) => (number(b, s)?, a.to_string()),
            None => (1.0, t.clone()),
        };
        let (scale, name) = match name.strip_prefix('-') {
            Some(rest) => (-scale, rest.to_string()),
            None => (scale, name),
        };
        if name.is_empty() || name.contains(['*', '+', '/']) {
            return Err(Error::msg(format!("--link '{s}': cannot read term '{t}'")));
        }
        if source.is_some() {
            return Err(Error::msg(format!(
                "--link '{s}': the right side must name exactly one coordinate"
            )));
        }
        source = Some((sign * scale, name));
    }
    let (scale, source) = source.ok_or_else(|| {
        Error::msg(format!(
            "--link '{s}': the right side names no coordinate (use target=a*source+b)"
        ))
    })?;
    Ok(Link {
        target: target.to_string(),
        scale,
        source,
        offset,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_jerk_closed_form() {
        assert_eq!(min_jerk(0.0), 0.0);
        assert_eq!(min_jerk(1.0), 1.0);
        assert!((min_jerk(0.5) - 0.5).abs() < 1e-15);
        // Symmetry: x(1-s) = 1 - x(s).
        for s in [0.1, 0.23, 0.4] {
            assert!((min_jerk(1.0 - s) - (1.0 - min_jerk(s))).abs() < 1e-14);
        }
    }

    #[test]
    fn plant_spellings() {
        assert_eq!(parse_plant("heel").unwrap(), ("heel".into(), vec![]));
        assert_eq!(
            parse_plant(" heel = sled_x, hip ").unwrap(),
            ("heel".into(), vec!["sled_x".into(), "hip".into()])
        );
        for bad in ["", "=sled", "heel=", "heel=a,,b", "heel=a,"] {
            assert!(parse_plant(bad).is_err(), "{bad} accepted");
        }
    }

    /// Segments: hold at A, A → B, hold at B, B → A; boundary rows shared,
    /// times strictly increasing, each segment's rows at its own spacing.
    #[test]
    fn repetition_profile() {
        let one = MinJerkMotion {
            from: -60.0,
            to: -10.0,
            duration: 1.0,
            rate: 10.0,
            ..MinJerkMotion::default()
        };
        let rows = profile(&one).unwrap();
        assert_eq!(rows.len(), 11);
        assert_eq!(rows[0], (0.0, -60.0));
        assert_eq!(rows[10], (1.0, -10.0));
        let reps = MinJerkMotion {
            back: true,
            return_duration: Some(2.0),
            hold_start: 0.5,
            hold_end: 0.3,
            repeat: 2,
            ..one.clone()
        };
        let rows = profile(&reps).unwrap();
        // Per repetition 5 + 10 + 3 + 20 intervals.
        assert_eq!(rows.len(), 2 * 38 + 1);
        assert!(rows.windows(2).all(|w| w[1].0 > w[0].0));
        for (i, t, v) in [
            (5, 0.5, -60.0),
            (15, 1.5, -10.0),
            (18, 1.8, -10.0),
            (38, 3.8, -60.0),
            (43, 4.3, -60.0),
            (76, 7.6, -60.0),
        ] {
            assert!((rows[i].0 - t).abs() < 1e-12, "row {i}: t {}", rows[i].0);
            assert!((rows[i].1 - v).abs() < 1e-12, "row {i}: {}", rows[i].1);
        }
        // Midway back: the midpoint.
        assert!((rows[28].1 + 35.0).abs() < 1e-12);
        for (bad, what) in [
            (
                MinJerkMotion {
                    repeat: 0,
                    ..one.clone()
                },
                "--repeat",
            ),
            (
                MinJerkMotion {
                    repeat: 2,
                    ..one.clone()
                },
                "--return",
            ),
            (
                MinJerkMotion {
                    return_duration: Some(1.0),
                    ..one.clone()
                },
                "--return-duration",
            ),
            (
                MinJerkMotion {
                    hold_end: -1.0,
                    ..one.clone()
                },
                "--hold-end",
            ),
            (
                MinJerkMotion {
                    hold_start: f64::NAN,
                    ..one.clone()
                },
                "--hold-start",
            ),
            (
                MinJerkMotion {
                    back: true,
                    return_duration: Some(0.0),
                    ..one.clone()
                },
                "--return-duration",
            ),
        ] {
            let e = profile(&bad).unwrap_err().to_string();
            assert!(e.contains(what), "{e}");
        }
    }

    #[test]
    fn link_spellings() {
        let l = parse_link("lever_angle=1*knee_angle_r+0").unwrap();
        assert_eq!(
            l,
            Link {
                target: "lever_angle".into(),
                scale: 1.0,
                source: "knee_angle_r".into(),
                offset: 0.0
            }
        );
        let l = parse_link("a = -knee + 90").unwrap();
        assert_eq!((l.scale, l.source.as_str(), l.offset), (-1.0, "knee", 90.0));
        let l = parse_link("a=knee*0.5-1e-3").unwrap();
        assert_eq!((l.scale, l.source.as_str(), l.offset), (0.5, "knee", -1e-3));
        let l = parse_link("a=10-2*knee").unwrap();
        assert_eq!((l.scale, l.source.as_str(), l.offset), (-2.0, "knee", 10.0));
        let l = parse_link("a=2e1*knee").unwrap();
        assert_eq!((l.scale, l.source.as_str(), l.offset), (20.0, "knee", 0.0));
        let l = parse_link("a=2*-knee").unwrap();
        assert_eq!((l.scale, l.source.as_str(), l.offset), (-2.0, "knee", 0.0));
        let l = parse_link("a=rotate-1").unwrap();
        assert_eq!(
            (l.scale, l.source.as_str(), l.offset),
            (1.0, "rotate", -1.0)
        );
        for bad in [
            "a",
            "a=",
            "=knee",
            "a=1+2",
            "a=knee+hip",
            "a=knee+",
            "a=2*x*y",
        ] {
            assert!(parse_link(bad).is_err(), "{bad} accepted");
        }
    }
}
