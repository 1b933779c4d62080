//! Initial shapes: the smoothed VOF function `phi` and the convolved reference curvature
//! `kappa_R tilde = delta kappa_R` of a closed surface, as cell averages.
//!
//! ```text
//! H(x)  = (1 + tanh(beta' s(x))) / 2 = sigma(2 beta' s),    beta' = beta / h     (2.42)
//! phi_ijk = <H>_ijk                                                             (2.14)
//! kt_ijk  = <|grad H| kappa_R(p(x))>_ijk,   |grad H| = 2 beta' sigma (1 - sigma)  (2.17)
//! ```
//!
//! with `s` the signed distance to the surface (**positive inside**), `p(x)` the closest surface
//! point and `kappa_R` its mean curvature (sign convention of [`super::geometry`]: `1 / R` for a
//! sphere or a circle of radius `R`). Cell averages `<.>` use a tensor Gauss-Legendre rule
//! ([`Smoothing::points`] per axis; in the xy-plane only on a 2D grid). In the profile's tails,
//! where a rule with fewer points errs by less than `1e-15` (with a safety factor of 100 on the
//! error estimate of the exponential tail), fewer points are used, and a cell average is exactly
//! 0 or 1 where `H` is that close to it over the whole cell. Where `H` and `1 - H` stay below
//! `5e-11` over the cell (outside the `phi` range the capsule geometry reads, where `phi` enters
//! only through sums) the allowed error is `1e-12` instead: at the default sharpness and 4 points,
//! 3 points from about 13 cells from the surface, 0 or 1 from about 15 (no subnormal tails).
//!
//! On periodic axes the query point is moved to the image nearest the shape's centre, so a
//! shape smaller than half the box may straddle a periodic boundary.
//!
//! The smoothed volume `sum phi h^3` exceeds the sharp one: for a surface of area `A` and mean
//! curvature `k`, `int (H - 1_{s>0}) dV = pi^2 k A / (12 beta'^2) + O(beta'^-4)`, i.e.
//! `(pi^2 / 4) (h / (beta R))^2` relative for a sphere ([`smoothed_volume_excess`]).

use super::advect::characteristic_length;
use crate::grid::{Field, Grid};
use crate::{Error, Real, Result};
use rayon::prelude::*;
use std::f64::consts::PI;

/// The closest point of a surface to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Signed distance from the query point, positive inside.
    pub distance: f64,
    /// The closest point.
    pub point: [f64; 3],
    /// Unit normal at the closest point, pointing into the shape.
    pub normal: [f64; 3],
    /// Principal curvatures at the closest point (positive where convex); for a 2D shape, the
    /// curve's curvature and 0.
    pub principal: [f64; 2],
    /// Mean curvature at the closest point (see [`super::geometry`]): the average of the
    /// principal curvatures in 3D, the curvature of the curve in 2D.
    pub mean_curvature: f64,
}

/// A closed surface (3D) or a closed curve in the xy-plane (2D, a cylinder along z).
pub trait Shape: Sync {
    /// 3 for a surface, 2 for a curve in the xy-plane (z is ignored).
    fn dimension(&self) -> usize;
    /// Signed distance, positive inside.
    fn signed_distance(&self, x: [f64; 3]) -> f64 {
        self.closest(x).distance
    }
    /// The closest surface point, with normal and curvature.
    fn closest(&self, x: [f64; 3]) -> SurfacePoint;
    /// A centre, used to pick the nearest periodic image.
    fn center(&self) -> Option<[f64; 3]>;
    /// The enclosed volume (area for a 2D shape), where known exactly.
    fn volume(&self) -> Option<f64> {
        None
    }
    /// The radius of a ball about the [`center`](Self::center) that holds the shape, where
    /// known (a capsule's box is sized from it; without it the capsule keeps its fields on the
    /// whole grid).
    fn bounding_radius(&self) -> Option<f64> {
        None
    }
}

/// How a shape is smoothed and averaged over cells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Smoothing {
    /// Sharpness `beta` of the profile (`beta' = beta / h`, `h` the characteristic length of
    /// the grid, see [`characteristic_length`]). Default 1.
    pub beta: f64,
    /// Gauss-Legendre points per axis of the cell averages (1 to 16). Default 4.
    pub points: usize,
}

impl Default for Smoothing {
    fn default() -> Self {
        Smoothing { beta: 1.0, points: 4 }
    }
}

impl Smoothing {
    fn check(&self) -> Result<()> {
        if !(self.beta.is_finite() && self.beta > 0.0) {
            return Err(Error::invalid(
                "Smoothing::beta",
                self.beta,
                "a finite number > 0 (the paper uses 1)",
            ));
        }
        if !(1..=16).contains(&self.points) {
            return Err(Error::invalid("Smoothing::points", self.points, "1 to 16 Gauss points per axis"));
        }
        Ok(())
    }
}

fn check_center(c: [f64; 3]) -> Result<()> {
    if c.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid("center", format!("{c:?}"), "finite coordinates"))
    }
}

fn check_length(name: &'static str, r: f64) -> Result<()> {
    if r.is_finite() && r > 0.0 { Ok(()) } else { Err(Error::invalid(name, r, "a finite length > 0")) }
}

/// A sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    center: [f64; 3],
    radius: f64,
}

impl Sphere {
    /// A sphere of `radius` around `center`; errors for a non-positive radius.
    pub fn new(center: [f64; 3], radius: f64) -> Result<Self> {
        check_center(center)?;
        check_length("Sphere radius", radius)?;
        Ok(Sphere { center, radius })
    }
}

fn radial(c: [f64; 3], x: [f64; 3], dims: usize) -> ([f64; 3], f64) {
    let mut d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
    if dims == 2 {
        d[2] = 0.0;
    }
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if r > 0.0 { ([d[0] / r, d[1] / r, d[2] / r], r) } else { ([1.0, 0.0, 0.0], 0.0) }
}

impl Shape for Sphere {
    fn dimension(&self) -> usize {
        3
    }
    fn signed_distance(&self, x: [f64; 3]) -> f64 {
        self.radius - radial(self.center, x, 3).1
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let (e, r) = radial(self.center, x, 3);
        let k = 1.0 / self.radius;
        SurfacePoint {
            distance: self.radius - r,
            point: std::array::from_fn(|d| self.center[d] + self.radius * e[d]),
            normal: [-e[0], -e[1], -e[2]],
            principal: [k, k],
            mean_curvature: k,
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        Some(self.center)
    }
    fn bounding_radius(&self) -> Option<f64> {
        Some(self.radius)
    }
    fn volume(&self) -> Option<f64> {
        Some(4.0 / 3.0 * PI * self.radius.powi(3))
    }
}

/// A circle in the xy-plane (2D).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    center: [f64; 3],
    radius: f64,
}

impl Circle {
    /// A circle of `radius` around `(center[0], center[1])`; errors for a non-positive radius.
    pub fn new(center: [f64; 2], radius: f64) -> Result<Self> {
        let c = [center[0], center[1], 0.0];
        check_center(c)?;
        check_length("Circle radius", radius)?;
        Ok(Circle { center: c, radius })
    }
}

