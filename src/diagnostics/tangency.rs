//! How far the surface deformation tensor `G_s` has left the tangent plane of the membrane.
//!
//! In the continuum `G_s = F_s F_s^T` is a surface tensor: `G_s n = 0` and `tr G_s` is the sum
//! of the squared principal stretches, 2 at rest (Sec. 2.1). The discrete transport (2.40) keeps
//! neither exactly; its normal part `G_s n` is what the projection `GsTransport::Tangential`
//! removes each step (see [`crate::membrane::strain`]). This module measures it over the
//! membrane band, the cells where `delta h >= epsilon` (the band criterion of Sec. 2.2.2, with
//! `h` the largest spacing among the axes that have more than one cell):
//!
//! ```text
//! max |G_s n|                                   largest normal part, and its cell
//! <|G_s n|> = sum delta |G_s n| / sum delta     its mean over the membrane
//! max tr G_s                                    largest area stretch lambda_1^2 + lambda_2^2
//! ```
//!
//! `n` is normalised in each cell; a band cell with a zero normal is skipped. A growing
//! `max |G_s n|` is an early warning: in the two red cells of `cases/examples/rbc_channel.rs` it ran away
//! on the rim next to the walls before the paper's transport failed (docs/validation/red_cells.md).

use super::reduce::{check_field, reduce_cells};
use crate::grid::{Field, Grid, SymField};
use crate::membrane::band::band_spacing;
use crate::tensor::{Sym, dot, sym_mul_vec, trace};
use crate::{Error, Real, Result};

/// The normal part of `G_s` over the membrane band (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GsTangency {
    /// `max |G_s n|` over the band cells.
    pub max_normal: f64,
    /// Interior cell `[i, j, k]` where `max_normal` is reached (the first in storage order).
    pub max_normal_at: [usize; 3],
    /// `sum delta |G_s n| / sum delta` over the band cells.
    pub mean_normal: f64,
    /// `max tr G_s` over the band cells.
    pub max_trace: f64,
    /// Interior cell `[i, j, k]` where `max_trace` is reached (the first in storage order).
    pub max_trace_at: [usize; 3],
    /// Number of band cells measured.
    pub cells: usize,
}

