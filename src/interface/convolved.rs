//! Advection of the convolved reference curvature `kappa_R tilde = delta kappa_R`,
//! equations (2.44)-(2.47) and the stretching term of (2.23)/(2.30).
//!
//! ```text
//! d kt/dt + div(v G) = kt div v - kt n . grad v . n        (2.44), (2.23)
//! G_ijk(x) = c_ijk |grad H_ijk(x)|
//!          = c_ijk (beta'/2) (1 - tanh^2(beta' (n . x + d)))   (2.45)
//! kt_ijk   = (1 / |dV|) int_{dV_ijk} G_ijk dV                     (2.46)
//! ```
//!
//! `kt` is carried with the profile of the interface itself: `G` has the shape of `|grad H|` of
//! the MTHINC reconstruction of `phi` in the same cell (same `n`, same `d`, computed once per
//! step for both fields), scaled by `c` so that its cell average is the cell value of `kt`
//! (2.47). In cell units `|grad H| = beta' * 2 sigma(2y) (1 - sigma(2y))`, so
//! `c beta' = kt / <2 sigma (1 - sigma)>_cell`, and the latter is exactly the derivative `F'(D)`
//! of the volume constraint that [`solve_offset`](super::mthinc::solve_offset) returns as
//! `mean_slope` (same quadrature, see [`CellQuadrature`](super::mthinc::CellQuadrature)): no extra
//! transcendental evaluation is needed. The face value in the flux is the 2 x 2 Gauss average of
//! `G` over the face of the upwind cell, computed together with `Hbar` from the same
//! exponentials.
//!
//! The stretching source `-kt n . grad v . n` (the change of `delta` as the surface stretches,
//! (2.27)) is evaluated at cell centres with the reconstruction normal and
//! [`grad_v_at_cell`](crate::grid::ops::grad_v_at_cell); it is applied in cells that have a
//! profile and vanishes in uniform cells, where `kt` is negligible.

use super::mthinc::{OffsetSolve, Reconstruction};
use crate::Real;
use crate::tensor::Mat3;

impl<T: Real> Reconstruction<T> {
    /// Attaches the convolved curvature `kappa_tilde` of the cell to a reconstruction: the
    /// coefficient (2.47) for a cell with a profile (using `solve.mean_slope`), or the cell value
    /// for a uniform cell. A vanishing mean slope (cannot happen for `phi` in `(tiny, 1 - tiny)`)
    /// makes `c = 0`.
    #[inline(always)]
    pub fn with_curvature(mut self, kappa_tilde: T, solve: Option<&OffsetSolve<T>>) -> Self {
        self.c = match solve {
            Some(s) if !self.is_uniform() => {
                if s.mean_slope > T::zero() && kappa_tilde.is_finite() {
                    kappa_tilde / s.mean_slope
                } else {
                    T::zero()
                }
            }
            _ => kappa_tilde,
        };
        self
    }

    /// The face average `Gbar` of the convolved profile on a face (the `kt` counterpart of
    /// [`Reconstruction::face_average`]); for a uniform cell, its `kappa_R tilde`.
    #[inline(always)]
    pub fn face_profile_average(&self, axis: usize, upper: bool) -> T {
        if self.is_uniform() {
            return self.c;
        }
        self.c * self.face_averages(axis, upper).1
    }

    /// `(Hbar, Gbar)` on a face, sharing the exponentials.
    #[inline(always)]
    pub(crate) fn face_pair(&self, axis: usize, upper: bool) -> (T, T) {
        if self.is_uniform() {
            return (self.d, self.c);
        }
        let (h, s) = self.face_averages(axis, upper);
        (h, self.c * s)
    }
}

/// The normal stretching rate `n . grad v . n` with `g[i][j] = d v_j / d x_i` (as returned by
/// [`grad_v_at_cell`](crate::grid::ops::grad_v_at_cell)).
#[inline(always)]
pub fn normal_stretching<T: Real>(n: &[T; 3], g: &Mat3<T>) -> T {
    let mut s = T::zero();
    for i in 0..3 {
        for j in 0..3 {
            s += n[i] * g[i][j] * n[j];
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::super::mthinc::CellQuadrature;
    use super::*;

    #[test]
    fn profile_reproduces_cell_value() {
        // For a profile along x only, the face averages of G are exact point values and the
        // cell average of the profile is kt.
        let n = [1.0f64, 0.0, 0.0];
        let (r, s) = Reconstruction::new(0.3, n, [1.0; 3], 1e-8, CellQuadrature::ExactAlongNormal);
        let r = r.with_curvature(2.5, s.as_ref());
        // Integrate G across the cell numerically along x.
        let m = 2000;
        let mut sum = 0.0;
        for k in 0..m {
            let xi = -0.5 + (k as f64 + 0.5) / m as f64;
            let y: f64 = r.a[0] * xi + r.d;
            let sg = 1.0 / (1.0 + (-2.0 * y).exp());
            sum += r.c * 2.0 * sg * (1.0 - sg);
        }
        assert!((sum / m as f64 - 2.5).abs() < 1e-6);
        let u = Reconstruction::uniform(0.0f64, 0.25).with_curvature(0.25, None);
        assert_eq!(u.face_profile_average(1, true), 0.25);
    }

    #[test]
    fn stretching_of_a_shear() {
        let g = [[0.0f64, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
        let n = [1.0 / 2f64.sqrt(), 1.0 / 2f64.sqrt(), 0.0];
        assert!((normal_stretching(&n, &g) - 0.5).abs() < 1e-15);
    }
}
