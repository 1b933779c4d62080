//! The stiff part of the bending force, linearised in the velocity, for the predictor: what
//! makes the bending step limit grow like `h²` or better instead of `h³`.
//!
//! The bending force (2.16)-(2.17) is evaluated from the shape `φ^{n+1}` and then drives the
//! velocity `v^{n+1}` that moves the shape on to `φ^{n+2}`: explicit in time, with the limit
//! `dt <= C mu h³ / E_b` of [`crate::simulation::stability`] (a short wave of the membrane
//! relaxes at the rate `E_b k³ / mu`). Its stiff part is known: a normal velocity `w` of the
//! membrane changes the curvature tensor at the rate
//!
//! ```text
//! dκ/dt = P (∇∇w) P + (lower order),      w = v·n   (n inward, as in [`super::bending`]),
//! ```
//!
//! so the moment `m̃ = E_b (δ κ − κ̃_R P)` at the rate `E_b δ P (∇∇w) P`, and the force at the
//! rate `L(v) = ∇·(q̃_L n_out)`, `q̃_L = (∇·m̃_L)·P`, `m̃_L = E_b δ P (∇∇(v·n)) P` (the same two
//! divergences as the force itself). For a flat membrane `z = ζ(x)`, `L(v) = −E_b ∂⁴_x v_z e_z`:
//! the plate operator, negative definite. The semi-implicit force of a step is
//!
//! ```text
//! f_b* = f_b(φ^{n+1}) + α Δt L(v*),
//! ```
//!
//! the force at the shape `α` of the way along the step that `v*` drives (`α = 1/2`: the
//! midpoint, second order). In a model of one short wave (`r = Δt E_b k³/mu`) the amplitude
//! changes by `(1 − (1 − α) r)/(1 + α r)` per step: bounded for every `dt` when `α >= 1/2`,
//! damped towards 0 when `α = 1`. The predictor takes `−α Δt L(v*)` into its operator, like the
//! in-plane term of (2.35); the curvature's lower-order terms and the motion of `δ` and `P` stay
//! explicit.
//!
//! Measured on the bending shear case (`E_b' = 0.0375`, `Ca = 0.05`, N = 64, the adaptive step
//! 0.0095, 25 times the largest stable explicit step): with `α = 1` `D(t)` stays within 1.6 % of
//! the explicit run at `dt = 3.75e-4` up to `t = 1` (0.01 % at `t = 1`); with `α = 0.5` and
//! `0.6` it departs by up to 51 % and 37 % (the short waves, undamped or barely damped, grow
//! through the explicit parts). Hence `α = 1`, the default of
//! [`BendingCoupling::SemiImplicit`](crate::simulation::BendingCoupling::SemiImplicit).
//!
//! # Discretisation
//!
//! `w = v_cell·n` on the cells of `halo(1)` (velocity averaged from the faces), `∇∇w` by the
//! compact second differences (`(w_{+1} − 2w + w_{−1})/h²` on the diagonal, the four diagonal
//! neighbours off it) on the band, then the steps 2-3 of the bending force
//! ([`super::bending`]). The compact differences weigh the shortest waves at least as much as
//! the wide central differences of the force's own curvature, so the implicit term is never
//! weaker than the force it stabilises.

use super::band::Band;
use super::bending::{face_force_of_moment, shear_tension_at};
use super::force::{face_divergence, scatter_add};
use crate::error::positive;
use crate::fluid::momentum::ImplicitTerm;
use crate::grid::ops::{cell_vector, velocity_at_cell};
use crate::grid::{Field, Grid, VectorField};
use crate::tensor::{Mat3, Vec3, dot, matmul, projector, sym_to_mat};
use crate::{Error, Real, Result};
use rayon::prelude::*;
use std::sync::Mutex;

/// Cells per rayon task.
const MIN_CELLS_PER_TASK: usize = 256;

