//! The paper's effects: in-plane [`Elasticity`] (2.4)-(2.6) with the quasi-implicit coupling
//! (2.32)-(2.35), [`Bending`] (2.16)-(2.17), a [`SurfaceLoad`] `delta f(x, t)` (2.26), and the
//! uniform [`BodyForce`]. Each acts on every capsule or on the ones
//! named with `only` (a mixed suspension: stiff and soft capsules, red cells with another law).

use super::effect::{Capsules, Effect, EnergyRole, Setup, StepState};
use super::settings::{BendingCoupling, MembraneCoupling, Traction};
use super::stability::{bending_dt_limit, membrane_dt_limit};
use super::view::{MembraneView, Needs, reference_integral};
use crate::error::positive;
use crate::fluid::{
    forcing::{BodyForce, Forcing},
    momentum::ImplicitTerm,
    stepper::PredictorSolver,
};
use crate::grid::{Grid, VectorField};
use crate::interface::geometry::NormalScheme;
use crate::membrane::law::check_stress_free;
use crate::membrane::stress::SurfaceKinematics;
use crate::membrane::{
    bending::{BendingForm, BendingStress},
    bending_implicit::BendingImplicit,
    extension::SurfaceExtension,
    force::InPlaneElasticity,
    law::{SurfaceLaw, small_strain_moduli},
};
use crate::{Error, Real, Result};
use std::sync::Arc;

/// A membrane law shared by the capsules an [`Elasticity`] acts on (one law object, one
/// evaluation state per capsule).
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

/// Adds the implicit term `term(work, membrane)` of each capsule `(c, work)` of `capsules` to
/// `y = P x` (a membrane effect's [`Effect::add_implicit`]).
fn add_implicit_terms<'s, 'w, T: Real, W: 'w, I: ImplicitTerm<T>>(
    state: &StepState<'s, T>,
    capsules: impl Iterator<Item = (usize, &'w W)>,
    term: impl Fn(&'w W, MembraneView<'s, T>) -> Result<I>,
    x: &VectorField<T>,
    y: &mut VectorField<T>,
) -> Result<()> {
    for (c, w) in capsules {
        let m = state.membrane(c)?;
        let t = term(w, m)?;
        m.on_box(state.grid, x, y, |g, x, y| t.add_apply(g, x, y))?;
    }
    Ok(())
}

/// The sum of the same terms at face `idx` of component `comp` ([`Effect::implicit_at`], for
/// SOR). A capsule whose term cannot be built, which [`add_implicit_terms`] reports, adds
/// nothing.
fn implicit_terms_at<'s, 'w, T: Real, W: 'w, I: ImplicitTerm<T>>(
    state: &StepState<'s, T>,
    capsules: impl Iterator<Item = (usize, &'w W)>,
    term: impl Fn(&'w W, MembraneView<'s, T>) -> Result<I>,
    x: &VectorField<T>,
    comp: usize,
    idx: usize,
) -> T {
    capsules
        .filter_map(|(c, w)| state.membrane(c).ok().filter(|m| m.window.is_whole()).map(|m| (w, m)))
        .filter_map(|(w, m)| term(w, m).ok())
        .fold(T::zero(), |s, t| s + t.apply_at(state.grid, x, comp, idx))
}

/// `add(v, out)` for a force on the fluid velocity `v`, or through the membrane velocity map
/// `extension` of [`Traction::Sharp`] (`out += Mᵀ F(M v)`).
fn through<T: Real>(
    extension: Option<&SurfaceExtension<T>>,
    v: &VectorField<T>,
    out: &mut VectorField<T>,
    add: impl FnOnce(&VectorField<T>, &mut VectorField<T>) -> Result<()>,
) -> Result<()> {
    match extension {
        Some(x) => x.pull_back(v, out, add),
        None => add(v, out),
    }
}

/// The capsules a membrane effect acts on and, once attached, its work state `W` on each of
/// them (`None` on the others).
struct PerCapsule<W> {
    capsules: Capsules,
    work: Vec<Option<W>>,
}

