//! Taylor deformation parameter of a capsule section (Sec. 3.3.1):
//!
//! ```text
//! a x^2 + b y^2 + c x y + d x + e y + 1 = 0      (least-squares fit of the phi = 1/2 contour)
//! D = (L - B) / (L + B)                          (L, B: semi-major and semi-minor axes)
//! ```
//!
//! 1. **Section.** The plane through the centre `x_c` normal to `normal_axis` (for the shear
//!    flow of Sec. 3.3, the x-z plane, normal to y). `phi` is interpolated linearly between the
//!    two layers of cell centres that bracket the plane (one layer on a 2D grid). The in-plane
//!    coordinates are the two other axes in increasing order ([`section_axes`]), measured from
//!    `x_c` and unwrapped across periodic boundaries.
//! 2. **Contour points.** As in the paper, "the cross points between the contour line of the VOF
//!    function at `phi = 0.5` and the computational meshes": along every grid line of the section
//!    (through the cell centres, in both in-plane directions), each pair of neighbouring values on
//!    either side of `1/2` gives one point by linear interpolation.
//! 3. **Fit.** The five coefficients minimise `sum (a x^2 + b y^2 + c x y + d x + e y + 1)^2`
//!    ([`fit_ellipse`]), solved by Householder QR (faer's [`Qr`](faer::linalg::solvers::Qr)) on coordinates relative to `x_c` and scaled by
//!    their r.m.s. radius (a well-conditioned 5-column problem). The constant term can be
//!    normalised to 1 because the conic does not pass through `x_c`, which lies inside the
//!    capsule.
//! 4. **Axes.** With `M = [[a, c/2], [c/2, b]]`, centre `x_0 = -M^{-1} (d, e)/2` and
//!    `f_0 = 1 + (d, e).x_0 / 2`, the conic is `(x - x_0)^T M (x - x_0) = -f_0`: an ellipse iff
//!    both eigenvalues `lambda_i` of `M` have the sign of `-f_0`, with semi-axes
//!    `sqrt(-f_0 / lambda_i)`. The inclination is the angle of the major axis from the first
//!    in-plane axis towards the second, in `(-90, 90]` degrees: for the shear case, from the flow
//!    direction x towards the shear direction z.

use super::reduce::{AxisFrame, check_field, check_point};
use crate::grid::{Field, Grid};
use crate::{Error, Real, Result};
use faer::Mat;
use faer::linalg::solvers::SolveLstsq;

/// Fewest contour points a fit accepts (five unknowns, plus one).
const MIN_POINTS: usize = 6;

/// The in-plane axes `[p, q]` of the section normal to `normal_axis`: the two other axes in
/// increasing order (`1 -> [0, 2]`, the x-z plane). `None` if `normal_axis > 2`.
pub fn section_axes(normal_axis: usize) -> Option<[usize; 2]> {
    match normal_axis {
        0 => Some([1, 2]),
        1 => Some([0, 2]),
        2 => Some([0, 1]),
        _ => None,
    }
}

/// The ellipse fitted to a section contour by [`fit_ellipse`] (centre, semi-axes, angle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EllipseFit {
    /// Centre, in the coordinates of the fitted points.
    pub centre: [f64; 2],
    /// Semi-major axis `L`.
    pub semi_major: f64,
    /// Semi-minor axis `B`.
    pub semi_minor: f64,
    /// Angle of the major axis from the first coordinate axis towards the second, radians, in
    /// `(-pi/2, pi/2]`.
    pub angle: f64,
    /// Root-mean-square distance of the fitted points from the ellipse (first-order estimate
    /// `|Q(x)| / |grad Q(x)|` of the fitted conic `Q`): a measure of how elliptic the contour is.
    pub rms_distance: f64,
}

impl EllipseFit {
    /// Taylor's deformation parameter `D = (L - B)/(L + B)`.
    pub fn deformation(&self) -> f64 {
        (self.semi_major - self.semi_minor) / (self.semi_major + self.semi_minor)
    }
}

/// The Taylor deformation of a capsule section (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaylorDeformation {
    /// `D = (L - B)/(L + B)`.
    pub deformation: f64,
    /// Semi-major axis `L`.
    pub semi_major: f64,
    /// Semi-minor axis `B`.
    pub semi_minor: f64,
    /// Inclination of the major axis from the first in-plane axis towards the second
    /// ([`section_axes`]), degrees in `(-90, 90]`.
    pub angle_deg: f64,
    /// Number of contour points fitted.
    pub points: usize,
    /// Centre of the fitted ellipse in the box coordinates of the two in-plane axes.
    pub centre: [f64; 2],
    /// Root-mean-square distance of the contour points from the fitted ellipse.
    pub rms_distance: f64,
}

