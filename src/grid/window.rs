//! [`Window`]: a box of whole cells of a grid, where one capsule keeps its fields.

use super::{Field, GHOST, Grid, SymField, VectorField};
use crate::{Error, Real, Result};
use std::ops::Range;

/// A box of whole cells of a grid, where one capsule keeps its fields.
///
/// A capsule's `phi` is 1 inside, 0 far outside and differs from 0 only within a few profile
/// widths of its membrane, so its fields need only a box of cells around it. A window is such
/// a box, aligned with the grid (the *whole grid*, whose flow it reads and whose forces and
/// mixture it adds to):
///
/// - along a periodic axis on which the box is shorter than the grid, the box is a *ring* of
///   `size` cells: its own grid ([`Window::grid`]) is periodic along that axis, with cell `b`
///   at the whole grid's cell `first + b` (unwrapped: a box may straddle the periodic seam,
///   and its positions then continue past the grid's upper side);
/// - along a wall axis on which the box is shorter than the grid, the box is a *segment* of
///   `size` cells between the walls, cell `b` at the grid's cell `first + b` with
///   `0 <= first <= n - size`, and a ring all the same: its own grid is periodic along that
///   axis (its two ends meet in the capsule's far field, as a ring's do; where a segment
///   touches a wall, the wall's face carries no flow and the capsule keeps its band the room's
///   cells away from it);
/// - along any other axis (a box as long as the grid) the box is the *whole axis*, with the
///   grid's own boundaries, cell for cell.
///
/// A box as large as the grid is the grid itself ([`Window::whole`]): gathering copies every
/// value, ghosts included, and adding back is adding field to field, bit for bit.
///
/// Values move between the two by [`Window::gather`] (the whole grid's values into the box,
/// ghosts included: on a ring axis a ghost is the box's own periodic image, as the box grid's
/// ghost filling would make it) and [`Window::add_to`] (the box's interior added to the whole
/// grid's cells). A ring's two ends meet in the box grid: what a capsule carries must be
/// negligible there (its margin), and is carried across the seam exactly as a periodic grid
/// carries it (nothing is lost). When the capsule moves, [`Window::shift`] moves the box by
/// whole cells and rolls its fields with it (no interpolation).
///
/// ```
/// use eulermembrane::grid::{Field, Grid, Window};
///
/// let g = Grid::<f64>::periodic([32, 32, 32], [0.0; 3], [1.0; 3])?;
/// let f = Field::from_cell_fn(&g, |x| (6.283185307179586 * x[0]).sin());
/// // A 12^3 box whose first cell is the grid's cell (-4, 10, 10): it straddles x = 0.
/// let w = Window::new(&g, [-4, 10, 10], [12, 12, 12])?;
/// let bg = w.grid(&g);
/// assert_eq!(bg.n(), [12, 12, 12]);
/// assert!((bg.lower()[0] + 0.125).abs() < 1e-15); // 4 cells left of x = 0
/// let mut b = Field::zeros(&bg);
/// w.gather(&g, &f, &bg, &mut b)?;
/// // Box cell (0, 0, 0) holds the grid's cell (28, 10, 10), the periodic image of (-4, 10, 10).
/// assert_eq!(b.at(&bg, 0, 0, 0), f.at(&g, 28, 10, 10));
/// // Adding the box back to a zero field puts its 12^3 cells where they came from.
/// let mut sum = Field::zeros(&g);
/// w.add_to(&bg, &b, &g, &mut sum)?;
/// assert_eq!(sum.at(&g, 28, 10, 10), f.at(&g, 28, 10, 10));
/// assert_eq!(sum.at(&g, 9, 10, 10), 0.0); // outside the box
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Window {
    /// Cells of the whole grid.
    n: [usize; 3],
    /// Cells of the box (`n[d]` on a whole axis).
    size: [usize; 3],
    /// The whole grid's (unwrapped) cell of box cell 0 (0 on a whole axis).
    first: [isize; 3],
    /// Whether the box is a ring (shorter than the grid, periodic) along each axis.
    ring: [bool; 3],
    /// Whether the box is a segment (shorter than the grid, a wall axis) along each axis.
    segment: [bool; 3],
    /// Per axis, the whole grid's storage coordinate (ghost offset included) of each box
    /// storage coordinate, ghosts included.
    map: [Vec<usize>; 3],
}

/// `Ok` if `f` is sized for `grid`, else an error naming `name`.
fn sized<T: Real>(f: &Field<T>, grid: &Grid<T>, name: &'static str) -> Result<()> {
    match f.data.len() == grid.len() {
        true => Ok(()),
        false => {
            Err(Error::invalid(name, format!("a field of {} values", f.data.len()), "a field of its grid"))
        }
    }
}

const SIZE_NAMES: [&str; 3] = ["size[0]", "size[1]", "size[2]"];
const FIRST_NAMES: [&str; 3] = ["first[0]", "first[1]", "first[2]"];

