//! [`FlowStepper`]: one time step of the incompressible Navier-Stokes equations with variable
//! density and viscosity, in the order of (2.31)-(2.39):
//!
//! 1. advection `A(v^n)` (divergence form, kinetic-energy conserving), AB2 with `A(v^{n-1})`;
//! 2. predictor (2.35):
//!    `P v* = (rho/dt) v^n - rho (3/2 A^n - 1/2 A^{n-1}) - grad p^n + (1/2) V(v^n) + (1/2) div T^n + f`,
//!    with `P = rho/dt - (1/2) V` (Crank-Nicolson) plus any extra implicit term; solved by
//!    preconditioned BiCGStab (default) or the paper's SOR;
//! 3. projection (2.36)-(2.38);
//! 4. the stress increment (2.39): since `T^n = dt mu (grad g + grad g^T)` with
//!    `g = grad psi^n / rho`, and `v^n + dt g = v*` of the previous step,
//!    `(1/2) V(v^n) + (1/2) div T^n = (1/2) V(v*_prev)`: the stepper keeps the previous `v*`
//!    instead of `T` (the viscosity of the current step is used for both halves).
//!
//! A step that fails (no convergence, a non-finite value) returns an error and leaves the state
//! exactly as it was.

use super::forcing::Forcing;
use super::krylov::KrylovParams;
use super::momentum::{
    Coefficient, ImplicitTerm, KrylovMomentum, Materials, MomentumSolver, MomentumSystem, Predictor,
    ViscosityView, advection_at, edge_viscosity, face_density, is_wall_face, uniform_helmholtz, viscous_at,
};
use super::projection::{PressureSolver, Projection};
use super::sor::{SorMomentum, SorParams};
use crate::grid::ops::{gradient_at_face, par_interior, par_interior_update};
use crate::grid::{Field, Grid, VectorField};
use crate::io::checkpoint::{CheckpointReader, CheckpointWriter};
use crate::{Error, Real, Result};
use rayon::prelude::*;

/// The built-in solvers of the predictor (2.35): which [`MomentumSolver`] a [`FlowStepper`]
/// builds (a user's own is plugged in with [`FlowStepper::with_momentum_solver`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PredictorSolver {
    /// BiCGStab preconditioned by the FFT solve of the constant-coefficient Helmholtz operator
    /// (the default): [`KrylovMomentum`].
    Krylov(KrylovParams),
    /// The paper's SOR (reference): [`SorMomentum`].
    Sor(SorParams),
}

impl Default for PredictorSolver {
    fn default() -> Self {
        PredictorSolver::Krylov(KrylovParams::default())
    }
}

/// Settings of a [`FlowStepper`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowConfig {
    /// The time weighting of the viscous term. Default [`ViscousScheme::CrankNicolson`] (the
    /// paper's).
    pub viscous: ViscousScheme,
    /// Solver of the momentum predictor.
    pub predictor: PredictorSolver,
    /// Stopping rule of the variable-density pressure PCG of the default
    /// [`SpectralPcg`](super::projection::SpectralPcg) (unused when the density is uniform).
    pub poisson: KrylovParams,
    /// With two viscosities more than 1.5 apart, whether the Krylov predictor's preconditioner
    /// inverts with both and blends them face by face
    /// ([`HelmholtzPrecond::set_two`](super::momentum::HelmholtzPrecond::set_two); default
    /// `true`) instead of inverting with the larger one only. Measured (one core): BiCGStab
    /// iterations a step 9.8 -> 6.6 and step time -14 % for the two red cells at N = 64, 12.9 ->
    /// 7.8 and -28 % for a capsule of viscosity ratio 5 in shear at N = 32; where the membrane
    /// term rather than the viscosity limits the iterations it can cost up to 20 % (the
    /// `krylov_solve_mixture_membrane_two` bench in f32): turn it off there.
    pub two_viscosity_preconditioner: bool,
}

