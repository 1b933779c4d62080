//! In-plane membrane stress at a point: eqs (2.18), (2.3), (2.4), the Jacobian (2.33) in the
//! component form (B.1)–(B.5), and the quasi-implicit term `H` of (2.35), (B.6)–(B.7).
//!
//! Everything here is pointwise: inputs are the surface deformation tensor `G_s`
//! ([`Sym`], tensor components) and the current unit normal `n` of one cell; nothing allocates.
//!
//! # Equations
//!
//! - (2.18) `B_s = P G_s P`, `P = I − n n`;
//! - (2.3) `c1 = tr B_s − 1`, `c2 = ½ (tr(B_s)² − tr(B_s²))`;
//! - (2.4) `τ = (2/√c2) (W_1 B_s + c2 W_2 P)` with `W_i = ∂W_s/∂c_i`;
//! - (2.33) `J = ∂τ/∂G_s` at fixed `n`;
//! - (2.35) `H(∇v, G_s, J) = J : (∇vᵀ·G_s + G_s·∇v)`.
//!
//! # The Jacobian, derived
//!
//! Differentiating (2.4) at fixed `P` (the paper's (B.4), with the mixed derivative `W_12` kept):
//!
//! ```text
//! dτ = (2/√c2) [ W_1 dB + dc1 X + dc2 Y ],
//!   X = W_11 B + c2 W_12 P,
//!   Y = (W_12 − W_1/(2 c2)) B + (W_2/2 + c2 W_22) P,
//! ```
//!
//! and, since `B = P G P` with `P` idempotent, `dB = P dG P`, `dc1 = tr(P dG P) = P : dG`,
//! `dc2 = (tr(B) I − B) : P dG P = C : dG` with `C = tr(B) P − B` (the in-plane cofactor of
//! `B`). Hence
//!
//! ```text
//! J = (2/√c2) [ W_1 (P ⊠ P) + X ⊗ P + Y ⊗ C ],     (P ⊠ P) : dG = P dG P.
//! ```
//!
//! This is assembled directly (no 6x6 product (B.1)).
//!
//! # Component convention of the 6x6 Jacobian (factor two)
//!
//! [`Jacobian`] `j` is defined by `dτ'_a = Σ_b j[a][b] dG'_b` where both `dτ'` and `dG'` hold
//! **tensor components** in the order `(11, 22, 33, 12, 23, 31)` of [`crate::tensor`]. Thus
//! `j[a][3]` is the derivative of `τ'_a` for the *symmetric* perturbation `dG12 = dG21 = 1`
//! (both entries move), not for `dG12` alone. Equivalently `j[a][b] = w_b ∂τ_a/∂G_{kl}` with
//! weights `w = (1, 1, 1, 2, 2, 2)` applied to the derivative with respect to one tensor entry.
//! With this convention (B.6) is a plain matrix–vector product `H' = J' R'`, `R'` the tensor
//! components of (B.7).
//!
//! # Notes on Appendix B
//!
//! The transform (B.3) as printed omits, in its lower-right 3x3 block (rows and columns
//! 12, 23, 31), the second product of `∂B_pq/∂G'_(kl) = P_pk P_lq + P_pl P_kq`: e.g. the
//! (12, 12) entry must be `P11 P22 + P12 P12`, not `P11 P22`. The difference vanishes only
//! when `n` is along a coordinate axis (`P12 = P23 = P31 = 0`); on a curved interface, even in
//! a 2D run (`n = (n1, n2, 0)`, `P12 = −n1 n2`), it does not. This module uses the full
//! expression and tests it against finite differences. The upper-right block of (B.3) has the
//! factor 2 consistent with the convention above. (B.4) assumes `W_12 = 0`; here it is kept.
//!
//! # Degenerate input
//!
//! If `c2 ≤ 0` (a degenerate `G_s`, e.g. a cell just re-initialised with a bad normal, or
//! `G_s = 0`), the stress, the Jacobian, the energy and the tensions are returned as **zero**
//! instead of NaN or infinity. A NaN in `G_s` or `n` is not hidden: it propagates (`c2` is then
//! NaN, which is not `≤ 0`), so that the caller's non-finite check can report it.
//! The normal `n` must have unit length.

