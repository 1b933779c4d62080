//! What a simulation holds: the [`Scene`] builder (fluids, capsules, membrane effects, forces,
//! solver settings). A scene is a description; [`Scene::build`] validates it and allocates only
//! what its effects need (see the [module docs](super)).

use super::Simulation;
use super::effect::{Effect, Setup};
use super::effects::{Bending, Elasticity, SurfaceLoad};
use super::settings::{CapsuleStorage, Phase, Settings, Traction, TransportMaker, box_margin};
use super::stability::effects_dt_limit;
use crate::fluid::{forcing::BodyForce, momentum::MomentumSolver, projection::PressureSolver};
use crate::grid::{Grid, Window};
use crate::interface::shapes::Shape;
use crate::interface::{
    advect::{Advector, Carried, InterfaceTransport},
    geometry::{Geometry, NormalEstimator},
};
use crate::membrane::law::SurfaceLaw;
use crate::{Error, Real, Result};

/// A scene: the box, the fluids, the capsules and the effects to simulate. Build it with the
/// chained setters, then [`build`](Scene::build) a [`Simulation`].
///
/// Only what the scene holds is computed and stored: without [`elasticity`](Scene::elasticity)
/// no `G_s`, stress or Jacobian; without [`bending`](Scene::bending) no `kappa_R tilde` and no
/// curvature tensor; with equal viscosities inside and outside a constant-coefficient viscous
/// operator; with equal densities the direct FFT pressure solve.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::law::NeoHookean;
/// use eulermembrane::simulation::{Phase, Scene};
///
/// let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
/// let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.5; 3], 0.25)?)
///     .elasticity(NeoHookean::new(1.0)?)
///     .build()?;
/// let report = sim.step(1e-3)?;
/// assert_eq!(report.flow.step, 1);
/// assert!(!sim.has_bending());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub struct Scene<T: Real> {
    pub(crate) grid: Grid<T>,
    pub(crate) outside: Phase<T>,
    pub(crate) inside: Phase<T>,
    pub(crate) capsules: Vec<Box<dyn Shape + Send>>,
    pub(crate) effects: Vec<Box<dyn Effect<T>>>,
    pub(crate) settings: Settings<T>,
    pub(crate) strategies: Strategies<T>,
    pub(crate) errors: Vec<Error>,
}

/// The strategies a user put in place of the defaults of [`Settings`] (`None`: the default).
#[derive(Default)]
pub(crate) struct Strategies<T: Real> {
    pub(crate) normals: Option<Box<dyn NormalEstimator<T>>>,
    pub(crate) transport: Option<TransportMaker<T>>,
    pub(crate) momentum: Option<Box<dyn MomentumSolver<T>>>,
    pub(crate) pressure: Option<Box<dyn PressureSolver<T>>>,
}

impl<T: Real> Strategies<T> {
    /// The normal estimator and the transport maker, the defaults of `settings` where the
    /// scene has none; the flow solvers stay optional (the flow stepper builds its defaults).
    pub(crate) fn interface(
        &mut self,
        grid: &Grid<T>,
        settings: &Settings<T>,
    ) -> (Box<dyn NormalEstimator<T>>, TransportMaker<T>) {
        let normals = self.normals.take().unwrap_or_else(|| Box::new(Geometry::new(grid, settings.normals)));
        let params = settings.advection;
        let transport = self.transport.take().unwrap_or_else(|| {
            Box::new(move |g: &Grid<T>, carried: Carried| -> Result<Box<dyn InterfaceTransport<T>>> {
                Ok(Box::new(Advector::new(g, params, carried)?))
            })
        });
        (normals, transport)
    }
}

impl<T: Real> Scene<T> {
    /// A scene on `grid` filled with `fluid`, which is also the fluid inside capsules until
    /// [`inside`](Scene::inside) says otherwise.
    pub fn new(grid: Grid<T>, fluid: Phase<T>) -> Self {
        Scene {
            grid,
            outside: fluid,
            inside: fluid,
            capsules: Vec::new(),
            effects: Vec::new(),
            settings: Settings::default(),
            strategies: Strategies::default(),
            errors: Vec::new(),
        }
    }

    /// The fluid inside the capsules (the paper's viscosity contrast `lambda = mu_in / mu_out`).
    pub fn inside(mut self, fluid: Phase<T>) -> Self {
        self.inside = fluid;
        self
    }