/// How the viscous term of the momentum predictor (2.35) is split between the time levels:
/// `theta V(v*) + (1 - theta) V(v*_prev)`.
///
/// The paper's Crank–Nicolson (`theta = 1/2`) is second order in time, but its amplification
/// factor `(1 - (1 - theta) s) / (1 + theta s)` tends to `-1` as the viscous number `s` of a mode
/// grows: at the capsule cases' viscous numbers (10-100 at the grid scale, `Re = 0.01`) the
/// highest modes are not damped, and a membrane force that excites them makes the run fail
/// (`docs/stability.md`). A `theta` above 1/2 damps them (the factor tends to
/// `-(1 - theta) / theta`: `-2/3` at 0.6, 0 at 1) at the price of a first-order error
/// `(theta - 1/2) dt` in the viscous term, which is negligible where the flow is nearly Stokes
/// (the shear capsule's `D` moves by 0.06 % at `theta` = 0.6).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ViscousScheme {
    /// `theta = 1/2`, the paper's (2.35): second order. The default of [`FlowConfig`].
    #[default]
    CrankNicolson,
    /// The theta-scheme with an implicit weight `theta` in `[1/2, 1]` (1: backward Euler,
    /// L-stable). The default of [`Settings`](crate::simulation::Settings) is `Theta(0.6)`.
    Theta(f64),
}

impl ViscousScheme {
    /// The implicit weight `theta`.
    pub fn implicit_weight(&self) -> f64 {
        match self {
            ViscousScheme::CrankNicolson => 0.5,
            ViscousScheme::Theta(t) => *t,
        }
    }

    /// `Ok` if the weight is in `[1/2, 1]`; else [`Error::InvalidParameter`] naming
    /// `FlowConfig::viscous`.
    pub fn validate(&self) -> Result<()> {
        let t = self.implicit_weight();
        if (0.5..=1.0).contains(&t) {
            Ok(())
        } else {
            Err(Error::invalid("FlowConfig::viscous", t, "an implicit weight theta in [1/2, 1]"))
        }
    }
}

impl Default for FlowConfig {
    fn default() -> Self {
        FlowConfig {
            viscous: ViscousScheme::default(),
            predictor: PredictorSolver::default(),
            poisson: KrylovParams::default(),
            two_viscosity_preconditioner: true,
        }
    }
}

/// What one step reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepInfo {
    /// Step number after the step.
    pub step: usize,
    /// Time after the step.
    pub time: f64,
    /// The step size.
    pub dt: f64,
    /// Iterations (BiCGStab) or sweeps (SOR) of the predictor.
    pub predictor_iterations: usize,
    /// Final relative residual (Krylov) or relative change (SOR) of the predictor.
    pub predictor_residual: f64,
    /// PCG iterations of the pressure equation (0 for the direct solve).
    pub poisson_iterations: usize,
    /// Advective CFL number `max |v_d| dt / h_d` of the new velocity.
    pub cfl: f64,
    /// Viscous number `max(mu / rho) dt / min h^2`.
    pub viscous_number: f64,
}

/// Time stepper of the incompressible flow; owns the velocity, the pressure and their history.
///
/// Its two linear solves are strategies: the predictor's [`MomentumSolver`] (built from
/// [`FlowConfig::predictor`], or [`with_momentum_solver`](Self::with_momentum_solver)) and the
/// pressure's [`PressureSolver`] (built from [`FlowConfig::poisson`], or
/// [`with_pressure_solver`](Self::with_pressure_solver)).
///
/// A two-phase step for custom drivers: [`prepare`](Self::prepare) computes `v^{n+1}` beside
/// the state, [`commit`](Self::commit) accepts it, [`discard`](Self::discard) forgets it.
///
/// ```
/// use eulermembrane::fluid::{forcing::BodyForce, stepper::FlowConfig, stepper::FlowStepper, momentum::Materials};
/// use eulermembrane::grid::{Boundary, Grid};
///
/// let mut bc = [[Boundary::Periodic; 2]; 3];
/// bc[1] = [Boundary::wall(), Boundary::wall()];
/// let grid = Grid::<f64>::new([4, 16, 4], [0.0; 3], [0.25, 1.0, 0.25], bc)?;
/// let mut flow = FlowStepper::new(&grid, Materials::uniform(1.0, 1.0)?, FlowConfig::default())?;
/// let drive = BodyForce::new([1.0, 0.0, 0.0])?;
/// // Propose a step, look at it, take it.
/// let info = flow.prepare(0.01, &drive, None)?;
/// assert!(info.cfl < 1.0 && flow.time() == 0.0);
/// flow.commit()?;
/// assert_eq!(flow.steps(), 1);
/// assert!(flow.commit().is_err()); // a step is committed once
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub struct FlowStepper<T: Real> {
    grid: Grid<T>,
    /// The implicit weight `theta` of the viscous term ([`FlowConfig::viscous`]).
    theta: T,
    materials: Materials<T>,
    v: VectorField<T>,
    p: Field<T>,
    time: T,
    step: usize,
    adv_prev: VectorField<T>,
    vstar_prev: VectorField<T>,
    has_history: bool,
    moving_walls: bool,
    /// `dt` of the step computed by [`prepare`](FlowStepper::prepare) and not yet committed.
    prepared: Option<T>,
    ws: Workspace<T>,
}

