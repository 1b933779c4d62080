//! The coupled capsule solver of Sec. 2.2.2: a [`Scene`] describes the box, the fluids, the
//! capsules and the effects; [`Scene::build`] makes a [`Simulation`] that owns the state and
//! advances it by the paper's time step.
//!
//! # The time step (2.29)–(2.40)
//!
//! For each capsule (each has its own `phi`, so capsules never merge):
//! 1. `phi` and `kappa_R tilde` advected with `v^n` by MTHINC and the convolved curvature
//!    equation (2.29)–(2.30);
//! 2. from `phi^{n+1}`: the normals `n^{n+1}`, `delta^{n+1} = |grad phi^{n+1}|` (2.26) and the
//!    membrane band `delta h >= epsilon`;
//! 3. the stress `tau(G_s^n, n^{n+1})` and its Jacobian (2.32)–(2.34), and the bending force
//!    `div(q~ n)` (2.16)–(2.17) from `n^{n+1}`, `delta^{n+1}`, `kappa_R tilde^{n+1}`.
//!
//! Then, for the fluid:
//! 4. the mixture (2.25) of the two phases with `phi^{n+1}` (summed over the capsules);
//! 5. the predictor (2.35) with the in-plane force split into the explicit part at `v^n` and
//!    the quasi-implicit part `-(dt/4) div(delta H(v*, G_s^n, J^n))` inside the Krylov (or SOR)
//!    solve, plus bending, body and surface forces; the projection (2.36)–(2.38);
//! 6. `G_s^{n+1}` by (2.40) with `v^n`, `v^{n+1}` and the re-set to `P^{n+1}` off the band.
//!
//! Every part is computed beside the state and committed at the end: a step that fails
//! (non-convergence, a non-finite value, a capsule reaching a wall) returns the error and leaves
//! the simulation exactly as it was.
//!
//! # What is computed
//!
//! Only what the scene holds: no elasticity, no `G_s`; no bending, no `kappa_R tilde` field and
//! no curvature tensor; equal viscosities, the constant-coefficient viscous operator and its
//! FFT preconditioner; equal densities, the direct FFT pressure solve; no body or surface force,
//! no forcing pass. Membrane work is restricted to the band of each capsule.
//!
//! # Example
//!
//! A capsule in a shear flow between two moving walls:
//!
//! ```
//! use eulermembrane::grid::{Boundary, Grid};
//! use eulermembrane::interface::shapes::Sphere;
//! use eulermembrane::membrane::law::NeoHookean;
//! use eulermembrane::simulation::{Phase, Scene};
//!
//! // Walls at z = -1 and z = 1 moving at -1 and +1 along x; periodic in x and y.
//! let mut bc = [[Boundary::Periodic; 2]; 3];
//! bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
//! let grid = Grid::<f64>::new([24, 16, 24], [-1.5, -1.0, -1.0], [1.5, 1.0, 1.0], bc)?;
//! let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?) // rho, mu
//!     .capsule(Sphere::new([0.0; 3], 0.4)?)
//!     .elasticity(NeoHookean::new(10.0)?) // E_s
//!     .build()?; // no bending: no curvature fields
//! sim.set_velocity(|x| [x[2], 0.0, 0.0])?; // start from the undisturbed shear
//! let v0 = sim.volume(0)?;
//! for _ in 0..10 {
//!     let report = sim.step(5e-3)?; // a failed step leaves the state as it was
//!     assert!(report.flow.cfl < 0.5);
//! }
//! assert!((sim.volume(0)? - v0).abs() < 1e-12 * v0);
//! sim.write_vti(std::env::temp_dir().join("eulermembrane_doc_capsule.vti"))?; // for ParaView
//! # Ok::<(), eulermembrane::Error>(())
//! ```

mod capsule;
pub mod contact;
pub mod effect;
mod effects;
pub mod observer;
mod output;
mod scene;
mod settings;
pub mod stability;
pub mod timestep;
mod view;

pub use effects::{Bending, Elasticity, SharedLaw, SurfaceForceFn, SurfaceLoad};
pub use scene::Scene;
use settings::box_grown_room;
pub use settings::{
    BOX_MIN_ROOM, BendingCoupling, CapsuleStorage, GsTransport, MembraneCoupling, Phase, ReferenceArea,
    Settings, Traction, TransportMaker, box_grow_room, box_margin,
};
pub use view::{MembraneView, Needs};

use crate::diagnostics::energy::{
    DissipationForm, EnergyState, StepIntegrals, body_force_power, kinetic_energy, viscous_dissipation,
};
use crate::error::positive;
use crate::fluid::momentum::{Coefficient, Materials};
use crate::fluid::stepper::FlowStepper;
use crate::grid::ops::cell_vector;
use crate::grid::{Field, Grid, SymField, VectorField, Window};
use crate::interface::geometry::NormalEstimator;
use crate::membrane::{band::Band, extension::SurfaceExtension};
use crate::tensor::{project, projector};
use crate::{Error, Real, Result};
use capsule::{BoxScratch, Capsule};
use effect::{Effect, EnergyRole, Setup, StepState};
use effects::{EffectForcing, EffectImplicit};
use scene::Strategies;
use view::LevelChoice;

/// What one step of a [`Simulation`] reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepReport {
    /// The flow step: step number and time after the step, `dt`, predictor and pressure solver
    /// iterations, CFL and viscous numbers.
    pub flow: crate::fluid::stepper::StepInfo,
    /// Cells with a reconstructed profile in the interface advection (all capsules).
    pub profile_cells: usize,
    /// Cells of the membrane bands after the step (all capsules).
    pub band_cells: usize,
    /// What the caller should know about this step (the library never prints).
    pub warning: Option<StepWarning>,
    /// Attempts at this step that an [`AdaptiveDt`](timestep::AdaptiveDt) rejected and retried smaller (0 for a
    /// step taken as asked).
    pub retries: usize,
    /// Core cells of the re-sampled sharp shells ([`Traction::SharpResampled`]) whose crushed
    /// `G_s` was re-set from the surface after the step
    /// ([`OuterLayers::repair`](crate::membrane::outer_layers::OuterLayers::repair); all
    /// capsules).
    pub repaired_cells: usize,
}

