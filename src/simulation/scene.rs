//! What a simulation holds: the [`Scene`] builder (fluids, capsules, membrane effects, forces,
//! solver settings). A scene is a description; [`Scene::build`] validates it and allocates only
//! what its effects need (see the [module docs](super)).

use super::Simulation;
use crate::error::positive;
use crate::fluid::FlowConfig;
use crate::grid::Grid;
use crate::interface::shapes::{Shape, Smoothing};
use crate::interface::{AdvectionParams, NormalScheme};
use crate::membrane::{BendingForm, StrainAdvection, SurfaceLaw};
use crate::{Error, Real, Result};
use std::sync::Arc;

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

/// A surface force density per unit area `f(x, t)` (position, time), applied to every capsule
/// as the volume force `delta f` (2.26), e.g. the paper's squashing force
/// `F_b = -delta sgn(z - 0.25) gamma e_z` of Sec. 3.2.
pub type SurfaceForceFn = dyn Fn([f64; 3], f64) -> [f64; 3] + Send + Sync;

/// A membrane law shared by the capsules of a scene (one law object, one evaluation state per
/// capsule).
#[derive(Clone)]
pub struct SharedLaw<T>(pub(crate) Arc<dyn SurfaceLaw<T>>);

impl<T: Real> SurfaceLaw<T> for SharedLaw<T> {
    fn name(&self) -> &str {
        self.0.name()
    }
    #[inline]
    fn energy(&self, c1: T, c2: T) -> T {
        self.0.energy(c1, c2)
    }
    #[inline]
    fn gradient(&self, c1: T, c2: T) -> [T; 2] {
        self.0.gradient(c1, c2)
    }
    #[inline]
    fn hessian(&self, c1: T, c2: T) -> [T; 3] {
        self.0.hessian(c1, c2)
    }
    #[inline]
    fn derivatives(&self, c1: T, c2: T) -> ([T; 2], [T; 3]) {
        self.0.derivatives(c1, c2)
    }
}

/// Numerical settings of a [`Scene`]; the defaults are the ones validated in `docs/`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings<T> {
    /// Flow solver settings (predictor solver, tolerances).
    pub flow: FlowConfig,
    /// Interface advection (MTHINC sharpness `beta`, normals of the reconstruction).
    pub advection: AdvectionParams<T>,
    /// Normals of the membrane mechanics (the `n` of `P = I - n n` in the stress, the re-set of
    /// `G_s` and the bending curvature). Default [`NormalScheme::Atanh4`].
    pub normals: NormalScheme,
    /// The `epsilon` of the membrane band `delta h >= epsilon` (Sec. 2.2.2): outside it `G_s` is
    /// re-set to `P` and no membrane force acts. Default 0.01 (the band then carries 99 % of
    /// the membrane force; see [`crate::membrane::band`]).
    pub epsilon: T,
    /// Cell averaging of the initial shapes.
    pub smoothing: Smoothing,
    /// How the in-plane membrane stress enters the predictor. Default
    /// [`MembraneCoupling::QuasiImplicit`] (2.32)-(2.35).
    pub coupling: MembraneCoupling,
    /// Projects `G_s` onto the tangent plane, `G_s <- P G_s P` with the new normals, on the
    /// band after each transport step (2.40). In the continuum `G_s` stays tangential; the
    /// discrete transport lets normal components grow, which feed the in-plane block through
    /// the velocity gradient. Not in the paper. Default `false`.
    pub tangential_gs: bool,
    /// Transports `G_s` in the tangent frame ([`StrainTransport::with_tangent_frame`]): each
    /// stencil value of the advection (2.40) is turned into the cell's tangent plane, and the
    /// stretching term leaves out that turn of the frame along the path, so that mixing
    /// neighbours of different tangent planes adds no normal part to `G_s` (other sources of
    /// it remain: combine with [`tangential_gs`](Self::tangential_gs), see
    /// `docs/validation/squashed_sphere.md`). Not in the paper. Default `false`.
    ///
    /// [`StrainTransport::with_tangent_frame`]: crate::membrane::StrainTransport::with_tangent_frame
    pub tangent_frame_gs: bool,
    /// Rescales `G_s` on each capsule's band after every step so that the membrane's reference
    /// area `sum delta / j_s h^3` keeps its initial value. Not in the paper. Default `false`.
    pub conserve_reference_area: bool,
    /// Face reconstruction in the advection of `G_s` (2.40). Default
    /// [`StrainAdvection::Upwind3`] (the paper's); [`StrainAdvection::Upwind5`] is more accurate
    /// and less dissipative.
    pub strain_advection: StrainAdvection,
    /// The discrete bending force. Default [`BendingForm::Divergence`] (the paper's
    /// `∇·(q̃ n)` (2.16)); [`BendingForm::EnergyGradient`] is the exact gradient of a discrete
    /// bending energy with the same moment (its power balances the energy; a slightly different
    /// continuum model, see its docs). It needs `normals` `Atanh2` or `Atanh4`. Not in the paper.
    pub bending_form: BendingForm,
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

