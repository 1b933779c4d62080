//! What a simulation holds: the [`Scene`] builder (fluids, capsules, membrane effects, forces,
//! solver settings). A scene is a description; [`Scene::build`] validates it and allocates only
//! what its effects need (see the [module docs](super)).

use super::Simulation;
use super::effect::{Effect, Setup};
use super::effects::{Bending, Elasticity, SurfaceLoad};
use super::stability::effects_dt_limit;
use crate::error::positive;
use crate::fluid::{BodyForce, FlowConfig, MomentumSolver, PressureSolver, ViscousScheme};
use crate::grid::{Grid, Window};
use crate::interface::shapes::{Shape, Smoothing};
use crate::interface::{
    AdvectionParams, Advector, Carried, Geometry, InterfaceTransport, NormalEstimator, NormalScheme,
};
use crate::membrane::{StrainAdvection, SurfaceLaw};
use crate::{Error, Real, Result};

/// Density `rho` and dynamic viscosity `mu` of one fluid phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phase<T> {
    /// Density.
    pub rho: T,
    /// Dynamic viscosity.
    pub mu: T,
}

impl<T: Real> Phase<T> {
    /// A phase; errors unless both values are finite and `> 0`.
    pub fn new(rho: T, mu: T) -> Result<Self> {
        positive("rho", rho)?;
        positive("mu", mu)?;
        Ok(Phase { rho, mu })
    }
}

/// Grid-wide numerical settings of a [`Scene`]; the defaults are the ones validated in `docs/`.
///
/// The options of one term belong to that term: the membrane traction and the coupling of the
/// in-plane stress to [`Elasticity`] ([`Elasticity::traction`], [`Elasticity::coupling`]), the
/// bending force's form and coupling to [`Bending`] ([`Bending::form`], [`Bending::coupling`]).
///
/// # Choosing
/// Start from `Settings::default()` and change only what the case needs. The validated capsule
/// runs (`examples/capsule_in_shear.rs`, `cases/examples/shear_capsule.rs`) keep every setting
/// and change one option of the elasticity: [`Traction::Sharp`], which at 6–8 cells per radius
/// holds the membrane's reference area and cuts the overshoot of the deformation to a third
/// (the default [`Traction::Smoothed`] is the paper's). Everything else stays: the damped
/// viscous scheme `Theta(0.6)`, the band `epsilon = 0.01`, the quasi-implicit membrane
/// coupling, the semi-implicit bending. For many capsules in a large box,
/// [`storage`](Self::storage) `= CapsuleStorage::Boxed { room: 1.2 }` saves memory. The step
/// is not a setting: [`AdaptiveDt::new`](super::AdaptiveDt::new)`(0.05)` (Courant target 0.3)
/// chooses it; a fixed `dt` should keep the Courant number `max|v| dt / h` near 0.3 and below
/// [`Simulation::membrane_dt_limit`].
///
/// ```
/// use eulermembrane::simulation::{CapsuleStorage, Settings};
///
/// let settings = Settings::<f64> { storage: CapsuleStorage::Boxed { room: 1.2 }, ..Settings::default() };
/// assert_eq!(settings.epsilon, 0.01);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings<T> {
    /// Flow solver settings (viscous time scheme, predictor solver, tolerances). Default: those
    /// of [`FlowConfig`] but with the damped viscous scheme [`ViscousScheme::Theta`]`(0.6)`
    /// instead of the paper's Crank–Nicolson, which leaves the highest viscous modes undamped
    /// at the capsule cases' viscous numbers and fails at steps that `Theta(0.6)` takes
    /// (`docs/stability.md`); [`ViscousScheme::CrankNicolson`] reproduces the paper.
    pub flow: FlowConfig,
    /// Interface advection (MTHINC sharpness `beta`, normals of the reconstruction) of the
    /// default [`InterfaceTransport`], the [`Advector`].
    pub advection: AdvectionParams<T>,
    /// Normals of the membrane mechanics (the `n` of `P = I - n n` in the stress, the re-set of
    /// `G_s` and the bending curvature): the default [`NormalEstimator`], a [`Geometry`] with
    /// this scheme. Default [`NormalScheme::Atanh4`].
    pub normals: NormalScheme,
    /// The `epsilon` of the membrane band `delta h >= epsilon` (Sec. 2.2.2): outside it `G_s` is
    /// re-set to `P` and no membrane force acts. Default 0.01 (the band then carries 99 % of
    /// the membrane force; see [`crate::membrane::band`]).
    pub epsilon: T,
    /// Cell averaging of the initial shapes.
    pub smoothing: Smoothing,
    /// How `G_s` is carried from step to step. Default [`GsTransport::Paper`] (2.40).
    pub gs_transport: GsTransport,
    /// Whether the membrane's reference area is left to the transport or held. Default
    /// [`ReferenceArea::Transported`] (the paper's).
    pub reference_area: ReferenceArea,
    /// Face reconstruction in the advection of `G_s` (2.40). Default
    /// [`StrainAdvection::Upwind3`] (the paper's); [`StrainAdvection::Upwind5`] is more accurate
    /// and less dissipative.
    pub strain_advection: StrainAdvection,
    /// Where each capsule keeps its fields. Default [`CapsuleStorage::Whole`].
    pub storage: CapsuleStorage,
}

