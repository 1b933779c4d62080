//! The membrane band: the cells where the smoothed delta function is non-negligible,
//! `δ_ijk h ≥ ε` (Sec. 2.2.2, "Spatial discretization"), and the layers of cells around them.
//!
//! Every membrane kernel of the crate ([`super::force`], [`super::bending`], [`super::strain`])
//! works on this list instead of the whole box, so that its cost grows with the capsule surface,
//! not with the box. The paper uses the same set to decide where `G_s` is kept and where it is
//! reset to `P` ((2.40) and the paragraph after it).
//!
//! # Contents
//!
//! - **band cells**: interior cells with `δ h ≥ ε`, in storage order (x fastest). `h` is the
//!   largest spacing among the axes that have more than one cell (`Δx` on the paper's uniform
//!   grids), `ε ∈ (0, 1)` a parameter (the paper uses 0.01–0.1);
//! - **halo layers** `r = 1..=`[`MAX_HALO`]: the cells within Chebyshev distance `r` of a band
//!   cell (the 26-neighbourhood applied `r` times; periodic axes wrap, walls stop it). The list
//!   [`Band::halo`]`(r)` holds the band first, then layer 1, ..., layer `r`, each layer in storage
//!   order: a quantity stored per entry of `halo(r)` is also stored for every entry of
//!   `halo(r - 1)`, at the same position;
//! - a **position map** from every storage index, ghost cells included, to the position of the
//!   cell in the lists: a ghost cell on a periodic axis maps to the position of its periodic image,
//!   so stencils that cross a periodic boundary read the right neighbour.
//!
//! Which kernel needs which layer: the in-plane force `∇·(δ τ)` is non-zero on the faces of
//! `halo(1)`; the bending force `∇·(q̃ n)` needs `q̃` on `halo(1)` and has faces on `halo(2)`;
//! the `G_s` transport updates the band, keeps the advective tendency on `halo(1)` (for AB2),
//! reads `G_s` up to `halo(3)` and resets `G_s = P` out to `halo(4)`.
//!
//! # What `ε` costs
//!
//! Everything the membrane does is cut off where `δ h < ε`: the force `∇·(δ τ)` (with `G_s`
//! reset to `P` there, `τ = 0`), and the bending moment. For the smoothed profile
//! `φ = (1 + tanh(β s/h))/2` the cut removes the part of `∫ δ ds = 1` outside
//! `sech²(β s/h) ≥ 2ε/β`, a fraction `1 − √(1 − 2ε/β)` of every membrane force, whatever the
//! grid: with `β = 1`, 1.0 % at `ε = 0.01` and 10.6 % at `ε = 0.1` (the paper's range). Measured
//! on a pre-stretched sphere, the Laplace jump is low by exactly this fraction plus a
//! discretisation error that vanishes at second order (`tests/membrane_grid.rs`). Prefer small
//! `ε` for accuracy; the band grows only logarithmically: its width is `2 atanh(√(1 − 2ε/β)) h/β`,
//! about `½ ln(2β/ε)` cells each side (5.3 cells in all at `ε = 0.01`, 2.9 at `ε = 0.1`).
//!
//! # Cost
//!
//! [`Band::rebuild`] reads `δ` once over the box (one comparison per cell, row by row, recording
//! the band as runs along x) and then works on the listed cells only: clearing the previous
//! position map, dilating the runs (per row, the runs of the nine neighbouring rows widened by
//! one cell and merged: `O(rows + runs)`), and listing the cells of each layer in storage order.
//! Its buffers keep their capacity, so that rebuilding allocates only when the band grows.
//!
//! # Walls
//!
//! A band cell closer than [`WALL_CLEARANCE`] cells to a wall is refused: the membrane stencils
//! read up to three cells around the band, and ghost values across a wall are mirror images that
//! a membrane cannot have. At two cells they read at most one mirrored layer, where `delta` has
//! fallen below `ε/h` (the capsule of the paper's Sec. 3.2 at 32 cells per unit length sits
//! there); keep capsules further away when you can.

