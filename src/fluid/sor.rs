//! The paper's SOR solver for the predictor (2.35), kept as the reference (Sec. 3): lexicographic
//! Gauss-Seidel sweeps over the three components with over-relaxation `omega` (1.4 in the
//! paper), until the relative change
//! `E = sqrt(sum (v^(k+1) - v^(k))^2 / sum (v^(0))^2)` falls below the tolerance (1e-6).

use super::momentum::{Predictor, is_wall_face};
use crate::grid::{Grid, VectorField};
use crate::{Error, Real, Result};

/// Settings of the SOR solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SorParams {
    /// Over-relaxation factor, in (0, 2). The paper uses 1.4.
    pub omega: f64,
    /// Relative change `E` to reach. The paper uses 1e-6.
    pub tolerance: f64,
    /// Sweep limit; reaching it is an error.
    pub max_sweeps: usize,
}

impl Default for SorParams {
    /// The paper's settings: `omega = 1.4`, `tolerance = 1e-6`, and at most 100 000 sweeps.
    fn default() -> Self {
        SorParams { omega: 1.4, tolerance: 1e-6, max_sweeps: 100_000 }
    }
}

impl SorParams {
    /// Checks the settings.
    pub fn validate(&self) -> Result<()> {
        if !(self.omega > 0.0 && self.omega < 2.0) {
            return Err(Error::invalid("SorParams::omega", self.omega, "a number in (0, 2)"));
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::invalid("SorParams::tolerance", self.tolerance, "a finite number > 0"));
        }
        if self.max_sweeps == 0 {
            return Err(Error::invalid("SorParams::max_sweeps", 0, "at least 1 sweep"));
        }
        Ok(())
    }
}

/// Solves `P x = b` by SOR from the given `x`; returns the number of sweeps and the final `E`.
pub(crate) fn sor<T: Real>(
    grid: &Grid<T>,
    op: &Predictor<T>,
    b: &VectorField<T>,
    x: &mut VectorField<T>,
    params: SorParams,
) -> Result<(usize, f64)> {
    let omega = T::lit(params.omega);
    x.fill_ghosts_homogeneous(grid);
    let mut norm0 = 0.0;
    for c in 0..3 {
        for (i, j, k) in grid.cells() {
            let v = x.c[c].data[grid.idx_u(i, j, k)].f64();
            norm0 += v * v;
        }
    }
    // A start from rest has no scale of its own: measure the change against the first sweep.
    let mut scale = if norm0 > 0.0 { Some(norm0) } else { None };
    let mut e = f64::INFINITY;
    for sweep in 1..=params.max_sweeps {
        let mut change = 0.0;
        for c in 0..3 {
            for (i, j, k) in grid.cells() {
                let idx = grid.idx_u(i, j, k);
                let wall = is_wall_face(grid, c, [i, j, k]);
                let r = b.c[c].data[idx] - op.apply_at(x, c, idx, wall);
                let dx = omega * r / op.diag_at(c, idx, wall);
                x.c[c].data[idx] += dx;
                change += dx.f64() * dx.f64();
            }
        }
        x.fill_ghosts_homogeneous(grid);
        let s = *scale.get_or_insert(change.max(f64::MIN_POSITIVE));
        e = (change / s).sqrt();
        if !e.is_finite() {
            break;
        }
        if e < params.tolerance {
            return Ok((sweep, e));
        }
    }
    Err(Error::NoConvergence {
        solver: "SOR",
        iterations: params.max_sweeps,
        residual: e,
        tolerance: params.tolerance,
    })
}
