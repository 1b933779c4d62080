//! Surface area of the membrane, measured directly and transported in time (Sec. 3.4.1):
//!
//! ```text
//! s = int delta dV  ~  sum_ijk delta_ijk dx dy dz,
//! ds/dt = - int delta n.grad v.n dV                                          (3.6)
//! s^{n+1} = s^n - dt sum_ijk dx dy dz delta^n_ijk n^n_ijk . grad v^n_ijk . n^n_ijk    (3.7)
//! ```
//!
//! `delta = |grad phi|` is the smoothed surface delta function: by the coarea formula
//! `int |grad phi| f dV = int_0^1 (int_{phi = c} f dA) dc`, so `sum delta dV` is the area of the
//! level sets of `phi` averaged over `0 < c < 1` (for a sphere of radius `r` and a logistic
//! profile of width `w`, `4 pi (r^2 + pi^2 w^2 / 3)`: second order in the band width).
//!
//! (3.6) is the surface divergence theorem for an incompressible flow: the rate of area change
//! per unit area is `div_s v = div v - n.grad v.n`, and `div v = 0`. A compressible velocity
//! field (a uniform expansion, say) therefore gives the wrong rate.
//!
//! `grad v` is the cell-centred velocity gradient of
//! [`grad_v_at_cell`] (exact for a linear velocity field), and
//! `n` is normalised in each cell, so either orientation and any length of the given normal
//! vectors give the same result; cells with a zero normal or a zero `delta` add nothing.

use super::reduce::{check_field, check_vector, finite_or, sum_cells};
use crate::grid::ops::grad_v_at_cell;
use crate::grid::{Field, Grid, VectorField};
use crate::{Error, Real, Result};

/// Surface area `s = sum delta_ijk dx dy dz` (the first relation of (3.6)), with `delta` the
/// smoothed delta function `|grad phi|` at cell centres.
///
/// Errors: `delta` not on `grid`; a non-finite value.
pub fn area_from_delta<T: Real>(grid: &Grid<T>, delta: &Field<T>) -> Result<f64> {
    check_field(grid, "delta", delta)?;
    let [s] = finite_or(sum_cells(grid, |idx, _| [delta.data[idx].f64()]), grid, &[("delta", delta)])?;
    Ok(s * grid.cell_volume().f64())
}

/// Rate of change of the surface area (3.6), `ds/dt = - sum delta n.grad v.n dx dy dz`.
///
/// `normals` are the three components of the membrane normal at cell centres (normalised here);
/// `v` is the staggered velocity with one ghost layer filled.
///
/// Errors: a field not on `grid`; a non-finite value.
pub fn dilation_rate<T: Real>(
    grid: &Grid<T>,
    delta: &Field<T>,
    normals: &[Field<T>; 3],
    v: &VectorField<T>,
) -> Result<f64> {
    check_field(grid, "delta", delta)?;
    for c in normals {
        check_field(grid, "normals", c)?;
    }
    check_vector(grid, "v", v)?;
    let [s] = sum_cells(grid, |idx, _| {
        let d = delta.data[idx].f64();
        if d == 0.0 {
            return [0.0];
        }
        let n = [normals[0].data[idx].f64(), normals[1].data[idx].f64(), normals[2].data[idx].f64()];
        let nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        if nn == 0.0 {
            return [0.0];
        }
        let g = grad_v_at_cell(grid, v, idx);
        let mut ngn = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                ngn += n[i] * g[i][j].f64() * n[j];
            }
        }
        [-d * ngn / nn]
    });
    let fields = [
        ("delta", delta),
        ("normals[0]", &normals[0]),
        ("normals[1]", &normals[1]),
        ("normals[2]", &normals[2]),
        ("v.u", &v.c[0]),
        ("v.v", &v.c[1]),
        ("v.w", &v.c[2]),
    ];
    let [s] = finite_or([s], grid, &fields)?;
    Ok(s * grid.cell_volume().f64())
}

/// The surface area transported in time by (3.7): forward Euler on the rate of
/// [`dilation_rate`], one call of [`step`](AreaTracker::step) per time step with the fields of
/// the start of the step (time level `n`).
///
/// ```
/// use eulermembrane::diagnostics::area::AreaTracker;
/// let tracker = AreaTracker::new(4.0 * std::f64::consts::PI)?;
/// assert_eq!(tracker.steps(), 0);
/// assert!((tracker.relative() - 1.0).abs() < 1e-15);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct AreaTracker {
    initial: f64,
    area: f64,
    time: f64,
    steps: usize,
}

impl AreaTracker {
    /// Starts from a given area `s^0` at time zero. Errors: `s^0` not finite and positive.
    pub fn new(initial_area: f64) -> Result<Self> {
        let a = crate::error::positive("initial_area", initial_area)?;
        Ok(AreaTracker { initial: a, area: a, time: 0.0, steps: 0 })
    }

    /// Starts from the area measured by [`area_from_delta`].
    pub fn from_delta<T: Real>(grid: &Grid<T>, delta: &Field<T>) -> Result<Self> {
        Self::new(area_from_delta(grid, delta)?)
    }

    /// Advances (3.7) by `dt` with `delta`, normals and velocity of time level `n` (velocity
    /// ghosts filled) and returns the new area. On error the tracker is left unchanged.
    ///
    /// Errors: `dt` not finite and positive; the errors of [`dilation_rate`].
    pub fn step<T: Real>(
        &mut self,
        grid: &Grid<T>,
        delta: &Field<T>,
        normals: &[Field<T>; 3],
        v: &VectorField<T>,
        dt: f64,
    ) -> Result<f64> {
        crate::error::positive("dt", dt)?;
        let rate = dilation_rate(grid, delta, normals, v)?;
        let area = self.area + dt * rate;
        if !area.is_finite() {
            return Err(Error::invalid("dt", dt, "a step that keeps the area finite"));
        }
        self.area = area;
        self.time += dt;
        self.steps += 1;
        Ok(area)
    }

    /// The current area `s^n`.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// The area normalised by the initial area, `s^n / s^0` (the quantity of Fig. 12).
    pub fn relative(&self) -> f64 {
        self.area / self.initial
    }

    /// The initial area `s^0`.
    pub fn initial(&self) -> f64 {
        self.initial
    }

    /// Time accumulated over the steps taken.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }
}
