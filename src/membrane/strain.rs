//! Transport of the surface deformation tensor `G_s`: eq. (2.22),
//!
//! ```text
//! ∂G_s/∂t + v·∇G_s = ∇vᵀ·G_s + G_s·∇v,
//! ```
//!
//! discretised as (2.40): second-order Adams–Bashforth for the advection, the average of the
//! velocity gradients of steps `n` and `n+1` for the stretching,
//!
//! ```text
//! (G^{n+1} − Gⁿ)/Δt + (3/2) A(vⁿ, Gⁿ) − (1/2) A(v^{n−1}, G^{n−1})
//!     = ½ (∇vⁿ + ∇v^{n+1})ᵀ·Gⁿ + ½ Gⁿ·(∇vⁿ + ∇v^{n+1}),
//! ```
//!
//! then the re-set `G^{n+1} = P^{n+1}` in the cells with `δ h < ε` (Sec. 2.2.2).
//!
//! # Advection: upwind finite volumes of third or fifth order
//!
//! `A(v, G) = ∇_h·(v G) − G ∇_h·v` for each of the six components, with the flux through a face
//! equal to the staggered velocity on that face times an upwind-biased reconstruction of `G`
//! there ([`StrainAdvection`]):
//!
//! - [`StrainAdvection::Upwind3`], the paper's: for the face between cells `i−1` and `i` and a
//!   velocity `u ≥ 0`, `G_face = (−G_{i−2} + 5 G_{i−1} + 2 G_i)/6` (mirrored for `u < 0`). This
//!   is the third-order upwind flux for cell averages, and — the flux difference being
//!   `u (G_{i−2} − 6 G_{i−1} + 3 G_i + 2 G_{i+1})/(6h)` — also third order for point values
//!   (leading error `u h³/12 ∂⁴G`, dissipative). QUICK's `(−1, 6, 3)/8` would be second order
//!   here;
//! - [`StrainAdvection::Upwind5`]: `G_face = (2 G_{i−3} − 13 G_{i−2} + 47 G_{i−1} + 27 G_i
//!   − 3 G_{i+1})/60`, fifth order (leading error `∝ u h⁵ ∂⁶G`, dissipative). The paper notes
//!   that (2.39) "should also be discretized by a less dissipative numerical method"; the
//!   squashed sphere of Sec. 3.2 shows why: the advection error of `G_s` relative to the
//!   rotating tangent frame is the largest source of spurious elastic energy there (see
//!   `docs/validation/squashed_sphere.md`).
//!
//! Subtracting `G ∇_h·v` makes a uniform `G_s` exactly steady under any velocity, and changes
//! nothing for a discretely divergence-free one.
//!
//! The stretching term uses the cell-centred velocity gradient [`grad_v_at_cell`]
//! (`∇v[i][j] = ∂v_j/∂x_i`), the operator whose negative adjoint is the face divergence of the
//! in-plane force (see [`super::force`]), and [`stretching`].
//!
//! # In the tangent frame (an option, not in the paper)
//!
//! `G_s` is a surface tensor: in the continuum it lies in the tangent plane of the material
//! surface. On the curved shell the upwind faces mix neighbours whose `G_s` lie in different
//! planes, and a mean of two projectors `P(n_1)`, `P(n_2)` has a normal part and a smaller
//! in-plane trace (on the squashed sphere of Sec. 3.2 the energy error is made in the transport
//! of `G_s`, see `docs/validation/squashed_sphere.md`). [`StrainTransport::with_tangent_frame`] (`GsTransport::TangentFrame`) turns every
//! stencil value into the cell's tangent plane first ([`advective_tendency_in_frame`]; a field
//! of projectors then has zero tendency) and, since that turn of the frame along the path,
//! `A = [n × (v·∇)n]_×`, is also in the material rotation of the stretching term, leaves it out
//! there: `∇v → ∇v + A` in the convention of [`stretching`] (`L → L − A`). The squashed
//! sphere's energy error falls from 2.31e-2 to 1.13e-2 at N = 32 and from 1.21e-2 to 8.73e-3
//! at N = 64; together with the projection `GsTransport::Tangential` it gives 1.61e-3 at N = 64
//! and 5.84e-3 at N = 96, against 1.84e-2 with the paper's transport (`docs/validation/squashed_sphere.md`).
//! Off by default.
//!
//! # Where it is computed
//!
//! With the band `B` of step `n+1` (from `δ^{n+1}`):
//! - the advective tendency on [`Band::halo`]`(1)` (so that cells entering the band next step
//!   have their AB2 history); it reads `Gⁿ` up to three (fifth order: four) cells from the band;
//! - the update on the band cells;
//! - the re-set `G = P^{n+1}` out to `halo(4)`, so that next step's reads find valid values.
//!
//! This assumes that the interface moves less than one cell per step (an advective CFL number
//! below one, which the advection schemes need anyway). Further from the band `G_s` keeps stale
//! values that nothing reads; [`reset_outside_band`] applies the paper's re-set to the whole box
//! (for output, or after a large jump). A band cell without history (it was more than one cell
//! from the band at the previous step) takes a forward-Euler advection step.
//!
//! Time levels: `vⁿ` (ghosts filled), `v^{n+1}` (ghosts filled), `n^{n+1}` and the band of step
//! `n+1`; the caller keeps `vⁿ` across the flow step.

