//! Fields on the grid: [`Field`] (one scalar per cell or per face), [`VectorField`] (the
//! staggered velocity, or any face vector) and [`SymField`] (symmetric tensors at cell centres),
//! and the one routine that fills their ghost layers.
//!
//! Ghost filling is the only place where boundary conditions and neighbouring parts enter a
//! field: on a part of a decomposed grid ([`Grid::split`]) the ghosts along the split axis are
//! the neighbours' cells, received through the grid's [`Exchange`](super::Exchange).

use super::{Boundary, GHOST, Grid};
use crate::Real;
use crate::tensor::SYM_PAIRS;

/// One scalar per cell (or per face of one orientation), with ghost layers.
///
/// ```
/// use eulermembrane::grid::{Field, Grid};
///
/// let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3])?;
/// // x at every cell centre, ghosts included; ghosts then made periodic copies.
/// let mut f = Field::from_cell_fn(&g, |x| x[0]);
/// f.fill_ghosts(&g);
/// assert_eq!(f.at(&g, -1, 0, 0), f.at(&g, 7, 0, 0)); // the ghost left of cell 0 is cell 7
/// assert!((f.interior_sum(&g) - 512.0 * 0.5).abs() < 1e-12); // mean of x over the box
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Field<T> {
    /// Storage, x fastest, `grid.len()` values; index with [`Grid::idx`].
    pub(crate) data: Vec<T>,
}

/// How a ghost layer is filled on one side of one axis.
#[derive(Debug, Clone, Copy)]
enum Side<T> {
    Periodic,
    /// The neighbouring part's cells (the split axis of a decomposed grid).
    Neighbour,
    /// Cell-centred value reflected about the wall: `ghost = offset + sign * mirror`.
    Cell {
        sign: T,
        offset: T,
    },
    /// Face value on the wall set to `value`, ghosts reflected antisymmetrically about it.
    Face {
        value: T,
    },
}

impl<T: Real> Field<T> {
    /// A field of zeros on `grid`.
    pub fn zeros(grid: &Grid<T>) -> Self {
        Field { data: vec![T::zero(); grid.len()] }
    }

    /// A cell-centred field sampled at cell centres (interior and ghosts) from `f(x)`.
    pub fn from_cell_fn(grid: &Grid<T>, f: impl Fn([T; 3]) -> T) -> Self {
        let mut out = Self::zeros(grid);
        let g = GHOST as isize;
        let [dx, dy, dz] = grid.dims();
        for k in -g..dz as isize - g {
            for j in -g..dy as isize - g {
                for i in -g..dx as isize - g {
                    out.data[grid.idx(i, j, k)] = f(grid.cell_center(i, j, k));
                }
            }
        }
        out
    }

    /// Value at cell `(i, j, k)` (ghost indices allowed).
    ///
    /// # Panics
    ///
    /// If `grid.idx(i, j, k)` is outside the field's storage (an index beyond the ghost layers
    /// may instead read another cell).
    #[inline(always)]
    pub fn at(&self, grid: &Grid<T>, i: isize, j: isize, k: isize) -> T {
        self.data[grid.idx(i, j, k)]
    }

    /// Storage, ghosts included, x fastest, `grid.len()` values; index with [`Grid::idx`].
    pub fn values(&self) -> &[T] {
        &self.data
    }

    /// Storage to write, ghosts included, x fastest, `grid.len()` values; index with [`Grid::idx`].
    pub fn values_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Sets every value, ghosts included, to `v`.
    pub fn fill(&mut self, v: T) {
        self.data.iter_mut().for_each(|x| *x = v);
    }

    /// Copies `other` into `self`.
    pub fn copy_from(&mut self, other: &Self) {
        self.data.copy_from_slice(&other.data);
    }

    /// Fills the ghost layers of a cell-centred scalar: periodic copies, or a zero normal
    /// gradient (even reflection) at walls.
    pub fn fill_ghosts(&mut self, grid: &Grid<T>) {
        let even = Side::Cell { sign: T::one(), offset: T::zero() };
        for axis in 0..3 {
            let sides = side_pair(grid, axis, |_| even);
            fill_axis(&mut self.data, grid, axis, sides);
        }
    }