impl Shape for Circle {
    fn dimension(&self) -> usize {
        2
    }
    fn signed_distance(&self, x: [f64; 3]) -> f64 {
        self.radius - radial(self.center, x, 2).1
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let (e, r) = radial(self.center, x, 2);
        let k = 1.0 / self.radius;
        SurfacePoint {
            distance: self.radius - r,
            point: [self.center[0] + self.radius * e[0], self.center[1] + self.radius * e[1], x[2]],
            normal: [-e[0], -e[1], 0.0],
            principal: [k, 0.0],
            mean_curvature: k,
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        Some(self.center)
    }
    fn bounding_radius(&self) -> Option<f64> {
        Some(self.radius)
    }
    fn volume(&self) -> Option<f64> {
        Some(PI * self.radius * self.radius)
    }
}

/// An axis-aligned ellipsoid with semi-axes `(a, b, c)` along x, y, z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    center: [f64; 3],
    semi_axes: [f64; 3],
}

impl Ellipsoid {
    /// An ellipsoid; errors for a non-positive semi-axis.
    pub fn new(center: [f64; 3], semi_axes: [f64; 3]) -> Result<Self> {
        check_center(center)?;
        for a in semi_axes {
            check_length("Ellipsoid semi-axis", a)?;
        }
        Ok(Ellipsoid { center, semi_axes })
    }
}

impl Shape for Ellipsoid {
    fn dimension(&self) -> usize {
        3
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let e = self.semi_axes;
        let y: [f64; 3] = std::array::from_fn(|d| x[d] - self.center[d]);
        // Sort the axes in decreasing order, reflect into the first octant.
        let mut ord = [0usize, 1, 2];
        ord.sort_by(|&p, &q| e[q].total_cmp(&e[p]));
        let es = ord.map(|d| e[d]);
        let ys = ord.map(|d| y[d].abs());
        let xs = ellipsoid_closest(es, ys);
        let mut p = [0.0; 3];
        for (k, &d) in ord.iter().enumerate() {
            p[d] = xs[k].copysign(if y[d] == 0.0 { 1.0 } else { y[d] });
        }
        let inside = (0..3).map(|d| (y[d] / e[d]).powi(2)).sum::<f64>() < 1.0;
        let dist = ((p[0] - y[0]).powi(2) + (p[1] - y[1]).powi(2) + (p[2] - y[2]).powi(2)).sqrt();
        // Outward gradient of sum x^2/a^2 at p, and the curvatures of the level set there.
        let g: [f64; 3] = std::array::from_fn(|d| 2.0 * p[d] / (e[d] * e[d]));
        let s: [f64; 3] = std::array::from_fn(|d| 2.0 / (e[d] * e[d]));
        let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        let gn = g2.sqrt();
        let gsg = (0..3).map(|d| g[d] * g[d] * s[d]).sum::<f64>();
        let ksum = ((s[0] + s[1] + s[2]) * g2 - gsg) / (g2 * gn);
        let q = (0..3).map(|d| p[d] * p[d] / e[d].powi(4)).sum::<f64>();
        let kg = 1.0 / ((e[0] * e[1] * e[2]).powi(2) * q * q);
        let hm = 0.5 * ksum;
        let disc = (hm * hm - kg).max(0.0).sqrt();
        SurfacePoint {
            distance: if inside { dist } else { -dist },
            point: std::array::from_fn(|d| p[d] + self.center[d]),
            normal: [-g[0] / gn, -g[1] / gn, -g[2] / gn],
            principal: [hm + disc, hm - disc],
            mean_curvature: hm,
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        Some(self.center)
    }
    fn bounding_radius(&self) -> Option<f64> {
        Some(self.semi_axes.iter().fold(0.0, |m: f64, &a| m.max(a)))
    }
    fn volume(&self) -> Option<f64> {
        let [a, b, c] = self.semi_axes;
        Some(4.0 / 3.0 * PI * a * b * c)
    }
}

/// An axis-aligned ellipse `(x - x_c)^2 / a^2 + (y - y_c)^2 / b^2 = 1` in the xy-plane (2D).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    center: [f64; 3],
    semi_axes: [f64; 2],
}

impl Ellipse {
    /// An ellipse with semi-axis `a` along x and `b` along y; errors for a non-positive one.
    pub fn new(center: [f64; 2], semi_axes: [f64; 2]) -> Result<Self> {
        let c = [center[0], center[1], 0.0];
        check_center(c)?;
        for a in semi_axes {
            check_length("Ellipse semi-axis", a)?;
        }
        Ok(Ellipse { center: c, semi_axes })
    }
}