impl<W> PerCapsule<W> {
    fn all() -> Self {
        PerCapsule { capsules: Capsules::All, work: Vec::new() }
    }

    fn only(&mut self, capsules: impl IntoIterator<Item = usize>) {
        self.capsules = Capsules::Only(capsules.into_iter().collect());
    }

    /// Checks the capsule selection of `effect` against a scene of `count` capsules and makes the
    /// work state of each selected capsule.
    fn attach(
        &mut self,
        effect: &'static str,
        count: usize,
        mut make: impl FnMut(usize) -> Result<W>,
    ) -> Result<()> {
        self.capsules.validate(effect, count)?;
        self.work = (0..count)
            .map(|c| self.capsules.contains(c).then(|| make(c)).transpose())
            .collect::<Result<_>>()?;
        Ok(())
    }

    /// The selected capsules and their work states.
    fn iter(&self) -> impl Iterator<Item = (usize, &W)> {
        self.work.iter().enumerate().filter_map(|(c, w)| Some((c, w.as_ref()?)))
    }

    fn iter_mut(&mut self) -> impl Iterator<Item = (usize, &mut W)> {
        self.work.iter_mut().enumerate().filter_map(|(c, w)| Some((c, w.as_mut()?)))
    }
}

/// In-plane elasticity of the membranes with a [`SurfaceLaw`]: the force
/// `div(delta tau)` (2.26) with the stress (2.4) of `G_s`, quasi-implicit (2.32)-(2.35) or
/// explicit by its [`coupling`](Self::coupling), acting across the smoothed shell or at the
/// surface by its [`traction`](Self::traction). Needs `G_s`.
///
/// ```
/// use eulermembrane::membrane::{law::NeoHookean, law::Skalak};
/// use eulermembrane::simulation::{Elasticity, MembraneCoupling, Traction};
///
/// // A stiff capsule 0 and a soft capsule 1 in one scene.
/// let stiff = Elasticity::<f64>::new(NeoHookean::new(10.0)?).only([0]);
/// let soft = Elasticity::<f64>::new(Skalak::new(1.0, 2.0)?).only([1]);
/// // The paper's smoothed traction (the default is the re-sampled sharp one).
/// let paper = Elasticity::<f64>::new(NeoHookean::new(1.0)?).traction(Traction::Smoothed);
/// // The explicit stress of the stability studies.
/// let explicit = Elasticity::<f64>::new(NeoHookean::new(1.0)?).coupling(MembraneCoupling::Explicit);
/// # let _ = (stiff, soft, paper, explicit);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub struct Elasticity<T: Real> {
    law: SharedLaw<T>,
    /// The capsules it acts on, each with its evaluation state.
    at: PerCapsule<InPlaneElasticity<T, SharedLaw<T>>>,
    coupling: MembraneCoupling,
    traction: Traction,
}

impl<T: Real> Elasticity<T> {
    /// Elasticity with `law` on every capsule, with the default [`MembraneCoupling`] and
    /// [`Traction`].
    pub fn new(law: impl SurfaceLaw<T> + 'static) -> Self {
        Elasticity {
            law: SharedLaw(Arc::new(law)),
            at: PerCapsule::all(),
            coupling: MembraneCoupling::default(),
            traction: Traction::default(),
        }
    }

    /// The same elasticity on the capsules with these indices only.
    pub fn only(mut self, capsules: impl IntoIterator<Item = usize>) -> Self {
        self.at.only(capsules);
        self
    }

    /// The same elasticity with the coupling `coupling` of its stress to the predictor
    /// (default [`MembraneCoupling::QuasiImplicit`], the paper's (2.32)-(2.35)).
    pub fn coupling(mut self, coupling: MembraneCoupling) -> Self {
        self.coupling = coupling;
        self
    }

