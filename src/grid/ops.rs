//! Discrete operators of the staggered grid (second-order central differences).
//!
//! Names say where the result lives: `*_at_cell` at cell centres, `*_at_face` on the faces of one
//! axis, `*_at_node` at cell corners `(i-1/2, j-1/2, k-1/2)`, `*_at_edge` on the cell edges
//! parallel to the third axis. Pointwise helpers take a storage index (see [`Grid::idx`]) and
//! read neighbours through the grid strides; field-level versions loop over interior cells in
//! parallel (rayon over x-lines) and touch no ghost value of the output.

use super::{Field, Grid, VectorField};
use crate::Real;
use crate::tensor::{Mat3, Vec3};
use rayon::prelude::*;

/// Rows of `dx` values per rayon task, so that a task holds at least a few thousand values (small
/// grids then run on one thread instead of paying for synchronisation).
#[inline]
pub fn min_rows(dx: usize) -> usize {
    (8192 / dx.max(1)).max(1)
}

/// Sets `out[idx] = f(idx, i, j, k)` for every interior cell, in parallel over x-lines.
/// Ghost values of `out` are left untouched.
pub fn par_interior<T: Real>(
    grid: &Grid<T>,
    out: &mut [T],
    f: impl Fn(usize, usize, usize, usize) -> T + Sync,
) {
    par_interior_update(grid, out, |idx, i, j, k, _| f(idx, i, j, k));
}

/// Replaces `out[idx]` by `f(idx, i, j, k, out[idx])` for every interior cell, in parallel.
pub fn par_interior_update<T: Real>(
    grid: &Grid<T>,
    out: &mut [T],
    f: impl Fn(usize, usize, usize, usize, T) -> T + Sync,
) {
    let nx = grid.n()[0];
    let dx = grid.dims()[0];
    let g = super::GHOST;
    out.par_chunks_mut(dx).with_min_len(min_rows(dx)).enumerate().for_each(|(row, line)| {
        if let Some((j, k)) = grid.row_jk(row) {
            let base = row * dx;
            for i in 0..nx {
                line[g + i] = f(base + g + i, i, j, k, line[g + i]);
            }
        }
    });
}

/// Divergence of a staggered vector at cell `idx`: `sum_d (v_d[i + e_d] - v_d[i]) / h_d`.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `v` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn divergence_at_cell<T: Real>(grid: &Grid<T>, v: &VectorField<T>, idx: usize) -> T {
    let st = grid.strides();
    let h = grid.h();
    let mut s = T::zero();
    for d in 0..3 {
        let c = &v.c[d].data;
        s += (c[idx + st[d]] - c[idx]) / h[d];
    }
    s
}

/// Divergence of `v` at every interior cell into `out`.
pub fn divergence<T: Real>(grid: &Grid<T>, v: &VectorField<T>, out: &mut Field<T>) {
    par_interior(grid, &mut out.data, |idx, _, _, _| divergence_at_cell(grid, v, idx));
}

/// Gradient of a cell-centred scalar on the lower face of cell `idx` normal to `axis`.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `p` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn gradient_at_face<T: Real>(grid: &Grid<T>, p: &Field<T>, axis: usize, idx: usize) -> T {
    let s = grid.strides()[axis];
    (p.data[idx] - p.data[idx - s]) / grid.h()[axis]
}

/// Gradient of `p` (ghosts filled) on every interior face; on a wall axis the wall faces get
/// zero (no flux through walls).
pub fn gradient<T: Real>(grid: &Grid<T>, p: &Field<T>, out: &mut VectorField<T>) {
    for d in 0..3 {
        let wall = !grid.is_periodic(d);
        par_interior(grid, &mut out.c[d].data, |idx, i, j, k| {
            if wall && [i, j, k][d] == 0 { T::zero() } else { gradient_at_face(grid, p, d, idx) }
        });
    }
}

/// Velocity-gradient tensor at the centre of cell `idx`: `g[i][j] = d v_j / d x_i`.
///
/// Diagonal terms are the compact differences across the cell; off-diagonal terms are central
/// differences over two cells of the component averaged to the cell centre. Needs one ghost layer.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `v` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn grad_v_at_cell<T: Real>(grid: &Grid<T>, v: &VectorField<T>, idx: usize) -> Mat3<T> {
    let st = grid.strides();
    let h = grid.h();
    let quarter = T::lit(0.25);
    let mut g = [[T::zero(); 3]; 3];
    for j in 0..3 {
        let c = &v.c[j].data;
        let sj = st[j];
        for i in 0..3 {
            g[i][j] = if i == j {
                (c[idx + sj] - c[idx]) / h[i]
            } else {
                let si = st[i];
                // Average to the cell centre along j, difference along i.
                let up = c[idx + si] + c[idx + si + sj];
                let dn = c[idx - si] + c[idx - si + sj];
                quarter * (up - dn) / h[i]
            };
        }
    }
    g
}

