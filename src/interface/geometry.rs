//! Geometry of the interface from the smoothed VOF function: normal, delta, projector and
//! curvature, equations (2.24), (2.26) and (2.9).
//!
//! ```text
//! n = grad phi / |grad phi|                  (2.24)   unit normal
//! delta = |grad phi|                         (2.26)   smoothed surface delta (1 / length)
//! P = I - n n                                         surface projector
//! kappa = -P . grad n . P                    (2.9a)   Cartesian curvature tensor (symmetric)
//! kappa_mean = tr(kappa) / (D - 1)           (2.9b)   mean curvature, D = 3 (D = 2 on a 2D grid)
//! ```
//!
//! # Sign conventions (stated here once for the whole crate)
//!
//! - `phi = 1` inside the capsule, `0` outside.
//! - `n` points **into** the capsule (towards larger `phi`).
//! - `delta >= 0`.
//! - `(grad n)_ij = d n_j / d x_i`; the curvature tensor is `kappa = -P . grad n . P`, symmetric,
//!   and `tr(kappa) = -div n` on the interface (the `kappa` of (2.24)).
//! - The mean curvature is `tr(kappa) / (D - 1)`: in 3D it is (2.9b), `-tr(grad n) / 2`; on a 2D
//!   grid (one cell along z) it is the curvature of the interface curve, `-div n`.
//! - Convex shapes have positive curvature: a sphere of radius `R` has `kappa = P / R`,
//!   `-div n = 2 / R` and mean curvature `1 / R`; a circle of radius `R` on a 2D grid has mean
//!   curvature `1 / R`. The reference curvature `kappa_R` of the shapes module uses the same
//!   convention, so a sphere in its reference state has a bending moment
//!   `m = E_b (kappa - kappa_R P) = 0` (2.8).
//!
//! # Normal constructions
//!
//! [`NormalScheme`] chooses how `grad phi` is estimated. The paper uses Youngs' weighted
//! 3x3x3 stencil. Because the MTHINC profile is a hyperbolic tangent of a signed distance, the
//! transform `psi = atanh(2 phi - 1)` is a signed-distance-like field (in units of `h / beta`)
//! inside the band, smooth where `phi` itself is steep or flat; differencing it gives normals and
//! curvatures an order of magnitude more accurate (see `docs/validation/interface.md`). Normals
//! and curvatures do not depend on the scale of the level function, so `beta` is not needed here.
//!
//! Curvature: for `psi` with gradient `g` and Hessian `S` (second- or fourth-order central
//! differences), `grad n = S . P / |g|`, so `kappa = -P . S . P / |g|`. Youngs' scheme
//! differentiates node normals (each from the 8 cells around a node) across the cell, the
//! classic CSF estimate; the central scheme differentiates the neighbours' unit normals.
//!
//! Every per-cell function reads a stencil around a storage index (ghosts of `phi` filled, see
//! [`Field::fill_ghosts`]): radius 1 for all schemes but [`NormalScheme::Atanh4`] (radius 2);
//! the central curvature also has radius 2 ([`NormalScheme::curvature_radius`]).
//!
//! # Panics
//!
//! The per-cell functions index the field like a slice: a storage index whose stencil leaves
//! the stored array (a ghost cell near the edge of the padding, or a field of another grid)
//! panics. Interior cells of a field of `grid` are always valid, except for [`normal_at`] and
//! [`curvature_at`] with [`NormalScheme::Deconvolved`] (radius 4 on the fly, more than
//! [`GHOST`](crate::grid::GHOST)) in the outermost layer of cells; the field-level methods only
//! visit interior cells.

use crate::Real;
use crate::grid::{Field, Grid};
use crate::tensor::{Sym, Vec3, projector};
use rayon::prelude::*;

/// How the gradient of `phi` (hence the normal and the curvature) is estimated.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalScheme {
    /// Youngs' weighted stencil on `phi` (the paper's choice): central differences smoothed by
    /// `(1, 2, 1) / 4` weights in the transverse directions; curvature from node normals.
    Youngs,
    /// Plain second-order central differences of `phi`; curvature from central differences of
    /// the neighbours' unit normals (stencil radius 2).
    CentralPhi,
    /// Second-order central differences of `psi = atanh(2 phi - 1)`.
    Atanh2,
    /// Fourth-order central differences of `psi = atanh(2 phi - 1)` (stencil radius 2). The
    /// default: the most accurate construction that is local to a few cells.
    #[default]
    Atanh4,
    /// Fourth-order central differences of the *deconvolved* level field: in each cell near the
    /// interface the offset `D` of the MTHINC reconstruction (2.43) with the [`Atanh4`] normal
    /// (exact-along-normal rule), `psi` elsewhere. Where `psi` of a cell average is distorted by
    /// the averaging (an orientation-dependent error that does not shrink with resolution), `D`
    /// inverts it: normals converge and curvature is about ten times more accurate than with
    /// [`Atanh4`]. It assumes the profile sharpness `beta` of the field ([`Geometry::with_beta`];
    /// the free functions assume `beta = 1`) and costs one offset solve per cell of the band;
    /// use it through a [`Geometry`] (the free functions recompute every neighbour, slowly).
    /// Not available for advection.
    ///
    /// [`Atanh4`]: NormalScheme::Atanh4
    Deconvolved,
}