/// A warning carried by a [`StepReport`]: the step was taken, but its result may not be
/// trustworthy. A report carries one warning, the first that applies of
/// [`CourantAboveOne`](Self::CourantAboveOne), [`DtAboveLimit`](Self::DtAboveLimit) and (from
/// an [`AdaptiveDt`](timestep::AdaptiveDt) run) [`VelocityGrowth`](Self::VelocityGrowth).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum StepWarning {
    /// The advective Courant number of the step ([`StepInfo::cfl`](crate::fluid::stepper::StepInfo::cfl),
    /// `max |v_d| dt / h_d` of the new velocity) exceeds 1: the flow moves more than a cell in
    /// one step, past the stability bound of the interface advection
    /// ([`interface::advect`](crate::interface::advect)), and the run may fail within a few
    /// steps (typically in the predictor's solver). The
    /// validated cases run at a Courant number of 0.3 ([`AdaptiveDt::DEFAULT_CFL`](timestep::AdaptiveDt::DEFAULT_CFL)) and fail
    /// near 0.35–0.5 ([`stability`]); take a smaller `dt`, or let [`AdaptiveDt`](timestep::AdaptiveDt) choose it.
    CourantAboveOne {
        /// The step's Courant number.
        cfl: f64,
    },
    /// `dt` is above the smallest time-step limit of the scene's effects
    /// ([`Simulation::membrane_dt_limit`]: the membrane rules of [`stability`] for
    /// [`Elasticity`] and [`Bending`], and a user effect's own [`Effect::dt_limit`]): the run
    /// may blow up.
    DtAboveLimit {
        /// The step's `dt`.
        dt: f64,
        /// The smallest limit of the scene's effects.
        limit: f64,
    },
    /// The largest velocity `max|v|` grew by `factor` within the last `steps` steps of an
    /// [`AdaptiveDt`](timestep::AdaptiveDt) run: a flow that speeds up, or the start of an instability. The step
    /// follows it (its Courant target shrinks `dt`); look at the run if no physics explains it.
    VelocityGrowth {
        /// `max|v|` of this step over the smallest of the recent steps.
        factor: f64,
        /// The recent steps compared.
        steps: usize,
    },
}

impl std::fmt::Display for StepWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepWarning::CourantAboveOne { cfl } => write!(
                f,
                "the Courant number {cfl:.3} of the step exceeds 1 (validated runs use 0.3); \
                 the run may fail within a few steps: take a smaller dt"
            ),
            StepWarning::DtAboveLimit { dt, limit } => write!(
                f,
                "dt = {dt:.3e} exceeds the time-step limit {limit:.3e} of the scene's effects \
                 (the membrane's, see eulermembrane::simulation::stability, or an effect's own \
                 dt_limit); the run may blow up"
            ),
            StepWarning::VelocityGrowth { factor, steps } => write!(
                f,
                "max|v| grew by a factor {factor:.2} within the last {steps} steps \
                 (a flow that speeds up, or the start of an instability)"
            ),
        }
    }
}

/// A step computed by [`Simulation::prepare`] and not yet committed.
struct Pending {
    report: StepReport,
    dissipated: f64,
    work: f64,
}

/// A coupled fluid-membrane simulation built from a [`Scene`]: owns the flow, the capsules'
/// fields and every solver workspace (see the [module docs](self)).
pub struct Simulation<T: Real> {
    grid: Grid<T>,
    flow: FlowStepper<T>,
    capsules: Vec<Capsule<T>>,
    outside: Phase<T>,
    inside: Phase<T>,
    effects: Vec<Box<dyn Effect<T>>>,
    settings: Settings<T>,
    /// The estimator of every capsule's normals.
    normals: Box<dyn NormalEstimator<T>>,
    /// `v^n` kept across the flow step for the `G_s` transport (only with `G_s`).
    v_old: Option<VectorField<T>>,
    /// Scratch of [`Simulation::energy`]: the external force on the faces.
    force: Option<VectorField<T>>,
    /// The step integrals of [`Simulation::track_energy`] and the midpoint velocity (scratch).
    ledger: Option<(StepIntegrals, VectorField<T>)>,
    /// The prepared step, if any.
    pending: Option<Pending>,
    /// How many capsules hold a prepared level (rolled back by [`Simulation::discard`]).
    prepared_capsules: usize,
    /// The grid of each capsule's box (for [`Setup`]).
    capsule_grids: Vec<Grid<T>>,
    /// Scratch of the mixture (2.25): the sum of the capsules' `phi` (only with variable
    /// materials).
    mixture: Option<Field<T>>,
}

