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
//! with `n` the unit normal from `phi` (a [`NormalScheme`](super::geometry::NormalScheme)) and the offset
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
//! bisection inside that bracket, from a start that is exact at `phi = 1/2` and in the far tail
//! (two or three evaluations). Since the quadratures are symmetric, `1 - F(D) = F(-D)`: for
//! `phi > 1/2` the solve is done for `1 - phi` (exact in floating point) and `-D`, so both
//! tails keep full relative accuracy and no NaN or infinity can arise for finite input.
//!
//! The cell average ([`CellQuadrature`]) uses by default the 2 x 2 x 2 Gauss rule the paper
//! uses for (2.46). Then every point value is `1 / (1 + E w_q)` with `E = exp(-2 D)` and
//! `w_q = exp(-2 a . xi_q)` fixed per cell: an evaluation costs one exponential. The
//! reconstruction stores `E` and the per-axis factors `exp(-a_k)` (half-cell shift) and
//! `exp(-a_k / sqrt 3)` (Gauss shift), so the face averages below need no transcendental
//! function at all. The alternative rule integrates exactly along the axis of the largest
//! `|a_k|` (the antiderivative of `sigma(2 y)` is `softplus(2 y) / 2`), after the original
//! MTHINC.
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
    /// The 2 x 2 x 2 Gauss-Legendre rule of the paper's (2.46) (8 points in 3D, 4 in 2D). The
    /// default: every point value is `1 / (1 + E W_q)` with `E = exp(-2 D)` and fixed weights
    /// `W_q`, so a Newton iteration costs one exponential.
    #[default]
    Gauss2,
    /// Exact integration along the axis of the largest normal component, 2-point Gauss in the
    /// other axes (after the original MTHINC); about three times as costly, no more accurate in
    /// the single-vortex test (see `docs/validation/interface.md`).
    ExactAlongNormal,
}

/// Half the offset of the 2-point Gauss-Legendre nodes on `[-1/2, 1/2]`: `1 / (2 sqrt 3)`.
#[inline(always)]
pub(crate) fn gauss_half<T: Real>() -> T {
    T::lit(0.5 / 3f64.sqrt())
}

/// `(sigma, 2 sigma (1 - sigma))` of the profile at a point where `exp(-2 y) = w`.
#[inline(always)]
fn from_weight<T: Real>(w: T) -> (T, T) {
    let s = T::one() / (T::one() + w);
    (s, (w + w) * s * s)
}

/// The MTHINC reconstruction of one cell (see the [module docs](self)).
///
/// A cell with a profile stores the slopes `a = beta' n h` (per axis, not all zero), the offset
/// `D`, and the exponential factors `E = exp(-2 D)`, `exp(-a_k)` and `exp(-a_k / sqrt 3)` from
/// which every quadrature-point value follows by products. A *uniform* cell has `a = 0` and
/// carries its cell values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reconstruction<T> {
    /// `beta' n_k h_k` per axis; all zero for a uniform cell.
    pub(crate) a: [T; 3],
    /// The offset `D = beta' (n . x_c + d)`, or the cell value of `phi` for a uniform cell.
    pub(crate) d: T,
    /// `exp(-2 D)`.
    e: T,
    /// `exp(-a_k)`: the factor of a half-cell shift along axis k.
    p: [T; 3],
    /// `exp(-2 a_k / (2 sqrt 3))`: the factor of a Gauss-point shift along axis k.
    g: [T; 3],
    /// The coefficient of the convolved profile (2.47) divided by `beta'`, or the cell value of
    /// `kappa_R tilde` for a uniform cell (see [`super::convolved`]).
    pub(crate) c: T,
}

impl<T: Real> Default for Reconstruction<T> {
    fn default() -> Self {
        Self::uniform(T::zero(), T::zero())
    }
}

/// What a reconstruction solve reports besides the offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetSolve<T> {
    /// The offset `D` of the profile in cell units (`y = a . xi + D`).
    pub offset: T,
    /// The cell average of `2 sigma (1 - sigma)` at the solution, `= F'(D)`: the cell average
    /// of `|grad H| / beta'`, needed by the convolved profile (2.47).
    pub mean_slope: T,
    /// Function evaluations (Newton or bisection steps) used.
    pub iterations: u32,
}