use super::band::Band;
use super::stress::stretching;
use crate::error::positive;
use crate::grid::ops::{
    cell_vector, grad_cell_vector_at, grad_v_at_cell, par_interior_update, velocity_at_cell,
};
use crate::grid::{Field, GHOST, Grid, SymField, VectorField};
use crate::tensor::{Mat3, Sym, Vec3, cross, projector, rotate, rotation_taking, skew};
use crate::{Error, Real, Result};
use rayon::prelude::*;

/// Cells per rayon task.
const MIN_CELLS_PER_TASK: usize = 256;

/// Position-map value of a cell without a stored tendency.
const NONE: u32 = u32::MAX;

/// Third-order upwind value on the face between `b` and `c` of the window `a | b | c | d`:
/// `(−a + 5b + 2c)/6` if `u ≥ 0`, else `(2b + 5c − d)/6`.
#[inline(always)]
pub(crate) fn upwind3_face<T: Real>(u: T, a: T, b: T, c: T, d: T) -> T {
    let sixth = T::lit(1.0 / 6.0);
    let five = T::lit(5.0);
    let two = T::lit(2.0);
    if u >= T::zero() { sixth * (five * b + two * c - a) } else { sixth * (two * b + five * c - d) }
}

/// Fifth-order upwind value on the face between `c` and `d` of the window `a b c | d e f`:
/// `(2a − 13b + 47c + 27d − 3e)/60` if `u ≥ 0`, else `(2f − 13e + 47d + 27c − 3b)/60`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn upwind5_face<T: Real>(u: T, a: T, b: T, c: T, d: T, e: T, f: T) -> T {
    let k = T::lit(1.0 / 60.0);
    let (w0, w1, w2, w3, w4) = (T::lit(2.0), T::lit(13.0), T::lit(47.0), T::lit(27.0), T::lit(3.0));
    if u >= T::zero() {
        k * (w0 * a - w1 * b + w2 * c + w3 * d - w4 * e)
    } else {
        k * (w0 * f - w1 * e + w2 * d + w3 * c - w4 * b)
    }
}

/// The upwind reconstruction of `G_s` on the faces in the advection of (2.39)/(2.40).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StrainAdvection {
    /// Third-order upwind (the paper's), `(−1, 5, 2)/6`; reads two cells upwind. The default:
    /// its dissipation keeps the hard cases of `cases/tests/stability.rs` stable.
    #[default]
    Upwind3,
    /// Fifth-order upwind, `(2, −13, 47, 27, −3)/60`; reads three cells upwind (the ghost depth).
    /// More accurate (the squashed sphere's energy error falls by 20-25 %), but less
    /// dissipative: two colliding capsules at 4 cells per radius blow up at `t = 3.6` with it
    /// (see `docs/stability.md`).
    Upwind5,
}