impl Shape for Ellipse {
    fn dimension(&self) -> usize {
        2
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let [a, b] = self.semi_axes;
        let y = [x[0] - self.center[0], x[1] - self.center[1]];
        let swap = b > a;
        let (e0, e1, y0, y1) =
            if swap { (b, a, y[1].abs(), y[0].abs()) } else { (a, b, y[0].abs(), y[1].abs()) };
        let (x0, x1) = ellipse_closest(e0, e1, y0, y1);
        let (px, py) = if swap { (x1, x0) } else { (x0, x1) };
        let p = [
            px.copysign(if y[0] == 0.0 { 1.0 } else { y[0] }),
            py.copysign(if y[1] == 0.0 { 1.0 } else { y[1] }),
        ];
        let inside = (y[0] / a).powi(2) + (y[1] / b).powi(2) < 1.0;
        let dist = ((p[0] - y[0]).powi(2) + (p[1] - y[1]).powi(2)).sqrt();
        let g = [p[0] / (a * a), p[1] / (b * b)];
        let gn = (g[0] * g[0] + g[1] * g[1]).sqrt();
        let q = p[0] * p[0] / a.powi(4) + p[1] * p[1] / b.powi(4);
        let k = 1.0 / (a * a * b * b * q.powf(1.5));
        SurfacePoint {
            distance: if inside { dist } else { -dist },
            point: [p[0] + self.center[0], p[1] + self.center[1], x[2]],
            normal: [-g[0] / gn, -g[1] / gn, 0.0],
            principal: [k, 0.0],
            mean_curvature: k,
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        Some(self.center)
    }
    fn bounding_radius(&self) -> Option<f64> {
        Some(self.semi_axes.iter().fold(0.0, |m: f64, &a| m.max(a)))
    }
    fn volume(&self) -> Option<f64> {
        Some(PI * self.semi_axes[0] * self.semi_axes[1])
    }
}

/// Bisection for Eberly's 2D root (robust distance from a point to an ellipse).
fn get_root2(r0: f64, z0: f64, z1: f64, g: f64) -> f64 {
    let n0 = r0 * z0;
    let mut s0 = z1 - 1.0;
    let mut s1 = if g < 0.0 { 0.0 } else { n0.hypot(z1) - 1.0 };
    let mut s = 0.0;
    for _ in 0..1100 {
        s = 0.5 * (s0 + s1);
        if s == s0 || s == s1 {
            break;
        }
        let a = n0 / (s + r0);
        let b = z1 / (s + 1.0);
        let g = a * a + b * b - 1.0;
        if g > 0.0 {
            s0 = s;
        } else if g < 0.0 {
            s1 = s;
        } else {
            break;
        }
    }
    s
}

/// Closest point of the ellipse with semi-axes `e0 >= e1 > 0` to `(y0, y1)`, `y >= 0`
/// (D. Eberly, *Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid*).
fn ellipse_closest(e0: f64, e1: f64, y0: f64, y1: f64) -> (f64, f64) {
    if y1 > 0.0 {
        if y0 > 0.0 {
            let z0 = y0 / e0;
            let z1 = y1 / e1;
            let g = z0 * z0 + z1 * z1 - 1.0;
            if g != 0.0 {
                let r0 = (e0 / e1).powi(2);
                let sb = get_root2(r0, z0, z1, g);
                (r0 * y0 / (sb + r0), y1 / (sb + 1.0))
            } else {
                (y0, y1)
            }
        } else {
            (0.0, e1)
        }
    } else {
        let numer0 = e0 * y0;
        let denom0 = e0 * e0 - e1 * e1;
        if numer0 < denom0 {
            let xde0 = numer0 / denom0;
            (e0 * xde0, e1 * (1.0 - xde0 * xde0).max(0.0).sqrt())
        } else {
            (e0, 0.0)
        }
    }
}

fn get_root3(r: [f64; 2], z: [f64; 3], g: f64) -> f64 {
    let n0 = r[0] * z[0];
    let n1 = r[1] * z[1];
    let mut s0 = z[2] - 1.0;
    let mut s1 = if g < 0.0 {
        0.0
    } else {
        let m = n0.abs().max(n1.abs()).max(z[2].abs());
        m * ((n0 / m).powi(2) + (n1 / m).powi(2) + (z[2] / m).powi(2)).sqrt() - 1.0
    };
    let mut s = 0.0;
    for _ in 0..1100 {
        s = 0.5 * (s0 + s1);
        if s == s0 || s == s1 {
            break;
        }
        let a = n0 / (s + r[0]);
        let b = n1 / (s + r[1]);
        let c = z[2] / (s + 1.0);
        let g = a * a + b * b + c * c - 1.0;
        if g > 0.0 {
            s0 = s;
        } else if g < 0.0 {
            s1 = s;
        } else {
            break;
        }
    }
    s
}

/// Closest point of the ellipsoid with semi-axes `e0 >= e1 >= e2 > 0` to `y >= 0` (Eberly).
fn ellipsoid_closest(e: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    if y[2] > 0.0 {
        if y[1] > 0.0 {
            if y[0] > 0.0 {
                let z = [y[0] / e[0], y[1] / e[1], y[2] / e[2]];
                let g = z[0] * z[0] + z[1] * z[1] + z[2] * z[2] - 1.0;
                if g != 0.0 {
                    let r = [(e[0] / e[2]).powi(2), (e[1] / e[2]).powi(2)];
                    let sb = get_root3(r, z, g);
                    [r[0] * y[0] / (sb + r[0]), r[1] * y[1] / (sb + r[1]), y[2] / (sb + 1.0)]
                } else {
                    y
                }
            } else {
                let (x1, x2) = ellipse_closest(e[1], e[2], y[1], y[2]);
                [0.0, x1, x2]
            }
        } else if y[0] > 0.0 {
            let (x0, x2) = ellipse_closest(e[0], e[2], y[0], y[2]);
            [x0, 0.0, x2]
        } else {
            [0.0, 0.0, e[2]]
        }
    } else {
        let d0 = e[0] * e[0] - e[2] * e[2];
        let d1 = e[1] * e[1] - e[2] * e[2];
        let n0 = e[0] * y[0];
        let n1 = e[1] * y[1];
        if n0 < d0 && n1 < d1 {
            let x0 = n0 / d0;
            let x1 = n1 / d1;
            let disc = 1.0 - x0 * x0 - x1 * x1;
            if disc > 0.0 {
                return [e[0] * x0, e[1] * x1, e[2] * disc.sqrt()];
            }
        }
        let (x0, x1) = ellipse_closest(e[0], e[1], y[0], y[1]);
        [x0, x1, 0.0]
    }
}

/// The biconcave red-blood-cell shape of Sec. 3.4 (after Evans & Fung), axisymmetric about an
/// axis through `center`:
///
/// ```text
/// (x - x_c) / a = +- (1/2) (c1 + c2 sigma + c3 sigma^2) sqrt(1 - sigma),
/// sigma = ((y - y_c)^2 + (z - z_c)^2) / a^2
/// ```
///
/// with the paper's `c1 = 0.35, c2 = 2.003, c3 = -1.123` by default (thicker than the classic
/// Evans-Fung `c1 = 0.207`), the axis along x. The meridian is parametrised as
/// `(X, R) = ((a/2) f(sin^2 t) cos t, a sin t)`, `t` in `[0, pi]`, which is smooth up to the rim
/// (where `x(r)` has a vertical tangent). Distances come from a dense sampling of the meridian
/// refined by safeguarded Newton iterations; curvatures are exact (meridian and parallel
/// curvatures of the surface of revolution).
#[derive(Debug, Clone, PartialEq)]
pub struct Biconcave {
    center: [f64; 3],
    radius: f64,
    axis: usize,
    c: [f64; 3],
    /// Meridian samples `X` and `R` at `t_k = pi k / BICONCAVE_SAMPLES` ([`sample_t`]), kept
    /// as two arrays so that the distance scan vectorises.
    sample_x: Box<[f64]>,
    sample_r: Box<[f64]>,
    /// One capsule per block of [`BLOCK`] samples holding the meridian's arc over the block's
    /// samples and their refinement brackets (one sample either side), as
    /// `[X0, R0, dX, dR, 1 / (dX^2 + dR^2), radius]`: the segment from `(X0, R0)` to
    /// `(X0 + dX, R0 + dR)` and the distance the arc gets from it. A block whose capsule lies
    /// farther from the query than some sample is skipped by the scan.
    blocks: Box<[[f64; 6]]>,
    /// How far the meridian gets from a sample within its refinement bracket (one sample
    /// either side), with the same allowance as the blocks' capsules.
    bracket_reach: f64,
}

/// Squared distance from `(x, r)` to the segment of a block capsule (see [`Biconcave::blocks`]).
#[inline]
fn segment_distance2(b: &[f64; 6], x: f64, r: f64) -> f64 {
    let (wx, wr) = (x - b[0], r - b[1]);
    let t = ((wx * b[2] + wr * b[3]) * b[4]).clamp(0.0, 1.0);
    (wx - t * b[2]).powi(2) + (wr - t * b[3]).powi(2)
}

/// Samples of the meridian used to start the closest-point search.
const BICONCAVE_SAMPLES: usize = 384;
/// The meridian parameter of sample `k`.
fn sample_t(k: usize) -> f64 {
    PI * k as f64 / BICONCAVE_SAMPLES as f64
}

/// Samples per block of the pruned scan.
const BLOCK: usize = 16;
/// Blocks of the pruned scan.
const BLOCKS: usize = (BICONCAVE_SAMPLES + 1).div_ceil(BLOCK);

impl Biconcave {
    /// The paper's red cell of radius `a` around `center`, axis along x.
    pub fn new(center: [f64; 3], radius: f64) -> Result<Self> {
        Self::with_coefficients(center, radius, 0, [0.35, 2.003, -1.123])
    }

