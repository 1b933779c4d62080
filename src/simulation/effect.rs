//! The [`Effect`] trait: one piece of physics of a [`Scene`](super::Scene) (the paper's in-plane
//! elasticity and bending, a surface load, a body force, or a user's own), and what the
//! simulation shows an effect while it computes a step.
//!
//! An effect declares what it needs the capsules to carry ([`Needs`]: `G_s`, `kappa_R tilde`)
//! and on which capsules it acts; the simulation allocates those fields only for the capsules
//! that some effect needs them on. Each step the simulation
//! 1. advects every capsule's `phi` (and `kappa_R tilde`) and derives its geometry at
//!    `t^{n+1}`;
//! 2. calls [`Effect::prepare`] of every effect in the order they were added, with a
//!    [`StepState`] that shows the capsules at `t^{n+1}` (their `G_s` still at `t^n`), and the
//!    velocity `v^n`; a failing `prepare` fails the step and leaves the state as it was;
//! 3. sums the explicit forces [`Effect::add_force`] in the order the effects were added (and
//!    the quasi-implicit terms [`Effect::add_implicit`] inside the predictor's operator), so that
//!    a run is reproducible to the bit.
//!
//! # A user's effect
//!
//! A spring tether that pulls every capsule's membrane towards a point with a force per unit area
//! `k (x0 - x)`, spread on the faces as `delta f` like every surface force (2.26):
//!
//! ```
//! use eulermembrane::grid::{Grid, VectorField};
//! use eulermembrane::interface::shapes::Sphere;
//! use eulermembrane::membrane::law::NeoHookean;
//! use eulermembrane::simulation::{effect::Effect, Phase, Scene, effect::StepState};
//! use eulermembrane::Result;
//!
//! struct Tether {
//!     k: f64,
//!     anchor: [f64; 3],
//! }
//!
//! impl Effect<f64> for Tether {
//!     fn name(&self) -> &str {
//!         "tether"
//!     }
//!     fn add_force(&self, state: &StepState<f64>, _v: &VectorField<f64>, out: &mut VectorField<f64>) -> Result<()> {
//!         let g = state.grid;
//!         for c in 0..state.capsule_count() {
//!             let m = state.membrane(c)?;
//!             for (&idx, ijk) in m.band.cells().iter().zip(m.band.coords(0)) {
//!                 let [i, j, k] = ijk.map(|x| x as isize);
//!                 for d in 0..3 {
//!                     let x = g.face_center(d, i, j, k);
//!                     out.c[d].values_mut()[idx] += m.delta.values()[idx] * self.k * (self.anchor[d] - x[d]);
//!                 }
//!             }
//!         }
//!         Ok(())
//!     }
//! }
//!
//! let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
//! let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
//!     .capsule(Sphere::new([0.5; 3], 0.25)?)
//!     .elasticity(NeoHookean::new(1.0)?)
//!     .effect(Tether { k: 0.5, anchor: [0.6, 0.5, 0.5] })
//!     .build()?;
//! for _ in 0..5 {
//!     sim.step(1e-3)?;
//! }
//! assert!(sim.centroid(0)?[0] > 0.5); // pulled towards x = 0.6
//! # Ok::<(), eulermembrane::Error>(())
//! ```

use super::capsule::Capsule;
use super::settings::{Phase, Settings, Traction};
use super::view::{LevelChoice, MembraneView, Needs};
use crate::grid::{Grid, VectorField};
use crate::membrane::law::SurfaceLaw;
use crate::{Error, Real, Result};

/// How the energy budget ([`Simulation::energy`](super::Simulation::energy)) counts an effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EnergyRole {
    /// An external force: its power `sum f . v dV` is work done on the system (body forces,
    /// surface loads, a user's tether).
    #[default]
    Work,
    /// An internal, conservative force: it stores the energy [`Effect::stored_energy`], and its
    /// power is not counted as work (membrane elasticity and bending).
    Stored,
}

/// Which capsules of a scene an effect acts on.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Capsules {
    /// Every capsule.
    #[default]
    All,
    /// The capsules with these indices (in the order they were added to the scene).
    Only(Vec<usize>),
}