/// The points where `phi = level` crosses the grid lines of the section through `centre`
/// normal to `normal_axis`, as in-plane displacements `[p - p_c, q - q_c]` from `centre` (axes of
/// [`section_axes`], unwrapped across periodic boundaries; see the [module docs](self)).
///
/// Points are ordered by grid line (first the lines along the first in-plane axis), not along
/// the contour.
///
/// Errors: `phi` not on `grid`; `normal_axis > 2`; a non-finite `centre` or `level`; a
/// non-finite `phi` value in the section.
pub fn section_contour<T: Real>(
    grid: &Grid<T>,
    phi: &Field<T>,
    centre: [f64; 3],
    normal_axis: usize,
    level: f64,
) -> Result<Vec<[f64; 2]>> {
    check_field(grid, "phi", phi)?;
    check_point("centre", centre)?;
    if !level.is_finite() {
        return Err(Error::invalid("level", level, "a finite number"));
    }
    let [pa, qa] =
        section_axes(normal_axis).ok_or_else(|| Error::invalid("normal_axis", normal_axis, "0, 1 or 2"))?;
    let n = grid.n();
    let (np, nq) = (n[pa], n[qa]);
    // The two layers that bracket the plane, and the interpolation weight of the upper one.
    let (na, ha, la) = (n[normal_axis], grid.h()[normal_axis].f64(), grid.lower()[normal_axis].f64());
    let t = (centre[normal_axis] - la) / ha - 0.5;
    let (k0, k1, w) = if na == 1 {
        (0, 0, 0.0)
    } else if grid.is_periodic(normal_axis) {
        let f = t.floor();
        let k0 = (f as isize).rem_euclid(na as isize) as usize;
        (k0, (k0 + 1) % na, t - f)
    } else if t <= 0.0 {
        (0, 0, 0.0)
    } else if t >= (na - 1) as f64 {
        (na - 1, na - 1, 0.0)
    } else {
        let f = t.floor();
        (f as usize, f as usize + 1, t - f)
    };
    // The section, s[a + np * b] at in-plane cell (a, b).
    let mut s = vec![0.0; np * nq];
    for b in 0..nq {
        for a in 0..np {
            let at = |kk: usize| {
                let mut ijk = [0usize; 3];
                ijk[pa] = a;
                ijk[qa] = b;
                ijk[normal_axis] = kk;
                (ijk, phi.data[grid.idx_u(ijk[0], ijk[1], ijk[2])].f64())
            };
            let (c0, v0) = at(k0);
            let (c1, v1) = at(k1);
            for (c, v) in [(c0, v0), (c1, v1)] {
                if !v.is_finite() {
                    return Err(Error::NonFinite { field: "phi", cell: c });
                }
            }
            s[a + np * b] = (1.0 - w) * v0 + w * v1;
        }
    }
    let fp = AxisFrame::new(grid, pa, centre[pa]);
    let fq = AxisFrame::new(grid, qa, centre[qa]);
    let (hp, hq) = (grid.h()[pa].f64(), grid.h()[qa].f64());
    let mut pts = Vec::new();
    let cross = |v0: f64, v1: f64| -> Option<f64> {
        ((v0 >= level) != (v1 >= level)).then(|| (level - v0) / (v1 - v0))
    };
    // Lines along p (q fixed at a cell centre), then lines along q. A periodic axis closes the
    // line with the pair (n-1, 0).
    for (along, nl, no, frame_l, frame_o, hl) in [(pa, np, nq, &fp, &fq, hp), (qa, nq, np, &fq, &fp, hq)] {
        let closed = grid.is_periodic(along) && nl > 1;
        let pairs = if closed { nl } else { nl.saturating_sub(1) };
        for o in 0..no {
            for l in 0..pairs {
                let l1 = (l + 1) % nl;
                let (v0, v1) = if along == pa {
                    (s[l + np * o], s[l1 + np * o])
                } else {
                    (s[o + np * l], s[o + np * l1])
                };
                if let Some(t) = cross(v0, v1) {
                    let dl = frame_l.wrap(frame_l.cell(l as isize) + t * hl);
                    let d_o = frame_o.cell(o as isize);
                    pts.push(if along == pa { [dl, d_o] } else { [d_o, dl] });
                }
            }
        }
    }
    Ok(pts)
}

