//! The sharp shell's outer layers as a closest-point extension of its core layers, for `G_s`
//! and, by the transpose, for the stress.
//!
//! # Why
//!
//! With the sharp membrane velocity ([`super::extension`]) every layer of the smoothed shell
//! slides with the surface, but a layer at depth `s` has the area of the parallel surface,
//! `(1 − s κ₁)(1 − s κ₂)` times the surface's. Where the shell's inner layers reach the medial
//! axis of a thin part (the tips of a capsule in shear: their radius of curvature is 1.4 cells
//! at `N` = 64, Ca = 0.2) they are crushed: `c2` falls to zero and below, and the transport of
//! `G_s` there creates elastic energy without work until the steps collapse.
//!
//! # The map
//!
//! A band cell deeper than [`RESAMPLE_DEPTH`] cells (`|s| = |ψ| h / β`) is an *outer* cell. Its
//! closest surface point `x_Γ = x − s n` has a trilinear stencil of eight cell centres; those
//! that are *core* band cells (depth at most [`RESAMPLE_DEPTH`], normal within 60° of the
//! outer cell's) carry the weights `w_k` (renormalised to sum to one). The linear map `A` from
//! the core cells' symmetric tensors to the outer cells' is
//!
//! ```text
//! (A X)_o = P_o ( Σ_k w_k R_k X_k R_kᵀ ) P_o,
//! ```
//!
//! `R_k` the least rotation taking the core cell's normal to the outer cell's, `P_o = I − n nᵀ`.
//! An outer cell without such a core cell (a tail of the profile beyond a tip) is an *orphan*:
//! no sample of the membrane.
//!
//! - [`OuterLayers::resample`] sets `G_s` of the outer cells to `A G_s` (orphans to `P`, as the
//!   paper re-sets the cells outside the band) after every step: the whole shell carries the
//!   surface's deformation, as it carries its velocity (Ruuth & Merriman's closest point
//!   method; the core layers keep their transport, so that no interpolation is repeated on them
//!   step after step).
//! - The outer cells' `G_s` is then a function of the core's, so the elastic energy is
//!   `E = Σ_core e(G_k) + Σ_outer e((A G)_o)` and its rate is the stress power on the core
//!   cells' stretching alone. [`OuterLayers::gather`] gives the outer cells the rates `A Ġ` of
//!   the core (for the quasi-implicit term `H = J : Ġ` of (2.35)), and [`OuterLayers::scatter`]
//!   moves the outer cells' stress `S_o = δ_o τ_o` onto the core with the transpose,
//!   `S_k += Σ_o w_k R_kᵀ P_o S_o P_o R_k` (the Frobenius adjoint of `A`), leaving the outer
//!   cells without stress of their own. The force `∇·S` then does the work the energy of the
//!   whole shell takes, and the quasi-implicit operator keeps the structure `D_hᵀ Aᵀ K A D_h`.
//!   (The transfer of `τ_o` rather than of `2 G_k ∂e/∂G_o` is exact where the core cells of a
//!   stencil agree, `G_k = R_kᵀ (A G)_o R_k`, and first-order in their difference otherwise.)
//!
//! # Crushed core layers
//!
//! The core layers keep their own transport, and one of them can be crushed too: outside a part
//! of the surface that is flattened or dented (the side of a capsule that faces a wall or a
//! neighbour) the medial axis of the shell comes within [`RESAMPLE_DEPTH`]. Such a layer's
//! area ratio `J_s` falls towards zero (and its `G_s` can turn indefinite), its stress grows
//! without bound, and the fluid velocity on one face next to it alternates in sign from step
//! to step, whatever the step (a 6-capsule suspension at 5 cells per radius: `max|v|` 35 against
//! the walls' 3.9, in steps of 0.0017). [`OuterLayers::repair`] re-sets, after every step and
//! before [`OuterLayers::resample`], each core cell whose `J_s` is below [`MIN_AREA_RATIO`] to the
//! closest-point extension of the healthy core, as it sets the outer cells (docs/validation/
//! shear_capsule.md: none at Ca = 0.0125, 236 cells in 1262 steps at Ca = 0.2, N = 64).
//!
//! Not in the paper: the paper's shell has no sharp velocity and no crushed layers.

