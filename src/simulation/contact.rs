//! Contact between capsules: a short-range repulsion ([`Contact`]) that keeps the surfaces of
//! two capsules apart when the film between them becomes thinner than the grid resolves, and the
//! smallest gap between any two membranes ([`min_gap_cells`]).
//!
//! Each capsule has its own `phi`, so capsules never merge numerically; but nothing stops their
//! `phi = 1/2` surfaces from crossing once the lubrication film between them is a cell or two
//! thick, which the grid no longer resolves. [`Contact`] adds the disjoining pressure of a
//! harmonic soft-contact law between every pair of capsules whose surfaces come closer than its
//! range.
//!
//! # Distances from `phi`
//!
//! The MTHINC profile is `phi = (1 + tanh(beta s / h)) / 2` of the signed distance `s` to the
//! surface (positive inside), so `psi = atanh(2 phi - 1)` ([`psi_of`]) gives it back:
//! `s = psi h / beta` (`h` the [`characteristic_length`] of the grid, the cell spacing of a
//! uniform grid), the construction of
//! [`SurfaceExtension`](crate::membrane::extension::SurfaceExtension). The distance outside capsule `c` is
//! `d_c = -s_c`, and for two capsules `a`, `b`
//!
//! ```text
//! g(x) = d_a(x) + d_b(x)
//! ```
//!
//! is, at every point of the film between them, the local gap between the two surfaces (exactly
//! along the line joining their closest points, and larger elsewhere): its minimum is the gap.
//! `s` is read only where both `phi` lie in `(tiny, 1 - tiny)`, `tiny` =
//! `max(1e-6, 1000 eps)`, the default [`AdvectionParams::tiny`](crate::interface::advect::AdvectionParams::tiny) (the cells that MTHINC reconstructs with a profile), so up to
//! `psi_max h / beta` from each surface, `psi_max = atanh(1 - 2 tiny)`: 6.9 cells at `beta = 1`
//! in `f64`, 4.5 in `f32`.
//!
//! # The potential
//!
//! Per unit area of the film, the harmonic soft-contact energy and its disjoining pressure are
//!
//! ```text
//! V(g) = p0 r / 2 (1 - g / r)^2,   Pi(g) = -V'(g) = p0 (1 - g / r)     for g < r,
//! V = Pi = 0                                                            for g >= r,
//! ```
//!
//! with the **range** `r` (a number of cells, `range_cells`, times `h`) and the **strength**
//! `p0`, the disjoining pressure at zero gap (a pressure: force per unit area, Pa, like the
//! fluid's; it grows on linearly, to `2 p0` at `g = -r`, where the surfaces have crossed). The
//! energy stored is, summed over the pairs,
//!
//! ```text
//! E = sum over pairs  integral V(g) (delta_a + delta_b) / 2 dV
//! ```
//!
//! (`delta = |grad phi|`): `g` is constant across a flat film, so each film line carries
//! `V(gap)` and `E` is `V(gap)` per unit area of the film.
//!
//! # The force
//!
//! The pressure `Pi` acts across the film as a normal stress, which is put in divergence form
//!
//! ```text
//! f = div sigma,   sigma = Pi(g) (1 - phi_a - phi_b) sym(n_a ⊗ n_b)
//! ```
//!
//! (`n_c` the unit normal of capsule `c`, into it): in the film `n_a = -n_b = -N`, so `sigma =
//! -Pi N N`, a compression along the film normal `N`, zero inside either capsule
//! (`1 - phi_a - phi_b = 0`) and of the other sign where they overlap (`= -1`). Its divergence
//! is
//!
//! ```text
//! f = -Pi sym(n_a ⊗ n_b) (grad phi_a + grad phi_b) + (1 - phi_a - phi_b) div(Pi sym(n_a ⊗ n_b)),
//! ```
//!
//! a pressure `Pi` on each membrane pushing it into its own capsule, away from the other
//! (`-Pi S grad phi_a ≈ Pi delta_a n_a`), plus a small body force on the film fluid (zero across
//! a flat film, where `g` is constant along `N`; of relative size `g / R` between curved
//! membranes of radius `R`). The force on each membrane is the derivative of `E` under a
//! displacement of that membrane with its profile (how MTHINC carries it): `-dE/dX_b` of a
//! capsule `b` moved rigidly is the pressure on its membrane, to the few per cent the test
//! `force_is_minus_the_energy_gradient` measures.
//!
//! **Momentum** is conserved exactly: `sigma` is built at cell centres and `f` is its discrete
//! divergence on the faces, whose sum over a periodic box telescopes to zero (to round-off); the
//! two membranes get equal and opposite pushes up to the film term above. Walls take the part
//! of a film that touches them (the capsules keep two profile widths from walls, so in practice
//! none).
//!
//! **Energy**: [`Contact`] is [`EnergyRole::Stored`]: `E` is added to
//! [`Simulation::elastic_energy`](super::Simulation::elastic_energy) and the work of the force is
//! not counted as external work, so the budget `kinetic + stored + dissipated - work` stays
//! balanced to the accuracy with which `f` is the gradient of `E` (the same few per cent during
//! contact; exactly zero before and after it).
//!
//! # Cost
//!
//! Only pairs of capsules whose bounding boxes (of their membrane bands with
//! [`MAX_HALO`] layers, which include the capsules) overlap are examined, and only the cells of
//! the overlap: nothing is done for capsules far apart, and a contact costs a pass over a box a
//! few cells thick. The stress is assembled in one tensor field allocated when the simulation
//! is built (only for two or more capsules).
//!
//! # Choosing the parameters
//!
//! Between two rigid spheres of radius `R` pushed together with a force `F`, the law holds the
//! gap `g` where `F = p0 pi R (r - g)^2 / (2 r)` (the pressure integrated over the film,
//! `g(rho) = g + rho^2 / R`): for a gap of about a cell, `p0 ≈ 2 r F / (pi R (r - g)^2)`, a few
//! tens of times the stresses that push the capsules (the load per area, `mu gamma_dot`). A
//! range of 1.5 to 3 cells keeps the film resolved by both profiles. The force is explicit: a
//! spring of stiffness `p0 / r` per unit area; the integration test `tests/contact.rs` is
//! stable at `dt = 0.4 mu r / (p0 h)` (no time-step limit is declared: check yours).
//!
//! What it does at coarse resolution, measured there (capsules of radius 5 cells, `E_s = 2`,
//! pushed together by a force of 2.6 each from a gap of 1.06 cells, `p0 = 200`, `r = 2`
//! cells): with the contact the film opens to 1.12 cells and holds while the push goes on; without
//! it, it thins to 0.99 cells by `t = 0.6`. The smoothed membranes themselves resist the
//! draining of a film a few cells thick (the fluid within a membrane's shell carries its force),
//! so films thin slowly at this resolution; the contact is the guard for when they do.