    /// The same elasticity with the traction `traction` on its capsules (default
    /// [`Traction::SharpResampled`], the validated one; [`Traction::Smoothed`] is the paper's):
    /// which velocity carries and strains their membranes and where its force acts. [`Traction::Sharp`] with the quasi-implicit coupling
    /// needs the Krylov predictor ([`Scene::build`](super::Scene::build) refuses it with SOR).
    pub fn traction(mut self, traction: Traction) -> Self {
        self.traction = traction;
        self
    }

    /// The law.
    pub fn law(&self) -> &dyn SurfaceLaw<T> {
        self.law.0.as_ref()
    }
}

impl<T: Real> Effect<T> for Elasticity<T> {
    fn name(&self) -> &str {
        "elasticity"
    }
    fn describe(&self) -> String {
        let (mu, k) = small_strain_moduli(self.law());
        format!(
            "elasticity law={} shear_modulus={:e} area_modulus={:e} capsules={:?}",
            self.law.name(),
            mu.f64(),
            k.f64(),
            self.at.capsules
        )
    }
    fn needs(&self) -> Needs {
        Needs::STRAIN
    }
    fn requested_traction(&self) -> Option<Traction> {
        Some(self.traction)
    }
    fn acts_on(&self, c: usize) -> bool {
        self.at.capsules.contains(c)
    }
    fn energy_role(&self) -> EnergyRole {
        EnergyRole::Stored
    }
    fn attach(&mut self, setup: &Setup<'_, T>) -> Result<()> {
        let law = &self.law;
        self.at.attach("elasticity", setup.capsules, |c| {
            Ok(InPlaneElasticity::new(setup.capsule_grid(c)?, law.clone()))
        })?;
        let (mu_s, k) = small_strain_moduli(self.law());
        if !(mu_s > T::zero() && k > T::zero()) {
            return Err(Error::invalid(
                "elasticity",
                format!("law {} with small-strain moduli ({mu_s}, {k})", self.law.name()),
                "a law with positive shear and area-dilation moduli",
            ));
        }
        // A law with stress at rest would drive a capsule in its reference state.
        check_stress_free(self.law())?;
        if self.traction.is_sharp()
            && self.coupling == MembraneCoupling::QuasiImplicit
            && matches!(setup.settings.flow.predictor, PredictorSolver::Sor(_))
        {
            return Err(Error::invalid(
                "traction",
                "sharp with the SOR predictor",
                "the Krylov predictor (or the explicit membrane coupling) with the sharp traction",
            ));
        }
        Ok(())
    }
    fn dt_limit(&self, setup: &Setup<'_, T>) -> Option<f64> {
        let (shear, area) = small_strain_moduli(self.law());
        let k = shear.max(area).f64();
        membrane_dt_limit(setup.mean_viscosity(), setup.min_spacing(), k, self.coupling).ok()
    }
    fn prepare(&mut self, state: &StepState<'_, T>, _: &VectorField<T>, dt: T) -> Result<()> {
        for (c, e) in self.at.iter_mut() {
            let m = state.membrane(c)?;
            let gs = m.gs.ok_or_else(|| missing_field("elasticity", "G_s", c))?;
            e.evaluate(m.grid, m.band, gs, m.normal, m.delta, dt)?;
        }
        Ok(())
    }
    fn is_active(&self, state: &StepState<'_, T>) -> bool {
        any_band(state, &self.at.capsules)
    }
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        v: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        for (c, e) in self.at.iter() {
            let m = state.membrane(c)?;
            let f = match self.coupling {
                MembraneCoupling::Explicit => e.explicit_forcing(m.band)?,
                MembraneCoupling::QuasiImplicit => e.forcing(m.band)?,
            };
            let f = match m.extension.and_then(SurfaceExtension::outer_layers) {
                Some(layers) => f.with_outer_layers(layers)?,
                None => f,
            };
            if f.is_active() {
                m.on_box(state.grid, v, out, |g, v, out| {
                    through(m.extension, v, out, |u, o| f.add(g, state.time, u, o))
                })?;
            }
        }
        Ok(())
    }
    fn has_implicit(&self, _: &StepState<'_, T>) -> bool {
        self.coupling == MembraneCoupling::QuasiImplicit
    }
    fn add_implicit(
        &self,
        state: &StepState<'_, T>,
        x: &VectorField<T>,
        y: &mut VectorField<T>,
    ) -> Result<()> {
        if self.coupling != MembraneCoupling::QuasiImplicit {
            return Ok(());
        }
        for (c, e) in self.at.iter() {
            let m = state.membrane(c)?;
            let term = match m.extension.and_then(SurfaceExtension::outer_layers) {
                Some(layers) => e.implicit(m.band)?.with_outer_layers(layers)?,
                None => e.implicit(m.band)?,
            };
            m.on_box(state.grid, x, y, |g, x, y| through(m.extension, x, y, |u, o| term.add_apply(g, u, o)))?;
        }
        Ok(())
    }
    fn implicit_at(&self, state: &StepState<'_, T>, x: &VectorField<T>, comp: usize, idx: usize) -> T {
        if self.coupling != MembraneCoupling::QuasiImplicit {
            return T::zero();
        }
        implicit_terms_at(state, self.at.iter(), |e, m| e.implicit(m.band), x, comp, idx)
    }
    fn stored_energy(&self, state: &StepState<'_, T>) -> f64 {
        let energy = |k: &SurfaceKinematics<T>| self.law.energy(k.c1, k.c2);
        self.at
            .iter()
            .filter_map(|(c, _)| {
                let m = state.membrane(c).ok()?;
                Some(reference_integral(m.grid, &m, m.gs?, energy))
            })
            .sum()
    }
    fn surface_law(&self, c: usize) -> Option<&dyn SurfaceLaw<T>> {
        self.at.capsules.contains(c).then(|| self.law())
    }
}

