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
//! use eulermembrane::membrane::NeoHookean;
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
mod forces;
mod output;
mod scene;
pub mod stability;

pub use scene::{MembraneCoupling, Phase, Scene, Settings, SharedLaw, SurfaceForceFn};

use crate::diagnostics::{
    DissipationForm, EnergyState, StepIntegrals, body_force_power, kinetic_energy, viscous_dissipation,
};
use crate::error::positive;
use crate::fluid::{BodyForce, Coefficient, Forcing, ImplicitTerm, Materials};
use crate::grid::ops::cell_vector;
use crate::grid::{Field, Grid, SymField, VectorField};
use crate::membrane::Band;
use crate::membrane::SurfaceLaw;
use crate::membrane::stress::SurfaceKinematics;
use crate::tensor::{project, projector};
use crate::{Error, Real, Result};
use capsule::{Capsule, reference_integral};
use forces::{SumForcing, SumImplicit, SurfaceForcing};
use std::sync::Arc;

pub use crate::fluid::FlowStepper;

/// What one step of a [`Simulation`] reports.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepReport {
    /// The flow step: step number and time after the step, `dt`, predictor and pressure solver
    /// iterations, CFL and viscous numbers.
    pub flow: crate::fluid::StepInfo,
    /// Cells with a reconstructed profile in the interface advection (all capsules).
    pub profile_cells: usize,
    /// Cells of the membrane bands after the step (all capsules).
    pub band_cells: usize,
}

/// A coupled fluid-membrane simulation built from a [`Scene`]: owns the flow, the capsules'
/// fields and every solver workspace (see the [module docs](self)).
pub struct Simulation<T: Real> {
    grid: Grid<T>,
    flow: FlowStepper<T>,
    capsules: Vec<Capsule<T>>,
    outside: Phase<T>,
    inside: Phase<T>,
    law: Option<SharedLaw<T>>,
    body_force: BodyForce<T>,
    surface_force: Option<Arc<SurfaceForceFn>>,
    settings: Settings<T>,
    /// `v^n` kept across the flow step for the `G_s` transport (only with elasticity).
    v_old: Option<VectorField<T>>,
    /// Scratch of [`Simulation::energy`]: the external force on the faces.
    force: Option<VectorField<T>>,
    /// The step integrals of [`Simulation::track_energy`] and the midpoint velocity (scratch).
    ledger: Option<(StepIntegrals, VectorField<T>)>,
    /// Whether the `dt` warning of [`stability`] was printed.
    dt_warned: bool,
}

impl<T: Real> Simulation<T> {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_scene(
        grid: Grid<T>,
        outside: Phase<T>,
        inside: Phase<T>,
        shapes: Vec<Box<dyn crate::interface::shapes::Shape + Send>>,
        law: Option<SharedLaw<T>>,
        eb: Option<T>,
        body_force: [T; 3],
        surface_force: Option<Arc<SurfaceForceFn>>,
        settings: Settings<T>,
    ) -> Result<Self> {
        let mut capsules = Vec::with_capacity(shapes.len());
        for (c, shape) in shapes.iter().enumerate() {
            let cap = Capsule::new(&grid, shape.as_ref(), &settings, law.as_ref(), eb)?;
            check_wall_distance(&grid, &cap.cur.phi, settings.smoothing.beta, c)?;
            capsules.push(cap);
        }
        let flow = FlowStepper::new(&grid, Materials::uniform(outside.rho, outside.mu)?, settings.flow)?;
        let mut sim = Simulation {
            v_old: law.as_ref().map(|_| VectorField::zeros(&grid)),
            grid,
            flow,
            capsules,
            outside,
            inside,
            law,
            body_force: BodyForce::new(body_force)?,
            surface_force,
            settings,
            force: None,
            ledger: None,
            dt_warned: false,
        };
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
        let (a, b) = (self.inside, self.outside);
        let caps = &self.capsules;
        let m = self.flow.materials_mut();
        for (coef, (xa, xb)) in [(&mut m.rho, (a.rho, b.rho)), (&mut m.mu, (a.mu, b.mu))] {
            if let Coefficient::Field(f) = coef {
                f.data.iter_mut().enumerate().for_each(|(idx, out)| {
                    let w = caps
                        .iter()
                        .map(|c| if next { c.next.phi.data[idx] } else { c.cur.phi.data[idx] })
                        .fold(T::zero(), |s, p| s + p)
                        .max(T::zero())
                        .min(T::one());
                    *out = w * xa + (T::one() - w) * xb;
                });
                f.fill_ghosts(&self.grid);
            }
        }
    }