impl Window {
    /// The whole grid: every axis whole.
    pub fn whole<T: Real>(grid: &Grid<T>) -> Self {
        Self::build(grid.n(), [0; 3], grid.n(), [false; 3], [false; 3])
    }

    /// The box of `size` cells whose cell 0 is the grid's cell `first` (unwrapped on periodic
    /// axes: any integer; on wall axes `0 <= first <= n - size`). An axis where `size` is at
    /// least the grid's cell count is whole (`first` is then ignored there).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `size[d]` for a ring or segment of fewer than 4 cells,
    /// or `first[d]` for a segment that leaves the grid along a wall axis.
    pub fn new<T: Real>(grid: &Grid<T>, first: [isize; 3], size: [usize; 3]) -> Result<Self> {
        let n = grid.n();
        let mut ring = [false; 3];
        let mut segment = [false; 3];
        let (mut f, mut s) = (first, size);
        for d in 0..3 {
            if size[d] >= n[d] {
                (f[d], s[d]) = (0, n[d]);
                continue;
            }
            if size[d] < 4 {
                return Err(Error::invalid(SIZE_NAMES[d], size[d], "at least 4 cells"));
            }
            if grid.is_periodic(d) {
                ring[d] = true;
                continue;
            }
            let last = (n[d] - size[d]) as isize;
            if !(0..=last).contains(&first[d]) {
                return Err(Error::invalid(
                    FIRST_NAMES[d],
                    format!(
                        "{} for a box of {} cells along wall axis {d} of {} cells (at most {last})",
                        first[d], size[d], n[d]
                    ),
                    "a first cell from 0 to the grid's cells less the box's (a box ends at the walls)",
                ));
            }
            segment[d] = true;
        }
        Ok(Self::build(n, f, s, ring, segment))
    }

    /// The smallest box that holds the cells whose centres lie within `[lo, hi]` (positions of
    /// the grid, unwrapped) and `margin` cells around them, whole wherever it would be at least
    /// as long as the grid and along a wall axis where it would reach past a wall.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `lo` or `hi` unless finite with `lo <= hi`.
    pub fn around<T: Real>(grid: &Grid<T>, lo: [f64; 3], hi: [f64; 3], margin: usize) -> Result<Self> {
        let (lower, h) = (grid.lower(), grid.h());
        let mut first = [0isize; 3];
        let mut size = [0usize; 3];
        for d in 0..3 {
            if !(lo[d].is_finite() && hi[d].is_finite() && lo[d] <= hi[d]) {
                return Err(Error::invalid(
                    "lo, hi",
                    format!("{lo:?}, {hi:?}"),
                    "finite corners with lo <= hi",
                ));
            }
            let cell = |x: f64| (x - lower[d].f64()) / h[d].f64() - 0.5;
            let (a, b) = (cell(lo[d]).floor() as isize, cell(hi[d]).ceil() as isize);
            first[d] = a - margin as isize;
            size[d] = ((b - a + 1) as usize + 2 * margin).max(4);
            // Along a wall axis a box that would reach past a wall is the whole axis.
            let n = grid.n()[d];
            if !grid.is_periodic(d) && (first[d] < 0 || first[d] + size[d] as isize > n as isize) {
                (first[d], size[d]) = (0, n);
            }
        }
        Self::new(grid, first, size)
    }

    fn build(
        n: [usize; 3],
        first: [isize; 3],
        size: [usize; 3],
        ring: [bool; 3],
        segment: [bool; 3],
    ) -> Self {
        let g = GHOST as isize;
        let map = std::array::from_fn(|d| {
            (-g..size[d] as isize + g)
                .map(|b| match ring[d] || segment[d] {
                    true => {
                        let cell = first[d] + b.rem_euclid(size[d] as isize);
                        (cell.rem_euclid(n[d] as isize) + g) as usize
                    }
                    false => (b + g) as usize,
                })
                .collect()
        });
        Window { n, size, first, ring, segment, map }
    }

    /// Cells of the box along each axis.
    pub fn size(&self) -> [usize; 3] {
        self.size
    }

    /// The whole grid's (unwrapped) cell of box cell 0.
    pub fn first(&self) -> [isize; 3] {
        self.first
    }

    /// Whether the box is a ring (a periodic axis it does not span) along each axis.
    pub fn rings(&self) -> [bool; 3] {
        self.ring
    }

    /// Whether the box is a segment (a wall axis it does not span) along each axis.
    pub fn segments(&self) -> [bool; 3] {
        self.segment
    }

    /// Whether the box can move along each axis: a ring or a segment.
    pub fn movable(&self) -> [bool; 3] {
        std::array::from_fn(|d| self.ring[d] || self.segment[d])
    }

    /// Whether the box is the whole grid.
    pub fn is_whole(&self) -> bool {
        self.ring == [false; 3] && self.segment == [false; 3]
    }