impl Capsules {
    /// Whether capsule `c` is among them.
    pub fn contains(&self, c: usize) -> bool {
        match self {
            Capsules::All => true,
            Capsules::Only(v) => v.contains(&c),
        }
    }

    /// `Ok` if every index is a capsule of a scene with `count` capsules and at least one
    /// capsule is selected; else [`Error::InvalidParameter`] naming `effect`.
    pub fn validate(&self, effect: &'static str, count: usize) -> Result<()> {
        if count == 0 {
            return Err(Error::invalid(
                effect,
                "a membrane effect in a scene without capsules",
                "at least one capsule (Scene::capsule) for membrane effects",
            ));
        }
        if let Capsules::Only(v) = self {
            if v.is_empty() {
                return Err(Error::invalid(effect, "an empty capsule list", "at least one capsule index"));
            }
            if let Some(&c) = v.iter().find(|&&c| c >= count) {
                return Err(Error::invalid(
                    effect,
                    format!("capsule {c} (of {count} capsules)"),
                    "indices of capsules of the scene",
                ));
            }
        }
        Ok(())
    }
}

/// What an effect sees when the simulation is built ([`Effect::attach`]) and when it asks for
/// its time-step limit ([`Effect::dt_limit`]).
#[derive(Debug, Clone, Copy)]
pub struct Setup<'a, T: Real> {
    /// The grid.
    pub grid: &'a Grid<T>,
    /// The scene's numerical settings.
    pub settings: &'a Settings<T>,
    /// The fluid outside the capsules.
    pub outside: Phase<T>,
    /// The fluid inside the capsules.
    pub inside: Phase<T>,
    /// Number of capsules in the scene.
    pub capsules: usize,
    /// The grid of each capsule's box.
    pub(crate) capsule_grids: &'a [Grid<T>],
}

impl<T: Real> Setup<'_, T> {
    /// The grid of capsule `c`'s box, where its fields live (the simulation's grid where the box
    /// is the whole grid): the grid of a membrane effect's work arrays for that capsule.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an index out of range.
    pub fn capsule_grid(&self, c: usize) -> Result<&Grid<T>> {
        self.capsule_grids.get(c).ok_or_else(|| {
            Error::invalid("capsule", format!("{c} (of {} capsules)", self.capsules), "a capsule index")
        })
    }

    /// Mean of the inner and outer viscosities (the `mu` of the membrane time-step rules).
    pub fn mean_viscosity(&self) -> f64 {
        0.5 * (self.inside.mu + self.outside.mu).f64()
    }

    /// Smallest grid spacing.
    pub fn min_spacing(&self) -> f64 {
        self.grid.h().iter().fold(f64::INFINITY, |m, x| m.min(x.f64()))
    }
}

/// What an effect sees while a step is computed: the grid, the settings, the time `t^n` and the
/// capsules' membranes (at `t^{n+1}` during a step, with `G_s` at `t^n`, as the paper's (2.35)
/// evaluates the membrane forces; at the current time when the energy budget asks). The
/// velocity comes as an argument where an effect may use it.
pub struct StepState<'a, T: Real> {
    /// The grid.
    pub grid: &'a Grid<T>,
    /// The scene's numerical settings.
    pub settings: &'a Settings<T>,
    /// The time `t^n` at the start of the step.
    pub time: T,
    pub(crate) capsules: &'a [Capsule<T>],
    pub(crate) level: LevelChoice,
}

impl<'a, T: Real> StepState<'a, T> {
    /// Number of capsules.
    pub fn capsule_count(&self) -> usize {
        self.capsules.len()
    }

    /// The membrane of capsule `c`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `capsule` for an index out of range.
    pub fn membrane(&self, c: usize) -> Result<MembraneView<'a, T>> {
        let cap = self.capsules.get(c).ok_or_else(|| {
            Error::invalid("capsule", format!("{c} (of {} capsules)", self.capsules.len()), "a capsule index")
        })?;
        Ok(cap.view(self.level))
    }
}

