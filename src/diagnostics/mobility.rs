//! The surface velocity seen by the smoothed membrane, projected on a prescribed mode:
//!
//! ```text
//! c = sum delta (v_c . m(x)) dx dy dz / sum delta |m(x)|^2 dx dy dz
//! ```
//!
//! with `v_c` the cell-centred velocity ([`velocity_at_cell`]) and `m(x)` a vector field given
//! by the caller, e.g. `Y(x) e_r` (a normal shape mode) or the surface gradient of `Y`
//! (a tangential one). Every membrane quantity of the method (`G_s`, the stress, the advected
//! `phi` profile) is carried by the cells of the band with the weight `delta`, so `c` is the
//! velocity the *smoothed* membrane moves with, not the fluid velocity on the sharp surface.
//!
//! Applied to the response to a prescribed surface force it measures the discrete mobility of
//! the membrane (see `cases/examples/surface_mobility.rs`): [`StokesL2`] holds the velocities of
//! a sharp sphere under the two `l = 2` surface forces `g Y_2 e_r` and `g grad_s Y_2`, for any
//! ratio of the inner to the outer viscosity; [`l2_normal_mode`] and [`l2_tangential_mode`] are
//! the two modes for `Y_2 = 2 x z / r^2`.

use super::reduce::{check_field, check_vector, finite_or, sum_cells};
use crate::grid::ops::velocity_at_cell;
use crate::grid::{Field, Grid, VectorField};
use crate::{Error, Real, Result};

/// The Stokes velocities on a sphere of radius `a` (a sharp membrane) under the `l = 2` surface
/// forces, in units of `g a / mu_out`: `u_r = c Y_2` for a normal part, `u_t = c grad_s Y_2` for a
/// tangential part.
///
/// From Lamb's general solution with the solid harmonic `r^2 Y_2` (regular inside, decaying
/// outside, inner viscosity `lambda mu_out`), with velocity continuous and the traction jump
/// equal to the force across `r = a`. With `lambda = 1` the normal coefficient is the
/// single-layer value 4/35 (Taylor's relaxation of a drop of equal viscosity); for any `lambda`
/// it is Taylor's `10 (lambda + 1) / ((2 lambda + 3)(19 lambda + 16))`, and the reciprocal
/// theorem ties the two cross terms: `tangential_normal = 6 normal_tangential`.
///
/// ```
/// use eulermembrane::diagnostics::mobility::StokesL2;
/// let equal = StokesL2::EQUAL_VISCOSITIES;
/// assert!((equal.tangential - 1.0 / 7.0).abs() < 1e-15);
/// let red_cell = StokesL2::with_viscosity_ratio(5.0)?;
/// assert!(red_cell.tangential < equal.tangential);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StokesL2 {
    /// `u_r / (g a Y_2 / mu)` under the normal force `g Y_2 e_r`.
    pub normal: f64,
    /// `u_t / (g a grad_s Y_2 / mu)` under the normal force `g Y_2 e_r`.
    pub normal_tangential: f64,
    /// `u_t / (g a grad_s Y_2 / mu)` under the tangential force `g grad_s Y_2`.
    pub tangential: f64,
    /// `u_r / (g a Y_2 / mu)` under the tangential force `g grad_s Y_2`.
    pub tangential_normal: f64,
}

impl StokesL2 {
    /// The same viscosity on both sides (`lambda = 1`).
    pub const EQUAL_VISCOSITIES: StokesL2 = StokesL2 {
        normal: 4.0 / 35.0,
        normal_tangential: 1.0 / 35.0,
        tangential: 1.0 / 7.0,
        tangential_normal: 6.0 / 35.0,
    };

    /// The coefficients for the inner viscosity `lambda` times the outer one.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless `lambda` is positive and finite.
    pub fn with_viscosity_ratio(lambda: f64) -> Result<Self> {
        if !(lambda > 0.0 && lambda.is_finite()) {
            return Err(Error::invalid("lambda", lambda, "a positive, finite viscosity ratio"));
        }
        let d = (2.0 * lambda + 3.0) * (19.0 * lambda + 16.0);
        Ok(StokesL2 {
            normal: 10.0 * (lambda + 1.0) / d,
            normal_tangential: (3.0 * lambda + 2.0) / d,
            tangential: (13.0 * lambda + 12.0) / d,
            tangential_normal: 6.0 * (3.0 * lambda + 2.0) / d,
        })
    }
}