    /// Number of cells of the box (its share of a field's storage, without ghosts).
    pub fn cell_count(&self) -> usize {
        self.size.iter().product()
    }

    /// The box's own grid: this window's cells of `grid`, periodic along its ring axes, with
    /// `grid`'s spacing and positions (unwrapped).
    pub fn grid<T: Real>(&self, grid: &Grid<T>) -> Grid<T> {
        grid.sub_grid(self.first, self.size, self.ring, self.segment)
    }

    /// The whole grid's cell (wrapped into `[0, n)` on periodic axes) of box cell `b` (ghosts
    /// allowed, `-GHOST <= b < size + GHOST`).
    ///
    /// # Panics
    /// If `b` lies outside the box's storage.
    pub fn grid_cell(&self, b: [isize; 3]) -> [isize; 3] {
        std::array::from_fn(|d| self.map[d][(b[d] + GHOST as isize) as usize] as isize - GHOST as isize)
    }

    /// `Ok` if `grid` is this window's whole grid and `boxed` its box grid.
    fn check<T: Real>(&self, grid: &Grid<T>, boxed: &Grid<T>) -> Result<()> {
        self.check_whole(grid)?;
        if boxed.n() != self.size {
            return Err(Error::invalid(
                "box grid",
                format!("{:?} cells, the window has {:?}", boxed.n(), self.size),
                "the window's own grid (Window::grid)",
            ));
        }
        Ok(())
    }

    /// `Ok` if `grid` is this window's whole grid.
    fn check_whole<T: Real>(&self, grid: &Grid<T>) -> Result<()> {
        match grid.n() == self.n {
            true => Ok(()),
            false => Err(Error::invalid(
                "grid",
                format!("{:?} cells, the window's grid has {:?}", grid.n(), self.n),
                "the grid the window was made on",
            )),
        }
    }

    /// Every storage coordinate of the box, ghosts included.
    fn storage(&self) -> [Range<usize>; 3] {
        std::array::from_fn(|d| 0..self.map[d].len())
    }

    /// The interior storage coordinates of the box.
    fn interior(&self) -> [Range<usize>; 3] {
        std::array::from_fn(|d| GHOST..GHOST + self.size[d])
    }

    /// Calls `f(grid row start, box row start, box x coordinates, grid x coordinates)` for each
    /// x-row of the box storage coordinates `range`.
    fn rows<T: Real>(
        &self,
        grid: &Grid<T>,
        boxed: &Grid<T>,
        range: &[Range<usize>; 3],
        mut f: impl FnMut(usize, usize, &[usize]),
    ) {
        let (gs, bs) = (grid.strides(), boxed.strides());
        let [mx, my, mz] = [0, 1, 2].map(|d| &self.map[d][range[d].clone()]);
        for (bk, &gk) in range[2].clone().zip(mz) {
            for (bj, &gj) in range[1].clone().zip(my) {
                f(gk * gs[2] + gj * gs[1], bk * bs[2] + bj * bs[1] + range[0].start, mx);
            }
        }
    }

    /// Copies `src` (whole grid) into every storage cell of `dst` (box), ghosts included.
    fn gather_data<T: Real>(&self, grid: &Grid<T>, boxed: &Grid<T>, src: &[T], dst: &mut [T]) {
        let ring = self.ring[0] || self.segment[0];
        self.rows(grid, boxed, &self.storage(), |grow, brow, mx| {
            let out = &mut dst[brow..brow + mx.len()];
            if ring {
                out.iter_mut().zip(mx).for_each(|(o, &gi)| *o = src[grow + gi]);
            } else {
                out.copy_from_slice(&src[grow + mx[0]..grow + mx[0] + mx.len()]);
            }
        });
    }

    /// Adds the interior of `src` (box) to `dst` (whole grid).
    fn add_data<T: Real>(&self, grid: &Grid<T>, boxed: &Grid<T>, src: &[T], dst: &mut [T]) {
        self.rows(grid, boxed, &self.interior(), |grow, brow, mx| {
            for (bi, &gi) in mx.iter().enumerate() {
                dst[grow + gi] += src[brow + bi];
            }
        });
    }

    /// The whole grid's storage index (in `grid`, of `dims`) of the interior box cell `c`.
    #[inline]
    pub(crate) fn grid_index(&self, dims: [usize; 3], c: [u32; 3]) -> usize {
        let m = |d: usize| self.map[d][c[d] as usize + GHOST];
        m(0) + dims[0] * (m(1) + dims[1] * m(2))
    }