use crate::grid::{Field, GHOST, Grid};
use crate::{Error, Real, Result};
use std::sync::atomic::{AtomicU64, Ordering};

/// Least number of cells between a band cell and a wall (see the [module docs](self)).
pub const WALL_CLEARANCE: usize = 2;

/// The `h` of the band criterion `delta h >= epsilon`: the largest spacing among the axes that
/// have more than one cell (`Δx` on the paper's uniform grids; the x spacing of a one-cell box).
pub(crate) fn band_spacing<T: Real>(grid: &Grid<T>) -> T {
    let n = grid.n();
    let h = (0..3).filter(|&d| n[d] > 1).map(|d| grid.h()[d]).fold(T::zero(), |a, b| a.max(b));
    if h > T::zero() { h } else { grid.h()[0] }
}

/// Number of halo layers kept around the band (see the [module docs](self)).
pub const MAX_HALO: usize = 4;

/// Position-map value of a cell that is in no list.
const NONE: u32 = u32::MAX;

/// Source of unique band generations (a stamp per rebuild, unique across all bands).
static GENERATION: AtomicU64 = AtomicU64::new(1);

fn fresh_generation() -> u64 {
    GENERATION.fetch_add(1, Ordering::Relaxed)
}

/// The band of cells with `δ h ≥ ε` and its halo layers (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct Band<T> {
    epsilon: T,
    h: T,
    dims: [usize; 3],
    n: [usize; 3],
    periodic: [bool; 3],
    /// Storage indices: band, then halo layer 1, ..., layer MAX_HALO.
    cells: Vec<usize>,
    /// Interior coordinates of `cells`.
    ijk: Vec<[u32; 3]>,
    /// `cells[..end[r]]` is `halo(r)` (`end[0]`: the band).
    end: [usize; MAX_HALO + 1],
    /// Position in `cells` of every storage index (ghosts: their periodic image), or `NONE`.
    slot: Vec<u32>,
    /// Runs of `halo(r)` per interior row, `r = 0..=MAX_HALO` (scratch of the rebuild).
    runs: [Runs; MAX_HALO + 1],
    /// Candidate runs of one row during a dilation (scratch).
    cand: Vec<[u32; 2]>,
    generation: u64,
}

/// Cells of a set as half-open runs `[i0, i1)` along x, per interior row `q = j + n_y k`: the
/// runs of row `q` are `runs[off[q]..off[q + 1]]`, sorted and disjoint.
#[derive(Debug, Clone, Default)]
struct Runs {
    off: Vec<u32>,
    runs: Vec<[u32; 2]>,
}

impl Runs {
    fn clear(&mut self) {
        self.off.clear();
        self.runs.clear();
        self.off.push(0);
    }
    #[inline]
    fn row(&self, q: usize) -> &[[u32; 2]] {
        &self.runs[self.off[q] as usize..self.off[q + 1] as usize]
    }
    fn end_row(&mut self) {
        self.off.push(self.runs.len() as u32);
    }
}

impl<T: Real> Band<T> {
    /// An empty band on `grid` with threshold `epsilon` (cells with `δ h ≥ epsilon` are in the
    /// band). Call [`rebuild`](Self::rebuild) to fill it.
    ///
    /// Allocates the position map (one `u32` per stored cell of the grid) once.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `epsilon` unless `0 < epsilon < 1`; or naming `grid` if
    /// the grid has more than `u32::MAX - 1` stored cells.
    pub fn new(grid: &Grid<T>, epsilon: T) -> Result<Self> {
        if !(epsilon > T::zero() && epsilon < T::one()) {
            return Err(Error::invalid("epsilon", epsilon, "a number in (0, 1), e.g. 0.01 to 0.1"));
        }
        if grid.len() >= NONE as usize {
            return Err(Error::invalid("grid", grid.len(), "fewer than 2^32 - 1 stored cells"));
        }
        let n = grid.n();
        Ok(Band {
            epsilon,
            h: band_spacing(grid),
            dims: grid.dims(),
            n,
            periodic: std::array::from_fn(|d| grid.is_periodic(d)),
            cells: Vec::new(),
            ijk: Vec::new(),
            end: [0; MAX_HALO + 1],
            slot: vec![NONE; grid.len()],
            runs: Default::default(),
            cand: Vec::new(),
            generation: fresh_generation(),
        })
    }