struct Workspace<T: Real> {
    adv: VectorField<T>,
    rhs: VectorField<T>,
    vstar: VectorField<T>,
    /// `v^{n+1}`; before the projection writes it, the explicit force of the step, then the
    /// moving walls' lift.
    v_new: VectorField<T>,
    psi: Field<T>,
    edge_mu: Option<[Field<T>; 3]>,
    momentum: Box<dyn MomentumSolver<T>>,
    projection: Projection<T>,
}

impl<T: Real> FlowStepper<T> {
    /// A stepper on `grid`, at rest, with the given materials. `grid` may be a part of a
    /// decomposed grid ([`Grid::split`]): every part then makes the same calls, and the step
    /// is the whole grid's to round-off (docs/architecture.md, "Domain decomposition").
    ///
    /// Errors: non-positive or non-finite materials, invalid solver settings, a grid the direct
    /// solvers cannot handle (more than one wall axis; on a part, no second periodic axis), the
    /// SOR predictor on a part.
    pub fn new(grid: &Grid<T>, materials: Materials<T>, config: FlowConfig) -> Result<Self> {
        if grid.is_split() && matches!(config.predictor, PredictorSolver::Sor(_)) {
            return Err(Error::Unsupported {
                component: "FlowStepper",
                detail: "SOR on a part of a decomposed grid (its sweeps are sequential): use \
                         PredictorSolver::Krylov"
                    .into(),
            });
        }
        materials.rho.validate(grid, "rho")?;
        materials.mu.validate(grid, "mu")?;
        config.viscous.validate()?;
        let momentum: Box<dyn MomentumSolver<T>> = match config.predictor {
            PredictorSolver::Sor(s) => Box::new(SorMomentum::new(s)?),
            PredictorSolver::Krylov(k) => {
                Box::new(KrylovMomentum::new(grid, k, config.two_viscosity_preconditioner)?)
            }
        };
        let projection = Projection::new(grid, config.poisson)?;
        let moving_walls =
            (0..3).any(|d| grid.bc(d).iter().any(|b| b.velocity().iter().any(|&x| x != T::zero())));
        let z = || VectorField::zeros(grid);
        let mut s = FlowStepper {
            grid: grid.clone(),
            theta: T::lit(config.viscous.implicit_weight()),
            materials,
            v: z(),
            p: Field::zeros(grid),
            time: T::zero(),
            step: 0,
            adv_prev: z(),
            vstar_prev: z(),
            has_history: false,
            moving_walls,
            prepared: None,
            ws: Workspace {
                adv: z(),
                rhs: z(),
                vstar: z(),
                v_new: z(),
                psi: Field::zeros(grid),
                edge_mu: None,
                momentum,
                projection,
            },
        };
        s.v.fill_ghosts(grid);
        Ok(s)
    }

    /// Replaces the solver of the predictor (2.35) (the one [`FlowConfig::predictor`] chose).
    pub fn with_momentum_solver(mut self, solver: Box<dyn MomentumSolver<T>>) -> Self {
        self.ws.momentum = solver;
        self
    }

    /// Replaces the solver of the pressure equation (2.36) (the default
    /// [`SpectralPcg`](super::projection::SpectralPcg)).
    pub fn with_pressure_solver(mut self, solver: Box<dyn PressureSolver<T>>) -> Self {
        self.ws.projection = Projection::with_solver(&self.grid, solver);
        self
    }

    /// The solver of the predictor (2.35).
    pub fn momentum_solver(&self) -> &dyn MomentumSolver<T> {
        self.ws.momentum.as_ref()
    }