    /// Copies the values of `src` on `grid` into every storage cell of `dst` on the box grid
    /// `boxed` (ghosts included: on a ring axis the box's periodic image, elsewhere the grid's
    /// own ghosts, so the ghosts of `src` must be filled).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if `grid` or `boxed` is not this window's, or a field is not
    /// sized for its grid.
    pub fn gather<T: Real>(
        &self,
        grid: &Grid<T>,
        src: &Field<T>,
        boxed: &Grid<T>,
        dst: &mut Field<T>,
    ) -> Result<()> {
        self.check(grid, boxed)?;
        sized(src, grid, "src")?;
        sized(dst, boxed, "dst")?;
        self.gather_data(grid, boxed, &src.data, &mut dst.data);
        Ok(())
    }

    /// [`gather`](Self::gather) of each component of a staggered field (face `b` of the box at
    /// face `b` of the grid's cell it maps to).
    ///
    /// # Errors
    /// As [`gather`](Self::gather).
    pub fn gather_vector<T: Real>(
        &self,
        grid: &Grid<T>,
        src: &VectorField<T>,
        boxed: &Grid<T>,
        dst: &mut VectorField<T>,
    ) -> Result<()> {
        for (s, d) in src.c.iter().zip(dst.c.iter_mut()) {
            self.gather(grid, s, boxed, d)?;
        }
        Ok(())
    }

    /// Adds the interior cells of `src` on the box grid `boxed` to the cells of `dst` on
    /// `grid` they map to (each grid cell receives at most one box cell); the rest of `dst`,
    /// ghosts included, is left as it was.
    ///
    /// # Errors
    /// As [`gather`](Self::gather).
    pub fn add_to<T: Real>(
        &self,
        boxed: &Grid<T>,
        src: &Field<T>,
        grid: &Grid<T>,
        dst: &mut Field<T>,
    ) -> Result<()> {
        self.check(grid, boxed)?;
        sized(src, boxed, "src")?;
        sized(dst, grid, "dst")?;
        self.add_data(grid, boxed, &src.data, &mut dst.data);
        Ok(())
    }

    /// [`add_to`](Self::add_to) of each component of a staggered field.
    ///
    /// # Errors
    /// As [`gather`](Self::gather).
    pub fn add_vector_to<T: Real>(
        &self,
        boxed: &Grid<T>,
        src: &VectorField<T>,
        grid: &Grid<T>,
        dst: &mut VectorField<T>,
    ) -> Result<()> {
        for (s, d) in src.c.iter().zip(dst.c.iter_mut()) {
            self.add_to(boxed, s, grid, d)?;
        }
        Ok(())
    }

    /// Moves the box by `by` cells along ring or segment axis `axis` (the box grid then starts
    /// `by` cells further: make it anew with [`grid`](Self::grid), and [`roll`](Self::roll)
    /// every field the box holds). A whole axis does not move; a segment stays between the
    /// walls ([`clamp_shift`](Self::clamp_shift) gives the move it allows).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `axis` for an axis that is neither a ring nor a
    /// segment, or `by` for a segment moved beyond a wall.
    pub fn shift(&mut self, axis: usize, by: isize) -> Result<()> {
        if axis > 2 || !self.movable()[axis] {
            return Err(Error::invalid(
                "axis",
                axis,
                "a ring or segment axis of the window (an axis it does not span)",
            ));
        }
        if self.clamp_shift(axis, by) != by {
            return Err(Error::invalid(
                "by",
                format!(
                    "{by} cells along wall axis {axis} for a box whose first cell is {}",
                    self.first[axis]
                ),
                "a move that keeps the box between the walls (Window::clamp_shift)",
            ));
        }
        *self = Self::build(
            self.n,
            std::array::from_fn(|d| self.first[d] + if d == axis { by } else { 0 }),
            self.size,
            self.ring,
            self.segment,
        );
        Ok(())
    }

    /// The box grown by `lo[d]` cells below and `hi[d]` cells above along each ring or segment
    /// axis `d` (whole axes stay whole), holding this box's cells where they were: a ring or
    /// segment that would reach the grid's length, and a segment that would reach past a wall,
    /// becomes the whole axis (as [`around`](Self::around) makes it). Move the box's values
    /// into the grown box's grid with [`transfer_slice`](Self::transfer_slice).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `grid` for a grid the window was not made on.
    pub fn grown<T: Real>(&self, grid: &Grid<T>, lo: [usize; 3], hi: [usize; 3]) -> Result<Self> {
        self.check_whole(grid)?;
        let mut first = self.first;
        let mut size = self.size;
        for d in 0..3 {
            if !self.movable()[d] {
                continue;
            }
            first[d] -= lo[d] as isize;
            size[d] += lo[d] + hi[d];
            if self.segment[d] && (first[d] < 0 || first[d] + size[d] as isize > self.n[d] as isize) {
                (first[d], size[d]) = (0, self.n[d]);
            }
        }
        Self::new(grid, first, size)
    }

