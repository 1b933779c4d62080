//! Vector operations over the interior of fields, for the iterative solvers.
//!
//! Reductions are summed in [`CHUNKS`] fixed blocks of x-lines, each block in order, then the
//! blocks in order: the result does not depend on the number of threads or on scheduling, so a
//! run is reproducible bit for bit (and so is a restarted run).

use crate::Real;
use crate::grid::{Field, GHOST, Grid, VectorField};
use rayon::prelude::*;

/// Number of fixed blocks of a reduction.
pub const CHUNKS: usize = 64;

/// `sum f(a_i, b_i)` over interior cells, reproducible (see the module docs).
fn reduce<T: Real>(grid: &Grid<T>, a: &[T], b: &[T], f: impl Fn(T, T) -> T + Sync) -> T {
    let [nx, ny, nz] = grid.n();
    let rows = ny * nz;
    let mut partial = [T::zero(); CHUNKS];
    let min_chunks = (8192 / (nx * rows / CHUNKS).max(1)).max(1);
    partial.par_iter_mut().with_min_len(min_chunks).enumerate().for_each(|(c, p)| {
        let (r0, r1) = (c * rows / CHUNKS, (c + 1) * rows / CHUNKS);
        let mut s = T::zero();
        for r in r0..r1 {
            let base = grid.idx_u(0, r % ny, r / ny);
            for i in 0..nx {
                s += f(a[base + i], b[base + i]);
            }
        }
        *p = s;
    });
    partial.iter().fold(T::zero(), |s, &p| s + p)
}

/// `y = a x + b y` over interior cells.
fn axpby<T: Real>(grid: &Grid<T>, a: T, x: &[T], b: T, y: &mut [T]) {
    let nx = grid.n()[0];
    let dx = grid.dims()[0];
    y.par_chunks_mut(dx).with_min_len(crate::grid::ops::min_rows(dx)).enumerate().for_each(|(row, line)| {
        if grid.row_jk(row).is_some() {
            let base = row * dx + GHOST;
            for (yi, &xi) in line[GHOST..GHOST + nx].iter_mut().zip(&x[base..base + nx]) {
                *yi = a * xi + b * *yi;
            }
        }
    });
}

/// A field seen as a vector of its interior values: what the Krylov solvers need.
pub trait InteriorVector<T: Real>: Send + Sync {
    /// Interior dot product (reproducible).
    fn dot(&self, grid: &Grid<T>, other: &Self) -> T;
    /// `self = a x + b self` on the interior.
    fn axpby(&mut self, grid: &Grid<T>, a: T, x: &Self, b: T);
    /// Copies all values of `other`.
    fn assign(&mut self, other: &Self);
    /// A zero vector on `grid`.
    fn zeros_like(grid: &Grid<T>) -> Self;
    /// Euclidean norm of the interior.
    fn norm(&self, grid: &Grid<T>) -> T {
        self.dot(grid, self).sqrt()
    }
}

impl<T: Real> InteriorVector<T> for Field<T> {
    fn dot(&self, grid: &Grid<T>, other: &Self) -> T {
        reduce(grid, &self.data, &other.data, |a, b| a * b)
    }
    fn axpby(&mut self, grid: &Grid<T>, a: T, x: &Self, b: T) {
        axpby(grid, a, &x.data, b, &mut self.data);
    }
    fn assign(&mut self, other: &Self) {
        self.data.copy_from_slice(&other.data);
    }
    fn zeros_like(grid: &Grid<T>) -> Self {
        Field::zeros(grid)
    }
}

impl<T: Real> InteriorVector<T> for VectorField<T> {
    fn dot(&self, grid: &Grid<T>, other: &Self) -> T {
        (0..3).fold(T::zero(), |s, d| s + self.c[d].dot(grid, &other.c[d]))
    }
    fn axpby(&mut self, grid: &Grid<T>, a: T, x: &Self, b: T) {
        for d in 0..3 {
            self.c[d].axpby(grid, a, &x.c[d], b);
        }
    }
    fn assign(&mut self, other: &Self) {
        self.copy_from(other);
    }
    fn zeros_like(grid: &Grid<T>) -> Self {
        VectorField::zeros(grid)
    }
}

/// Sum of `f(value)` over the interior of a field, reproducible.
pub fn interior_sum_of<T: Real>(grid: &Grid<T>, a: &Field<T>, f: impl Fn(T) -> T + Sync) -> T {
    reduce(grid, &a.data, &a.data, |x, _| f(x))
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
}
