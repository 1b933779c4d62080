//! One time step of the interface fields: MTHINC advection of `phi` and convolved-curvature
//! advection of `kappa_R tilde`, in flux form with second-order Adams-Bashforth,
//! equations (2.29)-(2.30), (2.41), (2.44) and (2.48).
//!
//! ```text
//! R_phi = -div(v Hbar) + phi div v                                 (2.41), (2.48)
//! R_kt  = -div(v Gbar) + kt div v - kt n . grad v . n              (2.44), (2.30)
//! q^{n+1} = q^n + dt ((1 + r/2) R^n - (r/2) R^{n-1}),  r = dt / dt_prev   (2.29)-(2.30)
//! ```
//!
//! On a capsule box's grid the compressibility terms (`phi div v`, `kt div v`) are left out of
//! the last cell along each seam axis ([`Grid::seams`]), where the face past the cell is the
//! image of the box's first face and the discrete divergence is the box's closure, not the
//! flow's: the fluxes through the seam cancel as on any periodic grid, and the sum of `phi`
//! is conserved as on the whole grid.
//!
//! With a constant step, `r = 1` gives the paper's `3/2, -1/2`; the first step (or the first
//! after [`Advector::reset_history`]) is forward Euler. The previous right-hand sides are stored,
//! not recomputed.
//!
//! # Stages of a step
//!
//! 1. Ghosts of `phi` (and `kt`) are filled.
//! 2. *Reconstruction* (time level n): the cells of the interior and of the first ghost layer
//!    with `tiny < phi < 1 - tiny` form the band (a list rebuilt each step, with a slot map from
//!    storage index to band entry). Each band cell gets its normal (the chosen
//!    [`NormalScheme`]), its offset (2.43) and its profile coefficient
//!    (2.47), stored once per cell; this is the only place where transcendental functions are
//!    evaluated, so the cost grows with the interface area, not with the box.
//! 3. *Update*: each interior cell evaluates its face fluxes from the upwind cell (a band cell's
//!    reconstruction by products of its stored factors; a uniform cell gives `v * phi`), forms
//!    `R`, applies AB2 into a work buffer and stores `R`; the buffers are then swapped with the
//!    fields' storage. A face flux is a deterministic function of the face, so both cells of a
//!    face use the very same number and the sum of `phi` is conserved to round-off (exactly, for
//!    a discretely divergence-free `v`, up to the rounding of the sums).
//!
//! Both parallel passes run over x-lines or band cells (rayon); the [`Advector`] owns its work
//! arrays. On a 2D grid (one cell along z) z-faces are skipped: their fluxes cancel exactly.
//!
//! Time step: keep the summed Courant number [`cfl_number`] at or below 1/2 (AB2 stability). On a 2D grid (one cell along z) z-faces are skipped: their fluxes cancel exactly.

use super::convolved::normal_stretching;
use super::geometry::{NormalScheme, normal_at};
use super::mthinc::{CellQuadrature, Reconstruction};
use crate::grid::ops::grad_v_at_cell;
use crate::grid::{Field, GHOST, Grid, VectorField};
use crate::io::checkpoint::{CheckpointReader, CheckpointWriter};
use crate::{Error, Real, Result};
use rayon::prelude::*;

/// Parameters of the interface advection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdvectionParams<T> {
    /// Sharpness `beta` of the profile, `beta' = beta / h` (2.42), in `(0, 10]`. Default 1 (the
    /// paper's).
    pub beta: T,
    /// Normal construction of the reconstruction. Default [`NormalScheme::Atanh4`]: more
    /// accurate than the paper's [`NormalScheme::Youngs`] at every resolution of the
    /// single-vortex test (see `docs/validation/interface.md`) for about 20 % more
    /// reconstruction cost. [`NormalScheme::Deconvolved`] is not allowed here.
    pub normals: NormalScheme,
    /// Cells with `phi <= tiny` or `phi >= 1 - tiny` are uniform (no profile). Default
    /// `max(1e-6, 1000 eps)`.
    pub tiny: T,
    /// Quadrature of the cell constraints (2.43), (2.46). Default [`CellQuadrature::Gauss2`]
    /// (the paper's).
    pub quadrature: CellQuadrature,
}

impl<T: Real> Default for AdvectionParams<T> {
    fn default() -> Self {
        AdvectionParams {
            beta: T::one(),
            normals: NormalScheme::Atanh4,
            tiny: default_tiny(),
            quadrature: CellQuadrature::default(),
        }
    }
}