impl<T: Real> Simulation<T> {
    pub(crate) fn from_scene(
        grid: Grid<T>,
        outside: Phase<T>,
        inside: Phase<T>,
        shapes: Vec<(Box<dyn crate::interface::shapes::Shape + Send>, Window, Traction)>,
        effects: Vec<Box<dyn Effect<T>>>,
        settings: Settings<T>,
        mut strategies: Strategies<T>,
    ) -> Result<Self> {
        let (mut normals, make) = strategies.interface(&grid, &settings);
        let mut capsules = Vec::with_capacity(shapes.len());
        let scratch = BoxScratch::default();
        for (c, (shape, window, traction)) in shapes.into_iter().enumerate() {
            let needs = effects.iter().filter(|e| e.acts_on(c)).fold(Needs::NONE, |n, e| {
                let m = e.needs();
                Needs { strain: n.strain || m.strain, curvature: n.curvature || m.curvature }
            });
            let mut cap = Capsule::new(
                &grid,
                window,
                shape.as_ref(),
                &settings,
                needs,
                traction,
                normals.as_mut(),
                &make,
                scratch.clone(),
            )?;
            if !cap.boxed.window.is_whole() {
                // A box moves and grows with its capsule: its transport must move its history
                // with it.
                cap.transport.roll(&cap.boxed.grid, 0, 0)?;
                let (w, g) = (&cap.boxed.window, &cap.boxed.grid);
                cap.transport.regrow(w, g, w, g)?;
            }
            check_wall_distance(&cap.boxed.grid, &cap.cur.phi, settings.smoothing.beta, c)?;
            check_extent(&cap.boxed.grid, &cap.cur.phi, shape.volume(), c)?;
            capsules.push(cap);
        }
        let mut flow = FlowStepper::new(&grid, Materials::uniform(outside.rho, outside.mu)?, settings.flow)?;
        if let Some(m) = strategies.momentum {
            flow = flow.with_momentum_solver(m);
        }
        if let Some(p) = strategies.pressure {
            flow = flow.with_pressure_solver(p);
        }
        let mut sim = Simulation {
            v_old: capsules.iter().any(|c| c.gs.is_some()).then(|| VectorField::zeros(&grid)),
            grid,
            flow,
            capsules,
            outside,
            inside,
            effects,
            settings,
            normals,
            force: None,
            ledger: None,
            pending: None,
            prepared_capsules: 0,
            capsule_grids: Vec::new(),
            mixture: None,
        };
        sim.capsule_grids = sim.capsules.iter().map(|c| c.boxed.grid.clone()).collect();
        sim.set_materials()?;
        Ok(sim)
    }

    /// Sets the flow's materials from the mixture (2.25) of the capsules' current `phi`.
    fn set_materials(&mut self) -> Result<()> {
        let (a, b) = (self.inside, self.outside);
        let mut m = Materials::uniform(b.rho, b.mu)?;
        if !self.capsules.is_empty() {
            let mix = |x: T, y: T| {
                if x == y {
                    Coefficient::Uniform(x)
                } else {
                    let mut f = Field::zeros(&self.grid);
                    f.fill(y);
                    Coefficient::Field(f)
                }
            };
            m = Materials { rho: mix(a.rho, b.rho), mu: mix(a.mu, b.mu) };
        }
        self.flow.set_materials(m)?;
        self.update_materials(false);
        Ok(())
    }

    /// Recomputes the variable material fields in place from `phi` (current or next level).
    fn update_materials(&mut self, next: bool) {
        let mix = &mut self.mixture;
        update_materials(&self.grid, self.inside, self.outside, &self.capsules, &mut self.flow, mix, next);
    }

    /// Advances one time step of size `dt` (see the [module docs](self) for its parts):
    /// [`prepare`](Self::prepare), then [`commit`](Self::commit).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `dt` unless it is finite and `> 0`. A step that
    /// fails returns [`Error::Step`] with the step number, the time and `dt`, wrapping the
    /// cause: a solver that does not converge ([`Error::NoConvergence`]); a non-finite value in
    /// any field ([`Error::NonFinite`] with the field and cell); a membrane band reaching a wall
    /// ([`Error::Unsupported`]); an effect that fails. The state is then exactly as before the
    /// call.
    pub fn step(&mut self, dt: T) -> Result<StepReport> {
        self.prepare(dt)?;
        self.commit()
    }

    /// Computes the step `dt` beside the state, which it does not change (the first phase of
    /// [`step`](Self::step), for custom drivers: inspect the proposal with
    /// [`proposed_velocity`](Self::proposed_velocity) and the report, then
    /// [`commit`](Self::commit) it or [`discard`](Self::discard) it and try another `dt`). A
    /// step prepared before is discarded first.
    ///
    /// # Errors
    /// As [`step`](Self::step); nothing is then prepared.
    pub fn prepare(&mut self, dt: T) -> Result<StepReport> {
        positive("dt", dt)?;
        self.discard();
        let (step, time) = (self.steps() + 1, self.time().f64());
        match self.prepare_step(dt) {
            Ok(report) => Ok(report),
            Err(e) => {
                self.discard();
                Err(Error::Step { step, time, dt: dt.f64(), source: Box::new(e) })
            }
        }
    }

    /// Makes the prepared step the state and returns its report.
    ///
    /// # Errors
    /// [`Error::Unsupported`] when no step is prepared; the state is unchanged.
    pub fn commit(&mut self) -> Result<StepReport> {
        let Some(p) = self.pending.take() else {
            return Err(Error::Unsupported {
                component: "Simulation::commit",
                detail: "no prepared step: call prepare first (a step is committed once)".into(),
            });
        };
        self.commit_step(p)
    }

    /// Forgets the prepared step, if any: the state is as before [`prepare`](Self::prepare).
    pub fn discard(&mut self) {
        self.pending = None;
        self.flow.discard();
        if self.prepared_capsules > 0 {
            for cap in &mut self.capsules[..self.prepared_capsules] {
                cap.discard();
            }
            self.prepared_capsules = 0;
            self.update_materials(false);
        }
    }

    /// The velocity `v^{n+1}` of the prepared step (`None` when none is prepared).
    pub fn proposed_velocity(&self) -> Option<&VectorField<T>> {
        self.pending.as_ref().and_then(|_| self.flow.proposed_velocity())
    }

    /// `phi^{n+1}` of capsule `c` in the prepared step (`None` when none is prepared).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an unknown capsule.
    pub fn proposed_phi(&self, c: usize) -> Result<Option<&Field<T>>> {
        let cap = self.capsule(c)?;
        Ok(self.pending.as_ref().map(|_| &cap.next.phi))
    }

