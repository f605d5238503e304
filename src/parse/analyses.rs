//! The analyses of an AnalyzeTool setup as typed values: the
//! StaticOptimization element (OpenSim's properties and statopt's
//! additions, among them the contact weights w0) and the JointReaction
//! element, each read once, with the element kept for located messages.
//! Later stages re-export them where they are used
//! (`frame::settings`, `reactions::setup`, `optimize`).

use std::path::PathBuf;

use crate::error::Result;
use crate::parse::setup::{resolve, AnalysisCommon};
use crate::xml::Element;

/// Representation of the static friction cone. The default is the exact
/// cone, as a StaticOptimization without `<friction_cone>` uses (README).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FrictionModel {
    /// Four-sided circumscribed pyramid, eq. 16 of the paper.
    Pyramid4,
    /// Eight-sided circumscribed pyramid (faces tangent to the cone every 45°).
    Pyramid8,
    /// Exact second-order cone ‖(λs1, λs2)‖ ≤ μ_s λn (eq. 2).
    #[default]
    Cone,
}

/// Solver selection of the frame solve (`optimize::SolveSettings`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SolverChoice {
    /// The dual semismooth Newton method (`optimize::dual`) where it applies
    /// and converges (to ‖A x − b‖∞ ≤ 1e-12·max(1, ‖b‖∞), accepting 1e-10,
    /// whatever `tolerance` says), Clarabel otherwise (other exponents,
    /// free variables of weight 0, contacts with bounds beyond λn ≥ 0 or
    /// unequal weights, possibly infeasible frames).
    #[default]
    Auto,
    /// Clarabel on every frame.
    Clarabel,
}

/// Which knees a StaticOptimization solves with the knee contact method
/// (`frame::knee_contact`, which re-exports it).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum KneeSelection {
    /// Plain static optimization (OpenSim's).
    #[default]
    Off,
    /// Every knee of the model (every joint whose child is a `tibia_*` body).
    All,
    /// The named joints.
    Joints(Vec<String>),
}

/// The StaticOptimization element of an AnalyzeTool setup.
#[derive(Debug, Clone)]
pub struct StaticOptimizationSetup {
    pub common: AnalysisCommon,
    pub use_model_force_set: bool,
    pub activation_exponent: f64,
    pub use_muscle_physiology: bool,
    /// OpenSim's IPOPT tolerance; statopt passes it to Clarabel only if it is
    /// tighter than [`DEFAULT_TOLERANCE`].
    pub convergence_criterion: f64,
    pub max_iterations: u32,
    /// statopt: add passive fiber force to each muscle (off by default, as
    /// OpenSim ignores it).
    pub passive_fiber_forces: bool,
    /// statopt: add a CoordinateActuator `<coordinate>_reserve` with this
    /// optimal force to every unconstrained coordinate, so that every frame
    /// can be solved; the run reports how much they carried.
    pub reserve_actuators: Option<f64>,
    /// statopt (Krüger & Wartzack eq. 6): the global contact weight w0; the
    /// objective is a'a + (1/w0) l'l. Several values run a sweep.
    pub contact_weights: Vec<f64>,
    /// Static-regime friction constraint: the paper's four-sided pyramid
    /// (eq. 16), an eight-sided one, or the exact cone (eq. 2; default).
    pub friction: FrictionModel,
    /// statopt: how the equations of motion become the constraint matrix
    /// (`<constraint_matrix>analytic|perturbation</constraint_matrix>`).
    pub constraint_matrix: ConstraintMatrix,
    /// statopt: Clarabel's tolerance exactly (`<solver_tolerance>`), looser or
    /// tighter than [`DEFAULT_TOLERANCE`]; unset: the convergence-criterion rule.
    /// (The dual Newton solver always solves to 1e-10 relative.)
    pub solver_tolerance: Option<f64>,
    /// statopt: `<solver>auto|newton|clarabel</solver>`: the dual Newton
    /// solver with Clarabel as fallback (auto, newton; default), or Clarabel
    /// on every frame.
    pub solver: SolverChoice,
    /// statopt `<knee_contact>`: solve the named knees (`all`/`true`: every
    /// knee of the model) with the knee contact method
    /// (`frame::knee_contact`, docs/knee_contact.md); off by default.
    pub knee_contact: KneeSelection,
    /// false when `<knee_contact>` holds the word `axial`: one axial contact
    /// per knee instead of two compartments (the ingredient study of
    /// docs/knee_contact.md).
    pub knee_contact_frontal: bool,
    /// statopt `<knee_contact_capacity>`: each compartment's load capacity in
    /// body weights, the unit of its cost (default
    /// [`DEFAULT_KNEE_CAPACITY_BW`]; `frame::knee_contact`).
    pub knee_contact_capacity_bw: f64,
    /// statopt `<knee_contact_medial_share>`: the medial compartment's share
    /// of the knee's capacity (twice `knee_contact_capacity_bw`), the lateral
    /// taking the rest (default [`DEFAULT_KNEE_MEDIAL_SHARE`];
    /// `frame::knee_contact`).
    pub knee_contact_medial_share: f64,
    /// statopt `<knee_contact_equal_activation>`: muscles held at one
    /// activation under the knee contact method (`frame::knee_contact`).
    pub knee_contact_equal_activation: EqualActivation,
    /// Whether the element gives `<contact_weight>` (else
    /// [`DEFAULT_CONTACT_WEIGHT`] applies).
    pub contact_weights_given: bool,
    /// The element, for located messages.
    pub element: Element,
}