    /// Adds a capsule of the given initial shape (in its reference, unstressed state). Each
    /// capsule has its own `phi`, so capsules that touch do not merge.
    pub fn capsule(mut self, shape: impl Shape + Send + 'static) -> Self {
        self.capsules.push(Box::new(shape));
        self
    }

    /// Adds an effect (see [`Effect`]): the paper's [`Elasticity`], [`Bending`],
    /// [`SurfaceLoad`], a [`BodyForce`], or a user's own. A `Box<dyn Effect<T>>` chosen at run
    /// time is an effect too. The explicit forces are summed in the order the effects were
    /// added.
    pub fn effect(mut self, effect: impl Effect<T> + 'static) -> Self {
        self.effects.push(Box::new(effect));
        self
    }

    /// In-plane elasticity of every membrane with the law `law` (e.g.
    /// [`NeoHookean`](crate::membrane::law::NeoHookean), [`Skalak`](crate::membrane::law::Skalak), or
    /// any user [`SurfaceLaw`]): [`effect`](Self::effect) with [`Elasticity::new`], the default
    /// traction and coupling. For others add the effect with them
    /// (`.effect(Elasticity::new(law).traction(Traction::Sharp))`); for a law per capsule, one
    /// [`Elasticity`] per law with [`Elasticity::only`].
    pub fn elasticity(self, law: impl SurfaceLaw<T> + 'static) -> Self {
        self.effect(Elasticity::new(law))
    }

    /// Bending of every membrane with modulus `eb` (`E_b` of (2.8)): [`effect`](Self::effect)
    /// with [`Bending::new`], the default form and coupling (an invalid `eb` is reported by
    /// [`build`](Self::build)). For others add the effect with them
    /// (`.effect(Bending::new(eb)?.coupling(BendingCoupling::Explicit))`).
    pub fn bending(mut self, eb: T) -> Self {
        match Bending::new(eb) {
            Ok(b) => self.effect(b),
            Err(e) => {
                self.errors.push(e);
                self
            }
        }
    }

    /// A uniform body force density (force per unit volume), e.g. a pressure gradient:
    /// [`effect`](Self::effect) with [`BodyForce::new`] (a non-finite component is reported by
    /// [`build`](Self::build)).
    pub fn body_force(mut self, f: [T; 3]) -> Self {
        for (d, name) in ["body_force[0]", "body_force[1]", "body_force[2]"].into_iter().enumerate() {
            if let Err(e) = crate::error::finite(name, f[d]) {
                self.errors.push(e);
                return self;
            }
        }
        match BodyForce::new(f) {
            Ok(b) => self.effect(b),
            Err(e) => {
                self.errors.push(e);
                self
            }
        }
    }

    /// A force per unit area `f(x, t)` on every membrane: [`effect`](Self::effect) with
    /// [`SurfaceLoad::new`] (acting with each capsule's traction).
    pub fn surface_force(self, f: impl Fn([f64; 3], f64) -> [f64; 3] + Send + Sync + 'static) -> Self {
        self.effect(SurfaceLoad::new(f))
    }

    /// Numerical settings (replaces the defaults).
    pub fn settings(mut self, settings: Settings<T>) -> Self {
        self.settings = settings;
        self
    }

    /// Estimates the capsules' normals with `estimator` instead of [`Settings::normals`] (see
    /// [`NormalEstimator`]; one estimator serves every capsule, in turn).
    /// [`BendingForm::EnergyGradient`](crate::membrane::bending::BendingForm::EnergyGradient) still
    /// differences `psi` with the stencil of [`Settings::normals`].
    pub fn normal_estimator(mut self, estimator: impl NormalEstimator<T> + 'static) -> Self {
        self.strategies.normals = Some(Box::new(estimator));
        self
    }

    /// Carries each capsule's interface with the [`InterfaceTransport`] that `make` returns
    /// (called once per capsule by [`build`](Self::build), with what the capsule must carry)
    /// instead of the [`Advector`] with [`Settings::advection`].
    pub fn interface_transport(
        mut self,
        make: impl Fn(&Grid<T>, Carried) -> Result<Box<dyn InterfaceTransport<T>>> + 'static,
    ) -> Self {
        self.strategies.transport = Some(Box::new(make));
        self
    }