/// Default uniform-cell threshold: `max(1e-6, 1000 eps)`.
pub(crate) fn default_tiny<T: Real>() -> T {
    T::lit(1e-6).max(T::lit(1000.0) * T::eps())
}

/// The characteristic length `h` of `beta' = beta / h`: the geometric mean of the spacings of
/// the axes with more than one cell (the spacing itself on a uniform grid).
pub fn characteristic_length<T: Real>(grid: &Grid<T>) -> T {
    let mut p = 0.0f64;
    let mut m = 0;
    for d in 0..3 {
        if grid.n()[d] > 1 {
            p += grid.h()[d].f64().ln();
            m += 1;
        }
    }
    T::lit((p / m.max(1) as f64).exp())
}

/// What a step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AdvectionInfo {
    /// Cells (interior and first ghost layer) with `tiny < phi < 1 - tiny`.
    pub band_cells: usize,
    /// Band cells that were reconstructed with a profile (the others had a vanishing gradient).
    pub profile_cells: usize,
    /// Largest number of function evaluations of an offset solve.
    pub max_iterations: u32,
}

const NONE: u32 = u32::MAX;

/// What an [`Advector`] carries with the flow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Carried {
    /// `phi` alone, by MTHINC (2.29).
    #[default]
    Phi,
    /// `phi` and the convolved reference curvature `kappa_R tilde` (2.30), advected with the
    /// same reconstruction (what bending needs).
    PhiAndCurvature,
}