    /// Rebuilds the band from the delta function `delta = |∇φ|` at cell centres (interior values
    /// are read; ghosts are not needed), and its halo layers.
    ///
    /// # Errors
    /// - [`Error::InvalidParameter`] naming `grid` or `delta` if they do not match the grid the
    ///   band was made for;
    /// - [`Error::NonFinite`] naming `delta` at the first interior cell holding NaN or infinity;
    /// - [`Error::Unsupported`] if a band cell lies closer than [`WALL_CLEARANCE`] cells to a
    ///   wall.
    ///
    /// On error the band is left as it was.
    pub fn rebuild(&mut self, grid: &Grid<T>, delta: &Field<T>) -> Result<()> {
        self.check_grid(grid)?;
        if delta.data.len() != grid.len() {
            return Err(Error::invalid("delta", delta.data.len(), "a field of the band's grid"));
        }
        let threshold = self.epsilon / self.h;
        let [nx, ny, nz] = self.n;
        // 1. Scan: band runs per row (the band is not touched until the scan succeeded).
        let level0 = &mut self.runs[0];
        level0.clear();
        for k in 0..nz {
            for j in 0..ny {
                let base = grid.idx_u(0, j, k);
                let row = &delta.data[base..base + nx];
                let mut open: Option<u32> = None;
                for (i, &d) in row.iter().enumerate() {
                    if !d.is_finite() {
                        return Err(Error::NonFinite { field: "delta", cell: [i, j, k] });
                    }
                    let inside = d >= threshold;
                    if inside {
                        let c = [i, j, k];
                        if let Some(axis) = (0..3).find(|&a| {
                            !self.periodic[a] && (c[a] < WALL_CLEARANCE || c[a] + WALL_CLEARANCE >= self.n[a])
                        }) {
                            return Err(Error::Unsupported {
                                component: "Band",
                                detail: format!(
                                    "band cell {c:?} (delta h >= {}) lies within {WALL_CLEARANCE} cells of the \
                                     wall on axis {axis}; move the capsule away from the wall or enlarge \
                                     the domain",
                                    self.epsilon
                                ),
                            });
                        }
                    }
                    match (inside, open) {
                        (true, None) => open = Some(i as u32),
                        (false, Some(a)) => {
                            level0.runs.push([a, i as u32]);
                            open = None;
                        }
                        _ => {}
                    }
                }
                if let Some(a) = open {
                    level0.runs.push([a, nx as u32]);
                }
                level0.end_row();
            }
        }
        // 2. Commit: forget the previous lists, dilate, list the cells layer by layer.
        for p in 0..self.cells.len() {
            let c = self.ijk[p];
            self.set_images(c, NONE);
        }
        self.cells.clear();
        self.ijk.clear();
        for r in 1..=MAX_HALO {
            self.dilate(r);
        }
        for r in 0..=MAX_HALO {
            for k in 0..nz {
                for j in 0..ny {
                    let q = j + ny * k;
                    let base = grid.idx_u(0, j, k);
                    let inner: &[[u32; 2]] = if r == 0 { &[] } else { self.runs[r - 1].row(q) };
                    let mut t = 0;
                    for ri in 0..self.runs[r].row(q).len() {
                        let [a, b] = self.runs[r].row(q)[ri];
                        for i in a..b {
                            while t < inner.len() && inner[t][1] <= i {
                                t += 1;
                            }
                            if t < inner.len() && inner[t][0] <= i {
                                continue;
                            }
                            self.cells.push(base + i as usize);
                            self.ijk.push([i, j as u32, k as u32]);
                        }
                    }
                }
            }
            self.end[r] = self.cells.len();
        }
        for p in 0..self.cells.len() {
            let c = self.ijk[p];
            self.set_images(c, p as u32);
        }
        self.generation = fresh_generation();
        Ok(())
    }

