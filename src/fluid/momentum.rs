//! The momentum equation on the staggered grid: material coefficients, the viscous stress
//! divergence, the advection term, and the matrix-free predictor operator of (2.35).
//!
//! # Operators (component `c` at its face, `idx` the storage index of that face)
//! - viscous: `V(w)_c = div(mu (grad w + grad w^T))_c`, normal stresses at cell centres with the
//!   cell viscosity, shear stresses on cell edges with the average of the four neighbouring cell
//!   viscosities ((2.25) mixture values arrive from the caller);
//! - advection in the divergence form of the second-order staggered scheme, which conserves
//!   kinetic energy for a discretely divergence-free velocity (Morinishi et al. 1998):
//!   `A(v)_c = sum_a d_a( avg_c(v_a) avg_a(v_c) )`;
//! - predictor (2.35): `P x = (rho/dt) x - (1/2) V(x) + [extra implicit terms, e.g. the membrane
//!   term -(dt/4) div(delta H(x, G_s, J))]`, with `rho` averaged to the face. The rows of
//!   normal-velocity unknowns on a wall are the identity scaled by `rho/dt` (their value stays
//!   zero).

use super::krylov::{KrylovInfo, KrylovParams, KrylovWorkspace, bicgstab};
use super::krylov::{LinOp, Precond};
use super::spectral::{Location, SpectralSolver};
use crate::grid::GHOST;
use crate::grid::ops::{min_rows, par_interior, par_interior_update};
use crate::grid::{Field, Grid, VectorField};
use crate::{Error, Real, Result};
use rayon::prelude::*;

/// A material coefficient (density or viscosity): uniform, or one value per cell (for example
/// the mixture (2.25) of the VOF function), with ghosts filled by the stepper.
#[derive(Debug, Clone, PartialEq)]
pub enum Coefficient<T> {
    /// The same value everywhere.
    Uniform(T),
    /// One value per cell centre.
    Field(Field<T>),
}

impl<T: Real> Coefficient<T> {
    /// Value at cell `idx`.
    ///
    /// # Panics
    ///
    /// If the coefficient is a field and `idx` is not one of its storage indices (`idx` at least
    /// [`Grid::len`] of its grid).
    #[inline(always)]
    pub fn at(&self, idx: usize) -> T {
        match self {
            Coefficient::Uniform(v) => *v,
            Coefficient::Field(f) => f.data[idx],
        }
    }

    /// Smallest and largest interior values.
    pub fn range(&self, grid: &Grid<T>) -> (T, T) {
        match self {
            Coefficient::Uniform(v) => (*v, *v),
            Coefficient::Field(f) => {
                let (lo, hi) =
                    grid.cells().fold((T::infinity(), T::neg_infinity()), |(lo, hi), (i, j, k)| {
                        let x = f.data[grid.idx_u(i, j, k)];
                        (lo.min(x), hi.max(x))
                    });
                // Over the whole grid where this is a part of one.
                let [lo, hi] = grid.max_over_parts([-lo, hi]);
                (-lo, hi)
            }
        }
    }

    /// Checks that a field coefficient is stored on `grid` and that every interior value is
    /// finite and positive.
    pub fn validate(&self, grid: &Grid<T>, name: &'static str) -> Result<()> {
        if let Coefficient::Field(f) = self {
            if f.data.len() != grid.len() {
                return Err(Error::invalid(
                    name,
                    format!("a field of {} values", f.data.len()),
                    "a field of the stepper's grid",
                ));
            }
            if let Some(c) = f.first_non_finite(grid) {
                return Err(Error::invalid(
                    name,
                    format!("non-finite value at cell {c:?}"),
                    "finite values > 0",
                ));
            }
        }
        let (lo, hi) = self.range(grid);
        if !(lo.is_finite() && hi.is_finite() && lo > T::zero()) {
            return Err(Error::invalid(
                name,
                format!("range [{lo}, {hi}]"),
                "finite values > 0 in every cell",
            ));
        }
        Ok(())
    }

    /// Fills ghost values (zero normal gradient at walls).
    pub fn fill_ghosts(&mut self, grid: &Grid<T>) {
        if let Coefficient::Field(f) = self {
            f.fill_ghosts(grid);
        }
    }

    /// Whether the coefficient is uniform.
    pub fn is_uniform(&self) -> bool {
        matches!(self, Coefficient::Uniform(_))
    }
}

/// Density and viscosity of the fluid (mixture) at cell centres.
#[derive(Debug, Clone, PartialEq)]
pub struct Materials<T> {
    /// Density `rho`.
    pub rho: Coefficient<T>,
    /// Dynamic viscosity `mu`.
    pub mu: Coefficient<T>,
}

impl<T: Real> Materials<T> {
    /// Uniform density and viscosity. Errors: non-positive or non-finite values.
    pub fn uniform(rho: T, mu: T) -> Result<Self> {
        crate::error::positive("rho", rho)?;
        crate::error::positive("mu", mu)?;
        Ok(Materials { rho: Coefficient::Uniform(rho), mu: Coefficient::Uniform(mu) })
    }

    /// The mixture (2.25) of two phases weighted by the VOF function `phi` (1 in phase 1):
    /// `rho = phi rho1 + (1 - phi) rho2`, `mu = phi mu1 + (1 - phi) mu2`. A property that is
    /// equal in both phases stays [`Coefficient::Uniform`] (no field is allocated, and the
    /// stepper keeps its constant-coefficient paths). Errors: non-positive or non-finite values,
    /// `phi` not on `grid`.
    pub fn mixture(grid: &Grid<T>, phi: &Field<T>, phase1: (T, T), phase2: (T, T)) -> Result<Self> {
        if phi.data.len() != grid.len() {
            return Err(Error::invalid(
                "phi",
                format!("a field of {} values", phi.data.len()),
                "a field of `grid`",
            ));
        }
        let names = [("rho1", "mu1"), ("rho2", "mu2")];
        for ((rho, mu), (rn, mn)) in [phase1, phase2].into_iter().zip(names) {
            crate::error::positive(rn, rho)?;
            crate::error::positive(mn, mu)?;
        }
        let mix = |a: T, b: T| {
            if a == b {
                Coefficient::Uniform(a)
            } else {
                let mut f = phi.clone();
                f.data.iter_mut().for_each(|p| {
                    let w = p.max(T::zero()).min(T::one());
                    *p = w * a + (T::one() - w) * b;
                });
                f.fill_ghosts(grid);
                Coefficient::Field(f)
            }
        };
        Ok(Materials { rho: mix(phase1.0, phase2.0), mu: mix(phase1.1, phase2.1) })
    }
}