use super::law::SurfaceLaw;
use crate::Real;
use crate::tensor::{
    Mat3, SYM_PAIRS, Sym, Vec3, XX, XY, YY, YZ, ZX, ZZ, dot, projector, sym_mul_vec, sym_to_mat, trace,
};

/// The 6x6 Jacobian `J' = dτ'/dG'` of (2.33) in the component form of Appendix B:
/// `j[a][b]`, row `a` a stress component, column `b` a component of `G_s`, both in the order
/// `(11, 22, 33, 12, 23, 31)`; see the [module docs](self) for the factor-two convention
/// (`dτ' = J' dG'` with `dG'` holding tensor components).
pub type Jacobian<T> = [[T; 6]; 6];

/// Weights turning a derivative with respect to one tensor entry into one with respect to a
/// [`Sym`] component (off-diagonal components stand for two entries).
const SYM_WEIGHT: [f64; 6] = [1.0, 1.0, 1.0, 2.0, 2.0, 2.0];

/// Surface kinematics at a point: the projector, `B_s` and its invariants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceKinematics<T> {
    /// Surface projector `P = I − n n`.
    pub p: Sym<T>,
    /// Surface left Cauchy–Green tensor `B_s = P G_s P`, eq. (2.18).
    pub b: Sym<T>,
    /// `c1 = tr B_s − 1`, eq. (2.3a).
    pub c1: T,
    /// `c2 = ½ (tr(B_s)² − tr(B_s²))`, eq. (2.3b): the squared area ratio `J_s²`.
    pub c2: T,
}

/// `P`, `B_s = P G_s P` (2.18) and the invariants `c1`, `c2` (2.3) for a unit normal `n`.
///
/// `B_s` is formed as `G − n⊗g − g⊗n + (n·g) n⊗n` with `g = G n` (equal to `P G P` for unit
/// `n`); `c2` is the sum of the principal 2x2 minors of `B_s` (equal to (2.3b)), which reduces
/// the cancellation of `tr(B)² − tr(B²)` when one stretch is much smaller than the other
/// (for `B_s = diag(a, b, 0)` it gives `a b` exactly).
#[inline]
pub fn surface_kinematics<T: Real>(g: &Sym<T>, n: &Vec3<T>) -> SurfaceKinematics<T> {
    let p = projector(n);
    let gn = sym_mul_vec(g, n);
    let s = dot(n, &gn);
    let mut b = [T::zero(); 6];
    for (c, &(i, j)) in SYM_PAIRS.iter().enumerate() {
        b[c] = g[c] - n[i] * gn[j] - gn[i] * n[j] + s * n[i] * n[j];
    }
    let c1 = trace(&b) - T::one();
    let c2 = b[XX] * b[YY] - b[XY] * b[XY] + b[YY] * b[ZZ] - b[YZ] * b[YZ] + b[ZZ] * b[XX] - b[ZX] * b[ZX];
    SurfaceKinematics { p, b, c1, c2 }
}

/// `τ = (2/√c2)(W_1 B + c2 W_2 P)` from precomputed kinematics and first derivatives.
#[inline]
fn tau_from<T: Real>(k: &SurfaceKinematics<T>, w1: T, w2: T) -> Sym<T> {
    let f = T::lit(2.0) / k.c2.sqrt();
    let a = f * w1;
    let c = f * k.c2 * w2;
    let mut tau = [T::zero(); 6];
    for (t, (&b, &p)) in tau.iter_mut().zip(k.b.iter().zip(k.p.iter())) {
        *t = a * b + c * p;
    }
    tau
}

