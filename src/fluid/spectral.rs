//! Direct solver for the constant-coefficient Helmholtz / Poisson problem
//! `(sigma - c sum_d L_d) x = b` on the staggered grid, exact to round-off.
//!
//! `L_d` is the standard 3-point second difference along axis `d`, with the boundary closure of
//! the unknown's location: periodic; a cell-centred unknown next to a wall with a zero normal
//! gradient (the pressure of (2.36)) or a no-slip value on the wall face (tangential velocity);
//! or a face-centred unknown whose wall faces are fixed (normal velocity). Periodic axes are
//! diagonalised by FFTs (eigenvalues `(2 - 2 cos(2 pi m / n)) / h^2`), and at most one wall axis
//! is solved by the Thomas algorithm, line by line, for each pair of wavenumbers.
//!
//! Used as the pressure solver of (2.36) when the density is uniform, as the preconditioner of
//! the variable-density PCG, and as the preconditioner of the momentum predictor (2.35).

mod split;

use crate::grid::ops::min_rows;
use crate::grid::{GHOST, Grid};
use crate::{Error, Real, Result};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// The FFT plans of the three axes of `n` cells and the eigenvalues of the second differences,
/// `(2 - 2 cos(2 pi m / n)) / h^2` for wavenumber `m`.
struct Modes<T: Real> {
    fwd: [Arc<dyn Fft<T>>; 3],
    inv: [Arc<dyn Fft<T>>; 3],
    lambda: [Vec<T>; 3],
}

impl<T: Real> Modes<T> {
    fn new(n: [usize; 3], h: [T; 3]) -> Self {
        let mut planner = FftPlanner::<T>::new();
        let fwd = std::array::from_fn(|a| planner.plan_fft_forward(n[a]));
        let inv = std::array::from_fn(|a| planner.plan_fft_inverse(n[a]));
        let two = T::lit(2.0);
        let lambda = std::array::from_fn(|a| {
            (0..n[a])
                .map(|m| {
                    let theta = T::TAU() * T::from_usize(m).unwrap() / T::from_usize(n[a]).unwrap();
                    (two - two * theta.cos()) / (h[a] * h[a])
                })
                .collect()
        });
        Modes { fwd, inv, lambda }
    }

    /// The in-place scratch the transforms along `axis` need.
    fn scratch_len(&self, axis: usize) -> usize {
        self.fwd[axis].get_inplace_scratch_len().max(self.inv[axis].get_inplace_scratch_len())
    }
}

/// The discrete boundary closure of one axis for one kind of unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisKind {
    /// Periodic.
    Periodic,
    /// Cell-centred unknowns, zero normal gradient at both walls (ghost = mirror).
    CellNeumann,
    /// Cell-centred unknowns, value given on the wall faces (ghost = 2 U - mirror).
    CellDirichlet,
    /// Face-centred unknowns, wall faces (index 0 and n) fixed.
    FaceDirichlet,
}

/// Where an unknown lives, which fixes its [`AxisKind`] on each axis of a grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A cell-centred scalar with zero normal gradient at walls (pressure).
    CellNeumann,
    /// Velocity component `d` (no slip at walls).
    Velocity(usize),
}

impl Location {
    /// The closures of the three axes on `grid`.
    pub fn kinds<T: Real>(self, grid: &Grid<T>) -> [AxisKind; 3] {
        std::array::from_fn(|a| {
            if grid.is_periodic(a) {
                AxisKind::Periodic
            } else {
                match self {
                    Location::CellNeumann => AxisKind::CellNeumann,
                    Location::Velocity(d) if d == a => AxisKind::FaceDirichlet,
                    Location::Velocity(_) => AxisKind::CellDirichlet,
                }
            }
        })
    }
}

/// Direct FFT (+ tridiagonal) solver of `(sigma - c sum_d L_d) x = b`; see the module docs.
pub struct SpectralSolver<T: Real> {
    n: [usize; 3],
    h: [T; 3],
    kinds: [AxisKind; 3],
    wall: Option<usize>,
    modes: Modes<T>,
    a: Vec<Complex<T>>,
    b: Vec<Complex<T>>,
    /// The second work array of the blended solves (empty until the first one).
    a2: Vec<Complex<T>>,
    fft_scratch: Vec<Vec<Complex<T>>>,
    /// Scratch of the line solves along a wall in x (empty otherwise).
    thomas_scratch: Vec<Vec<T>>,
    /// The eliminated upper diagonal of every cell, for a wall in y or z (empty otherwise).
    cp: Vec<T>,
    blocks: usize,
    /// The distributed solve of a part of a decomposed grid (the arrays above then stay empty).
    split: Option<Box<split::SplitSolve<T>>>,
}

