//! The numerical settings of a scene and the options its terms take: [`Settings`] (grid-wide),
//! [`Phase`], where capsules keep their fields ([`CapsuleStorage`]), and the options of the
//! membrane terms ([`Traction`], [`MembraneCoupling`], [`BendingCoupling`], [`GsTransport`],
//! [`ReferenceArea`]).

use crate::error::positive;
use crate::fluid::stepper::{FlowConfig, ViscousScheme};
use crate::grid::Grid;
use crate::interface::shapes::Smoothing;
use crate::interface::{
    advect::{AdvectionParams, Carried, InterfaceTransport},
    geometry::NormalScheme,
};
use crate::membrane::strain::StrainAdvection;
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

/// Grid-wide numerical settings of a [`Scene`](super::Scene); the defaults are the ones validated in `docs/`.
///
/// The options of one term belong to that term: the membrane traction and the coupling of the
/// in-plane stress to [`Elasticity`](super::Elasticity) ([`Elasticity::traction`](super::Elasticity::traction), [`Elasticity::coupling`](super::Elasticity::coupling)), the
/// bending force's form and coupling to [`Bending`](super::Bending) ([`Bending::form`](super::Bending::form), [`Bending::coupling`](super::Bending::coupling)).
///
/// # Choosing
/// Start from `Settings::default()` and change only what the case needs. The validated runs
/// (`examples/capsule_in_shear.rs` and the cases of `cases/examples`; `rbc_channel`'s red-cell
/// figures are still the paper's smoothed traction's) keep every setting: the
/// damped viscous scheme `Theta(0.6)`, the band `epsilon = 0.01`, the quasi-implicit membrane
/// coupling, the semi-implicit bending, and the elasticity's default traction
/// [`Traction::SharpResampled`], which at 6–8 cells per radius cuts the overshoot of the
/// deformation to a third and runs to `t` = 12 ([`Traction::Smoothed`] is the paper's: the
/// examples' `--traction smoothed`). For many capsules in a large box,
/// [`storage`](Self::storage) `= CapsuleStorage::Boxed { room: 1.2 }` saves memory. The step
/// is not a setting: [`AdaptiveDt::new`](super::timestep::AdaptiveDt::new)`(0.05)` (Courant target 0.3)
/// chooses it; a fixed `dt` should keep the Courant number `max|v| dt / h` near 0.3 and below
/// [`Simulation::membrane_dt_limit`](super::Simulation::membrane_dt_limit).
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
    /// default [`InterfaceTransport`], the [`Advector`](crate::interface::advect::Advector).
    pub advection: AdvectionParams<T>,
    /// Normals of the membrane mechanics (the `n` of `P = I - n n` in the stress, the re-set of
    /// `G_s` and the bending curvature): the default [`NormalEstimator`](crate::interface::geometry::NormalEstimator), a [`Geometry`](crate::interface::geometry::Geometry) with
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
/// histories): on the whole grid, or on a box of cells that follows it ([`Window`](crate::grid::Window)), so that
/// memory and the capsule's work follow the capsule, not the grid.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::law::NeoHookean;
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
    /// between the walls), and grows by whole cells where the capsule has stretched towards
    /// its sides (its band within [`box_grow_room`] cells of a side: the box then leaves
    /// [`box_margin`] + 2 cells on both sides of that axis, the whole axis where that reaches the
    /// grid's length or a wall). A step that carries the band within [`BOX_MIN_ROOM`] cells of
    /// a side fails with an error naming `room`. A shape without a bounding radius keeps the
    /// whole grid.
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

/// The cells between a membrane band and a movable side of its box below which the box grows
/// after a step, at profile sharpness `beta`: [`box_margin`] less 3 (9 cells at `beta = 1`; a
/// box made with `room = 1` starts about 9-10 cells from its band). The box then grows on that
/// axis to leave [`box_margin`] + 2 cells (14) on both sides, so that the
/// ends of its ring stay in the profile's far tail.
pub fn box_grow_room(beta: f64) -> usize {
    box_margin(beta).saturating_sub(3).max(BOX_MIN_ROOM + 1)
}

/// The cells a grown box leaves between the membrane band and both its sides along the axis it
/// grew on: [`box_margin`] + 2.
pub(crate) fn box_grown_room(beta: f64) -> usize {
    box_margin(beta) + 2
}