    fn check_grid(&self, grid: &Grid<T>) -> Result<()> {
        if grid.dims() != self.dims || grid.n() != self.n {
            return Err(Error::invalid(
                "grid",
                format!("{:?} cells", grid.n()),
                "the grid the band was made for",
            ));
        }
        Ok(())
    }

    /// `runs[r]` = the Chebyshev dilation by one cell of `runs[r - 1]`: per row, the runs of the
    /// nine neighbouring rows (periodic rows wrap, rows beyond a wall do not exist) widened by one
    /// cell (wrapping on a periodic x axis), sorted and merged.
    fn dilate(&mut self, r: usize) {
        let [nx, ny, nz] = self.n;
        let (lower, upper) = self.runs.split_at_mut(r);
        let (prev, out) = (&lower[r - 1], &mut upper[0]);
        out.clear();
        let wrap = |x: isize, n: usize, periodic: bool| -> Option<usize> {
            let n = n as isize;
            if (0..n).contains(&x) {
                Some(x as usize)
            } else if periodic {
                Some(x.rem_euclid(n) as usize)
            } else {
                None
            }
        };
        let nxi = nx as i64;
        for k in 0..nz {
            for j in 0..ny {
                let cand = &mut self.cand;
                cand.clear();
                for dk in -1..=1 {
                    let Some(kk) = wrap(k as isize + dk, nz, self.periodic[2]) else { continue };
                    for dj in -1..=1 {
                        let Some(jj) = wrap(j as isize + dj, ny, self.periodic[1]) else { continue };
                        for &[a, b] in prev.row(jj + ny * kk) {
                            let (a, b) = (a as i64 - 1, b as i64 + 1);
                            if !self.periodic[0] {
                                cand.push([a.max(0) as u32, b.min(nxi) as u32]);
                            } else if b - a >= nxi {
                                cand.push([0, nx as u32]);
                            } else if a < 0 {
                                cand.push([(a + nxi) as u32, nx as u32]);
                                cand.push([0, b as u32]);
                            } else if b > nxi {
                                cand.push([a as u32, nx as u32]);
                                cand.push([0, (b - nxi) as u32]);
                            } else {
                                cand.push([a as u32, b as u32]);
                            }
                        }
                    }
                }
                cand.sort_unstable_by_key(|run| run[0]);
                let mut cur: Option<[u32; 2]> = None;
                for &[a, b] in cand.iter() {
                    cur = match cur {
                        Some([c0, c1]) if a <= c1 => Some([c0, c1.max(b)]),
                        Some(done) => {
                            out.runs.push(done);
                            Some([a, b])
                        }
                        None => Some([a, b]),
                    };
                }
                if let Some(done) = cur {
                    out.runs.push(done);
                }
                out.end_row();
            }
        }
    }

    /// Sets the map of interior cell `c` and of all its periodic ghost images to `value`.
    #[inline]
    fn set_images(&mut self, c: [u32; 3], value: u32) {
        let [dx, dy, _] = self.dims;
        let near_seam =
            |d: usize| self.periodic[d] && ((c[d] as usize) < GHOST || c[d] as usize + GHOST >= self.n[d]);
        if !(near_seam(0) || near_seam(1) || near_seam(2)) {
            let g = GHOST;
            self.slot[(c[0] as usize + g) + dx * ((c[1] as usize + g) + dy * (c[2] as usize + g))] = value;
            return;
        }
        self.set_images_near_seam(c, value);
    }