impl<T: Real> SpectralSolver<T> {
    /// A solver for unknowns at `location` on `grid`.
    ///
    /// Errors: more than one wall axis (the direct solve handles one; use a periodic direction
    /// or an iterative solver); a velocity component above 2.
    pub fn new(grid: &Grid<T>, location: Location) -> Result<Self> {
        if let Location::Velocity(d @ 3..) = location {
            return Err(Error::invalid("Location::Velocity", d, "a component 0, 1 or 2"));
        }
        let kinds = location.kinds(grid);
        let walls: Vec<usize> = (0..3).filter(|&a| kinds[a] != AxisKind::Periodic).collect();
        if walls.len() > 1 {
            return Err(Error::Unsupported {
                component: "SpectralSolver",
                detail: format!(
                    "walls on axes {walls:?}: the direct solver handles at most one wall axis; \
                     make the other axes periodic"
                ),
            });
        }
        let wall = walls.first().copied();
        let n = grid.n();
        let h = grid.h();
        // A part of a decomposed grid solves through its own arrays; the whole-grid ones
        // below then stay empty.
        let split =
            if grid.is_split() { Some(Box::new(split::SplitSolve::new(grid, kinds, wall)?)) } else { None };
        let modes = Modes::new(n, h);
        let total = if split.is_some() { 0 } else { n[0] * n[1] * n[2] };
        let blocks = rayon::current_num_threads().max(1);
        let scratch_len = (0..3).map(|a| modes.scratch_len(a)).max().unwrap_or(0);
        Ok(SpectralSolver {
            n,
            h,
            kinds,
            wall,
            modes,
            a: vec![Complex::default(); total],
            b: vec![Complex::default(); total],
            a2: Vec::new(),
            fft_scratch: (0..blocks).map(|_| vec![Complex::default(); scratch_len]).collect(),
            thomas_scratch: match wall {
                Some(0) if split.is_none() => (0..blocks).map(|_| vec![T::zero(); n[0]]).collect(),
                _ => Vec::new(),
            },
            cp: match wall {
                Some(1 | 2) => vec![T::zero(); total],
                _ => Vec::new(),
            },
            blocks,
            split,
        })
    }

    /// The closures this solver was built for.
    pub fn kinds(&self) -> [AxisKind; 3] {
        self.kinds
    }

    /// Solves `(sigma - c sum_d L_d) x = b` for the interior values of `x` (storage of `grid`;
    /// ghosts untouched). `sigma >= 0`, `c > 0`. When `sigma = 0` and the operator is singular
    /// (all periodic, or Neumann), the mean of `b` is ignored and `x` has zero mean.
    pub fn solve(&mut self, grid: &Grid<T>, sigma: T, c: T, b: &[T], x: &mut [T]) {
        if let Some(sp) = &mut self.split {
            return sp.solve(grid, sigma, c, [Some(b), None], [Some(x), None]);
        }
        gather(grid, &mut self.a, b, None);
        let scale = self.transform(sigma, c);
        scatter(grid, &self.a, scale, x, None);
    }

    /// Solves two problems with the same operator at once, `b_1 -> x_1` and `b_2 -> x_2`, as
    /// [`solve`](Self::solve) does each: the operator is real, so one complex solve of
    /// `b_1 + i b_2` gives `x_1 + i x_2`, at the cost of one solve instead of two.
    pub fn solve_pair(&mut self, grid: &Grid<T>, sigma: T, c: T, b: [&[T]; 2], x: [&mut [T]; 2]) {
        if let Some(sp) = &mut self.split {
            let [x1, x2] = x;
            return sp.solve(grid, sigma, c, [Some(b[0]), Some(b[1])], [Some(x1), Some(x2)]);
        }
        gather(grid, &mut self.a, b[0], Some(b[1]));
        let scale = self.transform(sigma, c);
        let [x1, x2] = x;
        scatter(grid, &self.a, scale, x1, Some(x2));
    }