use super::band::{Band, band_spacing};
use super::extension::{Point, trilinear};
use super::stress::surface_kinematics;
use crate::grid::ops::cell_vector;
use crate::grid::{Field, Grid, SymField};
use crate::interface::geometry::psi_of;
use crate::tensor::{Mat3, Sym, dot, project, projector, rotate, rotation_taking, transpose};
use crate::{Error, Real, Result};
use rayon::prelude::*;
use std::sync::{Mutex, MutexGuard};

/// The depth `|s| / h` (in cells, `h` the band's spacing) beyond which a band cell is an
/// outer cell. The trilinear stencil around a surface point reaches `√3/2` of a cell from it
/// along the normal; 1.5 cells keeps it within the core layers nearly everywhere, and the band
/// reaches 2.65 cells (`ε` = 0.01, `β` = 1), so that one layer on each side is outer.
pub const RESAMPLE_DEPTH: f64 = 1.5;

/// The smallest area ratio `J_s = √c2` ((2.3b)) a core layer may carry: a layer squeezed
/// below half its reference area is crushed, not a sample of the membrane
/// ([`OuterLayers::repair`]).
pub const MIN_AREA_RATIO: f64 = 0.5;

/// Outer cells per rayon task.
const MIN_CELLS_PER_TASK: usize = 128;

/// One core cell of an outer cell's stencil.
#[derive(Debug, Clone, Copy)]
struct Entry<T> {
    /// Its position in the band.
    core: u32,
    /// Its (renormalised) weight.
    w: T,
    /// The least rotation taking its normal to the outer cell's.
    r: Mat3<T>,
}

/// An outer cell and the core cells of its closest point's stencil (none for an orphan).
#[derive(Debug, Clone, Copy)]
struct Stencil<T> {
    /// Its position in the band.
    outer: u32,
    /// Its projector `P_o`.
    p: Sym<T>,
    entries: [Entry<T>; 8],
    len: u8,
}

impl<T: Real> Stencil<T> {
    fn entries(&self) -> &[Entry<T>] {
        &self.entries[..self.len as usize]
    }

    /// `(A X)_o` from the core values `x(k)` (`k` a band position); `None` for an orphan.
    fn interpolate(&self, x: impl Fn(usize) -> Sym<T>) -> Option<Sym<T>> {
        if self.len == 0 {
            return None;
        }
        let mut sum = [T::zero(); 6];
        for e in self.entries() {
            for (s, r) in sum.iter_mut().zip(rotate(&e.r, &x(e.core as usize))) {
                *s += e.w * r;
            }
        }
        Some(project(&self.p, &sum))
    }
}

/// The outer layers of a sharp shell and the map `A` from its core (see the
/// [module docs](self)), rebuilt from `phi` and the normals whenever the band is.
#[derive(Debug)]
pub struct OuterLayers<T> {
    grid: Grid<T>,
    beta: T,
    stencils: Vec<Stencil<T>>,
    /// Per band position `k`, `users[starts[k]..starts[k + 1]]`: the `(stencil, entry)` pairs
    /// that read core cell `k`, in the order of the stencils (so that the transpose sums in
    /// a fixed order).
    starts: Vec<u32>,
    users: Vec<(u32, u8)>,
    /// One value per stencil (scratch of the parallel passes).
    values: Mutex<Vec<Sym<T>>>,
    /// The crushed core cells' stencils and new values (scratch of [`OuterLayers::repair`]).
    repairs: Mutex<Vec<(Stencil<T>, Sym<T>)>>,
    generation: u64,
}

impl<T: Real> OuterLayers<T> {
    /// No outer layers yet, for `grid` and the profile sharpness `beta` (`beta' = beta / h`,
    /// (2.42)).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `beta` unless it is finite and `> 0`.
    pub fn new(grid: &Grid<T>, beta: T) -> Result<Self> {
        crate::error::positive("beta", beta)?;
        Ok(OuterLayers {
            grid: grid.clone(),
            beta,
            stencils: Vec::new(),
            starts: Vec::new(),
            users: Vec::new(),
            values: Mutex::new(Vec::new()),
            repairs: Mutex::new(Vec::new()),
            generation: 0,
        })
    }