use super::Simulation;
use super::effect::{Capsules, Effect, EnergyRole, Setup, StepState};
use super::view::{LevelChoice, MembraneView};
use crate::error::positive;
use crate::grid::{Grid, SymField, VectorField};
use crate::interface::advect::{characteristic_length, default_tiny};
use crate::interface::geometry::psi_of;
use crate::membrane::band::{Band, MAX_HALO};
use crate::tensor::sym_index;
use crate::{Error, Real, Result};
use std::sync::{Mutex, PoisonError};

/// The largest range of a [`Contact`], in cells.
pub const MAX_RANGE_CELLS: f64 = 4.0;

/// A short-range repulsion between the membranes of every pair of capsules: the harmonic
/// soft-contact law `Pi(g) = p0 (1 - g / r)` for gaps `g` below the range `r`, as the stress
/// `sigma = Pi (1 - phi_a - phi_b) sym(n_a ⊗ n_b)` across the film (see the
/// [module docs](self) for the potential, the force, its momentum and energy).
///
/// `p0` is a pressure (the disjoining pressure at zero gap); `r` is given in cells.
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::law::NeoHookean;
/// use eulermembrane::simulation::{contact::Contact, Phase, Scene, contact::min_gap_cells};
///
/// // Two capsules 1.5 cells apart (h = 1/16), pushed apart by a pressure of 20 within 2 cells.
/// let grid = Grid::<f64>::periodic([32, 16, 16], [0.0; 3], [2.0, 1.0, 1.0])?;
/// let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.703125, 0.5, 0.5], 0.25)?)
///     .capsule(Sphere::new([1.296875, 0.5, 0.5], 0.25)?)
///     .elasticity(NeoHookean::new(1.0)?)
///     .effect(Contact::new(20.0, 2.0)?)
///     .build()?;
/// let gap0 = min_gap_cells(&sim).unwrap();
/// assert!((gap0 - 1.5).abs() < 0.2);
/// assert!(sim.elastic_energy() > 0.0); // the contact energy of the film
/// for _ in 0..3 {
///     sim.step(2e-3)?;
/// }
/// assert!(min_gap_cells(&sim).unwrap() > gap0); // pushed apart
/// // Bad parameters are refused, naming them.
/// assert!(Contact::<f64>::new(20.0, 0.0).unwrap_err().to_string().contains("range_cells"));
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub struct Contact<T: Real> {
    law: Law<T>,
    capsules: Capsules,
    /// The film stress, assembled by `add_force` (allocated by `attach` for two or more
    /// capsules; zero between calls).
    sigma: Mutex<Option<SymField<T>>>,
}

impl<T: Real> std::fmt::Debug for Contact<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Contact")
            .field("pressure", &self.law.p0)
            .field("range_cells", &self.law.range_cells)
            .field("capsules", &self.capsules)
            .finish()
    }
}

