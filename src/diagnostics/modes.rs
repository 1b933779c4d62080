//! Spherical-harmonic modes of the membrane shape (Sec. 3.2, (3.2)-(3.4)).
//!
//! The radius seen from the centroid `x_c` ((3.5), [`centroid`](super::volume::centroid)) is expanded as
//!
//! ```text
//! r(theta, varphi) = sum_n [ R_{n,0} Y_{n,0} + sum_{m=1..n} ( R^(c)_{n,m} Y^(c)_{n,m} + R^(s)_{n,m} Y^(s)_{n,m} ) ]   (3.2)
//! Y_{n,0} = P_{n,0}(cos theta) / sqrt(2 pi),
//! Y^(c)_{n,m} = P_{n,m}(cos theta) cos(m varphi) / sqrt(pi),   Y^(s)_{n,m} = P_{n,m}(cos theta) sin(m varphi) / sqrt(pi),
//! ```
//!
//! with `P_{n,m}` the **fully normalised** associated Legendre functions,
//! `int_{-1}^{1} P_{n,m}(x)^2 dx = 1`, without the Condon-Shortley phase
//! (`P_{n,m} = sqrt((2n+1)/2 (n-m)!/(n+m)!) (1-x^2)^{m/2} d^m P_n/dx^m`, so `P_{0,0} = 1/sqrt 2`,
//! `P_{2,0} = sqrt(5/2) (3x^2-1)/2`). The `Y` are then orthonormal on the unit sphere, and their
//! prefactors `1/sqrt(2 pi)`, `1/sqrt(pi)` are those of (3.3). The angles are those of (3.4):
//! `cos theta = (z - z_c)/|x - x_c|`, `varphi = atan2(y - y_c, x - x_c)`, displacements unwrapped
//! across periodic boundaries. The coefficients are estimated on the grid as (3.3),
//!
//! ```text
//! R_{n,m} = sum_ijk delta_ijk w_ijk Y_{n,m}(theta_ijk, varphi_ijk) dx dy dz,             (3.3)
//! ```
//!
//! i.e. `int_S w Y dA` by the coarea formula, with a weight `w` chosen by [`ModeWeight`]:
//!
//! - [`ModeWeight::Area`]: `w = 1`, (3.3) exactly as printed. The modes are those of the area
//!   density `dA/dOmega` (`~ r^2` for a near-sphere); a sphere of radius `r` gives
//!   `R_{0,0} = 2 sqrt(pi) r^2`, so `r = sqrt(R_{0,0} / (2 sqrt pi))`.
//! - [`ModeWeight::Radius`]: `w = 1/|x - x_c|`. Since `dOmega = (n_out . e_r) dA / r^2`, this
//!   is `int r Y dOmega` up to `1 - n_out . e_r = O(eps^2)` for a shape `eps` away from a sphere:
//!   the coefficients of (3.2) themselves to first order. A sphere gives `R_{0,0} = 2 sqrt(pi) r`.
//! - [`ModeWeight::SolidAngle`]: `w = (n_out . e_r)/|x - x_c|` with the membrane normals, exactly
//!   the coefficients of (3.2) for any star-shaped surface (`r = R_{0,0}/(2 sqrt pi)` for a
//!   sphere; `r = R (1 + eps P_2(cos theta))` gives `R_{2,0} = sqrt(4 pi / 5) eps R` and every
//!   other mode with `n >= 1` zero).
//!
//! The amplitudes plotted in Figs. 7-8 are `|R_{n,0}|` and
//! `|R_{n,m}| = sqrt((R^(c)_{n,m})^2 + (R^(s)_{n,m})^2)`, see [`SurfaceModes::amplitude`].
//! A sphere has zero modes for `n >= 1`; on the grid they are zero up to the discretisation
//! error of `delta` (and of the normals).

use super::reduce::{check_field, check_point, frames, non_finite, reduce_cells};
use crate::grid::{Field, Grid};
use crate::{Error, Real, Result};
use std::f64::consts::PI;

/// The weight `w` of the surface integral `R = int_S w Y dA` (see the [module docs](self)).
#[derive(Debug, Clone, Copy)]
pub enum ModeWeight<'a, T> {
    /// `w = 1`: (3.3) as printed, modes of the area density; a sphere gives
    /// `R_{0,0} = 2 sqrt(pi) r^2`.
    Area,
    /// `w = 1/|x - x_c|`: the radius expansion (3.2) to first order in the departure from a
    /// sphere; a sphere gives `R_{0,0} = 2 sqrt(pi) r`.
    Radius,
    /// `w = (n_out . e_r)/|x - x_c|`: the radius expansion (3.2), exact for star-shaped
    /// surfaces. `normals` are the membrane normals at cell centres in the crate's convention,
    /// pointing *into* the capsule (`grad phi / |grad phi|`; normalised here, so
    /// `grad phi` itself will do).
    SolidAngle {
        /// Components of the inward normal at cell centres.
        normals: &'a [Field<T>; 3],
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Area,
    Radius,
}

