//! Which foot a measured plate's load belongs to (issue 36).
//!
//! A force plate is assigned to a foot by the body its ExternalForce is
//! applied to. On a split-belt treadmill a runner sometimes steps across
//! onto the other belt, or onto the seam: a plate then holds the other
//! foot's load, or part of it, and the comparison of a foot with "its"
//! plate is wrong for that step. The test is geometric and has no
//! threshold: a plate's centre of pressure lies under the foot that loads
//! it, so a loaded plate whose centre of pressure is nearer the other
//! foot's sole than its own foot's holds the other foot's load. Each such
//! step (the plate's contiguous loaded frames, most of whose frames with a
//! reliable centre of pressure say so) is found whole, and its frames are
//! left out of the scores.

use nalgebra::Vector3;

/// A plate's vertical force above which it is loaded (N; the stance
/// threshold of the comparison).
pub const LOADED: f64 = 20.0;

/// A plate's vertical force above which its centre of pressure is taken
/// as evidence (N): a plate's centre of pressure is the ratio of moments to
/// force and wanders at small loads (about 7 % of body weight).
pub const COP_RELIABLE: f64 = 50.0;

/// One plate at one frame: the foot it is assigned to (0 right, 1 left),
/// its force and centre of pressure (ground).
#[derive(Debug, Clone, Copy)]
pub struct PlateSample {
    pub foot: usize,
    pub force: Vector3<f64>,
    pub cop: Vector3<f64>,
}

/// A step on the wrong plate: the plate (its index in the frames' lists),
/// the foot it is assigned to, and its first and last frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MisplacedStep {
    pub plate: usize,
    pub foot: usize,
    pub first: usize,
    pub last: usize,
}

/// The steps on the wrong plate. `plates[i]`: the plates at frame i (the
/// same plates, in the same order, at every frame); `feet[i][s]`: the
/// ground positions of foot s's contact points at frame i.
pub fn misplaced_steps(
    plates: &[Vec<PlateSample>],
    feet: &[[Vec<Vector3<f64>>; 2]],
) -> Vec<MisplacedStep> {
    let n = plates.len().min(feet.len());
    let np = plates.first().map_or(0, |p| p.len());
    let distance = |c: &Vector3<f64>, pts: &[Vector3<f64>]| {
        pts.iter()
            .map(|p| (p.x - c.x).hypot(p.z - c.z))
            .fold(f64::INFINITY, f64::min)
    };
    let mut out = Vec::new();
    for k in 0..np {
        let mut i = 0;
        while i < n {
            if !plates[i].get(k).is_some_and(|p| p.force.y > LOADED) {
                i += 1;
                continue;
            }
            let first = i;
            while i < n && plates[i].get(k).is_some_and(|p| p.force.y > LOADED) {
                i += 1;
            }
            let last = i - 1;
            let foot = plates[first][k].foot;
            let (mut wrong, mut evidence) = (0usize, 0usize);
            for j in first..=last {
                let p = &plates[j][k];
                if !(p.force.y > COP_RELIABLE) || !p.cop.iter().all(|x| x.is_finite()) {
                    continue;
                }
                evidence += 1;
                let own = distance(&p.cop, &feet[j][foot]);
                let other = distance(&p.cop, &feet[j][1 - foot]);
                if other < own {
                    wrong += 1;
                }
            }
            if evidence > 0 && 2 * wrong > evidence {
                out.push(MisplacedStep {
                    plate: k,
                    foot,
                    first,
                    last,
                });
            }
        }
    }
    out
}