/// The advective tendency `A(v, G) = ∇_h·(v G) − G ∇_h·v` of the six components of `gs` at cell
/// `idx` with the upwind fluxes of `scheme` (see the [module docs](self)). Reads `gs` two
/// (fifth order: three) cells and `v` one face around the cell (ghosts filled).
#[inline]
pub fn advective_tendency<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    gs: &SymField<T>,
    idx: usize,
    scheme: StrainAdvection,
) -> Sym<T> {
    tendency_from(grid, v, idx, scheme, |j| gs.get(j))
}

/// [`advective_tendency`] in the tangent frame of cell `idx`: every stencil value `G_j` enters
/// the reconstruction turned into this cell's tangent plane, `R G_j Rᵀ` with `R` the least
/// rotation taking `n_j` to `n_i` ([`rotation_taking`]; values of cells whose normal is not a
/// unit vector within 60° of `n_i` enter unturned). A field of projectors `P(n(x))` has zero
/// tendency under any velocity. Reads `normal` (unit normals at cell centres) where it reads `gs`.
#[inline]
pub fn advective_tendency_in_frame<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    gs: &SymField<T>,
    normal: &[Field<T>; 3],
    idx: usize,
    scheme: StrainAdvection,
) -> Sym<T> {
    let ni = cell_vector(normal, idx);
    tendency_from(grid, v, idx, scheme, |j| {
        let g = gs.get(j);
        if j == idx {
            return g;
        }
        match rotation_taking(&cell_vector(normal, j), &ni) {
            Some(r) => rotate(&r, &g),
            None => g,
        }
    })
}

/// The turn of the tangent frame along the path, `A = [n × (v·∇)n]_×` at cell `idx` (`A n =
/// (v·∇)n` for a unit normal), with `v` the mean of `v_a` and `v_b` at the cell centre and
/// `(v·∇)n` by central differences of `normal`. The frame-turned advection
/// ([`advective_tendency_in_frame`]) makes this turn; the stretching term must then leave it
/// out (`∇v → ∇v + A` in the convention of [`stretching`]).
fn frame_turn<T: Real>(
    grid: &Grid<T>,
    v_a: &VectorField<T>,
    v_b: &VectorField<T>,
    normal: &[Field<T>; 3],
    idx: usize,
) -> Mat3<T> {
    let gn = grad_cell_vector_at(grid, normal, idx);
    let (va, vb) = (velocity_at_cell(grid, v_a, idx), velocity_at_cell(grid, v_b, idx));
    let half = T::lit(0.5);
    let w: Vec3<T> =
        std::array::from_fn(|q| (0..3).fold(T::zero(), |s, d| s + half * (va[d] + vb[d]) * gn[d][q]));
    skew(&cross(&cell_vector(normal, idx), &w))
}