    /// Solves the momentum predictor (2.35) with `solver` instead of the one
    /// [`FlowConfig::predictor`](crate::fluid::stepper::FlowConfig::predictor) names (see [`MomentumSolver`]).
    pub fn momentum_solver(mut self, solver: impl MomentumSolver<T> + 'static) -> Self {
        self.strategies.momentum = Some(Box::new(solver));
        self
    }

    /// Solves the pressure equation (2.36) with `solver` instead of the default
    /// [`SpectralPcg`](crate::fluid::projection::SpectralPcg) (see [`PressureSolver`]).
    pub fn pressure_solver(mut self, solver: impl PressureSolver<T> + 'static) -> Self {
        self.strategies.pressure = Some(Box::new(solver));
        self
    }

    /// The grid.
    pub fn grid(&self) -> &Grid<T> {
        &self.grid
    }

    /// Validates the scene and builds the simulation at rest at `t = 0`.
    ///
    /// # Errors
    /// [`Error::Unsupported`] on a part of a decomposed grid ([`Grid::split`]: capsules are not
    /// decomposed yet). Then the first refusal found: [`Error::InvalidParameter`] naming the
    /// offending item,
    /// - what a setter was given: `eb` of [`bending`](Self::bending) not finite and `> 0`, a
    ///   non-finite `body_force[d]`;
    /// - `rho` or `mu` of a [`Phase`] not finite and `> 0`; `epsilon` outside `(0, 1)`;
    ///   `CapsuleStorage::Boxed room` not finite and `>= 1`;
    /// - each effect's [`Effect::attach`] (in the order they were added): a membrane effect
    ///   (`elasticity`, `bending`, `surface_force`, `contact`) in a scene without capsules, or
    ///   whose `only` list is empty or names a capsule the scene lacks; `elasticity` with a law
    ///   whose small-strain moduli are not positive, `law` with stress at rest or without
    ///   finite derivatives there; `traction`: an elasticity with [`Traction::Sharp`] and the
    ///   quasi-implicit coupling under the SOR predictor; `normals` other than
    ///   `atanh2`/`atanh4` with a bending of
    ///   [`BendingForm::EnergyGradient`](crate::membrane::bending::BendingForm::EnergyGradient); a
    ///   [`Contact`](super::contact::Contact)'s `range_cells` beyond what the profiles resolve; a user
    ///   effect's own errors;
    /// - `elasticity` or `bending`: two such effects acting on one capsule (their forces would
    ///   add up), naming the capsule;
    /// - `traction`: two effects that ask one capsule for different tractions
    ///   ([`Effect::requested_traction`]), naming the capsule and the effects;
    /// - `dt_limit`: an effect whose [`Effect::dt_limit`] is not finite and `> 0`, naming the
    ///   effect;
    /// - `capsule`, naming it: a shape of another dimension than the grid (2 on a grid with one
    ///   cell along z, else 3); a capsule within two profile widths (`4 h / beta`) of a wall or
    ///   across it, smaller than a sphere of one cell's radius, or as long as a periodic axis;
    /// - the settings the capsules' fields are made with: `Smoothing::beta`,
    ///   `Smoothing::points`, `AdvectionParams::beta` (in `(0, 10]`), `AdvectionParams::tiny`;
    ///
    /// and the errors of the solvers and strategies as they are made:
    /// [`FlowStepper::new`](crate::fluid::stepper::FlowStepper::new)'s (invalid [`FlowConfig`](crate::fluid::stepper::FlowConfig)
    /// settings, more than one wall axis), a user's
    /// [`interface_transport`](Self::interface_transport) maker's or
    /// [`normal_estimator`](Self::normal_estimator)'s, and [`Error::Unsupported`] from an
    /// [`Advector`] asked for `NormalScheme::Deconvolved` or from a boxed capsule whose
    /// transport cannot move its history with the box ([`InterfaceTransport::roll`]).
    pub fn build(self) -> Result<Simulation<T>> {
        if let Some(e) = self.errors.into_iter().next() {
            return Err(e);
        }
        if self.grid.is_split() {
            return Err(Error::Unsupported {
                component: "Scene",
                detail: "a part of a decomposed grid: capsules are not decomposed yet (a flow without \
                         capsules runs on parts with fluid::stepper::FlowStepper)"
                    .into(),
            });
        }
        Phase::new(self.outside.rho, self.outside.mu)?;
        Phase::new(self.inside.rho, self.inside.mu)?;
        let eps = self.settings.epsilon;
        if !(eps > T::zero() && eps < T::one()) {
            return Err(Error::invalid("epsilon", eps, "a number in (0, 1), e.g. 0.01"));
        }
        let (storage, beta) = (self.settings.storage, self.settings.advection.beta.f64());
        let windows = self
            .capsules
            .iter()
            .map(|s| window(&self.grid, storage, beta, s.as_ref()))
            .collect::<Result<Vec<_>>>()?;
        let mut effects = self.effects;
        let capsule_grids: Vec<Grid<T>> = windows.iter().map(|w| w.grid(&self.grid)).collect();
        let setup = Setup {
            grid: &self.grid,
            settings: &self.settings,
            outside: self.outside,
            inside: self.inside,
            capsules: self.capsules.len(),
            capsule_grids: &capsule_grids,
        };
        for e in effects.iter_mut() {
            e.attach(&setup)?;
        }
        // One elasticity and one bending a capsule: two would add their forces silently.
        for c in 0..self.capsules.len() {
            for (name, allowed) in [
                ("elasticity", "one Elasticity a capsule (Elasticity::only gives capsules different laws)"),
                ("bending", "one Bending a capsule (Bending::only gives capsules different moduli)"),
            ] {
                if effects.iter().filter(|e| e.name() == name && e.acts_on(c)).count() > 1 {
                    return Err(Error::invalid(name, format!("two {name} effects on capsule {c}"), allowed));
                }
            }
        }
        let tractions =
            (0..self.capsules.len()).map(|c| capsule_traction(&effects, c)).collect::<Result<Vec<_>>>()?;
        effects_dt_limit(&effects, &setup)?;
        let dim = if self.grid.is_2d() { 2 } else { 3 };
        for (c, s) in self.capsules.iter().enumerate() {
            if s.dimension() != dim {
                return Err(Error::invalid(
                    "capsule",
                    format!("capsule {c} of dimension {} on a grid of dimension {dim}", s.dimension()),
                    "a shape of the grid's dimension (2 on a grid with one cell along z, else 3)",
                ));
            }
        }
        Simulation::from_scene(
            self.grid,
            self.outside,
            self.inside,
            self.capsules.into_iter().zip(windows).zip(tractions).map(|((s, w), t)| (s, w, t)).collect(),
            effects,
            self.settings,
            self.strategies,
        )
    }
}

