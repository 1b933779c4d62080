//! What every capsule carries and how an effect sees it: the fields an effect [`Needs`], the
//! membrane of one capsule at one time level ([`MembraneView`]), and integrals over it. Below
//! the capsules and the effects, so that neither needs the other to describe a membrane.

use super::capsule::{BoxScratch, box_fields, lock_scratch};
use crate::grid::ops::cell_vector;
use crate::grid::{Field, Grid, SymField, VectorField, Window};
use crate::membrane::{
    band::Band,
    extension::SurfaceExtension,
    stress::{SurfaceKinematics, surface_kinematics},
};
use crate::{Real, Result};
use rayon::prelude::*;

/// The fields an [`Effect`](super::Effect) needs on the capsules it acts on, beyond `phi` and what is derived
/// from it (`delta`, normals, the membrane band), which every capsule has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Needs {
    /// The surface deformation tensor `G_s` (2.18), transported by (2.40).
    pub strain: bool,
    /// The convolved reference curvature `kappa_R tilde` (2.30), advected with `phi`.
    pub curvature: bool,
}

impl Needs {
    /// Nothing beyond `phi` and its geometry.
    pub const NONE: Needs = Needs { strain: false, curvature: false };
    /// `G_s`.
    pub const STRAIN: Needs = Needs { strain: true, curvature: false };
    /// `kappa_R tilde`.
    pub const CURVATURE: Needs = Needs { strain: false, curvature: true };
}

/// The membrane of one capsule at one time level, as an effect sees it. Its fields live on the
/// capsule's box ([`window`](Self::window)) and its [`grid`](Self::grid): indices of the band
/// and of the fields are the box grid's. A force on the fluid is added to the whole grid through
/// [`on_box`](Self::on_box).
#[derive(Debug, Clone, Copy)]
pub struct MembraneView<'a, T> {
    /// The grid of the capsule's box (the simulation's grid where the box is the whole grid).
    pub grid: &'a Grid<T>,
    /// The capsule's box in the simulation's grid.
    pub window: &'a Window,
    pub(crate) scratch: &'a BoxScratch<T>,
    /// The smoothed volume fraction `phi` (1 inside, 0 outside; ghosts filled).
    pub phi: &'a Field<T>,
    /// `delta = |grad phi|` (2.26) where `phi` is not saturated (ghosts filled).
    pub delta: &'a Field<T>,
    /// Unit normals at cell centres, pointing into the capsule (ghosts filled).
    pub normal: &'a [Field<T>; 3],
    /// The membrane band `delta h >= epsilon`, where every membrane force acts.
    pub band: &'a Band<T>,
    /// `kappa_R tilde` (2.30), where some effect [needs](Needs::curvature) it on this capsule.
    pub curvature: Option<&'a Field<T>>,
    /// `G_s` at `t^n` (valid on the band and its halo), where some effect
    /// [needs](Needs::strain) it on this capsule.
    pub gs: Option<&'a SymField<T>>,
    /// The map from the fluid velocity to the membrane velocity of [`Traction::Sharp`](super::Traction::Sharp), built
    /// for the step being computed (`None` where the capsule's traction is the smoothed one, see
    /// [`Effect::requested_traction`](super::Effect::requested_traction)): in-plane forces act through it.
    pub extension: Option<&'a SurfaceExtension<T>>,
}

impl<T: Real> MembraneView<'_, T> {
    /// Runs `f(box_grid, x, y)` for this capsule, for a force of its membrane: `x` is the
    /// staggered field `x` of the simulation's grid `grid` as the capsule's box sees it, and what
    /// `f` adds to `y` is added to `out` of `grid`, both on the faces of the band and its
    /// [`MAX_HALO`](crate::membrane::band::MAX_HALO) halo layers only (where a membrane force and its
    /// stencils reach; a force elsewhere, e.g. inside the capsule, is added to `out` directly).
    /// On a whole box `f` gets `grid`, `x` and `out` themselves.
    ///
    /// # Errors
    /// Fields of another grid ([`Error::InvalidParameter`](crate::Error::InvalidParameter)); `f`'s own.
    pub fn on_box(
        &self,
        grid: &Grid<T>,
        x: &VectorField<T>,
        out: &mut VectorField<T>,
        f: impl FnOnce(&Grid<T>, &VectorField<T>, &mut VectorField<T>) -> Result<()>,
    ) -> Result<()> {
        if self.window.is_whole() {
            return f(grid, x, out);
        }
        let mut lock = lock_scratch(self.scratch)?;
        let [bx, by] = box_fields(self.grid, &mut lock);
        // Only the faces of the band and its halo layers, where the membrane terms read and
        // write (their stencils and the membrane map's reach two cells beyond the band).
        let dims = grid.dims();
        let cells = self.band.halo(crate::membrane::band::MAX_HALO);
        let coords = self.band.coords(crate::membrane::band::MAX_HALO);
        let w = self.window;
        // One component a task: each writes its own field.
        bx.c.par_iter_mut().zip(by.c.par_iter_mut()).zip(x.c.par_iter()).for_each(|((bx, by), x)| {
            for (&b, &c) in cells.iter().zip(coords) {
                bx.data[b] = x.data[w.grid_index(dims, c)];
                by.data[b] = T::zero();
            }
        });
        f(self.grid, bx, by)?;
        out.c.par_iter_mut().zip(by.c.par_iter()).for_each(|(out, by)| {
            for (&b, &c) in cells.iter().zip(coords) {
                out.data[w.grid_index(dims, c)] += by.data[b];
            }
        });
        Ok(())
    }
}

/// Which time level of the capsules a [`StepState`] shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LevelChoice {
    Current,
    Next,
}

/// `sum delta q / j_s h^3` over the band of `m`: the integral of `q` (a function of the
/// surface kinematics of `gs`) over the membrane's reference area (`dA_R = dA / j_s`,
/// `j_s = sqrt(c2)`; cells with `c2 <= 0` left out).
pub(crate) fn reference_integral<T: Real>(
    grid: &Grid<T>,
    m: &MembraneView<'_, T>,
    gs: &SymField<T>,
    q: impl Fn(&SurfaceKinematics<T>) -> T,
) -> f64 {
    let mut s = 0.0;
    for &idx in m.band.cells() {
        let n = cell_vector(m.normal, idx);
        let k = surface_kinematics(&gs.get(idx), &n);
        if k.c2 > T::zero() {
            s += (m.delta.data[idx] * q(&k) / k.c2.sqrt()).f64();
        }
    }
    s * grid.cell_volume().f64()
}