/// Where each capsule keeps its fields (`phi`, its geometry, `G_s`, the transports'
/// histories): on the whole grid, or on a box of cells that follows it ([`Window`]), so that
/// memory and the capsule's work follow the capsule, not the grid.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::NeoHookean;
/// use eulermembrane::simulation::{CapsuleStorage, Phase, Scene, Settings};
///
/// let grid = Grid::<f64>::periodic([48, 16, 16], [0.0; 3], [3.0, 1.0, 1.0])?;
/// let settings = Settings { storage: CapsuleStorage::Boxed { room: 1.2 }, ..Settings::default() };
/// let sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.5; 3], 0.25)?)
///     .elasticity(NeoHookean::new(1.0)?)
///     .settings(settings)
///     .build()?;
/// // 1.2 radii (4.8 cells) and 12 cells on each side along x; y and z are shorter: whole.
/// assert_eq!(sim.window(0)?.size(), [36, 16, 16]);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum CapsuleStorage {
    /// Every capsule on the whole grid.
    #[default]
    Whole,
    /// Each capsule on a box of whole cells around it: along each axis `room` times its
    /// [bounding radius](crate::interface::shapes::Shape::bounding_radius) and [`box_margin`]
    /// cells on each side of its centre (the whole axis where that is as long as the grid, and
    /// along a wall axis where it would reach past a wall). The box moves with the capsule by
    /// whole cells after each step, so that its membrane stays centred (along a wall axis
    /// between the walls); a capsule that grows out of it (its band within [`BOX_MIN_ROOM`]
    /// cells of a side, a wall's included) fails the step with an error naming `room`. A shape
    /// without a bounding radius keeps the whole grid.
    Boxed {
        /// The box's half-width in bounding radii, beyond the margin (`>= 1`: room for the
        /// capsule to deform, e.g. 1.2 for red cells, 1.6 for a capsule at `D` = 0.3).
        room: f64,
    },
}

/// The far field of the profile: the `phi` whose reach sets [`box_margin`].
const FAR_FIELD: f64 = 1e-10;

/// Cells between a capsule's bounding ball (times its room) and its box's sides at profile
/// sharpness `beta`: the reach `atanh(1 - 2e-10) / beta` (11.5 cells at `beta = 1`) of the
/// geometry, which is evaluated where `phi` lies in `(1e-10, 1 - 1e-10)`, rounded up. The box's
/// two ends meet beyond it, so nothing a capsule's kernels compute reaches across them: a boxed
/// capsule then follows the whole-grid one to `2e-8` of its elastic energy (at 8 cells less it
/// differs by `1e-6`; `tests/capsule_boxes.rs`).
pub fn box_margin(beta: f64) -> usize {
    ((1.0 - 2.0 * FAR_FIELD).atanh() / beta).ceil() as usize
}