    /// The body of [`prepare`](Self::prepare), for a valid `dt`; on error the caller discards.
    fn prepare_step(&mut self, dt: T) -> Result<StepReport> {
        let limit = self.checked_dt_limit()?;
        let grid = &self.grid;
        let mut profile_cells = 0;
        // 1-2: per capsule, beside the state.
        for c in 0..self.capsules.len() {
            self.prepared_capsules = c + 1;
            profile_cells +=
                self.capsules[c].prepare(grid, self.flow.velocity(), dt, self.normals.as_mut())?;
            check_room(&self.capsules[c], c)?;
        }
        // 3: the effects, at the new level with G_s^n.
        let time = self.flow.time();
        let state = StepState {
            grid,
            settings: &self.settings,
            time,
            capsules: &self.capsules,
            level: LevelChoice::Next,
        };
        for e in self.effects.iter_mut() {
            e.prepare(&state, self.flow.velocity(), dt)?;
        }
        // 4-5: materials and the flow step (the same state: the mixture does not change it).
        let mix = &mut self.mixture;
        update_materials(grid, self.inside, self.outside, &self.capsules, &mut self.flow, mix, true);
        let forcing = EffectForcing { effects: &self.effects, state: &state };
        let implicit = EffectImplicit { effects: &self.effects, state: &state };
        let extra = implicit.any().then_some(&implicit as &dyn crate::fluid::momentum::ImplicitTerm<T>);
        let flow_info = self.flow.prepare(dt, &forcing, extra)?;
        // 6: G_s^{n+1}, beside the state.
        for cap in self.capsules.iter_mut() {
            if let (Some(strain), Some(gs)) = (cap.strain.as_mut(), cap.gs.as_mut()) {
                let (v_old, v_new) = (self.flow.velocity(), self.flow.prepared_velocity());
                let (band, normal, extension) = (&cap.next.band, &cap.next.normal, cap.extension.as_ref());
                cap.boxed.with_velocities(grid, v_old, v_new, |grid, v_old, v_new| {
                    gs.fill_ghosts(grid);
                    match extension {
                        Some(x) => x.with_extended(v_old, v_new, |u_old, u_new| {
                            strain.prepare(grid, band, dt, u_old, u_new, normal, gs)
                        }),
                        None => strain.prepare(grid, band, dt, v_old, v_new, normal, gs),
                    }
                })?;
            }
        }
        // The energy ledger, from the step's midpoint velocity.
        let (dissipated, work) = self.step_integrals(dt)?;
        let band_cells = self.capsules.iter().map(|c| c.next.band.len()).sum();
        let warning = if flow_info.cfl > 1.0 {
            Some(StepWarning::CourantAboveOne { cfl: flow_info.cfl })
        } else {
            (dt.f64() > limit).then_some(StepWarning::DtAboveLimit { dt: dt.f64(), limit })
        };
        let report =
            StepReport { flow: flow_info, profile_cells, band_cells, warning, retries: 0, repaired_cells: 0 };
        self.pending = Some(Pending { report, dissipated, work });
        Ok(report)
    }

    /// Makes the prepared step `p` the state.
    fn commit_step(&mut self, p: Pending) -> Result<StepReport> {
        if let Some((l, _)) = self.ledger.as_mut() {
            l.dissipated += p.dissipated;
            l.work += p.work;
        }
        if let Some(v_old) = self.v_old.as_mut() {
            v_old.copy_from(self.flow.velocity());
        }
        self.flow.commit()?;
        let mut repaired = 0;
        for cap in &mut self.capsules {
            if let (Some(strain), Some(gs)) = (cap.strain.as_mut(), cap.gs.as_mut()) {
                strain.commit(&cap.next.band, &cap.next.normal, gs)?;
                // The sharp membrane is one surface: G_s has no normal part (2.18).
                if self.settings.gs_transport.projects() || cap.extension.is_some() {
                    let n = &cap.next.normal;
                    for &idx in cap.next.band.cells() {
                        let p = projector(&cell_vector(n, idx));
                        gs.set(idx, &project(&p, &gs.get(idx)));
                    }
                }
                // The re-sampled sharp shell carries the surface's deformation in its outer
                // layers too.
                if let Some(layers) = cap.extension.as_ref().and_then(SurfaceExtension::outer_layers) {
                    repaired += layers.repair(&cap.next.band, &cap.next.phi, &cap.next.normal, gs)?;
                    layers.resample(&cap.next.band, gs)?;
                }
            }
            cap.commit();
            cap.restore_reference_area();
        }
        self.prepared_capsules = 0;
        // Each box follows its capsule: the membrane band centred, a segment of a wall axis
        // as far as the walls let it, where it leaves only the far field behind (a transport
        // that cannot move leaves its box where it is and reports it).
        for (cap, boxed_grid) in self.capsules.iter_mut().zip(&mut self.capsule_grids) {
            for (d, room) in cap.room(LevelChoice::Current).into_iter().enumerate() {
                let Some((lo, hi)) = room else { continue };
                let off =
                    cap.far_field_move(d, cap.boxed.window.clamp_shift(d, (lo as isize - hi as isize) / 2));
                if off != 0 {
                    cap.shift(&self.grid, d, off, self.normals.as_mut())?;
                    *boxed_grid = cap.boxed.grid.clone();
                }
            }
        }
        // ... and grows where the capsule has stretched towards its sides, so that the ends of
        // its ring stay in the far field.
        let beta = self.settings.advection.beta.f64();
        let (grow_at, target) = (box_grow_room(beta), box_grown_room(beta));
        for c in 0..self.capsules.len() {
            let cap = &mut self.capsules[c];
            let (mut lo, mut hi) = ([0usize; 3], [0usize; 3]);
            for (d, room) in cap.room(LevelChoice::Current).into_iter().enumerate() {
                if let Some((a, b)) = room
                    && a.min(b) < grow_at
                {
                    (lo[d], hi[d]) = (target.saturating_sub(a), target.saturating_sub(b));
                }
            }
            if (lo, hi) == ([0; 3], [0; 3]) {
                continue;
            }
            let to = cap.boxed.window.grown(&self.grid, lo, hi)?;
            cap.regrow(&self.grid, to, &self.settings, self.normals.as_mut())?;
            self.capsule_grids[c] = cap.boxed.grid.clone();
            self.box_resized(&[c])?;
        }
        Ok(StepReport { repaired_cells: repaired, ..p.report })
    }