/// Viscosity as seen by the stencils: cell values plus edge averages when it varies.
pub(crate) struct ViscosityView<'a, T> {
    pub(crate) mu: &'a Coefficient<T>,
    /// Edge viscosity, indexed by the axis the edge is parallel to (computed on the fly if
    /// absent).
    edge: Option<&'a [Field<T>; 3]>,
    st: [usize; 3],
}

impl<'a, T: Real> ViscosityView<'a, T> {
    pub(crate) fn new(grid: &Grid<T>, mu: &'a Coefficient<T>, edge: Option<&'a [Field<T>; 3]>) -> Self {
        ViscosityView { mu, edge, st: grid.strides() }
    }

    #[inline(always)]
    fn cell(&self, idx: usize) -> T {
        self.mu.at(idx)
    }

    /// Viscosity on the edge at the lower corner of cell `idx` in the plane of axes `a`, `b`.
    #[inline(always)]
    fn edge(&self, a: usize, b: usize, idx: usize) -> T {
        match (self.mu, self.edge) {
            (Coefficient::Uniform(v), _) => *v,
            (_, Some(e)) => e[3 - a - b].data[idx],
            (Coefficient::Field(f), None) => {
                let (sa, sb, d) = (self.st[a], self.st[b], &f.data);
                T::lit(0.25) * (d[idx] + d[idx - sa] + d[idx - sb] + d[idx - sa - sb])
            }
        }
    }
}

/// Computes the edge viscosities (average of the four cells around each edge) into `edge`,
/// indexed by the axis the edge is parallel to. `mu` needs its ghosts filled.
pub(crate) fn edge_viscosity<T: Real>(grid: &Grid<T>, mu: &Field<T>, edge: &mut [Field<T>; 3]) {
    for (e, out) in edge.iter_mut().enumerate() {
        let (a, b) = match e {
            0 => (1, 2),
            1 => (2, 0),
            _ => (0, 1),
        };
        par_interior(grid, &mut out.data, |idx, _, _, _| crate::grid::ops::cell_to_edge(grid, mu, a, b, idx));
        out.fill_ghosts(grid);
        // The edges on the upper sides along `a` and `b` (index `n`, the lower corners of the
        // first ghost cells) are read by the stencils of the last faces: average their four
        // cells too, from `mu`'s ghosts, instead of copying a neighbouring edge (which at a
        // wall gave the upper wall another viscosity than the lower one).
        let n = grid.n();
        let upper = (0..=n[b]).map(|v| (n[a], v)).chain((0..n[a]).map(|u| (u, n[b])));
        for (u, v) in upper {
            for w in 0..n[e] {
                let mut ijk = [0; 3];
                (ijk[a], ijk[b], ijk[e]) = (u, v, w);
                let idx = grid.idx_u(ijk[0], ijk[1], ijk[2]);
                out.data[idx] = crate::grid::ops::cell_to_edge(grid, mu, a, b, idx);
            }
        }
    }
}

/// `div(mu (grad w + grad w^T))` for component `c` at face `idx`. Needs one ghost layer of `w`.
#[inline(always)]
pub(crate) fn viscous_at<T: Real>(
    grid: &Grid<T>,
    mu: &ViscosityView<T>,
    w: &VectorField<T>,
    c: usize,
    idx: usize,
) -> T {
    let st = grid.strides();
    let h = grid.h();
    let two = T::lit(2.0);
    let wc = &w.c[c].data;
    let sc = st[c];
    let s_hi = two * mu.cell(idx) * (wc[idx + sc] - wc[idx]) / h[c];
    let s_lo = two * mu.cell(idx - sc) * (wc[idx] - wc[idx - sc]) / h[c];
    let mut div = (s_hi - s_lo) / h[c];
    for a in (0..3).filter(|&a| a != c) {
        let wa = &w.c[a].data;
        let sa = st[a];
        let shear = |m: usize| mu.edge(c, a, m) * ((wc[m] - wc[m - sa]) / h[a] + (wa[m] - wa[m - sc]) / h[c]);
        div += (shear(idx + sa) - shear(idx)) / h[a];
    }
    div
}

/// Runs `f(j, k, base, out)` over the interior x-lines of a face or cell array in parallel:
/// `base` is the storage index of the line's first interior value and `out` its `n_x` interior
/// values.
fn par_lines<T: Real>(grid: &Grid<T>, data: &mut [T], f: impl Fn(usize, usize, usize, &mut [T]) + Sync) {
    let (nx, dx) = (grid.n()[0], grid.dims()[0]);
    data.par_chunks_mut(dx).with_min_len(min_rows(dx)).enumerate().for_each(|(row, line)| {
        if let Some((j, k)) = grid.row_jk(row) {
            f(j, k, row * dx + GHOST, &mut line[GHOST..GHOST + nx]);
        }
    });
}

/// The `nx` values of `arr` from storage index `base + off`: an x-line, shifted by `off`.
#[inline(always)]
fn line_at<T>(arr: &[T], base: usize, off: isize, nx: usize) -> &[T] {
    let start = (base as isize + off) as usize;
    &arr[start..start + nx]
}

/// The positions along the x-line `(j, k)` of component `c` that are wall faces
/// ([`is_wall_face`]): its first face when x is a wall axis and `c = 0`, the whole line when it
/// is the first line along a wall axis `c`, none otherwise.
fn wall_faces<T: Real>(grid: &Grid<T>, c: usize, j: usize, k: usize) -> std::ops::Range<usize> {
    if grid.is_periodic(c) {
        0..0
    } else if c == 0 {
        0..1
    } else if [0, j, k][c] == 0 {
        0..grid.n()[0]
    } else {
        0..0
    }
}

