//! The hard cases of the stability suite, shared by the `stability` example and
//! `tests/stability.rs`: a capsule of radius `a = 1` in the shear flow of Sec. 3.3 (`rho = 1`,
//! `mu = 100`, shear rate 1, `E_s = mu a / Ca`), on a smaller box than the paper's so that the
//! cases run at small N.

use eulermembrane::Error;
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{
    Bending, BendingCoupling, Elasticity, MembraneCoupling, Phase, Scene, Simulation, Traction,
};

/// Outer density and viscosity (Re = rho a^2 / mu = 0.01, as in Sec. 3.3).
pub const RHO: f64 = 1.0;
/// Outer viscosity.
pub const MU: f64 = 100.0;

/// How the membrane forces of a run enter the flow: the in-plane stress's coupling and traction,
/// and the bending force's coupling (the rest of the settings are the defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// The in-plane stress ([`Elasticity::coupling`]).
    pub membrane: MembraneCoupling,
    /// The bending force ([`Bending::coupling`]).
    pub bending: BendingCoupling,
    /// How the in-plane stress reaches the fluid ([`Elasticity::traction`]).
    pub traction: Traction,
}

impl From<MembraneCoupling> for Coupling {
    /// The in-plane coupling `membrane` with the default bending coupling and the paper's
    /// smoothed traction (the limits of docs/stability.md's tables are measured on it).
    fn from(membrane: MembraneCoupling) -> Self {
        Coupling { membrane, bending: BendingCoupling::default(), traction: Traction::Smoothed }
    }
}

/// One scene of the suite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Case {
    /// Snake-case name for tables and RESULT lines.
    pub name: &'static str,
    /// Capillary number `mu a / E_s` (shear rate 1, `a = 1`).
    pub ca: f64,
    /// Reduced bending modulus `E_b / (a^2 E_s)` (0: no bending).
    pub eb_reduced: f64,
    /// Viscosity ratio `mu_in / mu_out`.
    pub lambda: f64,
    /// Outer viscosity.
    pub mu: f64,
    /// Shear rate (wall speed over half the box height).
    pub shear: f64,
    /// Geometry.
    pub layout: Layout,
}

/// Where the capsules sit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// One capsule at the centre of a `4 x 3 x 5` box (walls at `z = +-2.5`).
    Centre,
    /// One capsule between two walls, its surface one radius from each (`4 x 3 x 4` box, walls
    /// at `z = +-2`), on a grid 1.5 times finer (at `h = 1/4` the band would touch the walls).
    NearWall,
    /// Two capsules on streamlines one radius apart (`6 x 3 x 6` box) that collide and slide
    /// past each other.
    Pair,
}

impl Case {
    /// A centred capsule at capillary number `ca`, no bending, equal viscosities.
    pub const fn shear(name: &'static str, ca: f64) -> Case {
        Case { name, ca, eb_reduced: 0.0, lambda: 1.0, mu: MU, shear: 1.0, layout: Layout::Centre }
    }
    /// The membrane modulus `E_s = mu G a / Ca` (`G` the shear rate).
    pub fn e_s(&self) -> f64 {
        self.mu * self.shear / self.ca
    }
    /// The bending modulus `E_b = E_b' a^2 E_s`.
    pub fn e_b(&self) -> f64 {
        self.eb_reduced * self.e_s()
    }
}

/// The cases of the suite (issue 7, item 3).
pub fn cases() -> Vec<Case> {
    let base = Case::shear("stiff", 0.0125);
    vec![
        base,
        Case::shear("large_deformation", 0.2),
        Case { name: "strong_bending", ca: 0.05, eb_reduced: 0.0375, ..base },
        Case { name: "viscosity_ratio_5", ca: 0.05, lambda: 5.0, ..base },
        Case { name: "viscosity_ratio_0.2", ca: 0.05, lambda: 0.2, ..base },
        Case { name: "near_wall", ca: 0.05, layout: Layout::NearWall, ..base },
        Case { name: "two_capsules", ca: 0.05, layout: Layout::Pair, ..base },
    ]
}