/// The in-plane Cauchy stress `τ` (2.4) at a point, for the surface deformation tensor `g`
/// (= `G_s`, tensor components) and the unit normal `n`.
///
/// `τ` is symmetric and in-plane (`τ n = 0`). Returns zero if `c2 ≤ 0` (see the
/// [module docs](self)).
#[inline]
pub fn stress<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L, g: &Sym<T>, n: &Vec3<T>) -> Sym<T> {
    let k = surface_kinematics(g, n);
    if k.c2 <= T::zero() {
        return [T::zero(); 6];
    }
    let [w1, w2] = law.gradient(k.c1, k.c2);
    tau_from(&k, w1, w2)
}

/// The Jacobian `J' = dτ'/dG'_s` (2.33), (B.1)–(B.5), at fixed `n`, in the component convention
/// of [`Jacobian`]. Returns zero if `c2 ≤ 0`.
#[inline]
pub fn jacobian<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L, g: &Sym<T>, n: &Vec3<T>) -> Jacobian<T> {
    stress_and_jacobian(law, g, n).1
}

/// The stress `τ` (2.4) and the Jacobian `J'` (2.33) together, sharing the kinematics and the
/// law evaluation: the per-band-cell call of the quasi-implicit predictor (2.32)–(2.35).
///
/// Allocation free. Returns zeros if `c2 ≤ 0` (see the [module docs](self)).
pub fn stress_and_jacobian<T: Real, L: SurfaceLaw<T> + ?Sized>(
    law: &L,
    g: &Sym<T>,
    n: &Vec3<T>,
) -> (Sym<T>, Jacobian<T>) {
    let zero = T::zero();
    let k = surface_kinematics(g, n);
    if k.c2 <= zero {
        return ([zero; 6], [[zero; 6]; 6]);
    }
    let ([w1, w2], [w11, w12, w22]) = law.derivatives(k.c1, k.c2);
    let tau = tau_from(&k, w1, w2);

    let half = T::lit(0.5);
    let f = T::lit(2.0) / k.c2.sqrt();
    let trb = trace(&k.b);
    // X, Y (see module docs), already multiplied by f; and the weighted P, C rows.
    let xb = f * w11;
    let xp = f * k.c2 * w12;
    let yb = f * (w12 - half * w1 / k.c2);
    let yp = f * (half * w2 + k.c2 * w22);
    let fw1 = f * w1;
    let pm = sym_to_mat(&k.p);
    let mut pw = [zero; 6];
    let mut cw = [zero; 6];
    for c in 0..6 {
        let wt = T::lit(SYM_WEIGHT[c]);
        pw[c] = wt * k.p[c];
        cw[c] = wt * (trb * k.p[c] - k.b[c]);
    }
    let mut j = [[zero; 6]; 6];
    for (a, &(p, q)) in SYM_PAIRS.iter().enumerate() {
        let xa = xb * k.b[a] + xp * k.p[a];
        let ya = yb * k.b[a] + yp * k.p[a];
        for (b, &(kk, l)) in SYM_PAIRS.iter().enumerate() {
            // (P ⊠ P) in the symmetric component convention: d(PdGP)_pq / dG'_(kl).
            let mut t = pm[p][kk] * pm[l][q];
            if kk != l {
                t += pm[p][l] * pm[kk][q];
            }
            j[a][b] = fw1 * t + xa * pw[b] + ya * cw[b];
        }
    }
    (tau, j)
}

/// The rate `R = ∇vᵀ·G_s + G_s·∇v` of (2.22) and (B.7), as tensor components.
///
/// Convention: `grad_v[i][j] = ∂v_j/∂x_i` (the paper's `∇v`), so `∇vᵀ` is the velocity
/// gradient `L`, `L_ij = ∂v_i/∂x_j`, and `R = L G + G Lᵀ`.
#[inline]
pub fn stretching<T: Real>(grad_v: &Mat3<T>, g: &Sym<T>) -> Sym<T> {
    let gm = sym_to_mat(g);
    let mut r = [T::zero(); 6];
    for (c, &(i, j)) in SYM_PAIRS.iter().enumerate() {
        let mut s = T::zero();
        for kk in 0..3 {
            s += grad_v[kk][i] * gm[kk][j] + gm[i][kk] * grad_v[kk][j];
        }
        r[c] = s;
    }
    r
}