impl<T: Real> Contact<T> {
    /// Contact between every pair of capsules with the disjoining pressure `pressure` (`p0`, a
    /// pressure) at zero gap and the range `range_cells` (`r / h`, in cells).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `pressure` unless it is finite and `> 0`, or naming
    /// `range_cells` unless it is in `(0, 4]` ([`MAX_RANGE_CELLS`]). The profiles of the two
    /// membranes must also resolve the range: [`Scene::build`](super::Scene::build) refuses,
    /// naming `range_cells`, a range above `(atanh(1 - 2 tiny) - 1) / beta` cells (5.9 at
    /// `beta = 1` in `f64`, 3.5 in `f32`; see the [module docs](self)).
    pub fn new(pressure: T, range_cells: T) -> Result<Self> {
        positive("pressure", pressure)?;
        let r = range_cells.f64();
        if !(r.is_finite() && r > 0.0 && r <= MAX_RANGE_CELLS) {
            return Err(Error::invalid("range_cells", range_cells, "a number of cells in (0, 4]"));
        }
        Ok(Contact {
            law: Law { p0: pressure, range_cells },
            capsules: Capsules::All,
            sigma: Mutex::new(None),
        })
    }

    /// The same contact between the capsules with these indices only (a capsule outside the
    /// list neither pushes nor is pushed).
    pub fn only(mut self, capsules: impl IntoIterator<Item = usize>) -> Self {
        self.capsules = Capsules::Only(capsules.into_iter().collect());
        self
    }

    /// The disjoining pressure `p0` at zero gap.
    pub fn pressure(&self) -> T {
        self.law.p0
    }

    /// The range `r / h`, in cells.
    pub fn range_cells(&self) -> T {
        self.law.range_cells
    }

    /// The pairs of capsules this contact examines in `state`, with the overlap of their boxes.
    fn pairs<'a>(&self, state: &StepState<'a, T>) -> Result<Vec<Pair<'a, T>>> {
        let count = state.capsule_count();
        let selected = (0..count).filter(|&c| self.capsules.contains(c));
        pairs(state, selected)
    }
}

/// The harmonic soft-contact law `Pi(g) = p0 (1 - g / r)`.
#[derive(Debug, Clone, Copy)]
struct Law<T> {
    p0: T,
    range_cells: T,
}

/// The range `r` and the profile length `h / beta` of the capsules' `phi`, and the `phi` range
/// where their signed distances are read.
#[derive(Debug, Clone, Copy)]
struct Profile<T> {
    /// `h / beta`: `s = psi h / beta`.
    scale: T,
    /// `h`, the length of a cell.
    h: T,
    /// `tiny`: `phi` is read in `(tiny, 1 - tiny)`.
    tiny: T,
}

impl<T: Real> Profile<T> {
    fn new(grid: &Grid<T>, beta: T) -> Self {
        let h = characteristic_length(grid);
        Profile { scale: h / beta, h, tiny: default_tiny() }
    }

    /// The signed distance outside the surface at a cell of `phi`, `None` where `phi` is too
    /// close to 0 or 1 to tell.
    #[inline]
    fn distance(&self, phi: T) -> Option<T> {
        (phi > self.tiny && phi < T::one() - self.tiny).then(|| -psi_of(phi) * self.scale)
    }

    /// The largest distance from a surface that is read: `atanh(1 - 2 tiny) h / beta`.
    fn reach(&self) -> T {
        psi_of(T::one() - self.tiny) * self.scale
    }
}

/// Interior cells `lo..=hi` along each axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct CellBox {
    lo: [usize; 3],
    hi: [usize; 3],
}

impl CellBox {
    /// The bounding box of the band of a membrane and its [`MAX_HALO`] layers (`None` for an
    /// empty band).
    fn of_band<T: Real>(band: &Band<T>) -> Option<Self> {
        band.bounds(MAX_HALO).map(|(lo, hi)| CellBox { lo, hi })
    }

    fn union(&self, o: &Self) -> Self {
        CellBox {
            lo: std::array::from_fn(|d| self.lo[d].min(o.lo[d])),
            hi: std::array::from_fn(|d| self.hi[d].max(o.hi[d])),
        }
    }

    /// The box grown by one cell on every side, within the grid: an axis that would leave the
    /// grid across a periodic side becomes the whole axis (the cell across is the other end).
    fn grown<T: Real>(&self, grid: &Grid<T>) -> Self {
        let n = grid.n();
        let mut b = *self;
        for d in 0..3 {
            let out = b.lo[d] == 0 || b.hi[d] + 1 >= n[d];
            if out && grid.is_periodic(d) {
                b.lo[d] = 0;
                b.hi[d] = n[d] - 1;
            } else {
                b.lo[d] = b.lo[d].saturating_sub(1);
                b.hi[d] = (b.hi[d] + 1).min(n[d] - 1);
            }
        }
        b
    }

    /// Calls `f(storage index, [i, j, k])` for every cell, x fastest.
    fn for_each<T: Real>(&self, grid: &Grid<T>, mut f: impl FnMut(usize, [usize; 3])) {
        for k in self.lo[2]..=self.hi[2] {
            for j in self.lo[1]..=self.hi[1] {
                for i in self.lo[0]..=self.hi[0] {
                    f(grid.idx_u(i, j, k), [i, j, k]);
                }
            }
        }
    }
}