    /// Applies the inverse operator to the work array (FFTs, division or tridiagonal solves,
    /// inverse FFTs); returns the normalisation of the inverse FFTs still to apply.
    fn transform(&mut self, sigma: T, c: T) -> T {
        self.ffts(true);
        self.invert_modes(sigma, c);
        self.ffts(false)
    }

    /// FFTs of the work array along every periodic axis (forward or inverse); returns the
    /// normalisation of the inverse FFTs.
    fn ffts(&mut self, forward: bool) -> T {
        let periodic: Vec<usize> = (0..3).filter(|&a| self.kinds[a] == AxisKind::Periodic).collect();
        for &ax in &periodic {
            self.fft_axis(ax, forward);
        }
        T::one() / periodic.iter().map(|&a| T::from_usize(self.n[a]).unwrap()).fold(T::one(), |p, q| p * q)
    }

    /// Inverts the operator on the transformed work array: a division per mode, or the
    /// tridiagonal solves along the wall axis.
    fn invert_modes(&mut self, sigma: T, c: T) {
        let [nx, ny, _] = self.n;
        match self.wall {
            Some(w) => self.thomas(w, sigma, c),
            None => {
                let lam = &self.modes.lambda;
                self.a.par_chunks_mut(nx).with_min_len(min_rows(nx)).enumerate().for_each(|(line, row)| {
                    let (j, k) = (line % ny, line / ny);
                    let base = lam[1][j] + lam[2][k];
                    for (i, r) in row.iter_mut().enumerate() {
                        let d = sigma + c * (lam[0][i] + base);
                        *r = if d > T::zero() { *r / d } else { Complex::default() };
                    }
                });
            }
        }
    }

    /// Transforms the gathered right-hand side forward once and inverts it with two
    /// coefficients: `c[0]` into the work array `a`, `c[1]` into `a2` (allocated on first use).
    fn invert_two(&mut self, sigma: T, c: [T; 2]) {
        self.ffts(true);
        if self.a2.len() != self.a.len() {
            self.a2 = vec![Complex::default(); self.a.len()];
        }
        self.a2.par_iter_mut().zip(self.a.par_iter()).for_each(|(d, s)| *d = *s);
        self.invert_modes(sigma, c[0]);
        std::mem::swap(&mut self.a, &mut self.a2);
        self.invert_modes(sigma, c[1]);
        std::mem::swap(&mut self.a, &mut self.a2);
    }

    /// A blend of two solves, `x = w x_0 + (1 - w) x_1` with `x_m` the solution of
    /// `(sigma - c_m sum_d L_d) x_m = b` (as [`solve`](Self::solve)) and `w` a weight per
    /// unknown (storage of `grid`, values in `[0, 1]`). One forward transform serves both
    /// coefficients, and both solutions come back in one complex inverse transform
    /// (`x_0 + i x_1`, the operators being real): the cost of one solve plus a second
    /// division or tridiagonal sweep. The preconditioner of a two-viscosity predictor
    /// ([`crate::fluid::momentum::HelmholtzPrecond`]).
    pub fn solve_blended(&mut self, grid: &Grid<T>, sigma: T, c: [T; 2], w: &[T], b: &[T], x: &mut [T]) {
        if let Some(sp) = &mut self.split {
            return sp.solve_blended(grid, sigma, c, w, b, x);
        }
        gather(grid, &mut self.a, b, None);
        self.invert_two(sigma, c);
        self.a
            .par_iter_mut()
            .zip(self.a2.par_iter())
            .for_each(|(a, a2)| *a = Complex::new(a.re - a2.im, a.im + a2.re));
        let scale = self.ffts(false);
        let [nx, ny, _] = self.n;
        let (a, g, dx) = (&self.a, GHOST, grid.dims()[0]);
        x.par_chunks_mut(dx).zip(w.par_chunks(dx)).with_min_len(min_rows(dx)).enumerate().for_each(
            |(row, (xs, ws))| {
                if let Some((j, k)) = grid.row_jk(row) {
                    let line = &a[(j + ny * k) * nx..(j + ny * k + 1) * nx];
                    for ((xi, &wi), r) in xs[g..g + nx].iter_mut().zip(&ws[g..g + nx]).zip(line) {
                        *xi = scale * (wi * r.re + (T::one() - wi) * r.im);
                    }
                }
            },
        );
    }