/// How a frame's equality constraints are built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ConstraintMatrix {
    /// Force space: inverse dynamics once for the required generalized
    /// forces, each variable's unit generalized force projected on the
    /// coupling vectors (rows = C_kᵀ M u̇).
    #[default]
    Analytic,
    /// Acceleration space by unit perturbation (Krüger & Wartzack eq. 14,
    /// OpenSim's StaticOptimizationTarget): one forward-dynamics solve per
    /// variable, column i = u̇_i − u̇_0, b = u̇_target − u̇_0
    /// (see `tools::perturbation`).
    Perturbation,
}

/// Clarabel's feasibility/gap tolerance unless the setup asks for tighter.
pub const DEFAULT_TOLERANCE: f64 = 1e-8;

impl KneeSelection {
    /// The knees the words of `<knee_contact>` select, and whether each
    /// knee has two compartments (false when a word is `axial`: one axial
    /// contact per knee): `all`/`true` (or only `axial`) every knee,
    /// `false`/`off`/`none` none, else the named joints. The same check
    /// whether the words come from a setup or from an edit of its plan
    /// (`statopt-tool knee-contact`).
    pub fn from_words(words: &[String]) -> std::result::Result<(KneeSelection, bool), String> {
        let frontal = !words.iter().any(|w| w.eq_ignore_ascii_case("axial"));
        let mut named: Vec<String> = words
            .iter()
            .filter(|w| !w.eq_ignore_ascii_case("axial"))
            .cloned()
            .collect();
        if named.is_empty() && !words.is_empty() {
            named.push("all".into());
        }
        let lower: Vec<String> = named.iter().map(|w| w.to_ascii_lowercase()).collect();
        let selection = match lower.as_slice() {
            [] => {
                return Err(
                    "knee_contact is empty: give 'all' (every knee of the model), knee joint names, or 'false'"
                        .to_string(),
                )
            }
            [w] if w == "false" || w == "off" || w == "none" => KneeSelection::Off,
            [w] if w == "true" || w == "all" => KneeSelection::All,
            _ => KneeSelection::Joints(named),
        };
        Ok((selection, frontal))
    }
}

/// Why `w0` cannot be a list of contact weights (`text`: how the setup
/// gave them), or None.
fn contact_weights_problem(v: &[f64], text: &str) -> Option<String> {
    if v.is_empty() || v.iter().any(|x| !(*x > 0.0 && x.is_finite())) {
        return Some(format!(
            "contact_weight must be one or more positive numbers, found '{text}'"
        ));
    }
    v.iter()
        .find(|x| !(CONTACT_WEIGHT_RANGE.0..=CONTACT_WEIGHT_RANGE.1).contains(*x))
        .map(|x| format!(
            "contact_weight {x:e} lies outside [{:e}, {:e}]: the objective weighs contacts by 1/w0, and past these bounds one term no longer counts in double precision (the answer saturates long before: beyond w0 = 1e4 contacts carry more than 99.99 %, below 1e-4 muscles do)",
            CONTACT_WEIGHT_RANGE.0, CONTACT_WEIGHT_RANGE.1
        ))
}