    /// Tells every effect that the boxes of `capsules` have grown.
    fn box_resized(&mut self, capsules: &[usize]) -> Result<()> {
        let mut effects = std::mem::take(&mut self.effects);
        let setup = self.setup();
        let told =
            effects.iter_mut().try_for_each(|e| capsules.iter().try_for_each(|&c| e.box_resized(c, &setup)));
        self.effects = effects;
        told
    }

    /// `dt Phi(v^{n+1/2})` and `dt f^n . v^{n+1/2}` of the prepared step (see
    /// [`StepIntegrals`]; zeros without a ledger, nothing computed), with the materials and
    /// capsule levels of step `n + 1` and the external forces at `t^n`, as the flow step used
    /// them.
    fn step_integrals(&mut self, dt: T) -> Result<(f64, f64)> {
        let g = &self.grid;
        let Some((_, half)) = self.ledger.as_mut() else { return Ok((0.0, 0.0)) };
        let (v0, v1) = (self.flow.velocity(), self.flow.prepared_velocity());
        for d in 0..3 {
            for ((h, &a), &b) in half.c[d].data.iter_mut().zip(&v0.c[d].data).zip(&v1.c[d].data) {
                *h = T::lit(0.5) * (a + b);
            }
        }
        let half = &*half;
        let m = self.flow.materials();
        // The scheme's viscous term acts on `v_theta = theta v1 + (1 - theta) v0`; its power on
        // `v_half` is, `V` being symmetric, `Phi(v_half) + (theta - 1/2) (Phi(v1) - Phi(v0)) / 2`
        // (the second term is the damping a theta above 1/2 adds; none for Crank-Nicolson).
        let mut dissipation = viscous_dissipation(g, half, &m.mu, DissipationForm::Discrete)?;
        let theta = self.settings.flow.viscous.implicit_weight();
        if theta != 0.5 {
            let phi1 = viscous_dissipation(g, v1, &m.mu, DissipationForm::Discrete)?;
            let phi0 = viscous_dissipation(g, v0, &m.mu, DissipationForm::Discrete)?;
            dissipation += 0.5 * (theta - 0.5) * (phi1 - phi0);
        }
        let state = StepState {
            grid: g,
            settings: &self.settings,
            time: self.flow.time(),
            capsules: &self.capsules,
            level: LevelChoice::Next,
        };
        let power = external_power(&self.effects, &state, v0, half, &mut self.force)?;
        Ok((dt.f64() * dissipation, dt.f64() * power))
    }

    /// Starts the energy ledger: from now on every step adds `dt Phi(v^{n+1/2})` and
    /// `dt f^n . v^{n+1/2}` to the [`StepIntegrals`] that [`energy`](Self::energy) reports, the
    /// terms of the scheme's own kinetic-energy balance (an [`EnergyBudget`] built from them
    /// does not see the spurious jumps of the trapezoid rule where a force switches on or off).
    /// Costs one pass over the box per step and one velocity field; a second call restarts the
    /// integrals at zero. Checkpoints do not hold the ledger.
    ///
    /// [`EnergyBudget`]: crate::diagnostics::energy::EnergyBudget
    pub fn track_energy(&mut self) {
        let half = match self.ledger.take() {
            Some((_, h)) => h,
            None => VectorField::zeros(&self.grid),
        };
        self.ledger = Some((StepIntegrals::default(), half));
    }

    /// The grid.
    pub fn grid(&self) -> &Grid<T> {
        &self.grid
    }
    /// The settings in use.
    pub fn settings(&self) -> &Settings<T> {
        &self.settings
    }
    /// The time.
    pub fn time(&self) -> T {
        self.flow.time()
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.flow.steps()
    }
    /// The flow stepper (velocity, pressure, materials, CFL and viscous numbers).
    pub fn flow(&self) -> &FlowStepper<T> {
        &self.flow
    }
    /// The velocity `v^n` (staggered, ghosts filled).
    pub fn velocity(&self) -> &VectorField<T> {
        self.flow.velocity()
    }
    /// The pressure.
    pub fn pressure(&self) -> &Field<T> {
        self.flow.pressure()
    }
    /// Sets the velocity from a function of position (component `d` at the faces normal to
    /// `d`), e.g. an initial shear flow; see [`FlowStepper::set_velocity`].
    pub fn set_velocity(&mut self, f: impl Fn([T; 3]) -> [T; 3]) -> Result<()> {
        self.flow.set_velocity(f)
    }
    /// Number of capsules.
    pub fn capsule_count(&self) -> usize {
        self.capsules.len()
    }
    /// Whether any membrane carries `G_s` (some effect, e.g. [`Elasticity`], needs it).
    pub fn has_elasticity(&self) -> bool {
        self.capsules.iter().any(|c| c.gs.is_some())
    }
    /// Whether any membrane carries `kappa_R tilde` (some effect, e.g. [`Bending`], needs it).
    pub fn has_bending(&self) -> bool {
        self.capsules.iter().any(|c| c.cur.kappa.is_some())
    }
    /// The scene's effects, in the order they were added.
    pub fn effects(&self) -> &[Box<dyn Effect<T>>] {
        &self.effects
    }

    fn capsule(&self, c: usize) -> Result<&Capsule<T>> {
        self.capsules.get(c).ok_or_else(|| {
            Error::invalid(
                "capsule",
                format!("{c} (of {} capsules)", self.capsules.len()),
                "the index of a capsule of the scene",
            )
        })
    }