    /// [`solve_blended`](Self::solve_blended) for two right-hand sides with the same
    /// operators and their own weights, packed as in [`solve_pair`](Self::solve_pair): one
    /// forward and two inverse transforms for the four solutions.
    pub fn solve_pair_blended(
        &mut self,
        grid: &Grid<T>,
        sigma: T,
        c: [T; 2],
        w: [&[T]; 2],
        b: [&[T]; 2],
        x: [&mut [T]; 2],
    ) {
        if let Some(sp) = &mut self.split {
            return sp.solve_pair_blended(grid, sigma, c, w, b, x);
        }
        gather(grid, &mut self.a, b[0], Some(b[1]));
        self.invert_two(sigma, c);
        let scale = self.ffts(false);
        std::mem::swap(&mut self.a, &mut self.a2);
        self.ffts(false);
        std::mem::swap(&mut self.a, &mut self.a2);
        let [nx, ny, _] = self.n;
        let (a, a2, g, dx) = (&self.a, &self.a2, GHOST, grid.dims()[0]);
        let [x1, x2] = x;
        x1.par_chunks_mut(dx)
            .zip(x2.par_chunks_mut(dx))
            .zip(w[0].par_chunks(dx).zip(w[1].par_chunks(dx)))
            .with_min_len(min_rows(dx))
            .enumerate()
            .for_each(|(row, ((xs, ys), (w1, w2)))| {
                if let Some((j, k)) = grid.row_jk(row) {
                    let range = (j + ny * k) * nx..(j + ny * k + 1) * nx;
                    let (hi, lo) = (&a[range.clone()], &a2[range]);
                    for i in 0..nx {
                        let (u, v) = (w1[g + i], w2[g + i]);
                        xs[g + i] = scale * (u * hi[i].re + (T::one() - u) * lo[i].re);
                        ys[g + i] = scale * (v * hi[i].im + (T::one() - v) * lo[i].im);
                    }
                }
            });
    }

    /// In-place FFT of `self.a` along `axis`.
    fn fft_axis(&mut self, axis: usize, forward: bool) {
        let n = self.n;
        let len = n[axis];
        if len == 1 {
            return;
        }
        let plan = if forward { self.modes.fwd[axis].clone() } else { self.modes.inv[axis].clone() };
        let data = if axis == 0 {
            &mut self.a
        } else {
            to_lines(&self.a, &mut self.b, n, axis);
            &mut self.b
        };
        let lines = n[0] * n[1] * n[2] / len;
        let per = lines.div_ceil(self.blocks) * len;
        data.par_chunks_mut(per).zip(self.fft_scratch.par_iter_mut()).for_each(|(chunk, scratch)| {
            plan.process_with_scratch(chunk, scratch);
        });
        if axis != 0 {
            from_lines(&self.b, &mut self.a, n, axis);
        }
    }