    /// A biconcave shape with coefficients `c = (c1, c2, c3)` and symmetry `axis` (0, 1 or 2).
    /// Errors: non-positive radius, axis > 2, coefficients giving a non-positive thickness on
    /// `[0, 1)`.
    pub fn with_coefficients(center: [f64; 3], radius: f64, axis: usize, c: [f64; 3]) -> Result<Self> {
        check_center(center)?;
        check_length("Biconcave radius", radius)?;
        if axis > 2 {
            return Err(Error::invalid("Biconcave axis", axis, "0, 1 or 2"));
        }
        let f = |s: f64| c[0] + c[1] * s + c[2] * s * s;
        if !c.iter().all(|x| x.is_finite()) || (0..=100).any(|k| f(k as f64 / 100.0) <= 0.0) {
            return Err(Error::invalid(
                "Biconcave coefficients",
                format!("{c:?}"),
                "finite c1, c2, c3 with c1 + c2 s + c3 s^2 > 0 on [0, 1]",
            ));
        }
        let mut b = Biconcave {
            center,
            radius,
            axis,
            c,
            sample_x: Box::default(),
            sample_r: Box::default(),
            blocks: Box::default(),
            bracket_reach: 0.0,
        };
        let (x, r): (Vec<f64>, Vec<f64>) =
            (0..=BICONCAVE_SAMPLES).map(|k| b.meridian(sample_t(k))).map(|m| (m[0], m[1])).unzip();
        (b.sample_x, b.sample_r) = (x.into(), r.into());
        b.blocks = (0..BLOCKS).map(|q| b.block_capsule(q)).collect();
        b.bracket_reach = (0..=BICONCAVE_SAMPLES).map(|k| b.bracket_reach(k)).fold(0.0, f64::max);
        Ok(b)
    }

    /// `SUB + 1` points per sample interval of the meridian from sample `lo` to `hi`, and the
    /// longest gap between two of them (every point of the arc lies within half a gap of one,
    /// the arc's sag included).
    fn dense_arc(&self, lo: usize, hi: usize) -> (Vec<[f64; 2]>, f64) {
        const SUB: usize = 16;
        let pts: Vec<[f64; 2]> = (0..=(hi - lo) * SUB)
            .map(|j| {
                let t = PI * (lo as f64 + j as f64 / SUB as f64) / BICONCAVE_SAMPLES as f64;
                let mm = self.meridian(t.min(PI));
                [mm[0], mm[1]]
            })
            .collect();
        let gap = pts.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).fold(0.0, f64::max);
        (pts, gap)
    }

    /// How far the meridian gets from sample `k` within its refinement bracket.
    fn bracket_reach(&self, k: usize) -> f64 {
        let (pts, gap) = self.dense_arc(k.saturating_sub(1), (k + 1).min(BICONCAVE_SAMPLES));
        let (x, r) = (self.sample_x[k], self.sample_r[k]);
        pts.iter().map(|p| (p[0] - x).hypot(p[1] - r)).fold(0.0, f64::max) + gap
    }

    /// The capsule of block `q` (see [`Biconcave::blocks`]): the chord of the dense points of
    /// the arc from `t_{lo - 1}` to `t_{hi + 1}` ([`Self::dense_arc`]), its radius the
    /// farthest of them from the chord plus the longest gap between two of them.
    fn block_capsule(&self, q: usize) -> [f64; 6] {
        let (pts, gap) =
            self.dense_arc((q * BLOCK).saturating_sub(1), ((q + 1) * BLOCK).min(BICONCAVE_SAMPLES));
        let (p0, p1) = (pts[0], pts[pts.len() - 1]);
        let (dx, dr) = (p1[0] - p0[0], p1[1] - p0[1]);
        let len2 = dx * dx + dr * dr;
        let inv = if len2 > 0.0 { 1.0 / len2 } else { 0.0 };
        let mut b = [p0[0], p0[1], dx, dr, inv, 0.0];
        b[5] = pts.iter().map(|p| segment_distance2(&b, p[0], p[1]).sqrt()).fold(0.0, f64::max) + gap;
        b
    }

    /// `[X, R, X', R', X'', R'']` of the meridian at parameter `t`.
    fn meridian(&self, t: f64) -> [f64; 6] {
        let a = self.radius;
        let [c1, c2, c3] = self.c;
        let (s, co) = t.sin_cos();
        let sg = s * s;
        let f = c1 + c2 * sg + c3 * sg * sg;
        let fp = c2 + 2.0 * c3 * sg;
        let fpp = 2.0 * c3;
        let h = 0.5 * a;
        let x = h * f * co;
        let xp = h * (2.0 * fp * s * co * co - f * s);
        let xpp = h * (4.0 * fpp * sg * co * co * co + 2.0 * fp * co * co * co - 6.0 * fp * sg * co - f * co);
        [x, a * s, xp, a * co, xpp, -a * s]
    }

    /// Axial and radial coordinates of a point relative to the centre, and the radial unit
    /// vector.
    fn to_meridian(&self, x: [f64; 3]) -> (f64, f64, [f64; 3]) {
        let d: [f64; 3] = std::array::from_fn(|k| x[k] - self.center[k]);
        let xa = d[self.axis];
        let mut e = d;
        e[self.axis] = 0.0;
        let r = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        if r > 0.0 {
            (xa, r, [e[0] / r, e[1] / r, e[2] / r])
        } else {
            let mut u = [0.0; 3];
            u[(self.axis + 1) % 3] = 1.0;
            (xa, 0.0, u)
        }
    }

    /// Refines a local minimum of the squared distance on `[lo, hi]` from `t`: Newton on
    /// `g = d/dt |m(t) - q|^2 / 2`, kept inside the bracket (a bisection where the step leaves
    /// it or `g' <= 0`, beyond a centre of curvature). A Newton step below `1e-15` ends the
    /// search at the point it was computed at, before the bracket test: at convergence it
    /// lands on the bracket's end, where the test would otherwise throw the converged point
    /// away. Returns [`Self::meridian`] at the refined parameter.
    fn refine(&self, xa: f64, r: f64, mut t: f64, mut lo: f64, mut hi: f64) -> [f64; 6] {
        let mut m = self.meridian(t);
        for _ in 0..50 {
            let [x, rr, xp, rp, xpp, rpp] = m;
            let g = (x - xa) * xp + (rr - r) * rp;
            let gp = xp * xp + rp * rp + (x - xa) * xpp + (rr - r) * rpp;
            if g > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let mut next = if gp > 0.0 { t - g / gp } else { f64::NAN };
            if (next - t).abs() < 1e-15 {
                break;
            }
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            let done = (next - t).abs() < 1e-15 || hi - lo < 1e-15;
            t = next;
            m = self.meridian(t);
            if done {
                break;
            }
        }
        m
    }

    /// Whether a meridian point `(xa, r)` is inside.
    fn inside(&self, xa: f64, r: f64) -> bool {
        let a = self.radius;
        let sg = (r / a).powi(2);
        if sg >= 1.0 {
            return false;
        }
        let [c1, c2, c3] = self.c;
        xa.abs() < 0.5 * a * (c1 + c2 * sg + c3 * sg * sg) * (1.0 - sg).sqrt()
    }
}

