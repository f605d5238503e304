//! Contacts whose plane faces away from their point's body: such a
//! contact would pull the body through its plane, so every frame that
//! needs it fails (`--check` reports them before a run).

use crate::contacts::Contact;
use crate::error::Error;
use crate::model::Model;

/// The contacts of `contacts` whose point body's mass centre lies behind
/// the contact's plane (opposite its normal) by more than [`FACING_MARGIN`]
/// in the pose `q` (`when` says which pose, for the message), grips apart
/// (a partner between the same two bodies with the opposite normal and its
/// point within [`GRIP_SPAN`]); each error names the contact's file and line.
pub fn facing_away(model: &Model, contacts: &[Contact], q: &[f64], when: &str) -> Vec<Error> {
    let mut errors = Vec::new();
    let mut data = crate::dynamics::Data::new(model);
    data.q.copy_from_slice(q);
    crate::dynamics::kinematics::positions(model, &mut data);
    let ground = |c: &Contact| {
        (
            data.rotation[c.plane_body] * c.normal,
            data.station_position(c.point_body, &c.point),
        )
    };
    for c in contacts {
        let Some((d_point, d_com)) = c.sides(model, &data) else {
            continue;
        };
        if d_com >= -FACING_MARGIN {
            continue;
        }
        let (n, p) = ground(c);
        let grip = contacts.iter().any(|o| {
            let (n_o, p_o) = ground(o);
            o.point_body == c.point_body
                && o.plane_body == c.plane_body
                && n_o.dot(&n) < 0.0
                && (p_o - p).norm() <= GRIP_SPAN
        });
        if grip {
            continue;
        }
        errors.push(Error::input(
            c.loc.clone(),
            format!(
                "contact {}: its plane faces away from its point's body {}: {when} the body's mass centre lies {:.1} mm behind the plane (the point {:.1} mm {}), but a contact pushes its point body along the plane normal, away from the plane, so it would pull the body through the plane and every frame that needs it fails; flip <plane_normal> (or check the plane's body and origin)",
                c.name,
                model.bodies[c.point_body].name,
                -1e3 * d_com,
                1e3 * d_point.abs(),
                if d_point >= 0.0 { "in front of it" } else { "behind it" },
            ),
        ));
    }
    errors
}

/// [`facing_away`] at the start of a motion: in the pose of its first
/// frame `first` (time, q), or in the model's default pose when there is
/// none (the motion cannot be read). The contact pushes its point body
/// along the normal, away from the plane, so such a contact would pull the
/// body through it: every frame that needs it fails. A grip is not
/// reported: a contact with a partner between the same two bodies whose
/// normal points the other way and whose point lies within [`GRIP_SPAN`]
/// of its own (a hand holding a bar from both sides, as the leg
/// extension's handle_push and handle_hold do).
pub fn facing_away_at_start(
    model: &Model,
    contacts: &[Contact],
    first: Option<(f64, &[f64])>,
) -> Vec<Error> {
    if contacts.is_empty() {
        return Vec::new();
    }
    match first {
        Some((t, q)) => {
            let when = format!("at the first frame (t = {})", crate::storage::fmt_time(t));
            facing_away(model, contacts, q, &when)
        }
        None => {
            let q: Vec<f64> = model.coordinates.iter().map(|c| c.default_value).collect();
            facing_away(model, contacts, &q, "in the model's default pose")
        }
    }
}

/// How far (m) behind a contact's plane its point body's mass centre must
/// lie for `--check` to report the plane as facing away from the body: a
/// mass centre within 1 mm of the plane says nothing of the side (the same
/// millimetre the run's summary allows a loaded contact into its plane).
pub const FACING_MARGIN: f64 = 1e-3;

/// Two contacts of one body on one plane body with opposite normals and
/// points at most this far apart (m) are a grip, not a plane facing away:
/// both sides of a bar a hand holds lie within a hand's breadth (8 cm for
/// an adult, e.g. the hand breadth of ANSUR II, about 8.5–9 cm at the
/// metacarpals; the leg extension's grips use one point for both sides).
pub const GRIP_SPAN: f64 = 0.05;