    /// The storage index on `to_grid` (the grid of window `to`) of the storage index `idx` of an
    /// interior cell of this box's grid `grid`: the same cell of the whole grid (`None` where
    /// `to` does not hold it, or `idx` is not an interior cell).
    pub fn transfer_index<T: Real>(
        &self,
        grid: &Grid<T>,
        to: &Window,
        to_grid: &Grid<T>,
        idx: usize,
    ) -> Option<usize> {
        let (dims, to_dims) = (grid.dims(), to_grid.dims());
        let s = [idx % dims[0], (idx / dims[0]) % dims[1], idx / (dims[0] * dims[1])];
        let mut t = [0usize; 3];
        for d in 0..3 {
            let b = s[d] as isize - GHOST as isize;
            if b < 0 || b >= self.size[d] as isize {
                return None;
            }
            // The whole grid's cell, unwrapped on a ring or segment.
            let u = if self.movable()[d] { self.first[d] + b } else { b };
            let n = self.n[d] as isize;
            let c = if to.movable()[d] { (u - to.first[d]).rem_euclid(n) } else { u.rem_euclid(n) };
            if c >= to.size[d] as isize {
                return None;
            }
            t[d] = c as usize + GHOST;
        }
        Some(t[0] + to_dims[0] * (t[1] + to_dims[1] * t[2]))
    }

    /// Copies per-cell storage `src` of this box's grid `grid` (`grid.len()` values, ghosts
    /// included) into `dst` on the grid `to_grid` of window `to`, cell for cell of the whole
    /// grid: every interior cell of this box that `to` holds; the rest of `dst` is left as it
    /// was (e.g. a field, or a transport's time history, moved into a grown box,
    /// [`InterfaceTransport::regrow`](crate::interface::advect::InterfaceTransport::regrow)).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `src` or `dst` for storage of another length than its
    /// grid's, or `to` for a window of another whole grid.
    pub fn transfer_slice<T: Real, V: Copy>(
        &self,
        grid: &Grid<T>,
        src: &[V],
        to: &Window,
        to_grid: &Grid<T>,
        dst: &mut [V],
    ) -> Result<()> {
        if to.n != self.n {
            return Err(Error::invalid(
                "to",
                format!("a window of a {:?} grid", to.n),
                "a window of the same grid",
            ));
        }
        if src.len() != grid.len() {
            return Err(Error::invalid(
                "src",
                format!("{} values", src.len()),
                "one value per storage cell of its grid",
            ));
        }
        if dst.len() != to_grid.len() {
            return Err(Error::invalid(
                "dst",
                format!("{} values", dst.len()),
                "one value per storage cell of its grid",
            ));
        }
        for (i, j, k) in grid.cells() {
            let idx = grid.idx_u(i, j, k);
            if let Some(t) = self.transfer_index(grid, to, to_grid, idx) {
                dst[t] = src[idx];
            }
        }
        Ok(())
    }

    /// The part of a move by `by` cells along `axis` that keeps a segment between the walls
    /// (`by` itself on a ring, 0 on a whole axis).
    pub fn clamp_shift(&self, axis: usize, by: isize) -> isize {
        match (self.ring.get(axis), self.segment.get(axis)) {
            (Some(true), _) => by,
            (_, Some(true)) => {
                let last = (self.n[axis] - self.size[axis]) as isize;
                (self.first[axis] + by).clamp(0, last) - self.first[axis]
            }
            _ => 0,
        }
    }

    /// Rolls the interior of `field` on the box grid `boxed` by `by` cells along `axis`, as
    /// [`shift`](Self::shift) moved the box (box cell `b` takes the value of cell `b + by`,
    /// cells wrapping around the ring), and fills its ghosts periodically along that axis.
    /// `line` is scratch.
    pub fn roll<T: Real>(boxed: &Grid<T>, field: &mut Field<T>, axis: usize, by: isize, line: &mut Vec<T>) {
        Self::roll_slice(boxed, &mut field.data, axis, by, line);
    }

    /// [`roll`](Self::roll) of any per-cell storage of the box grid (`boxed.len()` values,
    /// ghosts included), e.g. a transport's time history
    /// ([`InterfaceTransport::roll`](crate::interface::advect::InterfaceTransport::roll)). Nothing for
    /// storage of another length.
    pub fn roll_slice<T: Real, V: Copy + Default>(
        boxed: &Grid<T>,
        data: &mut [V],
        axis: usize,
        by: isize,
        line: &mut Vec<V>,
    ) {
        if data.len() != boxed.len() || axis > 2 {
            return;
        }
        let n = boxed.n()[axis];
        let by = by.rem_euclid(n as isize) as usize;
        let dims = boxed.dims();
        let st = boxed.strides();
        let (a, b) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        line.resize(n, V::default());
        for q in 0..dims[b] {
            for p in 0..dims[a] {
                let base = p * st[a] + q * st[b];
                let at = |c: usize| base + (c + GHOST) * st[axis];
                for (c, l) in line.iter_mut().enumerate() {
                    *l = data[at((c + by) % n)];
                }
                for (c, l) in line.iter().enumerate() {
                    data[at(c)] = *l;
                }
                for gcell in 0..GHOST {
                    data[base + gcell * st[axis]] =
                        line[(gcell as isize - GHOST as isize).rem_euclid(n as isize) as usize];
                    data[base + (n + GHOST + gcell) * st[axis]] = line[gcell % n];
                }
            }
        }
    }