impl Shape for Biconcave {
    fn dimension(&self) -> usize {
        3
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let (xa, r, er) = self.to_meridian(x);
        // The scan of the samples' squared distances is most of the cost of a closest-point
        // query (a cell average of `phi` makes 64 of them). It visits only the blocks whose
        // capsule comes within `ub` of the query, `ub` the distance of some sample: the other
        // blocks' samples and refinement brackets are all farther than that sample, so they
        // can neither hold the nearest one nor win after refinement.
        let m = BICONCAVE_SAMPLES + 1;
        let mut dc2 = [0.0; BLOCKS];
        for (d, b) in dc2.iter_mut().zip(&self.blocks) {
            *d = segment_distance2(b, xa, r);
        }
        // The nearest block's nearest sample bounds the nearest sample's distance.
        let q0 = (0..BLOCKS).fold(0, |q0, q| if dc2[q] < dc2[q0] { q } else { q0 });
        let span = q0 * BLOCK..((q0 + 1) * BLOCK).min(m);
        let ub = self.sample_x[span.clone()]
            .iter()
            .zip(&self.sample_r[span])
            .map(|(x, rr)| (x - xa).powi(2) + (rr - r).powi(2))
            .fold(f64::INFINITY, f64::min)
            .sqrt();
        // Per visited block, the squared distances of its samples and their neighbours (+inf
        // beyond both ends of the meridian), then the two best local minima, in the order of a
        // full scan, each with its neighbours' squared distances.
        let mut best = [(f64::INFINITY, 0usize, 0.0, 0.0); 2];
        for q in (0..BLOCKS).filter(|&q| dc2[q] <= (ub + self.blocks[q][5]).powi(2)) {
            let (lo, hi) = (q * BLOCK, ((q + 1) * BLOCK).min(m));
            let (a, b) = (lo.saturating_sub(1), (hi + 1).min(m));
            // `w[j]` holds sample `lo - 1 + j`.
            let mut w = [f64::INFINITY; BLOCK + 2];
            for ((d, x), rr) in
                w[a + 1 - lo..b + 1 - lo].iter_mut().zip(&self.sample_x[a..b]).zip(&self.sample_r[a..b])
            {
                *d = (x - xa).powi(2) + (rr - r).powi(2);
            }
            for j in 1..=hi - lo {
                let v = w[j];
                if v <= w[j - 1] && v <= w[j + 1] {
                    let c = (v, lo + j - 1, w[j - 1], w[j + 1]);
                    if v < best[0].0 {
                        best[1] = best[0];
                        best[0] = c;
                    } else if v < best[1].0 {
                        best[1] = c;
                    }
                }
            }
        }
        let mut best_m = [f64::NAN; 6];
        let mut dbest = f64::INFINITY;
        for &(v, k, dm, dp) in &best {
            // The second candidate is refined only where its bracket may come closer than the
            // first's refined point.
            if !v.is_finite() || v.sqrt() - self.bracket_reach > dbest.sqrt() {
                continue;
            }
            let (lo, hi) = (sample_t(k.saturating_sub(1)), sample_t((k + 1).min(m - 1)));
            // Newton starts from the vertex of the parabola through the squared distances of
            // the sample and its neighbours (one iteration fewer than from the sample).
            let curv = dm - 2.0 * v + dp;
            let shift =
                if dm.is_finite() && dp.is_finite() && curv > 0.0 { 0.5 * (dm - dp) / curv } else { 0.0 };
            let start =
                (sample_t(k) + shift.clamp(-0.5, 0.5) * (PI / BICONCAVE_SAMPLES as f64)).clamp(lo, hi);
            let mm = self.refine(xa, r, start, lo, hi);
            let dd = (mm[0] - xa).powi(2) + (mm[1] - r).powi(2);
            if dd < dbest {
                dbest = dd;
                best_m = mm;
            }
        }
        let [xm, rm, xp, rp, xpp, rpp] = best_m;
        let speed = (xp * xp + rp * rp).sqrt();
        let km = (xp * rpp - rp * xpp) / speed.powi(3);
        let kp = if rm > 1e-9 * self.radius { -xp / (speed * rm) } else { km };
        // Inward normal in the meridian plane: (-R', X') / |v|.
        let (na, nr) = (-rp / speed, xp / speed);
        let mut normal = [nr * er[0], nr * er[1], nr * er[2]];
        normal[self.axis] = na;
        let mut point =
            [self.center[0] + rm * er[0], self.center[1] + rm * er[1], self.center[2] + rm * er[2]];
        point[self.axis] = self.center[self.axis] + xm;
        let dist = dbest.sqrt();
        let (k1, k2) = if km >= kp { (km, kp) } else { (kp, km) };
        SurfacePoint {
            distance: if self.inside(xa, r) { dist } else { -dist },
            point,
            normal,
            principal: [k1, k2],
            mean_curvature: 0.5 * (km + kp),
        }
    }
    fn center(&self) -> Option<[f64; 3]> {
        Some(self.center)
    }
    fn bounding_radius(&self) -> Option<f64> {
        Some(self.radius)
    }
    fn volume(&self) -> Option<f64> {
        // pi a^3 int_0^1 f(s) sqrt(1 - s) ds, with int s^k sqrt(1-s) = 2/3, 4/15, 16/105.
        let [c1, c2, c3] = self.c;
        Some(PI * self.radius.powi(3) * (c1 * 2.0 / 3.0 + c2 * 4.0 / 15.0 + c3 * 16.0 / 105.0))
    }
}

/// Any shape given by a signed-distance closure (positive inside). Closest points come from
/// projecting along the gradient; curvatures from central differences of the closure at the
/// closest point, with step [`SignedDistanceFn::with_step`] (default `1e-4` length units;
/// choose about `1e-4` of the shape's size).
pub struct SignedDistanceFn<F> {
    f: F,
    dimension: usize,
    center: Option<[f64; 3]>,
    step: f64,
}

impl<F: Fn([f64; 3]) -> f64 + Sync> SignedDistanceFn<F> {
    /// A shape of `dimension` 2 (a curve in the xy-plane) or 3 from the closure `f`.
    pub fn new(dimension: usize, f: F) -> Result<Self> {
        if !(dimension == 2 || dimension == 3) {
            return Err(Error::invalid("dimension", dimension, "2 or 3"));
        }
        Ok(SignedDistanceFn { f, dimension, center: None, step: 1e-4 })
    }

    /// Sets the finite-difference step (errors unless finite and positive).
    pub fn with_step(mut self, step: f64) -> Result<Self> {
        check_length("SignedDistanceFn step", step)?;
        self.step = step;
        Ok(self)
    }

    /// Sets a centre, used for periodic images.
    pub fn with_center(mut self, center: [f64; 3]) -> Result<Self> {
        check_center(center)?;
        self.center = Some(center);
        Ok(self)
    }

    fn grad_hess(&self, x: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let e = self.step;
        let n = self.dimension;
        let at = |dx: [f64; 3]| (self.f)([x[0] + dx[0], x[1] + dx[1], x[2] + dx[2]]);
        let f0 = at([0.0; 3]);
        let mut g = [0.0; 3];
        let mut h = [[0.0; 3]; 3];
        for d in 0..n {
            let mut u = [0.0; 3];
            u[d] = e;
            let fp = at(u);
            let fm = at(u.map(|v| -v));
            g[d] = (fp - fm) / (2.0 * e);
            h[d][d] = (fp - 2.0 * f0 + fm) / (e * e);
            for q in d + 1..n {
                let mut w = [0.0; 3];
                w[d] = e;
                w[q] = e;
                let mut w2 = w;
                w2[q] = -e;
                let v = (at(w) - at(w2) - at(w2.map(|v| -v)) + at(w.map(|v| -v))) / (4.0 * e * e);
                h[d][q] = v;
                h[q][d] = v;
            }
        }
        (g, h)
    }
}