    /// Sum over interior cells in a fixed order (reproducible run to run).
    pub fn interior_sum(&self, grid: &Grid<T>) -> T {
        let mut total = T::zero();
        for (i, j, k) in grid.cells() {
            total += self.data[grid.idx_u(i, j, k)];
        }
        total
    }

    /// The first interior cell holding a NaN or infinity, if any. On a part of a decomposed
    /// grid the answer is the whole grid's, on every part: the cell (in the whole grid's
    /// indices) is the first of all parts'.
    pub fn first_non_finite(&self, grid: &Grid<T>) -> Option<[usize; 3]> {
        let local = grid.cells().find(|&(i, j, k)| !self.data[grid.idx_u(i, j, k)].is_finite());
        if !grid.is_split() {
            return local.map(|(i, j, k)| [i, j, k]);
        }
        // The first bad cell of all parts: the largest negated linear index of the whole grid.
        let (o, n) = (grid.offset(), grid.global_cells());
        let linear = local.map(|(i, j, k)| (i + o[0]) + n[0] * ((j + o[1]) + n[1] * (k + o[2])));
        let [m] =
            grid.max_over_parts([linear.map_or(-T::infinity(), |l| -T::from_usize(l).unwrap_or(T::zero()))]);
        (m > -T::infinity()).then(|| {
            let l = (-m).to_usize().unwrap_or(0);
            [l % n[0], (l / n[0]) % n[1], l / (n[0] * n[1])]
        })
    }
}

/// A staggered vector: component `d` on the lower faces normal to axis `d` (the velocity `v`,
/// a pressure gradient, a face force).
///
/// ```
/// use eulermembrane::grid::{Grid, VectorField};
///
/// let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3])?;
/// // A shear u = z sampled where each component lives: u on the x-faces, at cell-centre z.
/// let v = VectorField::from_fn(&g, |x| [x[2], 0.0, 0.0]);
/// assert_eq!(g.face_center(0, 2, 0, 3), [0.25, 0.0625, 0.4375]);
/// assert_eq!(v.c[0].at(&g, 2, 0, 3), 0.4375);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct VectorField<T> {
    /// Components `[u, v, w]`.
    pub c: [Field<T>; 3],
}

impl<T: Real> VectorField<T> {
    /// `Ok` if every component is a field of `grid`, else [`Error::InvalidParameter`](crate::Error)
    /// naming `name`.
    pub fn matches(&self, grid: &Grid<T>, name: &'static str) -> crate::Result<()> {
        if self.c.iter().any(|f| f.data.len() != grid.len()) {
            return Err(crate::Error::invalid(
                name,
                "a vector field of another grid",
                "a field of the step's grid",
            ));
        }
        Ok(())
    }

    /// Zero vector field.
    pub fn zeros(grid: &Grid<T>) -> Self {
        VectorField { c: std::array::from_fn(|_| Field::zeros(grid)) }
    }

    /// Samples `f(x)[d]` at the face positions of each component `d` (ghosts included).
    pub fn from_fn(grid: &Grid<T>, f: impl Fn([T; 3]) -> [T; 3]) -> Self {
        let mut out = Self::zeros(grid);
        let g = GHOST as isize;
        let [dx, dy, dz] = grid.dims();
        for d in 0..3 {
            for k in -g..dz as isize - g {
                for j in -g..dy as isize - g {
                    for i in -g..dx as isize - g {
                        out.c[d].data[grid.idx(i, j, k)] = f(grid.face_center(d, i, j, k))[d];
                    }
                }
            }
        }
        out
    }