#[derive(Clone)]
struct Acc {
    max_n: (f64, [usize; 3]),
    max_tr: (f64, [usize; 3]),
    sum_dn: f64,
    sum_d: f64,
    cells: usize,
    bad: Option<(&'static str, [usize; 3])>,
}

/// Measures `G_s n` and `tr G_s` over the cells where `delta h >= epsilon`.
///
/// `delta` is the smoothed delta function, `normal` the three components of the membrane normal
/// (any length; normalised here), `gs` the tensor `G_s`, all at cell centres.
///
/// # Errors
/// - [`Error::InvalidParameter`] naming `epsilon` unless `0 < epsilon < 1`, a field not on
///   `grid`, or `delta` when no cell passes the band criterion;
/// - [`Error::NonFinite`] naming `delta` at the first cell (storage order) where it is not
///   finite, or `G_s` at the first band cell where a value is not finite.
pub fn gs_tangency<T: Real>(
    grid: &Grid<T>,
    delta: &Field<T>,
    normal: &[Field<T>; 3],
    gs: &SymField<T>,
    epsilon: f64,
) -> Result<GsTangency> {
    if !(epsilon > 0.0 && epsilon < 1.0) {
        return Err(Error::invalid("epsilon", epsilon, "a number in (0, 1), e.g. 0.01 as the band"));
    }
    check_field(grid, "delta", delta)?;
    for c in normal {
        check_field(grid, "normal", c)?;
    }
    for c in &gs.c {
        check_field(grid, "G_s", c)?;
    }
    let h = band_spacing(grid).f64();
    let zero = Acc {
        max_n: (f64::NEG_INFINITY, [0; 3]),
        max_tr: (f64::NEG_INFINITY, [0; 3]),
        sum_dn: 0.0,
        sum_d: 0.0,
        cells: 0,
        bad: None,
    };
    let acc = reduce_cells(
        grid,
        zero,
        |acc: &mut Acc, idx, ijk| {
            let d = delta.data[idx].f64();
            if !d.is_finite() {
                acc.bad.get_or_insert(("delta", ijk));
                return;
            }
            if d * h < epsilon {
                return;
            }
            let nv = [normal[0].data[idx].f64(), normal[1].data[idx].f64(), normal[2].data[idx].f64()];
            let len = dot(&nv, &nv).sqrt();
            if len == 0.0 {
                return;
            }
            let g: Sym<f64> = gs.get(idx).map(|x| x.f64());
            let gn = sym_mul_vec(&g, &nv.map(|x| x / len));
            let m = dot(&gn, &gn).sqrt();
            let tr = trace(&g);
            if !(m.is_finite() && tr.is_finite()) {
                acc.bad.get_or_insert(("G_s", ijk));
                return;
            }
            if m > acc.max_n.0 {
                acc.max_n = (m, ijk);
            }
            if tr > acc.max_tr.0 {
                acc.max_tr = (tr, ijk);
            }
            acc.sum_dn += d * m;
            acc.sum_d += d;
            acc.cells += 1;
        },
        |acc, b| {
            if acc.bad.is_none() {
                acc.bad = b.bad;
            }
            if b.max_n.0 > acc.max_n.0 {
                acc.max_n = b.max_n;
            }
            if b.max_tr.0 > acc.max_tr.0 {
                acc.max_tr = b.max_tr;
            }
            acc.sum_dn += b.sum_dn;
            acc.sum_d += b.sum_d;
            acc.cells += b.cells;
        },
    );
    if let Some((field, cell)) = acc.bad {
        return Err(Error::NonFinite { field, cell });
    }
    if acc.cells == 0 {
        return Err(Error::invalid(
            "delta",
            format!("no cell with delta h >= {epsilon} and a non-zero normal"),
            "a field holding a membrane",
        ));
    }
    Ok(GsTangency {
        max_normal: acc.max_n.0,
        max_normal_at: acc.max_n.1,
        mean_normal: acc.sum_dn / acc.sum_d,
        max_trace: acc.max_tr.0,
        max_trace_at: acc.max_tr.1,
        cells: acc.cells,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensor::{XX, XY, projector};

    /// A spherical shell of cells with radial normals, `delta = 2/h` in it and zero elsewhere.
    fn shell(n: usize) -> (Grid<f64>, Field<f64>, [Field<f64>; 3]) {
        let g = Grid::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
        let h = 1.0 / n as f64;
        let r = |x: [f64; 3]| ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
        let delta = Field::from_cell_fn(&g, |x| if (r(x) - 0.3).abs() < h { 2.0 / h } else { 0.0 });
        let normal = std::array::from_fn(|d| Field::from_cell_fn(&g, |x| 3.0 * (x[d] - 0.5) / r(x)));
        (g, delta, normal)
    }

    #[test]
    fn the_projector_has_no_normal_part_and_trace_two() {
        let (g, delta, normal) = shell(16);
        let mut gs = SymField::zeros(&g);
        for (i, j, k) in g.cells().collect::<Vec<_>>() {
            let idx = g.idx_u(i, j, k);
            let nv = std::array::from_fn(|d| normal[d].data[idx] / 3.0);
            gs.set(idx, &projector(&nv));
        }
        let t = gs_tangency(&g, &delta, &normal, &gs, 0.01).unwrap();
        assert!(t.cells > 100);
        assert!(t.max_normal < 1e-15, "{}", t.max_normal);
        assert!((t.max_trace - 2.0).abs() < 1e-14);
    }

    #[test]
    fn a_normal_stretch_is_measured_where_it_is() {
        // G_s = P + c n n: G_s n = c n, tr G_s = 2 + c; one cell gets c = 0.5, the rest 0.1.
        let (g, delta, normal) = shell(16);
        let mut gs = SymField::zeros(&g);
        let mut hot = None;
        for (i, j, k) in g.cells().collect::<Vec<_>>() {
            let idx = g.idx_u(i, j, k);
            let nv: [f64; 3] = std::array::from_fn(|d| normal[d].data[idx] / 3.0);
            let c = if delta.data[idx] > 0.0 && hot.is_none() {
                hot = Some([i, j, k]);
                0.5
            } else {
                0.1
            };
            let mut a = projector(&nv);
            let nn =
                crate::tensor::mat_to_sym(&std::array::from_fn(|p| std::array::from_fn(|q| nv[p] * nv[q])));
            for (x, y) in a.iter_mut().zip(nn) {
                *x += c * y;
            }
            gs.set(idx, &a);
        }
        let t = gs_tangency(&g, &delta, &normal, &gs, 0.01).unwrap();
        assert!((t.max_normal - 0.5).abs() < 1e-14);
        assert_eq!(t.max_normal_at, hot.unwrap());
        assert!((t.max_trace - 2.5).abs() < 1e-14);
        let mean = (0.5 + 0.1 * (t.cells - 1) as f64) / t.cells as f64;
        assert!((t.mean_normal - mean).abs() < 1e-14, "{} {}", t.mean_normal, mean);
    }

    #[test]
    fn bad_input_is_named() {
        let (g, delta, normal) = shell(8);
        let mut gs = SymField::zeros(&g);
        assert!(matches!(
            gs_tangency(&g, &delta, &normal, &gs, 0.0),
            Err(Error::InvalidParameter { name: "epsilon", .. })
        ));
        let empty = Field::zeros(&g);
        assert!(matches!(
            gs_tangency(&g, &empty, &normal, &gs, 0.01),
            Err(Error::InvalidParameter { name: "delta", .. })
        ));
        let idx = (0..g.len()).find(|&i| delta.data[i] > 0.0).unwrap();
        gs.c[XX].data[idx] = f64::NAN;
        gs.c[XY].data[idx] = 1.0;
        assert!(matches!(
            gs_tangency(&g, &delta, &normal, &gs, 0.01),
            Err(Error::NonFinite { field: "G_s", .. })
        ));
    }
}