    /// Advances one time step of size `dt` (see the [module docs](self) for its parts).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `dt` unless it is finite and `> 0`. A step that
    /// fails returns [`Error::Step`] with the step number, the time and `dt`, wrapping the
    /// cause: a solver that does not converge ([`Error::NoConvergence`]); a non-finite value in
    /// any field ([`Error::NonFinite`] with the field and cell); a membrane band reaching a wall
    /// ([`Error::Unsupported`]). The state is then exactly as before the call.
    pub fn step(&mut self, dt: T) -> Result<StepReport> {
        positive("dt", dt)?;
        self.warn_if_above_limit(dt);
        let (step, time) = (self.steps() + 1, self.time().f64());
        self.advance(dt).map_err(|e| Error::Step { step, time, dt: dt.f64(), source: Box::new(e) })
    }

    /// The body of [`step`](Self::step), for a valid `dt`.
    fn advance(&mut self, dt: T) -> Result<StepReport> {
        let grid = &self.grid.clone();
        let mut profile_cells = 0;
        // 1-3: per capsule, beside the state.
        for c in 0..self.capsules.len() {
            match self.capsules[c].prepare(grid, self.flow.velocity(), dt) {
                Ok(n) => profile_cells += n,
                Err(e) => {
                    for cap in &mut self.capsules[..=c] {
                        cap.discard();
                    }
                    return Err(e);
                }
            }
        }
        // 4-5: materials and the flow step.
        self.update_materials(true);
        let flow_info = (|| {
            let caps = &self.capsules;
            let mut implicit = Vec::new();
            let mut forcings: Vec<&dyn Forcing<T>> = vec![&self.body_force];
            let mut elastic = Vec::new();
            let mut bending = Vec::new();
            for cap in caps {
                if let Some(e) = &cap.elastic {
                    if self.settings.coupling == MembraneCoupling::Explicit {
                        elastic.push(e.explicit_forcing(&cap.next.band)?);
                    } else {
                        elastic.push(e.forcing(&cap.next.band)?);
                        implicit.push(e.implicit(&cap.next.band)?);
                    }
                }
                if let Some(b) = &cap.bending {
                    bending.push(b.forcing(&cap.next.band)?);
                }
            }
            let surface = self
                .surface_force
                .as_deref()
                .map(|f| SurfaceForcing { f, levels: caps.iter().map(|c| &c.next).collect() });
            forcings.extend(elastic.iter().map(|f| f as &dyn Forcing<T>));
            forcings.extend(bending.iter().map(|f| f as &dyn Forcing<T>));
            if let Some(s) = &surface {
                forcings.push(s);
            }
            let implicit = SumImplicit(implicit);
            let extra = (!implicit.0.is_empty()).then_some(&implicit as &dyn ImplicitTerm<T>);
            self.flow.prepare(dt, &SumForcing(forcings), extra)
        })();
        let flow_info = match flow_info {
            Ok(i) => i,
            Err(e) => return Err(self.abandon(e)),
        };
        // 6: G_s^{n+1}, beside the state.
        for c in 0..self.capsules.len() {
            let cap = &mut self.capsules[c];
            if let (Some(strain), Some(gs)) = (cap.strain.as_mut(), cap.gs.as_mut()) {
                gs.fill_ghosts(grid);
                let r = strain.prepare(
                    grid,
                    &cap.next.band,
                    dt,
                    self.flow.velocity(),
                    self.flow.proposed_velocity(),
                    &cap.next.normal,
                    gs,
                );
                if let Err(e) = r {
                    return Err(self.abandon(e));
                }
            }
        }
        // The energy ledger, from the step's midpoint velocity.
        let (dissipated, work) = match self.step_integrals(dt) {
            Ok(i) => i,
            Err(e) => return Err(self.abandon(e)),
        };
        // Commit.
        if let Some((l, _)) = self.ledger.as_mut() {
            l.dissipated += dissipated;
            l.work += work;
        }
        if let Some(v_old) = self.v_old.as_mut() {
            v_old.copy_from(self.flow.velocity());
        }
        self.flow.commit(dt);
        let mut band_cells = 0;
        for cap in &mut self.capsules {
            if let (Some(strain), Some(gs)) = (cap.strain.as_mut(), cap.gs.as_mut()) {
                strain.commit(&cap.next.band, &cap.next.normal, gs);
                if self.settings.tangential_gs {
                    let n = &cap.next.normal;
                    for &idx in cap.next.band.cells() {
                        let p = projector(&cell_vector(n, idx));
                        gs.set(idx, &project(&p, &gs.get(idx)));
                    }
                }
            }
            cap.commit();
            cap.restore_reference_area(grid);
            band_cells += cap.cur.band.len();
        }
        Ok(StepReport { flow: flow_info, profile_cells, band_cells })
    }

