//! Vector operations over the interior of fields, for the iterative solvers.
//!
//! Reductions are summed in [`CHUNKS`] fixed blocks of x-lines, each block in order, then the
//! blocks in order: the result does not depend on the number of threads or on scheduling, so a
//! run is reproducible bit for bit (and so is a restarted run). On a part of a decomposed grid
//! ([`Grid::split`]) each part sums its slab so and the parts' sums are added in part order
//! ([`Grid::sum_over_parts`]): reproducible for a given number of parts.
//!
//! The fused passes ([`InteriorVector::update`], [`InteriorVector::update_reduce`],
//! [`InteriorVector::reduce`]) read every operand once per cell, so that a Krylov iteration
//! streams each vector as few times as its data dependences allow (the solvers are bound by
//! memory bandwidth); they sum in the same blocks as [`InteriorVector::dot`].

use crate::Real;
use crate::grid::{Field, GHOST, Grid, VectorField};
use rayon::prelude::*;

/// Number of fixed blocks of a reduction.
pub const CHUNKS: usize = 64;

/// First and one-past-last x-line (row over the interior `j`, `k`) of block `c`.
fn block_rows(rows: usize, c: usize) -> (usize, usize) {
    (c * rows / CHUNKS, (c + 1) * rows / CHUNKS)
}

/// Smallest number of blocks a thread takes (about 8192 cells).
fn min_blocks<T: Real>(grid: &Grid<T>) -> usize {
    let [nx, ny, nz] = grid.n();
    (8192 / (nx * ny * nz / CHUNKS).max(1)).max(1)
}

/// Storage index of the first interior value of interior row `r`.
fn row_base<T: Real>(grid: &Grid<T>, r: usize) -> usize {
    let ny = grid.n()[1];
    grid.idx_u(0, r % ny, r / ny)
}

/// Runs `work(piece, rows)` on each of the fixed blocks of x-lines in parallel and sums the two
/// values each returns, the blocks in order.
fn sum_blocks<T: Real, P: Send>(
    grid: &Grid<T>,
    pieces: [P; CHUNKS],
    work: impl Fn(P, std::ops::Range<usize>) -> [T; 2] + Sync,
) -> [T; 2] {
    let [_, ny, nz] = grid.n();
    let mut partial = [[T::zero(); 2]; CHUNKS];
    partial.par_iter_mut().zip(pieces).with_min_len(min_blocks(grid)).enumerate().for_each(
        |(c, (p, piece))| {
            let (r0, r1) = block_rows(ny * nz, c);
            *p = work(piece, r0..r1);
        },
    );
    // On a part of a decomposed grid the parts' sums are then added in part order.
    grid.sum_over_parts(partial.iter().fold([T::zero(); 2], |s, p| [s[0] + p[0], s[1] + p[1]]))
}

/// The interior values of x-line `base .. base + nx` of each slice.
fn lines<'a, T, const K: usize>(xs: &[&'a [T]; K], base: usize, nx: usize) -> [&'a [T]; K] {
    std::array::from_fn(|q| &xs[q][base..base + nx])
}

/// The `i`-th value of each line.
fn at<T: Copy, const K: usize>(line: &[&[T]; K], i: usize) -> [T; K] {
    std::array::from_fn(|q| line[q][i])
}

/// For every interior cell in the fixed blocks of the module docs: `f` of the values of `a`
/// and of the `K` slices there, summed over the cells (two sums).
fn reduce<T: Real, const K: usize>(
    grid: &Grid<T>,
    a: &[T],
    xs: [&[T]; K],
    f: impl Fn(T, [T; K]) -> [T; 2] + Sync,
) -> [T; 2] {
    let nx = grid.n()[0];
    sum_blocks(grid, [(); CHUNKS], |(), rows| {
        let mut s = [T::zero(); 2];
        for base in rows.map(|r| row_base(grid, r)) {
            let line = lines(&xs, base, nx);
            for (i, &ai) in a[base..base + nx].iter().enumerate() {
                let v = f(ai, at(&line, i));
                s = [s[0] + v[0], s[1] + v[1]];
            }
        }
        s
    })
}