/// Least-squares fit of the conic `a x^2 + b y^2 + c x y + d x + e y + 1 = 0` to `points` and
/// its reduction to an [`EllipseFit`] (see the [module docs](self)). The points should surround
/// the origin (use coordinates relative to the capsule centre, as [`section_contour`] gives).
///
/// Errors: fewer than 6 points, or a non-finite coordinate ([`Error::InvalidParameter`]); a
/// degenerate fit or a conic that is not an ellipse ([`Error::Unsupported`]).
///
/// ```
/// use eulermembrane::diagnostics::taylor::fit_ellipse;
/// // Points on an ellipse with semi-axes 2 and 1, tilted by 30 degrees, centred at (0.1, 0).
/// let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
/// let pts: Vec<[f64; 2]> = (0..40)
///     .map(|k| {
///         let t = k as f64 * std::f64::consts::TAU / 40.0;
///         let (u, v) = (2.0 * t.cos(), t.sin());
///         [0.1 + c * u - s * v, s * u + c * v]
///     })
///     .collect();
/// let e = fit_ellipse(&pts)?;
/// assert!((e.semi_major - 2.0).abs() < 1e-9 && (e.semi_minor - 1.0).abs() < 1e-9);
/// assert!((e.angle.to_degrees() - 30.0).abs() < 1e-7);
/// assert!((e.deformation() - 1.0 / 3.0).abs() < 1e-9);
/// assert!(fit_ellipse(&pts[..3]).is_err());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn fit_ellipse(points: &[[f64; 2]]) -> Result<EllipseFit> {
    if points.len() < MIN_POINTS {
        return Err(Error::invalid(
            "points",
            format!("{} points", points.len()),
            "at least 6 contour points",
        ));
    }
    if let Some(p) = points.iter().find(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return Err(Error::invalid("points", format!("{p:?}"), "finite coordinates"));
    }
    let not_ellipse = |why: &str| Error::Unsupported {
        component: "fit_ellipse",
        detail: format!("{why}; fit a closed contour"),
    };
    // Scale by the r.m.s. radius, so that the columns are O(1).
    let ms = points.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum::<f64>() / points.len() as f64;
    let sc = ms.sqrt();
    if !(sc > 0.0 && sc.is_finite()) {
        return Err(not_ellipse("all points at the origin"));
    }
    // Rows [x^2, y^2, xy, x, y] against the right-hand side -1.
    let m = points.len();
    let a = Mat::from_fn(m, 5, |r, c| {
        let (x, y) = (points[r][0] / sc, points[r][1] / sc);
        [x * x, y * y, x * y, x, y][c]
    });
    let b = Mat::from_fn(m, 1, |_, _| -1.0);
    let sol = qr_lstsq(&a, &b).ok_or_else(|| not_ellipse("degenerate least-squares problem"))?;
    let [ca, cb, cc, cd, ce] = sol;
    // Conic in scaled coordinates: ca x^2 + cb y^2 + cc xy + cd x + ce y + 1 = 0.
    let det = ca * cb - 0.25 * cc * cc;
    if det <= 0.0 || !det.is_finite() {
        return Err(not_ellipse("the fitted conic is not an ellipse (4ab - c^2 <= 0)"));
    }
    // Centre: [2a c; c 2b] x0 = -[d; e].
    let x0 = (-cd * 2.0 * cb + cc * ce) / (4.0 * det);
    let y0 = (-ce * 2.0 * ca + cc * cd) / (4.0 * det);
    let f0 = 1.0 + 0.5 * (cd * x0 + ce * y0);
    // Eigenvalues of M = [[a, c/2], [c/2, b]]; lam_hi along the angle th.
    let mean = 0.5 * (ca + cb);
    let rad = (0.5 * (ca - cb)).hypot(0.5 * cc);
    let (lam_hi, lam_lo) = (mean + rad, mean - rad);
    let th = 0.5 * cc.atan2(ca - cb);
    let (s_hi, s_lo) = (-f0 / lam_hi, -f0 / lam_lo);
    if !(s_hi > 0.0 && s_lo > 0.0 && s_hi.is_finite() && s_lo.is_finite()) {
        return Err(not_ellipse("the fitted conic is an empty (imaginary) ellipse"));
    }
    let (ax_hi, ax_lo) = (s_hi.sqrt() * sc, s_lo.sqrt() * sc);
    // The major axis lies along the eigenvector of the eigenvalue with the larger semi-axis.
    let (major, minor, mut angle) =
        if ax_hi >= ax_lo { (ax_hi, ax_lo, th) } else { (ax_lo, ax_hi, th + std::f64::consts::FRAC_PI_2) };
    let half_pi = std::f64::consts::FRAC_PI_2;
    while angle > half_pi {
        angle -= std::f64::consts::PI;
    }
    while angle <= -half_pi {
        angle += std::f64::consts::PI;
    }
    // Sampson distance of each point from the conic, in original units.
    let mut d2 = 0.0;
    for p in points {
        let (x, y) = (p[0] / sc, p[1] / sc);
        let q = ca * x * x + cb * y * y + cc * x * y + cd * x + ce * y + 1.0;
        let gx = 2.0 * ca * x + cc * y + cd;
        let gy = 2.0 * cb * y + cc * x + ce;
        let g = gx.hypot(gy);
        d2 += if g > 0.0 { (q / g).powi(2) } else { 0.0 };
    }
    let rms_distance = (d2 / m as f64).sqrt() * sc;
    Ok(EllipseFit { centre: [x0 * sc, y0 * sc], semi_major: major, semi_minor: minor, angle, rms_distance })
}

