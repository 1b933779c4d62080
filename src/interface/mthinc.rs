//! MTHINC reconstruction of one cell, equations (2.42)-(2.43), and the face averages of the
//! flux (2.48).
//!
//! In cell `ijk`, the indicator `H` is approximated by a hyperbolic tangent of a plane,
//!
//! ```text
//! H_ijk(x) = (1 + tanh(beta' (n . x + d))) / 2,    beta' = beta / h,          (2.42)
//! phi_ijk  = (1 / |dV|) int_{dV_ijk} H_ijk dV                                 (2.43)
//! ```
//!
//! with `n` the unit normal from `phi` (a [`NormalScheme`](super::NormalScheme)) and the offset
//! `d` fixed by the volume constraint (2.43). In cell-local coordinates `xi` in
//! `[-1/2, 1/2]^3` (`x = x_c + h * xi` per axis) the argument is `y = a . xi + D` with
//! `a_k = beta' n_k h_k` and `D = beta' (n . x_c + d)`; `H = sigma(2 y)` with the logistic
//! `sigma(t) = 1 / (1 + exp(-t))`. [`Reconstruction`] stores `a` and `D`.
//!
//! # Solving the volume constraint
//!
//! `F(D) = <sigma(2 (a . xi + D))>_cell` increases strictly from 0 to 1, with
//! `F'(D) = <2 sigma (1 - sigma)>_cell > 0`, and is bracketed by
//! `atanh(2 phi - 1) -+ sum_k |a_k| / 2`. It is solved by Newton's method safeguarded by
//! bisection inside that bracket, started from `atanh(2 phi - 1)` (exact for a flat profile).
//! The cell average is computed ([`CellQuadrature`]) either exactly along the axis of the
//! largest `|a_k|` (the antiderivative of `sigma(2 y)` is `softplus(2 y) / 2`) with 2-point
//! Gauss-Legendre in the other axes (the default, after the original MTHINC), or with the
//! 2 x 2 x 2 Gauss rule the paper uses for (2.46). Everything is written with
//! `exp(-|t|)`, `ln_1p` and the symmetric form of `sigma`, so no cancellation occurs in either
//! tail and no NaN or infinity can arise for finite input.
//!
//! A cell with `phi <= tiny`, `phi >= 1 - tiny` or a vanishing gradient is *uniform*: its
//! reconstruction is the constant `phi` (and `kappa_R tilde`), so its face values equal its
//! cell values.
//!
//! # Face averages (2.48)
//!
//! The flux through a face is `v_face * Hbar`, with `Hbar` the average over the face of the
//! reconstruction of the upwind cell, by the 2 x 2 Gauss rule (four points).

use crate::Real;

/// How cell averages of the profile are computed in the constraints (2.43) and (2.46).
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CellQuadrature {
    /// Exact integration along the axis of the largest normal component, 2-point Gauss in the
    /// other axes (4 points in 3D, 2 in 2D). The default.
    #[default]
    ExactAlongNormal,
    /// The 2 x 2 x 2 Gauss-Legendre rule of the paper's (2.46) (8 points in 3D, 4 in 2D).
    Gauss2,
}

/// Half the offset of the 2-point Gauss-Legendre nodes on `[-1/2, 1/2]`: `1 / (2 sqrt 3)`.
#[inline(always)]
pub(crate) fn gauss_half<T: Real>() -> T {
    T::lit(0.5 / 3f64.sqrt())
}

/// `(sigma(t), sigma(t) (1 - sigma(t)), ln(1 + exp(-|t|)))` from one exponential, accurate in
/// both tails.
#[inline(always)]
pub(crate) fn logistic<T: Real>(t: T) -> (T, T, T) {
    let e = (-t.abs()).exp();
    let p = T::one() / (T::one() + e);
    let s = if t >= T::zero() { p } else { e * p };
    (s, e * p * p, e.ln_1p())
}

/// The profile `sigma(2 y)` and `2 sigma (1 - sigma)` at one point.
#[inline(always)]
fn point<T: Real>(y: T) -> (T, T) {
    let (s, ss, _) = logistic(y + y);
    (s, ss + ss)
}