    /// The grid of capsule `c`'s box, where its fields ([`phi`](Self::phi), [`delta`](Self::delta),
    /// the normals, the band, `G_s`) live: the simulation's grid where the box is the whole
    /// grid, else the box's cells of it ([`Window::grid`]).
    pub fn capsule_grid(&self, c: usize) -> Result<&Grid<T>> {
        Ok(&self.capsule(c)?.boxed.grid)
    }
    /// Capsule `c`'s box in the simulation's grid.
    pub fn window(&self, c: usize) -> Result<&Window> {
        Ok(&self.capsule(c)?.boxed.window)
    }
    /// `phi` of capsule `c` (1 inside, 0 outside), on its [`capsule_grid`](Self::capsule_grid).
    pub fn phi(&self, c: usize) -> Result<&Field<T>> {
        Ok(&self.capsule(c)?.cur.phi)
    }
    /// `kappa_R tilde` of capsule `c` (`None` without bending).
    pub fn kappa_r_tilde(&self, c: usize) -> Result<Option<&Field<T>>> {
        Ok(self.capsule(c)?.cur.kappa.as_ref())
    }
    /// `delta = |grad phi|` of capsule `c` (zero where `phi` is saturated).
    pub fn delta(&self, c: usize) -> Result<&Field<T>> {
        Ok(&self.capsule(c)?.cur.delta)
    }
    /// The velocity the membrane of capsule `c` moves and strains with, into `out` on the
    /// capsule's [`capsule_grid`](Self::capsule_grid): the fluid velocity with the smoothed
    /// traction, the map [`SurfaceExtension`] of it with
    /// [`Traction::Sharp`] (the tangential velocity of the closest surface point on the faces
    /// around the band).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an unknown capsule or `velocity` for a
    /// field of another grid.
    pub fn membrane_velocity(&self, c: usize, out: &mut VectorField<T>) -> Result<()> {
        let cap = self.capsule(c)?;
        let (g, bg) = (&self.grid, &cap.boxed.grid);
        out.matches(bg, "velocity")?;
        cap.boxed.window.gather_vector(g, self.flow.velocity(), bg, out)?;
        if let Some(e) = cap.extension.as_ref() {
            if e.generation() != cap.cur.band.generation() {
                return Err(Error::Unsupported {
                    component: "Simulation::membrane_velocity",
                    detail: "the membrane velocity map is not the current state's".into(),
                });
            }
            let v = out.clone();
            e.extend(&v, out);
        }
        Ok(())
    }
    /// The [`Traction`] of capsule `c`: the one its effects ask for
    /// ([`Effect::requested_traction`]), smoothed where none asks.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an unknown capsule.
    pub fn traction(&self, c: usize) -> Result<Traction> {
        Ok(self.capsule(c)?.traction())
    }
    /// Unit normals of capsule `c` at cell centres (pointing into the capsule).
    pub fn normal(&self, c: usize) -> Result<&[Field<T>; 3]> {
        Ok(&self.capsule(c)?.cur.normal)
    }
    /// The membrane band of capsule `c`.
    pub fn band(&self, c: usize) -> Result<&Band<T>> {
        Ok(&self.capsule(c)?.cur.band)
    }
    /// `G_s` of capsule `c` (`None` without elasticity). Valid on the band and its halo.
    pub fn gs(&self, c: usize) -> Result<Option<&SymField<T>>> {
        Ok(self.capsule(c)?.gs.as_ref())
    }

    /// Pre-stretches the membrane of capsule `c` isotropically by `lambda` (current over
    /// reference length): `G_s = lambda^2 P` with the current normals, so that the capsule's
    /// reference state is smaller than its shape (`lambda > 1`, an inflated capsule) or larger.
    /// The reference area `sum delta / j_s h^3` this leaves is the one that
    /// [`ReferenceArea::Conserved`] holds from then on.
    ///
    /// # Errors
    /// `lambda` not finite and `> 0`; a scene without elasticity; an unknown capsule.
    pub fn prestretch(&mut self, c: usize, lambda: T) -> Result<()> {
        positive("lambda", lambda)?;
        self.capsule(c)?;
        let cap = &mut self.capsules[c];
        let grid = &cap.boxed.grid;
        let Some(gs) = cap.gs.as_mut() else {
            return Err(Error::invalid(
                "prestretch",
                "a scene without elasticity",
                "a scene with Scene::elasticity",
            ));
        };
        crate::membrane::strain::fill_projector(grid, &cap.cur.normal, gs);
        let l2 = lambda * lambda;
        for f in gs.c.iter_mut() {
            f.data.iter_mut().for_each(|x| *x *= l2);
        }
        gs.fill_ghosts(grid);
        if let Some(s) = cap.strain.as_mut() {
            s.reset_history();
        }
        cap.reset_reference_target();
        Ok(())
    }

    /// Volume `sum phi h^3` of capsule `c`.
    pub fn volume(&self, c: usize) -> Result<f64> {
        crate::diagnostics::volume::volume(self.capsule_grid(c)?, self.phi(c)?)
    }
    /// Centroid (3.5) of capsule `c` (in the positions of its box: past the upper side of a
    /// periodic axis for a box that straddles it).
    pub fn centroid(&self, c: usize) -> Result<[f64; 3]> {
        crate::diagnostics::volume::centroid(self.capsule_grid(c)?, self.phi(c)?)
    }
    /// Surface area `sum delta h^3` of capsule `c` (for the transported area (3.7), see
    /// [`AreaTracker`](crate::diagnostics::area::AreaTracker)).
    pub fn area(&self, c: usize) -> Result<f64> {
        crate::diagnostics::area::area_from_delta(self.capsule_grid(c)?, self.delta(c)?)
    }

    /// Reference (unstressed) area `sum delta / j_s h^3` of the membrane of capsule `c`, with
    /// `j_s = sqrt(c2)` the local area dilation of `G_s` (`None` without elasticity). In the
    /// continuum it keeps its initial value; its drift measures how much the discrete
    /// transports of `G_s` (2.40) and of `phi` disagree on the change of area (with
    /// [`ReferenceArea::Conserved`] the step holds it at its initial value).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an unknown capsule.
    pub fn reference_area(&self, c: usize) -> Result<Option<f64>> {
        let cap = self.capsule(c)?;
        Ok(cap.reference_area())
    }

