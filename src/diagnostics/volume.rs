//! Volume and centroid of a capsule from its VOF function `phi` (`phi = 1` inside):
//!
//! ```text
//! V   = sum_ijk phi_ijk dx dy dz,
//! x_c = sum_ijk phi_ijk x_ijk dx dy dz / sum_ijk phi_ijk dx dy dz          (3.5)
//! ```
//!
//! with `x_ijk` the cell centres. The sums are exact integrals of `phi` when `phi_ijk` are cell
//! averages (as MTHINC transports them), and second-order midpoint rules when they are point
//! values.
//!
//! On a periodic axis the centroid is computed from displacements relative to the cell where
//! `phi` is largest (the first such cell in storage order), wrapped into `[-L/2, L/2)`, and the
//! result is mapped back into the box: a capsule straddling the periodic boundary gets its true
//! centroid as long as it spans less than half the period (see the [module docs](super)).

use super::reduce::{check_field, finite_or, frames, reduce_cells, sum_cells};
use crate::grid::{Field, Grid};
use crate::{Error, Real, Result};

/// Volume `V = sum phi_ijk dx dy dz` of the region where `phi = 1`, over the interior cells.
///
/// Errors: `phi` not on `grid`; a non-finite value in `phi`.
pub fn volume<T: Real>(grid: &Grid<T>, phi: &Field<T>) -> Result<f64> {
    check_field(grid, "phi", phi)?;
    let [s] = sum_cells(grid, |idx, _| [phi.data[idx].f64()]);
    let [s] = finite_or([s], grid, &[("phi", phi)])?;
    Ok(s * grid.cell_volume().f64())
}

/// Centroid (3.5) `x_c = sum phi x dV / sum phi dV`, unwrapped across periodic boundaries
/// (see the module docs) and returned inside the box.
///
/// Errors: `phi` not on `grid`; a non-finite value; a field whose sum is not positive (no
/// capsule).
pub fn centroid<T: Real>(grid: &Grid<T>, phi: &Field<T>) -> Result<[f64; 3]> {
    check_field(grid, "phi", phi)?;
    let n = grid.n();
    // Reference point: the centre of the first cell of largest phi (ties keep the earlier cell,
    // within and across blocks, so the choice does not depend on the thread count).
    let (max, at) = reduce_cells(
        grid,
        (f64::NEG_INFINITY, [0usize; 3]),
        |acc: &mut (f64, [usize; 3]), idx, ijk| {
            let x = phi.data[idx].f64();
            if x > acc.0 {
                *acc = (x, ijk);
            }
        },
        |acc, b| {
            if b.0 > acc.0 {
                *acc = *b;
            }
        },
    );
    if !max.is_finite() {
        return Err(super::reduce::non_finite(grid, &[("phi", phi)]));
    }
    let r = grid.cell_center(at[0] as isize, at[1] as isize, at[2] as isize).map(|x| x.f64());
    let fr = frames(grid, r);
    let off: [Vec<f64>; 3] = std::array::from_fn(|d| fr[d].cells(n[d]));
    let sums = sum_cells(grid, |idx, [i, j, k]| {
        let p = phi.data[idx].f64();
        [p, p * off[0][i], p * off[1][j], p * off[2][k]]
    });
    let [m, sx, sy, sz] = finite_or(sums, grid, &[("phi", phi)])?;
    if m <= 0.0 {
        return Err(Error::invalid("phi", format!("sum {m:e}"), "a field with a positive sum (a capsule)"));
    }
    let s = [sx, sy, sz];
    Ok(std::array::from_fn(|d| fr[d].absolute(s[d] / m)))
}