/// Least squares `min |A x - b|` by faer's Householder QR, with `a` the `m x 5` matrix `A` and
/// `b` the right-hand side. `None` if `A` is rank-deficient (a diagonal entry of `R` below
/// `1e-12` times the largest column norm of `A`) or the solution is not finite.
fn qr_lstsq(a: &Mat<f64>, b: &Mat<f64>) -> Option<[f64; 5]> {
    let col_max = (0..a.ncols()).map(|c| a.col(c).norm_l2()).fold(0.0, f64::max);
    let qr = a.qr();
    let r = qr.thin_R();
    if (0..a.ncols()).any(|k| r[(k, k)].abs() <= 1e-12 * col_max || !r[(k, k)].is_finite()) {
        return None;
    }
    let x = qr.solve_lstsq(b);
    let x: [f64; 5] = std::array::from_fn(|k| x[(k, 0)]);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Taylor deformation of the section of `phi` through `centre` normal to `normal_axis`:
/// [`section_contour`] at `phi = 1/2`, then [`fit_ellipse`] (see the [module docs](self)).
/// For the shear flow of Sec. 3.3 (walls normal to z, flow along x), use the
/// [`centroid`](super::volume::centroid) and `normal_axis = 1`; the angle is then the inclination to the
/// flow direction.
///
/// Errors: those of [`section_contour`] and [`fit_ellipse`] (fewer than 6 contour points, a
/// section that is not an ellipse).
pub fn taylor_deformation<T: Real>(
    grid: &Grid<T>,
    phi: &Field<T>,
    centre: [f64; 3],
    normal_axis: usize,
) -> Result<TaylorDeformation> {
    let pts = section_contour(grid, phi, centre, normal_axis, 0.5)?;
    let e = fit_ellipse(&pts)?;
    let [pa, qa] = section_axes(normal_axis).unwrap_or([0, 1]);
    let fp = AxisFrame::new(grid, pa, centre[pa]);
    let fq = AxisFrame::new(grid, qa, centre[qa]);
    Ok(TaylorDeformation {
        deformation: e.deformation(),
        semi_major: e.semi_major,
        semi_minor: e.semi_minor,
        angle_deg: e.angle.to_degrees(),
        points: pts.len(),
        centre: [fp.absolute(e.centre[0]), fq.absolute(e.centre[1])],
        rms_distance: e.rms_distance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// faer's QR least squares gives what the hand-written Householder solve it replaced gave
    /// (the values below, printed by that solve), to round-off: 1e-13 relative is 500 ulps,
    /// where the two differ by at most 3e-15.
    #[test]
    fn faer_fit_matches_the_former_householder_solve() {
        // Points on a tilted ellipse with a deterministic radial perturbation of 1 %.
        let pts: Vec<[f64; 2]> = (0..57)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 57.0;
                let r = 1.0 + 0.01 * (7.0 * t).sin() + 0.003 * (13.0 * t).cos();
                let (u, v) = (1.3 * r * t.cos(), 0.7 * r * t.sin());
                let (c, s) = (0.4f64.cos(), 0.4f64.sin());
                [0.05 + c * u - s * v, -0.02 + s * u + c * v]
            })
            .collect();
        let e = fit_ellipse(&pts).unwrap();
        let before = [
            0.04998892482969092,
            -0.019995680760244848,
            1.3001770596540256,
            0.7000959719525937,
            0.39999894276173426,
            0.007044589291569005,
            0.29999958916580843,
        ];
        let after =
            [e.centre[0], e.centre[1], e.semi_major, e.semi_minor, e.angle, e.rms_distance, e.deformation()];
        for (a, b) in after.into_iter().zip(before) {
            approx::assert_relative_eq!(a, b, max_relative = 1e-13);
        }
    }
}
