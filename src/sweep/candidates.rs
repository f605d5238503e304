//! A sweep's candidates: each one's specification (`plan::CandidateSpec`)
//! resolved against the compiled problem into the forces it changes
//! (`frame::candidates::ForceCandidate`), and its warm-start chain.

use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::forces::lepton::Expression;
use crate::forces::passive::PassiveForce;
use crate::frame::candidates::ForceCandidate;
use crate::frame::problem::{Control, SoProblem};
use crate::frame::settings::CONTACT_WEIGHT_RANGE;
use crate::plan::CandidateSpec;

/// Resolve the candidates against the problem (`setup_file` names the
/// setup in errors).
pub fn resolve(
    setup_file: &Path,
    problem: &SoProblem,
    specs: &[CandidateSpec],
) -> Result<Vec<ForceCandidate>> {
    let err = |k: usize, msg: String| {
        Error::input(
            Location::file(setup_file),
            format!("force sweep, candidate {k}: {msg}"),
        )
    };
    specs
        .iter()
        .enumerate()
        .map(|(k, s)| {
            if !(s.w0.is_finite()
                && (CONTACT_WEIGHT_RANGE.0..=CONTACT_WEIGHT_RANGE.1).contains(&s.w0))
            {
                return Err(err(
                    k,
                    format!(
                        "w0 = {} lies outside [{:e}, {:e}]",
                        s.w0, CONTACT_WEIGHT_RANGE.0, CONTACT_WEIGHT_RANGE.1
                    ),
                ));
            }
            let mut passive = Vec::new();
            for (name, text) in &s.expressions {
                let j = problem
                    .passive
                    .iter()
                    .position(|p| p.name() == name)
                    .ok_or_else(|| {
                        err(k, format!("the model has no passive force '{name}' (an ExpressionBasedCoordinateForce whose expression the sweep sets)"))
                    })?;
                let PassiveForce::ExpressionBasedCoordinate {
                    name: n,
                    coordinate,
                    ..
                } = &problem.passive[j]
                else {
                    return Err(err(
                        k,
                        format!("'{name}' is not an ExpressionBasedCoordinateForce: only their expressions can be swept"),
                    ));
                };
                let expr = Expression::compile(text).map_err(|m| {
                    err(k, format!("the expression of '{name}' ({text}): {m}"))
                })?;
                passive.push((
                    j,
                    PassiveForce::ExpressionBasedCoordinate {
                        name: n.clone(),
                        coordinate: *coordinate,
                        expr: Box::new(expr),
                    },
                ));
            }
            let mut optimal_force = Vec::new();
            for (name, f) in &s.optimal_forces {
                let v = problem
                    .controls
                    .iter()
                    .position(|c| matches!(c, Control::Actuator(a) if &a.name == name))
                    .ok_or_else(|| {
                        err(k, format!("the model has no actuator '{name}' (optimal forces of actuators other than muscles can be swept)"))
                    })?;
                let Control::Actuator(a) = &problem.controls[v] else {
                    unreachable!("matched an actuator")
                };
                if a.optimal_force == 0.0 || !f.is_finite() {
                    return Err(err(
                        k,
                        format!("optimal force {f} of '{name}' (its own is {}): both must be finite and the model's non-zero", a.optimal_force),
                    ));
                }
                optimal_force.push((v, *f));
            }
            let mut external = Vec::new();
            for (name, f) in &s.external_scales {
                let Some(loads) = &problem.loads else {
                    return Err(err(k, format!("external load scale of '{name}': the setup has no external loads")));
                };
                if !f.is_finite() {
                    return Err(err(k, format!("external load scale {f} of '{name}' is not a finite number")));
                }
                external.resize(loads.forces.len(), 1.0);
                if name == "*" {
                    external.iter_mut().for_each(|x| *x *= f);
                    continue;
                }
                let e = loads.forces.iter().position(|ef| &ef.name == name).ok_or_else(|| {
                    err(k, format!("the external loads have no ExternalForce '{name}' (names: {}; '*' scales them all)",
                        loads.forces.iter().map(|ef| ef.name.as_str()).collect::<Vec<_>>().join(", ")))
                })?;
                external[e] *= f;
            }
            Ok(ForceCandidate {
                w0: s.w0,
                passive,
                optimal_force,
                external,
            })
        })
        .collect()
}

/// The candidates' warm-start chains (one per w0, in the given order).
pub fn chains(cands: &[ForceCandidate]) -> Vec<usize> {
    let mut chain_w0: Vec<f64> = Vec::new();
    cands
        .iter()
        .map(|c| match chain_w0.iter().position(|w| *w == c.w0) {
            Some(k) => k,
            None => {
                chain_w0.push(c.w0);
                chain_w0.len() - 1
            }
        })
        .collect()
}