/// Which velocity carries and strains the membrane (`G_s`), and so where the in-plane membrane
/// force acts (it is the adjoint of that velocity's strain rate).
///
/// A capsule's traction is the one its effects ask for ([`Effect::requested_traction`](super::Effect::requested_traction)): its
/// [`Elasticity`](super::Elasticity) ([`Elasticity::traction`](super::Elasticity::traction), the default [`SharpResampled`](Self::SharpResampled)) or a
/// [`SurfaceLoad`](super::SurfaceLoad) given one ([`SurfaceLoad::traction`](super::SurfaceLoad::traction); without, a load acts with the
/// capsule's traction); smoothed where none asks (no membrane velocity map is then built). [`Scene::build`](super::Scene::build) refuses two effects that ask
/// one capsule for different tractions.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::law::NeoHookean;
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
    Smoothed,
    /// Each layer of the shell slides with the tangential velocity of its closest point on the
    /// surface `phi = 1/2` (its normal velocity stays the local one), and the in-plane force
    /// acts there, spread by the transposed interpolation
    /// ([`SurfaceExtension`](crate::membrane::extension::SurfaceExtension)); a
    /// [`surface force`](super::Scene::surface_force) on the capsule acts there too. `G_s` is
    /// projected onto the tangent plane after each step, as by [`GsTransport::Tangential`],
    /// whatever [`Settings::gs_transport`] says: without it the normal part of `G_s` grows and
    /// the steps shrink. Not in the paper. With [`MembraneCoupling::QuasiImplicit`] it needs
    /// the Krylov predictor.
    Sharp,
    /// [`Sharp`](Self::Sharp), and the layers deeper than
    /// [`RESAMPLE_DEPTH`](crate::membrane::outer_layers::RESAMPLE_DEPTH) cells take the `G_s` of
    /// their closest surface point after each step, and move their stress onto the layers
    /// they take it from ([`OuterLayers`](crate::membrane::outer_layers::OuterLayers)): the whole shell
    /// carries the surface's deformation as it carries its velocity, and the force is the
    /// work-conjugate of the whole shell's energy. In shear it removes the energy that the
    /// crushed inner layers at the tips create; the squashed sphere's energy error at N = 64
    /// is 4.7e-3 (6.6e-3 with `Sharp`). Not in the paper; docs/validation/shear_capsule.md.
    /// The default: the traction of the validated shear, squashed-sphere, inflated-capsule and
    /// suspension cases.
    #[default]
    SharpResampled,
}

impl Traction {
    /// Every traction, the default first.
    pub const ALL: [Traction; 3] = [Traction::SharpResampled, Traction::Sharp, Traction::Smoothed];

    /// The short name of the examples' `--traction` flag and their RESULT lines:
    /// `sharp-resampled`, `sharp`, `smoothed`.
    pub fn name(self) -> &'static str {
        match self {
            Traction::Smoothed => "smoothed",
            Traction::Sharp => "sharp",
            Traction::SharpResampled => "sharp-resampled",
        }
    }

    /// Whether the membrane velocity and force are those of the surface (`Sharp`,
    /// `SharpResampled`).
    pub fn is_sharp(self) -> bool {
        matches!(self, Traction::Sharp | Traction::SharpResampled)
    }

    /// The traction of a [`name`](Self::name).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `traction` for any other name.
    pub fn from_name(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| Error::invalid("traction", s, "sharp-resampled, sharp or smoothed"))
    }
}

/// How the bending force enters the momentum predictor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BendingCoupling {
    /// The force of the shape at the start of the step (the paper's): stable for
    /// `dt <= C_BENDING mu h^3 / E_b` ([`crate::simulation::stability`]).
    Explicit,
    /// The force's stiff part linearised in the velocity and taken `alpha` of the way along the
    /// step, inside the predictor ([`BendingImplicit`](crate::membrane::bending_implicit::BendingImplicit);
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
    /// [`StrainTransport::with_tangent_frame`]: crate::membrane::strain::StrainTransport::with_tangent_frame
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
    /// [`Scene::build`](super::Scene::build) like the fields themselves.
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

/// What makes the [`InterfaceTransport`] of one capsule, given the grid and what the capsule
/// carries (see [`Scene::interface_transport`](super::Scene::interface_transport)).
pub type TransportMaker<T> = Box<dyn Fn(&Grid<T>, Carried) -> Result<Box<dyn InterfaceTransport<T>>>>;