/// The quasi-implicit term `H(∇v, G_s, J) = J : (∇vᵀ·G_s + G_s·∇v)` of (2.35), (B.6)–(B.7),
/// as a symmetric tensor (tensor components).
///
/// `grad_v[i][j] = ∂v_j/∂x_i` (see [`stretching`]); `jac` from [`jacobian`] or
/// [`stress_and_jacobian`]. `H` is the derivative of `τ` along `G_s(ε) = G_s + ε R`.
#[inline]
pub fn h_tensor<T: Real>(grad_v: &Mat3<T>, g: &Sym<T>, jac: &Jacobian<T>) -> Sym<T> {
    jacobian_apply(jac, &stretching(grad_v, g))
}

/// `J : R`, the rate of `τ` along a rate `R` of `G_s` (tensor components).
#[inline]
pub(crate) fn jacobian_apply<T: Real>(jac: &Jacobian<T>, r: &Sym<T>) -> Sym<T> {
    let mut h = [T::zero(); 6];
    for (ha, row) in h.iter_mut().zip(jac.iter()) {
        *ha = row.iter().zip(r.iter()).fold(T::zero(), |s, (&jab, &rb)| s + jab * rb);
    }
    h
}

/// Strain energy per unit **reference** area, `W_s(c1, c2)`, at a point (zero if `c2 ≤ 0`).
///
/// Per unit current area it is `W_s/√c2`; in a band integral weighted by `δ = |∇φ|` (current
/// configuration) use `W_s/√c2`.
#[inline]
pub fn energy_density<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L, g: &Sym<T>, n: &Vec3<T>) -> T {
    let k = surface_kinematics(g, n);
    if k.c2 <= T::zero() {
        return T::zero();
    }
    law.energy(k.c1, k.c2)
}

/// Principal tensions `(T1, T2)`, `T1 ≥ T2`, of an in-plane symmetric tensor `tau` with unit
/// normal `n` (`tau n = 0`, as for (2.4)).
///
/// `T1,2 = m ± r` with `m = tr τ/2` and `r = √(½ |τ − m P|²)`: the radius is taken from the
/// in-plane deviator, so that it keeps full relative accuracy when `T1 ≈ T2` (the textbook
/// `√(m² − T1 T2)` loses half the digits there).
#[inline]
pub fn principal_tensions<T: Real>(tau: &Sym<T>, n: &Vec3<T>) -> (T, T) {
    let half = T::lit(0.5);
    let m = half * trace(tau);
    let p = projector(n);
    let dev: Sym<T> = std::array::from_fn(|c| tau[c] - m * p[c]);
    let r = (half * crate::tensor::ddot(&dev, &dev)).sqrt();
    (m + r, m - r)
}

/// Scalar membrane output at a point (for ParaView and diagnostics).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionInvariants<T> {
    /// Larger principal tension `T1` (force per unit current length).
    pub t1: T,
    /// Smaller principal tension `T2`.
    pub t2: T,
    /// Area dilation `J_s = √c2` (current over reference area).
    pub dilation: T,
    /// Strain energy per unit reference area `W_s(c1, c2)`.
    pub energy: T,
}

/// Principal tensions, area dilation `√c2` and strain energy density at a point, from one
/// kinematics evaluation. All zero if `c2 ≤ 0`.
pub fn tension_invariants<T: Real, L: SurfaceLaw<T> + ?Sized>(
    law: &L,
    g: &Sym<T>,
    n: &Vec3<T>,
) -> TensionInvariants<T> {
    let zero = T::zero();
    let k = surface_kinematics(g, n);
    if k.c2 <= zero {
        return TensionInvariants { t1: zero, t2: zero, dilation: zero, energy: zero };
    }
    let [w1, w2] = law.gradient(k.c1, k.c2);
    let (t1, t2) = principal_tensions(&tau_from(&k, w1, w2), n);
    TensionInvariants { t1, t2, dilation: k.c2.sqrt(), energy: law.energy(k.c1, k.c2) }
}