/// Two capsules whose boxes overlap, and the overlap: `region`, the grid's cells (unwrapped on
/// periodic axes) where both bands' boxes lie, and `cells`, those cells wrapped into the grid
/// (the whole axis where they cross a periodic side).
struct Pair<'a, T> {
    a: MembraneView<'a, T>,
    b: MembraneView<'a, T>,
    region: [(isize, isize); 3],
    cells: CellBox,
}

/// A cell of a pair's overlap: its storage index in the grid and in each capsule's box.
#[derive(Debug, Clone, Copy)]
struct PairCell {
    grid: usize,
    a: usize,
    b: usize,
}

/// The box coordinate of the grid's (unwrapped) cell `x` along axis `d` in the box of `m`, if it
/// holds it.
fn box_coord<T: Real>(grid: &Grid<T>, m: &MembraneView<'_, T>, d: usize, x: isize) -> Option<isize> {
    let n = grid.n()[d] as isize;
    let w = m.window;
    let l = match (w.rings()[d], w.segments()[d], grid.is_periodic(d)) {
        (true, _, _) => (x - w.first()[d]).rem_euclid(n),
        (false, true, _) => x - w.first()[d],
        (false, false, true) => x.rem_euclid(n),
        (false, false, false) => x,
    };
    (0..w.size()[d] as isize).contains(&l).then_some(l)
}

/// The band's box of `m` (with its halo layers) in the grid's unwrapped cells.
fn band_region<T: Real>(m: &MembraneView<'_, T>) -> Option<[(isize, isize); 3]> {
    let b = CellBox::of_band(m.band)?;
    let w = m.window;
    Some(std::array::from_fn(|d| {
        let off = if w.movable()[d] { w.first()[d] } else { 0 };
        (b.lo[d] as isize + off, b.hi[d] as isize + off)
    }))
}

/// The overlap of the intervals `a` and `b` of cells along an axis of `n` cells, periodic or not
/// (in `a`'s unwrapped cells).
fn overlap(a: (isize, isize), b: (isize, isize), n: isize, periodic: bool) -> Option<(isize, isize)> {
    let meet = |b: (isize, isize)| {
        let (lo, hi) = (a.0.max(b.0), a.1.min(b.1));
        (lo <= hi).then_some((lo, hi))
    };
    if !periodic {
        return meet(b);
    }
    if b.1 - b.0 + 1 >= n {
        return Some(a);
    }
    if a.1 - a.0 + 1 >= n {
        let k = (a.0 - b.0).div_euclid(n) + 1;
        return Some((b.0 + k * n, b.1 + k * n));
    }
    let k = (a.0 - b.0).div_euclid(n);
    (k - 1..=k + 2).find_map(|k| meet((b.0 + k * n, b.1 + k * n)))
}

/// The pairs of the capsules `selected` of `state` whose bands' boxes overlap.
fn pairs<'a, T: Real>(
    state: &StepState<'a, T>,
    selected: impl Iterator<Item = usize>,
) -> Result<Vec<Pair<'a, T>>> {
    let grid = state.grid;
    let n = grid.n();
    let mut boxed = Vec::new();
    for c in selected {
        let m = state.membrane(c)?;
        if let Some(r) = band_region(&m) {
            boxed.push((m, r));
        }
    }
    let mut out = Vec::new();
    for (i, (a, ra)) in boxed.iter().enumerate() {
        for (b, rb) in &boxed[i + 1..] {
            let region: [Option<(isize, isize)>; 3] =
                std::array::from_fn(|d| overlap(ra[d], rb[d], n[d] as isize, grid.is_periodic(d)));
            let [Some(x), Some(y), Some(z)] = region else { continue };
            let region = [x, y, z];
            let cells = CellBox {
                lo: std::array::from_fn(|d| wrapped_span(region[d], n[d]).0),
                hi: std::array::from_fn(|d| wrapped_span(region[d], n[d]).1),
            };
            out.push(Pair { a: *a, b: *b, region, cells });
        }
    }
    Ok(out)
}

/// The cells `lo..=hi` (unwrapped) wrapped into `0..n`: the whole axis where they cross a side.
fn wrapped_span((lo, hi): (isize, isize), n: usize) -> (usize, usize) {
    let (a, b) = (lo.rem_euclid(n as isize) as usize, hi.rem_euclid(n as isize) as usize);
    if hi - lo + 1 >= n as isize || a > b { (0, n - 1) } else { (a, b) }
}

