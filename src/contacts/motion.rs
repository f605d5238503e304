//! A synthetic motion's table (`statopt-tool motion`): the profile of
//! `motion::generate` on the driven coordinates, links and couplers, with
//! contacts kept closed or planted by coordinates solved together on every
//! row (`contacts::closure::Chain`). See docs/composition.md.
//!
//! Values are written in OpenSim's motion-file convention: `inDegrees=yes`,
//! rotational coordinates in degrees, all others (translational, coupled) in
//! their model units, as OpenSim converts only rotational columns
//! (opensim-semantics.md §1.3).

use crate::contacts::closure::{Chain, CHAIN_TOLERANCE};
use crate::contacts::Contact;
use crate::dynamics::Data;
use crate::error::{Error, Result};
use crate::model::{Model, MotionType};
use crate::motion::generate::{profile, MinJerkMotion};
use crate::storage::Storage;
use crate::xml::Element;

fn find(model: &Model, name: &str, what: &str) -> Result<usize> {
    model.coordinate_index(name).ok_or_else(|| {
        let names: Vec<&str> = model.coordinates.iter().map(|c| c.name.as_str()).collect();
        Error::msg(format!(
            "{what} '{name}' is not a coordinate of the model; its coordinates are: {}",
            names.join(", ")
        ))
    })
}

/// The contact element named `cname` among `forces`, compiled.
fn contact_named(model: &Model, forces: &[Element], cname: &str, option: &str) -> Result<Contact> {
    let el = forces
        .iter()
        .find(|f| f.name_attr() == cname)
        .ok_or_else(|| {
            Error::msg(format!(
                "{option}: no force element named '{cname}' in the model, its artifacts or the force-set files"
            ))
        })?;
    Contact::from_xml(el, model)?
        .ok_or_else(|| el.error(format!("{option}: '{cname}' is not a contact element")))
}