/// The fewest cells between a membrane band and its box's side (the reach of the stencils).
pub const BOX_MIN_ROOM: usize = 4;

/// Which velocity carries and strains the membrane (`G_s`), and so where the in-plane membrane
/// force acts (it is the adjoint of that velocity's strain rate).
///
/// A capsule's traction is the one its effects ask for ([`Effect::requested_traction`]): its
/// [`Elasticity`] ([`Elasticity::traction`], the default [`Smoothed`](Self::Smoothed)) or a
/// [`SurfaceLoad`] given one ([`SurfaceLoad::traction`]; without, a load acts with the
/// capsule's traction); smoothed where none asks. [`Scene::build`] refuses two effects that ask
/// one capsule for different tractions.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::NeoHookean;
/// use eulermembrane::simulation::{Elasticity, Phase, Scene, Traction};
///
/// let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
/// let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.5; 3], 0.25)?)
///     .effect(Elasticity::new(NeoHookean::new(1.0)?).traction(Traction::from_name("sharp")?))
///     .build()?;
/// sim.step(1e-3)?;
/// // The velocity the membrane moves with: the fluid's, with the surface's tangential part.
/// let mut u = sim.velocity().clone();
/// sim.membrane_velocity(0, &mut u)?;
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Traction {
    /// The paper's: each layer of the smoothed shell moves with the fluid velocity at that
    /// layer, and the force `∇·(δ τ)` acts across the shell.
    #[default]
    Smoothed,
    /// Each layer of the shell slides with the tangential velocity of its closest point on the
    /// surface `phi = 1/2` (its normal velocity stays the local one), and the in-plane force
    /// acts there, spread by the transposed interpolation
    /// ([`SurfaceExtension`](crate::membrane::SurfaceExtension)); a
    /// [`surface force`](super::Scene::surface_force) on the capsule acts there too. `G_s` is
    /// projected onto the tangent plane after each step, as by [`GsTransport::Tangential`],
    /// whatever [`Settings::gs_transport`] says: without it the normal part of `G_s` grows and
    /// the steps shrink. Not in the paper. With [`MembraneCoupling::QuasiImplicit`] it needs
    /// the Krylov predictor.
    Sharp,
}

impl Traction {
    /// Every traction, the default first.
    pub const ALL: [Traction; 2] = [Traction::Smoothed, Traction::Sharp];

    /// The short name of the examples' `--traction` flag and their RESULT lines: `smoothed`,
    /// `sharp`.
    pub fn name(self) -> &'static str {
        match self {
            Traction::Smoothed => "smoothed",
            Traction::Sharp => "sharp",
        }
    }

    /// The traction of a [`name`](Self::name).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `traction` for any other name.
    pub fn from_name(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| Error::invalid("traction", s, "smoothed or sharp"))
    }
}

/// How the bending force enters the momentum predictor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BendingCoupling {
    /// The force of the shape at the start of the step (the paper's): stable for
    /// `dt <= C_BENDING mu h^3 / E_b` ([`crate::simulation::stability`]).
    Explicit,
    /// The force's stiff part linearised in the velocity and taken `alpha` of the way along the
    /// step, inside the predictor ([`BendingImplicit`](crate::membrane::BendingImplicit);
    /// `alpha` in `[0.5, 1]`: 0.5 would be second order but leaves the shortest waves
    /// undamped, and at large steps `alpha` 0.5 and 0.6 lose the shape where 1 holds it; see
    /// the measurements there). Stable to `dt <= 6 mu h^2 / E_b`
    /// ([`crate::simulation::stability`]). Not in the paper.
    SemiImplicit {
        /// The weight `alpha` of the step.
        alpha: f64,
    },
}