impl<F: Fn([f64; 3]) -> f64 + Sync> Shape for SignedDistanceFn<F> {
    fn dimension(&self) -> usize {
        self.dimension
    }
    fn signed_distance(&self, x: [f64; 3]) -> f64 {
        (self.f)(x)
    }
    fn closest(&self, x: [f64; 3]) -> SurfacePoint {
        let s = (self.f)(x);
        let mut p = x;
        for _ in 0..3 {
            let sp = (self.f)(p);
            let (g, _) = self.grad_hess(p);
            let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            if g2.is_nan() || g2 <= 0.0 || !sp.is_finite() {
                break;
            }
            for d in 0..3 {
                p[d] -= sp * g[d] / g2;
            }
        }
        let (g, h) = self.grad_hess(p);
        let gn = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if !(gn > 0.0 && gn.is_finite()) {
            return SurfacePoint {
                distance: s,
                point: p,
                normal: [0.0; 3],
                principal: [0.0; 2],
                mean_curvature: 0.0,
            };
        }
        let n = [g[0] / gn, g[1] / gn, g[2] / gn];
        // Curvature tensor C = -P S P / |g|; k1 + k2 = tr C, k1 k2 = (tr^2 - tr C^2) / 2.
        let pm: [[f64; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j)) - n[i] * n[j]));
        let mut c = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let mut v = 0.0;
                for k in 0..3 {
                    for l in 0..3 {
                        v += pm[i][k] * h[k][l] * pm[l][j];
                    }
                }
                c[i][j] = -v / gn;
            }
        }
        let tr = c[0][0] + c[1][1] + c[2][2];
        let tr2: f64 = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| c[i][j] * c[j][i]).sum();
        let (principal, mean) = if self.dimension == 2 {
            ([tr, 0.0], tr)
        } else {
            let hm = 0.5 * tr;
            let kg = 0.5 * (tr * tr - tr2);
            let disc = (hm * hm - kg).max(0.0).sqrt();
            ([hm + disc, hm - disc], hm)
        };
        SurfacePoint { distance: s, point: p, normal: n, principal, mean_curvature: mean }
    }
    fn center(&self) -> Option<[f64; 3]> {
        self.center
    }
}

/// Gauss-Legendre nodes and weights on `[-1/2, 1/2]` (weights sum to 1).
pub(crate) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            if n == 1 {
                p0 = 1.0;
                p1 = z;
            }
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[i] = 0.5 * z;
        w[i] = 1.0 / ((1.0 - z * z) * dp * dp);
    }
    (x, w)
}

/// The relative excess `(pi^2/4) (h / (beta R))^2` of the smoothed volume `sum phi dV` of a
/// sphere of radius `R` over the sharp volume, to leading order (see the module docs).
pub fn smoothed_volume_excess(radius: f64, h: f64, beta: f64) -> f64 {
    0.25 * PI * PI * (h / (beta * radius)).powi(2)
}

/// The absolute error allowed to a cell average of `H` where a rule with fewer points than
/// [`Smoothing::points`] is used.
const TAIL_TOL: f64 = 1e-15;
/// The absolute error allowed instead in cells where `H` (or `1 - H`) stays below
/// [`OUTSIDE_GEOMETRY`] over the whole cell: the geometry never reads them, and `phi` enters
/// there only through sums (volume, fluxes).
const FAR_TAIL_TOL: f64 = 1e-12;
/// The `H` below which the capsule geometry does not read `phi` (the `1e-10` of its `phi`
/// range), with a factor 2 for the error a cell average may carry.
const OUTSIDE_GEOMETRY: f64 = 5e-11;
/// Safety factor on the error estimate of [`TailRules`].
const TAIL_MARGIN: f64 = 100.0;

/// The Gauss-Legendre rules of the cell averages and where each suffices. In the profile's
/// tails `H` (or `1 - H`) is close to `exp(2 beta' s)`, whose `n`-point average over a cell of
/// `beta' h <= b` per axis errs by at most `E_n(2 b) exp(-z)` per axis, `z = 2 beta' (|s| - d)` at
/// the cell centre (`d` half its diagonal) and `E_n(l) = l^(2n) (n!)^4 / ((2n + 1) ((2n)!)^3)`
/// the rule's remainder. A cell uses the fewest points whose error times [`TAIL_MARGIN`] stays
/// below [`TAIL_TOL`] ([`FAR_TAIL_TOL`] where `exp(-z) < OUTSIDE_GEOMETRY`), and is exactly 0 or
/// 1 where `exp(-z)` is below that tolerance.
struct TailRules {
    /// Rules with 1 to `points` points; `min_z[n - 1]` the least `z` where `n` points suffice.
    rules: Vec<(Vec<f64>, Vec<f64>)>,
    min_z: Vec<f64>,
    /// `z` beyond which the cell average is 0 or 1.
    flat: f64,
}

impl TailRules {
    fn new(points: usize, dims: usize, b: f64) -> Self {
        let rules: Vec<_> = (1..=points).map(gauss_legendre).collect();
        let fact = |n: usize| (1..=n).map(|k| k as f64).product::<f64>();
        let min_z = (1..=points)
            .map(|n| {
                if n == points {
                    return f64::NEG_INFINITY;
                }
                let e = (2.0 * b).powi(2 * n as i32) * fact(n).powi(4)
                    / ((2 * n + 1) as f64 * fact(2 * n).powi(3));
                let near = (dims as f64 * e * TAIL_MARGIN / TAIL_TOL).ln();
                let far = (dims as f64 * e * TAIL_MARGIN / FAR_TAIL_TOL).ln().max(-OUTSIDE_GEOMETRY.ln());
                near.min(far)
            })
            .collect();
        TailRules { rules, min_z, flat: (-FAR_TAIL_TOL.ln()).max(-OUTSIDE_GEOMETRY.ln()) }
    }

    /// The rule for a cell at `z` (nodes and weights on `[-1/2, 1/2]`).
    fn rule(&self, z: f64) -> (&[f64], &[f64]) {
        let n = self.min_z.iter().position(|&m| z >= m).expect("the full rule suffices everywhere");
        (&self.rules[n].0, &self.rules[n].1)
    }
}