/// `y = f(y, x_1 .. x_K)` on every interior cell, and the two sums that `f` returns beside,
/// summed in the fixed blocks of the module docs. Ghost values of `y` are left as they are.
fn update_reduce<T: Real, const K: usize>(
    grid: &Grid<T>,
    y: &mut [T],
    xs: [&[T]; K],
    f: impl Fn(T, [T; K]) -> (T, [T; 2]) + Sync,
) -> [T; 2] {
    let [nx, ny, nz] = grid.n();
    let rows = ny * nz;
    // Block c owns the storage from the first value of its first row to that of the next
    // block's (the ghosts in between included), so the blocks are disjoint pieces of `y`.
    let len = y.len();
    let start = |c: usize| {
        let r0 = block_rows(rows, c).0;
        if r0 < rows { row_base(grid, r0) } else { len }
    };
    let mut rest = y;
    let mut taken = 0;
    let pieces: [(usize, &mut [T]); CHUNKS] = std::array::from_fn(|c| {
        let end = if c + 1 < CHUNKS { start(c + 1) } else { len };
        let (piece, tail) = std::mem::take(&mut rest).split_at_mut(end - taken);
        rest = tail;
        let offset = taken;
        taken = end;
        (offset, piece)
    });
    sum_blocks(grid, pieces, |(offset, piece), rows| {
        let mut s = [T::zero(); 2];
        for base in rows.map(|r| row_base(grid, r)) {
            let line = lines(&xs, base, nx);
            for (i, o) in piece[base - offset..base - offset + nx].iter_mut().enumerate() {
                let (v, add) = f(*o, at(&line, i));
                *o = v;
                s = [s[0] + add[0], s[1] + add[1]];
            }
        }
        s
    })
}

/// `y = f(y, x_1 .. x_K)` on every interior cell, in parallel over x-lines. Ghost values of
/// `y` are left as they are.
fn update<T: Real, const K: usize>(
    grid: &Grid<T>,
    y: &mut [T],
    xs: [&[T]; K],
    f: impl Fn(T, [T; K]) -> T + Sync,
) {
    let nx = grid.n()[0];
    let dx = grid.dims()[0];
    y.par_chunks_mut(dx).with_min_len(crate::grid::ops::min_rows(dx)).enumerate().for_each(|(row, out)| {
        if grid.row_jk(row).is_some() {
            let base = row * dx + GHOST;
            let line = lines(&xs, base, nx);
            for (i, o) in out[GHOST..GHOST + nx].iter_mut().enumerate() {
                *o = f(*o, at(&line, i));
            }
        }
    });
}

/// A field seen as a vector of its interior values: what the Krylov solvers need.
pub trait InteriorVector<T: Real>: Send + Sync {
    /// Interior dot product (reproducible).
    fn dot(&self, grid: &Grid<T>, other: &Self) -> T {
        self.reduce(grid, [other], |a, [b]| [a * b, T::zero()])[0]
    }
    /// `self = a x + b self` on the interior.
    fn axpby(&mut self, grid: &Grid<T>, a: T, x: &Self, b: T) {
        self.update(grid, [x], |y, [x]| a * x + b * y);
    }
    /// Copies all values of `other`.
    fn assign(&mut self, other: &Self);
    /// A zero vector on `grid`.
    fn zeros_like(grid: &Grid<T>) -> Self;
    /// Euclidean norm of the interior.
    fn norm(&self, grid: &Grid<T>) -> T {
        self.dot(grid, self).sqrt()
    }
    /// The interior sums of the two values `f(self, x_1 .. x_K)` gives per value, in one pass
    /// (reproducible, summed as [`dot`](Self::dot)).
    fn reduce<const K: usize>(
        &self,
        grid: &Grid<T>,
        xs: [&Self; K],
        f: impl Fn(T, [T; K]) -> [T; 2] + Sync,
    ) -> [T; 2];
    /// `self = f(self, x_1 .. x_K)` on the interior, in one pass.
    fn update<const K: usize>(&mut self, grid: &Grid<T>, xs: [&Self; K], f: impl Fn(T, [T; K]) -> T + Sync);
    /// `self = f(self, x_1 .. x_K).0` on the interior, and the interior sums of the two values
    /// of `f(..).1`, in one pass (reproducible, summed as [`dot`](Self::dot)).
    fn update_reduce<const K: usize>(
        &mut self,
        grid: &Grid<T>,
        xs: [&Self; K],
        f: impl Fn(T, [T; K]) -> (T, [T; 2]) + Sync,
    ) -> [T; 2];
}

impl<T: Real> InteriorVector<T> for Field<T> {
    fn assign(&mut self, other: &Self) {
        self.data.copy_from_slice(&other.data);
    }
    fn zeros_like(grid: &Grid<T>) -> Self {
        Field::zeros(grid)
    }
    fn reduce<const K: usize>(
        &self,
        grid: &Grid<T>,
        xs: [&Self; K],
        f: impl Fn(T, [T; K]) -> [T; 2] + Sync,
    ) -> [T; 2] {
        reduce(grid, &self.data, std::array::from_fn(|q| &xs[q].data[..]), f)
    }
    fn update<const K: usize>(&mut self, grid: &Grid<T>, xs: [&Self; K], f: impl Fn(T, [T; K]) -> T + Sync) {
        update(grid, &mut self.data, std::array::from_fn(|q| &xs[q].data[..]), f);
    }
    fn update_reduce<const K: usize>(
        &mut self,
        grid: &Grid<T>,
        xs: [&Self; K],
        f: impl Fn(T, [T; K]) -> (T, [T; 2]) + Sync,
    ) -> [T; 2] {
        update_reduce(grid, &mut self.data, std::array::from_fn(|q| &xs[q].data[..]), f)
    }
}