    /// The band generation of the last [`rebuild`](Self::rebuild) (0 before the first).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The number of outer cells (orphans included).
    pub fn len(&self) -> usize {
        self.stencils.len()
    }

    /// Whether the band has no outer cell.
    pub fn is_empty(&self) -> bool {
        self.stencils.is_empty()
    }

    /// Finds the outer cells of `band` and their stencils from `phi` and the unit normals
    /// `normal` (into the capsule; both at cell centres, ghosts filled).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `grid` for a band or field of another grid.
    pub fn rebuild(&mut self, band: &Band<T>, phi: &Field<T>, normal: &[Field<T>; 3]) -> Result<()> {
        let grid = &self.grid;
        band.matches(grid)?;
        let len = grid.len();
        if phi.data.len() != len || normal.iter().any(|f| f.data.len() != len) {
            return Err(Error::invalid("grid", "a field of another grid", "a field of the band's grid"));
        }
        let scale = band_spacing(grid) / self.beta;
        let depth = T::lit(RESAMPLE_DEPTH) * band_spacing(grid);
        let depth_of = |idx: usize| (psi_of(phi.data[idx]) * scale).abs();
        let zero = Entry { core: 0, w: T::zero(), r: [[T::zero(); 3]; 3] };
        self.stencils.clear();
        for (q, &idx) in band.cells().iter().enumerate() {
            let n = cell_vector(normal, idx);
            // A NaN normal compares false: no normal, no closest point, no outer cell.
            if depth_of(idx) > depth && dot(&n, &n) > T::lit(0.5) {
                let outer = u32::try_from(q).map_err(|_| {
                    Error::invalid(
                        "grid",
                        format!("a band of {} cells", band.len()),
                        "at most 2^32 band cells",
                    )
                })?;
                self.stencils.push(Stencil { outer, p: projector(&n), entries: [zero; 8], len: 0 });
            }
        }
        let is_core = |k: usize| depth_of(band.cells()[k]) <= depth;
        self.stencils.par_iter_mut().with_min_len(MIN_CELLS_PER_TASK).for_each(|st| {
            closest_point_stencil(grid, band, phi, normal, scale, st, is_core);
        });
        // The reverse map, by counting.
        self.starts.clear();
        self.starts.resize(band.len() + 1, 0);
        for st in &self.stencils {
            for e in st.entries() {
                self.starts[e.core as usize + 1] += 1;
            }
        }
        for k in 0..band.len() {
            self.starts[k + 1] += self.starts[k];
        }
        self.users.clear();
        self.users.resize(self.starts[band.len()] as usize, (0, 0));
        // `starts[k]` as the cursor of cell k (ending at `starts[k + 1]`), then shifted back.
        for (i, st) in self.stencils.iter().enumerate() {
            for (j, e) in st.entries().iter().enumerate() {
                let at = &mut self.starts[e.core as usize];
                self.users[*at as usize] = (i as u32, j as u8);
                *at += 1;
            }
        }
        self.starts.copy_within(..band.len(), 1);
        self.starts[0] = 0;
        self.generation = band.generation();
        Ok(())
    }

    pub(crate) fn check_band(&self, band: &Band<T>) -> Result<()> {
        band.check_generation("OuterLayers", self.generation, "built")
    }

    /// Sets `G_s` of every outer cell to `A G_s` (an orphan to `P`); the core cells are not
    /// touched. `gs` is read on the band's core cells only.
    ///
    /// # Errors
    /// [`Error::Unsupported`] unless the layers were built on `band`;
    /// [`Error::InvalidParameter`] naming `gs` for a field of another grid.
    pub fn resample(&self, band: &Band<T>, gs: &mut SymField<T>) -> Result<()> {
        self.check_band(band)?;
        if gs.c.iter().any(|f| f.data.len() != self.grid.len()) {
            return Err(Error::invalid("gs", "a field of another grid", "a field of the band's grid"));
        }
        let cells = band.cells();
        let values = {
            let read: &SymField<T> = gs;
            self.values_of(|st| st.interpolate(|k| read.get(cells[k])).unwrap_or(st.p))
        };
        for (st, g) in self.stencils.iter().zip(values.iter()) {
            gs.set(cells[st.outer as usize], g);
        }
        Ok(())
    }

