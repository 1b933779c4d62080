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

use crate::grid::ops::min_rows;
use crate::grid::{GHOST, Grid};
use crate::{Error, Real, Result};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

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
    lambda: [Vec<T>; 3],
    fwd: [Arc<dyn Fft<T>>; 3],
    inv: [Arc<dyn Fft<T>>; 3],
    a: Vec<Complex<T>>,
    b: Vec<Complex<T>>,
    fft_scratch: Vec<Vec<Complex<T>>>,
    thomas_scratch: Vec<Vec<T>>,
    blocks: usize,
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
        let n = grid.n();
        let h = grid.h();
        let mut planner = FftPlanner::<T>::new();
        let fwd: [Arc<dyn Fft<T>>; 3] = std::array::from_fn(|a| planner.plan_fft_forward(n[a]));
        let inv: [Arc<dyn Fft<T>>; 3] = std::array::from_fn(|a| planner.plan_fft_inverse(n[a]));
        let two = T::lit(2.0);
        let lambda = std::array::from_fn(|a| {
            (0..n[a])
                .map(|m| {
                    let theta = T::TAU() * T::from_usize(m).unwrap() / T::from_usize(n[a]).unwrap();
                    (two - two * theta.cos()) / (h[a] * h[a])
                })
                .collect()
        });
        let total = n[0] * n[1] * n[2];
        let blocks = rayon::current_num_threads().max(1);
        let scratch_len = (0..3)
            .map(|a| fwd[a].get_inplace_scratch_len().max(inv[a].get_inplace_scratch_len()))
            .max()
            .unwrap_or(0);
        let nmax = n.iter().copied().max().unwrap_or(1);
        Ok(SpectralSolver {
            n,
            h,
            kinds,
            wall: walls.first().copied(),
            lambda,
            fwd,
            inv,
            a: vec![Complex::default(); total],
            b: vec![Complex::default(); total],
            fft_scratch: (0..blocks).map(|_| vec![Complex::default(); scratch_len]).collect(),
            thomas_scratch: (0..blocks).map(|_| vec![T::zero(); nmax]).collect(),
            blocks,
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
        self.gather(grid, b, None);
        let scale = self.transform(sigma, c);
        self.scatter(grid, scale, x, None);
    }

    /// Solves two problems with the same operator at once, `b_1 -> x_1` and `b_2 -> x_2`, as
    /// [`solve`](Self::solve) does each: the operator is real, so one complex solve of
    /// `b_1 + i b_2` gives `x_1 + i x_2`, at the cost of one solve instead of two.
    pub fn solve_pair(&mut self, grid: &Grid<T>, sigma: T, c: T, b: [&[T]; 2], x: [&mut [T]; 2]) {
        self.gather(grid, b[0], Some(b[1]));
        let scale = self.transform(sigma, c);
        let [x1, x2] = x;
        self.scatter(grid, scale, x1, Some(x2));
    }

    /// Gathers the interior values of `re` (and `im`) into the complex work array, x fastest.
    fn gather(&mut self, grid: &Grid<T>, re: &[T], im: Option<&[T]>) {
        let [nx, ny, _] = self.n;
        self.a.par_chunks_mut(nx).with_min_len(min_rows(nx)).enumerate().for_each(|(line, row)| {
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

    /// Applies the inverse operator to the work array (FFTs, division or tridiagonal solves,
    /// inverse FFTs); returns the normalisation of the inverse FFTs still to apply.
    fn transform(&mut self, sigma: T, c: T) -> T {
        let [nx, ny, _] = self.n;
        let periodic: Vec<usize> = (0..3).filter(|&a| self.kinds[a] == AxisKind::Periodic).collect();
        for &ax in &periodic {
            self.fft_axis(ax, true);
        }
        match self.wall {
            Some(w) => self.thomas(w, sigma, c),
            None => {
                let lam = &self.lambda;
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
        for &ax in &periodic {
            self.fft_axis(ax, false);
        }
        T::one() / periodic.iter().map(|&a| T::from_usize(self.n[a]).unwrap()).fold(T::one(), |p, q| p * q)
    }

    /// Scatters the real part of the work array, times `scale`, into the interior of `re`
    /// (and the imaginary part into `im`).
    fn scatter(&self, grid: &Grid<T>, scale: T, re: &mut [T], im: Option<&mut [T]>) {
        let [nx, ny, _] = self.n;
        let (a, g, dx) = (&self.a, GHOST, grid.dims()[0]);
        let line_of =
            |row: usize| grid.row_jk(row).map(|(j, k)| &a[(j + ny * k) * nx..(j + ny * k + 1) * nx]);
        match im {
            None => re.par_chunks_mut(dx).with_min_len(min_rows(dx)).enumerate().for_each(|(row, xs)| {
                if let Some(line) = line_of(row) {
                    for (xi, r) in xs[g..g + nx].iter_mut().zip(line) {
                        *xi = r.re * scale;
                    }
                }
            }),
            Some(im) => re
                .par_chunks_mut(dx)
                .zip(im.par_chunks_mut(dx))
                .with_min_len(min_rows(dx))
                .enumerate()
                .for_each(|(row, (xs, ys))| {
                    if let Some(line) = line_of(row) {
                        for ((xi, yi), r) in xs[g..g + nx].iter_mut().zip(&mut ys[g..g + nx]).zip(line) {
                            *xi = r.re * scale;
                            *yi = r.im * scale;
                        }
                    }
                }),
        }
    }

    /// In-place FFT of `self.a` along `axis`.
    fn fft_axis(&mut self, axis: usize, forward: bool) {
        let n = self.n;
        let len = n[axis];
        if len == 1 {
            return;
        }
        let plan = if forward { self.fwd[axis].clone() } else { self.inv[axis].clone() };
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
        let len = n[w];
        if w != 0 {
            to_lines(&self.a, &mut self.b, n, w);
        } else {
            self.b.copy_from_slice(&self.a);
        }
        let (o1, o2) = others(w);
        let lines = n[0] * n[1] * n[2] / len;
        let per_lines = lines.div_ceil(self.blocks);
        let kind = self.kinds[w];
        let hw2 = self.h[w] * self.h[w];
        let lam = &self.lambda;
        let n_o1 = n[o1];
        self.b.par_chunks_mut(per_lines * len).zip(self.thomas_scratch.par_iter_mut()).enumerate().for_each(
            |(blk, (chunk, cp))| {
                for (l, line) in chunk.chunks_mut(len).enumerate() {
                    let gl = blk * per_lines + l;
                    let (m1, m2) = (gl % n_o1, gl / n_o1);
                    let shift = sigma + c * (lam[o1][m1] + lam[o2][m2]);
                    solve_line(line, &mut cp[..len], shift, c / hw2, kind);
                }
            },
        );
        if w != 0 {
            from_lines(&self.b, &mut self.a, n, w);
        } else {
            self.a.copy_from_slice(&self.b);
        }
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

/// Solves `-e x_{i-1} + d_i x_i - e x_{i+1} = b_i` in place by the Thomas algorithm, with
/// `e = c / h^2`, `d_i = shift + 2e` in the interior and the end rows closed as `kind` says.
/// Row 0 becomes `x_0 = 0` for fixed wall faces and for the singular Neumann mode (pinning it).
fn solve_line<T: Real>(x: &mut [Complex<T>], cp: &mut [T], shift: T, e: T, kind: AxisKind) {
    let n = x.len();
    let two = T::lit(2.0);
    let end = match kind {
        AxisKind::CellNeumann => shift + e,
        AxisKind::CellDirichlet => shift + T::lit(3.0) * e,
        _ => shift + two * e,
    };
    let diag = |i: usize| if i == 0 || i == n - 1 { end } else { shift + two * e };
    let pinned = kind == AxisKind::FaceDirichlet || (kind == AxisKind::CellNeumann && shift <= T::zero());
    if pinned {
        x[0] = Complex::default();
        cp[0] = T::zero();
    } else {
        let d0 = diag(0);
        cp[0] = -e / d0;
        x[0] /= d0;
    }
    for i in 1..n {
        let m = diag(i) + e * cp[i - 1];
        cp[i] = -e / m;
        x[i] = (x[i] + x[i - 1] * e) / m;
    }
    for i in (0..n - 1).rev() {
        let next = x[i + 1];
        x[i] -= next * cp[i];
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
            let mut bc = [[Boundary::Periodic; 2]; 3];
            bc[w] = [Boundary::wall(), Boundary::wall()];
            out.push(Grid::new([6, 8, 5], [0.0; 3], [1.0, 1.5, 0.7], bc).unwrap());
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

    #[test]
    fn two_wall_axes_are_refused() {
        let mut bc = [[Boundary::<f64>::wall(); 2]; 3];
        bc[0] = [Boundary::Periodic; 2];
        let g = Grid::new([6, 6, 6], [0.0; 3], [1.0; 3], bc).unwrap();
        assert!(SpectralSolver::new(&g, Location::CellNeumann).is_err());
    }
}
