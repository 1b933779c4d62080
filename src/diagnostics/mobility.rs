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
//! the membrane (see `examples/surface_mobility.rs`): for a sphere of radius `a` in a fluid of
//! viscosity `mu` on both sides, a force `g Y_2 e_r` gives `u_r = (4/35) g a Y_2 / mu` on the
//! surface (the single-layer Stokes potential; the same as Taylor's relaxation time of a drop of
//! equal viscosity), and `g grad_s Y_2` gives `u_t = (1/7) g a grad_s Y_2 / mu`.

use super::reduce::{check_field, check_vector, finite_or, sum_cells};
use crate::grid::ops::velocity_at_cell;
use crate::grid::{Field, Grid, VectorField};
use crate::{Error, Real, Result};

/// The `delta`-weighted projection `c` of the cell-centred velocity on the mode `m(x)` (see the
/// [module docs](self)). `v` is the staggered velocity with one ghost layer filled; `delta` the
/// smoothed delta function at cell centres; `m` is evaluated at the centres of the cells where
/// `delta > 0`.
///
/// ```
/// use eulermembrane::diagnostics::surface_velocity_projection;
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
    if den <= 0.0 || !den.is_finite() {
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
    fn a_mode_that_vanishes_on_the_band_is_refused() {
        let g = Grid::<f64>::periodic([4; 3], [0.0; 3], [1.0; 3]).unwrap();
        let v = VectorField::zeros(&g);
        let delta = Field::from_cell_fn(&g, |_| 1.0);
        let e = surface_velocity_projection(&g, &v, &delta, |_| [0.0; 3]).unwrap_err();
        assert!(e.to_string().contains('m'), "{e}");
    }
}