/// Why `v` cannot be a knee compartment's capacity in body weights, or None.
fn knee_capacity_problem(v: f64) -> Option<String> {
    (!(v > 0.0 && v.is_finite())).then(|| format!(
        "knee_contact_capacity is a compartment's load capacity in body weights and must be positive, found {v}"
    ))
}

/// Which muscles the knee contact method holds at one activation
/// (`<knee_contact_equal_activation>`).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum EqualActivation {
    /// The two heads of each knee's gastrocnemius (the default; the word
    /// `gastrocnemius`): one muscle, one nerve, one tendon, split by the
    /// model for its paths only.
    #[default]
    Gastrocnemius,
    /// None (the word `none`).
    Off,
    /// Named groups: muscles separated by spaces, groups by `;`.
    Groups(Vec<Vec<String>>),
}

impl EqualActivation {
    /// The property's text read, or why not.
    pub fn from_text(text: &str) -> std::result::Result<Self, String> {
        let t = text.trim();
        if t.eq_ignore_ascii_case("gastrocnemius") {
            return Ok(EqualActivation::Gastrocnemius);
        }
        if t.eq_ignore_ascii_case("none") || t.eq_ignore_ascii_case("false") {
            return Ok(EqualActivation::Off);
        }
        let groups: Vec<Vec<String>> = t
            .split(';')
            .map(|g| g.split_whitespace().map(String::from).collect::<Vec<_>>())
            .filter(|g| !g.is_empty())
            .collect();
        if groups.is_empty() {
            return Err("knee_contact_equal_activation is empty: give 'gastrocnemius' (the default), 'none', or groups of muscle names separated by ';'".into());
        }
        if let Some(g) = groups.iter().find(|g| g.len() < 2) {
            return Err(format!(
                "knee_contact_equal_activation: a group needs at least two muscles, found '{}'",
                g.join(" ")
            ));
        }
        Ok(EqualActivation::Groups(groups))
    }
}

/// Why `v` cannot be the medial compartment's share of the knee's capacity, or None.
fn knee_medial_share_problem(v: f64) -> Option<String> {
    (!(v > 0.0 && v < 1.0)).then(|| format!(
        "knee_contact_medial_share is the medial compartment's share of the knee's load capacity and must lie in (0, 1), found {v}"
    ))
}

/// Why `v` cannot be Clarabel's tolerance, or None.
fn solver_tolerance_problem(v: f64) -> Option<String> {
    (!(v > 0.0 && v < 1.0)).then(|| format!("solver_tolerance must lie in (0, 1), found {v}"))
}

/// Typed edits of the plan (`statopt-tool knee-contact`, `bench --grid`,
/// tests), checked as the same values are when read from a setup; an error
/// names the StaticOptimization element.
impl StaticOptimizationSetup {
    /// Solve the knees `words` select ([`KneeSelection::from_words`]) with
    /// the knee contact method.
    pub fn set_knee_contact(&mut self, words: &[String]) -> Result<()> {
        let (selection, frontal) =
            KneeSelection::from_words(words).map_err(|m| self.element.error(m))?;
        self.knee_contact = selection;
        self.knee_contact_frontal = frontal;
        Ok(())
    }

    /// The contact weights w0 (a sweep when several).
    pub fn set_contact_weights(&mut self, w0: &[f64]) -> Result<()> {
        let text = w0
            .iter()
            .map(|w| w.to_string())
            .collect::<Vec<_>>()
            .join(" ");
        if let Some(m) = contact_weights_problem(w0, &text) {
            return Err(self.element.error(m));
        }
        self.contact_weights = w0.to_vec();
        self.contact_weights_given = true;
        Ok(())
    }