/// Cell averages `(<H>, <|grad H| kappa_R>)` of every interior cell, x fastest (the second is
/// zero unless `want_kappa`).
fn cell_averages<T: Real>(
    grid: &Grid<T>,
    shape: &dyn Shape,
    sm: &Smoothing,
    want_kappa: bool,
) -> Result<Vec<[f64; 2]>> {
    sm.check()?;
    let bp = sm.beta / characteristic_length(grid).f64();
    let h = grid.h().map(|x| x.f64());
    let planar = grid.is_2d();
    let dims = if planar { 2 } else { 3 };
    let rules = TailRules::new(sm.points, dims, bp * h[..dims].iter().copied().fold(0.0, f64::max));
    let halfdiag = 0.5 * (h[0] * h[0] + h[1] * h[1] + if planar { 0.0 } else { h[2] * h[2] }).sqrt();
    let lower = grid.lower().map(|x| x.f64());
    let upper = grid.upper().map(|x| x.f64());
    let periodic: [bool; 3] = std::array::from_fn(|d| grid.is_periodic(d) && grid.n()[d] > 1);
    let center = shape.center();
    let bounding = shape.bounding_radius();
    // Beyond `far` from the surface every point of a cell has `H` within `FAR_TAIL_TOL` of 0 or 1.
    let far = rules.flat / (2.0 * bp) + halfdiag;
    let [nx, ny, _] = grid.n();
    // Value at one point: (H, |grad H| kappa_R).
    let at = |x: [f64; 3]| -> [f64; 2] {
        if want_kappa {
            let sp = shape.closest(x);
            let (s, ss) = profile(2.0 * bp * sp.distance);
            [s, 2.0 * bp * ss * sp.mean_curvature]
        } else {
            [profile(2.0 * bp * shape.signed_distance(x)).0, 0.0]
        }
    };
    let cell = |i: usize, j: usize, k: usize| -> [f64; 2] {
        let mut xc = grid.cell_center(i as isize, j as isize, k as isize).map(|x| x.f64());
        if let Some(ctr) = center {
            for d in 0..3 {
                if periodic[d] {
                    let l = upper[d] - lower[d];
                    xc[d] -= l * ((xc[d] - ctr[d]) / l).round();
                }
            }
        }
        // Beyond the bounding ball by more than the profile's reach: 0 (what the distance
        // would give, without computing it).
        if let (Some(ctr), Some(r)) = (center, bounding) {
            let d2: f64 = (0..dims).map(|d| (xc[d] - ctr[d]).powi(2)).sum();
            if d2 > (r + far).powi(2) {
                return [0.0, 0.0];
            }
        }
        let s0 = shape.signed_distance(xc);
        if !s0.is_finite() {
            return [f64::NAN; 2];
        }
        let z = 2.0 * bp * (s0.abs() - halfdiag);
        if z > rules.flat {
            return [if s0 > 0.0 { 1.0 } else { 0.0 }, 0.0];
        }
        let (gx, gw) = rules.rule(z);
        if gx.len() == 1 {
            return at(xc);
        }
        let mut acc = [0.0; 2];
        let nz = if planar { 1 } else { gx.len() };
        for qz in 0..nz {
            let (oz, wz) = if planar { (0.0, 1.0) } else { (gx[qz], gw[qz]) };
            for (qy, &wy) in gw.iter().enumerate() {
                for (qx, &wx) in gw.iter().enumerate() {
                    let p = [xc[0] + gx[qx] * h[0], xc[1] + gx[qy] * h[1], xc[2] + oz * h[2]];
                    let v = at(p);
                    let w = wx * wy * wz;
                    acc[0] += w * v[0];
                    acc[1] += w * v[1];
                }
            }
        }
        acc
    };
    let mut out = vec![[0.0; 2]; grid.cell_count()];
    out.par_chunks_mut(nx).enumerate().for_each(|(row, line)| {
        let (j, k) = (row % ny, row / ny);
        for (i, v) in line.iter_mut().enumerate() {
            *v = cell(i, j, k);
        }
    });
    if out.iter().any(|v| !(v[0].is_finite() && v[1].is_finite())) {
        return Err(Error::Unsupported {
            component: "shapes",
            detail: "the shape returned a non-finite signed distance or curvature".into(),
        });
    }
    Ok(out)
}

/// Copies component `c` of the cell averages into a new field and fills its ghosts.
fn to_field<T: Real>(grid: &Grid<T>, v: &[[f64; 2]], c: usize) -> Field<T> {
    let mut f = Field::zeros(grid);
    for ((i, j, k), x) in grid.cells().zip(v) {
        f.data[grid.idx_u(i, j, k)] = T::lit(x[c]);
    }
    f.fill_ghosts(grid);
    f
}

/// `(sigma(z), sigma(z) (1 - sigma(z)))`, accurate in both tails.
#[inline]
fn profile(z: f64) -> (f64, f64) {
    let e = (-z.abs()).exp();
    let p = 1.0 / (1.0 + e);
    (if z >= 0.0 { p } else { e * p }, e * p * p)
}

/// The smoothed VOF function of `shape` on `grid` (cell averages of `H`, ghosts filled).
///
/// ```
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::{smoothed_phi, Shape, Smoothing, Sphere};
/// let g = Grid::<f64>::periodic([32, 32, 32], [0.0; 3], [1.0; 3]).unwrap();
/// let s = Sphere::new([0.5; 3], 0.25).unwrap();
/// let phi = smoothed_phi(&g, &s, &Smoothing::default()).unwrap();
/// let vol = phi.interior_sum(&g) / 32f64.powi(3);
/// // The smoothed volume exceeds the sharp one by (pi^2/4) (h/R)^2 = 3.9 % here.
/// let excess = eulermembrane::interface::shapes::smoothed_volume_excess(0.25, 1.0 / 32.0, 1.0);
/// assert!((vol / s.volume().unwrap() - 1.0 - excess).abs() < 0.002);
/// ```
pub fn smoothed_phi<T: Real>(grid: &Grid<T>, shape: &dyn Shape, smoothing: &Smoothing) -> Result<Field<T>> {
    let v = cell_averages(grid, shape, smoothing, false)?;
    Ok(to_field(grid, &v, 0))
}

/// The convolved reference curvature `kappa_R tilde = delta kappa_R` of `shape` on `grid` (cell
/// averages of `|grad H| kappa_R(closest point)`, ghosts filled).
pub fn convolved_curvature<T: Real>(
    grid: &Grid<T>,
    shape: &dyn Shape,
    smoothing: &Smoothing,
) -> Result<Field<T>> {
    let v = cell_averages(grid, shape, smoothing, true)?;
    Ok(to_field(grid, &v, 1))
}