/// Coefficients `R_{n,0}`, `R^(c)_{n,m}`, `R^(s)_{n,m}` for `0 <= m <= n <= n_max`.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceModes {
    n_max: usize,
    centre: [f64; 3],
    kind: Kind,
    /// `R^(c)_{n,m}` at `tri(n, m)` (with `R^(c)_{n,0} = R_{n,0}`).
    cos: Vec<f64>,
    /// `R^(s)_{n,m}` at `tri(n, m)` (zero for `m = 0`).
    sin: Vec<f64>,
}

#[inline]
fn tri(n: usize, m: usize) -> usize {
    n * (n + 1) / 2 + m
}

impl SurfaceModes {
    /// Largest degree `n` computed.
    pub fn n_max(&self) -> usize {
        self.n_max
    }

    /// The centre `x_c` the angles were measured from.
    pub fn centre(&self) -> [f64; 3] {
        self.centre
    }

    /// `R_{n,0}`; `None` if `n > n_max`.
    pub fn zonal(&self, n: usize) -> Option<f64> {
        (n <= self.n_max).then(|| self.cos[tri(n, 0)])
    }

    /// `R^(c)_{n,m}` (equal to `R_{n,0}` for `m = 0`); `None` unless `m <= n <= n_max`.
    pub fn cos(&self, n: usize, m: usize) -> Option<f64> {
        (m <= n && n <= self.n_max).then(|| self.cos[tri(n, m)])
    }

    /// `R^(s)_{n,m}` (zero for `m = 0`); `None` unless `m <= n <= n_max`.
    pub fn sin(&self, n: usize, m: usize) -> Option<f64> {
        (m <= n && n <= self.n_max).then(|| self.sin[tri(n, m)])
    }

    /// Amplitude `|R_{n,m}| = sqrt((R^(c)_{n,m})^2 + (R^(s)_{n,m})^2)` (`|R_{n,0}|` for `m = 0`),
    /// as in Figs. 7-8; `None` unless `m <= n <= n_max`.
    pub fn amplitude(&self, n: usize, m: usize) -> Option<f64> {
        (m <= n && n <= self.n_max).then(|| self.cos[tri(n, m)].hypot(self.sin[tri(n, m)]))
    }

    /// All amplitudes: `out[n][m] = |R_{n,m}|` for `0 <= m <= n <= n_max`.
    pub fn amplitudes(&self) -> Vec<Vec<f64>> {
        (0..=self.n_max)
            .map(|n| (0..=n).map(|m| self.cos[tri(n, m)].hypot(self.sin[tri(n, m)])).collect())
            .collect()
    }

    /// Radius of the sphere with the same `R_{0,0}`: `sqrt(R_{0,0} / (2 sqrt pi))` for
    /// [`ModeWeight::Area`] (the radius of the sphere of equal area), `R_{0,0} / (2 sqrt pi)`
    /// otherwise (the mean radius).
    pub fn equivalent_radius(&self) -> f64 {
        let r00 = self.cos[0] / (2.0 * PI.sqrt());
        match self.kind {
            Kind::Area => r00.max(0.0).sqrt(),
            Kind::Radius => r00,
        }
    }
}

/// The fully normalised associated Legendre function `P_{n,m}(x)` of the [module docs](self)
/// (`int_{-1}^{1} P_{n,m}^2 dx = 1`, no Condon-Shortley phase); `None` unless `m <= n` and
/// `-1 <= x <= 1`.
///
/// ```
/// use eulermembrane::diagnostics::modes::normalized_legendre;
/// let x = 0.3_f64;
/// let p20 = normalized_legendre(2, 0, x).unwrap();
/// assert!((p20 - (2.5_f64).sqrt() * (3.0 * x * x - 1.0) / 2.0).abs() < 1e-15);
/// assert!(normalized_legendre(1, 2, x).is_none());
/// ```
pub fn normalized_legendre(n: usize, m: usize, x: f64) -> Option<f64> {
    if m > n || !(-1.0..=1.0).contains(&x) {
        return None;
    }
    let mut p = vec![0.0; tri(n, n) + 1];
    legendre_table(n, x, (1.0 - x * x).max(0.0).sqrt(), &mut p);
    Some(p[tri(n, m)])
}