    /// The solver of the pressure equation (2.36).
    pub fn pressure_solver(&self) -> &dyn PressureSolver<T> {
        self.ws.projection.solver()
    }

    /// The grid.
    pub fn grid(&self) -> &Grid<T> {
        &self.grid
    }
    /// The velocity `v^n` (ghosts filled).
    pub fn velocity(&self) -> &VectorField<T> {
        &self.v
    }
    /// The pressure `p^n`.
    pub fn pressure(&self) -> &Field<T> {
        &self.p
    }
    /// Time `t^n`.
    pub fn time(&self) -> T {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.step
    }
    /// The materials used by the next step.
    pub fn materials(&self) -> &Materials<T> {
        &self.materials
    }

    /// Replaces the materials used by the next steps (e.g. the mixture (2.25) of a new `phi`).
    /// Errors: a non-positive or non-finite value (the stepper keeps its materials).
    pub fn set_materials(&mut self, mut materials: Materials<T>) -> Result<()> {
        self.prepared = None;
        materials.rho.validate(&self.grid, "rho")?;
        materials.mu.validate(&self.grid, "mu")?;
        materials.rho.fill_ghosts(&self.grid);
        materials.mu.fill_ghosts(&self.grid);
        self.materials = materials;
        Ok(())
    }

    /// Sets the velocity from `f(x)` sampled at the faces, and clears the time history (the next
    /// step starts with forward Euler for advection). Errors: a non-finite value.
    pub fn set_velocity(&mut self, f: impl Fn([T; 3]) -> [T; 3]) -> Result<()> {
        self.prepared = None;
        let mut v = VectorField::from_fn(&self.grid, f);
        v.fill_ghosts(&self.grid);
        if let Some((c, cell)) = v.first_non_finite(&self.grid) {
            return Err(Error::NonFinite { field: ["velocity.u", "velocity.v", "velocity.w"][c], cell });
        }
        self.v = v;
        self.vstar_prev.copy_from(&self.v);
        self.has_history = false;
        Ok(())
    }

    /// Sets the pressure from `f(x)` at cell centres (e.g. an exact initial pressure). Errors: a
    /// non-finite value.
    pub fn set_pressure(&mut self, f: impl Fn([T; 3]) -> T) -> Result<()> {
        self.prepared = None;
        let mut p = Field::from_cell_fn(&self.grid, f);
        if let Some(cell) = p.first_non_finite(&self.grid) {
            return Err(Error::NonFinite { field: "pressure", cell });
        }
        p.fill_ghosts(&self.grid);
        self.p = p;
        Ok(())
    }

    /// Adds the whole flow state (velocity, pressure, time history, materials, time, step
    /// count) to a checkpoint, with names prefixed by `prefix`.
    pub fn checkpoint(&self, w: &mut CheckpointWriter, prefix: &str) {
        let n = self.grid.n();
        w.number(&format!("{prefix}nx"), n[0] as f64)
            .number(&format!("{prefix}ny"), n[1] as f64)
            .number(&format!("{prefix}nz"), n[2] as f64)
            .number(&format!("{prefix}time"), self.time.f64())
            .number(&format!("{prefix}step"), self.step as f64)
            .number(&format!("{prefix}has_history"), if self.has_history { 1.0 } else { 0.0 });
        for d in 0..3 {
            w.array(&format!("{prefix}v{d}"), &self.v.c[d].data)
                .array(&format!("{prefix}adv_prev{d}"), &self.adv_prev.c[d].data)
                .array(&format!("{prefix}vstar_prev{d}"), &self.vstar_prev.c[d].data);
        }
        w.array(&format!("{prefix}p"), &self.p.data);
        for (name, c) in [("rho", &self.materials.rho), ("mu", &self.materials.mu)] {
            match c {
                Coefficient::Uniform(x) => w.number(&format!("{prefix}{name}_uniform"), x.f64()),
                Coefficient::Field(f) => w.array(&format!("{prefix}{name}_field"), &f.data),
            };
        }
    }