    /// The energy stored by the membranes: the sum of [`Effect::stored_energy`] over the
    /// scene's effects; for [`Elasticity`] the elastic energy `sum delta W_s / j_s h^3` over the
    /// bands (zero without elasticity): `W_s` is an energy per unit *reference* area ((2.4)
    /// divides by `j_s = sqrt(c2)`), `delta h^3` an element of *current* area,
    /// `dA_R = dA / j_s`.
    pub fn elastic_energy(&self) -> f64 {
        let state = self.state(LevelChoice::Current);
        self.effects
            .iter()
            .filter(|e| e.energy_role() == EnergyRole::Stored)
            .map(|e| e.stored_energy(&state))
            .sum()
    }

    /// Adds the force density of the membranes (the [`EnergyRole::Stored`] effects:
    /// elasticity, bending, contact) at the current state to `out`, on the faces of the
    /// staggered grid as the flow step receives it: the force whose first moment is the
    /// suspension's particle stress ([`particle_stress`](crate::diagnostics::suspension::particle_stress)).
    /// The effects are evaluated at the current level (as a step would with `dt`), and their
    /// quasi-implicit operators applied to the current velocity are added to their explicit
    /// forces: the `dt` terms of (2.35) cancel and what is added is the force itself (e.g.
    /// `div(delta tau^n)`), independent of `dt`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `out` if it is not sized for the simulation's grid,
    /// or `dt` unless finite and `> 0`; [`Error::Unsupported`] while a step is prepared (between
    /// [`prepare`](Self::prepare) and [`commit`](Self::commit)); an effect's own error.
    pub fn membrane_force(&mut self, dt: T, out: &mut VectorField<T>) -> Result<()> {
        positive("dt", dt)?;
        if (0..3).any(|d| out.c[d].data.len() != self.flow.velocity().c[d].data.len()) {
            return Err(Error::invalid(
                "out",
                "a vector field of another grid",
                "VectorField::zeros(sim.grid())",
            ));
        }
        if self.pending.is_some() {
            return Err(Error::Unsupported {
                component: "Simulation::membrane_force",
                detail: "a step is prepared: commit or discard it first".into(),
            });
        }
        let state = StepState {
            grid: &self.grid,
            settings: &self.settings,
            time: self.flow.time(),
            capsules: &self.capsules,
            level: LevelChoice::Current,
        };
        let v = self.flow.velocity();
        let mut implicit: Option<VectorField<T>> = None;
        for e in self.effects.iter_mut().filter(|e| e.energy_role() == EnergyRole::Stored) {
            if !e.is_active(&state) {
                continue;
            }
            e.prepare(&state, v, dt)?;
            e.add_force(&state, v, out)?;
            if e.has_implicit(&state) {
                let y = implicit.get_or_insert_with(|| VectorField::zeros(&self.grid));
                e.add_implicit(&state, v, y)?;
            }
        }
        if let Some(y) = implicit {
            for (o, y) in out.c.iter_mut().zip(&y.c) {
                o.data.iter_mut().zip(&y.data).for_each(|(o, y)| *o += *y);
            }
        }
        Ok(())
    }

    /// What the effects see of the scene.
    fn setup(&self) -> Setup<'_, T> {
        Setup {
            grid: &self.grid,
            settings: &self.settings,
            outside: self.outside,
            inside: self.inside,
            capsules: self.capsules.len(),
            capsule_grids: &self.capsule_grids,
        }
    }

    /// The state the effects see at the current time level.
    fn state(&self, level: LevelChoice) -> StepState<'_, T> {
        StepState {
            grid: &self.grid,
            settings: &self.settings,
            time: self.flow.time(),
            capsules: &self.capsules,
            level,
        }
    }

    /// The terms of the energy budget of Sec. 3.2 at the current time: kinetic and elastic
    /// energy, viscous dissipation rate, the power of the external forces ([`EnergyRole::Work`]
    /// effects) and, after [`track_energy`](Self::track_energy), their step integrals (feed them
    /// to an [`EnergyBudget`](crate::diagnostics::energy::EnergyBudget)).
    pub fn energy(&mut self) -> Result<EnergyState> {
        let g = &self.grid;
        let m = self.flow.materials();
        let v = self.flow.velocity();
        let kinetic = kinetic_energy(g, v, &m.rho)?;
        let dissipation_rate = viscous_dissipation(g, v, &m.mu, DissipationForm::Discrete)?;
        let state = StepState {
            grid: g,
            settings: &self.settings,
            time: self.flow.time(),
            capsules: &self.capsules,
            level: LevelChoice::Current,
        };
        let body_power = external_power(&self.effects, &state, v, v, &mut self.force)?;
        let elastic = self.elastic_energy();
        let integrals = self.ledger.as_ref().map(|(i, _)| *i);
        Ok(EnergyState {
            time: self.flow.time().f64(),
            kinetic,
            elastic,
            dissipation_rate,
            body_power,
            integrals,
        })
    }
}