/// `y = a x + b V(x)` for a uniform viscosity folded into `b` (`V(x) = mu (Lap x + grad div x)`,
/// which equals `div(mu (grad x + grad x^T))` exactly on the staggered grid when `mu` is
/// uniform, since the difference operators commute). Rows of wall faces get `y = a x`.
///
/// The constant-coefficient fast path: one pass per component over x-lines, with slices that
/// let the compiler drop bounds checks and vectorise.
pub(crate) fn uniform_helmholtz<T: Real>(
    grid: &Grid<T>,
    x: &VectorField<T>,
    a: T,
    b: T,
    y: &mut VectorField<T>,
) {
    let st = grid.strides();
    let h = grid.h();
    let ih: [T; 3] = std::array::from_fn(|d| T::one() / h[d]);
    let ih2: [T; 3] = std::array::from_fn(|d| ih[d] * ih[d]);
    let nx = grid.n()[0];
    let two = T::lit(2.0);
    for (c, yc) in y.c.iter_mut().enumerate() {
        par_lines(grid, &mut yc.data, |j, k, base, out| {
            let sl = |arr, off| line_at(arr, base, off, nx);
            let xc = &x.c[c].data;
            let x0 = sl(xc, 0);
            // a x + b (Laplacian)
            let (xm0, xp0) = (sl(xc, -1), sl(xc, 1));
            let (xm1, xp1) = (sl(xc, -(st[1] as isize)), sl(xc, st[1] as isize));
            let (xm2, xp2) = (sl(xc, -(st[2] as isize)), sl(xc, st[2] as isize));
            for i in 0..nx {
                let c0 = x0[i];
                let lap = (xp0[i] - two * c0 + xm0[i]) * ih2[0]
                    + (xp1[i] - two * c0 + xm1[i]) * ih2[1]
                    + (xp2[i] - two * c0 + xm2[i]) * ih2[2];
                out[i] = a * c0 + b * lap;
            }
            // + b d_c(div x) = b sum_a (x_a[+s_a] - x_a[0] - x_a[-s_c + s_a] + x_a[-s_c]) / (h_a h_c)
            let sc = st[c] as isize;
            for ax in 0..3 {
                let sa = st[ax] as isize;
                let xa = &x.c[ax].data;
                let (p, z, q, r) = (sl(xa, sa), sl(xa, 0), sl(xa, sa - sc), sl(xa, -sc));
                let w = b * ih[ax] * ih[c];
                for i in 0..nx {
                    out[i] += w * ((p[i] - z[i]) - (q[i] - r[i]));
                }
            }
            for i in wall_faces(grid, c, j, k) {
                out[i] = a * x0[i];
            }
        });
    }
}

/// `y = (rho_f / dt) x - (1/2) div(mu (grad x + grad x^T))` for a variable viscosity with its
/// edge averages `edge` (the operator of [`Predictor`] without extra terms); rows of wall faces
/// get `y = (rho_f / dt) x`.
///
/// The variable-coefficient fast path: the arithmetic of [`viscous_at`] and
/// [`face_density`] term by term (so the result is the same to the bit), over x-lines with
/// slices instead of a closure per face, which lets the compiler vectorise.
#[allow(clippy::too_many_arguments)]
fn variable_helmholtz<T: Real>(
    grid: &Grid<T>,
    x: &VectorField<T>,
    rho: &Coefficient<T>,
    inv_dt: T,
    theta: T,
    mu: &Field<T>,
    edge: Option<&[Field<T>; 3]>,
    y: &mut VectorField<T>,
) {
    let st = grid.strides();
    let h = grid.h();
    let nx = grid.n()[0];
    let (two, half) = (T::lit(2.0), T::lit(0.5));
    for (c, yc) in y.c.iter_mut().enumerate() {
        let sc = st[c] as isize;
        let (a1, a2) = ((c + 1) % 3, (c + 2) % 3);
        // `viscous_at` adds the two shear terms in increasing axis order.
        let axes = if a1 < a2 { [a1, a2] } else { [a2, a1] };
        par_lines(grid, &mut yc.data, |j, k, base, out| {
            let sl = |arr, off| line_at(arr, base, off, nx);
            let (xc, m) = (&x.c[c].data, &mu.data);
            let (x0, xp, xm) = (sl(xc, 0), sl(xc, sc), sl(xc, -sc));
            let (m0, mm) = (sl(m, 0), sl(m, -sc));
            for i in 0..nx {
                let s_hi = two * m0[i] * (xp[i] - x0[i]) / h[c];
                let s_lo = two * mm[i] * (x0[i] - xm[i]) / h[c];
                out[i] = (s_hi - s_lo) / h[c];
            }
            for a in axes {
                let sa = st[a] as isize;
                let xa = &x.c[a].data;
                let (cp, cm) = (sl(xc, sa), sl(xc, -sa));
                let (ap, apm, a0, am) = (sl(xa, sa), sl(xa, sa - sc), sl(xa, 0), sl(xa, -sc));
                let w = [x0, cp, cm, ap, apm, a0, am];
                match edge {
                    Some(e) => {
                        let (e0, ep) = (sl(&e[3 - c - a].data, 0), sl(&e[3 - c - a].data, sa));
                        shear_pass(out, w, [h[a], h[c]], |i| e0[i], |i| ep[i]);
                    }
                    None => {
                        // The average of `ViscosityView::edge`, in its order.
                        let (p, q) = (sl(m, sa), sl(m, sa - sc));
                        let (r, t) = (sl(m, -sa), sl(m, -sa - sc));
                        let quarter = T::lit(0.25);
                        let e0 = |i: usize| quarter * (m0[i] + mm[i] + r[i] + t[i]);
                        shear_pass(out, w, [h[a], h[c]], e0, |i| quarter * (p[i] + q[i] + m0[i] + mm[i]));
                    }
                }
            }
            let diag = |i: usize| -> T {
                let rf = match rho {
                    Coefficient::Uniform(r) => *r,
                    Coefficient::Field(f) => half * (f.data[base + i] + f.data[(base + i) - st[c]]),
                };
                rf * inv_dt
            };
            for i in 0..nx {
                out[i] = diag(i) * x0[i] - theta * out[i];
            }
            for i in wall_faces(grid, c, j, k) {
                out[i] = diag(i) * x0[i];
            }
        });
    }
}

/// Adds the shear term of axis `a` of [`viscous_at`] along an x-line: `w` holds the lines of
/// `x_c` at `0, +s_a, -s_a` and of `x_a` at `+s_a, s_a - s_c, 0, -s_c`, `ha_hc` the spacings
/// along `a` and `c`, `e0` and `ep` the edge viscosities at `0` and `+s_a`.
#[inline(always)]
fn shear_pass<T: Real>(
    out: &mut [T],
    w: [&[T]; 7],
    ha_hc: [T; 2],
    e0: impl Fn(usize) -> T,
    ep: impl Fn(usize) -> T,
) {
    let [x0, cp, cm, ap, apm, a0, am] = w;
    let [ha, hc] = ha_hc;
    for i in 0..out.len() {
        let hi = ep(i) * ((cp[i] - x0[i]) / ha + (ap[i] - apm[i]) / hc);
        let lo = e0(i) * ((x0[i] - cm[i]) / ha + (a0[i] - am[i]) / hc);
        out[i] += (hi - lo) / ha;
    }
}