    /// Each knee compartment's load capacity in body weights.
    pub fn set_knee_contact_capacity(&mut self, bw: f64) -> Result<()> {
        if let Some(m) = knee_capacity_problem(bw) {
            return Err(self.element.error(m));
        }
        self.knee_contact_capacity_bw = bw;
        Ok(())
    }

    /// The muscles the knee contact method holds at one activation.
    pub fn set_knee_contact_equal_activation(&mut self, e: EqualActivation) {
        self.knee_contact_equal_activation = e;
    }

    /// The medial compartment's share of the knee's load capacity.
    pub fn set_knee_contact_medial_share(&mut self, share: f64) -> Result<()> {
        if let Some(m) = knee_medial_share_problem(share) {
            return Err(self.element.error(m));
        }
        self.knee_contact_medial_share = share;
        Ok(())
    }

    /// Clarabel's tolerance exactly (`<solver_tolerance>`).
    pub fn set_solver_tolerance(&mut self, tol: f64) -> Result<()> {
        if let Some(m) = solver_tolerance_problem(tol) {
            return Err(self.element.error(m));
        }
        self.solver_tolerance = Some(tol);
        Ok(())
    }

    /// The contact weight a run takes when the element gives none
    /// (`<contact_weight>` left out): a tool's own default for its contacts
    /// (predict-grf's foot contacts), checked as a given weight is; the
    /// element still counts as giving none.
    pub fn set_default_contact_weight(&mut self, w0: f64) -> Result<()> {
        if let Some(m) = contact_weights_problem(&[w0], &w0.to_string()) {
            return Err(self.element.error(m));
        }
        self.contact_weights = vec![w0];
        Ok(())
    }

    /// The static friction constraint's representation (`<friction_cone>`).
    pub fn set_friction(&mut self, friction: FrictionModel) {
        self.friction = friction;
    }

    /// The frame solver (`<solver>`).
    pub fn set_solver(&mut self, solver: SolverChoice) {
        self.solver = solver;
    }

    /// How the equations of motion become the constraint matrix
    /// (`<constraint_matrix>`).
    pub fn set_constraint_matrix(&mut self, m: ConstraintMatrix) {
        self.constraint_matrix = m;
    }

    /// The reserves' optimal force (`<reserve_actuators>`), or none: a
    /// positive, finite force.
    pub fn set_reserve_actuators(&mut self, optimal_force: Option<f64>) -> Result<()> {
        if let Some(v) = optimal_force {
            if !(v > 0.0 && v.is_finite()) {
                return Err(self.element.error(format!(
                    "reserve_actuators is the reserves' optimal force and must be positive, found {v}"
                )));
            }
        }
        self.reserve_actuators = optimal_force;
        Ok(())
    }
}