/// Both fields at once (one closest-point search per quadrature point): `(phi, kappa_R tilde)`.
pub fn smoothed_fields<T: Real>(
    grid: &Grid<T>,
    shape: &dyn Shape,
    smoothing: &Smoothing,
) -> Result<(Field<T>, Field<T>)> {
    let v = cell_averages(grid, shape, smoothing, true)?;
    Ok((to_field(grid, &v, 0), to_field(grid, &v, 1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        for n in 1..=8 {
            let (x, w) = gauss_legendre(n);
            for p in 0..2 * n {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p as i32)).sum();
                let exact = if p % 2 == 1 { 0.0 } else { 2.0 * 0.5f64.powi(p as i32 + 1) / (p as f64 + 1.0) };
                assert!((q - exact).abs() < 1e-14, "n={n} p={p}");
            }
        }
    }

    #[test]
    fn ellipsoid_closest_point_is_orthogonal() {
        let e = Ellipsoid::new([0.1, 0.2, 0.3], [0.5, 0.3, 0.2]).unwrap();
        for x in [[0.5, 0.4, 0.1], [0.12, 0.21, 0.29], [1.0, -0.3, 0.8], [0.1, 0.2, 0.35]] {
            let sp = e.closest(x);
            let d: [f64; 3] = std::array::from_fn(|k| x[k] - sp.point[k]);
            // x - p is parallel to the normal.
            let dn = d[0] * sp.normal[0] + d[1] * sp.normal[1] + d[2] * sp.normal[2];
            let dd = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((dn.abs() - dd).abs() < 1e-10, "{x:?}");
            assert!((dd - sp.distance.abs()).abs() < 1e-12);
            assert_eq!(sp.distance > 0.0, dn > 0.0);
        }
        // A sphere as an ellipsoid.
        let s = Ellipsoid::new([0.0; 3], [0.4; 3]).unwrap();
        let sp = s.closest([0.1, 0.2, -0.05]);
        assert!((sp.mean_curvature - 2.5).abs() < 1e-12);
        assert!((sp.distance - (0.4 - (0.01f64 + 0.04 + 0.0025).sqrt())).abs() < 1e-12);
    }

    #[test]
    fn ellipse_curvature_at_the_vertices() {
        let e = Ellipse::new([0.5, 0.75], [0.15, 0.105]).unwrap();
        let sp = e.closest([0.9, 0.75, 0.0]);
        assert!((sp.mean_curvature - 0.15 / 0.105f64.powi(2)).abs() < 1e-9);
        assert!((sp.distance + 0.25).abs() < 1e-12);
        let sp = e.closest([0.5, 0.76, 0.0]);
        assert!((sp.mean_curvature - 0.105 / 0.15f64.powi(2)).abs() < 1e-9);
    }

    #[test]
    fn biconcave_meridian_derivatives_and_curvature() {
        let b = Biconcave::new([0.0; 3], 1.0).unwrap();
        let e = 1e-6;
        for t in [0.3, 1.0, 1.5, 2.5] {
            let m = b.meridian(t);
            let p = b.meridian(t + e);
            let q = b.meridian(t - e);
            for k in 0..4 {
                assert!(((p[k] - q[k]) / (2.0 * e) - m[k + 2]).abs() < 1e-7, "t={t} k={k}");
            }
        }
        // Dimple: concave at the centre of the faces.
        let sp = b.closest([0.5, 0.0, 0.0]);
        assert!(sp.mean_curvature < 0.0 && sp.distance < 0.0);
        assert!((sp.distance + (0.5 - 0.175)).abs() < 1e-9);
        // The SDF closure version of a sphere agrees with the sphere.
        let f =
            SignedDistanceFn::new(3, |x: [f64; 3]| 0.3 - (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt())
                .unwrap();
        let sp = f.closest([0.2, 0.1, 0.0]);
        assert!((sp.mean_curvature - 1.0 / 0.3).abs() < 1e-4, "{}", sp.mean_curvature);
    }

    /// Cell averages by the full tensor rule at every cell, no shortcut.
    fn full_rule_averages(grid: &Grid<f64>, shape: &dyn Shape, sm: &Smoothing) -> Vec<[f64; 2]> {
        let bp = sm.beta / characteristic_length(grid);
        let h = grid.h();
        let (gx, gw) = gauss_legendre(sm.points);
        let nz = if grid.is_2d() { 1 } else { sm.points };
        grid.cells()
            .map(|(i, j, k)| {
                let xc = grid.cell_center(i as isize, j as isize, k as isize);
                let mut acc = [0.0; 2];
                for qz in 0..nz {
                    let (oz, wz) = if grid.is_2d() { (0.0, 1.0) } else { (gx[qz], gw[qz]) };
                    for qy in 0..sm.points {
                        for qx in 0..sm.points {
                            let p = [xc[0] + gx[qx] * h[0], xc[1] + gx[qy] * h[1], xc[2] + oz * h[2]];
                            let sp = shape.closest(p);
                            let (s, ss) = profile(2.0 * bp * sp.distance);
                            let w = gw[qx] * gw[qy] * wz;
                            acc[0] += w * s;
                            acc[1] += w * 2.0 * bp * ss * sp.mean_curvature;
                        }
                    }
                }
                acc
            })
            .collect()
    }

    #[test]
    fn tail_rules_agree_with_the_full_rule() {
        // Cells out to about 25 cells from the surface, where the fewer-point rules and the
        // exact 0 / 1 take over: every cell average within 1e-15 of the full rule's where the
        // geometry reads phi (H and 1 - H above 5e-11), within 1e-12 elsewhere (the curvature
        // term in units of its scale 2 beta' max kappa).
        let g3 = Grid::<f64>::periodic([32; 3], [0.0; 3], [1.0; 3]).unwrap();
        let g2 = Grid::<f64>::periodic([96, 96, 1], [0.0; 3], [1.0, 1.0, 1.0 / 96.0]).unwrap();
        let sphere = Sphere::new([0.5; 3], 0.08).unwrap();
        let ellipsoid = Ellipsoid::new([0.5; 3], [0.2, 0.12, 0.08]).unwrap();
        let ellipse = Ellipse::new([0.5, 0.5], [0.2, 0.1]).unwrap();
        let cases: [(&Grid<f64>, &dyn Shape, f64); 3] =
            [(&g3, &sphere, 12.5), (&g3, &ellipsoid, 0.2 / 0.08f64.powi(2)), (&g2, &ellipse, 0.2 / 0.01)];
        for (g, shape, kmax) in cases {
            for sm in
                [Smoothing::default(), Smoothing { beta: 2.0, points: 3 }, Smoothing { beta: 0.5, points: 5 }]
            {
                let fast = cell_averages(g, shape, &sm, true).unwrap();
                let full = full_rule_averages(g, shape, &sm);
                let scale = 2.0 * sm.beta / characteristic_length(g) * kmax;
                for (a, b) in fast.iter().zip(&full) {
                    let tol = if b[0].min(1.0 - b[0]) < OUTSIDE_GEOMETRY { FAR_TAIL_TOL } else { TAIL_TOL };
                    assert!((a[0] - b[0]).abs() <= tol, "{sm:?}: H {} against {}", a[0], b[0]);
                    assert!((a[1] - b[1]).abs() <= tol * scale, "{sm:?}: kappa {} against {}", a[1], b[1]);
                }
            }
        }
    }

    #[test]
    fn biconcave_distance_matches_a_dense_search() {
        // Query points over the meridian half-plane, inside and outside, near the axis (where
        // the dimple's centre of curvature lies), near the rim and far out, against the smallest distance
        // to 400 001 points of the meridian refined by a golden-section search.
        let a = 0.17;
        let b = Biconcave::new([0.0; 3], a).unwrap();
        let n = 400_000;
        let pts: Vec<[f64; 2]> = (0..=n)
            .map(|k| {
                let m = b.meridian(PI * k as f64 / n as f64);
                [m[0], m[1]]
            })
            .collect();
        // Near the cell, and out to 4 a, where the pruned scan skips most blocks.
        let near = (0..=24)
            .flat_map(|i| (0..=12).map(move |j| (-1.5 + 3.0 * i as f64 / 24.0, 1.5 * j as f64 / 12.0)));
        let far = (0..=8).flat_map(|i| (0..=4).map(move |j| (-4.0 + i as f64, j as f64)));
        for (xa, r) in near.chain(far).map(|(x, r)| (a * x, a * r)) {
            {
                let sp = b.closest([xa, r, 0.0]);
                let k = (0..=n)
                    .min_by(|&p, &q| {
                        let d = |m: &[f64; 2]| (m[0] - xa).powi(2) + (m[1] - r).powi(2);
                        d(&pts[p]).total_cmp(&d(&pts[q]))
                    })
                    .unwrap();
                let d = |t: f64| {
                    let m = b.meridian(t);
                    ((m[0] - xa).powi(2) + (m[1] - r).powi(2)).sqrt()
                };
                let (mut lo, mut hi) =
                    (PI * k.saturating_sub(1) as f64 / n as f64, PI * (k + 1).min(n) as f64 / n as f64);
                for _ in 0..60 {
                    let (m1, m2) = (lo + 0.382 * (hi - lo), hi - 0.382 * (hi - lo));
                    if d(m1) < d(m2) {
                        hi = m2;
                    } else {
                        lo = m1;
                    }
                }
                let dense = d(0.5 * (lo + hi));
                assert!(
                    (sp.distance.abs() - dense).abs() < 1e-12 * a,
                    "({xa}, {r}): {} against {dense}",
                    sp.distance
                );
                // The closest point is the foot of the normal through the query point.
                let foot: f64 = (0..3).map(|c| (sp.point[c] - [xa, r, 0.0][c]).powi(2)).sum::<f64>().sqrt();
                assert!((foot - sp.distance.abs()).abs() < 1e-12 * a);
            }
        }
    }
}