/// One piece of physics in a [`Scene`](super::Scene): a force on the fluid, explicit
/// ([`add_force`](Self::add_force)) and optionally quasi-implicit
/// ([`add_implicit`](Self::add_implicit)), with the state it needs. The paper's membrane
/// ([`Elasticity`](super::Elasticity), [`Bending`](super::Bending)), the loads
/// ([`SurfaceLoad`](super::SurfaceLoad), [`BodyForce`](crate::fluid::forcing::BodyForce)) and a user's
/// effects are all effects; see the [module docs](self) for the order of calls and an example.
///
/// Every method but [`name`](Self::name) and [`add_force`](Self::add_force) has a default: an
/// effect that needs nothing, acts on every capsule, does work on the fluid, limits no time
/// step and has no implicit part.
pub trait Effect<T: Real>: Send + Sync {
    /// A short snake_case name, for error messages and checkpoints.
    fn name(&self) -> &str;

    /// The effect and its parameters in one line, recorded in checkpoints: a checkpoint is
    /// restored only into a scene whose effects describe themselves the same way. The default
    /// is the [`name`](Self::name); include every parameter that changes the physics.
    fn describe(&self) -> String {
        self.name().to_string()
    }

    /// The fields this effect needs on the capsules it [acts on](Self::acts_on).
    fn needs(&self) -> Needs {
        Needs::NONE
    }

    /// The [`Traction`] this effect asks for on the capsules it [acts on](Self::acts_on), if it
    /// has a say (`None`: it acts with whatever traction the capsule has). A capsule with the
    /// sharp traction carries the membrane velocity map ([`MembraneView::extension`]) and has
    /// `G_s` projected onto the tangent plane after each step; two effects that ask one capsule
    /// for different tractions are refused by [`Scene::build`](super::Scene::build). Default:
    /// `None`.
    fn requested_traction(&self) -> Option<Traction> {
        None
    }

    /// Whether the effect acts on capsule `c` (for [`needs`](Self::needs)). Default: all.
    fn acts_on(&self, c: usize) -> bool {
        let _ = c;
        true
    }

    /// How the energy budget counts this effect.
    fn energy_role(&self) -> EnergyRole {
        EnergyRole::Work
    }

    /// Called once by [`Scene::build`](super::Scene::build), in the order the effects were
    /// added: validate the effect against the scene and allocate its work arrays.
    ///
    /// # Errors
    /// Anything that makes the effect meaningless in this scene (e.g. a membrane effect without
    /// capsules); `build` returns it.
    fn attach(&mut self, setup: &Setup<'_, T>) -> Result<()> {
        let _ = setup;
        Ok(())
    }

    /// Called between steps when capsule `c`'s box has grown
    /// ([`CapsuleStorage::Boxed`](super::CapsuleStorage::Boxed)): its fields now live on
    /// [`setup.capsule_grid(c)`](Setup::capsule_grid), where the effect's work arrays for that
    /// capsule must be made anew. Default: [`attach`](Self::attach) again, which serves an
    /// effect that allocates its work arrays there and keeps nothing from one step to the next.
    ///
    /// # Errors
    /// As [`attach`](Self::attach); the step that grew the box then reports it.
    fn box_resized(&mut self, c: usize, setup: &Setup<'_, T>) -> Result<()> {
        let _ = c;
        self.attach(setup)
    }

    /// The largest stable `dt` this effect allows in this scene (`None`: no limit), finite and
    /// `> 0`: [`Scene::build`](super::Scene::build), every step and every [`AdaptiveDt`] step
    /// refuse any other value with an error naming `dt_limit` and this effect's
    /// [`name`](Self::name). A step with a larger `dt` is still taken, and its
    /// [`StepReport`](super::StepReport) carries
    /// [`StepWarning::DtAboveLimit`](super::StepWarning::DtAboveLimit).
    ///
    /// [`AdaptiveDt`]: super::timestep::AdaptiveDt
    fn dt_limit(&self, setup: &Setup<'_, T>) -> Option<f64> {
        let _ = setup;
        None
    }

    /// Evaluates what the force of the step `dt` needs (see the [module docs](self)), given
    /// the velocity `v^n` (staggered, ghosts filled).
    ///
    /// # Errors
    /// Anything that keeps the force from being evaluated; the step then fails and leaves the
    /// state as it was.
    fn prepare(&mut self, state: &StepState<'_, T>, velocity: &VectorField<T>, dt: T) -> Result<()> {
        let _ = (state, velocity, dt);
        Ok(())
    }