    /// Re-sets `G_s` of every crushed core cell, one whose area ratio `J_s` is below
    /// [`MIN_AREA_RATIO`] (or that has no area at all), to the closest-point extension of the
    /// core cells that are not crushed, as [`resample`](Self::resample) sets the outer cells (an
    /// orphan to `P`), and returns how many it re-set. Run before `resample` (which reads the
    /// core), on the band, `phi` and normals the layers were built on.
    ///
    /// Why: with the sharp velocity a layer at depth `s` keeps `(1 − s κ₁)(1 − s κ₂)` of the
    /// surface's area, which vanishes where the layer meets a medial axis of the shell; outside a
    /// flattened or dented part of the surface that happens within [`RESAMPLE_DEPTH`], and the
    /// stress of the crushed layer, whose energy grows without bound as `J_s → 0`, drives a
    /// velocity that alternates in sign from step to step at one face, at any step size.
    ///
    /// # Errors
    /// [`Error::Unsupported`] unless the layers were built on `band`;
    /// [`Error::InvalidParameter`] naming `gs`, `phi` or `normal` for a field of another grid.
    pub fn repair(
        &self,
        band: &Band<T>,
        phi: &Field<T>,
        normal: &[Field<T>; 3],
        gs: &mut SymField<T>,
    ) -> Result<usize> {
        self.check_band(band)?;
        let len = self.grid.len();
        for (name, bad) in [
            ("gs", gs.c.iter().any(|f| f.data.len() != len)),
            ("phi", phi.data.len() != len),
            ("normal", normal.iter().any(|f| f.data.len() != len)),
        ] {
            if bad {
                return Err(Error::invalid(name, "a field of another grid", "a field of the band's grid"));
            }
        }
        let grid = &self.grid;
        let cells = band.cells();
        let scale = band_spacing(grid) / self.beta;
        let depth = T::lit(RESAMPLE_DEPTH) * band_spacing(grid);
        let min_c2 = T::lit(MIN_AREA_RATIO * MIN_AREA_RATIO);
        let mut repairs = self.repairs.lock().unwrap_or_else(|p| p.into_inner());
        repairs.clear();
        {
            let read: &SymField<T> = gs;
            let is_core = |k: usize| (psi_of(phi.data[cells[k]]) * scale).abs() <= depth;
            // A NaN invariant is crushed too.
            let crushed = |k: usize| {
                let n = cell_vector(normal, cells[k]);
                let c2 = surface_kinematics(&read.get(cells[k]), &n).c2;
                is_core(k) && (c2 < min_c2 || c2.is_nan())
            };
            let zero = Entry { core: 0, w: T::zero(), r: [[T::zero(); 3]; 3] };
            for k in 0..band.len() {
                let n = cell_vector(normal, cells[k]);
                // A NaN normal compares false: no tangent plane, nothing to repair.
                if dot(&n, &n) > T::lit(0.5) && crushed(k) {
                    let st = Stencil { outer: k as u32, p: projector(&n), entries: [zero; 8], len: 0 };
                    repairs.push((st, [T::zero(); 6]));
                }
            }
            repairs.par_iter_mut().with_min_len(MIN_CELLS_PER_TASK).for_each(|(st, value)| {
                closest_point_stencil(grid, band, phi, normal, scale, st, |k| is_core(k) && !crushed(k));
                *value = st.interpolate(|k| read.get(cells[k])).unwrap_or(st.p);
            });
        }
        for (st, value) in repairs.iter() {
            gs.set(cells[st.outer as usize], value);
        }
        Ok(repairs.len())
    }