    /// Tridiagonal solves along the wall axis `w` for every pair of periodic wavenumbers.
    fn thomas(&mut self, w: usize, sigma: T, c: T) {
        let n = self.n;
        let e = c / (self.h[w] * self.h[w]);
        let closure = Closure { e, kind: self.kinds[w] };
        if w == 0 {
            // Lines along x are contiguous: one Thomas solve per line.
            let len = n[0];
            let per_lines = (n[1] * n[2]).div_ceil(self.blocks);
            let lam = &self.modes.lambda;
            self.a
                .par_chunks_mut(per_lines * len)
                .zip(self.thomas_scratch.par_iter_mut())
                .enumerate()
                .for_each(|(blk, (chunk, cp))| {
                    for (l, line) in chunk.chunks_mut(len).enumerate() {
                        let gl = blk * per_lines + l;
                        let shift = sigma + c * (lam[1][gl % n[1]] + lam[2][gl / n[1]]);
                        solve_line(line, &mut cp[..len], shift, closure);
                    }
                });
            return;
        }
        // Walls in y or z: the recurrence runs across x-rows, each row of `nx` independent
        // systems at once (no transpose, no dependency chain within a row). `cp` keeps the
        // eliminated upper diagonal of every cell for the back substitution.
        let nx = n[0];
        let plane = nx * n[1];
        let (lam, cp) = (&self.modes.lambda, &mut self.cp);
        if w == 1 {
            // Each z-plane is independent: the recurrence runs over its rows j.
            self.a
                .par_chunks_mut(plane)
                .zip(cp.par_chunks_mut(plane))
                .with_min_len(min_rows(plane))
                .enumerate()
                .for_each(|(k, (xa, xc))| {
                    let lo = lam[2][k];
                    for j in 0..n[1] {
                        let (done, rest) = xa.split_at_mut(j * nx);
                        let (cdone, crest) = xc.split_at_mut(j * nx);
                        let prev = (j > 0).then(|| (&done[(j - 1) * nx..], &cdone[(j - 1) * nx..]));
                        eliminate_row(&mut rest[..nx], &mut crest[..nx], prev, j, n[1], closure, |i| {
                            sigma + c * (lam[0][i] + lo)
                        });
                    }
                    for j in (0..n[1] - 1).rev() {
                        let (head, tail) = xa.split_at_mut((j + 1) * nx);
                        substitute_row(&mut head[j * nx..], &tail[..nx], &xc[j * nx..(j + 1) * nx]);
                    }
                });
        } else {
            // The recurrence runs over the z-planes; the rows of a plane are independent.
            let nz = n[2];
            for k in 0..nz {
                let (done, rest) = self.a.split_at_mut(k * plane);
                let (cdone, crest) = cp.split_at_mut(k * plane);
                let prev = (k > 0).then(|| (&done[(k - 1) * plane..], &cdone[(k - 1) * plane..]));
                rest[..plane]
                    .par_chunks_mut(nx)
                    .zip(crest[..plane].par_chunks_mut(nx))
                    .with_min_len(min_rows(nx))
                    .enumerate()
                    .for_each(|(j, (xr, cr))| {
                        let lo = lam[1][j];
                        let p = prev.map(|(x, c)| (&x[j * nx..(j + 1) * nx], &c[j * nx..(j + 1) * nx]));
                        eliminate_row(xr, cr, p, k, nz, closure, |i| sigma + c * (lam[0][i] + lo));
                    });
            }
            for k in (0..nz - 1).rev() {
                let (head, tail) = self.a.split_at_mut((k + 1) * plane);
                head[k * plane..]
                    .par_chunks_mut(nx)
                    .zip(tail[..plane].par_chunks(nx))
                    .zip(cp[k * plane..(k + 1) * plane].par_chunks(nx))
                    .with_min_len(min_rows(nx))
                    .for_each(|((xr, next), cr)| substitute_row(xr, next, cr));
            }
        }
    }
}

/// The tridiagonal rows along a wall axis: `-e x_{m-1} + d_m x_m - e x_{m+1} = b_m` with
/// `e = c / h^2`, `d_m = shift + 2e` in the interior and the end rows closed as `kind` says.
#[derive(Clone, Copy)]
struct Closure<T> {
    e: T,
    kind: AxisKind,
}

impl<T: Real> Closure<T> {
    /// The diagonal of row `m` of `len`.
    #[inline(always)]
    fn diag(self, shift: T, m: usize, len: usize) -> T {
        let two = T::lit(2.0);
        if m == 0 || m == len - 1 {
            match self.kind {
                AxisKind::CellNeumann => shift + self.e,
                AxisKind::CellDirichlet => shift + T::lit(3.0) * self.e,
                _ => shift + two * self.e,
            }
        } else {
            shift + two * self.e
        }
    }

    /// Row 0 becomes `x_0 = 0` for fixed wall faces and for the singular Neumann mode (pinning
    /// it).
    #[inline(always)]
    fn pinned(self, shift: T) -> bool {
        self.kind == AxisKind::FaceDirichlet || (self.kind == AxisKind::CellNeumann && shift <= T::zero())
    }
}

/// Forward elimination of row `m` of `len` for a row of independent systems (`shift(i)` of
/// system `i`): `x` holds the right-hand sides and becomes the eliminated values, `cp` the
/// eliminated upper diagonal; `prev` is row `m - 1` after its elimination (none for `m = 0`).
#[inline(always)]
fn eliminate_row<T: Real>(
    x: &mut [Complex<T>],
    cp: &mut [T],
    prev: Option<(&[Complex<T>], &[T])>,
    m: usize,
    len: usize,
    closure: Closure<T>,
    shift: impl Fn(usize) -> T,
) {
    let e = closure.e;
    match prev {
        None => {
            for (i, (xi, ci)) in x.iter_mut().zip(cp.iter_mut()).enumerate() {
                let s = shift(i);
                if closure.pinned(s) {
                    *xi = Complex::default();
                    *ci = T::zero();
                } else {
                    let inv = T::one() / closure.diag(s, m, len);
                    *ci = -e * inv;
                    *xi *= inv;
                }
            }
        }
        Some((xp, cpp)) => {
            for (i, (((xi, ci), &xq), &cq)) in x.iter_mut().zip(cp.iter_mut()).zip(xp).zip(cpp).enumerate() {
                let inv = T::one() / (closure.diag(shift(i), m, len) + e * cq);
                *ci = -e * inv;
                *xi = (*xi + xq * e) * inv;
            }
        }
    }
}