/// The traction of capsule `c`: the one the effects acting on it ask for
/// ([`Effect::requested_traction`]), [`Traction::Smoothed`] where none asks (no elasticity reads
/// a membrane velocity map then, so none is built).
///
/// # Errors
/// [`Error::InvalidParameter`] naming `traction` where two of them ask for different ones.
fn capsule_traction<T: Real>(effects: &[Box<dyn Effect<T>>], c: usize) -> Result<Traction> {
    let mut asked =
        effects.iter().filter(|e| e.acts_on(c)).filter_map(|e| Some((e.name(), e.requested_traction()?)));
    let Some((first, traction)) = asked.next() else { return Ok(Traction::Smoothed) };
    match asked.find(|&(_, t)| t != traction) {
        None => Ok(traction),
        Some((other, t)) => Err(Error::invalid(
            "traction",
            format!(
                "{first} asks capsule {c} for the {} traction, {other} for the {}",
                traction.name(),
                t.name()
            ),
            "one traction a capsule: the same Traction for every effect on it",
        )),
    }
}

/// The box of `shape`'s fields on `g` by `storage` (see [`CapsuleStorage`]).
fn window<T: Real>(g: &Grid<T>, storage: CapsuleStorage, beta: f64, shape: &dyn Shape) -> Result<Window> {
    match (storage, shape.center(), shape.bounding_radius()) {
        (CapsuleStorage::Boxed { room }, Some(c), Some(r)) => {
            if !(room.is_finite() && room >= 1.0) {
                return Err(Error::invalid("CapsuleStorage::Boxed room", room, "a number >= 1"));
            }
            let r = room * r;
            Window::around(g, c.map(|x| x - r), c.map(|x| x + r), box_margin(beta))
        }
        _ => Ok(Window::whole(g)),
    }
}