impl Default for BendingCoupling {
    fn default() -> Self {
        BendingCoupling::SemiImplicit { alpha: 1.0 }
    }
}

/// How the in-plane membrane stress enters the momentum predictor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MembraneCoupling {
    /// The paper's quasi-implicit stress (2.32)-(2.35): `τ* ≈ τⁿ + J' : ΔG_s` linearised in `v*`
    /// and solved with the predictor. Allows several times larger steps.
    #[default]
    QuasiImplicit,
    /// The explicit stress `τⁿ` only: cheaper per step, but stable only for small `Δt`. Kept as
    /// the reference for stability studies.
    Explicit,
}

/// How the surface deformation tensor `G_s` is carried from step to step. Only
/// [`Paper`](Self::Paper) is the paper's; the others repair the normal part of `G_s` that its
/// discrete transport lets grow (in the continuum `G_s n = 0`, (2.18)); see
/// `docs/architecture.md` ("Numerical options beyond the paper") and
/// `docs/validation/squashed_sphere.md` for what each gains and costs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GsTransport {
    /// The transport (2.40) and the re-set to `P` off the band.
    #[default]
    Paper,
    /// (2.40), then the projection `G_s <- P G_s P` with the new normals on the band.
    Tangential,
    /// (2.40) in the tangent frame ([`StrainTransport::with_tangent_frame`]): each stencil
    /// value is turned into the cell's tangent plane, and the stretching term leaves out that
    /// turn of the frame along the path.
    ///
    /// [`StrainTransport::with_tangent_frame`]: crate::membrane::StrainTransport::with_tangent_frame
    TangentFrame,
    /// [`TangentFrame`](Self::TangentFrame), then the projection of
    /// [`Tangential`](Self::Tangential).
    TangentFrameTangential,
}

impl GsTransport {
    /// Every transport, the default first.
    pub const ALL: [GsTransport; 4] = [
        GsTransport::Paper,
        GsTransport::Tangential,
        GsTransport::TangentFrame,
        GsTransport::TangentFrameTangential,
    ];

    /// The short name used by the examples' `--gs-transport` flag and their RESULT lines:
    /// `paper`, `tangential`, `frame`, `both`.
    pub fn name(self) -> &'static str {
        match self {
            GsTransport::Paper => "paper",
            GsTransport::Tangential => "tangential",
            GsTransport::TangentFrame => "frame",
            GsTransport::TangentFrameTangential => "both",
        }
    }

    /// The transport of a [`name`](Self::name).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `gs_transport` for any other name.
    pub fn from_name(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| Error::invalid("gs_transport", s, "paper, tangential, frame or both"))
    }

    /// Whether the advection works in the tangent frame.
    pub fn tangent_frame(self) -> bool {
        matches!(self, GsTransport::TangentFrame | GsTransport::TangentFrameTangential)
    }

    /// Whether `G_s` is projected onto the tangent plane after each step.
    pub fn projects(self) -> bool {
        matches!(self, GsTransport::Tangential | GsTransport::TangentFrameTangential)
    }
}

/// Whether the membrane's reference (unstressed) area `sum delta / j_s h^3` is left to the
/// transports of `G_s` and `phi` or held at its initial value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ReferenceArea {
    /// Left to the transports (the paper's method); its drift measures their disagreement.
    #[default]
    Transported,
    /// `G_s` on each capsule's band is rescaled after every step so that the reference area
    /// keeps its initial value (or the one a pre-stretch left). Not in the paper.
    Conserved,
}