/// Calls `f(cell, g)` at every cell of the pair's overlap where both signed distances are read,
/// with the local gap `g = d_a + d_b`, x fastest.
fn for_each_gap<T: Real>(grid: &Grid<T>, p: &Profile<T>, pair: &Pair<'_, T>, mut f: impl FnMut(PairCell, T)) {
    let (a, b) = (&pair.a, &pair.b);
    let r = pair.region;
    for z in r[2].0..=r[2].1 {
        let (Some(az), Some(bz)) = (box_coord(grid, a, 2, z), box_coord(grid, b, 2, z)) else { continue };
        for y in r[1].0..=r[1].1 {
            let (Some(ay), Some(by)) = (box_coord(grid, a, 1, y), box_coord(grid, b, 1, y)) else { continue };
            for x in r[0].0..=r[0].1 {
                let (Some(ax), Some(bx)) = (box_coord(grid, a, 0, x), box_coord(grid, b, 0, x)) else {
                    continue;
                };
                let at = PairCell {
                    grid: grid.idx(wrap(grid, 0, x), wrap(grid, 1, y), wrap(grid, 2, z)),
                    a: a.grid.idx(ax, ay, az),
                    b: b.grid.idx(bx, by, bz),
                };
                if let (Some(da), Some(db)) = (p.distance(a.phi.data[at.a]), p.distance(b.phi.data[at.b])) {
                    f(at, da + db);
                }
            }
        }
    }
}

/// The grid's cell of the unwrapped cell `x` along axis `d`.
fn wrap<T: Real>(grid: &Grid<T>, d: usize, x: isize) -> isize {
    if grid.is_periodic(d) { x.rem_euclid(grid.n()[d] as isize) } else { x }
}

impl<T: Real> Law<T> {
    /// `r`, the range as a length.
    fn range(&self, p: &Profile<T>) -> T {
        self.range_cells * p.h
    }

    /// `Pi(g)`.
    #[inline]
    fn pressure(&self, g: T, r: T) -> T {
        if g < r { self.p0 * (T::one() - g / r) } else { T::zero() }
    }

    /// `V(g)`.
    #[inline]
    fn energy(&self, g: T, r: T) -> f64 {
        if g < r {
            let x = (T::one() - g / r).f64();
            0.5 * (self.p0 * r).f64() * x * x
        } else {
            0.0
        }
    }

    /// `sym(n_a ⊗ n_b)` and `Pi(g)` at a cell where `Pi > 0`: calls `f(idx, Pi, S)`.
    fn for_each_stress(
        &self,
        grid: &Grid<T>,
        p: &Profile<T>,
        pair: &Pair<'_, T>,
        mut f: impl FnMut(PairCell, T, [T; 6]),
    ) {
        let r = self.range(p);
        let half = T::lit(0.5);
        let (na, nb) = (pair.a.normal, pair.b.normal);
        for_each_gap(grid, p, pair, |at, g| {
            let pi = self.pressure(g, r);
            if pi == T::zero() {
                return;
            }
            let a: [T; 3] = std::array::from_fn(|d| na[d].data[at.a]);
            let b: [T; 3] = std::array::from_fn(|d| nb[d].data[at.b]);
            let mut s = [T::zero(); 6];
            for d in 0..3 {
                for e in d..3 {
                    s[sym_index(d, e)] = half * (a[d] * b[e] + a[e] * b[d]);
                }
            }
            f(at, pi, s);
        });
    }

    /// Adds `sigma = Pi (1 - phi_a - phi_b) S` of the pair to `sigma`.
    fn add_stress(&self, grid: &Grid<T>, p: &Profile<T>, pair: &Pair<'_, T>, sigma: &mut SymField<T>) {
        let (pa, pb) = (pair.a.phi, pair.b.phi);
        self.for_each_stress(grid, p, pair, |at, pi, s| {
            let w = pi * (T::one() - pa.data[at.a] - pb.data[at.b]);
            for (c, sc) in sigma.c.iter_mut().zip(s) {
                c.data[at.grid] += w * sc;
            }
        });
    }

    /// `sum V(g) (delta_a + delta_b) / 2 h^3` over the pair's box.
    fn pair_energy(&self, grid: &Grid<T>, p: &Profile<T>, pair: &Pair<'_, T>) -> f64 {
        let r = self.range(p);
        let (da, db) = (pair.a.delta, pair.b.delta);
        let mut e = 0.0;
        for_each_gap(grid, p, pair, |at, g| {
            let v = self.energy(g, r);
            if v > 0.0 {
                e += v * 0.5 * (da.data[at.a] + db.data[at.b]).f64();
            }
        });
        e * grid.cell_volume().f64()
    }
}

/// Adds `div sigma` on the faces around the cells `cells` to `out` (component `d` on the faces
/// normal to `d`; wall faces left out), `sigma` with its ghosts filled.
fn add_divergence<T: Real>(grid: &Grid<T>, sigma: &SymField<T>, cells: &CellBox, out: &mut VectorField<T>) {
    let st = grid.strides();
    let h = grid.h();
    let quarter = T::lit(0.25);
    cells.grown(grid).for_each(grid, |idx, ijk| {
        for d in 0..3 {
            if !grid.is_periodic(d) && ijk[d] == 0 {
                continue;
            }
            let m = idx - st[d];
            let dd = &sigma.c[sym_index(d, d)].data;
            let mut f = (dd[idx] - dd[m]) / h[d];
            for e in (0..3).filter(|&e| e != d) {
                let s = &sigma.c[sym_index(d, e)].data;
                let se = st[e];
                f += quarter * (s[idx + se] + s[m + se] - s[idx - se] - s[m - se]) / h[e];
            }
            out.c[d].data[idx] += f;
        }
    });
}

