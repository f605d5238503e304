//! Synthetic motions (`statopt-tool motion`): one coordinate, optionally
//! several, moving from A to B along a minimum-jerk profile (Flash & Hogan
//! 1985: bell-shaped velocity, zero velocity and acceleration at both ends),
//! every other coordinate at its default value, plus linked coordinates that
//! follow a linear relation and coupler-dependent coordinates that follow
//! their constraint. See docs/composition.md.
//!
//! Values are written in OpenSim's motion-file convention: `inDegrees=yes`,
//! rotational coordinates in degrees, all others (translational, coupled) in
//! their model units, as OpenSim converts only rotational columns
//! (opensim-semantics.md §1.3).

use crate::contacts::Contact;
use crate::dynamics::Data;
use crate::error::{Error, Result};
use crate::model::{Model, MotionType};
use crate::storage::Storage;
use crate::xml::Element;

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
    /// Seconds.
    pub duration: f64,
    /// Rows per second (the last row is at exactly `duration`).
    pub rate: f64,
    /// Applied in order, after the driven coordinates.
    pub links: Vec<Link>,
    /// `(contact, coordinate)`: on every row, set the coordinate so that the
    /// contact's point lies on its plane (distance 0) by Newton's method,
    /// starting from the coordinate's `--link` value on every row when it has
    /// one, else from the previous row's solution (first row: the default), so
    /// the solution followed is the one nearest that start.
    pub touch: Vec<(String, String)>,
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

fn find(model: &Model, name: &str, what: &str) -> Result<usize> {
    model.coordinate_index(name).ok_or_else(|| {
        let names: Vec<&str> = model.coordinates.iter().map(|c| c.name.as_str()).collect();
        Error::msg(format!(
            "{what} '{name}' is not a coordinate of the model; its coordinates are: {}",
            names.join(", ")
        ))
    })
}