    /// [`set_images`](Self::set_images) for a cell with periodic images in the ghost layers.
    fn set_images_near_seam(&mut self, c: [u32; 3], value: u32) {
        let g = GHOST as isize;
        let mut img = [[0isize; 8]; 3];
        let mut cnt = [0usize; 3];
        for d in 0..3 {
            let ci = c[d] as isize;
            if self.periodic[d] {
                let n = self.n[d] as isize;
                let mut m = ci - n * ((ci + g) / n);
                while m < n + g {
                    if m >= -g && cnt[d] < 8 {
                        img[d][cnt[d]] = m;
                        cnt[d] += 1;
                    }
                    m += n;
                }
            } else {
                img[d][0] = ci;
                cnt[d] = 1;
            }
        }
        let [dx, dy, _] = self.dims;
        for &k in &img[2][..cnt[2]] {
            for &j in &img[1][..cnt[1]] {
                for &i in &img[0][..cnt[0]] {
                    let idx = (i + g) as usize + dx * ((j + g) as usize + dy * (k + g) as usize);
                    self.slot[idx] = value;
                }
            }
        }
    }

    /// The threshold `ε` of `δ h ≥ ε`.
    pub fn epsilon(&self) -> T {
        self.epsilon
    }

    /// The length `h` in `δ h ≥ ε`: the largest spacing among axes with more than one cell.
    pub fn h(&self) -> T {
        self.h
    }

    /// Number of band cells.
    pub fn len(&self) -> usize {
        self.end[0]
    }

    /// Whether the band has no cell (before the first rebuild, or with no interface).
    pub fn is_empty(&self) -> bool {
        self.end[0] == 0
    }

    /// Storage indices of the band cells, in storage order (x fastest).
    pub fn cells(&self) -> &[usize] {
        &self.cells[..self.end[0]]
    }

    /// Storage indices of the cells within Chebyshev distance `r` of the band (`r = 0`: the band
    /// itself), band first, then layer 1, ..., layer `r`. `r` above [`MAX_HALO`] is read as
    /// `MAX_HALO`.
    pub fn halo(&self, r: usize) -> &[usize] {
        &self.cells[..self.end[r.min(MAX_HALO)]]
    }

    /// The smallest and largest interior coordinates, per axis, of the cells of
    /// [`halo`](Self::halo)`(r)` (`None` for an empty band).
    pub(crate) fn bounds(&self, r: usize) -> Option<([usize; 3], [usize; 3])> {
        let coords = self.coords(r);
        let first = coords.first()?.map(|x| x as usize);
        Some(coords.iter().fold((first, first), |(lo, hi), c| {
            (
                std::array::from_fn(|d| lo[d].min(c[d] as usize)),
                std::array::from_fn(|d| hi[d].max(c[d] as usize)),
            )
        }))
    }

    /// Interior coordinates `(i, j, k)` of the entries of [`halo`](Self::halo)`(r)`.
    pub fn coords(&self, r: usize) -> &[[u32; 3]] {
        &self.ijk[..self.end[r.min(MAX_HALO)]]
    }

    /// Position in [`halo`](Self::halo)`(MAX_HALO)` of the cell at storage index `idx` (a ghost
    /// cell on a periodic axis answers for its periodic image), or `None` if the cell is further
    /// than `MAX_HALO` cells from the band. Positions below [`len`](Self::len) are band cells.
    #[inline]
    pub fn position(&self, idx: usize) -> Option<usize> {
        let s = self.slot[idx];
        if s == NONE { None } else { Some(s as usize) }
    }

    /// Position of storage index `idx` if it lies in `halo(r)`.
    #[inline(always)]
    pub(crate) fn position_in(&self, idx: usize, r: usize) -> Option<usize> {
        let s = self.slot[idx] as usize;
        if s < self.end[r] { Some(s) } else { None }
    }

    /// Whether storage index `idx` is a band cell (or the periodic ghost image of one).
    #[inline]
    pub fn contains(&self, idx: usize) -> bool {
        (self.slot[idx] as usize) < self.end[0]
    }