/// Bending of the membranes with modulus `E_b` (2.8): the force `div(q~ n)` of the modified
/// bending stress (2.16)-(2.17), or the energy gradient of [`BendingForm::EnergyGradient`]
/// (by its [`form`](Self::form)), explicit or semi-implicit by its
/// [`coupling`](Self::coupling). Needs `kappa_R tilde`.
///
/// ```
/// use eulermembrane::membrane::bending::BendingForm;
/// use eulermembrane::simulation::{Bending, BendingCoupling};
///
/// // The paper's bending: the divergence form, explicit.
/// let paper = Bending::<f64>::new(1e-3)?.coupling(BendingCoupling::Explicit);
/// // The energy gradient, semi-implicit with alpha = 1 (the default coupling).
/// let energy = Bending::<f64>::new(1e-3)?.form(BendingForm::EnergyGradient);
/// # let _ = (paper, energy);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub struct Bending<T: Real> {
    eb: T,
    /// The capsules it acts on, each with its bending stress and the semi-implicit part
    /// ([`BendingCoupling::SemiImplicit`]), if any.
    at: PerCapsule<(BendingStress<T>, Option<BendingImplicit<T>>)>,
    form: BendingForm,
    coupling: BendingCoupling,
    atanh4: bool,
}

impl<T: Real> Bending<T> {
    /// Bending with modulus `eb` on every capsule, with the default [`BendingForm`] and
    /// [`BendingCoupling`].
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `eb` unless it is finite and `> 0`.
    pub fn new(eb: T) -> Result<Self> {
        positive("eb", eb)?;
        Ok(Bending {
            eb,
            at: PerCapsule::all(),
            form: BendingForm::default(),
            coupling: BendingCoupling::default(),
            atanh4: false,
        })
    }

    /// The same bending on the capsules with these indices only.
    pub fn only(mut self, capsules: impl IntoIterator<Item = usize>) -> Self {
        self.at.only(capsules);
        self
    }

    /// The same bending with the discrete force `form` (default [`BendingForm::Divergence`],
    /// the paper's `div(q~ n)` (2.16)). [`BendingForm::EnergyGradient`] is the exact gradient of
    /// a discrete bending energy with the same moment (its power balances the energy; a
    /// slightly different continuum model, see its docs) and needs
    /// [`Settings::normals`](super::Settings::normals) `Atanh2` or `Atanh4`. Not in the paper.
    pub fn form(mut self, form: BendingForm) -> Self {
        self.form = form;
        self
    }