/// The flux-form tendency of [`advective_tendency`] with the stencil values from `at`.
#[inline(always)]
fn tendency_from<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    idx: usize,
    scheme: StrainAdvection,
    at: impl Fn(usize) -> Sym<T>,
) -> Sym<T> {
    let st = grid.strides();
    let h = grid.h();
    let mut out = [T::zero(); 6];
    let mut div = T::zero();
    let c0 = at(idx);
    for d in 0..3 {
        let s = st[d];
        let ih = T::one() / h[d];
        let u_lo = v.c[d].data[idx];
        let u_hi = v.c[d].data[idx + s];
        div += (u_hi - u_lo) * ih;
        let (m2, m1, p1, p2) = (at(idx - 2 * s), at(idx - s), at(idx + s), at(idx + 2 * s));
        let (f_lo, f_hi): (Sym<T>, Sym<T>) = match scheme {
            StrainAdvection::Upwind3 => (
                std::array::from_fn(|k| upwind3_face(u_lo, m2[k], m1[k], c0[k], p1[k])),
                std::array::from_fn(|k| upwind3_face(u_hi, m1[k], c0[k], p1[k], p2[k])),
            ),
            StrainAdvection::Upwind5 => {
                let (m3, p3) = (at(idx - 3 * s), at(idx + 3 * s));
                (
                    std::array::from_fn(|k| upwind5_face(u_lo, m3[k], m2[k], m1[k], c0[k], p1[k], p2[k])),
                    std::array::from_fn(|k| upwind5_face(u_hi, m2[k], m1[k], c0[k], p1[k], p2[k], p3[k])),
                )
            }
        };
        for k in 0..6 {
            out[k] += (u_hi * f_hi[k] - u_lo * f_lo[k]) * ih;
        }
    }
    for k in 0..6 {
        out[k] -= c0[k] * div;
    }
    out
}

/// Sets `G_s = P = I − n n` in every interior cell (the stress-free initial state; ghosts are
/// not touched). O(box): for initialisation.
pub fn fill_projector<T: Real>(grid: &Grid<T>, normal: &[Field<T>; 3], gs: &mut SymField<T>) {
    for (c, comp) in gs.c.iter_mut().enumerate() {
        par_interior_update(grid, &mut comp.data, |idx, _, _, _, _| projector(&cell_vector(normal, idx))[c]);
    }
}

/// The paper's re-set over the whole box: `G_s = P` in every interior cell that is not a band
/// cell (`δ h < ε`). O(box): for output or after a jump of the interface; a step of
/// [`StrainTransport`] does this only near the band.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `grid` if `band` was made for another grid.
pub fn reset_outside_band<T: Real>(
    grid: &Grid<T>,
    band: &Band<T>,
    normal: &[Field<T>; 3],
    gs: &mut SymField<T>,
) -> Result<()> {
    band.matches(grid)?;
    for (c, comp) in gs.c.iter_mut().enumerate() {
        par_interior_update(grid, &mut comp.data, |idx, _, _, _, old| {
            if band.contains(idx) { old } else { projector(&cell_vector(normal, idx))[c] }
        });
    }
    Ok(())
}

/// The `G_s` transport (2.40) with its AB2 history and work arrays (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct StrainTransport<T> {
    grid: Grid<T>,
    scheme: StrainAdvection,
    frame: bool,
    /// Position in `prev_cells` of every interior storage index, or `NONE`.
    slot: Vec<u32>,
    prev_cells: Vec<usize>,
    prev_adv: Vec<Sym<T>>,
    adv: Vec<Sym<T>>,
    new_g: Vec<Sym<T>>,
    has_history: bool,
    /// Generation of the band of the step computed by `prepare` and not yet committed (0: none).
    prepared: u64,
}

impl<T: Real> StrainTransport<T> {
    /// A transport on `grid`, without history (the first step uses forward Euler for the
    /// advection). Allocates one `u32` per stored cell for the history map.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `grid` if it has `2^32 − 1` stored cells or more.
    pub fn new(grid: &Grid<T>) -> Result<Self> {
        if grid.len() >= NONE as usize {
            return Err(Error::invalid("grid", grid.len(), "fewer than 2^32 - 1 stored cells"));
        }
        Ok(StrainTransport {
            grid: grid.clone(),
            scheme: StrainAdvection::default(),
            frame: false,
            slot: vec![NONE; grid.len()],
            prev_cells: Vec::new(),
            prev_adv: Vec::new(),
            adv: Vec::new(),
            new_g: Vec::new(),
            has_history: false,
            prepared: 0,
        })
    }

    /// The same transport with the face reconstruction `scheme` (default
    /// [`StrainAdvection::Upwind3`]).
    pub fn with_advection(mut self, scheme: StrainAdvection) -> Self {
        self.scheme = scheme;
        self
    }