    /// A velocity in the xy-plane, discretely divergence-free, from a stream function sampled
    /// on the cell edges parallel to z: `u = (psi(x_i, y_{j+1}) - psi(x_i, y_j)) / h_y`,
    /// `v = -(psi(x_{i+1}, y_j) - psi(x_i, y_j)) / h_x`, `w = 0`, where `x_i = lower_x + i h_x`,
    /// `y_j = lower_y + j h_y` and z is the cell centre. Ghosts are filled. Along a wall, `psi`
    /// must be constant (no flow through the wall), else the wall faces break the divergence.
    pub fn from_stream_function(grid: &Grid<T>, psi: impl Fn([T; 3]) -> T) -> Self {
        let (lo, h) = (grid.lower(), grid.h());
        let at = |i: isize, j: isize, z: T| {
            let x = lo[0] + T::from_isize(i).unwrap_or(T::zero()) * h[0];
            let y = lo[1] + T::from_isize(j).unwrap_or(T::zero()) * h[1];
            psi([x, y, z])
        };
        let mut v = Self::zeros(grid);
        for (i, j, k) in grid.cells() {
            let (i, j, k) = (i as isize, j as isize, k as isize);
            let id = grid.idx(i, j, k);
            let z = grid.cell_center(i, j, k)[2];
            let p = at(i, j, z);
            v.c[0].data[id] = (at(i, j + 1, z) - p) / h[1];
            v.c[1].data[id] = -(at(i + 1, j, z) - p) / h[0];
        }
        v.fill_ghosts(grid);
        v
    }

    /// Copies `other` into `self`.
    pub fn copy_from(&mut self, other: &Self) {
        for d in 0..3 {
            self.c[d].copy_from(&other.c[d]);
        }
    }

    /// Fills ghost layers as a velocity: periodic copies; at a wall, the normal component is set
    /// to zero on the wall face and reflected antisymmetrically, and each tangential component
    /// is reflected about the wall velocity (`ghost = 2 U_wall - mirror`, no slip).
    pub fn fill_ghosts(&mut self, grid: &Grid<T>) {
        self.fill_velocity_ghosts(grid, T::one());
    }

    /// Fills ghost layers as a velocity with walls at rest, whatever their velocity: the
    /// homogeneous closure used inside linear solvers (the wall motion enters their right-hand
    /// side instead).
    pub fn fill_ghosts_homogeneous(&mut self, grid: &Grid<T>) {
        self.fill_velocity_ghosts(grid, T::zero());
    }

    fn fill_velocity_ghosts(&mut self, grid: &Grid<T>, wall_scale: T) {
        let two = T::lit(2.0) * wall_scale;
        for (d, comp) in self.c.iter_mut().enumerate() {
            for axis in 0..3 {
                let sides = side_pair(grid, axis, |b: Boundary<T>| {
                    if axis == d {
                        Side::Face { value: T::zero() }
                    } else {
                        Side::Cell { sign: -T::one(), offset: two * b.velocity()[d] }
                    }
                });
                fill_axis(&mut comp.data, grid, axis, sides);
            }
        }
    }

    /// The first interior non-finite value: `(component, cell)`.
    pub fn first_non_finite(&self, grid: &Grid<T>) -> Option<(usize, [usize; 3])> {
        (0..3).find_map(|d| self.c[d].first_non_finite(grid).map(|c| (d, c)))
    }
}

/// A symmetric tensor per cell centre, six components in the order of [`crate::tensor`].
#[derive(Debug, Clone, PartialEq)]
pub struct SymField<T> {
    /// Components `(11, 22, 33, 12, 23, 31)`.
    pub c: [Field<T>; 6],
}

impl<T: Real> SymField<T> {
    /// Zero tensor field.
    pub fn zeros(grid: &Grid<T>) -> Self {
        SymField { c: std::array::from_fn(|_| Field::zeros(grid)) }
    }

    /// The tensor at storage index `idx`.
    ///
    /// # Panics
    ///
    /// If `idx` is not a storage index of every component (`idx` at least [`Grid::len`] of
    /// their grid).
    #[inline(always)]
    pub fn get(&self, idx: usize) -> [T; 6] {
        std::array::from_fn(|c| self.c[c].data[idx])
    }