    /// The same bending with the coupling `coupling` of its force to the predictor (default
    /// [`BendingCoupling::SemiImplicit`] with `alpha = 1`; [`BendingCoupling::Explicit`] is the
    /// paper's). An `alpha` outside `[0.5, 1]` is refused by [`Scene::build`](super::Scene::build).
    pub fn coupling(mut self, coupling: BendingCoupling) -> Self {
        self.coupling = coupling;
        self
    }

    /// The bending modulus `E_b`.
    pub fn eb(&self) -> T {
        self.eb
    }
}

impl<T: Real> Effect<T> for Bending<T> {
    fn name(&self) -> &str {
        "bending"
    }
    fn describe(&self) -> String {
        format!("bending eb={:e} capsules={:?}", self.eb.f64(), self.at.capsules)
    }
    fn needs(&self) -> Needs {
        Needs::CURVATURE
    }
    fn acts_on(&self, c: usize) -> bool {
        self.at.capsules.contains(c)
    }
    fn energy_role(&self) -> EnergyRole {
        EnergyRole::Stored
    }
    fn attach(&mut self, setup: &Setup<'_, T>) -> Result<()> {
        let eb = self.eb;
        let s = setup.settings;
        let alpha = match self.coupling {
            BendingCoupling::Explicit => None,
            BendingCoupling::SemiImplicit { alpha } => Some(T::lit(alpha)),
        };
        self.at.attach("bending", setup.capsules, |c| {
            let g = setup.capsule_grid(c)?;
            let implicit = alpha.map(|a| BendingImplicit::new(g, eb, a)).transpose()?;
            Ok((BendingStress::new(g, eb)?, implicit))
        })?;
        if self.form == BendingForm::EnergyGradient
            && !matches!(s.normals, NormalScheme::Atanh2 | NormalScheme::Atanh4)
        {
            return Err(Error::invalid(
                "normals",
                s.normals.name(),
                "atanh2 or atanh4 with bending form EnergyGradient",
            ));
        }
        self.atanh4 = s.normals == NormalScheme::Atanh4;
        Ok(())
    }
    fn dt_limit(&self, setup: &Setup<'_, T>) -> Option<f64> {
        bending_dt_limit(setup.mean_viscosity(), setup.min_spacing(), self.eb.f64(), self.coupling).ok()
    }
    fn prepare(&mut self, state: &StepState<'_, T>, _: &VectorField<T>, dt: T) -> Result<()> {
        for (c, (b, imp)) in self.at.iter_mut() {
            if let Some(imp) = imp {
                imp.set_dt(dt)?;
            }
            let m = state.membrane(c)?;
            let kappa = m.curvature.ok_or_else(|| missing_field("bending", "kappa_R tilde", c))?;
            match self.form {
                BendingForm::EnergyGradient => {
                    b.evaluate_variational(m.grid, m.band, m.phi, kappa, self.atanh4)?
                }
                _ => b.evaluate(m.grid, m.band, m.normal, m.delta, kappa)?,
            }
        }
        Ok(())
    }
    fn is_active(&self, state: &StepState<'_, T>) -> bool {
        any_band(state, &self.at.capsules)
    }
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        v: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        for (c, (b, _)) in self.at.iter() {
            let m = state.membrane(c)?;
            let f = b.forcing(m.band)?;
            if f.is_active() {
                m.on_box(state.grid, v, out, |g, v, out| f.add(g, state.time, v, out))?;
            }
        }
        Ok(())
    }
    fn has_implicit(&self, _: &StepState<'_, T>) -> bool {
        matches!(self.coupling, BendingCoupling::SemiImplicit { .. })
    }
    fn add_implicit(
        &self,
        state: &StepState<'_, T>,
        x: &VectorField<T>,
        y: &mut VectorField<T>,
    ) -> Result<()> {
        let terms = self.at.iter().filter_map(|(c, (_, imp))| Some((c, imp.as_ref()?)));
        add_implicit_terms(state, terms, |imp, m| imp.term(m.band, m.normal, m.delta), x, y)
    }
    fn implicit_at(&self, state: &StepState<'_, T>, x: &VectorField<T>, comp: usize, idx: usize) -> T {
        let terms = self.at.iter().filter_map(|(c, (_, imp))| Some((c, imp.as_ref()?)));
        implicit_terms_at(state, terms, |imp, m| imp.term(m.band, m.normal, m.delta), x, comp, idx)
    }
}

