//! Mean velocity profiles across a channel (Fig. 17):
//!
//! ```text
//! <u>(y) = (1 / N_x) sum_i u(x_i, y, z)               (at one spanwise position z), or
//! <u>(y) = (1 / (N_x N_z)) sum_i sum_k u(x_i, y, z_k)  (averaged over the span as well)
//! ```
//!
//! `u` is the streamwise velocity component on its faces (cell-centred in the two other
//! directions); values between cell centres in the wall-normal (and spanwise) direction are
//! interpolated linearly, using the ghost layer next to a wall, whose filled value makes the
//! interpolant equal the wall velocity on the wall ([`VectorField::fill_ghosts`]): ghosts must be
//! filled. Along a periodic streamwise axis the faces `0..n` are averaged; along a wall axis the
//! faces `0..=n`.

use super::reduce::{check_vector, non_finite};
use crate::grid::{Grid, VectorField};
use crate::{Error, Real, Result};

/// Which axes a profile uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProfileAxes {
    /// The streamwise axis (the averaged component and the first averaging direction).
    pub streamwise: usize,
    /// The wall-normal axis (where the profile is sampled).
    pub wall_normal: usize,
}

impl Default for ProfileAxes {
    /// Flow along x, walls normal to y (the channel of Sec. 3.4).
    fn default() -> Self {
        ProfileAxes { streamwise: 0, wall_normal: 1 }
    }
}

/// What to do along the third (spanwise) axis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Span {
    /// Average over all spanwise cells.
    #[default]
    Average,
    /// Sample at this spanwise coordinate (linear interpolation between cell centres).
    At(f64),
}

/// Linear interpolation stencil of a coordinate between cell centres of an axis: `(j0, w)` such
/// that the value is `(1 - w) f[j0] + w f[j0 + 1]`, with `j0` in `-1..n` (ghosts at both ends).
fn stencil<T: Real>(grid: &Grid<T>, axis: usize, name: &'static str, x: f64) -> Result<(isize, f64)> {
    let (lo, hi) = (grid.lower()[axis].f64(), grid.upper()[axis].f64());
    if !(x.is_finite() && x >= lo && x <= hi) {
        return Err(Error::invalid(name, x, "a coordinate inside the box along that axis"));
    }
    let n = grid.n()[axis];
    if n == 1 {
        return Ok((0, 0.0));
    }
    let t = (x - lo) / grid.h()[axis].f64() - 0.5;
    let j0 = (t.floor() as isize).clamp(-1, n as isize - 1);
    Ok((j0, t - j0 as f64))
}

/// The mean streamwise velocity at the wall-normal coordinates `positions`, averaged over the
/// streamwise direction and, with [`Span::Average`], over the span (see the
/// [module docs](self)).
///
/// Errors: `v` not on `grid`; equal or out-of-range axes; a position outside the box; a
/// non-finite value.
pub fn streamwise_profile<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    axes: ProfileAxes,
    positions: &[f64],
    span: Span,
) -> Result<Vec<f64>> {
    check_vector(grid, "v", v)?;
    let (s, w) = (axes.streamwise, axes.wall_normal);
    if s > 2 || w > 2 || s == w {
        return Err(Error::invalid(
            "axes",
            format!("streamwise {s}, wall_normal {w}"),
            "two different axes among 0, 1, 2",
        ));
    }
    let z = 3 - s - w;
    let n = grid.n();
    let faces = if grid.is_periodic(s) { n[s] } else { n[s] + 1 };
    let spans: Vec<(isize, f64)> = match span {
        Span::Average => (0..n[z] as isize).map(|k| (k, 0.0)).collect(),
        Span::At(x) => vec![stencil(grid, z, "span", x)?],
    };
    let u = &v.c[s];
    let mut out = Vec::with_capacity(positions.len());
    for &y in positions {
        let (j0, wy) = stencil(grid, w, "positions", y)?;
        let mut sum = 0.0;
        for &(k0, wz) in &spans {
            for i in 0..faces as isize {
                let at = |j: isize, k: isize| {
                    let mut c = [0isize; 3];
                    c[s] = i;
                    c[w] = j;
                    c[z] = k;
                    u.at(grid, c[0], c[1], c[2]).f64()
                };
                let lo = (1.0 - wy) * at(j0, k0) + if wy != 0.0 { wy * at(j0 + 1, k0) } else { 0.0 };
                let val = if wz != 0.0 {
                    let hi =
                        (1.0 - wy) * at(j0, k0 + 1) + if wy != 0.0 { wy * at(j0 + 1, k0 + 1) } else { 0.0 };
                    (1.0 - wz) * lo + wz * hi
                } else {
                    lo
                };
                sum += val;
            }
        }
        let mean = sum / (faces * spans.len()) as f64;
        if !mean.is_finite() {
            return Err(non_finite(grid, &[("v.u", &v.c[0]), ("v.v", &v.c[1]), ("v.w", &v.c[2])]));
        }
        out.push(mean);
    }
    Ok(out)
}