impl<T: Real> Default for Settings<T> {
    fn default() -> Self {
        Settings {
            flow: FlowConfig::default(),
            advection: AdvectionParams::default(),
            normals: NormalScheme::Atanh4,
            epsilon: T::lit(0.01),
            smoothing: Smoothing::default(),
            coupling: MembraneCoupling::default(),
            tangential_gs: false,
            tangent_frame_gs: false,
            conserve_reference_area: false,
            strain_advection: StrainAdvection::default(),
            bending_form: BendingForm::Divergence,
        }
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
    pub(crate) law: Option<SharedLaw<T>>,
    pub(crate) eb: Option<T>,
    pub(crate) body_force: [T; 3],
    pub(crate) surface_force: Option<Arc<SurfaceForceFn>>,
    pub(crate) settings: Settings<T>,
    pub(crate) errors: Vec<Error>,
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
            law: None,
            eb: None,
            body_force: [T::zero(); 3],
            surface_force: None,
            settings: Settings::default(),
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

    /// In-plane elasticity of the membranes with the law `law` (e.g.
    /// [`NeoHookean`](crate::membrane::NeoHookean), [`Skalak`](crate::membrane::Skalak), or
    /// any user [`SurfaceLaw`]).
    pub fn elasticity(mut self, law: impl SurfaceLaw<T> + 'static) -> Self {
        self.law = Some(SharedLaw(Arc::new(law)));
        self
    }

    /// Bending of the membranes with modulus `eb` (`E_b` of (2.8)).
    pub fn bending(mut self, eb: T) -> Self {
        match positive("eb", eb) {
            Ok(_) => self.eb = Some(eb),
            Err(e) => self.errors.push(e),
        }
        self
    }

    /// A uniform body force density (force per unit volume), e.g. a pressure gradient.
    pub fn body_force(mut self, f: [T; 3]) -> Self {
        for (d, name) in ["body_force[0]", "body_force[1]", "body_force[2]"].into_iter().enumerate() {
            if let Err(e) = crate::error::finite(name, f[d]) {
                self.errors.push(e);
            }
        }
        self.body_force = f;
        self
    }

    /// A force per unit area `f(x, t)` on every membrane (see [`SurfaceForceFn`]).
    pub fn surface_force(mut self, f: impl Fn([f64; 3], f64) -> [f64; 3] + Send + Sync + 'static) -> Self {
        self.surface_force = Some(Arc::new(f));
        self
    }

    /// Numerical settings (replaces the defaults).
    pub fn settings(mut self, settings: Settings<T>) -> Self {
        self.settings = settings;
        self
    }

    /// The grid.
    pub fn grid(&self) -> &Grid<T> {
        &self.grid
    }

    /// Validates the scene and builds the simulation at rest at `t = 0`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the offending item: a non-positive modulus or
    /// material value, `epsilon` outside `(0, 1)`, a membrane effect or surface force without
    /// any capsule, a capsule whose band (where `phi` is neither 0 nor 1) leaves the domain
    /// across a wall or comes within two band widths of it, a 2D capsule on a 3D grid or the
    /// reverse; and the errors of the solvers' constructors.
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
        if self.capsules.is_empty() {
            let needs = if self.law.is_some() {
                Some("elasticity")
            } else if self.eb.is_some() {
                Some("bending")
            } else if self.surface_force.is_some() {
                Some("surface_force")
            } else {
                None
            };
            if let Some(what) = needs {
                return Err(Error::invalid(
                    what,
                    "a membrane effect in a scene without capsules",
                    "at least one capsule (Scene::capsule) for membrane effects",
                ));
            }
        }
        if let Some(law) = &self.law {
            let (mu_s, k) = crate::membrane::law::small_strain_moduli(law.0.as_ref());
            if !(mu_s > T::zero() && k > T::zero()) {
                return Err(Error::invalid(
                    "elasticity",
                    format!("law {} with small-strain moduli ({mu_s}, {k})", law.0.name()),
                    "a law with positive shear and area-dilation moduli",
                ));
            }
        }
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
            self.capsules,
            self.law,
            self.eb,
            self.body_force,
            self.surface_force,
            self.settings,
        )
    }
}