    /// The face reconstruction in use.
    pub fn advection(&self) -> StrainAdvection {
        self.scheme
    }

    /// The same transport in the tangent frame (`on = true`; default off): the advection
    /// turns every stencil value into the cell's tangent plane
    /// ([`advective_tendency_in_frame`]) and the stretching term leaves out that turn of the
    /// frame along the path (see the [module docs](self)). Not in the paper.
    pub fn with_tangent_frame(mut self, on: bool) -> Self {
        self.frame = on;
        self
    }

    /// Whether the transport works in the tangent frame.
    pub fn tangent_frame(&self) -> bool {
        self.frame
    }

    /// Forgets the AB2 history (the next step uses forward Euler), e.g. after a restart from a
    /// state without history or a change of the time step.
    pub fn reset_history(&mut self) {
        for &idx in &self.prev_cells {
            self.slot[idx] = NONE;
        }
        self.prev_cells.clear();
        self.prev_adv.clear();
        self.has_history = false;
    }

    /// Whether the next step uses AB2 (a previous tendency is stored).
    pub fn has_history(&self) -> bool {
        self.has_history
    }

    /// Moves the AB2 history with a capsule's box rolled by `by` cells along `axis`
    /// ([`Window::roll`](crate::grid::Window::roll): cell `b` takes the value of cell `b + by`,
    /// round the ring).
    pub fn roll(&mut self, axis: usize, by: isize) {
        if !self.has_history || axis > 2 {
            return;
        }
        let g = &self.grid;
        let (dims, n) = (g.dims(), g.n()[axis] as isize);
        let cells: Vec<usize> = self
            .prev_cells
            .iter()
            .map(|&idx| {
                let mut c = [idx % dims[0], (idx / dims[0]) % dims[1], idx / (dims[0] * dims[1])];
                let b = c[axis] as isize - GHOST as isize;
                c[axis] = ((b - by).rem_euclid(n) + GHOST as isize) as usize;
                c[0] + dims[0] * (c[1] + dims[1] * c[2])
            })
            .collect();
        let tend = std::mem::take(&mut self.prev_adv);
        // The cells are interior cells of the same grid and the tendencies finite: this holds.
        let _ = self.restore_history(&cells, &tend);
    }

    /// Moves the transport onto the grid `to_grid` of a grown capsule box `to`, from the box
    /// `from` of its grid (see [`Window::grown`](crate::grid::Window::grown)): the AB2 history
    /// cell for cell of the whole grid.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `grid` if `from_grid` is not this transport's grid, or
    /// as [`new`](Self::new) for `to_grid`; the transport is then unchanged.
    pub fn regrow(
        &mut self,
        from: &crate::grid::Window,
        from_grid: &Grid<T>,
        to: &crate::grid::Window,
        to_grid: &Grid<T>,
    ) -> Result<()> {
        if from_grid.dims() != self.grid.dims() {
            return Err(Error::invalid("grid", format!("{:?} cells", from_grid.n()), "the transport's grid"));
        }
        let mut moved = Self::new(to_grid)?.with_advection(self.scheme).with_tangent_frame(self.frame);
        if let Some((cells, tend)) = self.history() {
            let (cells, tend): (Vec<usize>, Vec<Sym<T>>) = cells
                .iter()
                .zip(tend)
                .filter_map(|(&idx, t)| Some((from.transfer_index(from_grid, to, to_grid, idx)?, *t)))
                .unzip();
            moved.restore_history(&cells, &tend)?;
        }
        *self = moved;
        Ok(())
    }

    /// The AB2 history, for checkpoints: the storage indices of the cells with a stored
    /// advective tendency and those tendencies (`None` before the first step).
    pub fn history(&self) -> Option<(&[usize], &[Sym<T>])> {
        self.has_history.then_some((self.prev_cells.as_slice(), self.prev_adv.as_slice()))
    }