    /// Stores tensor `a` at storage index `idx`.
    ///
    /// # Panics
    ///
    /// If `idx` is not a storage index of every component (`idx` at least [`Grid::len`] of
    /// their grid).
    #[inline(always)]
    pub fn set(&mut self, idx: usize, a: &[T; 6]) {
        for (comp, &x) in self.c.iter_mut().zip(a) {
            comp.data[idx] = x;
        }
    }

    /// Copies `other` into `self`.
    pub fn copy_from(&mut self, other: &Self) {
        for c in 0..6 {
            self.c[c].copy_from(&other.c[c]);
        }
    }

    /// Fills ghost layers: periodic copies, or the mirror image at a wall (components with
    /// exactly one index normal to the wall change sign).
    pub fn fill_ghosts(&mut self, grid: &Grid<T>) {
        for (c, comp) in self.c.iter_mut().enumerate() {
            let (a, b) = SYM_PAIRS[c];
            for axis in 0..3 {
                let odd = (a == axis) != (b == axis);
                let sign = if odd { -T::one() } else { T::one() };
                let sides = side_pair(grid, axis, |_| Side::Cell { sign, offset: T::zero() });
                fill_axis(&mut comp.data, grid, axis, sides);
            }
        }
    }
}

fn side_pair<T: Real>(grid: &Grid<T>, axis: usize, wall: impl Fn(Boundary<T>) -> Side<T>) -> [Side<T>; 2] {
    let bc = grid.bc(axis);
    if grid.is_split() && grid.part().is_some_and(|p| p.axis == axis) {
        return [Side::Neighbour; 2];
    }
    std::array::from_fn(|s| if bc[s].is_periodic() { Side::Periodic } else { wall(bc[s]) })
}

/// Fills the ghosts of `data` along the split axis of a part from its two neighbours: its first
/// [`GHOST`] layers go down (the lower part's upper ghosts), its last ones up, every line of
/// the padded array (so that edges and corners come out right, as in [`fill_axis`]).
fn exchange_axis<T: Real>(data: &mut [T], grid: &Grid<T>, axis: usize) {
    let Some(part) = grid.part() else { return };
    let dims = grid.dims();
    let st = grid.strides();
    let n = grid.n()[axis];
    let (a1, a2) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let lines = dims[a1] * dims[a2];
    let index =
        |line: usize, m: usize| (line % dims[a1]) * st[a1] + (line / dims[a1]) * st[a2] + m * st[axis];
    let pack = |from: usize| -> Vec<f64> {
        let mut buf = Vec::with_capacity(lines * GHOST);
        for line in 0..lines {
            buf.extend((from..from + GHOST).map(|m| data[index(line, m)].f64()));
        }
        buf
    };
    // Storage layers: ghosts 0..GHOST, interior GHOST..GHOST + n, ghosts above.
    let (to_lower, to_upper) = (pack(GHOST), pack(n));
    let (mut from_lower, mut from_upper) = (vec![0.0; to_lower.len()], vec![0.0; to_upper.len()]);
    let [lower, upper] = part.neighbours();
    part.exchange.swap(lower, upper, &to_lower, &to_upper, &mut from_lower, &mut from_upper);
    for line in 0..lines {
        for m in 0..GHOST {
            data[index(line, m)] = T::lit(from_lower[line * GHOST + m]);
            data[index(line, n + GHOST + m)] = T::lit(from_upper[line * GHOST + m]);
        }
    }
}