/// The MTHINC reconstruction of one cell (see the [module docs](self)).
///
/// For a cell with a profile, `a = beta' n h` (per axis) is non-zero; a *uniform* cell has
/// `a = 0` and carries its cell values.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Reconstruction<T> {
    /// `beta' n_k h_k` per axis; all zero for a uniform cell.
    pub(crate) a: [T; 3],
    /// The offset `D = beta' (n . x_c + d)`, or the cell value of `phi` for a uniform cell.
    pub(crate) d: T,
    /// The coefficient of the convolved profile (2.47) divided by `beta'`, or the cell value of
    /// `kappa_R tilde` for a uniform cell (see [`super::convolved`]).
    pub(crate) c: T,
}

/// What a reconstruction solve reports besides the offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetSolve<T> {
    /// The offset `D` of the profile in cell units (`y = a . xi + D`).
    pub offset: T,
    /// The cell average of `2 sigma (1 - sigma)` at the solution, `= F'(D)`: the cell average
    /// of `|grad H| / beta'`, needed by the convolved profile (2.47).
    pub mean_slope: T,
    /// Newton/bisection iterations used.
    pub iterations: u32,
}

impl<T: Real> Reconstruction<T> {
    /// A uniform cell with values `phi` and `kappa_tilde`.
    #[inline(always)]
    pub fn uniform(phi: T, kappa_tilde: T) -> Self {
        Reconstruction {
            a: [T::zero(); 3],
            d: phi,
            c: kappa_tilde,
        }
    }

    /// Whether the cell is uniform (no profile).
    #[inline(always)]
    pub fn is_uniform(&self) -> bool {
        self.a[0] == T::zero() && self.a[1] == T::zero() && self.a[2] == T::zero()
    }

    /// The slope vector `a = beta' n h` (zero for a uniform cell).
    #[inline(always)]
    pub fn slope(&self) -> [T; 3] {
        self.a
    }

    /// The offset `D` (for a uniform cell, its `phi`).
    #[inline(always)]
    pub fn offset(&self) -> T {
        self.d
    }

    /// The unit normal `n` recovered from `a` and the spacing `h` (`None` for a uniform cell).
    #[inline]
    pub fn normal(&self, h: [T; 3]) -> Option<[T; 3]> {
        if self.is_uniform() {
            return None;
        }
        let m = [self.a[0] / h[0], self.a[1] / h[1], self.a[2] / h[2]];
        let s = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        Some([m[0] / s, m[1] / s, m[2] / s])
    }

    /// Reconstructs a cell from its value `phi`, unit normal `normal` (into the capsule) and
    /// `scale = beta' h` per axis. Returns a uniform cell when `phi` is within `tiny` of 0 or 1
    /// or not finite, or when the normal is not finite. Never panics.
    pub fn new(
        phi: T,
        normal: [T; 3],
        scale: [T; 3],
        tiny: T,
        quadrature: CellQuadrature,
    ) -> (Self, Option<OffsetSolve<T>>) {
        let a = [
            normal[0] * scale[0],
            normal[1] * scale[1],
            normal[2] * scale[2],
        ];
        match solve_offset(a, phi, tiny, quadrature) {
            Some(s) => (
                Reconstruction {
                    a,
                    d: s.offset,
                    c: T::zero(),
                },
                Some(s),
            ),
            None => (Reconstruction::uniform(phi, T::zero()), None),
        }
    }

    /// The average of the reconstructed `H` over the face of the cell normal to `axis`, on the
    /// upper side (`upper = true`, `xi_axis = +1/2`) or the lower side, by the 2 x 2 Gauss rule:
    /// the `Hbar` of (2.48). For a uniform cell, its `phi`.
    #[inline(always)]
    pub fn face_average(&self, axis: usize, upper: bool) -> T {
        self.face_averages(axis, upper).0
    }

    /// `(Hbar, <2 sigma (1 - sigma)>_face)` on a face: the profile and its slope share the
    /// exponentials. For a uniform cell, `(phi, 0)`.
    #[inline(always)]
    pub(crate) fn face_averages(&self, axis: usize, upper: bool) -> (T, T) {
        if self.is_uniform() {
            return (self.d, T::zero());
        }
        let half = T::lit(0.5);
        let y0 = if upper {
            self.d + half * self.a[axis]
        } else {
            self.d - half * self.a[axis]
        };
        let g = gauss_half::<T>();
        let (t1, t2) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let p = g * self.a[t1];
        let q = g * self.a[t2];
        if q == T::zero() {
            if p == T::zero() {
                return point(y0);
            }
            let (h1, s1) = point(y0 + p);
            let (h2, s2) = point(y0 - p);
            return (half * (h1 + h2), half * (s1 + s2));
        }
        let quarter = T::lit(0.25);
        let (h1, s1) = point(y0 + p + q);
        let (h2, s2) = point(y0 + p - q);
        let (h3, s3) = point(y0 - p + q);
        let (h4, s4) = point(y0 - p - q);
        (quarter * (h1 + h2 + h3 + h4), quarter * (s1 + s2 + s3 + s4))
    }
}