    /// [`roll`](Self::roll) of each component of a symmetric tensor field.
    pub fn roll_sym<T: Real>(
        boxed: &Grid<T>,
        field: &mut SymField<T>,
        axis: usize,
        by: isize,
        line: &mut Vec<T>,
    ) {
        for c in field.c.iter_mut() {
            Self::roll(boxed, c, axis, by, line);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Boundary;
    use proptest::prelude::*;

    fn field(g: &Grid<f64>) -> Field<f64> {
        let mut f = Field::from_cell_fn(g, |x| (7.0 * x[0]).sin() + 3.0 * x[1] * x[1] - (5.0 * x[2]).cos());
        f.fill_ghosts(g);
        f
    }

    fn walled() -> Grid<f64> {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[2] = [Boundary::wall(), Boundary::wall()];
        Grid::new([16, 12, 10], [0.0; 3], [1.6, 1.2, 1.0], bc).unwrap()
    }

    #[test]
    fn a_whole_window_copies_and_adds_bit_for_bit() {
        let g = walled();
        let w = Window::whole(&g);
        let bg = w.grid(&g);
        assert_eq!(bg, g);
        let f = field(&g);
        let mut b = Field::zeros(&bg);
        w.gather(&g, &f, &bg, &mut b).unwrap();
        assert_eq!(b, f);
        let mut sum = f.clone();
        w.add_to(&bg, &b, &g, &mut sum).unwrap();
        for (i, j, k) in g.cells() {
            let idx = g.idx_u(i, j, k);
            assert_eq!(sum.data[idx], 2.0 * f.data[idx]);
        }
        // Ghosts are not added to.
        assert_eq!(sum.at(&g, -1, 0, 0), f.at(&g, -1, 0, 0));
    }

    #[test]
    fn a_ring_box_holds_the_grid_cells_at_its_positions() {
        let g = walled();
        let w = Window::new(&g, [-3, 9, 0], [8, 6, 10]).unwrap();
        assert!(!w.is_whole());
        let bg = w.grid(&g);
        assert!(bg.is_periodic(0) && bg.is_periodic(1) && !bg.is_periodic(2));
        assert_eq!(bg.h(), g.h());
        let f = field(&g);
        let mut b = Field::zeros(&bg);
        w.gather(&g, &f, &bg, &mut b).unwrap();
        // The box field's values are the grid's at the same (periodic) positions.
        let exact = |x: [f64; 3]| {
            let x = [x[0].rem_euclid(1.6), x[1].rem_euclid(1.2), x[2]];
            (7.0 * x[0]).sin() + 3.0 * x[1] * x[1] - (5.0 * x[2]).cos()
        };
        for (i, j, k) in bg.cells() {
            let x = bg.cell_center(i as isize, j as isize, k as isize);
            assert!((b.data[bg.idx_u(i, j, k)] - exact(x)).abs() < 1e-12, "{i} {j} {k}");
        }
        // Ghosts: the box's own periodic images along rings, the grid's ghosts along z.
        let mut filled = b.clone();
        filled.fill_ghosts(&bg);
        assert_eq!(filled, b);
        assert_eq!(w.grid_cell([0, 0, -1]), [13, 9, -1]);
        assert_eq!(w.grid_cell([7, 5, 0]), [4, 2, 0]);
    }

    #[test]
    fn a_segment_box_stops_at_the_walls_and_reads_the_grid_beyond_its_sides() {
        let g = walled();
        let w = Window::new(&g, [-3, 9, 2], [8, 6, 5]).unwrap();
        assert_eq!(w.segments(), [false, false, true]);
        assert_eq!(w.movable(), [true, true, true]);
        let bg = w.grid(&g);
        // The box grid is periodic along z too, from the grid's cell 2.
        assert!(bg.is_periodic(2));
        assert!((bg.lower()[2] - 0.2).abs() < 1e-15 && (bg.upper()[2] - 0.7).abs() < 1e-15);
        let f = field(&g);
        let mut b = Field::zeros(&bg);
        w.gather(&g, &f, &bg, &mut b).unwrap();
        for (i, j, k) in bg.cells() {
            let c = w.grid_cell([i, j, k].map(|x| x as isize));
            assert_eq!(b.data[bg.idx_u(i, j, k)], f.at(&g, c[0], c[1], c[2]));
        }
        // Ghosts are the box's own periodic images, as on a ring.
        assert_eq!(b.at(&bg, 0, 0, -1), f.at(&g, 13, 9, 6));
        assert_eq!(b.at(&bg, 0, 0, 5), f.at(&g, 13, 9, 2));
        let mut filled = b.clone();
        filled.fill_ghosts(&bg);
        assert_eq!(filled, b);
        // Added back, the box lands on the grid's cells 2..7 along z only.
        let mut sum = Field::zeros(&g);
        w.add_to(&bg, &b, &g, &mut sum).unwrap();
        for (i, j, k) in g.cells() {
            let inside = (2..7).contains(&k) && !(5..13).contains(&i) && !(3..9).contains(&j);
            assert_eq!(sum.data[g.idx_u(i, j, k)], if inside { f.data[g.idx_u(i, j, k)] } else { 0.0 });
        }
        // A segment moves between the walls only.
        let near = Window::new(&g, [0, 0, 0], [8, 8, 6]).unwrap();
        assert_eq!(near.clamp_shift(2, -3), 0);
        assert_eq!(near.clamp_shift(2, 7), 4);
    }

    #[test]
    fn adding_a_box_back_conserves_its_sum_and_touches_nothing_else() {
        let g = walled();
        let w = Window::new(&g, [12, -2, 0], [7, 5, 10]).unwrap();
        let bg = w.grid(&g);
        let b = field(&bg);
        let mut out = Field::zeros(&g);
        w.add_to(&bg, &b, &g, &mut out).unwrap();
        let (sb, so) = (b.interior_sum(&bg), out.interior_sum(&g));
        assert!((sb - so).abs() < 1e-12 * sb.abs().max(1.0));
        let touched = g.cells().filter(|&(i, j, k)| out.data[g.idx_u(i, j, k)] != 0.0).count();
        assert_eq!(touched, 7 * 5 * 10);
        assert!(out.data[g.idx_u(3, 5, 0)] == 0.0 && out.data[g.idx_u(15, 10, 3)] != 0.0);
    }

    #[test]
    fn a_shift_with_a_roll_carries_the_box_round_its_ring() {
        let g = Grid::<f64>::periodic([16, 16, 16], [0.0; 3], [1.0; 3]).unwrap();
        let f = field(&g);
        let mut line = Vec::new();
        for (axis, by) in [(0, 3), (1, -2), (2, 1)] {
            let mut w = Window::new(&g, [14, 3, 5], [8, 9, 10]).unwrap();
            let bg = w.grid(&g);
            let mut b = Field::zeros(&bg);
            w.gather(&g, &f, &bg, &mut b).unwrap();
            let old = b.clone();
            w.shift(axis, by).unwrap();
            Window::roll(&bg, &mut b, axis, by, &mut line);
            let moved = w.grid(&g);
            assert_eq!(w.first()[axis], [14, 3, 5][axis] + by);
            let h = g.h()[axis];
            assert!((moved.lower()[axis] - bg.lower()[axis] - by as f64 * h).abs() < 1e-14);
            let mut fresh = Field::zeros(&moved);
            w.gather(&g, &f, &moved, &mut fresh).unwrap();
            let size = w.size()[axis] as isize;
            for (i, j, k) in moved.cells() {
                let idx = moved.idx_u(i, j, k);
                let c = [i, j, k][axis] as isize;
                if (0..size).contains(&(c + by)) {
                    // A cell that stayed in the box holds the value at its new place...
                    assert_eq!(b.data[idx], fresh.data[idx]);
                } else {
                    // ... one that came round the ring what the box held at the other end.
                    let mut from = [i, j, k].map(|x| x as isize);
                    from[axis] = (c + by).rem_euclid(size);
                    assert_eq!(b.data[idx], old.at(&bg, from[0], from[1], from[2]));
                }
            }
            // Ghosts are the ring's periodic images.
            let mut filled = b.clone();
            filled.fill_ghosts(&moved);
            assert_eq!(filled, b);
        }
    }

    #[test]
    fn a_grown_box_holds_the_cells_of_the_old_one_where_they_were() {
        let g = walled();
        let f = field(&g);
        // A ring along x across the seam, a ring along y, a segment along z.
        let w = Window::new(&g, [-3, 2, 2], [8, 6, 5]).unwrap();
        let cases = [
            ([2, 1, 1], [3, 0, 1], [13, 7, 7], [true, true, true]),
            // x reaches the grid's 16 cells, z would pass the lower wall: both whole.
            ([5, 0, 3], [3, 0, 0], [16, 6, 10], [false, true, false]),
        ];
        for (lo, hi, size, movable) in cases {
            let to = w.grown(&g, lo, hi).unwrap();
            assert_eq!((to.size(), to.movable()), (size, movable));
            let (bg, tg) = (w.grid(&g), to.grid(&g));
            let (mut b, mut t) = (Field::zeros(&bg), Field::zeros(&tg));
            w.gather(&g, &f, &bg, &mut b).unwrap();
            w.transfer_slice(&bg, &b.data, &to, &tg, &mut t.data).unwrap();
            // Moved into the grown box, then added back to the grid: the old box's cells, with
            // their grid values, and nothing else.
            let (mut from_old, mut from_new) = (Field::zeros(&g), Field::zeros(&g));
            w.add_to(&bg, &b, &g, &mut from_old).unwrap();
            to.add_to(&tg, &t, &g, &mut from_new).unwrap();
            assert_eq!(from_old, from_new);
            assert_eq!(from_old.data.iter().filter(|&&x| x != 0.0).count(), w.cell_count());
            // Every interior cell of the old box has its place in the new one.
            for (i, j, k) in bg.cells() {
                assert!(w.transfer_index(&bg, &to, &tg, bg.idx_u(i, j, k)).is_some());
            }
            assert_eq!(w.transfer_index(&bg, &to, &tg, 0), None, "a ghost cell");
        }
        assert!(w.transfer_slice(&w.grid(&g), &[0.0; 3], &w, &w.grid(&g), &mut [0.0; 3]).is_err());
    }

    #[test]
    fn errors_name_the_parameter() {
        let g = walled();
        let e = Window::new(&g, [0, 0, 5], [8, 8, 6]).unwrap_err().to_string();
        assert!(e.contains("first[2]") && e.contains("at most 4"), "{e}");
        let e = Window::new(&g, [0, 0, 0], [8, 8, 3]).unwrap_err().to_string();
        assert!(e.contains("size[2]"), "{e}");
        let mut s = Window::new(&g, [0, 0, 3], [8, 8, 6]).unwrap();
        assert_eq!(s.clamp_shift(2, 5), 1);
        assert!(s.shift(2, 2).unwrap_err().to_string().contains("by"));
        let e = Window::new(&g, [0; 3], [3, 8, 10]).unwrap_err().to_string();
        assert!(e.contains("size[0]"), "{e}");
        let mut w = Window::new(&g, [0; 3], [8, 12, 10]).unwrap();
        assert!(w.shift(1, 1).unwrap_err().to_string().contains("axis"));
        let other = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
        let bg = w.grid(&g);
        let mut b = Field::zeros(&bg);
        assert!(w.gather(&other, &Field::zeros(&other), &bg, &mut b).is_err());
        assert!(Window::around(&g, [0.0, f64::NAN, 0.0], [1.0; 3], 2).is_err());
    }

    #[test]
    fn around_covers_the_corners_and_the_margin() {
        let g = walled();
        // Cells are 0.1 wide: centres at 0.05 + 0.1 i.
        let w = Window::around(&g, [-0.12, 0.31, 0.2], [0.14, 0.52, 0.3], 2).unwrap();
        assert_eq!(w.first()[0], -2 - 2);
        // Along the wall axis z: cells 1..=3 and 2 each side would reach past the lower wall.
        assert_eq!((w.first()[2], w.size()[2]), (0, 10));
        let inner = Window::around(&g, [0.0, 0.0, 0.4], [0.1, 0.1, 0.5], 2).unwrap();
        assert_eq!((inner.first()[2], inner.size()[2], inner.segments()[2]), (1, 7, true));
        let bg = w.grid(&g);
        let (lo, hi) = (bg.lower(), bg.upper());
        assert!(lo[0] <= -0.12 - 2.0 * 0.1 + 1e-12 && hi[0] >= 0.14 + 2.0 * 0.1 - 1e-12);
        assert!(lo[1] <= 0.31 - 0.2 + 1e-12 && hi[1] >= 0.52 + 0.2 - 1e-12);
        // A box longer than the grid is the whole axis.
        assert_eq!(Window::around(&g, [0.0; 3], [1.5, 0.1, 0.1], 2).unwrap().size()[0], 16);
    }

    proptest! {
        #[test]
        fn gather_then_add_is_the_identity_on_the_box(
            fx in -20isize..20, fy in -20isize..20, sx in 4usize..20, sy in 4usize..16,
        ) {
            let g = walled();
            let w = Window::new(&g, [fx, fy, 0], [sx, sy, 10]).unwrap();
            let bg = w.grid(&g);
            let f = field(&g);
            let mut b = Field::zeros(&bg);
            w.gather(&g, &f, &bg, &mut b).unwrap();
            let mut back = Field::zeros(&g);
            w.add_to(&bg, &b, &g, &mut back).unwrap();
            let mut count = 0;
            for (i, j, k) in g.cells() {
                let idx = g.idx_u(i, j, k);
                if back.data[idx] != 0.0 {
                    prop_assert_eq!(back.data[idx], f.data[idx]);
                    count += 1;
                }
            }
            // Every box cell lands on a distinct grid cell (none is zero in this field).
            prop_assert_eq!(count, w.cell_count());
        }
    }
}