/// Diagonal coefficient of `-(1/2) V` for component `c` at face `idx` (walls' ghost
/// contributions left out: an approximation for SOR only).
#[inline(always)]
fn viscous_diag<T: Real>(grid: &Grid<T>, mu: &ViscosityView<T>, c: usize, idx: usize) -> T {
    let st = grid.strides();
    let h = grid.h();
    let mut d = (mu.cell(idx) + mu.cell(idx - st[c])) / (h[c] * h[c]);
    for a in (0..3).filter(|&a| a != c) {
        d += T::lit(0.5) * (mu.edge(c, a, idx + st[a]) + mu.edge(c, a, idx)) / (h[a] * h[a]);
    }
    d
}

/// Advection `(v . grad v)_c` in divergence form at face `idx` of component `c`.
#[inline(always)]
pub(crate) fn advection_at<T: Real>(grid: &Grid<T>, v: &VectorField<T>, c: usize, idx: usize) -> T {
    let st = grid.strides();
    let h = grid.h();
    let half = T::lit(0.5);
    let quarter = T::lit(0.25);
    let vc = &v.c[c].data;
    let sc = st[c];
    let fc = |m: usize| {
        let a = half * (vc[m] + vc[m + sc]);
        a * a
    };
    let mut adv = (fc(idx) - fc(idx - sc)) / h[c];
    for a in (0..3).filter(|&a| a != c) {
        let va = &v.c[a].data;
        let sa = st[a];
        let fe = |m: usize| quarter * (va[m] + va[m - sc]) * (vc[m] + vc[m - sa]);
        adv += (fe(idx + sa) - fe(idx)) / h[a];
    }
    adv
}

/// Density averaged to face `idx` of component `c`.
#[inline(always)]
pub(crate) fn face_density<T: Real>(grid: &Grid<T>, rho: &Coefficient<T>, c: usize, idx: usize) -> T {
    match rho {
        Coefficient::Uniform(r) => *r,
        Coefficient::Field(f) => T::lit(0.5) * (f.data[idx] + f.data[idx - grid.strides()[c]]),
    }
}

/// Whether face `(i, j, k)` of component `c` lies on a wall (a fixed unknown).
#[inline(always)]
pub(crate) fn is_wall_face<T: Real>(grid: &Grid<T>, c: usize, ijk: [usize; 3]) -> bool {
    ijk[c] == 0 && !grid.is_periodic(c)
}

/// An extra term of the implicit predictor operator (2.35), such as the membrane term
/// `-(dt/4) div(delta H(v*, G_s^n, J^n))`. The operator calls it after its own part.
pub trait ImplicitTerm<T: Real>: Sync {
    /// Adds this term's contribution to `y = P x` on interior faces (ghosts of `x` are filled).
    ///
    /// # Errors
    /// Whatever keeps the term from being applied (e.g. fields of another grid); the predictor
    /// solve, and with it the step, then fails and leaves the state as it was.
    fn add_apply(&self, grid: &Grid<T>, x: &VectorField<T>, y: &mut VectorField<T>) -> Result<()>;
    /// This term's contribution to `(P x)_c` at face `idx`, used by the SOR reference solver.
    /// It cannot fail: a term that can fail reports it from [`add_apply`](Self::add_apply),
    /// which the default Krylov predictor calls.
    fn apply_at(&self, grid: &Grid<T>, x: &VectorField<T>, c: usize, idx: usize) -> T;
}

/// The predictor operator `P = rho/dt - theta V` of (2.35) (`theta` = 1/2, Crank–Nicolson, in
/// the paper; see [`ViscousScheme`](super::stepper::ViscousScheme)), matrix-free.
pub struct Predictor<'a, T: Real> {
    pub(crate) grid: &'a Grid<T>,
    pub(crate) inv_dt: T,
    /// The implicit weight `theta` of the viscous term.
    pub(crate) theta: T,
    pub(crate) rho: &'a Coefficient<T>,
    pub(crate) mu: ViscosityView<'a, T>,
    pub(crate) extra: Option<&'a dyn ImplicitTerm<T>>,
}

impl<'a, T: Real> Predictor<'a, T> {
    /// The operator of (2.35) for the step `dt` with `materials` (ghosts filled) and an optional
    /// extra implicit term, for use with [`LinOp::apply`] and the Krylov solvers. A variable
    /// viscosity is averaged to the cell edges on the fly (the stepper keeps edge fields).
    pub fn new(
        grid: &'a Grid<T>,
        dt: T,
        materials: &'a Materials<T>,
        extra: Option<&'a dyn ImplicitTerm<T>>,
    ) -> Self {
        Predictor {
            grid,
            inv_dt: T::one() / dt,
            theta: T::lit(0.5),
            rho: &materials.rho,
            mu: ViscosityView::new(grid, &materials.mu, None),
            extra,
        }
    }

    /// The operator with the viscous weighting of `scheme` instead of Crank–Nicolson.
    pub fn viscous(mut self, scheme: super::stepper::ViscousScheme) -> Self {
        self.theta = T::lit(scheme.implicit_weight());
        self
    }

    /// `(P x)_c` at face `idx` without the extra terms, with the ghosts of `x` as they are.
    #[inline(always)]
    fn base_at(&self, x: &VectorField<T>, c: usize, idx: usize, wall: bool) -> T {
        let diag = face_density(self.grid, self.rho, c, idx) * self.inv_dt;
        if wall {
            diag * x.c[c].data[idx]
        } else {
            diag * x.c[c].data[idx] - self.theta * viscous_at(self.grid, &self.mu, x, c, idx)
        }
    }

    /// `(P x)_c` at face `idx` with the ghosts of `x` as they are.
    #[inline(always)]
    pub(crate) fn apply_at(&self, x: &VectorField<T>, c: usize, idx: usize, wall: bool) -> T {
        let y = self.base_at(x, c, idx, wall);
        match self.extra {
            Some(e) if !wall => y + e.apply_at(self.grid, x, c, idx),
            _ => y,
        }
    }

    /// Approximate diagonal of `P` at face `idx` (for SOR).
    #[inline(always)]
    pub(crate) fn diag_at(&self, c: usize, idx: usize, wall: bool) -> T {
        let d = face_density(self.grid, self.rho, c, idx) * self.inv_dt;
        if wall { d } else { d + T::lit(2.0) * self.theta * viscous_diag(self.grid, &self.mu, c, idx) }
    }