/// Cell average `F(D)` of `sigma(2 (a . xi + D))` and its derivative `F'(D)`.
struct CellAverage<T> {
    /// Axis integrated exactly (largest `|a_k|`), or 3 for full Gauss.
    exact_axis: usize,
    /// `|a|` along the exact axis.
    am: T,
    /// Offsets of the transverse (or all) Gauss points, `sum_k a_k xi_k`.
    offsets: [T; 8],
    count: usize,
}

impl<T: Real> CellAverage<T> {
    fn new(a: [T; 3], quadrature: CellQuadrature) -> Self {
        let g = gauss_half::<T>();
        let mut m = 0;
        for k in 1..3 {
            if a[k].abs() > a[m].abs() {
                m = k;
            }
        }
        let am = a[m].abs();
        // Exact integration along m when the profile varies enough along it for the
        // difference of softplus values to be accurate.
        let exact = quadrature == CellQuadrature::ExactAlongNormal && am > T::lit(1e-3);
        let axes: [usize; 3] = [0, 1, 2];
        let mut offsets = [T::zero(); 8];
        let mut count = 1;
        for &k in axes.iter().filter(|&&k| !(exact && k == m)) {
            if a[k] == T::zero() {
                continue;
            }
            let dk = g * a[k];
            for j in 0..count {
                offsets[j + count] = offsets[j] - dk;
                offsets[j] += dk;
            }
            count *= 2;
        }
        CellAverage {
            exact_axis: if exact { m } else { 3 },
            am,
            offsets,
            count,
        }
    }

    /// `(F(D), F'(D))`.
    #[inline(always)]
    fn eval(&self, d: T) -> (T, T) {
        let mut f = T::zero();
        let mut fp = T::zero();
        if self.exact_axis < 3 {
            // int_{-1/2}^{1/2} sigma(2 (am xi + z)) dxi
            //   = (softplus(2 z + am) - softplus(2 z - am)) / (2 am)
            let am = self.am;
            for &o in &self.offsets[..self.count] {
                let z2 = (o + d) * T::lit(2.0);
                let (sp, _, lp) = logistic(z2 + am);
                let (sm, _, lm) = logistic(z2 - am);
                let hi = (z2 + am).max(T::zero()) + lp;
                let lo = (z2 - am).max(T::zero()) + lm;
                f += hi - lo;
                fp += sp - sm;
            }
            let w = T::one() / (T::from_usize(self.count).unwrap_or(T::one()) * am);
            (f * w * T::lit(0.5), fp * w)
        } else {
            for &o in &self.offsets[..self.count] {
                let (h, s) = point(o + d);
                f += h;
                fp += s;
            }
            let w = T::one() / T::from_usize(self.count).unwrap_or(T::one());
            (f * w, fp * w)
        }
    }
}