    /// A stamp that changes at every rebuild and differs between bands: quantities evaluated on
    /// the band record it, so that using them with another band (or after a rebuild) is caught.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// `Ok` if `generation`, recorded by `component` when it was `done` ("evaluated", "built")
    /// on a band, is this band's: [`Error::Unsupported`] otherwise (another band, a rebuild
    /// since, or 0 for a failed or missing evaluation).
    pub(crate) fn check_generation(
        &self,
        component: &'static str,
        generation: u64,
        done: &str,
    ) -> Result<()> {
        if generation == 0 || generation != self.generation {
            return Err(Error::Unsupported {
                component,
                detail: format!(
                    "not {done} on this band (or the band was rebuilt since): call it after Band::rebuild"
                ),
            });
        }
        Ok(())
    }

    /// Checks that `grid` is the grid of this band.
    pub(crate) fn matches(&self, grid: &Grid<T>) -> Result<()> {
        self.check_grid(grid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Boundary;

    fn sphere_delta(g: &Grid<f64>, r0: f64) -> Field<f64> {
        let h = g.h()[0];
        Field::from_cell_fn(g, |x| {
            let r = ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
            let t = ((r0 - r) / h).tanh();
            0.5 * (1.0 - t * t) / h
        })
    }

    #[test]
    fn band_layers_and_positions() {
        let g = Grid::<f64>::periodic([24, 24, 24], [0.0; 3], [1.0; 3]).unwrap();
        let mut b = Band::new(&g, 0.05).unwrap();
        assert!(b.is_empty());
        let delta = sphere_delta(&g, 0.3);
        b.rebuild(&g, &delta).unwrap();
        let gen1 = b.generation();
        assert!(!b.is_empty());
        for (p, &idx) in b.cells().iter().enumerate() {
            assert!(delta.data[idx] * b.h() >= 0.05);
            assert_eq!(b.position(idx), Some(p));
        }
        let inside = g.cells().filter(|&(i, j, k)| delta.data[g.idx_u(i, j, k)] * b.h() >= 0.05).count();
        assert_eq!(inside, b.len());
        for r in 1..=MAX_HALO {
            assert!(b.halo(r).len() > b.halo(r - 1).len());
            // Every cell of layer r touches layer r-1.
            for &c in &b.coords(r)[b.halo(r - 1).len()..] {
                let near =
                    b.coords(r - 1).iter().any(|d| (0..3).all(|a| (c[a] as i64 - d[a] as i64).abs() <= 1));
                assert!(near);
            }
        }
        // Rebuild with a smaller sphere: old cells are forgotten.
        b.rebuild(&g, &sphere_delta(&g, 0.2)).unwrap();
        assert_ne!(b.generation(), gen1);
        let listed: std::collections::HashSet<usize> = b.halo(MAX_HALO).iter().copied().collect();
        for (i, j, k) in g.cells() {
            let idx = g.idx_u(i, j, k);
            assert_eq!(b.position(idx).is_some(), listed.contains(&idx));
        }
    }

    /// Layers against a brute-force Chebyshev distance, on periodic, wall and 2D grids.
    #[test]
    fn layers_match_brute_force_distance() {
        let wall_y = Boundary::walls_on(Some(1));
        let grids = [
            Grid::<f64>::periodic([11, 9, 7], [0.0; 3], [1.0; 3]).unwrap(),
            Grid::<f64>::new([10, 14, 6], [0.0; 3], [1.0; 3], wall_y).unwrap(),
            Grid::<f64>::periodic([13, 10, 1], [0.0; 3], [1.0, 1.0, 0.1]).unwrap(),
        ];
        for g in &grids {
            let n = g.n();
            // A scattered pattern of band cells (away from walls), some touching the seams.
            let on = |i: usize, j: usize, k: usize| {
                (i * 7 + j * 3 + k * 5).is_multiple_of(17) && j >= 3 && j + 3 < n[1] || (i == 0 && j == 4)
            };
            let delta = Field::from_cell_fn(g, |_| 0.0);
            let mut delta = delta;
            for (i, j, k) in g.cells() {
                delta.data[g.idx_u(i, j, k)] = if on(i, j, k) { 10.0 } else { 0.0 };
            }
            let mut b = Band::new(g, 0.5).unwrap();
            b.rebuild(g, &delta).unwrap();
            let band: Vec<[usize; 3]> =
                g.cells().filter(|&(i, j, k)| on(i, j, k)).map(|(i, j, k)| [i, j, k]).collect();
            let dist = |c: [usize; 3]| {
                band.iter()
                    .map(|bc| {
                        (0..3)
                            .map(|a| {
                                let d = (c[a] as i64 - bc[a] as i64).abs();
                                if g.is_periodic(a) { d.min(n[a] as i64 - d) } else { d }
                            })
                            .max()
                            .unwrap()
                    })
                    .min()
                    .unwrap()
            };
            for (i, j, k) in g.cells() {
                let idx = g.idx_u(i, j, k);
                let d = dist([i, j, k]) as usize;
                for r in 0..=MAX_HALO {
                    assert_eq!(b.position_in(idx, r).is_some(), d <= r, "{:?} cell {:?} r {r}", n, [i, j, k]);
                }
            }
            for r in 0..=MAX_HALO {
                let lo = if r == 0 { 0 } else { b.halo(r - 1).len() };
                let layer = &b.halo(r)[lo..];
                assert!(layer.windows(2).all(|w| w[0] < w[1]), "layer {r} not in storage order");
            }
        }
    }

    #[test]
    fn periodic_ghosts_map_to_images() {
        let g = Grid::<f64>::periodic([8, 8, 1], [0.0; 3], [1.0, 1.0, 0.125]).unwrap();
        // A band along the plane x = 0 (a periodic seam).
        let delta = Field::from_cell_fn(&g, |x| if x[0] < 0.125 { 100.0 } else { 0.0 });
        let mut b = Band::new(&g, 0.5).unwrap();
        b.rebuild(&g, &delta).unwrap();
        assert_eq!(b.len(), 8);
        for j in 0..8 {
            let p = b.position(g.idx(0, j, 0)).unwrap();
            assert_eq!(b.position(g.idx(8, j, 0)), Some(p));
            for k in -3..=3 {
                assert_eq!(b.position(g.idx(0, j, k)), Some(p));
            }
            assert!(b.contains(g.idx(8, j, 2)));
            // Layer 1 holds x = 1 and x = 7 (wrapped).
            assert!(b.position_in(g.idx(7, j, 0), 1).is_some());
            assert!(b.position_in(g.idx(-1, j, 0), 1).is_some());
            assert!(b.position_in(g.idx(2, j, 0), 1).is_none());
        }
    }

    #[test]
    fn rejects_bad_input() {
        let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
        for e in [0.0, 1.0, -0.1, f64::NAN] {
            assert!(Band::new(&g, e).is_err());
        }
        let mut b = Band::new(&g, 0.1).unwrap();
        let mut d = Field::zeros(&g);
        d.data[g.idx_u(3, 4, 5)] = f64::NAN;
        let e = b.rebuild(&g, &d).unwrap_err();
        assert!(matches!(e, Error::NonFinite { field: "delta", cell: [3, 4, 5] }));
        let g2 = Grid::<f64>::periodic([8, 8, 4], [0.0; 3], [1.0; 3]).unwrap();
        assert!(b.rebuild(&g2, &Field::zeros(&g2)).is_err());
        let gw = Grid::<f64>::new([8, 10, 8], [0.0; 3], [1.0; 3], Boundary::walls_on(Some(1))).unwrap();
        let mut bw = Band::new(&gw, 0.1).unwrap();
        let mut d = Field::zeros(&gw);
        d.data[gw.idx_u(4, 5, 4)] = 100.0;
        bw.rebuild(&gw, &d).unwrap();
        assert_eq!(bw.len(), 1);
        d.data[gw.idx_u(4, 1, 4)] = 100.0;
        assert!(matches!(bw.rebuild(&gw, &d), Err(Error::Unsupported { .. })));
        assert_eq!(bw.len(), 1, "a failed rebuild leaves the band as it was");
    }
}
