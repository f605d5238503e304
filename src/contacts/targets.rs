//! Group force targets (statopt extension, `force_target_*`): the summed
//! force of a group of contacts on their point bodies, along given axes in
//! ground, held to a target that varies with time.
//!
//! The target is soft: per axis the frame's program gets one row
//! `Σ_c Σ_k (a · f_ck) λ_ck − S x = target(t)`, with f_ck the force on the
//! point body of contact c's multiplier k at unit value (in the contact's
//! regime, [`super::Contact::forces`]), and x a free variable of optimal force S
//! weighted like an actuator: a departure e = S x from the target costs
//! (e/S)^p. So the target always has a solution (the departure pays), and
//! with S equal to the root residuals' optimal force a newton off the target
//! is as doubtful as a newton on the pelvis. Outside the knots' time span
//! the row is `x = 0` and the group is free.
//!
//! predict-grf uses it for both feet through double support: the trailing
//! foot's smooth transition (after Ren, Jones & Howard 2008, J Biomech
//! 41:2750) and each foot's force along its leg (docs/grf_prediction.md,
//! "The step-to-step transition").

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::xml::Element;

use super::Contact;

/// One contact's `force_target_*` properties.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetSpec {
    /// `force_target_group`: the contacts sharing it are summed.
    pub group: String,
    /// `force_target_rows`: the number m of axes (rows) of the target.
    pub rows: usize,
    /// `force_target`: knots (t, on, m pairs (unit axis in ground, force
    /// in N along it)), times ascending; the target holds between two
    /// knots that are both on. A row of axis 0 and force 0 holds nothing
    /// at its knot (its program row is −S x = 0).
    pub knots: Vec<Knot>,
    /// `force_target_optimal_force` S (N), > 0, per row.
    pub optimal_force: Vec<f64>,
}

/// A knot of a target: time (s), whether it holds, and per row the axis
/// (unit, ground) and the force along it (N).
pub type Knot = (f64, bool, Vec<(Vector3<f64>, f64)>);

const PROPS: [&str; 4] = [
    "force_target_group",
    "force_target_rows",
    "force_target",
    "force_target_optimal_force",
];

impl TargetSpec {
    /// Reads the properties of contact element `el` (named `name`); None
    /// when it has none. Given in part, or with knots that do not fit the
    /// rows, times not ascending, or an axis that is not a unit vector: an
    /// error naming the element.
    pub fn from_xml(el: &Element, name: &str) -> Result<Option<TargetSpec>> {
        let given: Vec<&str> = PROPS
            .iter()
            .copied()
            .filter(|p| el.child(p).is_some_and(|c| !c.text().is_empty()))
            .collect();
        if given.is_empty() {
            return Ok(None);
        }
        for p in &PROPS[..3] {
            if !given.contains(p) {
                return Err(el.error(format!(
                    "{} '{name}': <{p}> is missing: a force target needs <force_target_group>, <force_target_rows> and <force_target> (found {})",
                    el.name,
                    given.iter().map(|g| format!("<{g}>")).collect::<Vec<_>>().join(", ")
                )));
            }
        }
        let group = el.child("force_target_group").unwrap().text().to_string();
        let rc = el.child("force_target_rows").unwrap();
        let m = rc.f64()?;
        if !(m >= 1.0 && m <= 3.0 && m.fract() == 0.0) {
            return Err(rc.error(format!(
                "{} '{name}': <force_target_rows> is the number of axes of the target, 1, 2 or 3, found {m}",
                el.name
            )));
        }
        let m = m as usize;
        let kn = el.child("force_target").unwrap();
        let v = kn.numbers()?;
        let w = 2 + 4 * m;
        // A unit axis; or 0 0 0 with force 0: the row holds nothing at that
        // knot (a group whose knots need fewer rows in one span than in
        // another, e.g. a foot's target when it lands and when it trails).
        let unit = |c: &[f64]| {
            (Vector3::new(c[0], c[1], c[2]).norm() - 1.0).abs() <= 1e-6
                || c.iter().all(|x| *x == 0.0)
        };
        let ok = !v.is_empty()
            && v.len() % w == 0
            && v.chunks(w)
                .all(|c| (c[1] == 0.0 || c[1] == 1.0) && c[2..].chunks(4).all(unit))
            && v.chunks(w)
                .zip(v.chunks(w).skip(1))
                .all(|(a, b)| a[0] < b[0]);
        if !ok {
            return Err(kn.error(format!(
                "{} '{name}': <force_target> takes knots t on, then {m} times ax ay az f (s; 1 or 0; a unit axis in ground and the force in N along it, or 0 0 0 0 for a row that holds nothing at that knot), with the times ascending, found '{}'",
                el.name,
                kn.text()
            )));
        }
        let knots = v
            .chunks(w)
            .map(|c| {
                let rows = c[2..]
                    .chunks(4)
                    .map(|r| (Vector3::new(r[0], r[1], r[2]), r[3]))
                    .collect();
                (c[0], c[1] == 1.0, rows)
            })
            .collect();
        let optimal_force = match el.child("force_target_optimal_force") {
            Some(c) if !c.text().is_empty() => {
                let s = c.numbers()?;
                if !(s.len() == 1 || s.len() == m) || s.iter().any(|x| !(*x > 0.0)) {
                    return Err(c.error(format!(
                        "{} '{name}': <force_target_optimal_force> takes one positive force (N), or one per row ({m}), found '{}'",
                        el.name,
                        c.text()
                    )));
                }
                if s.len() == 1 {
                    vec![s[0]; m]
                } else {
                    s
                }
            }
            _ => vec![1.0; m],
        };
        Ok(Some(TargetSpec {
            group,
            rows: m,
            knots,
            optimal_force,
        }))
    }