/// Solves the volume constraint (2.43) for the offset `D` of a cell with slopes `a`
/// (`beta' n_k h_k`) and value `phi`: `<sigma(2 (a . xi + D))>_cell = phi`.
///
/// Returns `None` (the cell is uniform) when `phi` is not in `(tiny, 1 - tiny)`, when `a` is
/// not finite, or when `a` vanishes. Never NaN: the iterate stays inside a finite bracket.
pub fn solve_offset<T: Real>(
    a: [T; 3],
    phi: T,
    tiny: T,
    quadrature: CellQuadrature,
) -> Option<OffsetSolve<T>> {
    if !(phi > tiny && phi < T::one() - tiny) {
        return None;
    }
    let asum = a[0].abs() + a[1].abs() + a[2].abs();
    if !(asum.is_finite() && asum > T::lit(1e-6)) {
        return None;
    }
    let avg = CellAverage::new(a, quadrature);
    // The rules are symmetric, so 1 - F(D) = F(-D): solve for the smaller of phi and 1 - phi,
    // where F is computed with full relative accuracy (1 - phi is exact for phi >= 1/2).
    let flip = phi > T::lit(0.5);
    let phi = if flip { T::one() - phi } else { phi };
    let d0 = T::lit(0.5) * (phi / (T::one() - phi)).ln();
    let half = T::lit(0.5) * asum;
    let mut lo = d0 - half;
    let mut hi = d0 + half;
    let mut d = d0;
    let tol = T::lit(4.0) * T::eps();
    let mut slope = T::zero();
    let mut it = 0;
    while it < 60 {
        it += 1;
        let (f, fp) = avg.eval(d);
        slope = fp;
        let r = f - phi;
        if r == T::zero() {
            break;
        }
        if r > T::zero() {
            hi = d;
        } else {
            lo = d;
        }
        let step = r / fp;
        let scale = tol * (T::one() + d.abs());
        if step.abs() <= scale {
            // Converged: the Newton correction is below the resolution of D.
            d -= step;
            break;
        }
        let mut next = d - step;
        if !(next > lo && next < hi) {
            next = T::lit(0.5) * (lo + hi);
        }
        d = next;
        if hi - lo <= scale {
            break;
        }
    }
    Some(OffsetSolve {
        offset: if flip { -d } else { d },
        mean_slope: slope,
        iterations: it,
    })
}

/// The cell average of `H = sigma(2 (a . xi + D))` by the given quadrature (for checks).
pub fn cell_average<T: Real>(a: [T; 3], offset: T, quadrature: CellQuadrature) -> T {
    CellAverage::new(a, quadrature).eval(offset).0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve_reproduces_phi() {
        let n = [0.6f64, -0.48, 0.64];
        for q in [CellQuadrature::ExactAlongNormal, CellQuadrature::Gauss2] {
            for &phi in &[1e-6, 0.01, 0.3, 0.5, 0.77, 0.999, 1.0 - 1e-6] {
                let (r, s) = Reconstruction::new(phi, n, [1.0; 3], 1e-8, q);
                let s = s.unwrap();
                let f = cell_average(r.a, r.d, q);
                assert!((f - phi).abs() < 1e-14, "{phi} {f} {}", s.iterations);
                assert!(s.iterations < 12, "{}", s.iterations);
            }
        }
    }

    #[test]
    fn uniform_cells() {
        for phi in [0.0f64, 1.0, 1e-12, f64::NAN] {
            let (r, s) =
                Reconstruction::new(phi, [1.0, 0.0, 0.0], [1.0; 3], 1e-8, Default::default());
            assert!(s.is_none() && r.is_uniform());
        }
        let (r, s) = Reconstruction::new(0.4f64, [0.0; 3], [1.0; 3], 1e-8, Default::default());
        assert!(s.is_none() && r.face_average(0, true) == 0.4);
    }

    #[test]
    fn exact_and_gauss_agree_for_a_smooth_profile() {
        let a = [0.8f64, 0.5, 0.2];
        let e = cell_average(a, 0.3, CellQuadrature::ExactAlongNormal);
        let g = cell_average(a, 0.3, CellQuadrature::Gauss2);
        assert!((e - g).abs() < 1e-3, "{e} {g}");
        // 1D check against the closed form.
        let a1 = [1.0f64, 0.0, 0.0];
        let e1 = cell_average(a1, 0.3, CellQuadrature::ExactAlongNormal);
        let sp = |t: f64| (1.0 + t.exp()).ln();
        let exact = (sp(2.0 * 0.3 + 1.0) - sp(2.0 * 0.3 - 1.0)) / 2.0;
        assert!((e1 - exact).abs() < 1e-15);
    }

    #[test]
    fn face_average_of_a_flat_normal_profile() {
        // Along x only: face value is sigma(2 (D +- a/2)).
        let r = Reconstruction {
            a: [1.0f64, 0.0, 0.0],
            d: 0.2,
            c: 0.0,
        };
        let s = |t: f64| 1.0 / (1.0 + (-t).exp());
        assert!((r.face_average(0, true) - s(2.0 * 0.7)).abs() < 1e-15);
        assert!((r.face_average(0, false) - s(2.0 * -0.3)).abs() < 1e-15);
        let g = 0.5 / 3f64.sqrt();
        let y = 0.5 * (s(2.0 * (0.2 + g)) + s(2.0 * (0.2 - g)));
        assert!((r.face_average(1, true) - y).abs() < 1e-15);
    }
}
