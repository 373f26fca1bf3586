//! Which stepper runs a model, chosen from the model ([`Plan::compile`]), and the one entry point
//! [`simulate`] for a [`Mechanism`] of any kind.
//!
//! | the model | stepper |
//! |---|---|
//! | every link and bearing body on a frame that translates at a fixed angle, only clearance joints without friction (no pin, slider, support, point mass, load or gravity), no Coriolis, inertia-coupling or geometric term asked for, no link energy or link peak recorded | [`StepperKind::Constant`]: the contact-free effective matrix factorized once (faer LDL^T, banded substitution), contact by Woodbury ([`crate::integrator::constant`]) |
//! | otherwise, every link frame at rest or turning at a constant rate, no geometric terms (K2, K3, D2), no node pinned or on a slider in a link that rotates, and (modified method) both sides of each clearance joint turning at one rate, no joint with friction ([`NewtonRun::constant_rate_obstacle`]) | [`StepperKind::ConstantRate`]: the moving-frame equations with the contact-free Jacobian factorized once (band LU), contact by Woodbury on it |
//! | a rigid link (`Link::rigid`): its rigid-body terms follow the frame's nominal acceleration | [`StepperKind::Newton`] |
//! | anything else | [`StepperKind::Newton`]: Newton iterations, the Jacobian refactorized when it changes ([`crate::integrator::newton`]); a clearance joint with friction always lands here, on the refactorizing path (the friction tangent is not a symmetric 2 x 2 block of the relative displacement: it couples the rotations, and its dependence on the normal force is unsymmetric) |
//!
//! Adaptive steps ([`Settings::adaptive`]) run on the constant stepper where the model allows it
//! (its factorizations of recent step sizes cached: [`crate::integrator::constant`], "Adaptive
//! steps"), else on the Newton stepper (not on the constant-rate one).
//!
//! The constant stepper runs the mechanism's translating-frame form
//! ([`Mechanism::to_translating`]) and records the link channels (frame, nodal displacements,
//! axial force, midspan deflection) from its node histories, in the layout of the Newton
//! stepper. Energy channels need the velocities: a run that records them takes the Newton stepper.
//!
//! For the Newton and constant-rate kinds the plan numbers the moving-frame unknowns, pins
//! eliminated ([`dofs::number`]), keeps the numbering ([`Plan::dofs`]) and hands it to the stepper
//! (`NewtonRun::with_plan_dofs`, with each clearance joint's moves-apart flag: the plan numbers
//! only a mechanism that passed [`Mechanism::validate_apart`], so the stepper does not validate
//! it again).

pub mod assembly;
pub mod dofs;
pub mod translating;

use crate::error::Error;
use crate::integrator::newton::NewtonRun;
use crate::model::mechanism::Mechanism;
use crate::record::LinkHistory;
use crate::run::{simulate as simulate_translating, RunFailure, RunOutput, Settings};
use translating::Model;

/// The kinds of stepper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepperKind {
    /// Constant effective matrix: factorized once, contact by Woodbury.
    Constant,
    /// Moving frames whose contact-free Jacobian is constant (frames at rest or turning at a
    /// constant rate, no geometric terms): band LU once, contact by Woodbury on it.
    ConstantRate,
    /// Newton on the moving-frame equations, the Jacobian refactorized when it changes.
    Newton,
}

impl StepperKind {
    /// The name in `RunStats::stepper`.
    pub fn name(self) -> &'static str {
        match self {
            StepperKind::Constant => "constant",
            StepperKind::ConstantRate => "constant-rate",
            StepperKind::Newton => "newton",
        }
    }
}

/// The stepper chosen for a model and settings, and why.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The stepper that runs.
    pub kind: StepperKind,
    /// Why the constant stepper cannot run it (empty for [`StepperKind::Constant`]).
    pub reason: String,
    /// Why the constant-rate stepper cannot run it (empty for [`StepperKind::ConstantRate`], and
    /// for [`StepperKind::Constant`], where it is not examined).
    pub rate_reason: String,
    translating: Option<Model>,
    /// The numbering of the moving-frame unknowns ([`dofs::number`]) for the Newton and
    /// constant-rate kinds; `None` for the constant kind and for a model that fails validation or
    /// numbering (its run fails with that error).
    dofs: Option<Numbered>,
}