/// Builds `case` with `n` cells along x of the 4-wide box (`h = 4 / n`; the pair box is 6 wide,
/// `1.5 n` cells; the near-wall case uses `h = 4 / (1.5 n)`), with the given membrane coupling,
/// in the linear shear flow `u = G z`.
pub fn build(case: &Case, n: usize, coupling: impl Into<Coupling>) -> eulermembrane::Result<Simulation<f64>> {
    let coupling = coupling.into();
    let (h, (lx, ly, lz)) = match case.layout {
        Layout::Centre => (4.0 / n as f64, (4.0, 3.0, 5.0)),
        Layout::NearWall => (4.0 / (1.5 * n as f64), (4.0, 3.0, 4.0)),
        Layout::Pair => (4.0 / n as f64, (6.0, 3.0, 6.0)),
    };
    let cells = |l: f64| (l / h).round() as usize;
    let half = [lx / 2.0, ly / 2.0, lz / 2.0];
    let mut bc = [[Boundary::Periodic; 2]; 3];
    let u = case.shear * half[2];
    bc[2] = [Boundary::Wall { velocity: [-u, 0.0, 0.0] }, Boundary::Wall { velocity: [u, 0.0, 0.0] }];
    let grid = Grid::new([cells(lx), cells(ly), cells(lz)], half.map(|x| -x), half, bc)?;
    let mut scene =
        Scene::new(grid, Phase::new(RHO, case.mu)?).inside(Phase::new(RHO, case.mu * case.lambda)?).effect(
            Elasticity::new(NeoHookean::new(case.e_s())?)
                .traction(coupling.traction)
                .coupling(coupling.membrane),
        );
    scene = match case.layout {
        Layout::Centre => scene.capsule(Sphere::new([0.0; 3], 1.0)?),
        Layout::NearWall => scene.capsule(Sphere::new([0.0; 3], 1.0)?),
        Layout::Pair => {
            scene.capsule(Sphere::new([-1.4, 0.0, 0.5], 1.0)?).capsule(Sphere::new([1.4, 0.0, -0.5], 1.0)?)
        }
    };
    if case.eb_reduced > 0.0 {
        scene = scene.effect(Bending::new(case.e_b())?.coupling(coupling.bending));
    }
    let mut sim = scene.build()?;
    sim.set_velocity(|x| [case.shear * x[2], 0.0, 0.0])?;
    Ok(sim)
}

/// What a run of a case measured.
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    /// Steps completed.
    pub steps: usize,
    /// Why the run stopped early (`None`: it completed): a snake-case kind (`no_convergence`,
    /// `band_at_wall`, `non_finite`, `blow_up`, `error`) and the message.
    pub failure: Option<(&'static str, String)>,
    /// Largest relative volume change of any capsule.
    pub volume_drift: f64,
    /// Relative change of the total surface area (`sum delta h^3`) at the end.
    pub area_drift: f64,
    /// Largest relative surface-area change during the run.
    pub max_area_drift: f64,
    /// Largest elastic energy over `E_s a^2` during the run.
    pub max_elastic: f64,
    /// Largest kinetic energy over its initial value.
    pub max_kinetic_ratio: f64,
    /// Largest advective CFL number.
    pub max_cfl: f64,
    /// Whether every diagnostic stayed finite.
    pub finite: bool,
}

impl Outcome {
    /// Completed, finite and bounded.
    pub fn stable(&self) -> bool {
        self.failure.is_none()
    }
}

