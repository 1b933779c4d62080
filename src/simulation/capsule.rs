//! The state of one capsule: its own `phi`, `kappa_R tilde` (bending only), `G_s` (elasticity
//! only), the geometry derived from `phi` and the membrane band, double-buffered so that a step
//! is computed beside the state and committed only when every part of it succeeded.

use super::scene::{Settings, SharedLaw};
use crate::grid::ops::cell_vector;
use crate::grid::{Field, Grid, SymField, VectorField};
use crate::interface::geometry::{Band as PhiBand, delta_in_band};
use crate::interface::shapes::{Shape, smoothed_fields, smoothed_phi};
use crate::interface::{Advector, Geometry, NormalScheme};
use crate::membrane::stress::{SurfaceKinematics, surface_kinematics};
use crate::membrane::{Band, Bending, BendingForm, InPlaneElasticity, StrainTransport, fill_projector};
use crate::{Real, Result};

/// What is derived from `phi` at one time level.
#[derive(Debug, Clone)]
pub(crate) struct Level<T> {
    pub(crate) phi: Field<T>,
    /// `kappa_R tilde` (only with bending).
    pub(crate) kappa: Option<Field<T>>,
    /// `delta = |grad phi|` (2.26) where `phi` is not saturated.
    pub(crate) delta: Field<T>,
    /// Unit normal at cell centres (ghosts filled), where `phi` is not saturated.
    pub(crate) normal: [Field<T>; 3],
    /// The membrane band `delta h >= epsilon`.
    pub(crate) band: Band<T>,
}

/// One capsule of a [`Simulation`](super::Simulation).
pub(crate) struct Capsule<T: Real> {
    /// Time level `n` (the state).
    pub(crate) cur: Level<T>,
    /// Time level `n + 1` under construction.
    pub(crate) next: Level<T>,
    /// `G_s^n` (only with elasticity).
    pub(crate) gs: Option<SymField<T>>,
    pub(crate) advector: Advector<T>,
    pub(crate) geometry: Geometry<T>,
    pub(crate) elastic: Option<InPlaneElasticity<T, SharedLaw<T>>>,
    pub(crate) strain: Option<StrainTransport<T>>,
    pub(crate) bending: Option<Bending<T>>,
    /// Which bending force `bending` evaluates.
    bending_form: BendingForm,
    /// Saved AB2 history of the advector (restored when a step fails).
    saved: (Option<T>, Vec<T>, Vec<T>),
    /// The reference area `sum delta / j_s h^3` that [`Settings::conserve_reference_area`]
    /// restores after each step (set from the initial state and by a pre-stretch); `None`
    /// without that setting or without elasticity.
    pub(crate) reference_target: Option<f64>,
}

/// `sum delta q / j_s h^3` over the band of `level`: the integral of `q` (a function of the
/// surface kinematics of `gs`) over the membrane's reference area (`dA_R = dA / j_s`,
/// `j_s = sqrt(c2)`; cells with `c2 <= 0` left out).
pub(crate) fn reference_integral<T: Real>(
    grid: &Grid<T>,
    l: &Level<T>,
    gs: &SymField<T>,
    q: impl Fn(&SurfaceKinematics<T>) -> T,
) -> f64 {
    let mut s = 0.0;
    for &idx in l.band.cells() {
        let n = cell_vector(&l.normal, idx);
        let k = surface_kinematics(&gs.get(idx), &n);
        if k.c2 > T::zero() {
            s += (l.delta.data[idx] * q(&k) / k.c2.sqrt()).f64();
        }
    }
    s * grid.cell_volume().f64()
}

/// `phi` range where the geometry (normals, `delta`) is evaluated: wide enough for the
/// membrane band and the four halo layers around it.
pub(crate) fn geometry_band<T: Real>() -> PhiBand<T> {
    let tiny = T::lit(1e-10).max(T::epsilon() * T::lit(4.0));
    PhiBand { lower: tiny, upper: T::one() - tiny }
}

impl<T: Real> Level<T> {
    fn zeros(grid: &Grid<T>, bending: bool, epsilon: T) -> Result<Self> {
        Ok(Level {
            phi: Field::zeros(grid),
            kappa: bending.then(|| Field::zeros(grid)),
            delta: Field::zeros(grid),
            normal: std::array::from_fn(|_| Field::zeros(grid)),
            band: Band::new(grid, epsilon)?,
        })
    }

    /// Recomputes `delta`, the normals and the band from `phi` (ghosts of `phi` filled here).
    pub(crate) fn derive(&mut self, grid: &Grid<T>, geometry: &mut Geometry<T>) -> Result<()> {
        self.phi.fill_ghosts(grid);
        geometry.update(grid, &self.phi);
        let band = geometry_band();
        geometry.normals(grid, &self.phi, band, &mut self.normal);
        for c in self.normal.iter_mut() {
            c.fill_ghosts(grid);
        }
        delta_in_band(grid, &self.phi, band, &mut self.delta);
        self.delta.fill_ghosts(grid);
        self.band.rebuild(grid, &self.delta)
    }

    fn copy_from(&mut self, other: &Level<T>) {
        self.phi.data.copy_from_slice(&other.phi.data);
        if let (Some(a), Some(b)) = (self.kappa.as_mut(), other.kappa.as_ref()) {
            a.data.copy_from_slice(&b.data);
        }
    }
}

