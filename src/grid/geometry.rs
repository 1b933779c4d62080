//! [`Grid`]: cells, spacing, origin, ghost layers and index arithmetic.

use super::Boundary;
use crate::{Error, Real, Result};

/// Ghost layers on every side of every field: enough for the widest stencil of the crate (MTHINC
/// reconstruction of an upwind cell with Youngs normals, third-order upwind fluxes, and the third
/// derivatives of `phi` in the bending force).
pub const GHOST: usize = 3;

/// Smallest number of cells allowed along a non-trivial axis.
const MIN_CELLS: usize = 4;

/// A uniform Cartesian grid with staggered storage (see the [module docs](super)).
///
/// ```
/// use eulermembrane::grid::{Boundary, Grid};
///
/// // A channel: periodic in x and z, no-slip walls at y = 0 and y = 1.
/// let mut bc = [[Boundary::Periodic; 2]; 3];
/// bc[1] = [Boundary::wall(), Boundary::wall()];
/// let g = Grid::<f64>::new([32, 16, 8], [0.0; 3], [2.0, 1.0, 0.5], bc)?;
/// assert_eq!(g.h(), [0.0625; 3]);
/// assert!(g.is_periodic(0) && !g.is_periodic(1));
/// assert_eq!(g.cells().count(), 32 * 16 * 8);
/// // A cell count that cannot hold the stencils is refused, naming the parameter.
/// assert!(Grid::<f64>::periodic([2, 16, 16], [0.0; 3], [1.0; 3]).is_err());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Grid<T> {
    pub(super) n: [usize; 3],
    pub(super) lower: [T; 3],
    pub(super) upper: [T; 3],
    h: [T; 3],
    bc: [[Boundary<T>; 2]; 3],
    pub(super) dims: [usize; 3],
    seam: [bool; 3],
    /// Where this grid is one part of a decomposed grid ([`Grid::split`]).
    pub(super) part: Option<super::decomposition::Part>,
}

const AXIS_NAMES: [&str; 3] = ["cells[0]", "cells[1]", "cells[2]"];

impl<T: Real> Grid<T> {
    /// A grid of `cells` cells over the box `[lower, upper]`, with boundary conditions
    /// `bc[axis] = [lower side, upper side]`.
    ///
    /// Errors: an axis with fewer than 4 cells (1 cell is allowed on a periodic axis, for 2D), so
    /// many cells that a field cannot be addressed, an empty or non-finite box (or one so small
    /// that the spacing underflows), a periodic side paired with a wall, a wall whose velocity
    /// has a normal component.
    ///
    /// ```
    /// use eulermembrane::grid::{Boundary, Grid};
    /// // A 2D periodic unit square, 32 x 32 cells.
    /// let g = Grid::<f64>::new([32, 32, 1], [0.0; 3], [1.0, 1.0, 1.0 / 32.0],
    ///                          [[Boundary::Periodic; 2]; 3]).unwrap();
    /// assert_eq!(g.h()[0], 1.0 / 32.0);
    /// ```
    pub fn new(cells: [usize; 3], lower: [T; 3], upper: [T; 3], bc: [[Boundary<T>; 2]; 3]) -> Result<Self> {
        let mut h = [T::one(); 3];
        for d in 0..3 {
            let periodic = bc[d][0].is_periodic();
            if periodic != bc[d][1].is_periodic() {
                return Err(Error::invalid(
                    ["bc[0]", "bc[1]", "bc[2]"][d],
                    "one periodic side and one wall",
                    "both sides periodic or both sides walls",
                ));
            }
            let min = if periodic { 1 } else { MIN_CELLS };
            if cells[d] < min || (cells[d] > 1 && cells[d] < MIN_CELLS) {
                return Err(Error::invalid(
                    AXIS_NAMES[d],
                    cells[d],
                    "at least 4 cells (or exactly 1 along a periodic axis, for 2D)",
                ));
            }
            let len = upper[d] - lower[d];
            if !(len.is_finite() && lower[d].is_finite() && len > T::zero()) {
                return Err(Error::invalid(
                    ["upper[0] - lower[0]", "upper[1] - lower[1]", "upper[2] - lower[2]"][d],
                    len,
                    "a finite length > 0",
                ));
            }
            h[d] = len / T::from_usize(cells[d]).unwrap_or(T::one());
            if !(h[d] > T::zero() && h[d].is_finite()) {
                return Err(Error::invalid(
                    ["upper[0] - lower[0]", "upper[1] - lower[1]", "upper[2] - lower[2]"][d],
                    len,
                    "a length whose cell spacing is a finite number > 0",
                ));
            }
            for side in bc[d] {
                let v = side.velocity();
                if !v.iter().all(|x| x.is_finite()) || v[d] != T::zero() {
                    return Err(Error::invalid(
                        "Boundary::Wall velocity",
                        format!("{v:?} on axis {d}"),
                        "finite components with a zero component normal to the wall",
                    ));
                }
            }
        }
        let dims = cells.map(|c| c.saturating_add(2 * GHOST));
        let bytes = dims.iter().try_fold(std::mem::size_of::<T>(), |acc, &d| acc.checked_mul(d));
        if bytes.is_none_or(|b| b > isize::MAX as usize) {
            return Err(Error::invalid(
                "cells",
                format!("{cells:?}"),
                "cell counts whose field storage (with ghost layers) is addressable",
            ));
        }
        Ok(Grid { n: cells, lower, upper, h, bc, dims, seam: [false; 3], part: None })
    }