/// The bending rate operator `L` of the [module docs](self), with its weight `α Δt` and its work
/// arrays (one per scene: the capsules are applied one after the other).
#[derive(Debug)]
pub struct BendingImplicit<T> {
    eb: T,
    alpha: T,
    /// `α Δt` of the current step.
    weight: T,
    grid: Grid<T>,
    work: Mutex<Work<T>>,
}

#[derive(Debug, Default)]
struct Work<T> {
    /// `w = v·n` per cell of `halo(1)`.
    w: Vec<T>,
    /// `m̃_L` per band cell.
    m: Vec<Mat3<T>>,
    /// `q̃_L` per cell of `halo(1)`.
    q: Vec<Vec3<T>>,
    /// Face force per cell of `halo(2)`.
    f: Vec<[T; 3]>,
}

impl<T: Real> BendingImplicit<T> {
    /// The operator for bending modulus `eb` on `grid`, the force taken `alpha` of the way along
    /// the step. Nothing is allocated until the first application.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `eb` unless finite and `> 0`, or `bending alpha` (the
    /// `alpha` of [`BendingCoupling::SemiImplicit`](crate::simulation::BendingCoupling)) unless
    /// in `[1/2, 1]`.
    pub fn new(grid: &Grid<T>, eb: T, alpha: T) -> Result<Self> {
        positive("eb", eb)?;
        if !(alpha >= T::lit(0.5) && alpha <= T::one()) {
            return Err(Error::invalid("bending alpha", alpha, "a weight in [0.5, 1]"));
        }
        Ok(BendingImplicit { eb, alpha, weight: T::zero(), grid: grid.clone(), work: Mutex::default() })
    }

    /// Sets the step: the weight of `L` becomes `alpha dt`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `dt` unless finite and `> 0`.
    pub fn set_dt(&mut self, dt: T) -> Result<()> {
        positive("dt", dt)?;
        self.weight = self.alpha * dt;
        Ok(())
    }

    /// The implicit term `−α Δt L(x)` of the predictor on `band`, with the unit normal `normal`
    /// (cell centres, ghosts filled) and `delta`, at the level of the bending force (`n+1`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `grid`, `normal` or `delta` for fields or a band of
    /// another grid.
    pub fn term<'a>(
        &'a self,
        band: &'a Band<T>,
        normal: &'a [Field<T>; 3],
        delta: &'a Field<T>,
    ) -> Result<BendingImplicitTerm<'a, T>> {
        band.matches(&self.grid)?;
        let len = self.grid.len();
        if normal.iter().any(|f| f.data.len() != len) || delta.data.len() != len {
            return Err(Error::invalid(
                "normal or delta",
                "a field of another grid",
                "a field of the band's grid",
            ));
        }
        Ok(BendingImplicitTerm { op: self, band, normal, delta })
    }
}

/// The compact Hessian `∂_i ∂_j w` at cell `idx` from `w` at the cell and its face and edge
/// neighbours.
#[inline]
fn hessian_at<T: Real>(st: &[usize; 3], ih: &[T; 3], idx: usize, w: impl Fn(usize) -> T) -> Mat3<T> {
    let w0 = w(idx);
    let two = T::lit(2.0);
    let quarter = T::lit(0.25);
    let mut hs = [[T::zero(); 3]; 3];
    for i in 0..3 {
        hs[i][i] = (w(idx + st[i]) - two * w0 + w(idx - st[i])) * ih[i] * ih[i];
        for j in i + 1..3 {
            let (a, b) = (st[i], st[j]);
            let x =
                (w(idx + a + b) - w(idx + a - b) - w(idx - a + b) + w(idx - a - b)) * quarter * ih[i] * ih[j];
            hs[i][j] = x;
            hs[j][i] = x;
        }
    }
    hs
}

/// One application of `−α Δt L` (see [`BendingImplicit::term`]).
#[derive(Debug, Clone, Copy)]
pub struct BendingImplicitTerm<'a, T> {
    op: &'a BendingImplicit<T>,
    band: &'a Band<T>,
    normal: &'a [Field<T>; 3],
    delta: &'a Field<T>,
}