    /// `y = P x` on interior faces, with the ghosts of `x` as they are.
    pub(crate) fn apply_raw(&self, x: &VectorField<T>, y: &mut VectorField<T>) -> Result<()> {
        let g = self.grid;
        match (self.rho, self.mu.mu, self.mu.edge) {
            (Coefficient::Uniform(rho), Coefficient::Uniform(mu), _) => {
                uniform_helmholtz(g, x, *rho * self.inv_dt, -self.theta * *mu, y);
            }
            (rho, Coefficient::Field(mu), edge) => {
                variable_helmholtz(g, x, rho, self.inv_dt, self.theta, mu, edge, y);
            }
            _ => {
                for (c, yc) in y.c.iter_mut().enumerate() {
                    par_interior(g, &mut yc.data, |idx, i, j, k| {
                        self.base_at(x, c, idx, is_wall_face(g, c, [i, j, k]))
                    });
                }
            }
        }
        if let Some(e) = self.extra {
            e.add_apply(g, x, y)?;
        }
        Ok(())
    }
}

impl<T: Real> LinOp<T, VectorField<T>> for Predictor<'_, T> {
    fn apply(&self, x: &mut VectorField<T>, y: &mut VectorField<T>) -> Result<()> {
        x.fill_ghosts_homogeneous(self.grid);
        self.apply_raw(x, y)
    }
}

/// Preconditioner of the predictor: the constant-coefficient Helmholtz operator
/// `(rho_ref/dt) - (mu_ref/2) Lap` per component, inverted exactly by [`SpectralSolver`].
/// Two components with the same boundary closures on every axis (all three in a periodic box,
/// the two tangential ones with walls) share one complex solve
/// ([`SpectralSolver::solve_pair`]), so an application costs two solves instead of three.
///
/// **Two viscosities** ([`set_two`](Self::set_two)). With one reference viscosity the modes of
/// the phase whose viscosity differs from it are inverted with the wrong diffusion, and the
/// Krylov solver pays for the mismatch (the viscosity ratio 5 of the red cells: 9.8 BiCGStab
/// iterations a step at N = 64). Then the preconditioner inverts with both viscosities and
/// blends the two answers face by face, `z = w z_hi + (1 - w) z_lo` with
/// `w = (mu_f - mu_lo) / (mu_hi - mu_lo)` from the face viscosity `mu_f`: where the
/// Helmholtz response is shorter than the distance to the interface (`sqrt(mu dt / rho)`, about
/// a cell at the red cells' step) each phase sees its own operator, so only the faces near the
/// interface keep a mismatch (6.6 iterations). The two solves share their forward transform and
/// return in one inverse one ([`SpectralSolver::solve_blended`]).
pub struct HelmholtzPrecond<T: Real> {
    /// The solvers, each with the component it inverts and the one it pairs with, if any.
    groups: Vec<(SpectralSolver<T>, usize, Option<usize>)>,
    grid: Grid<T>,
    sigma: T,
    c: T,
    /// With two viscosities: `c_lo = mu_lo / 2` and the weight `w` of `c` on every face
    /// (allocated on first use).
    two: Option<(T, VectorField<T>)>,
    /// Whether [`set_two`](Self::set_two) is in force.
    blended: bool,
}

impl<T: Real> HelmholtzPrecond<T> {
    /// Builds the component solvers, pairing components of equal closures. Errors as
    /// [`SpectralSolver::new`].
    pub fn new(grid: &Grid<T>) -> Result<Self> {
        let kinds: [_; 3] = std::array::from_fn(|d| Location::Velocity(d).kinds(grid));
        let mut groups = Vec::with_capacity(3);
        let mut taken = [false; 3];
        for d in 0..3 {
            if taken[d] {
                continue;
            }
            let pair = (d + 1..3).find(|&e| !taken[e] && kinds[e] == kinds[d]);
            if let Some(e) = pair {
                taken[e] = true;
            }
            groups.push((SpectralSolver::new(grid, Location::Velocity(d))?, d, pair));
        }
        Ok(HelmholtzPrecond {
            groups,
            grid: grid.clone(),
            sigma: T::one(),
            c: T::one(),
            two: None,
            blended: false,
        })
    }

    /// Sets the reference coefficients of `sigma - c lap`: `sigma = rho_ref / dt`,
    /// `c = theta mu_ref` (`theta` the implicit weight of the viscous term, 1/2 for
    /// Crank–Nicolson).
    pub fn set(&mut self, sigma: T, c: T) {
        self.sigma = sigma;
        self.c = c;
        self.blended = false;
    }

    /// Sets two reference viscosities, `mu_lo < mu_hi`, and blends the two inverses with the
    /// face weights `(mu_f - mu_lo) / (mu_hi - mu_lo)` of the cell viscosity field `mu` (ghosts
    /// filled); `sigma = rho_ref / dt`, `theta` the implicit weight of the viscous term (1/2 for
    /// Crank–Nicolson). See the type's docs.
    pub fn set_two(&mut self, sigma: T, theta: T, mu_lo: T, mu_hi: T, mu: &Field<T>) {
        let (g, half) = (&self.grid, T::lit(0.5));
        let (c_lo, w) = self.two.get_or_insert_with(|| (T::zero(), VectorField::zeros(g)));
        *c_lo = theta * mu_lo;
        let span = T::one() / (mu_hi - mu_lo);
        for (c, wc) in w.c.iter_mut().enumerate() {
            let st = g.strides()[c];
            par_interior_update(g, &mut wc.data, |idx, _, _, _, _| {
                let m = half * (mu.data[idx] + mu.data[idx - st]);
                ((m - mu_lo) * span).max(T::zero()).min(T::one())
            });
        }
        self.sigma = sigma;
        self.c = theta * mu_hi;
        self.blended = true;
    }
}

impl<T: Real> Precond<T, VectorField<T>> for HelmholtzPrecond<T> {
    fn apply(&mut self, r: &VectorField<T>, z: &mut VectorField<T>) {
        let (g, sigma, c) = (&self.grid, self.sigma, self.c);
        let two = self.two.as_ref().filter(|_| self.blended);
        for (solver, d, pair) in &mut self.groups {
            let d = *d;
            match (*pair, two) {
                (None, None) => solver.solve(g, sigma, c, &r.c[d].data, &mut z.c[d].data),
                (None, Some((c_lo, w))) => {
                    solver.solve_blended(g, sigma, [c, *c_lo], &w.c[d].data, &r.c[d].data, &mut z.c[d].data)
                }
                (Some(e), two) => {
                    // d < e by construction.
                    let (lo, hi) = z.c.split_at_mut(e);
                    let x = [&mut lo[d].data[..], &mut hi[0].data[..]];
                    let b = [&r.c[d].data[..], &r.c[e].data[..]];
                    match two {
                        None => solver.solve_pair(g, sigma, c, b, x),
                        Some((c_lo, w)) => solver.solve_pair_blended(
                            g,
                            sigma,
                            [c, *c_lo],
                            [&w.c[d].data, &w.c[e].data],
                            b,
                            x,
                        ),
                    }
                }
            }
        }
    }
}