/// A surface force density per unit area `f(x, t)` (position, time), applied to every capsule
/// as the volume force `delta f` (2.26), e.g. the paper's squashing force
/// `F_b = -delta sgn(z - 0.25) gamma e_z` of Sec. 3.2.
pub type SurfaceForceFn = dyn Fn([f64; 3], f64) -> [f64; 3] + Send + Sync;

/// A surface force `f(x, t)` per unit area on the membranes ([`SurfaceForceFn`]), spread as
/// `delta f` on the faces around each membrane band, with `delta` cut to the band
/// (`delta h >= epsilon`, like every membrane force) and averaged to the faces; on a capsule
/// with the sharp traction it acts at the surface, through the membrane velocity map.
///
/// ```
/// use eulermembrane::simulation::{SurfaceLoad, Traction};
///
/// // A load on membranes without elasticity, acting at the surface `phi = 1/2`.
/// let load = SurfaceLoad::new(|x, _| [0.0, 0.0, -x[2]]).traction(Traction::Sharp);
/// # let _ = load;
/// ```
pub struct SurfaceLoad {
    f: Arc<SurfaceForceFn>,
    capsules: Capsules,
    traction: Option<Traction>,
}

impl SurfaceLoad {
    /// A load `f(x, t)` on every capsule, acting with each capsule's traction.
    pub fn new(f: impl Fn([f64; 3], f64) -> [f64; 3] + Send + Sync + 'static) -> Self {
        SurfaceLoad { f: Arc::new(f), capsules: Capsules::All, traction: None }
    }

    /// The same load on the capsules with these indices only.
    pub fn only(mut self, capsules: impl IntoIterator<Item = usize>) -> Self {
        self.capsules = Capsules::Only(capsules.into_iter().collect());
        self
    }

    /// The same load, asking its capsules for the traction `traction` (see
    /// [`Effect::requested_traction`]): for a load on membranes without [`Elasticity`], which
    /// otherwise have the smoothed one. Without it the load acts with whatever traction the
    /// capsule has.
    pub fn traction(mut self, traction: Traction) -> Self {
        self.traction = Some(traction);
        self
    }
}

impl<T: Real> Effect<T> for SurfaceLoad {
    fn name(&self) -> &str {
        "surface_force"
    }
    fn describe(&self) -> String {
        format!("surface_force capsules={:?}", self.capsules)
    }
    fn requested_traction(&self) -> Option<Traction> {
        self.traction
    }
    fn acts_on(&self, c: usize) -> bool {
        self.capsules.contains(c)
    }
    fn attach(&mut self, setup: &Setup<'_, T>) -> Result<()> {
        self.capsules.validate("surface_force", setup.capsules)
    }
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        v: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        out.matches(state.grid, "force")?;
        let half = T::lit(0.5);
        let t = state.time.f64();
        for c in (0..state.capsule_count()).filter(|&c| self.capsules.contains(c)) {
            let m = state.membrane(c)?;
            let (band, grid) = (m.band, m.grid);
            let st = grid.strides();
            let delta = |idx: usize| if band.contains(idx) { m.delta.data[idx] } else { T::zero() };
            let add = |out: &mut VectorField<T>| {
                for (&idx, ijk) in band.halo(1).iter().zip(band.coords(1)) {
                    let [i, j, k] = ijk.map(|x| x as isize);
                    for d in 0..3 {
                        if !grid.is_periodic(d) && ijk[d] == 0 {
                            continue;
                        }
                        let dd = half * (delta(idx) + delta(idx - st[d]));
                        if dd == T::zero() {
                            continue;
                        }
                        let x = grid.face_center(d, i, j, k).map(|x| x.f64());
                        out.c[d].data[idx] += dd * T::lit((self.f)(x, t)[d]);
                    }
                }
                Ok(())
            };
            m.on_box(state.grid, v, out, |_, _, out| match m.extension {
                Some(x) => x.spread(out, add),
                None => add(out),
            })?;
        }
        Ok(())
    }
}

