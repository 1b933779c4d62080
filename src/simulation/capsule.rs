//! The state of one capsule: its own `phi`, `kappa_R tilde` (bending only), `G_s` (elasticity
//! only), the geometry derived from `phi` and the membrane band, double-buffered so that a step
//! is computed beside the state and committed only when every part of it succeeded. Every
//! field lives on the capsule's box ([`Window`]) and its grid; the whole grid's fields (the
//! velocity) are read through it.

use super::settings::{ReferenceArea, Settings, Traction, TransportMaker};
use super::view::{LevelChoice, MembraneView, Needs, reference_integral};
use crate::grid::{Field, Grid, SymField, VectorField, Window};
use crate::interface::geometry::{PhiRange, delta_in_band};
use crate::interface::shapes::{Shape, smoothed_fields, smoothed_phi};
use crate::interface::{
    advect::{Carried, InterfaceTransport},
    geometry::NormalEstimator,
};
use crate::membrane::{
    band::Band,
    extension::SurfaceExtension,
    strain::{StrainTransport, fill_projector},
};
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

/// The two staggered fields a box's kernels work in (the velocities they read, the scratch of
/// [`MembraneView::on_box`]), shared by every capsule of a simulation: the capsules' passes run
/// one capsule at a time, so one pair, sized to the box in use, serves them all.
pub(crate) type BoxScratch<T> = std::sync::Arc<std::sync::Mutex<Option<[VectorField<T>; 2]>>>;

/// Where a capsule's fields live: its window of the whole grid and the window's own grid,
/// with the box velocities gathered for its kernels (none on a whole window, whose kernels
/// read the whole grid's fields themselves).
pub(crate) struct Boxed<T: Real> {
    pub(crate) window: Window,
    pub(crate) grid: Grid<T>,
    /// The simulation's [`BoxScratch`] (never used on a whole window).
    pub(crate) scratch: BoxScratch<T>,
}

impl<T: Real> Boxed<T> {
    pub(crate) fn new(whole: &Grid<T>, window: Window, scratch: BoxScratch<T>) -> Self {
        let grid = window.grid(whole);
        Boxed { window, grid, scratch }
    }

    /// Runs `f` on the box grid and the staggered field `a` of the whole grid `whole` as the box
    /// sees it (see [`with_velocities`](Self::with_velocities)).
    pub(crate) fn with_velocity<R>(
        &self,
        whole: &Grid<T>,
        a: &VectorField<T>,
        f: impl FnOnce(&Grid<T>, &VectorField<T>) -> Result<R>,
    ) -> Result<R> {
        if self.window.is_whole() {
            return f(&self.grid, a);
        }
        let mut guard = lock_scratch(&self.scratch)?;
        let [ba, _] = box_fields(&self.grid, &mut guard);
        self.window.gather_vector(whole, a, &self.grid, ba)?;
        f(&self.grid, ba)
    }

    /// Runs `f` on the box grid and the staggered fields `a` and `b` of the whole grid `whole`
    /// as the box sees them: the fields themselves on a whole window, else gathered into the
    /// box (ghosts of `a` and `b` filled).
    pub(crate) fn with_velocities<R>(
        &self,
        whole: &Grid<T>,
        a: &VectorField<T>,
        b: &VectorField<T>,
        f: impl FnOnce(&Grid<T>, &VectorField<T>, &VectorField<T>) -> Result<R>,
    ) -> Result<R> {
        if self.window.is_whole() {
            return f(&self.grid, a, b);
        }
        let mut guard = lock_scratch(&self.scratch)?;
        let [ba, bb] = box_fields(&self.grid, &mut guard);
        self.window.gather_vector(whole, a, &self.grid, ba)?;
        self.window.gather_vector(whole, b, &self.grid, bb)?;
        f(&self.grid, ba, bb)
    }
}

/// The lock of a [`BoxScratch`].
pub(crate) fn lock_scratch<T: Real>(
    scratch: &BoxScratch<T>,
) -> Result<std::sync::MutexGuard<'_, Option<[VectorField<T>; 2]>>> {
    scratch.lock().map_err(|_| crate::Error::Unsupported {
        component: "capsule box scratch",
        detail: "the box scratch was poisoned by a panic in another thread".into(),
    })
}

/// The two staggered fields of a [`BoxScratch`], sized for the box grid `grid` (made on first
/// use; their values are those of whichever box used them last).
pub(crate) fn box_fields<'a, T: Real>(
    grid: &Grid<T>,
    slot: &'a mut Option<[VectorField<T>; 2]>,
) -> &'a mut [VectorField<T>; 2] {
    let fields = slot.get_or_insert_with(|| [VectorField::zeros(grid), VectorField::zeros(grid)]);
    for f in fields.iter_mut().flat_map(|v| v.c.iter_mut()) {
        f.data.resize(grid.len(), T::zero());
    }
    fields
}