    /// Restores the state written by [`FlowStepper::checkpoint`] with the same `prefix`. The
    /// state is replaced only if everything could be read. Errors: a checkpoint of another
    /// grid, a missing entry.
    pub fn restore(&mut self, r: &CheckpointReader, prefix: &str) -> Result<()> {
        self.prepared = None;
        let g = &self.grid;
        let n = g.n();
        for (d, axis) in ["nx", "ny", "nz"].iter().enumerate() {
            let m = r.number(&format!("{prefix}{axis}"))?;
            if m != n[d] as f64 {
                return Err(Error::invalid(
                    "checkpoint grid",
                    format!("{axis} = {m}"),
                    "the cell counts of this stepper's grid",
                ));
            }
        }
        let len = g.len();
        let field = |name: String| -> Result<Field<T>> { Ok(Field { data: r.array(&name, len)? }) };
        let vector = |name: &str| -> Result<VectorField<T>> {
            Ok(VectorField {
                c: [
                    field(format!("{prefix}{name}0"))?,
                    field(format!("{prefix}{name}1"))?,
                    field(format!("{prefix}{name}2"))?,
                ],
            })
        };
        let coefficient = |name: &str| -> Result<Coefficient<T>> {
            let uniform = format!("{prefix}{name}_uniform");
            if r.has(&uniform) {
                Ok(Coefficient::Uniform(T::lit(r.number(&uniform)?)))
            } else {
                Ok(Coefficient::Field(field(format!("{prefix}{name}_field"))?))
            }
        };
        let (v, adv_prev, vstar_prev) = (vector("v")?, vector("adv_prev")?, vector("vstar_prev")?);
        let p = field(format!("{prefix}p"))?;
        let materials = Materials { rho: coefficient("rho")?, mu: coefficient("mu")? };
        let time = T::lit(r.number(&format!("{prefix}time"))?);
        let step = r.number(&format!("{prefix}step"))? as usize;
        let has_history = r.number(&format!("{prefix}has_history"))? != 0.0;
        self.set_materials(materials)?;
        self.v = v;
        self.adv_prev = adv_prev;
        self.vstar_prev = vstar_prev;
        self.p = p;
        self.time = time;
        self.step = step;
        self.has_history = has_history;
        Ok(())
    }

    /// Advances one step of size `dt` with the explicit forcing `forcing` and an optional extra
    /// implicit term of the predictor: [`prepare`](Self::prepare) and [`commit`](Self::commit).
    pub fn step(
        &mut self,
        dt: T,
        forcing: &impl Forcing<T>,
        extra: Option<&dyn ImplicitTerm<T>>,
    ) -> Result<StepInfo> {
        let info = self.prepare(dt, forcing, extra)?;
        self.commit_prepared(dt);
        Ok(info)
    }

    /// The new velocity `v^{n+1}` computed by [`prepare`](Self::prepare), not yet committed
    /// (`None` when no step is prepared).
    pub fn proposed_velocity(&self) -> Option<&VectorField<T>> {
        self.prepared.map(|_| &self.ws.v_new)
    }

    /// The proposed velocity of the prepared step, for a driver that prepared one.
    pub(crate) fn prepared_velocity(&self) -> &VectorField<T> {
        &self.ws.v_new
    }

    /// The materials, for in-place updates by a driver that owns the mixture (ghosts are filled
    /// at the next step).
    pub(crate) fn materials_mut(&mut self) -> &mut Materials<T> {
        &mut self.materials
    }