    /// `x_o = (A x)_o` for every outer cell (zero for an orphan), `x` one value per band cell
    /// (in the order of [`Band::cells`]); the core values are not touched.
    pub fn gather(&self, x: &mut [Sym<T>]) {
        let values = {
            let read: &[Sym<T>] = x;
            self.values_of(|st| st.interpolate(|k| read[k]).unwrap_or([T::zero(); 6]))
        };
        for (st, v) in self.stencils.iter().zip(values.iter()) {
            x[st.outer as usize] = *v;
        }
    }

    /// `x_k += (Aᵀ x)_k` on the core cells, then `x_o = 0` on the outer cells: the outer
    /// cells' values moved onto the core with the transpose of [`gather`](Self::gather).
    pub fn scatter(&self, x: &mut [Sym<T>]) {
        // `P_o x_o P_o` per outer cell, then emptied.
        let values = {
            let read: &[Sym<T>] = x;
            self.values_of(|st| project(&st.p, &read[st.outer as usize]))
        };
        for st in &self.stencils {
            x[st.outer as usize] = [T::zero(); 6];
        }
        // Each core cell sums what its users send back, in the stencils' order.
        let (starts, users, values) = (&self.starts, &self.users, &*values);
        x.par_iter_mut().enumerate().with_min_len(MIN_CELLS_PER_TASK).for_each(|(k, xk)| {
            let Some(range) = starts.get(k..k + 2) else { return };
            for &(i, j) in &users[range[0] as usize..range[1] as usize] {
                let e = &self.stencils[i as usize].entries[j as usize];
                let back = rotate(&transpose(&e.r), &values[i as usize]);
                for (a, b) in xk.iter_mut().zip(back) {
                    *a += e.w * b;
                }
            }
        });
    }

    /// `value(stencil)` for every stencil, computed in parallel into the scratch (in the order
    /// of the stencils).
    fn values_of(&self, value: impl Fn(&Stencil<T>) -> Sym<T> + Sync) -> MutexGuard<'_, Vec<Sym<T>>> {
        let mut values = self.values.lock().unwrap_or_else(|p| p.into_inner());
        values.resize(self.stencils.len(), [T::zero(); 6]);
        values
            .par_iter_mut()
            .zip(self.stencils.par_iter())
            .with_min_len(MIN_CELLS_PER_TASK)
            .for_each(|(v, st)| *v = value(st));
        values
    }
}