/// The predictor system (2.35) of one step, as a [`MomentumSolver`] receives it: the operator
/// `P` and what a preconditioner may want to know about it.
pub struct MomentumSystem<'a, T: Real> {
    /// The grid.
    pub grid: &'a Grid<T>,
    /// The operator `P` of (2.35) (with the extra implicit term of the step, if any); apply it
    /// with [`LinOp::apply`].
    pub operator: &'a Predictor<'a, T>,
    /// The materials of the step (ghosts filled).
    pub materials: &'a Materials<T>,
    /// `1 / dt`.
    pub inv_dt: T,
    /// The smallest density.
    pub rho_min: T,
    /// The smallest and the largest viscosity.
    pub mu_range: (T, T),
    /// The implicit weight `theta` of the viscous term in the operator (`1/2`: Crank–Nicolson;
    /// see [`ViscousScheme`](super::stepper::ViscousScheme)).
    pub theta: T,
}

/// The strategy that solves the momentum predictor (2.35) `P v* = b`, once per step.
///
/// [`FlowStepper::new`](super::stepper::FlowStepper::new) builds the default from
/// [`FlowConfig::predictor`](super::stepper::FlowConfig::predictor) (a
/// [`PredictorSolver`](super::stepper::PredictorSolver): [`KrylovMomentum`] or
/// [`SorMomentum`](super::sor::SorMomentum));
/// [`FlowStepper::with_momentum_solver`](super::stepper::FlowStepper::with_momentum_solver) and
/// [`Scene::momentum_solver`](crate::simulation::Scene::momentum_solver) take a user's. A solver
/// owns its workspace, allocated when it is built: the step calls it through one dynamic
/// dispatch and it must not allocate.
///
/// A user solver that wraps the default one and counts its calls:
///
/// ```
/// use eulermembrane::fluid::forcing::BodyForce;
/// use eulermembrane::fluid::krylov::KrylovInfo;
/// use eulermembrane::fluid::momentum::{KrylovMomentum, Materials, MomentumSolver, MomentumSystem};
/// use eulermembrane::fluid::stepper::{FlowConfig, FlowStepper};
/// use eulermembrane::grid::{Grid, VectorField};
/// use std::sync::atomic::{AtomicUsize, Ordering};
/// use std::sync::Arc;
///
/// struct Counted(KrylovMomentum<f64>, Arc<AtomicUsize>);
/// impl MomentumSolver<f64> for Counted {
///     fn name(&self) -> &str {
///         "counted_krylov"
///     }
///     fn solve(
///         &mut self,
///         system: &MomentumSystem<'_, f64>,
///         b: &VectorField<f64>,
///         x: &mut VectorField<f64>,
///     ) -> eulermembrane::Result<KrylovInfo> {
///         self.1.fetch_add(1, Ordering::Relaxed);
///         self.0.solve(system, b, x)
///     }
/// }
///
/// let grid = Grid::<f64>::periodic([8; 3], [0.0; 3], [1.0; 3])?;
/// let config = FlowConfig::default();
/// let calls = Arc::new(AtomicUsize::new(0));
/// let solver = Counted(KrylovMomentum::new(&grid, Default::default(), true)?, calls.clone());
/// let mut flow = FlowStepper::new(&grid, Materials::uniform(1.0, 1.0)?, config)?
///     .with_momentum_solver(Box::new(solver));
/// flow.step(1e-2, &BodyForce::new([1.0, 0.0, 0.0])?, None)?;
/// assert_eq!(calls.load(Ordering::Relaxed), 1);
/// assert_eq!(flow.momentum_solver().name(), "counted_krylov");
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub trait MomentumSolver<T: Real>: Send + Sync {
    /// A short snake_case name, for [`Simulation::numerics`](crate::simulation::Simulation::numerics)
    /// and error messages.
    fn name(&self) -> &str;

    /// Solves `P x = b` on the interior faces, starting from the given `x` (`v^n`); the ghosts
    /// of `x` may be left in any state (the stepper fills them). Returns the iterations (or
    /// sweeps) and the final relative residual (or change).
    ///
    /// # Errors
    /// A solve that does not converge ([`Error::NoConvergence`]) or an operator that fails; the
    /// step then fails and leaves the flow state as it was.
    fn solve(
        &mut self,
        system: &MomentumSystem<'_, T>,
        b: &VectorField<T>,
        x: &mut VectorField<T>,
    ) -> Result<KrylovInfo>;
}

/// The viscosity ratio above which [`KrylovMomentum`] inverts with both extremes
/// ([`HelmholtzPrecond::set_two`]); below it one inverse with the larger viscosity already
/// leaves the preconditioned spectrum within `[1 / ratio, 1]`.
const TWO_VISCOSITY_RATIO: f64 = 1.5;

/// The default [`MomentumSolver`] ([`PredictorSolver::Krylov`](super::stepper::PredictorSolver::Krylov)):
/// right-preconditioned BiCGStab with the FFT solve of `(rho_min/dt) - (mu_max/2) Lap` per
/// component ([`HelmholtzPrecond`]; with two viscosities more than 1.5 apart and
/// `two_viscosities`, both inverses blended, [`HelmholtzPrecond::set_two`]).
pub struct KrylovMomentum<T: Real> {
    params: KrylovParams,
    two_viscosities: bool,
    precond: HelmholtzPrecond<T>,
    ws: KrylovWorkspace<VectorField<T>>,
}

impl<T: Real> KrylovMomentum<T> {
    /// The solver and its workspace for `grid`, with the stopping rule `params` and, with
    /// `two_viscosities`, the blended preconditioner
    /// ([`FlowConfig::two_viscosity_preconditioner`](super::stepper::FlowConfig::two_viscosity_preconditioner)).
    ///
    /// Errors: a tolerance outside `(0, 1)` or no iteration allowed (naming
    /// `FlowConfig::predictor`); a grid the FFT solves cannot handle.
    pub fn new(grid: &Grid<T>, params: KrylovParams, two_viscosities: bool) -> Result<Self> {
        params.validate("FlowConfig::predictor")?;
        Ok(KrylovMomentum {
            params,
            two_viscosities,
            precond: HelmholtzPrecond::new(grid)?,
            ws: KrylovWorkspace::new(grid),
        })
    }
}