/// The largest `phi` a move of a box along a wall axis may carry round to its other side (on a
/// periodic axis the profile's tail moves with the fluid, and the margin keeps it within `1e-10`).
const FAR_FIELD: f64 = 1e-8;

/// The membrane velocity map of `traction` on `grid`, built on `level` (`None` for the
/// smoothed traction).
fn membrane_map<T: Real>(
    grid: &Grid<T>,
    traction: Traction,
    settings: &Settings<T>,
    level: &Level<T>,
) -> Result<Option<SurfaceExtension<T>>> {
    Ok(match traction {
        Traction::Sharp | Traction::SharpResampled => {
            let mut e = SurfaceExtension::new(grid, settings.advection.beta)?;
            if traction == Traction::SharpResampled {
                e = e.with_outer_layers();
            }
            e.rebuild(&level.band, &level.phi, &level.normal)?;
            Some(e)
        }
        Traction::Smoothed => None,
    })
}

/// One capsule of a [`Simulation`](super::Simulation).
pub(crate) struct Capsule<T: Real> {
    /// Its box and the box's grid, where every field below lives.
    pub(crate) boxed: Boxed<T>,
    /// Time level `n` (the state).
    pub(crate) cur: Level<T>,
    /// Time level `n + 1` under construction.
    pub(crate) next: Level<T>,
    /// `G_s^n` (only with elasticity).
    pub(crate) gs: Option<SymField<T>>,
    /// The transport of `phi` (and `kappa_R tilde`) (2.29)-(2.30).
    pub(crate) transport: Box<dyn InterfaceTransport<T>>,
    /// The `G_s` transport (2.40) (only with `G_s`).
    pub(crate) strain: Option<StrainTransport<T>>,
    /// The reference area `sum delta / j_s h^3` that [`ReferenceArea::Conserved`]
    /// restores after each step (set from the initial state and by a pre-stretch); `None`
    /// without that setting or without elasticity.
    pub(crate) reference_target: Option<f64>,
    /// The membrane velocity map of [`Traction::Sharp`], built on the level of the step being
    /// computed (`None` with the smoothed traction).
    pub(crate) extension: Option<SurfaceExtension<T>>,
}