/// Runs `steps` steps of `dt`, recording the diagnostics every `every` steps (and at the end).
/// A run fails on a step error, a non-finite diagnostic, a kinetic energy above 100 times the
/// initial one (the shear flow's energy is set by the walls) or an elastic energy above
/// `100 E_s a^2` (at Ca = 0.2 the steady capsule holds about `0.1 E_s a^2`).
pub fn run(sim: &mut Simulation<f64>, case: &Case, dt: f64, steps: usize, every: usize) -> Outcome {
    let caps = sim.capsule_count();
    let vol0: Vec<f64> = (0..caps).map(|c| sim.volume(c).unwrap()).collect();
    let area = |sim: &Simulation<f64>| (0..caps).map(|c| sim.area(c).unwrap()).sum::<f64>();
    let a0 = area(sim);
    let k0 = sim.energy().map(|e| e.kinetic).unwrap_or(f64::NAN);
    let mut out = Outcome { finite: true, ..Outcome::default() };
    for s in 1..=steps {
        match sim.step(dt) {
            Ok(r) => out.max_cfl = out.max_cfl.max(r.flow.cfl),
            Err(e) => {
                let kind = match &e {
                    Error::NoConvergence { .. } => "no_convergence",
                    Error::NonFinite { .. } => "non_finite",
                    Error::Unsupported { component: "Band", .. } => "band_at_wall",
                    _ => "error",
                };
                out.finite = !matches!(e, Error::NonFinite { .. });
                out.failure = Some((kind, format!("step {s}: {e}")));
                return out;
            }
        }
        out.steps = s;
        if s % every != 0 && s != steps {
            continue;
        }
        let e = match sim.energy() {
            Ok(e) => e,
            Err(e) => {
                out.failure = Some(("non_finite", format!("step {s}: energy: {e}")));
                out.finite = false;
                return out;
            }
        };
        let a = area(sim);
        for (c, v0) in vol0.iter().enumerate() {
            let v = sim.volume(c).unwrap_or(f64::NAN);
            out.volume_drift = out.volume_drift.max(((v - v0) / v0).abs());
        }
        out.area_drift = (a - a0) / a0;
        out.max_area_drift = out.max_area_drift.max(out.area_drift.abs());
        out.max_elastic = out.max_elastic.max(e.elastic / case.e_s());
        out.max_kinetic_ratio = out.max_kinetic_ratio.max(e.kinetic / k0);
        let values = [e.kinetic, e.elastic, e.dissipation_rate, a, out.volume_drift];
        if values.iter().any(|x| !x.is_finite()) {
            out.finite = false;
            out.failure = Some(("non_finite", format!("step {s}: non-finite diagnostic {values:?}")));
            return out;
        }
        if out.max_kinetic_ratio > 100.0 || out.max_elastic > 100.0 {
            let msg = format!(
                "step {s}: blow-up (kinetic x{:.1}, area drift {:.2}, elastic {:.2} E_s a^2)",
                out.max_kinetic_ratio, out.max_area_drift, out.max_elastic
            );
            out.failure = Some(("blow_up", msg));
            return out;
        }
    }
    out
}

/// How [`largest_stable_dt`] searches: runs of `max(t_end / dt, min_steps)` steps, bisection in
/// `log dt` between `lo` and `hi` for `iters` halvings of `log(hi / lo)`.
#[derive(Debug, Clone, Copy)]
pub struct Search {
    /// Simulated time of each run.
    pub t_end: f64,
    /// Fewest steps of a run (an instability needs steps to grow).
    pub min_steps: usize,
    /// Lower end of the bracket (expected stable).
    pub lo: f64,
    /// Upper end (expected unstable).
    pub hi: f64,
    /// Bisections.
    pub iters: usize,
}

/// The result of [`largest_stable_dt`].
#[derive(Debug, Clone)]
pub struct Bracket {
    /// Largest `dt` found stable (0 if even `lo` failed).
    pub stable: f64,
    /// Smallest `dt` found unstable (infinite if even `hi` was stable).
    pub unstable: f64,
    /// How the run at `unstable` failed (kind, message).
    pub why: (&'static str, String),
    /// The run at `stable`.
    pub at_stable: Outcome,
}

/// The largest stable `dt` of `case` at `n` cells with `coupling` (see [`Search`]).
pub fn largest_stable_dt(case: &Case, n: usize, coupling: impl Into<Coupling>, search: Search) -> Bracket {
    let coupling = coupling.into();
    let attempt = |dt: f64| {
        let steps = ((search.t_end / dt).ceil() as usize).max(search.min_steps);
        let mut sim = build(case, n, coupling).expect("scene");
        run(&mut sim, case, dt, steps, 5)
    };
    let mut b = Bracket {
        stable: 0.0,
        unstable: f64::INFINITY,
        why: ("none", String::new()),
        at_stable: Outcome::default(),
    };
    let (mut lo, mut hi) = (search.lo, search.hi);
    let first = attempt(lo);
    match first.failure.clone() {
        Some(why) => {
            b.unstable = lo;
            b.why = why;
            return b;
        }
        None => (b.stable, b.at_stable) = (lo, first),
    }
    let top = attempt(hi);
    match top.failure.clone() {
        None => {
            (b.stable, b.at_stable) = (hi, top);
            return b;
        }
        Some(why) => (b.unstable, b.why) = (hi, why),
    }
    for _ in 0..search.iters {
        let mid = (lo * hi).sqrt();
        let o = attempt(mid);
        match o.failure.clone() {
            None => {
                lo = mid;
                (b.stable, b.at_stable) = (mid, o);
            }
            Some(why) => {
                hi = mid;
                (b.unstable, b.why) = (mid, why);
            }
        }
    }
    b
}