/// All `P_{n,m}(x)`, `0 <= m <= n <= n_max`, into `p[tri(n, m)]`, with `s = sqrt(1 - x^2)`, by
/// the standard stable recurrences of the fully normalised functions:
/// `P_{0,0} = 1/sqrt 2`, `P_{m,m} = sqrt((2m+1)/(2m)) s P_{m-1,m-1}`,
/// `P_{m+1,m} = sqrt(2m+3) x P_{m,m}`,
/// `P_{n,m} = a_{n,m} (x P_{n-1,m} - P_{n-2,m} / a_{n-1,m})`, `a_{n,m} = sqrt((4n^2-1)/(n^2-m^2))`.
fn legendre_table(n_max: usize, x: f64, s: f64, p: &mut [f64]) {
    let a = |n: usize, m: usize| (((4 * n * n - 1) as f64) / ((n * n - m * m) as f64)).sqrt();
    let mut pmm = std::f64::consts::FRAC_1_SQRT_2;
    for m in 0..=n_max {
        if m > 0 {
            pmm *= ((2 * m + 1) as f64 / (2 * m) as f64).sqrt() * s;
        }
        p[tri(m, m)] = pmm;
        if m < n_max {
            p[tri(m + 1, m)] = ((2 * m + 3) as f64).sqrt() * x * pmm;
        }
        for n in m + 2..=n_max {
            p[tri(n, m)] = a(n, m) * (x * p[tri(n - 1, m)] - p[tri(n - 2, m)] / a(n - 1, m));
        }
    }
}

/// Per-block accumulator: the sums, plus scratch for the Legendre table and `cos/sin(m varphi)`.
#[derive(Clone)]
struct Acc {
    cos: Vec<f64>,
    sin: Vec<f64>,
    p: Vec<f64>,
    cm: Vec<f64>,
    sm: Vec<f64>,
}

/// Largest `n_max` accepted (the recurrences are stable far beyond, but a grid cannot resolve
/// such modes).
const N_MAX_LIMIT: usize = 64;

/// Spherical-harmonic coefficients (3.3) of the surface described by `delta = |grad phi|`, about
/// `centre` (normally the [`centroid`](super::volume::centroid) (3.5)), for all `n <= n_max`, with the
/// weight `weight` (see the [module docs](self) for the normalisation).
///
/// Cells where `delta` is zero, and a cell whose centre coincides with `centre`, add nothing.
///
/// Errors: a field not on `grid`; `n_max > 64`; a non-finite `centre` or field value.
///
/// ```
/// use eulermembrane::diagnostics::{modes::ModeWeight, volume::centroid, modes::surface_modes};
/// use eulermembrane::grid::{Field, Grid};
/// // A sphere of radius 0.25 with a smooth delta of unit integral across the surface.
/// let g = Grid::<f64>::periodic([32; 3], [-0.5; 3], [0.5; 3])?;
/// let w = 1.0 / 32.0;
/// let delta = Field::from_cell_fn(&g, |x| {
///     let d = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt() - 0.25;
///     (-(d / w).powi(2)).exp() / (w * std::f64::consts::PI.sqrt())
/// });
/// let m = surface_modes(&g, &delta, [0.0; 3], 4, ModeWeight::Radius)?;
/// assert!((m.equivalent_radius() - 0.25).abs() < 1e-3);
/// assert!(m.amplitude(2, 0).unwrap() < 1e-3 * m.amplitude(0, 0).unwrap());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn surface_modes<T: Real>(
    grid: &Grid<T>,
    delta: &Field<T>,
    centre: [f64; 3],
    n_max: usize,
    weight: ModeWeight<'_, T>,
) -> Result<SurfaceModes> {
    check_field(grid, "delta", delta)?;
    check_point("centre", centre)?;
    if n_max > N_MAX_LIMIT {
        return Err(Error::invalid("n_max", n_max, "at most 64"));
    }
    let normals = match weight {
        ModeWeight::SolidAngle { normals } => {
            for c in normals {
                check_field(grid, "normals", c)?;
            }
            Some(normals)
        }
        _ => None,
    };
    let kind = if matches!(weight, ModeWeight::Area) { Kind::Area } else { Kind::Radius };
    let n = grid.n();
    let fr = frames(grid, centre);
    let off: [Vec<f64>; 3] = std::array::from_fn(|d| fr[d].cells(n[d]));
    let len = tri(n_max, n_max) + 1;
    let zero = Acc {
        cos: vec![0.0; len],
        sin: vec![0.0; len],
        p: vec![0.0; len],
        cm: vec![0.0; n_max + 1],
        sm: vec![0.0; n_max + 1],
    };
    let tiny = 1e-12 * grid.h().iter().fold(0.0f64, |a, h| a.max(h.f64()));
    let (c0, c1) = (1.0 / (2.0 * PI).sqrt(), 1.0 / PI.sqrt());
    let acc = reduce_cells(
        grid,
        zero,
        |acc: &mut Acc, idx, [i, j, k]| {
            let d = delta.data[idx].f64();
            if d == 0.0 {
                return;
            }
            let x = [off[0][i], off[1][j], off[2][k]];
            let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
            if r <= tiny {
                return;
            }
            let w = match (kind, normals) {
                (Kind::Area, _) => d,
                (Kind::Radius, None) => d / r,
                (Kind::Radius, Some(nv)) => {
                    let nn = [nv[0].data[idx].f64(), nv[1].data[idx].f64(), nv[2].data[idx].f64()];
                    let norm = (nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]).sqrt();
                    if norm == 0.0 {
                        return;
                    }
                    // Outward normal = -inward.
                    -d * (nn[0] * x[0] + nn[1] * x[1] + nn[2] * x[2]) / (norm * r * r)
                }
            };
            let rho = x[0].hypot(x[1]);
            let (ct, st) = (x[2] / r, rho / r);
            let (cp, sp) = if rho > 0.0 { (x[0] / rho, x[1] / rho) } else { (1.0, 0.0) };
            legendre_table(n_max, ct.clamp(-1.0, 1.0), st, &mut acc.p);
            acc.cm[0] = 1.0;
            acc.sm[0] = 0.0;
            for m in 1..=n_max {
                acc.cm[m] = acc.cm[m - 1] * cp - acc.sm[m - 1] * sp;
                acc.sm[m] = acc.sm[m - 1] * cp + acc.cm[m - 1] * sp;
            }
            for nn in 0..=n_max {
                acc.cos[tri(nn, 0)] += w * c0 * acc.p[tri(nn, 0)];
                for m in 1..=nn {
                    let wp = w * c1 * acc.p[tri(nn, m)];
                    acc.cos[tri(nn, m)] += wp * acc.cm[m];
                    acc.sin[tri(nn, m)] += wp * acc.sm[m];
                }
            }
        },
        |tot, b| {
            for (a, x) in tot.cos.iter_mut().zip(&b.cos) {
                *a += x;
            }
            for (a, x) in tot.sin.iter_mut().zip(&b.sin) {
                *a += x;
            }
        },
    );
    let dv = grid.cell_volume().f64();
    let cos: Vec<f64> = acc.cos.iter().map(|x| x * dv).collect();
    let sin: Vec<f64> = acc.sin.iter().map(|x| x * dv).collect();
    if !cos.iter().chain(&sin).all(|x| x.is_finite()) {
        let mut fields = vec![("delta", delta)];
        if let Some(nv) = normals {
            fields.extend([("normals[0]", &nv[0]), ("normals[1]", &nv[1]), ("normals[2]", &nv[2])]);
        }
        return Err(non_finite(grid, &fields));
    }
    Ok(SurfaceModes { n_max, centre, kind, cos, sin })
}