    /// `dt Phi(v^{n+1/2})` and `dt f^n . v^{n+1/2}` of the prepared step (see
    /// [`StepIntegrals`]; zeros without a ledger, nothing computed), with the materials and capsule levels of step `n + 1` and the external
    /// forces at `t^n`, as the flow step used them.
    fn step_integrals(&mut self, dt: T) -> Result<(f64, f64)> {
        let g = &self.grid;
        let Some((_, half)) = self.ledger.as_mut() else { return Ok((0.0, 0.0)) };
        let (v0, v1) = (self.flow.velocity(), self.flow.proposed_velocity());
        for d in 0..3 {
            for ((h, &a), &b) in half.c[d].data.iter_mut().zip(&v0.c[d].data).zip(&v1.c[d].data) {
                *h = T::lit(0.5) * (a + b);
            }
        }
        let half = &*half;
        let m = self.flow.materials();
        let dissipation = viscous_dissipation(g, half, &m.mu, DissipationForm::Discrete)?;
        let levels = self.capsules.iter().map(|c| &c.next).collect();
        let power = external_power(
            g,
            &self.body_force,
            self.surface_force.as_deref(),
            levels,
            self.flow.time(),
            v0,
            half,
            &mut self.force,
        )?;
        Ok((dt.f64() * dissipation, dt.f64() * power))
    }

    /// Starts the energy ledger: from now on every step adds `dt Phi(v^{n+1/2})` and
    /// `dt f^n . v^{n+1/2}` to the [`StepIntegrals`] that [`energy`](Self::energy) reports, the
    /// terms of the scheme's own kinetic-energy balance (an [`EnergyBudget`] built from them
    /// does not see the spurious jumps of the trapezoid rule where a force switches on or off).
    /// Costs one pass over the box per step and one velocity field; a second call restarts the
    /// integrals at zero. Checkpoints do not hold the ledger.
    ///
    /// [`EnergyBudget`]: crate::diagnostics::EnergyBudget
    pub fn track_energy(&mut self) {
        let half = match self.ledger.take() {
            Some((_, h)) => h,
            None => VectorField::zeros(&self.grid),
        };
        self.ledger = Some((StepIntegrals::default(), half));
    }