impl<T: Real> Effect<T> for Contact<T> {
    fn name(&self) -> &str {
        "contact"
    }
    fn describe(&self) -> String {
        format!(
            "contact pressure={:e} range_cells={} capsules={:?}",
            self.law.p0.f64(),
            self.law.range_cells.f64(),
            self.capsules
        )
    }
    fn acts_on(&self, c: usize) -> bool {
        self.capsules.contains(c)
    }
    fn energy_role(&self) -> EnergyRole {
        EnergyRole::Stored
    }
    fn attach(&mut self, setup: &Setup<'_, T>) -> Result<()> {
        self.capsules.validate("contact", setup.capsules)?;
        let beta = setup.settings.advection.beta;
        let p = Profile::new(setup.grid, beta);
        // The gap at a membrane must be read from the other capsule's profile, a cell beyond.
        let resolved = (p.reach() / p.h).f64() - 1.0 / beta.f64();
        if self.law.range_cells.f64() > resolved {
            return Err(Error::invalid(
                "range_cells",
                format!(
                    "{} cells with beta = {} (the profiles resolve distances to {resolved:.2} cells)",
                    self.law.range_cells,
                    beta.f64()
                ),
                "a range within what the profiles resolve, atanh(1 - 2 tiny) / beta - 1 / beta cells",
            ));
        }
        let selected = (0..setup.capsules).filter(|&c| self.capsules.contains(c)).count();
        let sigma = (selected >= 2).then(|| SymField::zeros(setup.grid));
        *self.sigma.get_mut().unwrap_or_else(PoisonError::into_inner) = sigma;
        Ok(())
    }
    fn is_active(&self, state: &StepState<'_, T>) -> bool {
        self.pairs(state).is_ok_and(|p| !p.is_empty())
    }
    fn add_force(
        &self,
        state: &StepState<'_, T>,
        _: &VectorField<T>,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        let grid = state.grid;
        out.matches(grid, "force")?;
        let pairs = self.pairs(state)?;
        let Some(cells) = pairs.iter().map(|p| p.cells).reduce(|a, b| a.union(&b)) else {
            return Ok(());
        };
        let p = Profile::new(grid, state.settings.advection.beta);
        let mut guard = self.sigma.lock().unwrap_or_else(PoisonError::into_inner);
        let sigma = guard.get_or_insert_with(|| SymField::zeros(grid));
        for pair in &pairs {
            self.law.add_stress(grid, &p, pair, sigma);
        }
        sigma.fill_ghosts(grid);
        add_divergence(grid, sigma, &cells, out);
        // Leave the stress zero for the next call (ghosts are refilled from the interior).
        for c in sigma.c.iter_mut() {
            cells.for_each(grid, |idx, _| c.data[idx] = T::zero());
        }
        Ok(())
    }
    fn stored_energy(&self, state: &StepState<'_, T>) -> f64 {
        let Ok(pairs) = self.pairs(state) else { return 0.0 };
        let p = Profile::new(state.grid, state.settings.advection.beta);
        pairs.iter().map(|pair| self.law.pair_energy(state.grid, &p, pair)).sum()
    }
}