impl NormalScheme {
    /// All schemes, for studies.
    pub const ALL: [NormalScheme; 5] = [
        NormalScheme::Youngs,
        NormalScheme::CentralPhi,
        NormalScheme::Atanh2,
        NormalScheme::Atanh4,
        NormalScheme::Deconvolved,
    ];

    /// Stencil radius in cells of the normal estimate.
    pub fn radius(self) -> usize {
        match self {
            NormalScheme::Atanh4 => 2,
            NormalScheme::Deconvolved => 4,
            _ => 1,
        }
    }

    /// Stencil radius in cells of the curvature estimate.
    pub fn curvature_radius(self) -> usize {
        match self {
            NormalScheme::Atanh4 | NormalScheme::CentralPhi => 2,
            NormalScheme::Deconvolved => 4,
            _ => 1,
        }
    }

    /// Whether the scheme differences `psi = atanh(2 phi - 1)` rather than `phi`.
    pub fn uses_psi(self) -> bool {
        matches!(self, NormalScheme::Atanh2 | NormalScheme::Atanh4 | NormalScheme::Deconvolved)
    }

    /// A short snake_case name (for tables and command lines).
    pub fn name(self) -> &'static str {
        match self {
            NormalScheme::Youngs => "youngs",
            NormalScheme::CentralPhi => "central_phi",
            NormalScheme::Atanh2 => "atanh2",
            NormalScheme::Atanh4 => "atanh4",
            NormalScheme::Deconvolved => "deconvolved",
        }
    }

    /// Parses [`NormalScheme::name`].
    pub fn from_name(s: &str) -> crate::Result<Self> {
        Self::ALL.into_iter().find(|x| x.name() == s).ok_or_else(|| {
            crate::Error::invalid(
                "normal scheme",
                s,
                "one of youngs, central_phi, atanh2, atanh4, deconvolved",
            )
        })
    }
}

/// Curvature at a point: the tensor `kappa = -P . grad n . P` and the mean curvature
/// `tr(kappa) / (D - 1)` (see the [module docs](self) for signs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curvature<T> {
    /// The symmetric curvature tensor, components in the order of [`crate::tensor`].
    pub tensor: Sym<T>,
    /// The mean curvature (`1 / R` for a sphere or a circle of radius `R`).
    pub mean: T,
}

/// A range `lower < phi < upper` of `phi`: the cells around the interface where the geometry
/// (normals, `delta`, curvature) is evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhiRange<T> {
    /// Cells with `phi <= lower` are outside the band.
    pub lower: T,
    /// Cells with `phi >= upper` are outside the band.
    pub upper: T,
}

impl<T: Real> PhiRange<T> {
    /// The range `lower < phi < upper`; errors unless `0 <= lower < upper <= 1`.
    pub fn new(lower: T, upper: T) -> crate::Result<Self> {
        if !(lower >= T::zero() && lower < upper && upper <= T::one()) {
            return Err(crate::Error::invalid(
                "PhiRange",
                format!("({lower}, {upper})"),
                "0 <= lower < upper <= 1",
            ));
        }
        Ok(PhiRange { lower, upper })
    }

    /// Whether a cell value lies in the band.
    #[inline(always)]
    pub fn contains(&self, phi: T) -> bool {
        phi > self.lower && phi < self.upper
    }
}

/// Clamp of `phi` before the inverse-tanh transform: `phi` is kept in `[e, 1 - e]` with
/// `e = max(1e-12, 100 eps)` (`|psi| <= 13.8` in f64, `<= 5.7` in f32).
#[inline(always)]
pub(crate) fn psi_clamp<T: Real>() -> T {
    T::lit(1e-12).max(T::lit(100.0) * T::eps())
}

/// The inverse-tanh transform `psi = atanh(2 phi - 1) = ln(phi / (1 - phi)) / 2` of a cell
/// value, with `phi` clamped to `[e, 1 - e]` (`e = max(1e-12, 100 eps)`); finite for every finite input.
/// For the MTHINC profile `phi = (1 + tanh(beta s / h)) / 2`, `psi = beta s / h`.
#[inline(always)]
pub fn psi_of<T: Real>(phi: T) -> T {
    let e = psi_clamp::<T>();
    let p = phi.max(e).min(T::one() - e);
    // NaN input: max/min return the other operand, so p stays finite.
    let p = if p.is_nan() { T::lit(0.5) } else { p };
    T::lit(0.5) * (p / (T::one() - p)).ln()
}

/// Strides and spacing of a stencil evaluation.
#[derive(Clone, Copy)]
struct Stencil<T> {
    st: [isize; 3],
    h: [T; 3],
    /// 2D grid: z-derivatives are zero and z-neighbours are skipped.
    planar: bool,
}