/// Generate the motion: a table with one column per model coordinate (tree
/// order) in file units, and warnings (ranges left, locked coordinates driven).
/// `forces` are the force elements `--touch` and `--plant` may name (the
/// composed model's and force-set files').
pub fn generate(
    model: &Model,
    m: &MinJerkMotion,
    forces: &[Element],
) -> Result<(Storage, Vec<String>)> {
    let rows = profile(m)?;
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
    let linked = |i: usize| links.iter().any(|(t, _, _)| *t == i);
    // The chain: every contact named once, every coordinate solved once.
    let mut chain = Chain {
        contacts: Vec::new(),
        anchors: Vec::new(),
        unknowns: Vec::new(),
    };
    let mut planted: Vec<bool> = Vec::new();
    let named: Vec<(&str, &[String], bool, &str)> = m
        .touch
        .iter()
        .map(|(c, q)| (c.as_str(), std::slice::from_ref(q), false, "--touch"))
        .chain(
            m.plant
                .iter()
                .map(|(c, qs)| (c.as_str(), qs.as_slice(), true, "--plant")),
        )
        .collect();
    for (cname, qnames, plant, option) in named {
        let k = match chain.contacts.iter().position(|c| c.name == cname) {
            Some(k) => k,
            None => {
                chain
                    .contacts
                    .push(contact_named(model, forces, cname, option)?);
                chain.anchors.push(None);
                planted.push(false);
                chain.contacts.len() - 1
            }
        };
        planted[k] |= plant;
        for qname in qnames {
            let i = find(model, qname, &format!("{option} coordinate"))?;
            if chain.unknowns.contains(&i) {
                continue;
            }
            // A --link on the same coordinate gives the starting value.
            if explicit[i] && !linked(i) {
                return Err(Error::msg(format!(
                    "{option}: coordinate '{qname}' is already driven (--coordinate or --also); a contact can only set a coordinate that is not driven"
                )));
            }
            explicit[i] = true;
            chain.unknowns.push(i);
        }
    }
    if !chain.contacts.is_empty() && chain.unknowns.is_empty() {
        return Err(Error::msg(
            "--plant: no coordinate to solve; name one with --plant CONTACT=COORDINATE or --touch CONTACT=COORDINATE",
        ));
    }
    let full_residuals = chain.contacts.len() + 2 * planted.iter().filter(|p| **p).count();
    let hint = if full_residuals > chain.unknowns.len() {
        "; free another coordinate (--touch CONTACT=COORDINATE, --plant CONTACT=COORDINATE) or plant fewer contacts".to_string()
    } else {
        "; check that the coordinates given with --touch/--plant move these contacts (and start near a solution: --link gives a start)".to_string()
    };
    let mut data = Data::new(model);
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
    let mut header = format!(
        "statopt-tool motion: {} from {} to {} over {} s (minimum jerk)",
        m.coordinate, m.from, m.to, m.duration
    );
    if m.back {
        header.push_str(&format!(
            ", back over {} s",
            m.return_duration.unwrap_or(m.duration)
        ));
    }
    if m.hold_start > 0.0 || m.hold_end > 0.0 {
        header.push_str(&format!(
            ", held {} s before and {} s after",
            m.hold_start, m.hold_end
        ));
    }
    if m.repeat > 1 {
        header.push_str(&format!(", {} repetitions", m.repeat));
    }
    let mut table = Storage {
        name: format!("minimum-jerk motion of {}", m.coordinate),
        labels: model.coordinates.iter().map(|c| c.name.clone()).collect(),
        time: Vec::with_capacity(rows.len()),
        rows: Vec::with_capacity(rows.len()),
        in_degrees: true,
        metadata: vec![("header".into(), header)],
    };
    // The dependent coordinates of one-independent couplers, in file
    // units (`couple`) and model units (`prepare`, inside the solve).
    let couple = |row: &mut Vec<f64>| {
        for c in &model.couplers {
            if explicit[c.dependent] || c.independent.len() != 1 {
                continue;
            }
            let x = to_model(c.independent[0], row[c.independent[0]]);
            row[c.dependent] = to_file(c.dependent, c.scale * c.function.value(x));
        }
    };
    let prepare = |q: &mut [f64]| {
        for c in &model.couplers {
            if explicit[c.dependent] || c.independent.len() != 1 {
                continue;
            }
            q[c.dependent] = c.scale * c.function.value(q[c.independent[0]]);
        }
    };
    let round = |v: f64| -> f64 {
        match m.precision {
            Some(p) => crate::storage::format_c_fixed(v, 0, p)
                .trim()
                .parse()
                .unwrap_or(v),
            None => v,
        }
    };
    let mut previous: Option<Vec<f64>> = None;
    let mut q = vec![0.0; nq];
    for &(t, v) in &rows {
        let mut row = defaults.clone();
        for &d in &driven {
            row[d] = v;
        }
        for &(t_i, s_i, l) in &links {
            row[t_i] = l.scale * row[s_i] + l.offset;
        }
        couple(&mut row);
        if !chain.contacts.is_empty() {
            for i in 0..nq {
                q[i] = to_model(i, row[i]);
            }
            // Start from the previous row's solution unless a --link
            // gives the start.
            if let Some(prev) = &previous {
                for (j, &i) in chain.unknowns.iter().enumerate() {
                    if !linked(i) {
                        q[i] = prev[j];
                    }
                }
            }
            chain
                .solve(model, &mut data, &mut q, &prepare, t)
                .map_err(|e| Error::msg(format!("{e}{hint}")))?;
            if previous.is_none() {
                // Plant where the first row put the contacts.
                data.q.copy_from_slice(&q);
                crate::dynamics::kinematics::positions(model, &mut data);
                for k in 0..chain.contacts.len() {
                    if planted[k] {
                        chain.anchors[k] = Some(chain.in_plane(&data, k));
                    }
                }
            }
            previous = Some(chain.unknowns.iter().map(|&i| q[i]).collect());
            for &i in &chain.unknowns {
                row[i] = to_file(i, q[i]);
            }
            couple(&mut row);
        }
        if m.precision.is_some() {
            row.iter_mut().for_each(|x| *x = round(*x));
            if !chain.contacts.is_empty() {
                for i in 0..nq {
                    q[i] = to_model(i, row[i]);
                }
                if let Some(w) = chain.worst(model, &mut data, &mut q, &prepare) {
                    if !(w.value.abs() <= CHAIN_TOLERANCE) {
                        return Err(Error::msg(format!(
                            "at t = {t}, {} in the values rounded to {} decimals (tolerance {CHAIN_TOLERANCE:e} m); write more decimals (--precision)",
                            chain.describe(&w),
                            m.precision.unwrap_or(0)
                        )));
                    }
                }
            }
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