/// The smallest distance between the `phi = 1/2` surfaces of any two capsules of `sim`, in
/// cells (of the [`characteristic_length`] `h`): the minimum of `(d_a + d_b) / h` over the cells
/// where the boxes of two capsules' bands overlap and both signed distances are read (see the
/// [module docs](self)); negative where two surfaces have crossed (then minus the largest
/// depth of the overlap along the line of centres). For two spheres it is off by the distortion
/// of `psi` by the cell averages of the profile, which pulls it towards zero, and by the offset
/// of the nearest cell from the line joining the closest points: within 0.11 cell for gaps from
/// -1 to 4.6 cells in the test `min_gap_of_two_spheres`.
///
/// `None` with fewer than two capsules; `Some(f64::INFINITY)` when no two capsules come close
/// enough for their profiles to meet (about `2 atanh(1 - 2 tiny) / beta` cells: 13.8 at
/// `beta = 1` in `f64`, 9 in `f32`). Costs a pass over the overlaps of the boxes, like
/// [`Contact`]; it does not need a [`Contact`] in the scene.
pub fn min_gap_cells<T: Real>(sim: &Simulation<T>) -> Option<f64> {
    let state = sim.state(LevelChoice::Current);
    let count = state.capsule_count();
    if count < 2 {
        return None;
    }
    let p = Profile::new(state.grid, state.settings.advection.beta);
    let pairs = pairs(&state, 0..count).ok()?;
    let mut min = T::infinity();
    for pair in &pairs {
        for_each_gap(state.grid, &p, pair, |_, g| min = min.min(g));
    }
    Some((min / p.h).f64())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interface::shapes::Sphere;
    use crate::simulation::{Phase, Scene, Settings};

    /// A box of 36 x 24 x 24 cells of unit size with two spheres of radii `ra`, `rb` along x,
    /// their surfaces `gap` cells apart, the second shifted by `shift` along x.
    fn two_spheres(ra: f64, rb: f64, gap: f64, shift: f64, effects: Vec<Contact<f64>>) -> Simulation<f64> {
        let grid = Grid::<f64>::periodic([36, 24, 24], [0.0; 3], [36.0, 24.0, 24.0]).unwrap();
        let (ca, cb) = (18.0 - 0.5 * gap - ra, 18.0 + 0.5 * gap + rb + shift);
        let mut scene = Scene::new(grid, Phase::new(1.0, 1.0).unwrap())
            .capsule(Sphere::new([ca, 12.0, 12.0], ra).unwrap())
            .capsule(Sphere::new([cb, 12.2, 11.9], rb).unwrap());
        for e in effects {
            scene = scene.effect(e);
        }
        scene.build().unwrap()
    }

    /// The applied force field of the first effect of `sim` (a contact) at the current state.
    fn force(sim: &Simulation<f64>) -> VectorField<f64> {
        let state = sim.state(LevelChoice::Current);
        let mut f = VectorField::zeros(sim.grid());
        sim.effects()[0].add_force(&state, sim.velocity(), &mut f).unwrap();
        f
    }

    /// `sum f h^3` over the interior faces with `x < x_split` and with `x >= x_split`.
    fn split_sums(grid: &Grid<f64>, f: &VectorField<f64>, x_split: f64) -> ([f64; 3], [f64; 3]) {
        let (mut left, mut right) = ([0.0; 3], [0.0; 3]);
        for (i, j, k) in grid.cells() {
            let idx = grid.idx_u(i, j, k);
            for d in 0..3 {
                let x = grid.face_center(d, i as isize, j as isize, k as isize)[0];
                let side = if x < x_split { &mut left } else { &mut right };
                side[d] += f.c[d].data[idx];
            }
        }
        (left, right)
    }

    /// The pressure on each membrane, `-sum Pi S grad phi_c h^3` (the surface parts of
    /// `div sigma`), for the two capsules of `sim` with `law`.
    fn membrane_forces(sim: &Simulation<f64>, law: Law<f64>) -> [[f64; 3]; 2] {
        let state = sim.state(LevelChoice::Current);
        let p = Profile::new(state.grid, state.settings.advection.beta);
        let mut out = [[0.0; 3]; 2];
        for pair in pairs(&state, 0..2).unwrap() {
            law.for_each_stress(state.grid, &p, &pair, |at, pi, s| {
                for (c, (m, idx)) in [(pair.a, at.a), (pair.b, at.b)].iter().enumerate() {
                    let g: [f64; 3] = std::array::from_fn(|d| m.delta.data[*idx] * m.normal[d].data[*idx]);
                    for d in 0..3 {
                        let sg: f64 = (0..3).map(|e| s[sym_index(d, e)] * g[e]).sum();
                        out[c][d] -= pi * sg;
                    }
                }
            });
        }
        out
    }

    fn contact() -> Contact<f64> {
        Contact::new(10.0, 2.5).unwrap()
    }

    #[test]
    fn close_spheres_are_pushed_apart_with_equal_and_opposite_forces() {
        let (ra, rb, gap) = (6.0, 8.0, 1.0);
        let sim = two_spheres(ra, rb, gap, 0.0, vec![contact()]);
        let f = force(&sim);
        let (left, right) = split_sums(sim.grid(), &f, 18.0);
        let scale = left[0].abs();
        // Momentum: the stress divergence sums to zero over the box.
        for d in 0..3 {
            assert!((left[d] + right[d]).abs() < 1e-10 * scale, "{left:?} {right:?}");
        }
        // The capsule on the left is pushed to -x, the one on the right to +x.
        assert!(left[0] < 0.0 && right[0] > 0.0, "{left:?} {right:?}");
        // The pressure on each membrane: apart, equal and opposite up to the film term.
        let [fa, fb] = membrane_forces(&sim, Law { p0: 10.0, range_cells: 2.5 });
        println!("membrane forces {fa:?} {fb:?}, split at the midplane {left:?} {right:?}");
        assert!(fa[0] < 0.0 && fb[0] > 0.0);
        assert!((fa[0] + fb[0]).abs() < 0.06 * fb[0], "{fa:?} {fb:?}");
        for d in 1..3 {
            assert!(fa[d].abs() < 0.05 * fb[0] && fb[d].abs() < 0.05 * fb[0], "{fa:?} {fb:?}");
        }
        // Far apart (4 cells, beyond the range of 2.5): no force at all.
        let far = two_spheres(ra, rb, 4.0, 0.0, vec![contact()]);
        let f = force(&far);
        assert!(f.c.iter().all(|c| c.data.iter().all(|&x| x == 0.0)));
        assert_eq!(far.elastic_energy(), 0.0);
    }

    #[test]
    fn one_capsule_feels_no_force() {
        let grid = Grid::<f64>::periodic([24; 3], [0.0; 3], [24.0; 3]).unwrap();
        let sim = Scene::new(grid, Phase::new(1.0, 1.0).unwrap())
            .capsule(Sphere::new([12.0; 3], 6.0).unwrap())
            .effect(contact())
            .build()
            .unwrap();
        let state = sim.state(LevelChoice::Current);
        assert!(!sim.effects()[0].is_active(&state));
        let f = force(&sim);
        assert!(f.c.iter().all(|c| c.data.iter().all(|&x| x == 0.0)));
        assert_eq!(sim.elastic_energy(), 0.0);
        assert_eq!(min_gap_cells(&sim), None);
    }

    #[test]
    fn min_gap_of_two_spheres() {
        // Radii 5 and 7 in a period of 36: the gap across the periodic side is 12 - gap.
        for gap in [-1.0, 0.0, 0.7, 1.5, 2.3, 4.6] {
            let sim = two_spheres(5.0, 7.0, gap, 0.0, vec![]);
            // The surfaces are closest along the line of centres; its 0.2 / -0.1 offset in y, z
            // changes the gap by less than 1e-3 cell.
            let got = min_gap_cells(&sim).unwrap();
            println!("gap {gap}: min_gap_cells {got:.4} (error {:+.4})", got - gap);
            assert!((got - gap).abs() < 0.15, "gap {gap}: {got}");
        }
        // Too far for the profiles to meet: 16 cells apart both ways.
        let grid = Grid::<f64>::periodic([48, 16, 16], [0.0; 3], [48.0, 16.0, 16.0]).unwrap();
        let far = Scene::new(grid, Phase::new(1.0, 1.0).unwrap())
            .capsule(Sphere::new([12.0, 8.0, 8.0], 4.0).unwrap())
            .capsule(Sphere::new([36.0, 8.0, 8.0], 4.0).unwrap())
            .build()
            .unwrap();
        assert_eq!(min_gap_cells(&far), Some(f64::INFINITY));
    }

    #[test]
    fn bad_parameters_are_refused_by_name() {
        let name = |r: Result<Contact<f64>>| match r {
            Err(Error::InvalidParameter { name, .. }) => name,
            _ => "accepted",
        };
        for p in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(name(Contact::new(p, 2.0)), "pressure");
        }
        for r in [0.0, -1.0, 4.5, f64::NAN, f64::INFINITY] {
            assert_eq!(name(Contact::new(1.0, r)), "range_cells");
        }
        let e = Contact::<f64>::new(1.0, 5.0).err().unwrap().to_string();
        assert!(e.contains("range_cells") && e.contains('5') && e.contains("(0, 4]"), "{e}");
        // A range the profiles cannot resolve with a sharp profile, a scene without capsules,
        // an unknown capsule.
        let grid = Grid::<f64>::periodic([24; 3], [0.0; 3], [24.0; 3]).unwrap();
        let scene = || {
            Scene::new(grid.clone(), Phase::new(1.0, 1.0).unwrap())
                .capsule(Sphere::new([12.0; 3], 6.0).unwrap())
        };
        let err = |s: Scene<f64>| match s.build() {
            Err(Error::InvalidParameter { name, .. }) => name,
            _ => "accepted",
        };
        let sharp = Settings::default().with_beta(2.0);
        assert_eq!(err(scene().settings(sharp).effect(Contact::new(1.0, 3.0).unwrap())), "range_cells");
        assert_eq!(err(scene().settings(sharp).effect(Contact::new(1.0, 2.0).unwrap())), "accepted");
        let empty = Scene::new(grid.clone(), Phase::new(1.0, 1.0).unwrap()).effect(contact());
        assert_eq!(err(empty), "contact");
        assert_eq!(err(scene().effect(contact().only([0, 3]))), "contact");
    }

    #[test]
    fn force_is_minus_the_energy_gradient() {
        // Capsule b moved rigidly along x (its profile with it, as MTHINC carries it) by +-eps:
        // -dE/dx_b against the pressure on its membrane.
        let (ra, rb, eps) = (6.0, 8.0, 0.05);
        let law = Law { p0: 10.0, range_cells: 2.5 };
        for gap in [0.5, 1.0, 1.5] {
            let energy = |shift| two_spheres(ra, rb, gap, shift, vec![contact()]).elastic_energy();
            let de = (energy(eps) - energy(-eps)) / (2.0 * eps);
            let sim = two_spheres(ra, rb, gap, 0.0, vec![contact()]);
            let [fa, fb] = membrane_forces(&sim, law);
            let rel = (fb[0] + de) / fb[0];
            println!(
                "gap {gap}: E {:.5e}  -dE/dx_b {:.5e}  F_b {:.5e}  F_a {:.5e} rel {rel:+.4}",
                sim.elastic_energy(),
                -de,
                fb[0],
                fa[0]
            );
            assert!(de < 0.0 && rel.abs() < 0.05, "gap {gap}: -dE/dx_b {} against {}", -de, fb[0]);
        }
    }
}