/// What a plan keeps of a mechanism that passed [`Mechanism::validate`] for its settings'
/// `t_end` ([`Mechanism::validate_apart`]) for the moving-frame steppers.
#[derive(Debug, Clone)]
struct Numbered {
    /// The unknowns' numbering ([`dofs::number`]).
    dofs: dofs::DofMap,
    /// Per clearance joint, whether its sides move apart under the nominal motion.
    apart: Vec<bool>,
}

impl Numbered {
    /// The run of `mech` with `settings` on this numbering (validated, not again).
    fn run<'a>(&self, mech: &'a Mechanism, settings: &'a Settings) -> crate::error::Result<NewtonRun<'a>> {
        NewtonRun::with_plan_dofs(mech, settings, self.dofs.clone(), self.apart.clone())
    }
}

impl Plan {
    /// Chooses the stepper for `mech` run with `settings` (the rules of the module table), or
    /// takes the one `settings.stepper` asks for. Fails with [`Error::InvalidParameter`] naming
    /// `stepper` when the constant or constant-rate stepper is asked for a model it cannot run
    /// (the message says why).
    pub fn compile(mech: &Mechanism, settings: &Settings) -> crate::error::Result<Plan> {
        let plan = Self::choose(mech, settings);
        match settings.stepper {
            Some(StepperKind::Newton) => Ok(Plan {
                kind: StepperKind::Newton,
                reason: "asked for".into(),
                rate_reason: "asked for".into(),
                translating: None,
                dofs: plan.dofs.or_else(|| Self::number(mech, settings)),
            }),
            Some(StepperKind::ConstantRate) if settings.adaptive.is_some() => Err(Error::param(
                "stepper",
                "\"constant-rate\"",
                "\"constant\" (translating models), \"newton\" or None with adaptive steps (a tolerance \
                 instead of a step)",
            )),
            Some(StepperKind::ConstantRate) => match Self::rate_obstacle(mech, settings, plan.dofs.as_ref()) {
                None => Ok(Plan {
                    kind: StepperKind::ConstantRate,
                    reason: "asked for".into(),
                    rate_reason: String::new(),
                    translating: None,
                    dofs: plan.dofs.or_else(|| Self::number(mech, settings)),
                }),
                Some(why) => Err(Error::param(
                    "stepper",
                    "\"constant-rate\"",
                    format!("\"newton\" or None for this model ({why})"),
                )),
            },
            Some(StepperKind::Constant) if plan.kind != StepperKind::Constant => Err(Error::param(
                "stepper",
                "\"constant\"",
                match plan.kind {
                    StepperKind::ConstantRate => {
                        format!("\"constant-rate\", \"newton\" or None for this model ({})", plan.reason)
                    }
                    _ => format!("\"newton\" or None for this model ({})", plan.reason),
                },
            )),
            _ => Ok(plan),
        }
    }

    /// Why the constant-rate stepper cannot run `mech` with `settings`
    /// ([`NewtonRun::constant_rate_obstacle`]; the links' obstacles are found from the numbering
    /// alone, [`crate::integrator::newton::links_rate_obstacle`]; where no link is one, an
    /// invalid model or settings is a reason too, and the run then fails with that error on the
    /// Newton stepper). `dofs`: the plan's numbering.
    fn rate_obstacle(mech: &Mechanism, settings: &Settings, dofs: Option<&Numbered>) -> Option<String> {
        if let Some(d) = dofs {
            // the links' obstacles need only the numbering: no run is built for them (a
            // slider-crank's rod turns at a varying rate)
            let terms = dofs::link_terms(mech, &d.dofs.nodes);
            if let Err(why) = crate::integrator::newton::links_rate_obstacle(mech, terms) {
                return Some(why);
            }
        }
        let run = match dofs {
            Some(d) => d.run(mech, settings),
            None => NewtonRun::new(mech, settings),
        };
        match run {
            Ok(run) => run.constant_rate_obstacle(),
            Err(e) => Some(e.to_string()),
        }
    }