/// The amplitudes `|R_{n,m}|` for `0 <= m <= n <= n_max` (`out[n][m]`, Figs. 7-8): a shorthand
/// for [`surface_modes`] followed by [`SurfaceModes::amplitudes`].
pub fn mode_amplitudes<T: Real>(
    grid: &Grid<T>,
    delta: &Field<T>,
    centre: [f64; 3],
    n_max: usize,
    weight: ModeWeight<'_, T>,
) -> Result<Vec<Vec<f64>>> {
    Ok(surface_modes(grid, delta, centre, n_max, weight)?.amplitudes())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gauss-Legendre-free check: the trapezoid rule on a fine grid of `x` gives the norms.
    #[test]
    fn legendre_functions_are_orthonormal() {
        let n_max = 8;
        let k = 20000;
        let mut gram = vec![vec![0.0; tri(n_max, n_max) + 1]; tri(n_max, n_max) + 1];
        let mut p = vec![0.0; tri(n_max, n_max) + 1];
        for q in 0..k {
            // Midpoint rule in theta (x = cos theta, dx = sin theta dtheta).
            let th = (q as f64 + 0.5) * PI / k as f64;
            legendre_table(n_max, th.cos(), th.sin(), &mut p);
            let w = th.sin() * PI / k as f64;
            for a in 0..p.len() {
                for b in 0..p.len() {
                    gram[a][b] += w * p[a] * p[b];
                }
            }
        }
        for m in 0..=n_max {
            for n1 in m..=n_max {
                for n2 in m..=n_max {
                    let want = if n1 == n2 { 1.0 } else { 0.0 };
                    let got = gram[tri(n1, m)][tri(n2, m)];
                    assert!((got - want).abs() < 1e-6, "({n1},{n2},{m}) {got}");
                }
            }
        }
        // P_{2,2} = sqrt(15/16) (1 - x^2) (no Condon-Shortley phase).
        let x = 0.4;
        let want = (15.0f64 / 16.0).sqrt() * (1.0 - x * x);
        assert!((normalized_legendre(2, 2, x).unwrap() - want).abs() < 1e-14);
    }
}