    /// Restores a history saved from [`history`](Self::history) on the same grid.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `history` if the lengths differ, an index is not an
    /// interior cell of the grid, or a tendency is not finite. The history is then left as it
    /// was.
    pub fn restore_history(&mut self, cells: &[usize], tendencies: &[Sym<T>]) -> Result<()> {
        let g = &self.grid;
        let interior = |idx: usize| {
            let (row, i) = (idx / g.dims()[0], idx % g.dims()[0]);
            idx < g.len() && g.row_jk(row).is_some() && (GHOST..GHOST + g.n()[0]).contains(&i)
        };
        if cells.len() != tendencies.len()
            || !cells.iter().all(|&c| interior(c))
            || !tendencies.iter().all(|t| t.iter().all(|x| x.is_finite()))
        {
            return Err(Error::invalid(
                "history",
                format!("{} cells, {} tendencies", cells.len(), tendencies.len()),
                "interior cells of this grid with as many finite tendencies (from StrainTransport::history)",
            ));
        }
        self.reset_history();
        self.prev_cells.extend_from_slice(cells);
        self.prev_adv.extend_from_slice(tendencies);
        for (p, &idx) in cells.iter().enumerate() {
            self.slot[idx] = p as u32;
        }
        self.has_history = true;
        Ok(())
    }