    /// Whether the run records link channels only the Newton stepper tracks: energies (they
    /// need the velocities) and the running link peaks.
    fn links_on_newton(settings: &Settings) -> bool {
        settings.record.links.energy || settings.record.links.peaks
    }

    fn choose(mech: &Mechanism, settings: &Settings) -> Plan {
        if settings.adaptive.is_some() && (Self::links_on_newton(settings) || mech.to_translating().is_err()) {
            // adaptive steps run on the constant stepper (its cache of factorizations) or on Newton
            let why = "adaptive steps (a tolerance instead of a step) on a model the constant stepper cannot run \
                       run on the Newton stepper";
            return Plan {
                kind: StepperKind::Newton,
                reason: why.into(),
                rate_reason: why.into(),
                translating: None,
                dofs: Self::number(mech, settings),
            };
        }
        let reason = if settings.record.links.energy {
            "the run records link energies".into()
        } else if settings.record.links.peaks {
            "the run tracks the links' peaks".into()
        } else if settings.coupling == crate::contact::Coupling::Continuous && !mech.joints.is_empty() {
            "the continuous-contact model (method=\"continuous\") runs on the Newton stepper".into()
        } else {
            match mech.to_translating() {
                Ok(model) => {
                    return Plan {
                        kind: StepperKind::Constant,
                        reason: String::new(),
                        rate_reason: String::new(),
                        translating: Some(model),
                        dofs: None,
                    }
                }
                Err(reason) => reason,
            }
        };
        let dofs = Self::number(mech, settings);
        match Self::rate_obstacle(mech, settings, dofs.as_ref()) {
            None => Plan {
                kind: StepperKind::ConstantRate,
                reason,
                rate_reason: String::new(),
                translating: None,
                dofs,
            },
            Some(rate_reason) => Plan {
                kind: StepperKind::Newton,
                reason,
                rate_reason,
                translating: None,
                dofs,
            },
        }
    }

    /// The numbering of the moving-frame unknowns of `mech` ([`dofs::number`]), once it passes
    /// [`Mechanism::validate`]; `None` where either fails (the Newton stepper reports the error
    /// when it prepares the run).
    fn number(mech: &Mechanism, settings: &Settings) -> Option<Numbered> {
        let apart = mech.validate_apart(settings.t_end).ok()?;
        let dofs = dofs::number(mech).ok()?;
        Some(Numbered { dofs, apart })
    }

    /// The numbering of the moving-frame unknowns ([`dofs::number`]) that the Newton and
    /// constant-rate steppers run on (`None` for the constant stepper, or a model that fails
    /// validation or numbering).
    pub fn dofs(&self) -> Option<&dofs::DofMap> {
        self.dofs.as_ref().map(|n| &n.dofs)
    }
}

/// Runs `mech` with `settings` on the stepper [`Plan::compile`] chooses, after the one
/// validation of the mechanism ([`Mechanism::validate`], which the Newton stepper makes itself); `control` as in
/// [`crate::run::simulate`]. The output has the Newton stepper's layout either way (link
/// histories in `record.links`), and `stats.stepper` says which ran.
pub fn simulate(
    mech: &Mechanism,
    settings: &Settings,
    control: &mut dyn FnMut(f64) -> bool,
) -> std::result::Result<RunOutput, Box<RunFailure>> {
    let plan = Plan::compile(mech, settings).map_err(RunFailure::before_start)?;
    simulate_planned(mech, settings, &plan, control)
}