    /// Per row, the axis and the force along it at time `t`: linear between
    /// two knots that are both on (the axis renormalised), a knot's own at
    /// its time; None elsewhere.
    pub fn value_at(&self, t: f64) -> Option<Vec<(Vector3<f64>, f64)>> {
        let k = &self.knots;
        let i = k.partition_point(|p| p.0 <= t);
        // k[i - 1].0 <= t < k[i].0
        let a = k.get(i.checked_sub(1)?)?;
        if a.0 == t && a.1 {
            return Some(a.2.clone());
        }
        let b = k.get(i)?;
        if !(a.1 && b.1) {
            return None;
        }
        let r = (t - a.0) / (b.0 - a.0);
        Some(
            a.2.iter()
                .zip(&b.2)
                .map(|((xa, fa), (xb, fb))| {
                    let x = xa + (xb - xa) * r;
                    let n = x.norm();
                    (if n > 0.0 { x / n } else { *xa }, fa + (fb - fa) * r)
                })
                .collect(),
        )
    }
}

/// One group: its contacts (indices into the problem's contacts) and the
/// target they share.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceTarget {
    pub contacts: Vec<usize>,
    pub spec: TargetSpec,
}

impl ForceTarget {
    /// Rows (and free variables) the group adds: one per axis.
    pub fn rows(&self) -> usize {
        self.spec.rows
    }
}

/// The groups of `contacts`, in the order of their first contact. Contacts
/// of one group must give the same axes, knots and optimal force: else an
/// error naming both contacts and where the second is.
pub fn groups(contacts: &[Contact]) -> Result<Vec<ForceTarget>> {
    let mut out: Vec<ForceTarget> = Vec::new();
    for (i, c) in contacts.iter().enumerate() {
        let Some(spec) = &c.force_target else {
            continue;
        };
        match out.iter_mut().find(|g| g.spec.group == spec.group) {
            Some(g) => {
                if g.spec != *spec {
                    let first = &contacts[g.contacts[0]].name;
                    return Err(Error::input(
                        c.loc.clone(),
                        format!(
                            "{} '{}': its force target differs from that of '{first}', in the same <force_target_group> '{}': contacts of one group share one target (rows, knots, optimal force)",
                            c.type_name, c.name, spec.group
                        ),
                    ));
                }
                g.contacts.push(i);
            }
            None => out.push(ForceTarget {
                contacts: vec![i],
                spec: spec.clone(),
            }),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn spec(knots: &str) -> Result<Option<TargetSpec>> {
        let text = format!(
            "<PointOnPlaneContact name=\"c\"><force_target_group>g</force_target_group><force_target_rows>2</force_target_rows><force_target>{knots}</force_target></PointOnPlaneContact>"
        );
        let el = crate::xml::parse_str(&text, Path::new("contacts.xml")).unwrap();
        TargetSpec::from_xml(&el, "c")
    }

    /// A row of axis 0 0 0 and force 0 holds nothing at its knot, so one
    /// group can hold two rows in one span and one in another (a foot that
    /// trails, then lands); a zero axis with a force, or an axis that is
    /// neither unit nor zero, is refused.
    #[test]
    fn a_zero_row_holds_nothing_and_other_axes_must_be_unit() {
        let s = spec("0 1 0 1 0 50 1 0 0 0  0.1 1 0 1 0 50 1 0 0 0  0.12 0 0 1 0 50 1 0 0 0  0.2 1 1 0 0 0 0 0 0 0  0.3 1 1 0 0 0 0 0 0 0")
            .unwrap()
            .unwrap();
        let v = s.value_at(0.05).unwrap();
        assert_eq!(v[0], (Vector3::new(0.0, 1.0, 0.0), 50.0));
        let v = s.value_at(0.25).unwrap();
        assert_eq!(v[0], (Vector3::new(1.0, 0.0, 0.0), 0.0));
        assert_eq!(v[1], (Vector3::zeros(), 0.0));
        // Between the spans (the knot at 0.12 is off): no target.
        assert!(s.value_at(0.15).is_none());
        for bad in ["0 1 0 0 0 5 1 0 0 0", "0 1 0 2 0 5 1 0 0 0"] {
            let e = spec(bad).unwrap_err().to_string();
            assert!(e.contains("contacts.xml") && e.contains("0 0 0 0"), "{e}");
        }
    }
}