/// Generate the motion: a table with one column per model coordinate (tree
/// order) in file units, and warnings (ranges left, locked coordinates driven).
/// `forces` are the force elements `--touch` may name (the composed model's
/// and force-set files').
pub fn generate(
    model: &Model,
    m: &MinJerkMotion,
    forces: &[Element],
) -> Result<(Storage, Vec<String>)> {
    if !(m.duration.is_finite() && m.duration > 0.0) {
        return Err(Error::msg(format!(
            "--duration must be a positive number of seconds, found {}",
            m.duration
        )));
    }
    if !(m.rate.is_finite() && m.rate > 0.0) {
        return Err(Error::msg(format!(
            "--rate must be a positive number of rows per second, found {}",
            m.rate
        )));
    }
    if !(m.from.is_finite() && m.to.is_finite()) {
        return Err(Error::msg("--from and --to must be finite numbers"));
    }
    let intervals = (m.duration * m.rate).round().max(1.0);
    if intervals > 1e7 {
        return Err(Error::msg(format!(
            "{intervals} rows requested; use a lower --rate or --duration"
        )));
    }
    let n = intervals as usize;
    let to_file = |i: usize, v: f64| {
        if model.coordinates[i].motion_type == MotionType::Rotational {
            v.to_degrees()
        } else {
            v
        }
    };
    let to_model = |i: usize, v: f64| {
        if model.coordinates[i].motion_type == MotionType::Rotational {
            v.to_radians()
        } else {
            v
        }
    };
    let nq = model.nq();
    let mut explicit = vec![false; nq];
    let mut driven = vec![find(model, &m.coordinate, "--coordinate")?];
    for a in &m.also {
        driven.push(find(model, a, "--also")?);
    }
    for &d in &driven {
        if explicit[d] {
            return Err(Error::msg(format!(
                "coordinate '{}' is driven twice",
                model.coordinates[d].name
            )));
        }
        explicit[d] = true;
    }
    let mut links = Vec::new();
    for l in &m.links {
        let t = find(model, &l.target, "--link target")?;
        let s = find(model, &l.source, "--link source")?;
        if explicit[t] {
            return Err(Error::msg(format!(
                "--link: coordinate '{}' is already driven",
                l.target
            )));
        }
        explicit[t] = true;
        links.push((t, s, l));
    }
    let mut touches = Vec::new();
    for (cname, qname) in &m.touch {
        let el = forces
            .iter()
            .find(|f| f.name_attr() == cname.as_str())
            .ok_or_else(|| {
                Error::msg(format!(
                    "--touch: no force element named '{cname}' in the model, its artifacts or the force-set files"
                ))
            })?;
        let contact = Contact::from_xml(el, model)?
            .ok_or_else(|| el.error(format!("--touch: '{cname}' is not a contact element")))?;
        let i = find(model, qname, "--touch coordinate")?;
        // A --link on the same coordinate gives the starting value.
        let linked = links.iter().any(|(t, _, _)| *t == i);
        if (explicit[i] && !linked) || touches.iter().any(|(_, k)| *k == i) {
            return Err(Error::msg(format!(
                "--touch: coordinate '{qname}' is already driven or touched"
            )));
        }
        explicit[i] = true;
        touches.push((contact, i));
    }
    let mut data = Data::new(model);
    let mut touch_start: Vec<Option<f64>> = vec![None; touches.len()];
    let mut warnings = Vec::new();
    for (i, c) in model.coordinates.iter().enumerate() {
        if explicit[i] && c.is_constrained() {
            warnings.push(format!(
                "coordinate '{}' is locked, prescribed or coupler-dependent; the values written for it may be overridden by the model",
                c.name
            ));
        }
    }

    let defaults: Vec<f64> = (0..nq)
        .map(|i| to_file(i, model.coordinates[i].default_value))
        .collect();
    let mut table = Storage {
        name: format!("minimum-jerk motion of {}", m.coordinate),
        labels: model.coordinates.iter().map(|c| c.name.clone()).collect(),
        time: Vec::with_capacity(n + 1),
        rows: Vec::with_capacity(n + 1),
        in_degrees: true,
        metadata: vec![(
            "header".into(),
            format!(
                "statopt-tool motion: {} from {} to {} over {} s (minimum jerk)",
                m.coordinate, m.from, m.to, m.duration
            ),
        )],
    };
    for k in 0..=n {
        let t = m.duration * k as f64 / n as f64;
        let mut row = defaults.clone();
        let v = m.from + (m.to - m.from) * min_jerk(t / m.duration);
        for &d in &driven {
            row[d] = v;
        }
        for &(t_i, s_i, l) in &links {
            row[t_i] = l.scale * row[s_i] + l.offset;
        }
        let couple = |row: &mut Vec<f64>| {
            for c in &model.couplers {
                if explicit[c.dependent] || c.independent.len() != 1 {
                    continue;
                }
                let x = to_model(c.independent[0], row[c.independent[0]]);
                row[c.dependent] = to_file(c.dependent, c.scale * c.function.value(x));
            }
        };
        couple(&mut row);
        if !touches.is_empty() {
            let mut q: Vec<f64> = (0..nq).map(|i| to_model(i, row[i])).collect();
            for (k, (contact, i)) in touches.iter().enumerate() {
                // Start from the previous row's solution unless a --link
                // gives the start.
                if let (Some(x), false) = (touch_start[k], links.iter().any(|(t, _, _)| t == i)) {
                    q[*i] = x;
                }
                crate::contacts::closure::close_contact(model, &mut data, contact, *i, &mut q, t)?;
                touch_start[k] = Some(q[*i]);
                row[*i] = to_file(*i, q[*i]);
            }
            couple(&mut row);
        }
        table.time.push(t);
        table.rows.push(row);
    }
    for (i, c) in model.coordinates.iter().enumerate() {
        let (lo, hi) = (to_file(i, c.range[0]), to_file(i, c.range[1]));
        let col = table.column(i);
        let (min, max) = col
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let tol = 1e-9 * (hi - lo).abs().max(1.0);
        if min < lo - tol || max > hi + tol {
            warnings.push(format!(
                "coordinate '{}' goes from {min} to {max}, outside its range [{lo}, {hi}]",
                c.name
            ));
        }
    }
    Ok((table, warnings))
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