/// Back substitution of one row: `x_m -= cp_m x_{m+1}`.
#[inline(always)]
fn substitute_row<T: Real>(x: &mut [Complex<T>], next: &[Complex<T>], cp: &[T]) {
    for ((xi, &xn), &c) in x.iter_mut().zip(next).zip(cp) {
        *xi -= xn * c;
    }
}

/// The two axes other than `w`, in storage order.
fn others(w: usize) -> (usize, usize) {
    match w {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Solves one line of `closure` in place by the Thomas algorithm (`cp` of the line's length
/// is scratch).
fn solve_line<T: Real>(x: &mut [Complex<T>], cp: &mut [T], shift: T, closure: Closure<T>) {
    let n = x.len();
    let e = closure.e;
    if closure.pinned(shift) {
        x[0] = Complex::default();
        cp[0] = T::zero();
    } else {
        let d0 = closure.diag(shift, 0, n);
        cp[0] = -e / d0;
        x[0] /= d0;
    }
    for i in 1..n {
        let m = closure.diag(shift, i, n) + e * cp[i - 1];
        cp[i] = -e / m;
        x[i] = (x[i] + x[i - 1] * e) / m;
    }
    for i in (0..n - 1).rev() {
        let next = x[i + 1];
        x[i] -= next * cp[i];
    }
}

/// Gathers the interior values of `re` (and `im`) of `grid` into the complex work array `a`, x
/// fastest (also a part's layout A, [`split`]).
fn gather<T: Real>(grid: &Grid<T>, a: &mut [Complex<T>], re: &[T], im: Option<&[T]>) {
    let [nx, ny, _] = grid.n();
    a.par_chunks_mut(nx).with_min_len(min_rows(nx)).enumerate().for_each(|(line, row)| {
        let base = grid.idx_u(0, line % ny, line / ny);
        let re = &re[base..base + nx];
        match im {
            Some(im) => {
                for ((r, &a), &b) in row.iter_mut().zip(re).zip(&im[base..base + nx]) {
                    *r = Complex::new(a, b);
                }
            }
            None => {
                for (r, &a) in row.iter_mut().zip(re) {
                    *r = Complex::new(a, T::zero());
                }
            }
        }
    });
}

/// Scatters the real part of the work array `a`, times `scale`, into the interior of `re` (and the
/// imaginary part into `im`), the inverse of [`gather`].
fn scatter<T: Real>(grid: &Grid<T>, a: &[Complex<T>], scale: T, re: &mut [T], im: Option<&mut [T]>) {
    let [nx, ny, _] = grid.n();
    let (g, dx) = (GHOST, grid.dims()[0]);
    let line_of = |row: usize| grid.row_jk(row).map(|(j, k)| &a[(j + ny * k) * nx..(j + ny * k + 1) * nx]);
    match im {
        None => re.par_chunks_mut(dx).with_min_len(min_rows(dx)).enumerate().for_each(|(row, xs)| {
            if let Some(line) = line_of(row) {
                for (xi, r) in xs[g..g + nx].iter_mut().zip(line) {
                    *xi = r.re * scale;
                }
            }
        }),
        Some(im) => {
            re.par_chunks_mut(dx).zip(im.par_chunks_mut(dx)).with_min_len(min_rows(dx)).enumerate().for_each(
                |(row, (xs, ys))| {
                    if let Some(line) = line_of(row) {
                        for ((xi, yi), r) in xs[g..g + nx].iter_mut().zip(&mut ys[g..g + nx]).zip(line) {
                            *xi = r.re * scale;
                            *yi = r.im * scale;
                        }
                    }
                },
            )
        }
    }
}

/// Lines moved together by [`to_lines`], planes by [`from_lines`]: their strided side then
/// reads or writes whole cache lines instead of one value per line (a stride of a plane maps
/// every access to the same few cache sets).
const BLOCK: usize = 8;

/// Copies `src` (x fastest) to `dst` with `axis` fastest, `BLOCK` lines at a time (lines
/// consecutive along the first other axis, where `src` is contiguous).
fn to_lines<T: Real>(src: &[Complex<T>], dst: &mut [Complex<T>], n: [usize; 3], axis: usize) {
    let len = n[axis];
    let (o1, o2) = others(axis);
    let st = [1, n[0], n[0] * n[1]];
    let (s_o1, s_o2, s_ax) = (st[o1], st[o2], st[axis]);
    let min_blocks = min_rows(len).div_ceil(BLOCK);
    dst.par_chunks_mut(len * BLOCK).with_min_len(min_blocks).enumerate().for_each(|(blk, lines)| {
        let count = lines.len() / len;
        let mut base = [0; BLOCK];
        for (b, x) in base.iter_mut().enumerate().take(count) {
            let l = blk * BLOCK + b;
            *x = (l % n[o1]) * s_o1 + (l / n[o1]) * s_o2;
        }
        for m in 0..len {
            let off = m * s_ax;
            for (b, &x) in base.iter().enumerate().take(count) {
                lines[b * len + m] = src[x + off];
            }
        }
    });
}

/// Inverse of [`to_lines`].
fn from_lines<T: Real>(src: &[Complex<T>], dst: &mut [Complex<T>], n: [usize; 3], axis: usize) {
    let len = n[axis];
    if axis == 2 {
        // `BLOCK` planes at a time: each source line gives `BLOCK` consecutive values.
        let plane = n[0] * n[1];
        dst.par_chunks_mut(plane * BLOCK).enumerate().for_each(|(c, planes)| {
            let (k0, count) = (c * BLOCK, planes.len() / plane);
            for l in 0..plane {
                for (p, &v) in src[l * len + k0..l * len + k0 + count].iter().enumerate() {
                    planes[p * plane + l] = v;
                }
            }
        });
        return;
    }
    dst.par_chunks_mut(n[0] * n[1]).with_min_len(min_rows(n[0] * n[1])).enumerate().for_each(|(k, plane)| {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let (l, m) = if axis == 0 { (j + n[1] * k, i) } else { (i + n[0] * k, j) };
                plane[i + n[0] * j] = src[l * len + m];
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Boundary, Field, VectorField};

    fn grids() -> Vec<Grid<f64>> {
        let mut out = vec![Grid::periodic([8, 6, 4], [0.0; 3], [1.0, 2.0, 0.5]).unwrap()];
        for w in 0..3 {
            out.push(Grid::new([6, 8, 5], [0.0; 3], [1.0, 1.5, 0.7], Boundary::walls_on(Some(w))).unwrap());
        }
        // Large enough planes and rows that the wall sweeps split into several rayon tasks.
        for (w, n) in [(1, [40, 24, 36]), (2, [96, 100, 6])] {
            out.push(Grid::new(n, [0.0; 3], [1.0, 1.5, 0.7], Boundary::walls_on(Some(w))).unwrap());
        }
        out
    }

    fn pseudo_random(i: usize) -> f64 {
        ((i as f64 * 12.9898).sin() * 43758.5453).fract()
    }

    /// `sigma x - c Lap x` by the 7-point stencil with the ghost closure of `x`.
    fn apply(g: &Grid<f64>, x: &Field<f64>, sigma: f64, c: f64, id: usize) -> f64 {
        let st = g.strides();
        let mut lap = 0.0;
        for d in 0..3 {
            let h2 = g.h()[d] * g.h()[d];
            lap += (x.data[id + st[d]] - 2.0 * x.data[id] + x.data[id - st[d]]) / h2;
        }
        sigma * x.data[id] - c * lap
    }

    #[test]
    fn pressure_poisson_is_exact() {
        for g in grids() {
            let mut solver = SpectralSolver::new(&g, Location::CellNeumann).unwrap();
            let mut x = Field::zeros(&g);
            for (n, (i, j, k)) in g.cells().enumerate() {
                x.data[g.idx_u(i, j, k)] = pseudo_random(n);
            }
            // Remove the mean: the singular mode is fixed by zero mean.
            let mean = x.interior_sum(&g) / g.cell_count() as f64;
            for (i, j, k) in g.cells() {
                x.data[g.idx_u(i, j, k)] -= mean;
            }
            x.fill_ghosts(&g);
            let mut b = Field::zeros(&g);
            for (i, j, k) in g.cells() {
                let id = g.idx_u(i, j, k);
                b.data[id] = apply(&g, &x, 0.0, 1.0, id);
            }
            let mut y = Field::zeros(&g);
            solver.solve(&g, 0.0, 1.0, &b.data, &mut y.data);
            let ymean = y.interior_sum(&g) / g.cell_count() as f64;
            for (i, j, k) in g.cells() {
                let id = g.idx_u(i, j, k);
                assert!((y.data[id] - ymean - x.data[id]).abs() < 1e-10, "{:?}", g.bc(1));
            }
        }
    }

    #[test]
    fn velocity_helmholtz_is_exact() {
        for g in grids() {
            for d in 0..3 {
                let mut solver = SpectralSolver::new(&g, Location::Velocity(d)).unwrap();
                let mut v = VectorField::zeros(&g);
                for (n, (i, j, k)) in g.cells().enumerate() {
                    let wall_face = !g.is_periodic(d) && [i, j, k][d] == 0;
                    v.c[d].data[g.idx_u(i, j, k)] = if wall_face { 0.0 } else { pseudo_random(n + 7) };
                }
                v.fill_ghosts_homogeneous(&g);
                let mut b = Field::zeros(&g);
                for (i, j, k) in g.cells() {
                    let id = g.idx_u(i, j, k);
                    b.data[id] = apply(&g, &v.c[d], 3.0, 0.7, id);
                }
                let mut y = Field::zeros(&g);
                solver.solve(&g, 3.0, 0.7, &b.data, &mut y.data);
                for (i, j, k) in g.cells() {
                    let id = g.idx_u(i, j, k);
                    assert!((y.data[id] - v.c[d].data[id]).abs() < 1e-11, "d={d} {:?}", (i, j, k));
                }
            }
        }
    }

    /// The blended solves equal the blend of two separate solves, single and paired, with and
    /// without walls (velocity closures, where the pairs occur).
    #[test]
    fn blended_solves_are_blends_of_two_solves() {
        let (sigma, c) = (3.0, [0.9, 0.2]);
        for g in grids() {
            let len = g.dims().iter().product::<usize>();
            let field = |seed: usize| (0..len).map(|i| pseudo_random(i + seed)).collect::<Vec<f64>>();
            let w = field(11).iter().map(|x| x.abs()).collect::<Vec<_>>();
            let w2 = field(29).iter().map(|x| x.abs()).collect::<Vec<_>>();
            let (b1, b2) = (field(3), field(17));
            for d in 0..3 {
                let mut solver = SpectralSolver::new(&g, Location::Velocity(d)).unwrap();
                let separate = |solver: &mut SpectralSolver<f64>, b: &[f64], w: &[f64]| {
                    let (mut hi, mut lo) = (vec![0.0; len], vec![0.0; len]);
                    solver.solve(&g, sigma, c[0], b, &mut hi);
                    solver.solve(&g, sigma, c[1], b, &mut lo);
                    (0..len).map(|i| w[i] * hi[i] + (1.0 - w[i]) * lo[i]).collect::<Vec<_>>()
                };
                let (e1, e2) = (separate(&mut solver, &b1, &w), separate(&mut solver, &b2, &w2));
                let mut x1 = vec![0.0; len];
                solver.solve_blended(&g, sigma, c, &w, &b1, &mut x1);
                let (mut y1, mut y2) = (vec![0.0; len], vec![0.0; len]);
                solver.solve_pair_blended(&g, sigma, c, [&w, &w2], [&b1, &b2], [&mut y1, &mut y2]);
                for (i, j, k) in g.cells() {
                    let id = g.idx_u(i, j, k);
                    let scale = 1.0 + e1[id].abs();
                    assert!((x1[id] - e1[id]).abs() < 1e-13 * scale, "d={d} {:?}", (i, j, k));
                    assert!((y1[id] - e1[id]).abs() < 1e-13 * scale, "d={d} {:?}", (i, j, k));
                    assert!((y2[id] - e2[id]).abs() < 1e-13 * (1.0 + e2[id].abs()), "d={d} {:?}", (i, j, k));
                }
            }
        }
    }

    #[test]
    fn two_wall_axes_are_refused() {
        let mut bc = [[Boundary::<f64>::wall(); 2]; 3];
        bc[0] = [Boundary::Periodic; 2];
        let g = Grid::new([6, 6, 6], [0.0; 3], [1.0; 3], bc).unwrap();
        assert!(SpectralSolver::new(&g, Location::CellNeumann).is_err());
    }
}