/// Fills the entries of `st` (its cell `st.outer` a band cell with a unit normal): the band
/// cells of the trilinear stencil around its closest surface point `x − s n` that `source`
/// accepts (by band position), with their weights renormalised to sum to one and the rotations
/// taking their normals to the cell's; none where their weights sum to at most `1e-3` (an
/// orphan). `scale` is `h / β`, so that `s = ψ(φ) scale`.
fn closest_point_stencil<T: Real>(
    grid: &Grid<T>,
    band: &Band<T>,
    phi: &Field<T>,
    normal: &[Field<T>; 3],
    scale: T,
    st: &mut Stencil<T>,
    source: impl Fn(usize) -> bool,
) {
    st.len = 0;
    let q = st.outer as usize;
    let idx = band.cells()[q];
    let n = cell_vector(normal, idx);
    let ijk = band.coords(0)[q].map(|x| x as isize);
    let x = grid.cell_center(ijk[0], ijk[1], ijk[2]);
    let s = psi_of(phi.data[idx]) * scale;
    let xg: [T; 3] = std::array::from_fn(|d| x[d] - s * n[d]);
    let Some(corners) = Point::new(grid, &xg).and_then(|p| trilinear(grid, None, &p)) else {
        return;
    };
    let mut weight = T::zero();
    for (at, w) in corners {
        // Band cells only (the stencil's periodic corners are wrapped already; a ghost across a
        // wall is in no band).
        let Some(k) = band.position(at).filter(|&k| k < band.len()) else { continue };
        if w == T::zero() || !source(k) {
            continue;
        }
        let Some(r) = rotation_taking(&cell_vector(normal, band.cells()[k]), &n) else { continue };
        st.entries[st.len as usize] = Entry { core: k as u32, w, r };
        st.len += 1;
        weight += w;
    }
    if weight > T::lit(1e-3) {
        let len = st.len as usize;
        for e in &mut st.entries[..len] {
            e.w /= weight;
        }
    } else {
        st.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::membrane::extension::tests::{noise, sphere};
    use crate::tensor::ddot;

    fn layers(
        g: &Grid<f64>,
        band: &Band<f64>,
        phi: &Field<f64>,
        normal: &[Field<f64>; 3],
    ) -> OuterLayers<f64> {
        let mut l = OuterLayers::new(g, 1.0).unwrap();
        l.rebuild(band, phi, normal).unwrap();
        assert_eq!(l.generation(), band.generation());
        l
    }

    fn depth(phi: &Field<f64>, idx: usize) -> f64 {
        psi_of(phi.data[idx]).abs()
    }

    /// An isotropic stretch `a P(n)` on the core layers: every outer cell takes `a P` of its
    /// own normal, whatever it held, and the core is not touched.
    #[test]
    fn outer_layers_take_the_strain_of_the_core() {
        let (g, phi, normal, band) = sphere(32);
        let l = layers(&g, &band, &phi, &normal);
        let a = 1.3;
        let mut gs = SymField::zeros(&g);
        for (k, &idx) in band.cells().iter().enumerate() {
            let p = projector(&cell_vector(&normal, idx));
            let value =
                if depth(&phi, idx) <= RESAMPLE_DEPTH { p.map(|x| a * x) } else { p.map(|x| x + noise(k)) };
            gs.set(idx, &value);
        }
        let before = gs.clone();
        l.resample(&band, &mut gs).unwrap();
        let (mut outer, mut worst) = ([0usize; 2], 0.0f64);
        for &idx in band.cells() {
            if depth(&phi, idx) <= RESAMPLE_DEPTH {
                assert_eq!(gs.get(idx), before.get(idx));
                continue;
            }
            outer[usize::from(phi.data[idx] > 0.5)] += 1;
            let expected = projector(&cell_vector(&normal, idx)).map(|x| a * x);
            let err = gs.get(idx).iter().zip(&expected).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
            worst = worst.max(err);
        }
        assert_eq!(outer[0] + outer[1], l.len());
        assert!(outer[0] > 500 && outer[1] > 200, "outer cells outside / inside: {outer:?}");
        assert!(worst < 1e-12, "largest deviation {worst}");
    }

    /// Outer cells whose closest point has no core layer around it are re-set to `P`.
    #[test]
    fn outer_layers_without_a_core_are_reset() {
        let (g, mut phi, normal, band) = sphere(32);
        // No core: every band cell reads as deep inside.
        for &idx in band.cells() {
            if depth(&phi, idx) <= RESAMPLE_DEPTH {
                phi.data[idx] = 0.9999;
            }
        }
        phi.fill_ghosts(&g);
        let l = layers(&g, &band, &phi, &normal);
        assert!(l.len() > 500);
        let mut gs = SymField::zeros(&g);
        let value = [2.0, 0.1, 0.2, 3.0, 0.3, 4.0];
        for &idx in band.cells() {
            gs.set(idx, &value);
        }
        l.resample(&band, &mut gs).unwrap();
        for &idx in band.cells() {
            let expected = match depth(&phi, idx) > RESAMPLE_DEPTH {
                true => projector(&cell_vector(&normal, idx)),
                false => value,
            };
            assert_eq!(gs.get(idx), expected);
        }
    }

    /// Crushed core cells (`J_s` below [`MIN_AREA_RATIO`], or no area at all) take the strain of
    /// the healthy core around their closest point; every other cell is left as it was.
    #[test]
    fn crushed_core_cells_take_the_strain_of_the_healthy_core() {
        let (g, phi, normal, band) = sphere(32);
        let l = layers(&g, &band, &phi, &normal);
        let a = 1.3;
        let mut gs = SymField::zeros(&g);
        let mut crushed = Vec::new();
        for (k, &idx) in band.cells().iter().enumerate() {
            let p = projector(&cell_vector(&normal, idx));
            let core = depth(&phi, idx) <= RESAMPLE_DEPTH;
            // Every 23rd core cell crushed: `J_s` 0.45, or a NaN.
            let value = match (core, k % 23) {
                (true, 0) => p.map(|x| 0.45 * x),
                (true, 11) => p.map(|_| f64::NAN),
                _ => p.map(|x| a * x),
            };
            if core && matches!(k % 23, 0 | 11) {
                crushed.push(idx);
            }
            gs.set(idx, &value);
        }
        let before = gs.clone();
        assert_eq!(l.repair(&band, &phi, &normal, &mut gs).unwrap(), crushed.len());
        assert!(crushed.len() > 100);
        for &idx in band.cells() {
            if crushed.contains(&idx) {
                let expected = projector(&cell_vector(&normal, idx)).map(|x| a * x);
                let err = gs.get(idx).iter().zip(&expected).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
                assert!(err < 1e-12, "repaired cell {idx}: deviation {err}");
            } else {
                assert_eq!(gs.get(idx), before.get(idx));
            }
        }
        // A stretch that is not crushed (`J_s` 0.55) is left alone.
        let idx = crushed[0];
        let mild = projector(&cell_vector(&normal, idx)).map(|x| 0.55 * x);
        gs.set(idx, &mild);
        assert_eq!(l.repair(&band, &phi, &normal, &mut gs).unwrap(), 0);
        assert_eq!(gs.get(idx), mild);
    }

    /// A crushed core with no healthy core cell around its closest point is re-set to `P`.
    #[test]
    fn crushed_core_without_a_healthy_one_is_reset() {
        let (g, phi, normal, band) = sphere(32);
        let l = layers(&g, &band, &phi, &normal);
        let mut gs = SymField::zeros(&g);
        let crushed = [0.1, 0.0, 0.0, 0.0, 0.0, 0.0];
        for &idx in band.cells() {
            gs.set(idx, &crushed);
        }
        let core = band.cells().iter().filter(|&&i| depth(&phi, i) <= RESAMPLE_DEPTH).count();
        assert_eq!(l.repair(&band, &phi, &normal, &mut gs).unwrap(), core);
        for &idx in band.cells() {
            let expected = match depth(&phi, idx) <= RESAMPLE_DEPTH {
                true => projector(&cell_vector(&normal, idx)),
                false => crushed,
            };
            assert_eq!(gs.get(idx), expected);
        }
    }

    /// `scatter` is the transpose of `gather` in the double contraction: `Σ_o (A x)_o : y_o =
    /// Σ_k x_k : (Aᵀ y)_k` for any core values `x` and outer values `y`.
    #[test]
    fn scatter_is_the_transpose_of_gather() {
        let (g, phi, normal, band) = sphere(32);
        let l = layers(&g, &band, &phi, &normal);
        let is_outer: Vec<bool> = band.cells().iter().map(|&i| depth(&phi, i) > RESAMPLE_DEPTH).collect();
        let random = |salt: usize| -> Vec<Sym<f64>> {
            (0..band.len()).map(|q| std::array::from_fn(|c| noise(6 * q + c + salt))).collect()
        };
        // x on the core only, y on the outer cells only.
        let mut x = random(1);
        let mut y = random(2);
        for (q, &o) in is_outer.iter().enumerate() {
            if o {
                x[q] = [0.0; 6];
            } else {
                y[q] = [0.0; 6];
            }
        }
        let mut ax = x.clone();
        l.gather(&mut ax);
        let mut aty = y.clone();
        l.scatter(&mut aty);
        let lhs: f64 = (0..band.len()).filter(|&q| is_outer[q]).map(|q| ddot(&ax[q], &y[q])).sum();
        let rhs: f64 = (0..band.len()).filter(|&q| !is_outer[q]).map(|q| ddot(&x[q], &aty[q])).sum();
        assert!(lhs.abs() > 1.0);
        assert!((lhs - rhs).abs() <= 1e-10 * lhs.abs(), "{lhs} vs {rhs}");
        // The core values are kept by gather, the outer ones emptied by scatter.
        for (q, &o) in is_outer.iter().enumerate() {
            match o {
                true => assert_eq!(aty[q], [0.0; 6]),
                false => assert_eq!(ax[q], x[q]),
            }
        }
    }
}