/// [`simulate`] on `plan`, [`Plan::compile`] of these same `mech` and `settings` (a batch
/// compiles each sample's plan once, to group the samples, and runs it). Crate-private: the run
/// trusts the plan's validation of `mech` (another mechanism's plan would skip its checks).
pub(crate) fn simulate_planned(
    mech: &Mechanism,
    settings: &Settings,
    plan: &Plan,
    control: &mut dyn FnMut(f64) -> bool,
) -> std::result::Result<RunOutput, Box<RunFailure>> {
    let fail = RunFailure::before_start;
    let Some(model) = plan.translating.as_ref() else {
        // the Newton and constant-rate steppers run on the plan's numbering
        // (`simulate_mechanism`, `simulate_constant_rate` with it)
        let mut run = match &plan.dofs {
            Some(numbered) => numbered.run(mech, settings),
            None => NewtonRun::new(mech, settings),
        }
        .map_err(fail)?;
        if plan.kind == StepperKind::ConstantRate {
            run.use_constant_rate().map_err(fail)?;
        }
        return run.run(control);
    };
    mech.validate(settings.t_end).map_err(fail)?;
    let ch = settings.record.links;
    let link_channels = ch.displacements || ch.axial_force || ch.midspan;
    let mut s = settings.clone();
    s.record.nodes = if link_channels && settings.record.histories {
        model
            .links
            .iter()
            .enumerate()
            .flat_map(|(l, link)| (0..=link.section.elements).map(move |n| (l, n)))
            .collect()
    } else {
        // no link channel: the node histories asked for by the caller (the Python `Model`'s
        // `Record(nodes=...)`), as the translating run records them
        settings.record.nodes.clone()
    };
    let with_links = |mut out: RunOutput| {
        // the node histories the link channels are made from stay in the output (as the memory
        // estimate of the Python `Model` counts them)
        out.record.links = link_histories(model, &out, settings);
        out
    };
    match simulate_translating(model, &s, control) {
        Ok(out) => Ok(with_links(out)),
        Err(mut fail) => {
            if !matches!(fail.error, Error::InvalidParameter { .. } | Error::InvalidModel { .. }) {
                fail.output = with_links(std::mem::take(&mut fail.output));
            }
            Err(fail)
        }
    }
}

/// The link histories of a constant-stepper run in the Newton stepper's layout: with
/// displacements, the frame (origin x, y in m, fixed angle in rad, rate 0) at every recorded
/// time, and from the node histories
/// (one per node, link by link, as [`simulate`] asks for them) the nodal displacements, axial
/// forces `E A (u_{k+1} - u_k) / l` (N) and the midspan deflection relative to the chord (m),
/// as far as `settings.record.links` asks for them.
fn link_histories(model: &Model, out: &RunOutput, settings: &Settings) -> Vec<LinkHistory> {
    let ch = settings.record.links;
    let rec = &out.record;
    let mut first = 0;
    model
        .links
        .iter()
        .map(|l| {
            let nn = l.section.elements + 1;
            let mut h = LinkHistory::default();
            // the frame goes with the displacements (as the memory estimate counts it)
            for &t in rec.time.iter().filter(|_| ch.displacements) {
                let o = l.motion.at(t).pos;
                h.frame.push([o[0], o[1], l.angle, 0.0]);
            }
            let nodes = rec.nodes.get(first..first + nn).unwrap_or(&[]);
            first += nn;
            if nodes.len() < nn {
                return h;
            }
            let rows = nodes[0].u.len();
            let e = l.section().element(false);
            let ea_l = l.section.youngs_modulus * l.section.area / l.element_length();
            for r in 0..rows {
                if ch.displacements {
                    for n in nodes {
                        h.displacements.extend_from_slice(&[n.u[r], n.v[r], n.theta[r]]);
                    }
                }
                if ch.axial_force {
                    for k in 0..l.section.elements {
                        h.axial_force.push(ea_l * (nodes[k + 1].u[r] - nodes[k].u[r]));
                    }
                }
                if ch.midspan {
                    let xm = 0.5 * l.section.elements as f64;
                    let k = (xm.floor() as usize).min(l.section.elements - 1);
                    let xi = xm - k as f64;
                    let (a, b) = (&nodes[k], &nodes[k + 1]);
                    let q = crate::element::Vec6::new(a.u[r], a.v[r], a.theta[r], b.u[r], b.v[r], b.theta[r]);
                    let vm = e.transverse_at(xi, &q);
                    h.midspan.push(vm - 0.5 * (nodes[0].v[r] + nodes[nn - 1].v[r]));
                }
            }
            h
        })
        .collect()
}