/// Fills the ghosts of `data` along `axis`, on every line of the padded array (so that edges and
/// corners come out right when the axes are filled one after the other).
fn fill_axis<T: Real>(data: &mut [T], grid: &Grid<T>, axis: usize, sides: [Side<T>; 2]) {
    if matches!(sides[0], Side::Neighbour) {
        exchange_axis(data, grid, axis);
        return;
    }
    let dims = grid.dims();
    let st = grid.strides();
    let n = grid.n()[axis] as isize;
    let g = GHOST as isize;
    let (a1, a2) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let s = st[axis] as isize;
    for q2 in 0..dims[a2] {
        for q1 in 0..dims[a1] {
            let base = (q1 * st[a1] + q2 * st[a2]) as isize + g * s;
            let at = |m: isize| (base + m * s) as usize;
            // Lower side.
            match sides[0] {
                Side::Neighbour => unreachable!("exchanged above"),
                Side::Periodic => {
                    for m in -g..0 {
                        data[at(m)] = data[at(m.rem_euclid(n))];
                    }
                }
                Side::Cell { sign, offset } => {
                    for m in 1..=g {
                        data[at(-m)] = offset + sign * data[at(m - 1)];
                    }
                }
                Side::Face { value } => {
                    data[at(0)] = value;
                    for m in 1..=g {
                        data[at(-m)] = value + value - data[at(m)];
                    }
                }
            }
            // Upper side.
            match sides[1] {
                Side::Neighbour => unreachable!("exchanged above"),
                Side::Periodic => {
                    for m in n..n + g {
                        data[at(m)] = data[at(m.rem_euclid(n))];
                    }
                }
                Side::Cell { sign, offset } => {
                    for m in 0..g {
                        data[at(n + m)] = offset + sign * data[at(n - 1 - m)];
                    }
                }
                Side::Face { value } => {
                    data[at(n)] = value;
                    for m in 1..g {
                        data[at(n + m)] = value + value - data[at(n - m)];
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel() -> Grid<f64> {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[1] = [Boundary::wall(), Boundary::Wall { velocity: [2.0, 0.0, 0.0] }];
        Grid::new([8, 6, 4], [0.0; 3], [1.0; 3], bc).unwrap()
    }

    #[test]
    fn periodic_ghosts_copy_interior() {
        let g = Grid::<f64>::periodic([5, 4, 1], [0.0; 3], [1.0; 3]).unwrap();
        let mut f = Field::from_cell_fn(&g, |x| x[0] + 10.0 * x[1]);
        f.fill_ghosts(&g);
        for k in -3..4 {
            for j in -3isize..7 {
                for i in -3isize..8 {
                    let (ii, jj) = (i.rem_euclid(5), j.rem_euclid(4));
                    assert_eq!(f.at(&g, i, j, k), f.at(&g, ii, jj, 0));
                }
            }
        }
    }

    #[test]
    fn stream_function_velocity_is_discretely_divergence_free() {
        // Walls at y = 0 and 1: psi must be constant along them (no flow through the walls).
        let g = channel();
        let tau = std::f64::consts::TAU;
        let v =
            VectorField::from_stream_function(&g, |x| (tau * x[0]).sin() * (tau * x[1]).sin() * (1.0 + x[2]));
        let mut div = Field::zeros(&g);
        crate::grid::ops::divergence(&g, &v, &mut div);
        for (i, j, k) in g.cells() {
            assert!(div.data[g.idx_u(i, j, k)].abs() < 1e-12);
        }
    }

    #[test]
    fn wall_ghosts_give_no_slip_and_zero_gradient() {
        let g = channel();
        let mut v = VectorField::from_fn(&g, |x| [x[1], x[0], x[2]]);
        v.fill_ghosts(&g);
        // Tangential u: the average across the wall equals the wall velocity.
        for i in 0..8 {
            let lo = 0.5 * (v.c[0].at(&g, i, -1, 1) + v.c[0].at(&g, i, 0, 1));
            let hi = 0.5 * (v.c[0].at(&g, i, 5, 1) + v.c[0].at(&g, i, 6, 1));
            assert!(lo.abs() < 1e-14 && (hi - 2.0).abs() < 1e-14);
        }
        // Normal v: zero on both wall faces.
        assert_eq!(v.c[1].at(&g, 3, 0, 1), 0.0);
        assert_eq!(v.c[1].at(&g, 3, 6, 1), 0.0);
        let mut p = Field::from_cell_fn(&g, |x| x[1]);
        p.fill_ghosts(&g);
        assert_eq!(p.at(&g, 2, -1, 0), p.at(&g, 2, 0, 0));
        assert_eq!(p.at(&g, 2, 6, 0), p.at(&g, 2, 5, 0));
    }
}