impl<T: Real> Stencil<T> {
    fn new(grid: &Grid<T>) -> Self {
        let s = grid.strides();
        Stencil { st: [s[0] as isize, s[1] as isize, s[2] as isize], h: grid.h(), planar: grid.is_2d() }
    }
    #[inline(always)]
    fn axes(&self) -> usize {
        if self.planar { 2 } else { 3 }
    }
}

const fn others(d: usize) -> (usize, usize) {
    match d {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Youngs' gradient at a cell centre: central differences weighted `(1, 2, 1) / 4` in each
/// transverse direction (the average of the 8 node gradients).
#[inline(always)]
fn youngs_gradient<T: Real, F: Fn(isize) -> T>(f: &F, s: &Stencil<T>) -> Vec3<T> {
    let w = [T::lit(0.25), T::lit(0.5), T::lit(0.25)];
    let mut g = [T::zero(); 3];
    for (d, gd) in g.iter_mut().enumerate().take(s.axes()) {
        let (t1, t2) = others(d);
        let mut sum = T::zero();
        for a in -1isize..=1 {
            let (b_lo, b_hi) = if s.planar && t2 == 2 { (0, 0) } else { (-1, 1) };
            for b in b_lo..=b_hi {
                let wb = if s.planar && t2 == 2 { T::one() } else { w[(b + 1) as usize] };
                let off = a * s.st[t1] + b * s.st[t2];
                sum += w[(a + 1) as usize] * wb * (f(off + s.st[d]) - f(off - s.st[d]));
            }
        }
        *gd = sum / (T::lit(2.0) * s.h[d]);
    }
    g
}

/// Gradient and (optionally) Hessian of the level function by central differences of order 2
/// or 4.
#[allow(clippy::needless_range_loop)] // symmetric fill of hm[d][e] and hm[e][d]
#[inline(always)]
fn central_grad_hess<T: Real, F: Fn(isize) -> T>(
    f: &F,
    s: &Stencil<T>,
    fourth: bool,
    hess: bool,
) -> (Vec3<T>, [[T; 3]; 3]) {
    let mut g = [T::zero(); 3];
    let mut hm = [[T::zero(); 3]; 3];
    let n = s.axes();
    // First-derivative stencil along axis d, applied at an extra offset.
    let d1 = |d: usize, off: isize| -> T {
        let sd = s.st[d];
        if fourth {
            (T::lit(8.0) * (f(off + sd) - f(off - sd)) - (f(off + 2 * sd) - f(off - 2 * sd)))
                / (T::lit(12.0) * s.h[d])
        } else {
            (f(off + sd) - f(off - sd)) / (T::lit(2.0) * s.h[d])
        }
    };
    for (d, gd) in g.iter_mut().enumerate().take(n) {
        *gd = d1(d, 0);
    }
    if hess {
        let f0 = f(0);
        for d in 0..n {
            let sd = s.st[d];
            let h2 = s.h[d] * s.h[d];
            hm[d][d] = if fourth {
                (T::lit(16.0) * (f(sd) + f(-sd)) - (f(2 * sd) + f(-2 * sd)) - T::lit(30.0) * f0)
                    / (T::lit(12.0) * h2)
            } else {
                (f(sd) + f(-sd) - T::lit(2.0) * f0) / h2
            };
            for e in d + 1..n {
                let se = s.st[e];
                let v = if fourth {
                    (T::lit(8.0) * (d1(d, se) - d1(d, -se)) - (d1(d, 2 * se) - d1(d, -2 * se)))
                        / (T::lit(12.0) * s.h[e])
                } else {
                    (d1(d, se) - d1(d, -se)) / (T::lit(2.0) * s.h[e])
                };
                hm[d][e] = v;
                hm[e][d] = v;
            }
        }
    }
    (g, hm)
}

#[inline(always)]
fn norm<T: Real>(g: &Vec3<T>) -> T {
    (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
}

/// Smallest gradient norm (times the spacing) accepted as defining a normal.
#[inline(always)]
fn gradient_floor<T: Real>() -> T {
    T::lit(1e-3) * T::eps().sqrt()
}

#[inline(always)]
fn unit<T: Real>(g: Vec3<T>, hmin: T) -> Option<(Vec3<T>, T)> {
    let m = norm(&g);
    if m.is_finite() && m * hmin > gradient_floor::<T>() {
        Some(([g[0] / m, g[1] / m, g[2] / m], m))
    } else {
        None
    }
}

/// Gradient of the level function of `scheme` (`phi` for Youngs and CentralPhi, `psi` for the
/// inverse-tanh schemes) read through `f(offset)`.
#[inline(always)]
fn level_gradient<T: Real, F: Fn(isize) -> T>(scheme: NormalScheme, f: &F, s: &Stencil<T>) -> Vec3<T> {
    match scheme {
        NormalScheme::Youngs => youngs_gradient(f, s),
        NormalScheme::CentralPhi | NormalScheme::Atanh2 => central_grad_hess(f, s, false, false).0,
        NormalScheme::Atanh4 | NormalScheme::Deconvolved => central_grad_hess(f, s, true, false).0,
    }
}

#[inline(always)]
fn hmin<T: Real>(s: &Stencil<T>) -> T {
    let mut m = s.h[0].min(s.h[1]);
    if !s.planar {
        m = m.min(s.h[2]);
    }
    m
}

/// Curvature from a level function read through `f(offset)`.
#[inline(always)]
fn level_curvature<T: Real, F: Fn(isize) -> T>(
    scheme: NormalScheme,
    f: &F,
    s: &Stencil<T>,
) -> Option<Curvature<T>> {
    let dim_minus_one = if s.planar { T::one() } else { T::lit(2.0) };
    let hm = hmin(s);
    let (n, gn) = match scheme {
        NormalScheme::Youngs => {
            let (n, _) = unit(youngs_gradient(f, s), hm)?;
            (n, youngs_grad_n(f, s))
        }
        NormalScheme::CentralPhi => {
            // phi is far from linear across the band: difference the unit normals of the
            // neighbours (radius 2) rather than phi's Hessian.
            let (n, _) = unit(central_grad_hess(f, s, false, false).0, hm)?;
            let mut gn = [[T::zero(); 3]; 3];
            for (i, row) in gn.iter_mut().enumerate().take(s.axes()) {
                let si = s.st[i];
                let up = unit(central_grad_hess(&|o| f(o + si), s, false, false).0, hm)?.0;
                let dn = unit(central_grad_hess(&|o| f(o - si), s, false, false).0, hm)?.0;
                for j in 0..3 {
                    row[j] = (up[j] - dn[j]) / (T::lit(2.0) * s.h[i]);
                }
            }
            (n, gn)
        }
        _ => {
            let fourth = matches!(scheme, NormalScheme::Atanh4 | NormalScheme::Deconvolved);
            let (g, hs) = central_grad_hess(f, s, fourth, true);
            let (n, m) = unit(g, hm)?;
            let mut gn = hs;
            // grad n = S . P / |g|
            let p = crate::tensor::sym_to_mat(&projector(&n));
            for (i, row) in gn.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    *x = (hs[i][0] * p[0][j] + hs[i][1] * p[1][j] + hs[i][2] * p[2][j]) / m;
                }
            }
            (n, gn)
        }
    };
    let p = crate::tensor::sym_to_mat(&projector(&n));
    let pgp = crate::tensor::matmul(&crate::tensor::matmul(&p, &gn), &p);
    let mut k = crate::tensor::mat_to_sym(&pgp);
    for x in k.iter_mut() {
        *x = -*x;
    }
    let mean = crate::tensor::trace(&k) / dim_minus_one;
    if mean.is_finite() { Some(Curvature { tensor: k, mean }) } else { None }
}

/// `grad n` at a cell centre from Youngs node normals (each node normal from the 8 cells
/// around the node), differenced across the cell.
#[inline(always)]
fn youngs_grad_n<T: Real, F: Fn(isize) -> T>(f: &F, s: &Stencil<T>) -> [[T; 3]; 3] {
    let mut gn = [[T::zero(); 3]; 3];
    let cs: &[isize] = if s.planar { &[1] } else { &[-1, 1] };
    let quarter = T::lit(0.25);
    for &c in cs {
        for b in [-1isize, 1] {
            for a in [-1isize, 1] {
                let sgn = [a, b, c];
                // Node gradient from the cells {0, a} x {0, b} x {0, c}.
                let mut g = [T::zero(); 3];
                for (d, gd) in g.iter_mut().enumerate().take(s.axes()) {
                    let (t1, t2) = others(d);
                    let mut sum = T::zero();
                    let q2: &[isize] = if s.planar && t2 == 2 { &[0] } else { &[0, 1] };
                    for p1 in [0isize, 1] {
                        for &p2 in q2 {
                            let off = p1 * sgn[t1] * s.st[t1] + p2 * sgn[t2] * s.st[t2];
                            sum += f(off + sgn[d] * s.st[d]) - f(off);
                        }
                    }
                    let count = if q2.len() == 1 { T::lit(2.0) } else { T::lit(4.0) };
                    *gd = T::from_isize(sgn[d]).unwrap_or(T::one()) * sum / (count * s.h[d]);
                }
                let m = norm(&g);
                if m.is_nan() || m <= T::zero() {
                    continue;
                }
                let w = if s.planar { T::lit(0.5) } else { quarter };
                for (i, row) in gn.iter_mut().enumerate().take(s.axes()) {
                    let si = T::from_isize(sgn[i]).unwrap_or(T::one()) * w / s.h[i];
                    for j in 0..3 {
                        row[j] += si * g[j] / m;
                    }
                }
            }
        }
    }
    gn
}

/// `delta = |grad phi|` (2.26) at cell `idx`, by second-order central differences of `phi`.
///
/// # Panics
///
/// If `idx` or a neighbour it reads is outside the storage of `phi` (never for an interior
/// cell of a field of `grid`).
#[inline]
pub fn delta_at<T: Real>(grid: &Grid<T>, phi: &Field<T>, idx: usize) -> T {
    let s = Stencil::new(grid);
    let f = |o: isize| phi.data[(idx as isize + o) as usize];
    norm(&central_grad_hess(&f, &s, false, false).0)
}

/// Cells with `phi` within this of 0 or 1 keep `psi` in the deconvolved level field.
#[inline(always)]
fn deconvolve_tiny<T: Real>() -> T {
    T::lit(1e-7).max(T::lit(1000.0) * T::eps())
}

/// The deconvolved level value of the cell at `idx`: the MTHINC offset `D` with the
/// fourth-order `psi` normal, or `psi` where `phi` is saturated or the normal vanishes.
#[inline]
fn deconvolved_value<T: Real, F: Fn(isize) -> T>(psi: &F, phi: T, s: &Stencil<T>, scale: [T; 3]) -> T {
    let tiny = deconvolve_tiny::<T>();
    if !(phi > tiny && phi < T::one() - tiny) {
        return psi(0);
    }
    let g = central_grad_hess(psi, s, true, false).0;
    match unit(g, hmin(s)) {
        Some((n, _)) => {
            let a = [n[0] * scale[0], n[1] * scale[1], n[2] * scale[2]];
            super::mthinc::solve_offset(a, phi, tiny, super::mthinc::CellQuadrature::ExactAlongNormal)
                .map_or_else(|| psi(0), |x| x.offset)
        }
        None => psi(0),
    }
}

/// `beta' h` per axis for a profile sharpness `beta`.
fn profile_scale<T: Real>(grid: &Grid<T>, beta: T) -> [T; 3] {
    let bp = beta / super::advect::characteristic_length(grid);
    let h = grid.h();
    [bp * h[0], bp * h[1], bp * h[2]]
}

/// Runs `f` with the level function of `scheme` around `idx`, computed on the fly from `phi`.
#[inline(always)]
fn on_the_fly<T: Real, R>(
    grid: &Grid<T>,
    scheme: NormalScheme,
    phi: &Field<T>,
    idx: usize,
    f: impl FnOnce(&dyn Fn(isize) -> T, &Stencil<T>) -> R,
) -> R {
    let s = Stencil::new(grid);
    let d = &phi.data;
    let at = |o: isize| (idx as isize + o) as usize;
    match scheme {
        NormalScheme::Youngs | NormalScheme::CentralPhi => f(&|o| d[at(o)], &s),
        NormalScheme::Atanh2 | NormalScheme::Atanh4 => f(&|o| psi_of(d[at(o)]), &s),
        NormalScheme::Deconvolved => {
            let scale = profile_scale(grid, T::one());
            f(
                &|o| {
                    let j = at(o) as isize;
                    deconvolved_value(&|q| psi_of(d[(j + q) as usize]), d[j as usize], &s, scale)
                },
                &s,
            )
        }
    }
}

/// The unit normal (into the capsule) at cell `idx`, or `None` where the gradient vanishes
/// (a flat `phi`). For the inverse-tanh schemes `psi` is computed on the fly from `phi`; for
/// many cells use a [`Geometry`], which caches it.
///
/// # Panics
///
/// If the stencil around `idx` leaves the storage of `phi`: never for an interior cell of a
/// field of `grid`, except with [`NormalScheme::Deconvolved`] in the outermost layer of cells
/// (see the [module docs](self#panics)).
#[inline]
pub fn normal_at<T: Real>(
    grid: &Grid<T>,
    scheme: NormalScheme,
    phi: &Field<T>,
    idx: usize,
) -> Option<Vec3<T>> {
    on_the_fly(grid, scheme, phi, idx, |f, s| unit(level_gradient(scheme, &f, s), hmin(s)).map(|x| x.0))
}

/// The curvature at cell `idx` (see the [module docs](self) for definitions and signs), or
/// `None` where the gradient vanishes. For the inverse-tanh schemes `psi` is computed on the
/// fly; for many cells use a [`Geometry`].
///
/// # Panics
///
/// If the stencil around `idx` leaves the storage of `phi`: never for an interior cell of a
/// field of `grid`, except with [`NormalScheme::Deconvolved`] in the outermost layer of cells
/// (see the [module docs](self#panics)).
#[inline]
pub fn curvature_at<T: Real>(
    grid: &Grid<T>,
    scheme: NormalScheme,
    phi: &Field<T>,
    idx: usize,
) -> Option<Curvature<T>> {
    on_the_fly(grid, scheme, phi, idx, |f, s| level_curvature(scheme, &f, s))
}

/// Fills `psi` from `phi` at every stored cell (saturated cells by a constant, no logarithm).
fn fill_psi<T: Real>(grid: &Grid<T>, phi: &Field<T>, psi: &mut Field<T>) {
    let e = psi_clamp::<T>();
    let lo = psi_of(T::zero());
    let hi = psi_of(T::one());
    psi.data.par_chunks_mut(grid.dims()[0]).zip(phi.data.par_chunks(grid.dims()[0])).for_each(
        |(out, inp)| {
            for (o, &p) in out.iter_mut().zip(inp) {
                *o = if p <= e {
                    lo
                } else if p >= T::one() - e {
                    hi
                } else {
                    psi_of(p)
                };
            }
        },
    );
}

/// Field-level geometry: caches `psi = atanh(2 phi - 1)` for the inverse-tanh schemes (and the
/// deconvolved level field) and fills
/// fields of normals, curvature tensors, mean curvature (and, free function, delta) restricted
/// to a [`PhiRange`]. Create it once; its
/// methods allocate nothing.
///
/// ```
/// use eulermembrane::grid::{Field, Grid};
/// use eulermembrane::interface::geometry::{PhiRange, Geometry, NormalScheme};
/// let g = Grid::<f64>::periodic([16, 16, 16], [0.0; 3], [1.0; 3]).unwrap();
/// let mut phi = Field::from_cell_fn(&g, |x| {
///     let r = ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
///     0.5 * (1.0 + ((0.3 - r) * 16.0).tanh())
/// });
/// phi.fill_ghosts(&g);
/// let mut geo = Geometry::new(&g, NormalScheme::Atanh4);
/// geo.update(&g, &phi);
/// let c = geo.curvature(&g, &phi, g.idx(12, 8, 8)).unwrap();
/// assert!((c.mean - 1.0 / 0.3).abs() < 0.3); // 1/R, R = 0.3, at a cell centre near r = R
/// ```
#[derive(Debug, Clone)]
pub struct Geometry<T> {
    scheme: NormalScheme,
    beta: T,
    /// `psi` (inverse-tanh schemes) or the deconvolved level field.
    level: Field<T>,
    /// `psi` for the deconvolved scheme.
    psi: Field<T>,
}

impl<T: Real> Geometry<T> {
    /// A geometry workspace for `grid` (allocates the level-field cache the scheme needs),
    /// assuming the profile sharpness `beta = 1` (only [`NormalScheme::Deconvolved`] uses it).
    pub fn new(grid: &Grid<T>, scheme: NormalScheme) -> Self {
        let empty = || Field { data: Vec::new() };
        Geometry {
            scheme,
            beta: T::one(),
            level: if scheme.uses_psi() { Field::zeros(grid) } else { empty() },
            psi: if scheme == NormalScheme::Deconvolved { Field::zeros(grid) } else { empty() },
        }
    }

    /// Sets the profile sharpness `beta` of the fields this geometry will see (errors unless in
    /// `(0, 10]`).
    pub fn with_beta(mut self, beta: T) -> crate::Result<Self> {
        if !(beta > T::zero() && beta <= T::lit(10.0)) {
            return Err(crate::Error::invalid(
                "Geometry beta",
                beta,
                "a number in (0, 10] (the paper uses 1)",
            ));
        }
        self.beta = beta;
        Ok(self)
    }

    /// The normal construction in use.
    pub fn scheme(&self) -> NormalScheme {
        self.scheme
    }

    /// Recomputes the cache from `phi` (ghosts filled): `psi` at every stored cell, ghosts
    /// included, and for [`NormalScheme::Deconvolved`] the offsets `D` at the interior cells
    /// (ghosts then filled like `phi`'s). Must be called after every change of `phi` and before
    /// the other methods.
    pub fn update(&mut self, grid: &Grid<T>, phi: &Field<T>) {
        if !self.scheme.uses_psi() {
            return;
        }
        let deconvolve = self.scheme == NormalScheme::Deconvolved;
        let psi = if deconvolve { &mut self.psi } else { &mut self.level };
        fill_psi(grid, phi, psi);
        if deconvolve {
            let s = Stencil::new(grid);
            let scale = profile_scale(grid, self.beta);
            let psi = &self.psi.data;
            crate::grid::ops::par_interior(grid, &mut self.level.data, |idx, _, _, _| {
                let j = idx as isize;
                deconvolved_value(&|q| psi[(j + q) as usize], phi.data[idx], &s, scale)
            });
            self.level.fill_ghosts(grid);
        }
    }

    #[inline(always)]
    fn with_level<R>(&self, phi: &Field<T>, idx: usize, f: impl FnOnce(&dyn Fn(isize) -> T) -> R) -> R {
        let d = if self.scheme.uses_psi() { &self.level.data } else { &phi.data };
        f(&|o: isize| d[(idx as isize + o) as usize])
    }

    /// The unit normal at cell `idx` (see [`normal_at`]).
    ///
    /// # Panics
    ///
    /// If the stencil around `idx` leaves the storage of `phi` or of the cache (never for an
    /// interior cell of a field of the grid this geometry was made for).
    #[inline]
    pub fn normal(&self, grid: &Grid<T>, phi: &Field<T>, idx: usize) -> Option<Vec3<T>> {
        let s = Stencil::new(grid);
        let g = self.with_level(phi, idx, |f| level_gradient(self.scheme, &f, &s));
        unit(g, hmin(&s)).map(|x| x.0)
    }

    /// The curvature at cell `idx` (see [`curvature_at`]).
    ///
    /// # Panics
    ///
    /// If the stencil around `idx` leaves the storage of `phi` or of the cache (never for an
    /// interior cell of a field of the grid this geometry was made for).
    #[inline]
    pub fn curvature(&self, grid: &Grid<T>, phi: &Field<T>, idx: usize) -> Option<Curvature<T>> {
        let s = Stencil::new(grid);
        self.with_level(phi, idx, |f| level_curvature(self.scheme, &f, &s))
    }

    /// Unit normals at the interior cells of `band` into `out` (three cell-centred components);
    /// zero outside the band and where the gradient vanishes. Ghosts of `out` are not touched.
    pub fn normals(&self, grid: &Grid<T>, phi: &Field<T>, band: PhiRange<T>, out: &mut [Field<T>; 3]) {
        let [o0, o1, o2] = out;
        let dx = grid.dims()[0];
        let nx = grid.n()[0];
        let g0 = crate::grid::GHOST;
        o0.data
            .par_chunks_mut(dx)
            .zip(o1.data.par_chunks_mut(dx))
            .zip(o2.data.par_chunks_mut(dx))
            .enumerate()
            .for_each(|(row, ((l0, l1), l2))| {
                if grid.row_jk(row).is_none() {
                    return;
                }
                for i in g0..g0 + nx {
                    let idx = row * dx + i;
                    let n = if band.contains(phi.data[idx]) {
                        self.normal(grid, phi, idx).unwrap_or([T::zero(); 3])
                    } else {
                        [T::zero(); 3]
                    };
                    l0[i] = n[0];
                    l1[i] = n[1];
                    l2[i] = n[2];
                }
            });
    }

    /// Mean curvature at the interior cells of `band` into `out`; zero elsewhere.
    pub fn mean_curvature(&self, grid: &Grid<T>, phi: &Field<T>, band: PhiRange<T>, out: &mut Field<T>) {
        crate::grid::ops::par_interior(grid, &mut out.data, |idx, _, _, _| {
            if band.contains(phi.data[idx]) {
                self.curvature(grid, phi, idx).map_or(T::zero(), |c| c.mean)
            } else {
                T::zero()
            }
        });
    }
}

impl<T: Real> Geometry<T> {
    /// Curvature tensors `kappa = -P . grad n . P` at the interior cells of `band` into `out`
    /// (components in the order of [`crate::tensor`]); zero elsewhere and where the gradient
    /// vanishes. Ghosts of `out` are not touched.
    pub fn curvature_tensors(
        &self,
        grid: &Grid<T>,
        phi: &Field<T>,
        band: PhiRange<T>,
        out: &mut crate::grid::SymField<T>,
    ) {
        let dx = grid.dims()[0];
        let nx = grid.n()[0];
        let g0 = crate::grid::GHOST;
        let [c0, c1, c2, c3, c4, c5] = &mut out.c;
        c0.data
            .par_chunks_mut(dx)
            .zip(c1.data.par_chunks_mut(dx))
            .zip(c2.data.par_chunks_mut(dx))
            .zip(c3.data.par_chunks_mut(dx))
            .zip(c4.data.par_chunks_mut(dx))
            .zip(c5.data.par_chunks_mut(dx))
            .enumerate()
            .for_each(|(row, (((((l0, l1), l2), l3), l4), l5))| {
                if grid.row_jk(row).is_none() {
                    return;
                }
                for i in g0..g0 + nx {
                    let idx = row * dx + i;
                    let k = if band.contains(phi.data[idx]) {
                        self.curvature(grid, phi, idx).map_or([T::zero(); 6], |k| k.tensor)
                    } else {
                        [T::zero(); 6]
                    };
                    (l0[i], l1[i], l2[i], l3[i], l4[i], l5[i]) = (k[0], k[1], k[2], k[3], k[4], k[5]);
                }
            });
    }
}

/// The strategy that estimates the unit normal `n = grad phi / |grad phi|` (2.24) of a capsule
/// from its `phi`, once per step: the `n` of the membrane mechanics (`P = I - n n` in the
/// stress, the re-set of `G_s`, the bending force).
///
/// The default is a [`Geometry`] with [`Settings::normals`](crate::simulation::Settings::normals)
/// (a [`NormalScheme`], [`Atanh4`](NormalScheme::Atanh4) unless set): the enum names the
/// construction, the `Geometry` adds the cache of `psi` that makes it cost one pass.
/// [`Scene::normal_estimator`](crate::simulation::Scene::normal_estimator) takes a user's; the
/// simulation calls it for every capsule after each transport, through one dynamic dispatch,
/// and it must not allocate in the step.
///
/// A user estimator that wraps the default one and counts its calls:
///
/// ```
/// use eulermembrane::grid::{Field, Grid};
/// use eulermembrane::interface::geometry::{Geometry, NormalEstimator, NormalScheme, PhiRange};
/// use eulermembrane::prelude::*;
///
/// struct Counted(Geometry<f64>, usize);
/// impl NormalEstimator<f64> for Counted {
///     fn name(&self) -> &str {
///         "counted_atanh4"
///     }
///     fn estimate(
///         &mut self,
///         grid: &Grid<f64>,
///         phi: &Field<f64>,
///         band: PhiRange<f64>,
///         out: &mut [Field<f64>; 3],
///     ) -> eulermembrane::Result<()> {
///         self.1 += 1;
///         self.0.estimate(grid, phi, band, out)
///     }
/// }
///
/// let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
/// let mut sim = Scene::new(grid.clone(), Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.5; 3], 0.25)?)
///     .normal_estimator(Counted(Geometry::new(&grid, NormalScheme::Atanh4), 0))
///     .build()?;
/// sim.step(1e-3)?;
/// assert!(sim.numerics().contains("normals=counted_atanh4"));
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub trait NormalEstimator<T: Real>: Send + Sync {
    /// A short snake_case name, for [`Simulation::numerics`](crate::simulation::Simulation::numerics).
    fn name(&self) -> &str;

    /// Unit normals (pointing into the capsule) at the interior cells where `band` contains
    /// `phi` (ghosts of `phi` filled), into the three cell-centred components of `out`; zero
    /// elsewhere and where the gradient vanishes. The ghosts of `out` are the caller's.
    ///
    /// # Errors
    /// Whatever keeps the estimate from being made; the step then fails and leaves the state
    /// as it was.
    fn estimate(
        &mut self,
        grid: &Grid<T>,
        phi: &Field<T>,
        band: PhiRange<T>,
        out: &mut [Field<T>; 3],
    ) -> crate::Result<()>;
}

/// The default estimator: [`Geometry::update`] then [`Geometry::normals`].
impl<T: Real> NormalEstimator<T> for Geometry<T> {
    fn name(&self) -> &str {
        self.scheme.name()
    }

    fn estimate(
        &mut self,
        grid: &Grid<T>,
        phi: &Field<T>,
        band: PhiRange<T>,
        out: &mut [Field<T>; 3],
    ) -> crate::Result<()> {
        self.update(grid, phi);
        self.normals(grid, phi, band, out);
        Ok(())
    }
}

/// `delta = |grad phi|` (2.26) at the interior cells of `band` into `out`; zero elsewhere.
pub fn delta_in_band<T: Real>(grid: &Grid<T>, phi: &Field<T>, band: PhiRange<T>, out: &mut Field<T>) {
    crate::grid::ops::par_interior(grid, &mut out.data, |idx, _, _, _| {
        if band.contains(phi.data[idx]) { delta_at(grid, phi, idx) } else { T::zero() }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tanh_sphere(n: usize, r: f64) -> (Grid<f64>, Field<f64>) {
        let g = Grid::<f64>::periodic([n, n, n], [0.0; 3], [n as f64; 3]).unwrap();
        let c = n as f64 / 2.0 + 0.1;
        let mut phi = Field::from_cell_fn(&g, |x| {
            let d = ((x[0] - c).powi(2) + (x[1] - c).powi(2) + (x[2] - c).powi(2)).sqrt();
            0.5 * (1.0 + (r - d).tanh())
        });
        phi.fill_ghosts(&g);
        (g, phi)
    }

    #[test]
    fn signs_on_a_sphere() {
        let (g, phi) = tanh_sphere(24, 7.0);
        for scheme in NormalScheme::ALL {
            let idx = g.idx(19, 12, 12);
            let n = normal_at(&g, scheme, &phi, idx).unwrap();
            assert!(n[0] < -0.99, "{scheme:?} {n:?}"); // points inward (towards -x)
            let k = curvature_at(&g, scheme, &phi, idx).unwrap();
            let r = 19.5 - 12.1;
            assert!((k.mean - 1.0 / r).abs() < 0.3 / r, "{scheme:?} {}", k.mean);
            // kappa = P / r: the normal direction has no curvature.
            assert!(k.tensor[0].abs() < 0.05 / r, "{scheme:?} {:?}", k.tensor);
        }
    }

    #[test]
    fn flat_and_saturated_fields_give_no_normal() {
        let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
        for v in [0.0, 1.0, 0.5] {
            let mut phi = Field::zeros(&g);
            phi.fill(v);
            for scheme in NormalScheme::ALL {
                assert!(normal_at(&g, scheme, &phi, g.idx(3, 3, 3)).is_none());
                assert!(curvature_at(&g, scheme, &phi, g.idx(3, 3, 3)).is_none());
            }
            assert_eq!(delta_at(&g, &phi, g.idx(3, 3, 3)), 0.0);
        }
        assert!(psi_of(f64::NAN).is_finite());
        assert!(psi_of(-1.0_f64).is_finite() && psi_of(2.0_f64).is_finite());
    }

    #[test]
    fn geometry_cache_matches_on_the_fly() {
        let (g, phi) = tanh_sphere(16, 5.0);
        for scheme in NormalScheme::ALL {
            let mut geo = Geometry::new(&g, scheme);
            geo.update(&g, &phi);
            let idx = g.idx(13, 9, 7);
            let a = geo.curvature(&g, &phi, idx).unwrap();
            let b = curvature_at(&g, scheme, &phi, idx).unwrap();
            assert!((a.mean - b.mean).abs() < 1e-12);
        }
    }
}