impl StaticOptimizationSetup {
    pub fn from_xml(el: &Element, common: AnalysisCommon) -> Result<Self> {
        let p = el.child_f64_or("activation_exponent", DEFAULT_ACTIVATION_EXPONENT)?;
        if !(p >= 1.0 && p.is_finite()) {
            return Err(el.req("activation_exponent")?.error(format!("activation_exponent must be a finite number >= 1 (the problem is convex only then), found {p}")));
        }
        let max_iter = el.child_f64_or(
            "optimizer_max_iterations",
            f64::from(DEFAULT_MAX_ITERATIONS),
        )?;
        if !(max_iter >= 1.0) {
            return Err(el
                .req("optimizer_max_iterations")?
                .error("optimizer_max_iterations must be positive"));
        }
        let (knee_contact, knee_contact_frontal) = match el.child("knee_contact") {
            None => (KneeSelection::Off, true),
            Some(k) => KneeSelection::from_words(&k.words()).map_err(|m| k.error(m))?,
        };
        Ok(StaticOptimizationSetup {
            common,
            contact_weights_given: el.child("contact_weight").is_some(),
            element: el.clone(),
            use_model_force_set: el.child_bool_or("use_model_force_set", true)?,
            activation_exponent: p,
            use_muscle_physiology: el.child_bool_or("use_muscle_physiology", true)?,
            convergence_criterion: el
                .child_f64_or("optimizer_convergence_criterion", DEFAULT_CONVERGENCE_CRITERION)?,
            max_iterations: max_iter as u32,
            passive_fiber_forces: el.child_bool_or("passive_fiber_forces", false)?,
            contact_weights: match el.child("contact_weight") {
                Some(w) if w.text().trim().is_empty() => {
                    return Err(w.error(format!(
                        "contact_weight is empty: give w0 (one or more positive numbers), or leave the element out for the default {DEFAULT_CONTACT_WEIGHT}"
                    )))
                }
                Some(w) => {
                    let v = w.numbers()?;
                    if let Some(m) = contact_weights_problem(&v, w.text()) {
                        return Err(w.error(m));
                    }
                    v
                }
                None => vec![DEFAULT_CONTACT_WEIGHT],
            },
            friction: match el.child("friction_cone") {
                Some(f) if !f.text().is_empty() => match f.text().to_ascii_lowercase().as_str() {
                    "cone" => FrictionModel::Cone,
                    "pyramid" | "pyramid4" => FrictionModel::Pyramid4,
                    "pyramid8" => FrictionModel::Pyramid8,
                    other => return Err(f.error(format!("friction_cone must be 'cone', 'pyramid' (four-sided, the paper's eq. 16) or 'pyramid8', found '{other}'"))),
                },
                _ => FrictionModel::default(),
            },
            constraint_matrix: match el.child("constraint_matrix") {
                Some(f) if !f.text().is_empty() => match f.text().to_ascii_lowercase().as_str() {
                    "analytic" => ConstraintMatrix::Analytic,
                    "perturbation" => ConstraintMatrix::Perturbation,
                    other => return Err(f.error(format!("constraint_matrix must be 'analytic' or 'perturbation', found '{other}'"))),
                },
                _ => ConstraintMatrix::Analytic,
            },
            solver_tolerance: match el.child("solver_tolerance") {
                Some(r) if !r.text().is_empty() => {
                    let v = r.f64()?;
                    if let Some(m) = solver_tolerance_problem(v) {
                        return Err(r.error(m));
                    }
                    Some(v)
                }
                _ => None,
            },
            solver: match el.child("solver") {
                Some(f) if !f.text().trim().is_empty() => match f.text().trim().to_ascii_lowercase().as_str() {
                    "auto" | "newton" => SolverChoice::Auto,
                    "clarabel" => SolverChoice::Clarabel,
                    other => return Err(f.error(format!("solver must be 'auto' (or 'newton': the dual Newton solver, Clarabel where it does not apply or converge) or 'clarabel', found '{other}'"))),
                },
                _ => SolverChoice::Auto,
            },
            knee_contact_capacity_bw: match el.child("knee_contact_capacity") {
                Some(c) if !c.text().trim().is_empty() => {
                    let v = c.f64()?;
                    if let Some(m) = knee_capacity_problem(v) {
                        return Err(c.error(m));
                    }
                    v
                }
                _ => DEFAULT_KNEE_CAPACITY_BW,
            },
            knee_contact_equal_activation: match el.child("knee_contact_equal_activation") {
                Some(c) => EqualActivation::from_text(c.text()).map_err(|m| c.error(m))?,
                None => EqualActivation::Gastrocnemius,
            },
            knee_contact_medial_share: match el.child("knee_contact_medial_share") {
                Some(c) if !c.text().trim().is_empty() => {
                    let v = c.f64()?;
                    if let Some(m) = knee_medial_share_problem(v) {
                        return Err(c.error(m));
                    }
                    v
                }
                _ => DEFAULT_KNEE_MEDIAL_SHARE,
            },
            knee_contact_frontal,
            knee_contact,
            reserve_actuators: match el.child("reserve_actuators") {
                Some(r) if !r.text().is_empty() => {
                    let v = r.f64()?;
                    if !(v > 0.0 && v.is_finite()) {
                        return Err(r.error(format!("reserve_actuators is the reserves' optimal force and must be positive, found {v}")));
                    }
                    Some(v)
                }
                _ => None,
            },
        })
    }
}