// Tensor components are indexed by number in the tests, as in the equations.
#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::membrane::law::{NeoHookean, Skalak};
    use crate::tensor::project;

    fn unit(v: [f64; 3]) -> [f64; 3] {
        let s = dot(&v, &v).sqrt();
        [v[0] / s, v[1] / s, v[2] / s]
    }

    /// An oblique normal and a stretched in-plane G (not aligned with the axes).
    fn oblique_state() -> (Sym<f64>, Vec3<f64>) {
        let n = unit([0.3, -0.5, 0.8]);
        let p = projector(&n);
        // G = P A P for a symmetric positive A: in-plane, generic.
        let a = [1.7, 0.6, 1.1, 0.3, -0.2, 0.25];
        (project(&p, &a), n)
    }

    #[test]
    fn kinematics_match_definitions() {
        let (g, n) = oblique_state();
        let g = [g[0] + 0.1, g[1], g[2] - 0.05, g[3] + 0.07, g[4], g[5]]; // not in-plane
        let k = surface_kinematics(&g, &n);
        let b = project(&projector(&n), &g);
        for c in 0..6 {
            assert!((k.b[c] - b[c]).abs() < 1e-14);
        }
        let trb = trace(&b);
        let c2 = 0.5 * (trb * trb - crate::tensor::ddot(&b, &b));
        assert!((k.c1 - (trb - 1.0)).abs() < 1e-14);
        assert!((k.c2 - c2).abs() < 1e-14);
    }

    #[test]
    fn jacobian_matches_finite_differences_oblique_normal() {
        let (g, n) = oblique_state();
        let laws: [&dyn SurfaceLaw<f64>; 2] =
            [&NeoHookean::new(1.3).unwrap(), &Skalak::new(0.7, 5.0).unwrap()];
        for law in laws {
            let (tau, j) = stress_and_jacobian(law, &g, &n);
            assert_eq!(tau, stress(law, &g, &n));
            let h = 1e-6;
            let mut scale = 0.0f64;
            for row in &j {
                for &x in row {
                    scale = scale.max(x.abs());
                }
            }
            for b in 0..6 {
                let (mut gp, mut gm) = (g, g);
                gp[b] += h;
                gm[b] -= h;
                let (tp, tm) = (stress(law, &gp, &n), stress(law, &gm, &n));
                for a in 0..6 {
                    let fd = (tp[a] - tm[a]) / (2.0 * h);
                    assert!((fd - j[a][b]).abs() < 1e-7 * scale, "{a},{b}: {fd} vs {}", j[a][b]);
                }
            }
        }
    }

    /// The paper's (B.3) lower-right block keeps only `P_pk P_lq`; the correct entry has the
    /// second product too. Check on the (12,12) entry of `P ⊠ P` (W_1 part of J only).
    #[test]
    fn b3_lower_right_block_needs_both_products() {
        let n = unit([1.0, 1.0, 1.0]);
        let p = projector(&n);
        // d(P dG P)_12 for dG12 = dG21 = 1: P11 P22 + P12 P21.
        let dg = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
        let db = project(&p, &dg);
        let full = p[XX] * p[YY] + p[XY] * p[XY];
        let paper = p[XX] * p[YY];
        assert!((db[XY] - full).abs() < 1e-15);
        assert!((db[XY] - paper).abs() > 0.1);
    }

    #[test]
    fn reference_state_and_degenerate_input() {
        let (_, n) = oblique_state();
        let p = projector(&n);
        let law = Skalak::new(2.0, 10.0).unwrap();
        let tau = stress(&law, &p, &n);
        assert!(tau.iter().all(|x| x.abs() < 1e-14));
        let inv = tension_invariants(&law, &p, &n);
        assert!(inv.t1.abs() < 1e-14 && inv.t2.abs() < 1e-14);
        assert!((inv.dilation - 1.0).abs() < 1e-14 && inv.energy.abs() < 1e-14);
        // Degenerate: G = 0, or G = n n (no in-plane part): zeros, not NaN.
        let nh = NeoHookean::new(1.0).unwrap();
        let nn = [n[0] * n[0], n[1] * n[1], n[2] * n[2], n[0] * n[1], n[1] * n[2], n[2] * n[0]];
        for g in [[0.0; 6], nn] {
            let (t, j) = stress_and_jacobian(&nh, &g, &n);
            assert!(t.iter().all(|x| *x == 0.0));
            assert!(j.iter().flatten().all(|x| *x == 0.0));
            assert_eq!(energy_density(&nh, &g, &n), 0.0);
            assert_eq!(tension_invariants(&nh, &g, &n).t1, 0.0);
        }
        // A NaN is not hidden.
        let g = [f64::NAN, 1.0, 1.0, 0.0, 0.0, 0.0];
        assert!(stress(&nh, &g, &[0.0, 0.0, 1.0])[0].is_nan());
    }

    #[test]
    fn h_is_jacobian_applied_to_stretching() {
        let (g, n) = oblique_state();
        let law = NeoHookean::new(1.0).unwrap();
        let j = jacobian(&law, &g, &n);
        let gv = [[0.1, -0.3, 0.2], [0.05, 0.4, -0.1], [0.3, 0.0, -0.5]];
        let h = h_tensor(&gv, &g, &j);
        let r = stretching(&gv, &g);
        let e = 1e-6;
        let gp: Sym<f64> = std::array::from_fn(|c| g[c] + e * r[c]);
        let gm: Sym<f64> = std::array::from_fn(|c| g[c] - e * r[c]);
        let (tp, tm) = (stress(&law, &gp, &n), stress(&law, &gm, &n));
        for c in 0..6 {
            assert!(((tp[c] - tm[c]) / (2.0 * e) - h[c]).abs() < 1e-8);
        }
        // (B.7) row 4, written out.
        let r4 = gv[0][1] * g[XX]
            + gv[1][0] * g[YY]
            + (gv[0][0] + gv[1][1]) * g[XY]
            + gv[2][0] * g[YZ]
            + gv[2][1] * g[ZX];
        assert!((r[XY] - r4).abs() < 1e-15);
    }

    #[test]
    fn principal_tensions_of_diagonal_state() {
        let law = Skalak::new(2.0, 1.0).unwrap();
        let (l1, l2) = (1.3, 0.9);
        let g = [l1 * l1, l2 * l2, 0.0, 0.0, 0.0, 0.0];
        let inv = tension_invariants(&law, &g, &[0.0, 0.0, 1.0]);
        let gs = 1.0;
        let t = |a: f64, b: f64| gs * (a / b) * (a * a - 1.0 + b * b * (a * a * b * b - 1.0));
        assert!((inv.t1 - t(l1, l2)).abs() < 1e-13);
        assert!((inv.t2 - t(l2, l1)).abs() < 1e-13);
        assert!((inv.dilation - l1 * l2).abs() < 1e-15);
    }

    #[test]
    fn works_in_f32() {
        let law = NeoHookean::new(1.0f32).unwrap();
        let n = [0.0f32, 0.6, 0.8];
        let p = projector(&n);
        let (t, _) = stress_and_jacobian(&law, &p, &n);
        assert!(t.iter().all(|x| x.abs() < 1e-6));
        let g: Sym<f32> = std::array::from_fn(|c| 1.2 * p[c]);
        let inv = tension_invariants(&law, &g, &n);
        // Equibiaxial λ² = 1.2: T = G_s (1 − λ^-6) with G_s = 1/3.
        let expect = (1.0 - 1.2f32.powi(-3)) / 3.0;
        assert!((inv.t1 - expect).abs() < 1e-6 && (inv.t2 - expect).abs() < 1e-6);
    }
}