    /// The grid of a box of `size` whole cells of this grid whose cell 0 is this grid's cell
    /// `first` (unwrapped: it may lie outside `[0, n)` on a periodic axis), periodic where
    /// `ring[d]` or `segment[d]` (a part of a wall axis), else with this grid's boundaries; the
    /// spacing is this grid's, bit for bit.
    /// The caller (a [`Window`](super::Window)) has checked the sizes.
    pub(crate) fn sub_grid(
        &self,
        first: [isize; 3],
        size: [usize; 3],
        ring: [bool; 3],
        segment: [bool; 3],
    ) -> Self {
        let mut g = self.clone();
        for d in 0..3 {
            if ring[d] || segment[d] {
                let at = |c: isize| self.lower[d] + T::from_isize(c).unwrap_or(T::zero()) * self.h[d];
                g.lower[d] = at(first[d]);
                g.upper[d] = at(first[d] + size[d] as isize);
            }
            if ring[d] || segment[d] {
                g.bc[d] = [Boundary::Periodic; 2];
                g.seam[d] = true;
            }
        }
        g.n = size;
        g.dims = size.map(|c| c + 2 * GHOST);
        g
    }

    /// A fully periodic grid over `[lower, upper]`.
    pub fn periodic(cells: [usize; 3], lower: [T; 3], upper: [T; 3]) -> Result<Self> {
        Self::new(cells, lower, upper, [[Boundary::Periodic; 2]; 3])
    }