/// A knee compartment's load capacity in body weights when a
/// StaticOptimization gives no `<knee_contact_capacity>`: half of 3.46 BW,
/// the highest mean peak knee force of the activities of daily living
/// measured with instrumented knee implants (stair descent; Kutzner et al.
/// 2010, J Biomech 43:2164, five subjects), each compartment taking half
/// (docs/knee_contact.md says why).
pub const DEFAULT_KNEE_CAPACITY_BW: f64 = 1.73;

/// The medial compartment's share of the knee's load capacity when a
/// StaticOptimization gives no `<knee_contact_medial_share>`: instrumented
/// knees carry about 60–70 % of the tibiofemoral load medially in walking
/// (docs/knee_contact.md gives the sources), so each compartment's habitual
/// peak, its capacity, is that share of the knee's; 0.65 is the middle of
/// the range, not fitted to a trial.
pub const DEFAULT_KNEE_MEDIAL_SHARE: f64 = 0.65;

/// w0 when a StaticOptimization has no `<contact_weight>`.
pub const DEFAULT_CONTACT_WEIGHT: f64 = 1000.0;

/// OpenSim's `activation_exponent` when a StaticOptimization gives none.
pub const DEFAULT_ACTIVATION_EXPONENT: f64 = 2.0;

/// OpenSim's `optimizer_convergence_criterion` when a StaticOptimization
/// gives none.
pub const DEFAULT_CONVERGENCE_CRITERION: f64 = 1e-4;

/// OpenSim's `optimizer_max_iterations` when a StaticOptimization gives none.
pub const DEFAULT_MAX_ITERATIONS: u32 = 100;

/// The w0 statopt accepts: 1/w0 and w0 times a unit multiplier stay within
/// ten decades of the activations' scale either way.
pub const CONTACT_WEIGHT_RANGE: (f64, f64) = (1e-12, 1e12);

/// The JointReaction element of an AnalyzeTool setup (§7.1).
#[derive(Debug, Clone)]
pub struct JointReactionSetup {
    pub common: AnalysisCommon,
    /// Resolved against the setup's folder; None when empty.
    pub forces_file: Option<PathBuf>,
    pub joint_names: Vec<String>,
    pub apply_on_bodies: Vec<String>,
    pub express_in_frame: Vec<String>,
    /// statopt `<knee_loads>`: also write `<prefix>KneeLoads.sto`
    /// (`tools::knee_loads`) with each ReactionLoads table of a static
    /// optimization run.
    pub knee_loads: bool,
    /// The element, for located errors.
    pub element: Element,
}

impl JointReactionSetup {
    /// Take the actuators' forces from `path` instead (a study run with
    /// `-o DIR` reads another setup's force table where it moved it).
    pub fn set_forces_file(&mut self, path: PathBuf) {
        self.forces_file = Some(path);
    }

    /// A `<JointReaction>` element given as text, read as if it stood in
    /// the file `path` (paths in it resolve against `setup_dir`).
    pub fn from_text(
        text: &str,
        path: &std::path::Path,
        setup_dir: &std::path::Path,
    ) -> Result<Self> {
        let el = crate::xml::parse_str(text, path)?;
        let common = crate::parse::setup::read_common(&el)?;
        Self::from_xml(&el, common, setup_dir)
    }

    pub fn from_xml(
        el: &Element,
        common: AnalysisCommon,
        setup_dir: &std::path::Path,
    ) -> Result<Self> {
        let list = |name: &str, default: &str| -> Vec<String> {
            match el.child(name).map(|c| c.words()) {
                Some(w) if !w.is_empty() => w,
                _ => vec![default.to_string()],
            }
        };
        let forces_file = el
            .child_text("forces_file")
            .map(str::trim)
            .filter(|s| !s.is_empty() && *s != "Unassigned")
            .map(|s| resolve(setup_dir, s));
        Ok(JointReactionSetup {
            common,
            forces_file,
            joint_names: list("joint_names", "ALL"),
            apply_on_bodies: list("apply_on_bodies", "child"),
            express_in_frame: list("express_in_frame", "ground"),
            knee_loads: el.child_bool_or("knee_loads", false)?,
            element: el.clone(),
        })
    }
}