/// The vector of three cell-centred fields (e.g. the unit normal) at cell `idx`.
///
/// # Panics
///
/// If `idx` is not a storage index of every field of `f` (`idx` at least [`Grid::len`] of
/// their grid).
#[inline(always)]
pub fn cell_vector<T: Real>(f: &[Field<T>; 3], idx: usize) -> Vec3<T> {
    [f[0].data[idx], f[1].data[idx], f[2].data[idx]]
}

/// Gradient of three cell-centred fields at the centre of cell `idx` by central differences:
/// `g[i][j] = d f_j / d x_i`. Needs one ghost layer.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `f` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn grad_cell_vector_at<T: Real>(grid: &Grid<T>, f: &[Field<T>; 3], idx: usize) -> Mat3<T> {
    let st = grid.strides();
    let h = grid.h();
    let mut g = [[T::zero(); 3]; 3];
    for i in 0..3 {
        let ih = T::lit(0.5) / h[i];
        for j in 0..3 {
            let d = &f[j].data;
            g[i][j] = (d[idx + st[i]] - d[idx - st[i]]) * ih;
        }
    }
    g
}

/// Average of a cell-centred field on the lower face of cell `idx` normal to `axis`.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `f` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn cell_to_face<T: Real>(grid: &Grid<T>, f: &Field<T>, axis: usize, idx: usize) -> T {
    T::lit(0.5) * (f.data[idx] + f.data[idx - grid.strides()[axis]])
}

/// Average of a cell-centred field on the edge at the lower corner of cell `idx` in the plane
/// of axes `a` and `b` (the edge parallel to the third axis), from its four neighbouring cells.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `f` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn cell_to_edge<T: Real>(grid: &Grid<T>, f: &Field<T>, a: usize, b: usize, idx: usize) -> T {
    let st = grid.strides();
    let (sa, sb) = (st[a], st[b]);
    T::lit(0.25) * (f.data[idx] + f.data[idx - sa] + f.data[idx - sb] + f.data[idx - sa - sb])
}

/// Average of a cell-centred field at the lower node `(i-1/2, j-1/2, k-1/2)` of cell `idx`, from
/// its eight neighbouring cells (Sec. 2.2.2).
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `f` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn cell_to_node<T: Real>(grid: &Grid<T>, f: &Field<T>, idx: usize) -> T {
    let [_, sy, sz] = grid.strides();
    let d = &f.data;
    T::lit(0.125)
        * (d[idx]
            + d[idx - 1]
            + d[idx - sy]
            + d[idx - 1 - sy]
            + d[idx - sz]
            + d[idx - 1 - sz]
            + d[idx - sy - sz]
            + d[idx - 1 - sy - sz])
}

/// Staggered velocity averaged to the centre of cell `idx`.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `v` (never for an interior
/// cell of a field of `grid`).
#[inline(always)]
pub fn velocity_at_cell<T: Real>(grid: &Grid<T>, v: &VectorField<T>, idx: usize) -> [T; 3] {
    let st = grid.strides();
    std::array::from_fn(|d| T::lit(0.5) * (v.c[d].data[idx] + v.c[d].data[idx + st[d]]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Boundary;

    #[test]
    fn divergence_of_gradient_is_the_7_point_laplacian() {
        let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
        let tau = std::f64::consts::TAU;
        let mut p = Field::from_cell_fn(&g, |x| (tau * x[0]).sin() * (tau * x[2]).cos());
        p.fill_ghosts(&g);
        let mut gp = VectorField::zeros(&g);
        gradient(&g, &p, &mut gp);
        gp.c.iter_mut().for_each(|c| c.fill_ghosts(&g));
        let mut lap = Field::zeros(&g);
        divergence(&g, &gp, &mut lap);
        // Eigenvalue of the 7-point Laplacian for this mode.
        let h = 1.0 / 8.0;
        let lam = -2.0 * (2.0 - 2.0 * (tau * h).cos()) / (h * h);
        for (i, j, k) in g.cells() {
            let id = g.idx_u(i, j, k);
            assert!((lap.data[id] - lam * p.data[id]).abs() < 1e-10);
        }
    }

    #[test]
    fn velocity_gradient_of_a_linear_field_is_exact() {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
        let g = Grid::<f64>::new([6, 6, 8], [0.0, 0.0, -1.0], [1.0, 1.0, 1.0], bc).unwrap();
        let mut v = VectorField::from_fn(&g, |x| [x[2], 0.0, 0.0]);
        v.fill_ghosts(&g);
        for (i, j, k) in g.cells() {
            let gv = grad_v_at_cell(&g, &v, g.idx_u(i, j, k));
            assert!((gv[2][0] - 1.0).abs() < 1e-12, "{gv:?}");
            assert!(gv[0][2].abs() < 1e-12 && gv[0][0].abs() < 1e-12);
        }
    }
}