impl<T: Real> BendingImplicitTerm<'_, T> {
    /// `m̃ = −α Δt E_b δ P (∇∇w) P` at band cell `idx`, `w` looked up by `w`.
    #[inline]
    fn moment_at(&self, st: &[usize; 3], ih: &[T; 3], idx: usize, w: impl Fn(usize) -> T) -> Mat3<T> {
        let hs = hessian_at(st, ih, idx, w);
        let p = sym_to_mat(&projector(&cell_vector(self.normal, idx)));
        let s = -self.op.weight * self.op.eb * self.delta.data[idx];
        matmul(&matmul(&p, &hs), &p).map(|row| row.map(|x| s * x))
    }

    /// `w = v_cell·n` at cell `idx`.
    #[inline]
    fn w_at(&self, x: &VectorField<T>, idx: usize) -> T {
        dot(&velocity_at_cell(&self.op.grid, x, idx), &cell_vector(self.normal, idx))
    }
}

impl<T: Real> ImplicitTerm<T> for BendingImplicitTerm<'_, T> {
    /// Adds `−α Δt L(x)` on the faces of `halo(2)` (ghosts of `x` filled).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `velocity` or `force` for fields of another grid.
    fn add_apply(&self, _grid: &Grid<T>, x: &VectorField<T>, y: &mut VectorField<T>) -> Result<()> {
        let grid = &self.op.grid;
        x.matches(grid, "velocity")?;
        y.matches(grid, "force")?;
        if self.band.is_empty() {
            return Ok(());
        }
        let mut guard = self.op.work.lock().unwrap_or_else(|p| p.into_inner());
        let Work { w, m, q, f } = &mut *guard;
        let band = self.band;
        let cells1 = band.halo(1);
        w.resize(cells1.len(), T::zero());
        w.par_iter_mut()
            .zip(cells1.par_iter())
            .with_min_len(MIN_CELLS_PER_TASK)
            .for_each(|(wo, &idx)| *wo = self.w_at(x, idx));
        let st = grid.strides();
        let h = grid.h();
        let ih: [T; 3] = std::array::from_fn(|d| T::one() / h[d]);
        let wl = &*w;
        let w_of = |p: usize| band.position_in(p, 1).map_or(T::zero(), |b| wl[b]);
        m.resize(band.len(), [[T::zero(); 3]; 3]);
        m.par_iter_mut()
            .zip(band.cells().par_iter())
            .with_min_len(MIN_CELLS_PER_TASK)
            .for_each(|(mo, &idx)| *mo = self.moment_at(&st, &ih, idx, w_of));
        face_force_of_moment(grid, band, self.normal, m, q, f);
        scatter_add(band.halo(2), f, y);
        Ok(())
    }

    /// The same at one face, recomputing `w`, `m̃` and `q̃` around it (for SOR).
    fn apply_at(&self, _grid: &Grid<T>, x: &VectorField<T>, c: usize, idx: usize) -> T {
        let band = self.band;
        if band.position_in(idx, 2).is_none() {
            return T::zero();
        }
        let grid = &self.op.grid;
        let st = grid.strides();
        let h = grid.h();
        let ih: [T; 3] = std::array::from_fn(|d| T::one() / h[d]);
        let m_of = |p: usize| match band.position_in(p, 0) {
            Some(_) => self.moment_at(&st, &ih, p, |r| self.w_at(x, r)),
            None => [[T::zero(); 3]; 3],
        };
        face_divergence(&st, &ih, c, idx, |p| match band.position_in(p, 1) {
            Some(_) => {
                let q = shear_tension_at(grid, self.normal, p, m_of);
                let n = cell_vector(self.normal, p);
                std::array::from_fn(|a| std::array::from_fn(|b| -q[a] * n[b]))
            }
            None => [[T::zero(); 3]; 3],
        })
    }
}