    /// Cells along each axis (interior, without ghosts).
    #[inline]
    pub fn n(&self) -> [usize; 3] {
        self.n
    }
    /// Spacing along each axis.
    #[inline]
    pub fn h(&self) -> [T; 3] {
        self.h
    }
    /// Lower corner of the domain.
    #[inline]
    pub fn lower(&self) -> [T; 3] {
        self.lower
    }
    /// Upper corner of the domain.
    #[inline]
    pub fn upper(&self) -> [T; 3] {
        self.upper
    }
    /// Boundary conditions `[lower, upper]` of an axis.
    #[inline]
    pub fn bc(&self, axis: usize) -> [Boundary<T>; 2] {
        self.bc[axis]
    }
    /// Whether `axis` is periodic.
    #[inline]
    pub fn is_periodic(&self, axis: usize) -> bool {
        self.bc[axis][0].is_periodic()
    }
    /// Whether each axis's periodic closure is a *seam*: the grid is a capsule box's own grid
    /// ([`Window::grid`](super::Window::grid)) and, along that axis, its two ends meet in the
    /// capsule's far field rather than in the flow. A field gathered into the box is the
    /// flow's in the box's cells, but the face past its last cell is the image of its first
    /// one, so a discrete divergence there is the box's, not the flow's: a transport leaves
    /// terms that are zero for a divergence-free flow (the compressibility term of (2.48)) out
    /// of the last cell along a seam axis. `[false; 3]` for every grid built by [`Grid::new`].
    #[inline]
    pub fn seams(&self) -> [bool; 3] {
        self.seam
    }
    /// Whether the grid is 2D (one cell along z).
    #[inline]
    pub fn is_2d(&self) -> bool {
        self.n[2] == 1
    }
    /// Total number of interior cells.
    #[inline]
    pub fn cell_count(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }
    /// Volume of one cell.
    #[inline]
    pub fn cell_volume(&self) -> T {
        self.h[0] * self.h[1] * self.h[2]
    }
    /// Padded dimensions (cells plus ghosts) of every stored field.
    #[inline]
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    /// Length of the storage of one field.
    #[inline]
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }
    /// Always false: a grid has at least one cell.
    #[inline]
    pub fn is_empty(&self) -> bool {
        false
    }
    /// Storage strides `[1, sy, sz]` of the x, y, z directions.
    #[inline]
    pub fn strides(&self) -> [usize; 3] {
        [1, self.dims[0], self.dims[0] * self.dims[1]]
    }
    /// Storage index of cell `(i, j, k)`; indices from `-GHOST` to `n + GHOST - 1` are valid.
    #[inline(always)]
    pub fn idx(&self, i: isize, j: isize, k: isize) -> usize {
        let g = GHOST as isize;
        ((i + g) + self.dims[0] as isize * ((j + g) + self.dims[1] as isize * (k + g))) as usize
    }
    /// Storage index of interior cell `(i, j, k)`.
    #[inline(always)]
    pub fn idx_u(&self, i: usize, j: usize, k: usize) -> usize {
        (i + GHOST) + self.dims[0] * ((j + GHOST) + self.dims[1] * (k + GHOST))
    }
    /// Centre of cell `(i, j, k)`.
    #[inline]
    pub fn cell_center(&self, i: isize, j: isize, k: isize) -> [T; 3] {
        let half = T::lit(0.5);
        let c = [i, j, k];
        std::array::from_fn(|d| self.lower[d] + (T::from_isize(c[d]).unwrap_or(T::zero()) + half) * self.h[d])
    }
    /// Position of the velocity unknown of component `axis` with index `(i, j, k)` (the centre
    /// of the lower face of cell `(i, j, k)` normal to `axis`).
    #[inline]
    pub fn face_center(&self, axis: usize, i: isize, j: isize, k: isize) -> [T; 3] {
        let mut x = self.cell_center(i, j, k);
        x[axis] -= T::lit(0.5) * self.h[axis];
        x
    }
    /// Whether `other` has the same cells, spacing and boundaries, wherever it lies (a box of
    /// cells moved by whole cells: kernels that use no absolute position run the same on both).
    pub fn same_cells(&self, other: &Grid<T>) -> bool {
        self.n == other.n && self.h == other.h && self.bc == other.bc
    }
    /// The axes that end in walls.
    pub fn wall_axes(&self) -> Vec<usize> {
        (0..3).filter(|&d| !self.is_periodic(d)).collect()
    }
    /// Iterator over all interior cells `(i, j, k)`, x fastest.
    pub fn cells(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        let [nx, ny, nz] = self.n;
        (0..nz).flat_map(move |k| (0..ny).flat_map(move |j| (0..nx).map(move |i| (i, j, k))))
    }
    /// Range of storage rows (x-lines) of the padded array that hold interior cells: row
    /// `r = (k + GHOST) * dims[1] + (j + GHOST)` starts at storage index `r * dims[0]`.
    /// Returns `(j, k)` of a row, or `None` for a ghost row.
    #[inline]
    pub fn row_jk(&self, row: usize) -> Option<(usize, usize)> {
        let j = row % self.dims[1];
        let k = row / self.dims[1];
        let g = GHOST;
        if j >= g && j < g + self.n[1] && k >= g && k < g + self.n[2] { Some((j - g, k - g)) } else { None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_input() {
        let p = [[Boundary::<f64>::Periodic; 2]; 3];
        assert!(Grid::new([3, 8, 8], [0.0; 3], [1.0; 3], p).is_err());
        assert!(Grid::new([8, 8, 8], [0.0; 3], [1.0, -1.0, 1.0], p).is_err());
        assert!(Grid::new([8, 8, 8], [0.0; 3], [1.0, f64::NAN, 1.0], p).is_err());
        let mut w = p;
        w[1] = [Boundary::Periodic, Boundary::wall()];
        assert!(Grid::new([8, 8, 8], [0.0; 3], [1.0; 3], w).is_err());
        w[1] = [Boundary::wall(), Boundary::Wall { velocity: [0.0, 1.0, 0.0] }];
        let e = Grid::new([8, 8, 8], [0.0; 3], [1.0; 3], w).unwrap_err();
        assert!(e.to_string().contains("normal"));
        w[1] = [Boundary::wall(); 2];
        assert!(Grid::new([8, 1, 8], [0.0; 3], [1.0; 3], w).is_err());
        assert!(Grid::new([8, 8, 1], [0.0; 3], [1.0; 3], w).is_ok());
    }

    #[test]
    fn index_math() {
        let g = Grid::<f64>::periodic([4, 5, 6], [0.0; 3], [1.0; 3]).unwrap();
        assert_eq!(g.idx(0, 0, 0), g.idx_u(0, 0, 0));
        assert_eq!(g.idx(1, 0, 0) - g.idx(0, 0, 0), 1);
        assert_eq!(g.idx(0, 1, 0) - g.idx(0, 0, 0), g.strides()[1]);
        assert_eq!(g.idx(-3, -3, -3), 0);
        assert_eq!(g.idx(6, 7, 8), g.len() - 1);
        let c = g.cell_center(0, 0, 0);
        assert!((c[0] - 0.125).abs() < 1e-15);
        let rows = (0..g.dims()[1] * g.dims()[2]).filter(|&r| g.row_jk(r).is_some()).count();
        assert_eq!(rows, 5 * 6);
    }
}