    /// Computes the step into the workspace without touching the state (the first phase of
    /// [`step`](Self::step), for drivers that must see the new velocity before they accept it,
    /// e.g. to advance a membrane with `v^n` and `v^{n+1}`): [`commit`](Self::commit) makes it
    /// the new state; another `prepare`, or [`discard`](Self::discard), forgets it. The returned
    /// information is that of the step once committed.
    ///
    /// # Errors
    /// `dt` not finite and `> 0`; a forcing or implicit term that fails; a solver that does not
    /// converge; a non-finite force or velocity. The state is then as before the call and no
    /// step is prepared.
    pub fn prepare(
        &mut self,
        dt: T,
        forcing: &impl Forcing<T>,
        extra: Option<&dyn ImplicitTerm<T>>,
    ) -> Result<StepInfo> {
        self.prepared = None;
        crate::error::positive("dt", dt)?;
        let g = &self.grid;
        let inv_dt = T::one() / dt;
        self.materials.rho.fill_ghosts(g);
        self.materials.mu.fill_ghosts(g);
        self.v.fill_ghosts(g);
        self.p.fill_ghosts(g);
        self.vstar_prev.fill_ghosts(g);
        let ws = &mut self.ws;
        if let Coefficient::Field(mu) = &self.materials.mu {
            let e = ws.edge_mu.get_or_insert_with(|| std::array::from_fn(|_| Field::zeros(g)));
            edge_viscosity(g, mu, e);
        }
        let mu = ViscosityView::new(
            g,
            &self.materials.mu,
            if self.materials.mu.is_uniform() { None } else { ws.edge_mu.as_ref() },
        );
        let rho = &self.materials.rho;

        // 1. Advection A(v^n); AB2 weights (forward Euler on the first step).
        for c in 0..3 {
            par_interior(g, &mut ws.adv.c[c].data, |idx, _, _, _| advection_at(g, &self.v, c, idx));
        }
        let (a1, a0) = if self.has_history { (T::lit(1.5), T::lit(-0.5)) } else { (T::one(), T::zero()) };

        // 2. Explicit forces.
        let forced = forcing.is_active();
        if forced {
            // The force takes `v_new`'s storage: free until the lift below.
            for c in 0..3 {
                ws.v_new.c[c].fill(T::zero());
            }
            forcing.add(g, self.time, &self.v, &mut ws.v_new)?;
            if let Some((c, cell)) = ws.v_new.first_non_finite(g) {
                return Err(Error::NonFinite { field: ["force.u", "force.v", "force.w"][c], cell });
            }
        }

        // 3. Right-hand side of (2.35); the explicit viscous half first (fast path when mu is
        // uniform), then the other terms added in place.
        // The explicit weight `1 - theta` of the viscous term (1/2 for Crank-Nicolson).
        let half = T::one() - self.theta;
        let uniform_mu = match &self.materials.mu {
            Coefficient::Uniform(m) => Some(*m),
            Coefficient::Field(_) => None,
        };
        if let Some(m) = uniform_mu {
            uniform_helmholtz(g, &self.vstar_prev, T::zero(), half * m, &mut ws.rhs);
        }
        for c in 0..3 {
            let (adv, advp, force) = (&ws.adv.c[c].data, &self.adv_prev.c[c].data, &ws.v_new.c[c].data);
            let (v, p, vsp) = (&self.v, &self.p, &self.vstar_prev);
            par_interior_update(g, &mut ws.rhs.c[c].data, |idx, i, j, k, visc| {
                if is_wall_face(g, c, [i, j, k]) {
                    return T::zero();
                }
                let rf = face_density(g, rho, c, idx);
                let visc = if uniform_mu.is_some() { visc } else { half * viscous_at(g, &mu, vsp, c, idx) };
                let mut b = rf * inv_dt * v.c[c].data[idx]
                    - rf * (a1 * adv[idx] + a0 * advp[idx])
                    - gradient_at_face(g, p, c, idx)
                    + visc;
                if forced {
                    b += force[idx];
                }
                b
            });
        }
        let theta = self.theta;
        let op = Predictor { grid: g, inv_dt, theta, rho, mu, extra };
        if self.moving_walls {
            // Lift: the operator applied to a field that is zero inside with the wall velocity in
            // its ghosts moves to the right-hand side, so the solve is homogeneous.
            let lift = &mut ws.v_new;
            for c in 0..3 {
                lift.c[c].fill(T::zero());
            }
            lift.fill_ghosts(g);
            op.apply_raw(lift, &mut ws.vstar)?;
            for c in 0..3 {
                let l = &ws.vstar.c[c].data;
                par_interior_update(g, &mut ws.rhs.c[c].data, |idx, _, _, _, b| b - l[idx]);
            }
        }

        // 4. Solve the predictor from v^n.
        ws.vstar.copy_from(&self.v);
        // Extremes of the materials: the preconditioner's reference values and the viscous number.
        let (rho_lo, (mu_lo, mu_hi)) = (rho.range(g).0, self.materials.mu.range(g));
        let system = MomentumSystem {
            grid: g,
            operator: &op,
            materials: &self.materials,
            inv_dt,
            rho_min: rho_lo,
            mu_range: (mu_lo, mu_hi),
            theta,
        };
        let minfo = ws.momentum.solve(&system, &ws.rhs, &mut ws.vstar)?;
        ws.vstar.fill_ghosts(g);

        // 5. Projection (2.36)-(2.37).
        let pinfo = ws.projection.project(g, rho, dt, &ws.vstar, &mut ws.psi, &mut ws.v_new)?;
        ws.v_new.fill_ghosts(g);
        if let Some((c, cell)) = ws.v_new.first_non_finite(g) {
            return Err(Error::NonFinite { field: ["velocity.u", "velocity.v", "velocity.w"][c], cell });
        }

        // Nothing above touched the state.
        self.prepared = Some(dt);
        Ok(StepInfo {
            step: self.step + 1,
            time: (self.time + dt).f64(),
            dt: dt.f64(),
            predictor_iterations: minfo.iterations,
            predictor_residual: minfo.residual,
            poisson_iterations: pinfo.iterations,
            cfl: cfl_of(g, &ws.v_new, dt),
            viscous_number: viscous_number(g, rho_lo, mu_hi, dt),
        })
    }