/// `phi` range where the geometry (normals, `delta`) is evaluated: wide enough for the
/// membrane band and the four halo layers around it.
pub(crate) fn geometry_band<T: Real>() -> PhiRange<T> {
    let tiny = T::lit(1e-10).max(T::epsilon() * T::lit(4.0));
    PhiRange { lower: tiny, upper: T::one() - tiny }
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
    pub(crate) fn derive(&mut self, grid: &Grid<T>, normals: &mut dyn NormalEstimator<T>) -> Result<()> {
        self.phi.fill_ghosts(grid);
        let band = geometry_band();
        normals.estimate(grid, &self.phi, band, &mut self.normal)?;
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
    /// A capsule of `shape` in the box `window` of the grid `whole`, carrying the fields of
    /// `needs` and the membrane velocity map of `traction`, its normals from `normals`, its
    /// interface carried by the transport `make` returns.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        whole: &Grid<T>,
        window: Window,
        shape: &dyn Shape,
        settings: &Settings<T>,
        needs: Needs,
        traction: Traction,
        normals: &mut dyn NormalEstimator<T>,
        make: &TransportMaker<T>,
        scratch: BoxScratch<T>,
    ) -> Result<Self> {
        let boxed = Boxed::new(whole, window, scratch);
        let grid = &boxed.grid;
        let (smoothing, epsilon) = (&settings.smoothing, settings.epsilon);
        let curvature = needs.curvature;
        let mut cur = Level::zeros(grid, curvature, epsilon)?;
        if curvature {
            let (phi, kappa) = smoothed_fields(grid, shape, smoothing)?;
            cur.phi = phi;
            cur.kappa = Some(kappa);
        } else {
            cur.phi = smoothed_phi(grid, shape, smoothing)?;
        }
        cur.derive(grid, normals)?;
        let next = Level::zeros(grid, curvature, epsilon)?;
        let gs = needs.strain.then(|| {
            // The reference state: G_s = P (2.22) everywhere the normal is defined.
            let mut gs = SymField::zeros(grid);
            fill_projector(grid, &cur.normal, &mut gs);
            gs
        });
        let strain = match needs.strain {
            true => Some(
                StrainTransport::new(grid)?
                    .with_advection(settings.strain_advection)
                    .with_tangent_frame(settings.gs_transport.tangent_frame()),
            ),
            false => None,
        };
        let extension = membrane_map(grid, traction, settings, &cur)?;
        let transport = make(grid, if curvature { Carried::PhiAndCurvature } else { Carried::Phi })?;
        let mut cap = Capsule { boxed, cur, next, gs, transport, strain, reference_target: None, extension };
        if settings.reference_area == ReferenceArea::Conserved {
            cap.reference_target = cap.reference_area();
        }
        Ok(cap)
    }

    /// Its traction: sharp where it carries the membrane velocity map, re-sampled where the
    /// map carries the outer layers.
    pub(crate) fn traction(&self) -> Traction {
        match &self.extension {
            None => Traction::Smoothed,
            Some(e) if e.outer_layers().is_some() => Traction::SharpResampled,
            Some(_) => Traction::Sharp,
        }
    }

    /// The membrane at the current level.
    pub(crate) fn view(&self, level: LevelChoice) -> MembraneView<'_, T> {
        let l = match level {
            LevelChoice::Current => &self.cur,
            LevelChoice::Next => &self.next,
        };
        MembraneView {
            grid: &self.boxed.grid,
            window: &self.boxed.window,
            scratch: &self.boxed.scratch,
            phi: &l.phi,
            delta: &l.delta,
            normal: &l.normal,
            band: &l.band,
            curvature: l.kappa.as_ref(),
            gs: self.gs.as_ref(),
            extension: self.extension.as_ref(),
        }
    }

    /// The reference area `sum delta / j_s h^3` of the current level (`None` without
    /// elasticity).
    pub(crate) fn reference_area(&self) -> Option<f64> {
        self.gs.as_ref().map(|gs| {
            reference_integral(&self.boxed.grid, &self.view(LevelChoice::Current), gs, |_| T::one())
        })
    }

    /// Makes the current reference area the one to conserve (where one is conserved).
    pub(crate) fn reset_reference_target(&mut self) {
        if self.reference_target.is_some() {
            self.reference_target = self.reference_area();
        }
    }

    /// Rescales `G_s` on the band by `lambda = s_0 / s_0(target)`, so that the reference area
    /// `sum delta / j_s h^3` (which scales as `1 / lambda`) returns to its target. Nothing
    /// without a target.
    pub(crate) fn restore_reference_area(&mut self) {
        // The target first: without it no band pass is made.
        let Some(target) = self.reference_target else { return };
        let Some(s0) = self.reference_area() else { return };
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

    /// Steps 1-2 of the time step for this capsule: advects `phi` (and `kappa_R tilde`) with
    /// `v^n` (on the whole grid `whole`) into the next level and derives its geometry and band
    /// there. The state is not touched; on error call [`discard`](Self::discard).
    pub(crate) fn prepare(
        &mut self,
        whole: &Grid<T>,
        v: &VectorField<T>,
        dt: T,
        normals: &mut dyn NormalEstimator<T>,
    ) -> Result<usize> {
        self.next.copy_from(&self.cur);
        let (transport, next) = (&mut self.transport, &mut self.next);
        let info = self.boxed.with_velocity(whole, v, |grid, v| {
            transport.advance(grid, v, dt, &mut next.phi, next.kappa.as_mut())
        })?;
        self.next.derive(&self.boxed.grid, normals)?;
        if let Some(e) = self.extension.as_mut() {
            e.rebuild(&self.next.band, &self.next.phi, &self.next.normal)?;
        }
        Ok(info.profile_cells)
    }

    /// Undoes what [`prepare`](Self::prepare) changed outside the next level: the transport's
    /// history.
    pub(crate) fn discard(&mut self) {
        self.transport.undo();
        if let Some(e) = self.extension.as_mut() {
            // The current level was built by the same grid: this cannot fail, and a map that
            // failed would be caught by its generation where it is used.
            let _ = e.rebuild(&self.cur.band, &self.cur.phi, &self.cur.normal);
        }
    }

    /// Makes the next level the state (after the `G_s` commit).
    pub(crate) fn commit(&mut self) {
        std::mem::swap(&mut self.cur, &mut self.next);
    }

    /// The cells between the band of `level` and the two sides of the box along each axis the
    /// box can move along, a ring or a segment (`None` on whole axes and for an empty band).
    pub(crate) fn room(&self, level: LevelChoice) -> [Option<(usize, usize)>; 3] {
        let band = match level {
            LevelChoice::Current => &self.cur.band,
            LevelChoice::Next => &self.next.band,
        };
        let w = &self.boxed.window;
        let (size, bounds) = (w.size(), band.bounds(0));
        std::array::from_fn(|d| {
            let (lo, hi) = bounds.filter(|_| w.movable()[d])?;
            Some((lo[d], size[d] - 1 - hi[d]))
        })
    }

    /// The part of a move of the box by `by` cells along segment axis `axis` (a wall axis) that
    /// carries only the far field round the box: the layers that leave one side come round to
    /// the other (as on a ring; nothing is lost), and the move stops before a layer with `phi`
    /// above [`FAR_FIELD`] in some cell. The profile's tail stays behind where the fluid is
    /// slow, next to a wall (a capsule whose surface was 5 cells from a wall leaves `phi` ~ 1e-5
    /// there): the box then waits (`by` itself on a periodic axis).
    pub(crate) fn far_field_move(&self, axis: usize, by: isize) -> isize {
        if by == 0 || !self.boxed.window.segments()[axis] {
            return by;
        }
        let (g, phi) = (&self.boxed.grid, &self.cur.phi);
        let n = g.n()[axis];
        // The largest phi per layer across the axis, in the order the move carries them round.
        let mut layer = vec![0.0f64; n];
        for (i, j, k) in g.cells() {
            let l = &mut layer[[i, j, k][axis]];
            *l = l.max(phi.data[g.idx_u(i, j, k)].f64());
        }
        if by < 0 {
            layer.reverse();
        }
        let allowed = layer.iter().take(by.unsigned_abs()).take_while(|&&p| p <= FAR_FIELD).count();
        by.signum() * allowed as isize
    }

    /// Moves the box by `by` cells along ring or segment axis `axis` of the whole grid `whole`, rolling the
    /// state with it (the transport's history first: a transport that refuses leaves
    /// everything as it was), and derives the geometry and the membrane map anew there.
    pub(crate) fn shift(
        &mut self,
        whole: &Grid<T>,
        axis: usize,
        by: isize,
        normals: &mut dyn NormalEstimator<T>,
    ) -> Result<()> {
        self.transport.roll(&self.boxed.grid, axis, by)?;
        self.boxed.window.shift(axis, by)?;
        let mut line = Vec::new();
        let g = &self.boxed.grid;
        Window::roll(g, &mut self.cur.phi, axis, by, &mut line);
        if let Some(k) = self.cur.kappa.as_mut() {
            Window::roll(g, k, axis, by, &mut line);
        }
        if let Some(gs) = self.gs.as_mut() {
            Window::roll_sym(g, gs, axis, by, &mut line);
        }
        if let Some(s) = self.strain.as_mut() {
            s.roll(axis, by);
        }
        self.boxed.grid = self.boxed.window.grid(whole);
        self.cur.derive(&self.boxed.grid, normals)?;
        if let Some(e) = self.extension.as_mut() {
            e.rebuild(&self.cur.band, &self.cur.phi, &self.cur.normal)?;
        }
        Ok(())
    }

    /// Moves the capsule into the box `to` of the whole grid `whole`, grown from its own
    /// ([`Window::grown`]): the state (`phi`, `kappa_R tilde`, `G_s`, the transports' histories)
    /// cell for cell of the whole grid, the cells new to the box as a capsule built there would
    /// have them (`phi` 0, `G_s` the projector), and the geometry, band and membrane map
    /// derived anew. The transport first: one that refuses leaves everything as it was.
    pub(crate) fn regrow(
        &mut self,
        whole: &Grid<T>,
        to: Window,
        settings: &Settings<T>,
        normals: &mut dyn NormalEstimator<T>,
    ) -> Result<()> {
        let (from, from_grid) = (&self.boxed.window, &self.boxed.grid);
        let to_grid = to.grid(whole);
        self.transport.regrow(from, from_grid, &to, &to_grid)?;
        let curvature = self.cur.kappa.is_some();
        let mut cur = Level::zeros(&to_grid, curvature, settings.epsilon)?;
        from.transfer_slice(from_grid, &self.cur.phi.data, &to, &to_grid, &mut cur.phi.data)?;
        if let (Some(a), Some(b)) = (self.cur.kappa.as_ref(), cur.kappa.as_mut()) {
            from.transfer_slice(from_grid, &a.data, &to, &to_grid, &mut b.data)?;
        }
        cur.derive(&to_grid, normals)?;
        let gs = match self.gs.as_ref() {
            Some(old) => {
                let mut gs = SymField::zeros(&to_grid);
                fill_projector(&to_grid, &cur.normal, &mut gs);
                for (a, b) in old.c.iter().zip(gs.c.iter_mut()) {
                    from.transfer_slice(from_grid, &a.data, &to, &to_grid, &mut b.data)?;
                }
                Some(gs)
            }
            None => None,
        };
        if let Some(s) = self.strain.as_mut() {
            s.regrow(from, from_grid, &to, &to_grid)?;
        }
        self.extension = membrane_map(&to_grid, self.traction(), settings, &cur)?;
        self.next = Level::zeros(&to_grid, curvature, settings.epsilon)?;
        self.cur = cur;
        self.gs = gs;
        self.boxed = Boxed::new(whole, to, self.boxed.scratch.clone());
        Ok(())
    }
}