impl<T: Real> MomentumSolver<T> for KrylovMomentum<T> {
    fn name(&self) -> &str {
        "bicgstab"
    }

    fn solve(
        &mut self,
        system: &MomentumSystem<'_, T>,
        b: &VectorField<T>,
        x: &mut VectorField<T>,
    ) -> Result<KrylovInfo> {
        let (rho_lo, (mu_lo, mu_hi)) = (system.rho_min, system.mu_range);
        let sigma = rho_lo * system.inv_dt;
        match &system.materials.mu {
            // Two viscosities far apart: blend two inverses (HelmholtzPrecond::set_two).
            Coefficient::Field(f) if self.two_viscosities && mu_hi > T::lit(TWO_VISCOSITY_RATIO) * mu_lo => {
                self.precond.set_two(sigma, system.theta, mu_lo, mu_hi, f)
            }
            _ => self.precond.set(sigma, system.theta * mu_hi),
        }
        bicgstab(system.grid, system.operator, &mut self.precond, b, x, &mut self.ws, self.params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Boundary;

    /// With a viscosity ratio 5, the two-viscosity preconditioner gives the same solution in
    /// fewer BiCGStab iterations than one inverse with the larger viscosity, with a wall in y
    /// (the red cells' channel) and in a periodic box.
    #[test]
    fn two_viscosity_preconditioner_cuts_iterations() {
        use crate::fluid::krylov::{KrylovParams, KrylovWorkspace, bicgstab};
        for wall in [None, Some(1)] {
            let g = Grid::<f64>::new([24, 24, 24], [0.0; 3], [1.0; 3], Boundary::walls_on(wall)).unwrap();
            // A smoothed sphere of radius 0.3 (three cells wide interface), viscosity 5 inside.
            let mut phi = Field::from_cell_fn(&g, |p| {
                let r = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
                0.5 * (1.0 - ((r - 0.3) * 24.0).tanh())
            });
            phi.fill_ghosts(&g);
            let m = Materials::mixture(&g, &phi, (1.0, 5.0), (1.0, 1.0)).unwrap();
            let Coefficient::Field(mu) = &m.mu else { panic!("a viscosity field") };
            // The step of a red-cell run at this grid: rho / dt comparable to mu / h^2.
            let dt = 2e-4;
            let op = Predictor::new(&g, dt, &m, None);
            let mut target = VectorField::from_fn(&g, |p| {
                let s = (std::f64::consts::TAU * p[1]).sin();
                [s * (3.0 * p[2]).cos(), (5.0 * p[0]).sin() * s, (2.0 * p[0] + p[2]).cos() * s]
            });
            for (i, j, k) in g.cells() {
                // No slip: the wall faces of the normal component are fixed at zero.
                if let Some(w) = wall
                    && [i, j, k][w] == 0
                {
                    target.c[w].data[g.idx_u(i, j, k)] = 0.0;
                }
            }
            let mut b = VectorField::zeros(&g);
            op.apply(&mut target, &mut b).unwrap();
            let params = KrylovParams { tolerance: 1e-10, ..Default::default() };
            let mut ws = KrylovWorkspace::new(&g);
            let mut pc = HelmholtzPrecond::new(&g).unwrap();
            let mut solve = |pc: &mut HelmholtzPrecond<f64>| {
                let mut x = VectorField::zeros(&g);
                let its = bicgstab(&g, &op, pc, &b, &mut x, &mut ws, params).unwrap().iterations;
                (x, its)
            };
            pc.set(1.0 / dt, 2.5);
            let (x1, its1) = solve(&mut pc);
            pc.set_two(1.0 / dt, 0.5, 1.0, 5.0, mu);
            let (x2, its2) = solve(&mut pc);
            for d in 0..3 {
                for (i, j, k) in g.cells() {
                    let id = g.idx_u(i, j, k);
                    let e = target.c[d].data[id];
                    assert!((x1.c[d].data[id] - e).abs() < 1e-8 && (x2.c[d].data[id] - e).abs() < 1e-8);
                }
            }
            assert!(its2 * 4 <= its1 * 3, "wall {wall:?}: {its2} iterations against {its1}");
            eprintln!("wall {wall:?}: BiCGStab iterations {its1} (one viscosity) -> {its2} (two)");
        }
    }

    /// The uniform fast path equals the general variable-coefficient stencil with a constant
    /// viscosity field, on every kind of boundary.
    #[test]
    fn uniform_fast_path_matches_the_general_stencil() {
        for wall in [None, Some(0), Some(1), Some(2)] {
            let mut bc = [[Boundary::Periodic; 2]; 3];
            if let Some(w) = wall {
                let mut v = [0.0; 3];
                v[(w + 1) % 3] = 0.7;
                bc[w] = [Boundary::wall(), Boundary::Wall { velocity: v }];
            }
            let g = Grid::<f64>::new([6, 7, 5], [0.0; 3], [1.0, 1.3, 0.8], bc).unwrap();
            let mut x = VectorField::from_fn(&g, |p| {
                [(3.0 * p[1]).sin() + p[2], (2.0 * p[0]).cos() * p[2], p[0] * p[1]]
            });
            x.fill_ghosts(&g);
            let uniform = Coefficient::Uniform(0.37);
            let mut field = Coefficient::Field(Field::from_cell_fn(&g, |_| 0.37));
            field.fill_ghosts(&g);
            let rho = Coefficient::Uniform(1.5);
            // A theta other than 1/2 goes through both paths the same way.
            let fast = Predictor {
                grid: &g,
                inv_dt: 10.0,
                theta: 0.7,
                rho: &rho,
                mu: ViscosityView::new(&g, &uniform, None),
                extra: None,
            };
            let slow = Predictor {
                grid: &g,
                inv_dt: 10.0,
                theta: 0.7,
                rho: &rho,
                mu: ViscosityView::new(&g, &field, None),
                extra: None,
            };
            let (mut y1, mut y2) = (VectorField::zeros(&g), VectorField::zeros(&g));
            fast.apply_raw(&x, &mut y1).unwrap();
            slow.apply_raw(&x, &mut y2).unwrap();
            for d in 0..3 {
                for (i, j, k) in g.cells() {
                    let id = g.idx_u(i, j, k);
                    let (a, b) = (y1.c[d].data[id], y2.c[d].data[id]);
                    assert!(
                        (a - b).abs() < 1e-11 * (1.0 + b.abs()),
                        "wall {wall:?} d {d} {:?}: {a} {b}",
                        (i, j, k)
                    );
                }
            }
        }
    }

    /// `Predictor::viscous` sets the weight of the viscous term: `P x = rho/dt x - theta V x`
    /// is affine in `theta`, so `P_{3/4} x` is the mean of `P_{1/2} x` (Crank–Nicolson, the
    /// default of `new`) and `P_1 x`, and the two ends differ by `V x / 2`.
    #[test]
    fn viscous_scheme_sets_the_weight() {
        use super::super::stepper::ViscousScheme;
        let g = Grid::<f64>::new([6, 5, 7], [0.0; 3], [1.0, 0.8, 1.1], Boundary::walls_on(Some(2))).unwrap();
        let mut x =
            VectorField::from_fn(&g, |p| [(3.0 * p[1]).sin() + p[2], p[0] * p[2], (2.0 * p[0]).cos()]);
        x.fill_ghosts(&g);
        let m = Materials::uniform(1.2, 0.3).unwrap();
        let apply = |scheme: Option<ViscousScheme>| {
            let op = Predictor::new(&g, 0.05, &m, None);
            let op = match scheme {
                Some(s) => op.viscous(s),
                None => op,
            };
            let mut y = VectorField::zeros(&g);
            op.apply_raw(&x, &mut y).unwrap();
            y
        };
        let (cn, half, three, one) = (
            apply(None),
            apply(Some(ViscousScheme::CrankNicolson)),
            apply(Some(ViscousScheme::Theta(0.75))),
            apply(Some(ViscousScheme::Theta(1.0))),
        );
        let mut spread = 0.0f64;
        for d in 0..3 {
            for (i, j, k) in g.cells() {
                let id = g.idx_u(i, j, k);
                let (a, b, c, e) =
                    (cn.c[d].data[id], half.c[d].data[id], three.c[d].data[id], one.c[d].data[id]);
                assert_eq!(a, b);
                assert!(
                    (c - 0.5 * (b + e)).abs() < 1e-12 * (1.0 + c.abs()),
                    "{d} {:?}: {b} {c} {e}",
                    (i, j, k)
                );
                spread = spread.max((e - b).abs());
            }
        }
        assert!(spread > 1e-3, "theta changed nothing: {spread}");
    }

    /// The preconditioner pairs components of equal closures (two solves per application in
    /// a periodic box and with a wall) and gives what one solve per component gives, to
    /// round-off.
    #[test]
    fn paired_preconditioner_matches_one_solve_per_component() {
        for wall in [None, Some(0), Some(1), Some(2)] {
            let bc = Boundary::walls_on(wall);
            let g = Grid::<f64>::new([8, 6, 10], [0.0; 3], [1.0, 0.7, 1.2], bc).unwrap();
            let r = VectorField::from_fn(&g, |p| {
                [(6.0 * p[1]).sin() + p[2], (4.0 * p[0]).cos() * p[2], p[0] * p[1] - p[2] * p[2]]
            });
            let mut pc = HelmholtzPrecond::new(&g).unwrap();
            assert_eq!(pc.groups.len(), 2, "wall {wall:?}");
            pc.set(30.0, 0.4);
            let mut z = VectorField::zeros(&g);
            pc.apply(&r, &mut z);
            for d in 0..3 {
                let mut solver = SpectralSolver::new(&g, Location::Velocity(d)).unwrap();
                let mut x = Field::zeros(&g);
                solver.solve(&g, 30.0, 0.4, &r.c[d].data, &mut x.data);
                for (i, j, k) in g.cells() {
                    let id = g.idx_u(i, j, k);
                    let (a, b) = (z.c[d].data[id], x.data[id]);
                    assert!((a - b).abs() <= 1e-14 * (1.0 + b.abs()), "wall {wall:?} d {d}: {a} {b}");
                }
            }
        }
    }

    /// The variable-viscosity fast path equals the per-face stencil to the bit, with the edge
    /// viscosities given and averaged on the fly, a uniform and a variable density, on every
    /// kind of boundary.
    #[test]
    fn variable_fast_path_matches_the_per_face_stencil_bit_for_bit() {
        for wall in [None, Some(0), Some(1), Some(2)] {
            let bc = Boundary::walls_on(wall);
            let g = Grid::<f64>::new([6, 7, 5], [0.0; 3], [1.0, 1.3, 0.8], bc).unwrap();
            let mut x = VectorField::from_fn(&g, |p| {
                [(3.0 * p[1]).sin() + p[2], (2.0 * p[0]).cos() * p[2], p[0] * p[1] - p[2]]
            });
            x.fill_ghosts(&g);
            let mut mu =
                Field::from_cell_fn(&g, |p| 0.05 + 0.2 * (4.0 * p[0] + 3.0 * p[1] - 2.0 * p[2]).sin().abs());
            mu.fill_ghosts(&g);
            let mut edge = std::array::from_fn(|_| Field::zeros(&g));
            edge_viscosity(&g, &mu, &mut edge);
            let mu = Coefficient::Field(mu);
            let mut rho_field = Coefficient::Field(Field::from_cell_fn(&g, |p| 1.0 + p[0] * p[2]));
            rho_field.fill_ghosts(&g);
            let rhos = [Coefficient::Uniform(1.5), rho_field];
            for (rho, given) in rhos.iter().flat_map(|r| [(r, Some(&edge)), (r, None)]) {
                let fast = Predictor {
                    grid: &g,
                    inv_dt: 10.0,
                    theta: 0.5,
                    rho,
                    mu: ViscosityView::new(&g, &mu, given),
                    extra: None,
                };
                let (mut y1, mut y2) = (VectorField::zeros(&g), VectorField::zeros(&g));
                fast.apply_raw(&x, &mut y1).unwrap();
                for (c, yc) in y2.c.iter_mut().enumerate() {
                    par_interior(&g, &mut yc.data, |idx, i, j, k| {
                        fast.base_at(&x, c, idx, is_wall_face(&g, c, [i, j, k]))
                    });
                }
                for d in 0..3 {
                    for (i, j, k) in g.cells() {
                        let id = g.idx_u(i, j, k);
                        let (a, b) = (y1.c[d].data[id], y2.c[d].data[id]);
                        assert_eq!(a.to_bits(), b.to_bits(), "wall {wall:?} d {d} {:?}: {a} {b}", (i, j, k));
                    }
                }
            }
        }
    }
}