    /// Makes the step computed by the last successful [`prepare`](Self::prepare) the new state.
    ///
    /// # Errors
    /// [`Error::Unsupported`] when no step is prepared (none yet, or it was committed or
    /// discarded); the state is unchanged.
    pub fn commit(&mut self) -> Result<()> {
        let Some(dt) = self.prepared else {
            return Err(Error::Unsupported {
                component: "FlowStepper::commit",
                detail: "no prepared step: call prepare first (a step is committed once)".into(),
            });
        };
        self.commit_prepared(dt);
        Ok(())
    }

    /// Forgets a prepared step (nothing happens when none is prepared).
    pub fn discard(&mut self) {
        self.prepared = None;
    }

    /// The body of [`commit`](Self::commit) for the step prepared with `dt`.
    fn commit_prepared(&mut self, dt: T) {
        self.prepared = None;
        let g = &self.grid;
        let ws = &mut self.ws;
        std::mem::swap(&mut self.v, &mut ws.v_new);
        let psi = &ws.psi.data;
        par_interior_update(g, &mut self.p.data, |idx, _, _, _, p| p + psi[idx]);
        std::mem::swap(&mut self.adv_prev, &mut ws.adv);
        std::mem::swap(&mut self.vstar_prev, &mut ws.vstar);
        // Ghosts now, so that a later prepare (even a failing one) leaves the state unchanged.
        self.p.fill_ghosts(g);
        self.vstar_prev.fill_ghosts(g);
        self.has_history = true;
        self.time += dt;
        self.step += 1;
    }

    /// `max_d max |v_d| dt / h_d` over interior faces.
    pub fn cfl(&self, dt: T) -> f64 {
        cfl_of(&self.grid, &self.v, dt)
    }

    /// `max(mu / rho) dt / min(h)^2`.
    pub fn viscous_number(&self, dt: T) -> f64 {
        let g = &self.grid;
        viscous_number(g, self.materials.rho.range(g).0, self.materials.mu.range(g).1, dt)
    }
}

/// `max_d max |v_d| dt / h_d` over the interior faces of `v`.
fn cfl_of<T: Real>(g: &Grid<T>, v: &VectorField<T>, dt: T) -> f64 {
    let h = g.h();
    (0..3)
        .map(|d| {
            let vmax = v.c[d]
                .data
                .par_chunks(g.dims()[0])
                .with_min_len(crate::grid::ops::min_rows(g.dims()[0]))
                .enumerate()
                .filter(|(row, _)| g.row_jk(*row).is_some())
                .map(|(_, line)| line.iter().fold(T::zero(), |m, &x| m.max(x.abs())))
                .reduce(T::zero, |a, b| a.max(b));
            let [vmax] = g.max_over_parts([vmax]);
            (vmax * dt / h[d]).f64()
        })
        .fold(0.0, f64::max)
}

/// `mu_hi / rho_lo * dt / min(h)^2`.
fn viscous_number<T: Real>(g: &Grid<T>, rho_lo: T, mu_hi: T, dt: T) -> f64 {
    let h = g.h();
    let hmin = h[0].min(h[1]).min(h[2]);
    (mu_hi / rho_lo * dt / (hmin * hmin)).f64()
}