    /// Advances `gs` from `Gⁿ` to `G^{n+1}` by (2.40) and applies the re-set near the band.
    ///
    /// Inputs: `band` of step `n+1`; `dt`; `v_old = vⁿ` and `v_new = v^{n+1}` (staggered, ghosts
    /// filled); `normal = n^{n+1}` at cell centres (for `P^{n+1}` of the re-set). The ghosts of
    /// `gs` are filled here.
    ///
    /// # Errors
    /// - [`Error::InvalidParameter`] naming `grid` (another grid than [`new`](Self::new)'s, or
    ///   the band's), `dt` (not finite and `> 0`) or a field of the wrong size;
    /// - [`Error::NonFinite`] naming `G_s` at the first band cell whose new value is not finite.
    ///
    /// On error the interior of `gs` and the history are left as they were.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        dt: T,
        v_old: &VectorField<T>,
        v_new: &VectorField<T>,
        normal: &[Field<T>; 3],
        gs: &mut SymField<T>,
    ) -> Result<()> {
        if gs.c.iter().all(|f| f.data.len() == grid.len()) {
            gs.fill_ghosts(grid);
        }
        self.prepare(grid, band, dt, v_old, v_new, normal, gs)?;
        self.commit(band, normal, gs)
    }

    /// Computes `G^{n+1}` on the band into a work array, without touching `gs` (ghosts filled)
    /// or the history: [`commit`](Self::commit) writes it (the first phase of
    /// [`step`](Self::step), for drivers that must know that every part of a step succeeded
    /// before they change any state). Same inputs and errors as [`step`](Self::step).
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        dt: T,
        v_old: &VectorField<T>,
        v_new: &VectorField<T>,
        normal: &[Field<T>; 3],
        gs: &SymField<T>,
    ) -> Result<()> {
        self.prepared = 0;
        if !grid.same_cells(&self.grid) {
            return Err(Error::invalid(
                "grid",
                format!("{:?} cells", grid.n()),
                "the grid of StrainTransport::new",
            ));
        }
        band.matches(grid)?;
        positive("dt", dt)?;
        let len = grid.len();
        let sizes = [
            ("v_old", v_old.c.iter().all(|f| f.data.len() == len)),
            ("v_new", v_new.c.iter().all(|f| f.data.len() == len)),
            ("normal", normal.iter().all(|f| f.data.len() == len)),
            ("gs", gs.c.iter().all(|f| f.data.len() == len)),
        ];
        if let Some((name, _)) = sizes.iter().find(|(_, ok)| !ok) {
            return Err(Error::invalid(name, "a field of another grid", "a field of the band's grid"));
        }
        let gs_ro: &SymField<T> = gs;

        // 1. A(vⁿ, Gⁿ) on halo(1).
        let cells1 = band.halo(1);
        let (scheme, frame) = (self.scheme, self.frame);
        self.adv.resize(cells1.len(), [T::zero(); 6]);
        self.adv.par_iter_mut().zip(cells1.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(
            |(a, &idx)| {
                *a = if frame {
                    advective_tendency_in_frame(grid, v_old, gs_ro, normal, idx, scheme)
                } else {
                    advective_tendency(grid, v_old, gs_ro, idx, scheme)
                }
            },
        );

        // 2. G^{n+1} on the band.
        let nb = band.len();
        self.new_g.resize(nb, [T::zero(); 6]);
        let (slot, prev_adv, adv) = (&self.slot, &self.prev_adv, &self.adv);
        let history = self.has_history;
        let (ab_new, ab_old) = (T::lit(1.5), T::lit(-0.5));
        let half = T::lit(0.5);
        self.new_g.par_iter_mut().enumerate().with_min_len(MIN_CELLS_PER_TASK).for_each(|(p, out)| {
            let idx = cells1[p];
            let a_n = adv[p];
            let prev = if history { slot[idx] } else { NONE };
            let tendency: Sym<T> = if prev == NONE {
                a_n
            } else {
                let a_p = prev_adv[prev as usize];
                std::array::from_fn(|k| ab_new * a_n[k] + ab_old * a_p[k])
            };
            let g0 = grad_v_at_cell(grid, v_old, idx);
            let g1 = grad_v_at_cell(grid, v_new, idx);
            let mut gv: [[T; 3]; 3] =
                std::array::from_fn(|i| std::array::from_fn(|j| half * (g0[i][j] + g1[i][j])));
            if frame {
                let turn = frame_turn(grid, v_old, v_new, normal, idx);
                gv = std::array::from_fn(|i| std::array::from_fn(|j| gv[i][j] + turn[i][j]));
            }
            let g = gs_ro.get(idx);
            let r = stretching(&gv, &g);
            *out = std::array::from_fn(|k| g[k] + dt * (r[k] - tendency[k]));
        });
        if let Some(p) = self.new_g.iter().position(|g| !g.iter().all(|x| x.is_finite())) {
            let c = band.coords(0)[p];
            return Err(Error::NonFinite {
                field: "G_s",
                cell: [c[0] as usize, c[1] as usize, c[2] as usize],
            });
        }

        self.prepared = band.generation();
        Ok(())
    }

    /// Writes the values computed by the last successful [`prepare`](Self::prepare) (same band,
    /// normal and `gs`): band values, re-set around the band, history.
    ///
    /// # Errors
    /// [`Error::Unsupported`] when no step was prepared on `band` (none, another band, or the
    /// band was rebuilt since); `gs` and the history are unchanged.
    pub fn commit(&mut self, band: &Band<T>, normal: &[Field<T>; 3], gs: &mut SymField<T>) -> Result<()> {
        if self.prepared == 0 || self.prepared != band.generation() {
            return Err(Error::Unsupported {
                component: "StrainTransport::commit",
                detail: "no step prepared on this band: call prepare with it first".into(),
            });
        }
        self.prepared = 0;
        let nb = band.len();
        let cells1 = band.halo(1);
        for (&idx, g) in band.cells().iter().zip(&self.new_g) {
            gs.set(idx, g);
        }
        for &idx in &band.halo(super::band::MAX_HALO)[nb..] {
            gs.set(idx, &projector(&cell_vector(normal, idx)));
        }
        for &idx in &self.prev_cells {
            self.slot[idx] = NONE;
        }
        self.prev_cells.clear();
        self.prev_cells.extend_from_slice(cells1);
        for (p, &idx) in cells1.iter().enumerate() {
            self.slot[idx] = p as u32;
        }
        std::mem::swap(&mut self.prev_adv, &mut self.adv);
        self.has_history = true;
        Ok(())
    }
}