/// The strategy that carries a capsule's interface with the flow, once per step: `phi` (2.29)
/// and, when the capsule bends, the convolved reference curvature `kappa_R tilde` (2.30).
///
/// The default is the [`Advector`] (MTHINC with the convolved curvature, AB2) with
/// [`Settings::advection`](crate::simulation::Settings::advection).
/// [`Scene::interface_transport`](crate::simulation::Scene::interface_transport) takes a maker
/// of a user's, called once per capsule with what it must carry ([`Carried`]): a transport
/// holds one capsule's time history. The simulation proposes a step with
/// [`advance`](Self::advance) and, when the step is discarded, calls [`undo`](Self::undo);
/// checkpoints save and restore the history; a capsule's box that moves with it
/// ([`CapsuleStorage::Boxed`](crate::simulation::CapsuleStorage)) calls [`roll`](Self::roll),
/// and [`regrow`](Self::regrow) when the box grows. A transport without a time history keeps
/// the default `undo`, `checkpoint` and `restore`, which do nothing, and returns `Ok(())` from
/// `roll` and `regrow`.
///
/// A user transport that wraps the default one and counts its steps:
///
/// ```
/// use eulermembrane::grid::{Field, Grid, VectorField, Window};
/// use eulermembrane::interface::{advect::AdvectionInfo, advect::AdvectionParams, advect::Advector, advect::InterfaceTransport};
/// use eulermembrane::io::checkpoint::{CheckpointReader, CheckpointWriter};
/// use eulermembrane::prelude::*;
///
/// struct Counted(Advector<f64>, usize);
/// impl InterfaceTransport<f64> for Counted {
///     fn name(&self) -> &str {
///         "counted_mthinc"
///     }
///     fn advance(
///         &mut self,
///         grid: &Grid<f64>,
///         v: &VectorField<f64>,
///         dt: f64,
///         phi: &mut Field<f64>,
///         kappa: Option<&mut Field<f64>>,
///     ) -> eulermembrane::Result<AdvectionInfo> {
///         self.1 += 1;
///         self.0.advance(grid, v, dt, phi, kappa)
///     }
///     fn undo(&mut self) {
///         self.0.undo()
///     }
///     fn roll(&mut self, grid: &Grid<f64>, axis: usize, by: isize) -> eulermembrane::Result<()> {
///         self.0.roll(grid, axis, by)
///     }
///     fn regrow(
///         &mut self,
///         from: &Window,
///         from_grid: &Grid<f64>,
///         to: &Window,
///         to_grid: &Grid<f64>,
///     ) -> eulermembrane::Result<()> {
///         self.0.regrow(from, from_grid, to, to_grid)
///     }
///     fn checkpoint(&self, w: &mut CheckpointWriter, prefix: &str) {
///         self.0.checkpoint(w, prefix)
///     }
///     fn restore(&mut self, r: &CheckpointReader, prefix: &str) -> eulermembrane::Result<()> {
///         self.0.restore(r, prefix)
///     }
/// }
///
/// let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
/// let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.5; 3], 0.25)?)
///     .interface_transport(|grid, carried| {
///         let adv = Advector::new(grid, AdvectionParams::default(), carried)?;
///         Ok(Box::new(Counted(adv, 0)) as Box<dyn InterfaceTransport<f64>>)
///     })
///     .build()?;
/// sim.step(1e-3)?;
/// assert!(sim.numerics().contains("transport=counted_mthinc"));
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub trait InterfaceTransport<T: Real>: Send + Sync {
    /// A short snake_case name, for [`Simulation::numerics`](crate::simulation::Simulation::numerics).
    fn name(&self) -> &str;

    /// Advances `phi` (and `kappa_R tilde`, given exactly when the transport was made with
    /// [`Carried::PhiAndCurvature`]) by one step `dt` with the velocity `v^n` (ghosts filled):
    /// on return their interiors hold time level `n + 1`; their ghosts may be stale. Keeps what
    /// [`undo`](Self::undo) needs.
    ///
    /// # Errors
    /// Fields of another grid, a non-finite result; the step then fails, the simulation calls
    /// [`undo`](Self::undo) and its state is as it was.
    fn advance(
        &mut self,
        grid: &Grid<T>,
        v: &VectorField<T>,
        dt: T,
        phi: &mut Field<T>,
        kappa: Option<&mut Field<T>>,
    ) -> Result<AdvectionInfo>;

    /// Returns the transport's own state (its time history) to what it was before the last
    /// [`advance`](Self::advance) (called once, when that step is discarded).
    fn undo(&mut self) {}

    /// Moves the transport's own state (its time history on the grid) with the capsule's box:
    /// the box moved by `by` cells along `axis` and its fields were rolled by
    /// [`Window::roll`](crate::grid::Window::roll) (cell `b` took the value of cell `b + by`);
    /// roll every per-cell history the same way (e.g. with
    /// [`Window::roll_slice`](crate::grid::Window::roll_slice)). Called between steps only.
    ///
    /// # Errors
    /// The default refuses ([`Error::Unsupported`]): a transport that keeps no state on the
    /// grid returns `Ok(())`; one that does rolls it. The box then stays where it is and the
    /// step reports the error.
    fn roll(&mut self, grid: &Grid<T>, axis: usize, by: isize) -> Result<()> {
        let _ = (grid, axis, by);
        Err(Error::Unsupported {
            component: "InterfaceTransport::roll",
            detail: format!(
                "the transport {} does not move with a capsule's box (implement roll, or keep the \
                 capsules on the whole grid)",
                self.name()
            ),
        })
    }

    /// Moves the transport's own state into a grown box: the capsule's box `from` (grid
    /// `from_grid`) became `to` (grid `to_grid`), which holds every cell of `from`
    /// ([`Window::grown`](crate::grid::Window::grown)), and the capsule's fields were moved cell
    /// for cell of the whole grid ([`Window::transfer_slice`](crate::grid::Window::transfer_slice));
    /// reallocate every per-cell array on `to_grid` and move the time history the same way.
    /// Called between steps only.
    ///
    /// # Errors
    /// The default refuses ([`Error::Unsupported`]), as [`roll`](Self::roll) does; the box then
    /// keeps its size and the step reports the error.
    fn regrow(
        &mut self,
        from: &crate::grid::Window,
        from_grid: &Grid<T>,
        to: &crate::grid::Window,
        to_grid: &Grid<T>,
    ) -> Result<()> {
        let _ = (from, from_grid, to, to_grid);
        Err(Error::Unsupported {
            component: "InterfaceTransport::regrow",
            detail: format!(
                "the transport {} does not move into a grown box (implement regrow, or give the \
                 capsules more room)",
                self.name()
            ),
        })
    }

    /// Adds the transport's own state to a checkpoint, with names prefixed by `prefix`.
    fn checkpoint(&self, _w: &mut CheckpointWriter, _prefix: &str) {}

    /// Restores the state written by [`checkpoint`](Self::checkpoint) with the same `prefix`.
    ///
    /// # Errors
    /// A malformed or missing entry; the transport's state is then unchanged.
    fn restore(&mut self, _r: &CheckpointReader, _prefix: &str) -> Result<()> {
        Ok(())
    }
}