impl<T: Real> InteriorVector<T> for VectorField<T> {
    fn assign(&mut self, other: &Self) {
        self.copy_from(other);
    }
    fn zeros_like(grid: &Grid<T>) -> Self {
        VectorField::zeros(grid)
    }
    fn reduce<const K: usize>(
        &self,
        grid: &Grid<T>,
        xs: [&Self; K],
        f: impl Fn(T, [T; K]) -> [T; 2] + Sync,
    ) -> [T; 2] {
        (0..3).fold([T::zero(); 2], |s, d| {
            let p = reduce(grid, &self.c[d].data, std::array::from_fn(|q| &xs[q].c[d].data[..]), &f);
            [s[0] + p[0], s[1] + p[1]]
        })
    }
    fn update<const K: usize>(&mut self, grid: &Grid<T>, xs: [&Self; K], f: impl Fn(T, [T; K]) -> T + Sync) {
        for (d, y) in self.c.iter_mut().enumerate() {
            update(grid, &mut y.data, std::array::from_fn(|q| &xs[q].c[d].data[..]), &f);
        }
    }
    fn update_reduce<const K: usize>(
        &mut self,
        grid: &Grid<T>,
        xs: [&Self; K],
        f: impl Fn(T, [T; K]) -> (T, [T; 2]) + Sync,
    ) -> [T; 2] {
        let mut s = [T::zero(); 2];
        for (d, y) in self.c.iter_mut().enumerate() {
            let p = update_reduce(grid, &mut y.data, std::array::from_fn(|q| &xs[q].c[d].data[..]), &f);
            s = [s[0] + p[0], s[1] + p[1]];
        }
        s
    }
}

/// Sum of `f(value)` over the interior of a field, reproducible.
pub fn interior_sum_of<T: Real>(grid: &Grid<T>, a: &Field<T>, f: impl Fn(T) -> T + Sync) -> T {
    reduce(grid, &a.data, [], |x, []| [f(x), T::zero()])[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reductions_ignore_ghosts_and_are_exact_on_small_integers() {
        let g = Grid::<f64>::periodic([5, 7, 4], [0.0; 3], [1.0; 3]).unwrap();
        let mut a = Field::from_cell_fn(&g, |_| 2.0);
        let b = Field::from_cell_fn(&g, |_| 3.0);
        assert_eq!(a.dot(&g, &b), 6.0 * 140.0);
        a.axpby(&g, 1.0, &b, -1.0);
        assert_eq!(a.at(&g, 0, 0, 0), 1.0);
        assert_eq!(a.at(&g, -1, 0, 0), 2.0);
    }

    /// The fused passes give bit for bit what the separate ones give, leave the ghosts alone,
    /// and cut the storage into disjoint blocks for any number of x-lines (fewer lines than
    /// blocks, and more).
    #[test]
    fn fused_passes_equal_the_separate_ones_bit_for_bit() {
        for n in [[5, 7, 4], [9, 11, 13], [16, 4, 40], [6, 1, 5]] {
            let g = Grid::<f64>::periodic(n, [0.0; 3], [1.0; 3]).unwrap();
            let wave = |a: f64| move |p: [f64; 3]| (a * p[0] + 2.0 * p[1] - p[2]).sin() + 0.1 * a;
            let mut x = VectorField::<f64>::from_fn(&g, |p| [wave(1.0)(p), wave(2.0)(p), wave(3.0)(p)]);
            let y = VectorField::<f64>::from_fn(&g, |p| [wave(-4.0)(p), wave(5.0)(p), wave(0.5)(p)]);
            x.c[1].data[0] = 7.0; // a ghost value, to be left as it is
            let (alpha, omega) = (0.37, -1.3);
            let mut separate = x.clone();
            separate.axpby(&g, -alpha, &y, 1.0);
            let sums = [separate.dot(&g, &separate), y.dot(&g, &separate)];
            let mut fused = x.clone();
            let got = fused.update_reduce(&g, [&y], |x, [y]| {
                let s = -alpha * y + x;
                (s, [s * s, y * s])
            });
            assert_eq!(got, sums);
            assert_eq!(fused.c, separate.c);
            assert_eq!(fused.c[1].data[0], 7.0);
            separate.axpby(&g, omega, &y, 1.0);
            separate.axpby(&g, alpha, &x, 1.0);
            fused.update(&g, [&y, &x], |f, [y, x]| alpha * x + (omega * y + f));
            assert_eq!(fused.c, separate.c);
            let two = fused.reduce(&g, [&y], |f, [y]| [f * f, f * y]);
            assert_eq!(two, [separate.dot(&g, &separate), separate.dot(&g, &y)]);
        }
    }
}