    /// Rolls back the prepared parts of a failed step and returns its error.
    fn abandon(&mut self, e: Error) -> Error {
        for cap in &mut self.capsules {
            cap.discard();
        }
        self.update_materials(false);
        e
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
    /// Whether the membranes have in-plane elasticity.
    pub fn has_elasticity(&self) -> bool {
        self.law.is_some()
    }
    /// Whether the membranes bend.
    pub fn has_bending(&self) -> bool {
        self.capsules.first().is_some_and(|c| c.bending.is_some())
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

    /// `phi` of capsule `c` (1 inside, 0 outside).
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
    /// [`Settings::conserve_reference_area`] holds from then on.
    ///
    /// # Errors
    /// `lambda` not finite and `> 0`; a scene without elasticity; an unknown capsule.
    pub fn prestretch(&mut self, c: usize, lambda: T) -> Result<()> {
        positive("lambda", lambda)?;
        self.capsule(c)?;
        let grid = &self.grid;
        let cap = &mut self.capsules[c];
        let Some(gs) = cap.gs.as_mut() else {
            return Err(Error::invalid(
                "prestretch",
                "a scene without elasticity",
                "a scene with Scene::elasticity",
            ));
        };
        crate::membrane::fill_projector(grid, &cap.cur.normal, gs);
        let l2 = lambda * lambda;
        for f in gs.c.iter_mut() {
            f.data.iter_mut().for_each(|x| *x *= l2);
        }
        gs.fill_ghosts(grid);
        if let Some(s) = cap.strain.as_mut() {
            s.reset_history();
        }
        cap.reset_reference_target(grid);
        Ok(())
    }

    /// Volume `sum phi h^3` of capsule `c`.
    pub fn volume(&self, c: usize) -> Result<f64> {
        crate::diagnostics::volume(&self.grid, self.phi(c)?)
    }
    /// Centroid (3.5) of capsule `c`.
    pub fn centroid(&self, c: usize) -> Result<[f64; 3]> {
        crate::diagnostics::centroid(&self.grid, self.phi(c)?)
    }
    /// Surface area `sum delta h^3` of capsule `c` (for the transported area (3.7), see
    /// [`AreaTracker`](crate::diagnostics::AreaTracker)).
    pub fn area(&self, c: usize) -> Result<f64> {
        crate::diagnostics::area_from_delta(&self.grid, self.delta(c)?)
    }

    /// Reference (unstressed) area `sum delta / j_s h^3` of the membrane of capsule `c`, with
    /// `j_s = sqrt(c2)` the local area dilation of `G_s` (`None` without elasticity). In the
    /// continuum it keeps its initial value; its drift measures how much the discrete
    /// transports of `G_s` (2.40) and of `phi` disagree on the change of area (with
    /// [`Settings::conserve_reference_area`] the step holds it at its initial value).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an unknown capsule.
    pub fn reference_area(&self, c: usize) -> Result<Option<f64>> {
        let cap = self.capsule(c)?;
        Ok(cap.reference_area(&self.grid))
    }

    /// Elastic energy `sum delta W_s / j_s h^3` over the membrane bands (zero without
    /// elasticity): `W_s` is an energy per unit *reference* area ((2.4) divides by
    /// `j_s = sqrt(c2)`), `delta h^3` an element of *current* area, `dA_R = dA / j_s`.
    pub fn elastic_energy(&self) -> f64 {
        let Some(law) = &self.law else { return 0.0 };
        let energy = |k: &SurfaceKinematics<T>| law.energy(k.c1, k.c2);
        self.capsules
            .iter()
            .filter_map(|cap| Some(reference_integral(&self.grid, &cap.cur, cap.gs.as_ref()?, energy)))
            .sum()
    }

    /// The terms of the energy budget of Sec. 3.2 at the current time: kinetic and elastic
    /// energy, viscous dissipation rate, the power of the body and surface forces and, after
    /// [`track_energy`](Self::track_energy), their step integrals (feed them to an
    /// [`EnergyBudget`](crate::diagnostics::EnergyBudget)).
    pub fn energy(&mut self) -> Result<EnergyState> {
        let g = &self.grid;
        let m = self.flow.materials();
        let v = self.flow.velocity();
        let kinetic = kinetic_energy(g, v, &m.rho)?;
        let dissipation_rate = viscous_dissipation(g, v, &m.mu, DissipationForm::Discrete)?;
        let levels = self.capsules.iter().map(|c| &c.cur).collect();
        let body_power = external_power(
            g,
            &self.body_force,
            self.surface_force.as_deref(),
            levels,
            self.flow.time(),
            v,
            v,
            &mut self.force,
        )?;
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

/// The power `sum f . w dV` of the body force and the surface force at `time` (with the
/// capsule `levels` and the velocity `v` the forces see), `f` assembled in `scratch`; zero
/// without either force.
#[allow(clippy::too_many_arguments)]
fn external_power<T: Real>(
    g: &Grid<T>,
    body: &BodyForce<T>,
    surface: Option<&SurfaceForceFn>,
    levels: Vec<&capsule::Level<T>>,
    time: T,
    v: &VectorField<T>,
    w: &VectorField<T>,
    scratch: &mut Option<VectorField<T>>,
) -> Result<f64> {
    if !body.is_active() && surface.is_none() {
        return Ok(0.0);
    }
    let f = scratch.get_or_insert_with(|| VectorField::zeros(g));
    for c in f.c.iter_mut() {
        c.fill(T::zero());
    }
    body.add(g, time, v, f);
    if let Some(sf) = surface {
        SurfaceForcing { f: sf, levels }.add(g, time, v, f);
    }
    body_force_power(g, w, f)
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