impl<T: Real> Default for Settings<T> {
    fn default() -> Self {
        Settings {
            // Damped viscous modes (see `ViscousScheme`): the paper's Crank-Nicolson fails at
            // a quarter of the steps this takes (docs/stability.md).
            flow: FlowConfig { viscous: ViscousScheme::Theta(0.6), ..FlowConfig::default() },
            advection: AdvectionParams::default(),
            normals: NormalScheme::Atanh4,
            epsilon: T::lit(0.01),
            smoothing: Smoothing::default(),
            gs_transport: GsTransport::default(),
            reference_area: ReferenceArea::default(),
            strain_advection: StrainAdvection::default(),
            storage: CapsuleStorage::default(),
        }
    }
}

impl<T: Real> Settings<T> {
    /// These settings with the profile sharpness `beta` (`beta' = beta / h`, (2.42)) in both
    /// places it enters: the initial shapes' [`smoothing`](Settings::smoothing) and the
    /// MTHINC transport's [`advection`](Settings::advection) (a capsule built with one and
    /// carried with another relaxes to the second in its first steps). Checked by
    /// [`Scene::build`] like the fields themselves.
    ///
    /// ```
    /// use eulermembrane::simulation::Settings;
    ///
    /// let s = Settings::<f64>::default().with_beta(2.0);
    /// assert_eq!((s.advection.beta, s.smoothing.beta), (2.0, 2.0));
    /// ```
    #[must_use]
    pub fn with_beta(mut self, beta: T) -> Self {
        self.advection.beta = beta;
        self.smoothing.beta = beta.f64();
        self
    }
}

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
/// use eulermembrane::membrane::NeoHookean;
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

/// What makes the [`InterfaceTransport`] of one capsule, given the grid and what the capsule
/// carries (see [`Scene::interface_transport`]).
pub type TransportMaker<T> = Box<dyn Fn(&Grid<T>, Carried) -> Result<Box<dyn InterfaceTransport<T>>>>;

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
    /// [`NeoHookean`](crate::membrane::NeoHookean), [`Skalak`](crate::membrane::Skalak), or
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
    /// [`BendingForm::EnergyGradient`](crate::membrane::BendingForm::EnergyGradient) still
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
    /// [`FlowConfig::predictor`] names (see [`MomentumSolver`]).
    pub fn momentum_solver(mut self, solver: impl MomentumSolver<T> + 'static) -> Self {
        self.strategies.momentum = Some(Box::new(solver));
        self
    }

    /// Solves the pressure equation (2.36) with `solver` instead of the default
    /// [`SpectralPcg`](crate::fluid::SpectralPcg) (see [`PressureSolver`]).
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
    /// The first refusal found: [`Error::InvalidParameter`] naming the offending item,
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
    ///   [`BendingForm::EnergyGradient`](crate::membrane::BendingForm::EnergyGradient); a
    ///   [`Contact`](super::Contact)'s `range_cells` beyond what the profiles resolve; a user
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
    /// [`FlowStepper::new`](crate::fluid::FlowStepper::new)'s (invalid [`FlowConfig`]
    /// settings, more than one wall axis), a user's
    /// [`interface_transport`](Self::interface_transport) maker's or
    /// [`normal_estimator`](Self::normal_estimator)'s, and [`Error::Unsupported`] from an
    /// [`Advector`] asked for `NormalScheme::Deconvolved` or from a boxed capsule whose
    /// transport cannot move its history with the box ([`InterfaceTransport::roll`]).
    pub fn build(self) -> Result<Simulation<T>> {
        if let Some(e) = self.errors.into_iter().next() {
            return Err(e);
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
/// ([`Effect::requested_traction`]), [`Traction::Smoothed`] where none asks.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `traction` where two of them ask for different ones.
fn capsule_traction<T: Real>(effects: &[Box<dyn Effect<T>>], c: usize) -> Result<Traction> {
    let mut asked =
        effects.iter().filter(|e| e.acts_on(c)).filter_map(|e| Some((e.name(), e.requested_traction()?)));
    let Some((first, traction)) = asked.next() else { return Ok(Traction::default()) };
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