/// MTHINC advection of `phi`, and optionally of `kappa_R tilde`, with its work arrays and AB2
/// history: the default [`InterfaceTransport`]. Create once per grid; [`Advector::step`] allocates nothing once the band list has
/// reached its largest size.
#[derive(Debug, Clone)]
pub struct Advector<T> {
    params: AdvectionParams<T>,
    dims: [usize; 3],
    scale: [T; 3],
    /// Per stored cell: index into `band`, or `NONE` for a uniform cell.
    slot: Vec<u32>,
    /// Storage index of each band cell.
    band_idx: Vec<usize>,
    /// Reconstruction of each band cell.
    band: Vec<Reconstruction<T>>,
    next_phi: Vec<T>,
    next_kappa: Vec<T>,
    rhs_phi: Vec<T>,
    rhs_kappa: Vec<T>,
    dt_prev: Option<T>,
    curvature: bool,
    /// The history before the last [`InterfaceTransport::advance`]: `dt_prev` and the
    /// right-hand sides (for [`InterfaceTransport::undo`]).
    saved: (Option<T>, Vec<T>, Vec<T>),
}

impl<T: Real> Advector<T> {
    /// An advector for `grid` carrying `carried`. With [`Carried::PhiAndCurvature`] it also
    /// advects `kappa_R tilde` and [`Advector::step`] requires that field; with
    /// [`Carried::Phi`] it allocates nothing for it.
    ///
    /// Errors: `beta` not in `(0, 10]`, `tiny` not in `[0, 0.5)`.
    pub fn new(grid: &Grid<T>, params: AdvectionParams<T>, carried: Carried) -> Result<Self> {
        let with_curvature = carried == Carried::PhiAndCurvature;
        if !(params.beta > T::zero() && params.beta <= T::lit(10.0)) {
            return Err(Error::invalid(
                "AdvectionParams::beta",
                params.beta,
                "a number in (0, 10] (the paper uses 1)",
            ));
        }
        if params.normals == NormalScheme::Deconvolved {
            return Err(Error::Unsupported {
                component: "Advector",
                detail: "NormalScheme::Deconvolved is for geometry (it solves a reconstruction \
                         per neighbour); advect with Youngs, Atanh2 or Atanh4"
                    .into(),
            });
        }
        if !(params.tiny >= T::zero() && params.tiny < T::lit(0.5)) {
            return Err(Error::invalid(
                "AdvectionParams::tiny",
                params.tiny,
                "a number in [0, 0.5), e.g. 1e-6",
            ));
        }
        let bp = params.beta / characteristic_length(grid);
        let h = grid.h();
        let n = grid.len();
        let k = if with_curvature { n } else { 0 };
        Ok(Advector {
            params,
            dims: grid.dims(),
            scale: [bp * h[0], bp * h[1], bp * h[2]],
            slot: vec![NONE; n],
            band_idx: Vec::new(),
            band: Vec::new(),
            next_phi: vec![T::zero(); n],
            next_kappa: vec![T::zero(); k],
            rhs_phi: vec![T::zero(); n],
            rhs_kappa: vec![T::zero(); k],
            dt_prev: None,
            curvature: with_curvature,
            saved: (None, Vec::new(), Vec::new()),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &AdvectionParams<T> {
        &self.params
    }

    /// Whether `kappa_R tilde` is advected.
    pub fn carries_curvature(&self) -> bool {
        self.curvature
    }

    /// `Ok` if `grid` has the storage of the grid this advector was made (or last regrown) for.
    fn check_dims(&self, grid: &Grid<T>) -> Result<()> {
        match grid.dims() == self.dims {
            true => Ok(()),
            false => {
                Err(Error::invalid("grid", format!("{:?} cells", grid.n()), "the grid of Advector::new"))
            }
        }
    }

    /// Forgets the AB2 history: the next step is forward Euler.
    pub fn reset_history(&mut self) {
        self.dt_prev = None;
    }

    /// The AB2 history: the previous step size and right-hand sides of `phi` and `kappa_R
    /// tilde` (the latter empty without curvature), or `None` before the first step. For
    /// checkpoints; see [`Advector::restore_history`].
    pub fn history(&self) -> Option<(T, &[T], &[T])> {
        self.dt_prev.map(|dt| (dt, self.rhs_phi.as_slice(), self.rhs_kappa.as_slice()))
    }

    /// Restores a history saved from [`Advector::history`] (same grid). Errors on a length
    /// mismatch, a non-positive `dt_prev` or a non-finite value; the history is then unchanged.
    pub fn restore_history(&mut self, dt_prev: T, rhs_phi: &[T], rhs_kappa: &[T]) -> Result<()> {
        if rhs_phi.len() != self.rhs_phi.len() || rhs_kappa.len() != self.rhs_kappa.len() {
            return Err(Error::invalid(
                "history length",
                rhs_phi.len(),
                "the lengths of the arrays returned by Advector::history on the same grid",
            ));
        }
        crate::error::positive("dt_prev", dt_prev)?;
        if let Some(x) = rhs_phi.iter().chain(rhs_kappa).find(|x| !x.is_finite()) {
            return Err(Error::invalid("history", x, "finite right-hand sides (from Advector::history)"));
        }
        self.rhs_phi.copy_from_slice(rhs_phi);
        self.rhs_kappa.copy_from_slice(rhs_kappa);
        self.dt_prev = Some(dt_prev);
        Ok(())
    }

    /// The reconstruction of the cell at storage index `idx` from the last call of
    /// [`Advector::reconstruct`] or [`Advector::step`] (band cells of the interior and of the
    /// first ghost layer; `None` for a uniform cell). Its normal is [`Reconstruction::normal`].
    pub fn reconstruction(&self, idx: usize) -> Option<&Reconstruction<T>> {
        match self.slot.get(idx) {
            Some(&s) if s != NONE => self.band.get(s as usize),
            _ => None,
        }
    }

    /// Storage indices of the band cells of the last reconstruction.
    pub fn band_cells(&self) -> &[usize] {
        &self.band_idx
    }

    fn check(&self, grid: &Grid<T>, phi: &Field<T>, kappa: Option<&Field<T>>) -> Result<()> {
        if grid.dims() != self.dims {
            return Err(Error::invalid(
                "grid",
                format!("{:?}", grid.n()),
                "the grid the Advector was created for",
            ));
        }
        if phi.data.len() != grid.len() {
            return Err(Error::invalid("phi", phi.data.len(), "a field of this grid"));
        }
        match (kappa, self.curvature) {
            (Some(k), true) if k.data.len() == grid.len() => Ok(()),
            (Some(k), true) => Err(Error::invalid("kappa_tilde", k.data.len(), "a field of this grid")),
            (None, false) => Ok(()),
            (Some(_), false) => Err(Error::Unsupported {
                component: "Advector",
                detail: "a kappa_R tilde field was given to an advector created without \
                         curvature; create it with Carried::PhiAndCurvature"
                    .into(),
            }),
            (None, true) => Err(Error::Unsupported {
                component: "Advector",
                detail: "this advector was created with curvature: pass the kappa_R tilde field".into(),
            }),
        }
    }

    /// Reconstructs every band cell (`tiny < phi < 1 - tiny`) of the interior and of the first
    /// ghost layer from `phi` (and `kappa_R tilde`), ghosts of both filled. Called by
    /// [`Advector::step`]; public so that a stepper can reuse the normals without a step.
    pub fn reconstruct(
        &mut self,
        grid: &Grid<T>,
        phi: &Field<T>,
        kappa: Option<&Field<T>>,
    ) -> Result<AdvectionInfo> {
        self.check(grid, phi, kappa)?;
        let n = grid.n();
        let p = self.params;
        let (klo, khi) = if grid.is_2d() { (0, 0) } else { (-1, n[2] as isize) };
        // Band list (serial: a compare per cell; the work is in the parallel part below).
        self.band_idx.clear();
        let (lo, hi) = (p.tiny, T::one() - p.tiny);
        for k in klo..=khi {
            for j in -1..=n[1] as isize {
                let base = grid.idx(-1, j, k);
                for (off, &f) in phi.data[base..base + n[0] + 2].iter().enumerate() {
                    let idx = base + off;
                    if f > lo && f < hi {
                        self.slot[idx] = self.band_idx.len() as u32;
                        self.band_idx.push(idx);
                    } else {
                        self.slot[idx] = NONE;
                    }
                }
            }
        }
        self.band.resize(self.band_idx.len(), Reconstruction::default());
        let scale = self.scale;
        let info = self
            .band
            .par_iter_mut()
            .zip(self.band_idx.par_iter())
            .map(|(rec, &idx)| {
                let f = phi.data[idx];
                let kt = kappa.map_or(T::zero(), |k| k.data[idx]);
                let mut info = AdvectionInfo { band_cells: 1, ..Default::default() };
                *rec = Reconstruction::uniform(f, kt);
                if let Some(nrm) = normal_at(grid, p.normals, phi, idx) {
                    let (r, solve) = Reconstruction::new(f, nrm, scale, p.tiny, p.quadrature);
                    if let Some(s) = solve {
                        info.profile_cells = 1;
                        info.max_iterations = s.iterations;
                    }
                    *rec = r.with_curvature(kt, solve.as_ref());
                }
                info
            })
            .reduce(AdvectionInfo::default, |a, b| AdvectionInfo {
                band_cells: a.band_cells + b.band_cells,
                profile_cells: a.profile_cells + b.profile_cells,
                max_iterations: a.max_iterations.max(b.max_iterations),
            });
        Ok(info)
    }

    /// Advances `phi` (and `kappa_R tilde`) by one step `dt` with the velocity `v` at time level
    /// n (ghosts of `v` filled; the reconstruction uses `phi^n`). Fills the ghosts of `phi` and
    /// `kappa` first; on return their interiors hold time level n+1 and their ghosts are stale.
    /// (The new values are written into work buffers that are then swapped with the fields'
    /// storage: no copy, no allocation.)
    ///
    /// Errors: `dt` not finite and positive; fields of another grid; a `kappa` field missing or
    /// unexpected (see [`Advector::new`]); a non-finite result ([`Error::NonFinite`], the fields
    /// then hold it: keep a copy if you need to retry).
    pub fn step(
        &mut self,
        grid: &Grid<T>,
        v: &VectorField<T>,
        dt: T,
        phi: &mut Field<T>,
        mut kappa: Option<&mut Field<T>>,
    ) -> Result<AdvectionInfo> {
        crate::error::positive("dt", dt)?;
        self.check(grid, phi, kappa.as_deref())?;
        if v.c.iter().any(|c| c.data.len() != grid.len()) {
            return Err(Error::invalid("v", "a field of another grid", "a field of this grid"));
        }
        phi.fill_ghosts(grid);
        if let Some(k) = kappa.as_deref_mut() {
            k.fill_ghosts(grid);
        }
        let info = self.reconstruct(grid, phi, kappa.as_deref())?;
        let (c1, c0) = match self.dt_prev {
            None => (T::one(), T::zero()),
            Some(prev) => {
                let r = dt / prev;
                (T::one() + T::lit(0.5) * r, T::lit(0.5) * r)
            }
        };
        let coef = Ab2 { dt, c1, c0 };
        let bad = match kappa.as_deref_mut() {
            Some(k) => {
                let bad = self.update::<true>(grid, v, coef, phi, Some(k));
                std::mem::swap(&mut k.data, &mut self.next_kappa);
                bad
            }
            None => self.update::<false>(grid, v, coef, phi, None),
        };
        std::mem::swap(&mut phi.data, &mut self.next_phi);
        self.dt_prev = Some(dt);
        if bad {
            if let Some(cell) = phi.first_non_finite(grid) {
                return Err(Error::NonFinite { field: "phi", cell });
            }
            if let Some(cell) = kappa.and_then(|k| k.first_non_finite(grid)) {
                return Err(Error::NonFinite { field: "kappa_tilde", cell });
            }
        }
        Ok(info)
    }

    /// The update pass into the `next_*` buffers; returns whether a non-finite value appeared.
    fn update<const K: bool>(
        &mut self,
        grid: &Grid<T>,
        v: &VectorField<T>,
        coef: Ab2<T>,
        phi: &Field<T>,
        kappa: Option<&mut Field<T>>,
    ) -> bool {
        let dx = grid.dims()[0];
        let kdata: &[T] = kappa.as_deref().map_or(&[], |k| &k.data);
        let kern = RowKernel {
            grid,
            v,
            slot: &self.slot,
            band: &self.band,
            phi: &phi.data,
            kappa: kdata,
            coef,
            st: grid.strides(),
            axes: if grid.is_2d() { 2 } else { 3 },
            inv_h: grid.h().map(|h| T::one() / h),
            seam: grid.seams(),
        };
        let rows_phi = self.next_phi.par_chunks_mut(dx).zip(self.rhs_phi.par_chunks_mut(dx)).enumerate();
        if K {
            rows_phi
                .zip(self.next_kappa.par_chunks_mut(dx).zip(self.rhs_kappa.par_chunks_mut(dx)))
                .map(|((row, (p, rp)), (kl, rk))| kern.row::<true>(row, p, rp, kl, rk))
                .reduce(|| false, |a, b| a || b)
        } else {
            rows_phi
                .map(|(row, (p, rp))| kern.row::<false>(row, p, rp, &mut [], &mut []))
                .reduce(|| false, |a, b| a || b)
        }
    }
}

impl<T: Real> InterfaceTransport<T> for Advector<T> {
    fn name(&self) -> &str {
        if self.curvature { "mthinc_convolved_curvature" } else { "mthinc" }
    }

    /// Saves the AB2 history, then [`Advector::step`].
    fn advance(
        &mut self,
        grid: &Grid<T>,
        v: &VectorField<T>,
        dt: T,
        phi: &mut Field<T>,
        kappa: Option<&mut Field<T>>,
    ) -> Result<AdvectionInfo> {
        self.saved.0 = self.dt_prev;
        if self.dt_prev.is_some() {
            self.saved.1.clear();
            self.saved.1.extend_from_slice(&self.rhs_phi);
            self.saved.2.clear();
            self.saved.2.extend_from_slice(&self.rhs_kappa);
        }
        self.step(grid, v, dt, phi, kappa)
    }

    fn undo(&mut self) {
        match self.saved.0 {
            Some(dt_prev) => {
                self.rhs_phi.copy_from_slice(&self.saved.1);
                self.rhs_kappa.copy_from_slice(&self.saved.2);
                self.dt_prev = Some(dt_prev);
            }
            None => self.reset_history(),
        }
    }

    /// Rolls the AB2 right-hand sides with the box.
    fn roll(&mut self, grid: &Grid<T>, axis: usize, by: isize) -> Result<()> {
        self.check_dims(grid)?;
        let mut line = Vec::new();
        crate::grid::Window::roll_slice(grid, &mut self.rhs_phi, axis, by, &mut line);
        crate::grid::Window::roll_slice(grid, &mut self.rhs_kappa, axis, by, &mut line);
        Ok(())
    }

    /// Reallocates the work arrays on the grown box's grid and moves the AB2 right-hand sides
    /// into it.
    fn regrow(
        &mut self,
        from: &crate::grid::Window,
        from_grid: &Grid<T>,
        to: &crate::grid::Window,
        to_grid: &Grid<T>,
    ) -> Result<()> {
        self.check_dims(from_grid)?;
        let n = to_grid.len();
        let k = if self.curvature { n } else { 0 };
        let mut rhs_phi = vec![T::zero(); n];
        let mut rhs_kappa = vec![T::zero(); k];
        from.transfer_slice(from_grid, &self.rhs_phi, to, to_grid, &mut rhs_phi)?;
        if self.curvature {
            from.transfer_slice(from_grid, &self.rhs_kappa, to, to_grid, &mut rhs_kappa)?;
        }
        self.dims = to_grid.dims();
        self.slot = vec![NONE; n];
        self.band_idx.clear();
        self.band.clear();
        self.next_phi = vec![T::zero(); n];
        self.next_kappa = vec![T::zero(); k];
        self.rhs_phi = rhs_phi;
        self.rhs_kappa = rhs_kappa;
        self.saved = (None, Vec::new(), Vec::new());
        Ok(())
    }

    /// Writes `adv_dt_prev`, `adv_rhs_phi` and `adv_rhs_kappa` (nothing before the first
    /// step).
    fn checkpoint(&self, w: &mut CheckpointWriter, prefix: &str) {
        if let Some((dt_prev, rp, rk)) = self.history() {
            w.number(&format!("{prefix}adv_dt_prev"), dt_prev.f64());
            w.array(&format!("{prefix}adv_rhs_phi"), rp).array(&format!("{prefix}adv_rhs_kappa"), rk);
        }
    }

    /// Reads what [`checkpoint`](InterfaceTransport::checkpoint) wrote, or forgets the history
    /// where it wrote nothing; errors as [`Advector::restore_history`].
    fn restore(&mut self, r: &CheckpointReader, prefix: &str) -> Result<()> {
        let dt_name = format!("{prefix}adv_dt_prev");
        if !r.has(&dt_name) {
            self.reset_history();
            return Ok(());
        }
        let dt_prev = T::lit(r.number(&dt_name)?);
        let rp = r.array::<T>(&format!("{prefix}adv_rhs_phi"), self.rhs_phi.len())?;
        let rk = r.array::<T>(&format!("{prefix}adv_rhs_kappa"), self.rhs_kappa.len())?;
        self.restore_history(dt_prev, &rp, &rk)
    }
}

#[derive(Clone, Copy)]
struct Ab2<T> {
    dt: T,
    c1: T,
    c0: T,
}

struct RowKernel<'a, T> {
    grid: &'a Grid<T>,
    v: &'a VectorField<T>,
    slot: &'a [u32],
    band: &'a [Reconstruction<T>],
    phi: &'a [T],
    kappa: &'a [T],
    coef: Ab2<T>,
    st: [usize; 3],
    axes: usize,
    inv_h: [T; 3],
    seam: [bool; 3],
}

impl<T: Real> RowKernel<'_, T> {
    /// Flux `(v Hbar, v Gbar)` through the lower face of cell `idx` normal to `axis`, from the
    /// upwind cell's reconstruction (a uniform cell gives its values).
    #[inline(always)]
    fn flux<const K: bool>(&self, axis: usize, idx: usize) -> (T, T) {
        let u = self.v.c[axis].data[idx];
        let (cell, upper) = if u >= T::zero() { (idx - self.st[axis], true) } else { (idx, false) };
        let s = self.slot[cell];
        let (h, g) = if s == NONE {
            (self.phi[cell], if K { self.kappa[cell] } else { T::zero() })
        } else {
            let r = &self.band[s as usize];
            if K { r.face_pair(axis, upper) } else { (r.face_average(axis, upper), T::zero()) }
        };
        (u * h, u * g)
    }

    /// Updates one x-line; returns whether a non-finite value appeared.
    #[inline(always)]
    fn row<const K: bool>(
        &self,
        row: usize,
        phi_new: &mut [T],
        rhs: &mut [T],
        kappa_new: &mut [T],
        rhs_k: &mut [T],
    ) -> bool {
        let Some((j, k)) = self.grid.row_jk(row) else {
            return false;
        };
        let dx = self.grid.dims()[0];
        let [nx, ny, nz] = self.grid.n();
        // On a box's seam the last cell's divergence is the box's closure, not the flow's.
        let seam_row = (self.seam[1] && j + 1 == ny) || (self.seam[2] && k + 1 == nz);
        let g = GHOST;
        let seam_x = if self.seam[0] { g + nx - 1 } else { usize::MAX };
        let Ab2 { dt, c1, c0 } = self.coef;
        let first = c0 == T::zero();
        let mut bad = false;
        let h = self.grid.h();
        // The x-flux through the upper face of a cell is the lower one of the next.
        let mut lower_x = self.flux::<K>(0, row * dx + g);
        for i in g..g + nx {
            let idx = row * dx + i;
            let upper_x = self.flux::<K>(0, idx + 1);
            let mut div_f = (upper_x.0 - lower_x.0) * self.inv_h[0];
            let mut div_g = (upper_x.1 - lower_x.1) * self.inv_h[0];
            let mut div_v = (self.v.c[0].data[idx + 1] - self.v.c[0].data[idx]) * self.inv_h[0];
            lower_x = upper_x;
            for d in 1..self.axes {
                let up = idx + self.st[d];
                let (fl, gl) = self.flux::<K>(d, idx);
                let (fu, gu) = self.flux::<K>(d, up);
                div_f += (fu - fl) * self.inv_h[d];
                if K {
                    div_g += (gu - gl) * self.inv_h[d];
                }
                div_v += (self.v.c[d].data[up] - self.v.c[d].data[idx]) * self.inv_h[d];
            }
            if seam_row || i == seam_x {
                div_v = T::zero();
            }
            let f = self.phi[idx];
            let r = f * div_v - div_f;
            let rp = if first { T::zero() } else { rhs[i] };
            let new = f + dt * (c1 * r - c0 * rp);
            rhs[i] = r;
            phi_new[i] = new;
            bad |= !new.is_finite();
            if K {
                let kt = self.kappa[idx];
                let mut rk = kt * div_v - div_g;
                let s = self.slot[idx];
                if s != NONE
                    && let Some(n) = self.band[s as usize].normal(h)
                {
                    let gv = grad_v_at_cell(self.grid, self.v, idx);
                    rk -= kt * normal_stretching(&n, &gv);
                }
                let rkp = if first { T::zero() } else { rhs_k[i] };
                let newk = kt + dt * (c1 * rk - c0 * rkp);
                rhs_k[i] = rk;
                kappa_new[i] = newk;
                bad |= !newk.is_finite();
            }
        }
        bad
    }
}

/// The summed advective Courant number `max_cells sum_d max(|v_d^-|, |v_d^+|) dt / h_d` (the
/// larger of the two face velocities of each axis, summed over the axes, maximised over the
/// interior cells).
///
/// Stability: AB2 with upwind-biased face fluxes is stable for a summed Courant number up to
/// about 1/2 (the real axis of AB2's stability region is `[-1, 0]`, and the upwind operator
/// reaches `-2 C`): keep it at or below 0.5, e.g. 0.25 per axis in 2D. A diagonal flow in 3D
/// at 0.25 per axis (0.75 in all) is unstable.
pub fn cfl_number<T: Real>(grid: &Grid<T>, v: &VectorField<T>, dt: T) -> T {
    let st = grid.strides();
    let h = grid.h();
    let mut m = T::zero();
    for (i, j, k) in grid.cells() {
        let id = grid.idx_u(i, j, k);
        let mut c = T::zero();
        for d in 0..3 {
            if grid.n()[d] == 1 {
                continue;
            }
            let a = v.c[d].data[id].abs().max(v.c[d].data[id + st[d]].abs());
            c += a * dt / h[d];
        }
        m = m.max(c);
    }
    m
}