/// The unit vector along `r`.
fn radial(r: [f64; 3]) -> [f64; 3] {
    let len = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt().max(1e-12);
    r.map(|c| c / len)
}

/// The normal `l = 2` mode `Y_2 e_r`, `Y_2 = 2 e_x e_z`, at `r`, the position relative to the
/// sphere's centre (constant along radial lines, so it can be applied across the band).
pub fn l2_normal_mode(r: [f64; 3]) -> [f64; 3] {
    let e = radial(r);
    let y = 2.0 * e[0] * e[2];
    e.map(|c| y * c)
}

/// The tangential `l = 2` mode `grad_s Y_2 = (2 e_z, 0, 2 e_x) - 2 Y_2 e` on the unit sphere, at
/// `r`, the position relative to the sphere's centre (constant along radial lines).
pub fn l2_tangential_mode(r: [f64; 3]) -> [f64; 3] {
    let e = radial(r);
    let y = 2.0 * e[0] * e[2];
    [2.0 * e[2] - 2.0 * y * e[0], -2.0 * y * e[1], 2.0 * e[0] - 2.0 * y * e[2]]
}

/// The `delta`-weighted projection `c` of the cell-centred velocity on the mode `m(x)` (see the
/// [module docs](self)). `v` is the staggered velocity with one ghost layer filled; `delta` the
/// smoothed delta function at cell centres; `m` is evaluated at the centres of the cells where
/// `delta > 0`.
///
/// ```
/// use eulermembrane::diagnostics::mobility::surface_velocity_projection;
/// use eulermembrane::grid::{Field, Grid, VectorField};
/// let g = Grid::<f64>::periodic([8; 3], [0.0; 3], [1.0; 3])?;
/// let mut v = VectorField::from_fn(&g, |_| [2.0, 0.0, 0.0]);
/// v.fill_ghosts(&g);
/// let delta = Field::from_cell_fn(&g, |x| if x[2] < 0.5 { 1.0 } else { 0.0 });
/// // a uniform velocity 2 e_x projected on the mode e_x
/// let c = surface_velocity_projection(&g, &v, &delta, |_| [1.0, 0.0, 0.0])?;
/// assert!((c - 2.0).abs() < 1e-12);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
///
/// Errors: a field not on `grid`; a non-finite value; a mode that vanishes wherever
/// `delta > 0` (`m`, nothing to project on).
pub fn surface_velocity_projection<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    delta: &Field<T>,
    m: impl Fn([f64; 3]) -> [f64; 3] + Sync,
) -> Result<f64> {
    check_field(grid, "delta", delta)?;
    check_vector(grid, "v", v)?;
    let sums = sum_cells(grid, |idx, [i, j, k]| {
        let d = delta.data[idx].f64();
        if d <= 0.0 {
            return [0.0; 2];
        }
        let x = grid.cell_center(i as isize, j as isize, k as isize).map(|c| c.f64());
        let mode = m(x);
        let u = velocity_at_cell(grid, v, idx);
        let um: f64 = (0..3).map(|a| u[a].f64() * mode[a]).sum();
        let mm: f64 = mode.iter().map(|c| c * c).sum();
        [d * um, d * mm]
    });
    let fields = [("delta", delta), ("v.u", &v.c[0]), ("v.v", &v.c[1]), ("v.w", &v.c[2])];
    let [num, den] = finite_or(sums, grid, &fields)?;
    if den <= 0.0 {
        return Err(Error::invalid(
            "m",
            "a mode that is zero on the band",
            "a mode with m(x) != 0 somewhere delta > 0",
        ));
    }
    Ok(num / den)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_field_projects_exactly() {
        // v = (y, 0, 0) on a slab of delta: projection on e_x gives the delta-weighted mean y.
        let g = Grid::<f64>::periodic([8; 3], [0.0; 3], [1.0; 3]).unwrap();
        let mut v = VectorField::from_fn(&g, |x| [x[1], 0.0, 0.0]);
        v.fill_ghosts(&g);
        let delta = Field::from_cell_fn(&g, |x| if (x[1] - 0.4375).abs() < 0.01 { 3.0 } else { 0.0 });
        let c = surface_velocity_projection(&g, &v, &delta, |_| [1.0, 0.0, 0.0]).unwrap();
        assert!((c - 0.4375).abs() < 1e-12, "{c}");
        // a mode twice as long halves the coefficient
        let c2 = surface_velocity_projection(&g, &v, &delta, |_| [2.0, 0.0, 0.0]).unwrap();
        assert!((c2 - 0.5 * 0.4375).abs() < 1e-12, "{c2}");
    }

    #[test]
    fn stokes_l2_matches_the_drop_limits_and_reciprocity() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs().max(1.0);
        let one = StokesL2::with_viscosity_ratio(1.0).unwrap();
        let e = StokesL2::EQUAL_VISCOSITIES;
        assert!(close(one.normal, e.normal) && close(one.tangential, e.tangential));
        assert!(
            close(one.normal_tangential, e.normal_tangential)
                && close(one.tangential_normal, e.tangential_normal)
        );
        for lambda in [1e-6, 0.2, 1.0, 5.0, 1e6] {
            let c = StokesL2::with_viscosity_ratio(lambda).unwrap();
            // Taylor's relaxation time of a drop's l = 2 shape, tau = (2 lambda + 3)(19 lambda + 16)
            // mu a / (40 (lambda + 1) sigma), under the Laplace force 4 sigma / a^2 per unit
            // amplitude: u_r / f = a^2 / (4 sigma tau).
            let tau = (2.0 * lambda + 3.0) * (19.0 * lambda + 16.0) / (40.0 * (lambda + 1.0));
            assert!(close(c.normal, 1.0 / (4.0 * tau)), "lambda {lambda}");
            // reciprocity: int f_n u_r(tangential force) = int f_t . u_t(normal force), and
            // int |grad_s Y_2|^2 = 6 int Y_2^2 on the unit sphere
            assert!(close(c.tangential_normal, 6.0 * c.normal_tangential), "lambda {lambda}");
        }
        // a bubble (lambda -> 0) moves 5/24; a rigid interior (lambda -> infinity) not at all
        assert!((StokesL2::with_viscosity_ratio(1e-9).unwrap().normal - 5.0 / 24.0).abs() < 1e-8);
        assert!(StokesL2::with_viscosity_ratio(1e9).unwrap().tangential < 1e-9);
        assert!(
            StokesL2::with_viscosity_ratio(0.0).is_err() && StokesL2::with_viscosity_ratio(f64::NAN).is_err()
        );
    }

    #[test]
    fn the_l2_modes_are_normal_and_tangential_and_orthogonal() {
        for r in [[0.3, -0.5, 0.8], [2.0, 1.0, -1.5], [-0.1, 0.0, 0.4]] {
            let e = radial(r);
            let (n, t) = (l2_normal_mode(r), l2_tangential_mode(r));
            let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            let cross = [n[1] * e[2] - n[2] * e[1], n[2] * e[0] - n[0] * e[2], n[0] * e[1] - n[1] * e[0]];
            assert!(dot(cross, cross) < 1e-28, "{n:?} not along {e:?}");
            assert!(dot(t, e).abs() < 1e-14 && dot(t, n).abs() < 1e-14, "{t:?}");
            assert!((dot(n, e) - 2.0 * e[0] * e[2]).abs() < 1e-14);
        }
    }

    #[test]
    fn a_mode_that_vanishes_on_the_band_is_refused() {
        let g = Grid::<f64>::periodic([4; 3], [0.0; 3], [1.0; 3]).unwrap();
        let v = VectorField::zeros(&g);
        let delta = Field::from_cell_fn(&g, |_| 1.0);
        let e = surface_velocity_projection(&g, &v, &delta, |_| [0.0; 3]).unwrap_err();
        assert!(e.to_string().contains('m'), "{e}");
    }
}