impl<T: Real> Effect<T> for BodyForce<T> {
    fn name(&self) -> &str {
        "body_force"
    }
    fn describe(&self) -> String {
        format!("body_force f={:?}", self.density().map(|x| x.f64()))
    }
    fn is_active(&self, _: &StepState<'_, T>) -> bool {
        Forcing::is_active(self)
    }
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        v: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        Forcing::add(self, state.grid, state.time, v, out)
    }
}

/// Whether any of `capsules` has a non-empty membrane band (a membrane force is active).
fn any_band<T: Real>(state: &StepState<'_, T>, capsules: &Capsules) -> bool {
    (0..state.capsule_count())
        .filter(|&c| capsules.contains(c))
        .any(|c| state.membrane(c).is_ok_and(|m| !m.band.is_empty()))
}

/// The error of an effect run on a capsule without a field it needs (a bug of the effect's
/// [`needs`](Effect::needs), not of the user's input).
fn missing_field(effect: &str, field: &str, c: usize) -> Error {
    Error::Unsupported {
        component: "Effect",
        detail: format!(
            "{effect} on capsule {c}, which carries no {field}: the effect must declare it in needs()"
        ),
    }
}

/// The explicit forces of a scene's effects, summed in the order the effects were added, as the
/// flow stepper's [`Forcing`].
pub(crate) struct EffectForcing<'a, T: Real> {
    pub(crate) effects: &'a [Box<dyn Effect<T>>],
    pub(crate) state: &'a StepState<'a, T>,
}

impl<T: Real> Forcing<T> for EffectForcing<'_, T> {
    fn is_active(&self) -> bool {
        self.effects.iter().any(|e| e.is_active(self.state))
    }
    fn add(&self, _: &Grid<T>, _: T, v: &VectorField<T>, out: &mut VectorField<T>) -> Result<()> {
        for e in self.effects.iter().filter(|e| e.is_active(self.state)) {
            e.add_force(self.state, v, out)?;
        }
        Ok(())
    }
}

/// The quasi-implicit terms of a scene's effects, summed in order, as the predictor's
/// [`ImplicitTerm`].
pub(crate) struct EffectImplicit<'a, T: Real> {
    pub(crate) effects: &'a [Box<dyn Effect<T>>],
    pub(crate) state: &'a StepState<'a, T>,
}

impl<T: Real> EffectImplicit<'_, T> {
    /// Whether any effect has an implicit part this step.
    pub(crate) fn any(&self) -> bool {
        self.effects.iter().any(|e| e.has_implicit(self.state))
    }
}

impl<T: Real> ImplicitTerm<T> for EffectImplicit<'_, T> {
    fn add_apply(&self, _: &Grid<T>, x: &VectorField<T>, y: &mut VectorField<T>) -> Result<()> {
        for e in self.effects.iter().filter(|e| e.has_implicit(self.state)) {
            e.add_implicit(self.state, x, y)?;
        }
        Ok(())
    }
    fn apply_at(&self, _: &Grid<T>, x: &VectorField<T>, c: usize, idx: usize) -> T {
        self.effects
            .iter()
            .filter(|e| e.has_implicit(self.state))
            .fold(T::zero(), |s, e| s + e.implicit_at(self.state, x, c, idx))
    }
}
