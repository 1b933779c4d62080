//! Shared machinery of the diagnostics: reproducible sums over cells, input checks, and cell
//! positions relative to a point with periodic unwrapping.

use crate::fluid::linalg::CHUNKS;
use crate::grid::{Field, Grid, VectorField};
use crate::{Error, Real, Result};
use rayon::prelude::*;

/// Folds `cell(acc, idx, [i, j, k])` over the interior cells, in [`CHUNKS`] fixed blocks of
/// x-lines (each block in order), then combines the blocks in order with `combine`: the result
/// does not depend on the number of threads.
pub(crate) fn reduce_cells<T: Real, A: Clone + Send + Sync>(
    grid: &Grid<T>,
    zero: A,
    cell: impl Fn(&mut A, usize, [usize; 3]) + Sync,
    combine: impl Fn(&mut A, &A),
) -> A {
    let [nx, ny, nz] = grid.n();
    let rows = ny * nz;
    // Keep a few thousand cells per rayon task, so small grids run on one thread.
    let min_chunks = (8192 / (nx * rows / CHUNKS).max(1)).max(1);
    let blocks: Vec<A> = (0..CHUNKS)
        .into_par_iter()
        .with_min_len(min_chunks)
        .map(|c| {
            let mut acc = zero.clone();
            for r in c * rows / CHUNKS..(c + 1) * rows / CHUNKS {
                let (j, k) = (r % ny, r / ny);
                let base = grid.idx_u(0, j, k);
                for i in 0..nx {
                    cell(&mut acc, base + i, [i, j, k]);
                }
            }
            acc
        })
        .collect();
    let mut total = zero;
    for b in &blocks {
        combine(&mut total, b);
    }
    total
}

/// [`reduce_cells`] for a fixed number of sums: `cell` returns the terms of one cell.
pub(crate) fn sum_cells<T: Real, const K: usize>(
    grid: &Grid<T>,
    cell: impl Fn(usize, [usize; 3]) -> [f64; K] + Sync,
) -> [f64; K] {
    reduce_cells(
        grid,
        [0.0; K],
        |acc: &mut [f64; K], idx, ijk| {
            let t = cell(idx, ijk);
            for (a, x) in acc.iter_mut().zip(t) {
                *a += x;
            }
        },
        |acc, b| {
            for (a, x) in acc.iter_mut().zip(b) {
                *a += x;
            }
        },
    )
}

/// Checks that `f` is stored on `grid`.
pub(crate) fn check_field<T: Real>(grid: &Grid<T>, name: &'static str, f: &Field<T>) -> Result<()> {
    if f.data.len() != grid.len() {
        return Err(Error::invalid(
            name,
            format!("a field of {} values", f.data.len()),
            "a field on this grid (grid.len() values, ghosts included)",
        ));
    }
    Ok(())
}

/// Checks the three components of a face vector field.
pub(crate) fn check_vector<T: Real>(grid: &Grid<T>, name: &'static str, v: &VectorField<T>) -> Result<()> {
    v.c.iter().try_for_each(|c| check_field(grid, name, c))
}

/// The error for a non-finite result: the first non-finite interior value among `fields`, or,
/// if they are all finite (an overflow), the first cell.
pub(crate) fn non_finite<T: Real>(grid: &Grid<T>, fields: &[(&'static str, &Field<T>)]) -> Error {
    for &(name, f) in fields {
        if let Some(cell) = f.first_non_finite(grid) {
            return Error::NonFinite { field: name, cell };
        }
    }
    Error::NonFinite { field: fields.first().map_or("result", |f| f.0), cell: [0, 0, 0] }
}

/// `Ok(x)` if every value is finite, else the error of [`non_finite`].
pub(crate) fn finite_or<T: Real, const K: usize>(
    x: [f64; K],
    grid: &Grid<T>,
    fields: &[(&'static str, &Field<T>)],
) -> Result<[f64; K]> {
    if x.iter().all(|v| v.is_finite()) { Ok(x) } else { Err(non_finite(grid, fields)) }
}

/// Checks a point given by the caller (finite coordinates).
pub(crate) fn check_point(name: &'static str, p: [f64; 3]) -> Result<()> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid(name, format!("{p:?}"), "finite coordinates"))
    }
}

/// Displacement `x - p` along one axis, wrapped into `[-L/2, L/2)` when the axis is periodic.
pub(crate) struct AxisFrame {
    lower: f64,
    h: f64,
    p: f64,
    /// Period, or `None` on a wall axis.
    period: Option<f64>,
}

impl AxisFrame {
    pub(crate) fn new<T: Real>(grid: &Grid<T>, axis: usize, p: f64) -> Self {
        let lower = grid.lower()[axis].f64();
        let len = grid.upper()[axis].f64() - lower;
        AxisFrame { lower, h: grid.h()[axis].f64(), p, period: grid.is_periodic(axis).then_some(len) }
    }

    /// Wraps a displacement along a periodic axis into `[-L/2, L/2)`.
    #[inline]
    pub(crate) fn wrap(&self, dx: f64) -> f64 {
        match self.period {
            Some(l) => dx - l * (dx / l + 0.5).floor(),
            None => dx,
        }
    }

    /// Displacement of the centre of cell `i` (any integer) from the reference point.
    #[inline]
    pub(crate) fn cell(&self, i: isize) -> f64 {
        self.wrap(self.lower + (i as f64 + 0.5) * self.h - self.p)
    }

    /// The displacements of the interior cell centres, `0..n`.
    pub(crate) fn cells(&self, n: usize) -> Vec<f64> {
        (0..n as isize).map(|i| self.cell(i)).collect()
    }

    /// Maps `p + dx` back into the box along a periodic axis (unchanged on a wall axis).
    pub(crate) fn absolute(&self, dx: f64) -> f64 {
        match self.period {
            Some(l) => self.lower + (self.p + dx - self.lower).rem_euclid(l),
            None => self.p + dx,
        }
    }
}

/// The frames of the three axes about the point `p`.
pub(crate) fn frames<T: Real>(grid: &Grid<T>, p: [f64; 3]) -> [AxisFrame; 3] {
    std::array::from_fn(|d| AxisFrame::new(grid, d, p[d]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_sums_are_exact_on_integers_and_frames_wrap() {
        let g = Grid::<f64>::periodic([5, 7, 4], [0.0; 3], [1.0; 3]).unwrap();
        let [s, c] = sum_cells(&g, |_, [i, j, k]| [(i + 10 * j + 100 * k) as f64, 1.0]);
        assert_eq!(c, 140.0);
        // sum i = 10 * 28, sum 10 j = 10 * 21 * 20, sum 100 k = 100 * 6 * 35.
        assert_eq!(s, 280.0 + 4200.0 + 21000.0);
        let f = AxisFrame::new(&g, 0, 0.95);
        assert!((f.cell(0) - 0.15).abs() < 1e-12);
        assert!((f.cell(4) + 0.05).abs() < 1e-12);
        assert!((f.absolute(0.1) - 0.05).abs() < 1e-12);
    }
}