    /// Whether the effect adds any force this step (an inactive effect is not evaluated and
    /// costs nothing). Default: active.
    fn is_active(&self, state: &StepState<'_, T>) -> bool {
        let _ = state;
        true
    }

    /// Adds the explicit force density (force per unit volume) on the faces of the staggered
    /// grid to `out` (component `d` on the faces normal to `d`; wall faces are ignored), given
    /// the velocity `v^n` (staggered, ghosts filled).
    ///
    /// # Errors
    /// Anything that keeps the force from being evaluated; the step then fails.
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        velocity: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()>;

    /// Whether the effect has a quasi-implicit part this step. Default: no.
    fn has_implicit(&self, state: &StepState<'_, T>) -> bool {
        let _ = state;
        false
    }

    /// Adds the quasi-implicit term's contribution to `y = P x` of the predictor (2.35) on
    /// interior faces (ghosts of `x` filled), like
    /// [`ImplicitTerm::add_apply`](crate::fluid::momentum::ImplicitTerm::add_apply).
    ///
    /// # Errors
    /// As [`add_force`](Self::add_force).
    fn add_implicit(
        &self,
        state: &StepState<'_, T>,
        x: &VectorField<T>,
        y: &mut VectorField<T>,
    ) -> Result<()> {
        let _ = (state, x, y);
        Ok(())
    }

    /// The quasi-implicit term's contribution to `(P x)_c` at face `idx` (for the SOR
    /// reference solver), like [`ImplicitTerm::apply_at`](crate::fluid::momentum::ImplicitTerm::apply_at).
    fn implicit_at(&self, state: &StepState<'_, T>, x: &VectorField<T>, c: usize, idx: usize) -> T {
        let _ = (state, x, c, idx);
        T::zero()
    }

    /// The energy the effect stores at the state shown (for [`EnergyRole::Stored`]).
    fn stored_energy(&self, state: &StepState<'_, T>) -> f64 {
        let _ = state;
        0.0
    }

    /// The in-plane law this effect gives capsule `c`, if any (for the principal tensions of
    /// [`Simulation::write_vti`](super::Simulation::write_vti)).
    fn surface_law(&self, c: usize) -> Option<&dyn SurfaceLaw<T>> {
        let _ = c;
        None
    }
}

impl<T: Real> Effect<T> for Box<dyn Effect<T>> {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn needs(&self) -> Needs {
        (**self).needs()
    }
    fn requested_traction(&self) -> Option<Traction> {
        (**self).requested_traction()
    }
    fn acts_on(&self, c: usize) -> bool {
        (**self).acts_on(c)
    }
    fn energy_role(&self) -> EnergyRole {
        (**self).energy_role()
    }
    fn attach(&mut self, setup: &Setup<'_, T>) -> Result<()> {
        (**self).attach(setup)
    }
    fn box_resized(&mut self, c: usize, setup: &Setup<'_, T>) -> Result<()> {
        (**self).box_resized(c, setup)
    }
    fn dt_limit(&self, setup: &Setup<'_, T>) -> Option<f64> {
        (**self).dt_limit(setup)
    }
    fn prepare(&mut self, state: &StepState<'_, T>, velocity: &VectorField<T>, dt: T) -> Result<()> {
        (**self).prepare(state, velocity, dt)
    }
    fn is_active(&self, state: &StepState<'_, T>) -> bool {
        (**self).is_active(state)
    }
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        velocity: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        (**self).add_force(state, velocity, out)
    }
    fn has_implicit(&self, state: &StepState<'_, T>) -> bool {
        (**self).has_implicit(state)
    }
    fn add_implicit(
        &self,
        state: &StepState<'_, T>,
        x: &VectorField<T>,
        y: &mut VectorField<T>,
    ) -> Result<()> {
        (**self).add_implicit(state, x, y)
    }
    fn implicit_at(&self, state: &StepState<'_, T>, x: &VectorField<T>, c: usize, idx: usize) -> T {
        (**self).implicit_at(state, x, c, idx)
    }
    fn stored_energy(&self, state: &StepState<'_, T>) -> f64 {
        (**self).stored_energy(state)
    }
    fn surface_law(&self, c: usize) -> Option<&dyn SurfaceLaw<T>> {
        (**self).surface_law(c)
    }
}