const fn others(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

impl<T: Real> Reconstruction<T> {
    /// A uniform cell with values `phi` and `kappa_tilde`.
    #[inline(always)]
    pub fn uniform(phi: T, kappa_tilde: T) -> Self {
        Reconstruction {
            a: [T::zero(); 3],
            d: phi,
            e: T::one(),
            p: [T::one(); 3],
            g: [T::one(); 3],
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
        let a = [normal[0] * scale[0], normal[1] * scale[1], normal[2] * scale[2]];
        match solve_offset(a, phi, tiny, quadrature) {
            Some(s) => (Self::with_offset(a, s.offset), Some(s)),
            None => (Reconstruction::uniform(phi, T::zero()), None),
        }
    }

    /// The reconstruction with slopes `a` and offset `d` (no constraint solved).
    pub fn with_offset(a: [T; 3], d: T) -> Self {
        let gh = gauss_half::<T>() * T::lit(2.0);
        Reconstruction {
            a,
            d,
            e: (-(d + d)).exp(),
            p: a.map(|x| (-x).exp()),
            g: a.map(|x| (-gh * x).exp()),
            c: T::zero(),
        }
    }

    /// The average of the reconstructed `H` over the face of the cell normal to `axis`, on the
    /// upper side (`upper = true`, `xi_axis = +1/2`) or the lower side, by the 2 x 2 Gauss rule:
    /// the `Hbar` of (2.48). For a uniform cell, its `phi`.
    #[inline(always)]
    pub fn face_average(&self, axis: usize, upper: bool) -> T {
        self.face_averages(axis, upper).0
    }

    /// `(Hbar, <2 sigma (1 - sigma)>_face)` on a face, from products of the stored factors (no
    /// transcendental function). For a uniform cell, `(phi, 0)`.
    #[inline(always)]
    pub(crate) fn face_averages(&self, axis: usize, upper: bool) -> (T, T) {
        if self.is_uniform() {
            return (self.d, T::zero());
        }
        let base = if upper { self.e * self.p[axis] } else { self.e / self.p[axis] };
        let (t1, t2) = others(axis);
        let (g1, g2) = (self.g[t1], self.g[t2]);
        let half = T::lit(0.5);
        if self.a[t2] == T::zero() {
            if self.a[t1] == T::zero() {
                return from_weight(base);
            }
            let (h1, s1) = from_weight(base * g1);
            let (h2, s2) = from_weight(base / g1);
            return (half * (h1 + h2), half * (s1 + s2));
        }
        let quarter = T::lit(0.25);
        let (bp, bm) = (base * g1, base / g1);
        let (h1, s1) = from_weight(bp * g2);
        let (h2, s2) = from_weight(bp / g2);
        let (h3, s3) = from_weight(bm * g2);
        let (h4, s4) = from_weight(bm / g2);
        (quarter * (h1 + h2 + h3 + h4), quarter * (s1 + s2 + s3 + s4))
    }
}

/// Cell average `F(D)` of `sigma(2 (a . xi + D))` and its derivative `F'(D)`.
enum CellAverage<T> {
    /// Gauss points: `F = mean 1 / (1 + exp(-2 D) w_q)`.
    Gauss { w: [T; 8], count: usize },
    /// Exact along `am = |a_m|`, Gauss in the others at offsets `o_q = sum a_k xi_k`.
    Exact { am: T, e2: T, offsets: [T; 4], count: usize },
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
        if quadrature == CellQuadrature::ExactAlongNormal && am > T::lit(1e-3) {
            let mut offsets = [T::zero(); 4];
            let mut count = 1;
            for k in (0..3).filter(|&k| k != m && a[k] != T::zero()) {
                let dk = g * a[k];
                for j in 0..count {
                    offsets[j + count] = offsets[j] - dk;
                    offsets[j] += dk;
                }
                count *= 2;
            }
            return CellAverage::Exact { am, e2: (-(am + am)).exp(), offsets, count };
        }
        let mut w = [T::one(); 8];
        let mut count = 1;
        for k in (0..3).filter(|&k| a[k] != T::zero()) {
            let f = (-(g + g) * a[k]).exp();
            for j in 0..count {
                w[j + count] = w[j] / f;
                w[j] *= f;
            }
            count *= 2;
        }
        CellAverage::Gauss { w, count }
    }

    /// `mean_q w_q^-1`, the lower-tail factor: `F(D) ~ exp(2 D) mean w^-1` as `D -> -inf`.
    fn tail_factor(&self) -> Option<T> {
        match self {
            CellAverage::Gauss { w, count } => {
                let s = w[..*count].iter().fold(T::zero(), |s, &x| s + T::one() / x);
                Some(s / T::from_usize(*count).unwrap_or(T::one()))
            }
            CellAverage::Exact { .. } => None,
        }
    }

    /// `(F(D), F'(D))`.
    #[inline(always)]
    fn eval(&self, d: T) -> (T, T) {
        let mut f = T::zero();
        let mut fp = T::zero();
        let one = T::one();
        match self {
            CellAverage::Gauss { w, count } => {
                let e = (-(d + d)).exp();
                for &x in &w[..*count] {
                    let (h, s) = from_weight(e * x);
                    f += h;
                    fp += s;
                }
                let inv = one / T::from_usize(*count).unwrap_or(one);
                (f * inv, fp * inv)
            }
            CellAverage::Exact { am, e2, offsets, count } => {
                // int_{-1/2}^{1/2} sigma(2 (am xi + z)) dxi = (softplus(x1) - softplus(x0)) / (2 am)
                // with x0 = 2 z - am, x1 = 2 z + am; the difference of softplus values is
                // formed with one logarithm and no cancellation; its derivative in D is
                // sigma(x1) - sigma(x0) over am.
                let am = *am;
                for &o in &offsets[..*count] {
                    let x0 = (o + d) * T::lit(2.0) - am;
                    let x1 = x0 + am + am;
                    let (diff, slope) = if x0 >= T::zero() {
                        let e0 = (-x0).exp();
                        let e1 = e0 * *e2;
                        let den = (one + e0) * (one + e1);
                        (am + am + ((e1 - e0) / (one + e0)).ln_1p(), (e0 - e1) / den)
                    } else if x1 <= T::zero() {
                        let e1 = x1.exp();
                        let e0 = e1 * *e2;
                        let den = (one + e0) * (one + e1);
                        (((e1 - e0) / (one + e0)).ln_1p(), (e1 - e0) / den)
                    } else {
                        let e1 = (-x1).exp();
                        let e0 = x0.exp();
                        (x1 + ((one + e1) / (one + e0)).ln(), one / (one + e1) - e0 / (one + e0))
                    };
                    f += diff;
                    fp += slope;
                }
                let w = one / (T::from_usize(*count).unwrap_or(one) * am);
                (f * w * T::lit(0.5), fp * w)
            }
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
    let logit = T::lit(0.5) * (phi / (T::one() - phi)).ln();
    let half = T::lit(0.5) * asum;
    let mut lo = logit - half;
    let mut hi = logit + half;
    let mut d = initial_offset(&avg, a, phi, logit);
    if !(d > lo && d < hi) {
        d = logit;
    }
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
        // Newton converges quadratically with |F''/F'| <= 2: once 2 step^2 is below the
        // resolution of D, this correction is the last one.
        if T::lit(2.0) * step * step <= scale {
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
    Some(OffsetSolve { offset: if flip { -d } else { d }, mean_slope: slope, iterations: it })
}

/// Starting value of the offset for `phi <= 1/2`. For the Gauss rule: `logit(phi) / 2` (exact
/// at `phi = 1/2`) corrected towards the exact lower-tail value `ln(phi / mean w^-1) / 2` in
/// proportion to `1 - 2 phi`. For the exact rule: the exact solution for a profile varying along
/// one axis with slope `|a|`.
#[inline(always)]
fn initial_offset<T: Real>(avg: &CellAverage<T>, a: [T; 3], phi: T, logit: T) -> T {
    let half = T::lit(0.5);
    if let Some(m) = avg.tail_factor() {
        return logit - half * m.ln() * (T::one() - phi - phi);
    }
    let m = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if m.is_nan() || m <= T::lit(1e-3) {
        return logit;
    }
    let two = T::lit(2.0);
    let num = (two * m * phi).exp_m1();
    let den = -(-two * m * (T::one() - phi)).exp_m1();
    let d = half * (num.ln() - m - den.ln());
    if d.is_finite() { d } else { logit }
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
            let (r, s) = Reconstruction::new(phi, [1.0, 0.0, 0.0], [1.0; 3], 1e-8, Default::default());
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
        let r = Reconstruction::with_offset([1.0f64, 0.0, 0.0], 0.2);
        let s = |t: f64| 1.0 / (1.0 + (-t).exp());
        assert!((r.face_average(0, true) - s(2.0 * 0.7)).abs() < 1e-15);
        assert!((r.face_average(0, false) - s(2.0 * -0.3)).abs() < 1e-15);
        let g = 0.5 / 3f64.sqrt();
        let y = 0.5 * (s(2.0 * (0.2 + g)) + s(2.0 * (0.2 - g)));
        assert!((r.face_average(1, true) - y).abs() < 1e-15);
    }
}