impl<T: Real> Capsule<T> {
    pub(crate) fn new(
        grid: &Grid<T>,
        shape: &dyn Shape,
        settings: &Settings<T>,
        law: Option<&SharedLaw<T>>,
        eb: Option<T>,
    ) -> Result<Self> {
        let (smoothing, epsilon) = (&settings.smoothing, settings.epsilon);
        let bending = eb.is_some();
        if bending
            && settings.bending_form == BendingForm::EnergyGradient
            && !matches!(settings.normals, NormalScheme::Atanh2 | NormalScheme::Atanh4)
        {
            return Err(crate::Error::invalid(
                "normals",
                settings.normals.name(),
                "atanh2 or atanh4 with bending_form EnergyGradient",
            ));
        }
        let mut cur = Level::zeros(grid, bending, epsilon)?;
        if bending {
            let (phi, kappa) = smoothed_fields(grid, shape, smoothing)?;
            cur.phi = phi;
            cur.kappa = Some(kappa);
        } else {
            cur.phi = smoothed_phi(grid, shape, smoothing)?;
        }
        let mut geometry = Geometry::new(grid, settings.normals);
        cur.derive(grid, &mut geometry)?;
        let next = Level::zeros(grid, bending, epsilon)?;
        let gs = law.map(|_| {
            // The reference state: G_s = P (2.22) everywhere the normal is defined.
            let mut gs = SymField::zeros(grid);
            fill_projector(grid, &cur.normal, &mut gs);
            gs
        });
        let mut cap = Capsule {
            cur,
            next,
            gs,
            advector: Advector::new(grid, settings.advection, bending)?,
            geometry,
            elastic: law.map(|l| InPlaneElasticity::new(grid, l.clone())),
            strain: match law {
                Some(_) => Some(
                    StrainTransport::new(grid)?
                        .with_advection(settings.strain_advection)
                        .with_tangent_frame(settings.tangent_frame_gs),
                ),
                None => None,
            },
            bending: match eb {
                Some(eb) => Some(Bending::new(grid, eb)?),
                None => None,
            },
            bending_form: settings.bending_form,
            saved: (None, Vec::new(), Vec::new()),
            reference_target: None,
        };
        if settings.conserve_reference_area {
            cap.reference_target = cap.reference_area(grid);
        }
        Ok(cap)
    }

    /// The reference area `sum delta / j_s h^3` of the current level (`None` without
    /// elasticity).
    pub(crate) fn reference_area(&self, grid: &Grid<T>) -> Option<f64> {
        self.gs.as_ref().map(|gs| reference_integral(grid, &self.cur, gs, |_| T::one()))
    }

    /// Makes the current reference area the one to conserve (where one is conserved).
    pub(crate) fn reset_reference_target(&mut self, grid: &Grid<T>) {
        if self.reference_target.is_some() {
            self.reference_target = self.reference_area(grid);
        }
    }

    /// Rescales `G_s` on the band by `lambda = s_0 / s_0(target)`, so that the reference area
    /// `sum delta / j_s h^3` (which scales as `1 / lambda`) returns to its target. Nothing
    /// without a target.
    pub(crate) fn restore_reference_area(&mut self, grid: &Grid<T>) {
        // The target first: without it no band pass is made.
        let Some(target) = self.reference_target else { return };
        let Some(s0) = self.reference_area(grid) else { return };
        let Some(gs) = self.gs.as_mut() else { return };
        if !(s0 > 0.0 && target > 0.0) {
            return;
        }
        let lambda = T::lit(s0 / target);
        for &idx in self.cur.band.cells() {
            let g = gs.get(idx);
            gs.set(idx, &std::array::from_fn(|k| g[k] * lambda));
        }
    }

    /// Steps 1-3 of the time step for this capsule: advects `phi` (and `kappa_R tilde`) with
    /// `v^n` into the next level, derives its geometry and band, and evaluates the membrane
    /// stress and bending force there (`G_s^n`, `n^{n+1}`, `delta^{n+1}`). The state is not
    /// touched; on error call [`discard`](Self::discard).
    pub(crate) fn prepare(&mut self, grid: &Grid<T>, v: &VectorField<T>, dt: T) -> Result<usize> {
        self.saved.0 = None;
        if let Some((dt_prev, rp, rk)) = self.advector.history() {
            self.saved.0 = Some(dt_prev);
            self.saved.1.clear();
            self.saved.1.extend_from_slice(rp);
            self.saved.2.clear();
            self.saved.2.extend_from_slice(rk);
        }
        self.next.copy_from(&self.cur);
        let info = self.advector.step(grid, v, dt, &mut self.next.phi, self.next.kappa.as_mut())?;
        self.next.derive(grid, &mut self.geometry)?;
        let next = &self.next;
        if let (Some(e), Some(gs)) = (self.elastic.as_mut(), self.gs.as_ref()) {
            e.evaluate(grid, &next.band, gs, &next.normal, &next.delta, dt)?;
        }
        if let (Some(b), Some(kappa)) = (self.bending.as_mut(), next.kappa.as_ref()) {
            match self.bending_form {
                BendingForm::EnergyGradient => b.evaluate_variational(
                    grid,
                    &next.band,
                    &next.phi,
                    kappa,
                    self.geometry.scheme() == NormalScheme::Atanh4,
                )?,
                _ => b.evaluate(grid, &next.band, &next.normal, &next.delta, kappa)?,
            }
        }
        Ok(info.profile_cells)
    }

    /// Undoes what [`prepare`](Self::prepare) changed outside the next level: the advector's
    /// history.
    pub(crate) fn discard(&mut self) {
        match self.saved.0 {
            Some(dt_prev) => {
                // Same grid and same lengths: cannot fail.
                let _ = self.advector.restore_history(dt_prev, &self.saved.1, &self.saved.2);
            }
            None => self.advector.reset_history(),
        }
    }

    /// Makes the next level the state (after the `G_s` commit).
    pub(crate) fn commit(&mut self) {
        std::mem::swap(&mut self.cur, &mut self.next);
    }
}