/// Recomputes the variable material fields of `flow` in place from the mixture (2.25) of the
/// capsules' `phi` (current or next level), summed in capsule order into `mix` (scratch).
fn update_materials<T: Real>(
    grid: &Grid<T>,
    inside: Phase<T>,
    outside: Phase<T>,
    caps: &[Capsule<T>],
    flow: &mut FlowStepper<T>,
    mix: &mut Option<Field<T>>,
    next: bool,
) {
    let (a, b) = (inside, outside);
    let m = flow.materials_mut();
    let fields = [(&mut m.rho, (a.rho, b.rho)), (&mut m.mu, (a.mu, b.mu))];
    if !fields.iter().any(|(c, _)| matches!(c, Coefficient::Field(_))) {
        return;
    }
    let w = mix.get_or_insert_with(|| Field::zeros(grid));
    w.fill(T::zero());
    for c in caps {
        let phi = if next { &c.next.phi } else { &c.cur.phi };
        // The box grid and fields are the capsule's own: this cannot fail. (Only the interior
        // is summed: the ghosts of the coefficients are filled below.)
        let _ = c.boxed.window.add_to(&c.boxed.grid, phi, grid, w);
    }
    for (coef, (xa, xb)) in fields {
        if let Coefficient::Field(f) = coef {
            f.data.iter_mut().zip(&w.data).for_each(|(out, &w)| {
                let w = w.max(T::zero()).min(T::one());
                *out = w * xa + (T::one() - w) * xb;
            });
            f.fill_ghosts(grid);
        }
    }
}

/// The power `sum f . w dV` of the external forces (the [`EnergyRole::Work`] effects that are
/// active) at the state `state` with the velocity `v` the forces see, `f` assembled in
/// `scratch`; zero without any.
fn external_power<T: Real>(
    effects: &[Box<dyn Effect<T>>],
    state: &StepState<'_, T>,
    v: &VectorField<T>,
    w: &VectorField<T>,
    scratch: &mut Option<VectorField<T>>,
) -> Result<f64> {
    let mut work =
        effects.iter().filter(|e| e.energy_role() == EnergyRole::Work && e.is_active(state)).peekable();
    if work.peek().is_none() {
        return Ok(0.0);
    }
    let g = state.grid;
    let f = scratch.get_or_insert_with(|| VectorField::zeros(g));
    for c in f.c.iter_mut() {
        c.fill(T::zero());
    }
    for e in work {
        e.add_force(state, v, f)?;
    }
    body_force_power(g, w, f)
}

/// Refuses a prepared level whose membrane band comes within [`BOX_MIN_ROOM`] cells of its
/// box's side: the capsule has outgrown its box.
fn check_room<T: Real>(cap: &Capsule<T>, c: usize) -> Result<()> {
    for (d, room) in cap.room(LevelChoice::Next).into_iter().enumerate() {
        if let Some((lo, hi)) = room
            && lo.min(hi) < BOX_MIN_ROOM
        {
            return Err(Error::invalid(
                "CapsuleStorage::Boxed room",
                format!(
                    "a box of {} cells along axis {d} for capsule {c}, whose band comes within {} cells of its side",
                    cap.boxed.window.size()[d],
                    lo.min(hi)
                ),
                "a room that leaves the band BOX_MIN_ROOM cells from the box's sides as the capsule deforms",
            ));
        }
    }
    Ok(())
}

/// Refuses a capsule that the grid cannot carry: one whose volume (the shape's where it is known
/// exactly, `exact`; else that of `phi`) is below that of a sphere (a circle in 2D) of one
/// cell's radius, and one that overlaps its own periodic image: every
/// plane across a periodic axis holds some of its inside (`phi >= 1/2`; e.g. a radius of 2.5 in
/// a period of 4).
fn check_extent<T: Real>(grid: &Grid<T>, phi: &Field<T>, exact: Option<f64>, c: usize) -> Result<()> {
    let h = grid.h().iter().take(if grid.is_2d() { 2 } else { 3 }).fold(f64::INFINITY, |m, x| m.min(x.f64()));
    let (volume, smallest) = if grid.is_2d() {
        let area = match exact {
            Some(a) => a,
            None => crate::diagnostics::volume::volume(grid, phi)? / grid.h()[2].f64(),
        };
        (area, std::f64::consts::PI * h * h)
    } else {
        let v = match exact {
            Some(v) => v,
            None => crate::diagnostics::volume::volume(grid, phi)?,
        };
        (v, 4.0 / 3.0 * std::f64::consts::PI * h.powi(3))
    };
    if volume < smallest {
        return Err(Error::invalid(
            "capsule",
            format!(
                "capsule {c} of volume {volume:.3e} (area in 2D), less than a sphere of one cell's radius"
            ),
            "a capsule at least a cell in radius (a membrane needs several cells across)",
        ));
    }
    let half = T::lit(0.5);
    let n = grid.n();
    for d in (0..3).filter(|&d| grid.is_periodic(d) && n[d] > 1) {
        let mut touched = vec![false; n[d]];
        for (i, j, k) in grid.cells() {
            if phi.data[grid.idx_u(i, j, k)] >= half {
                touched[[i, j, k][d]] = true;
            }
        }
        if touched.iter().all(|&t| t) {
            return Err(Error::invalid(
                "capsule",
                format!("capsule {c}: its inside spans the whole period along axis {d}"),
                "a capsule shorter than the period (it would overlap its own periodic image)",
            ));
        }
    }
    Ok(())
}

/// Refuses a capsule whose surface (`phi = 1/2`) comes within two profile widths (`2 h/beta`
/// each, four cells at `beta = 1`) of a wall.
fn check_wall_distance<T: Real>(grid: &Grid<T>, phi: &Field<T>, beta: f64, c: usize) -> Result<()> {
    let min_cells = (4.0 / beta).ceil() as usize;
    let half = T::lit(0.5);
    for d in (0..3).filter(|&d| !grid.is_periodic(d)) {
        let n = grid.n()[d];
        let near = grid.cells().find(|&(i, j, k)| {
            let x = [i, j, k][d];
            x.min(n - 1 - x) < min_cells && phi.data[grid.idx_u(i, j, k)] >= half
        });
        if let Some(cell) = near {
            return Err(Error::invalid(
                "capsule",
                format!(
                    "capsule {c}: inside at cell {cell:?}, within {min_cells} cells of a wall on axis {d}"
                ),
                "a capsule whose surface stays two profile widths (4 h / beta) from every wall",
            ));
        }
    }
    Ok(())
}
