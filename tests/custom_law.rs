//! A user-defined membrane law, written with the public API only, gets the stress (2.4), the
//! Jacobian (2.33) and the simple-loading solvers for free — and is checked here against finite
//! differences of its own energy.
//!
//! The law is the membrane Mooney–Rivlin law (Barthès-Biesel, Diaz & Dhenin 2002), written in
//! the invariants (2.3) of the paper with `λ1² + λ2² = c1 + 1`, `λ1² λ2² = c2` and
//! `λ1⁻² + λ2⁻² = (c1 + 1)/c2`:
//!
//! ```text
//! W = (G_s/2) [ (1 − ψ)(c1 − 2 + 1/c2) + ψ ((c1 + 1)/c2 + c2 − 3) ],   0 ≤ ψ ≤ 1.
//! ```
//!
//! `ψ = 0` is the neo-Hookean law (2.5) with `E_s = 3 G_s`. Unlike (2.5) and (2.6), its mixed
//! derivative `W_c1c2 = −ψ G_s/(2 c2²)` is not zero, which exercises the term that the paper's
//! (B.4) drops.

mod common;
use common::{rodrigues, sphere};
use eulermembrane::Real;
use eulermembrane::membrane::{
    NeoHookean, SurfaceLaw, energy_density, jacobian, principal_tensions, small_strain_moduli, stress,
    stress_and_jacobian, tension_invariants, uniaxial_tension,
};
use eulermembrane::tensor::{Mat3, Sym, Vec3, ddot, mat_to_sym, matmul, transpose};
use proptest::prelude::*;

/// Membrane Mooney–Rivlin law (see the file docs). Generic over the float type.
#[derive(Debug, Clone, Copy)]
struct MooneyRivlin<T> {
    gs: T,
    psi: T,
}

impl<T: Real> SurfaceLaw<T> for MooneyRivlin<T> {
    fn name(&self) -> &str {
        "mooney_rivlin"
    }

    fn energy(&self, c1: T, c2: T) -> T {
        let (one, h) = (T::one(), T::lit(0.5));
        let r = c2.recip();
        h * self.gs
            * ((one - self.psi) * (c1 - T::lit(2.0) + r) + self.psi * ((c1 + one) * r + c2 - T::lit(3.0)))
    }

    fn gradient(&self, c1: T, c2: T) -> [T; 2] {
        let (one, h) = (T::one(), T::lit(0.5));
        let r = c2.recip();
        [
            h * self.gs * (one - self.psi + self.psi * r),
            h * self.gs * (-(one - self.psi) * r * r + self.psi * (one - (c1 + one) * r * r)),
        ]
    }

    fn hessian(&self, c1: T, c2: T) -> [T; 3] {
        let (one, h) = (T::one(), T::lit(0.5));
        let r = c2.recip();
        [T::zero(), -h * self.gs * self.psi * r * r, self.gs * (one + self.psi * c1) * r * r * r]
    }
}

fn law(gs: f64, psi: f64) -> MooneyRivlin<f64> {
    MooneyRivlin { gs, psi }
}

/// `Q diag(a, b, 0) Qᵀ` and `Q e3`: a flat sheet with principal stretches `√a`, `√b`, rotated.
fn rotated_sheet(q: &Mat3<f64>, a: f64, b: f64) -> (Sym<f64>, Vec3<f64>) {
    let d = [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, 0.0]];
    let g = mat_to_sym(&matmul(&matmul(q, &d), &transpose(q)));
    (g, [q[0][2], q[1][2], q[2][2]])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// The law's own derivatives agree with central differences of its energy.
    #[test]
    fn derivatives_match_energy(
        gs in 0.1f64..10.0, psi in 0.0f64..=1.0, c1 in 0.3f64..8.0, c2 in 0.1f64..8.0,
    ) {
        let m = law(gs, psi);
        let h = 1e-5;
        let w = |a: f64, b: f64| m.energy(a, b);
        let g = |a: f64, b: f64| m.gradient(a, b);
        let [w1, w2] = m.gradient(c1, c2);
        let [w11, w12, w22] = m.hessian(c1, c2);
        let fd = [
            (w(c1 + h, c2) - w(c1 - h, c2)) / (2.0 * h),
            (w(c1, c2 + h) - w(c1, c2 - h)) / (2.0 * h),
            (g(c1 + h, c2)[0] - g(c1 - h, c2)[0]) / (2.0 * h),
            (g(c1, c2 + h)[0] - g(c1, c2 - h)[0]) / (2.0 * h),
            (g(c1 + h, c2)[1] - g(c1 - h, c2)[1]) / (2.0 * h),
            (g(c1, c2 + h)[1] - g(c1, c2 - h)[1]) / (2.0 * h),
        ];
        let exact = [w1, w2, w11, w12, w12, w22];
        let scale = exact.iter().fold(gs, |s, x| s.max(x.abs()));
        for (e, f) in exact.iter().zip(fd.iter()) {
            prop_assert!((e - f).abs() <= 1e-6 * scale, "{} vs {}", e, f);
        }
    }

    /// The stress computed by the library from the law's derivatives is the derivative of the
    /// law's energy: for a sheet with principal stretches `λ1`, `λ2` (rotated arbitrarily),
    /// the principal tensions are `T1 = (1/λ2) ∂W/∂λ1` and `T2 = (1/λ1) ∂W/∂λ2` (power
    /// `Ẇ = T1 λ2 λ̇1 + T2 λ1 λ̇2` per unit reference area), with `∂W/∂λ_i` by central
    /// differences of `W(c1(λ), c2(λ))` through [`energy_density`].
    #[test]
    fn stress_is_energy_derivative(
        gs in 0.1f64..10.0, psi in 0.0f64..=1.0,
        l1 in 0.5f64..=2.0, l2 in 0.5f64..=2.0,
        axis_z in -1.0f64..=1.0, axis_phi in 0.0f64..std::f64::consts::TAU,
        angle in 0.0f64..std::f64::consts::TAU,
    ) {
        let m = law(gs, psi);
        let q = rodrigues(sphere(axis_z, axis_phi), angle);
        let w = |a: f64, b: f64| {
            let (g, n) = rotated_sheet(&q, a * a, b * b);
            energy_density(&m, &g, &n)
        };
        let h = 1e-6;
        let t1 = (w(l1 + h, l2) - w(l1 - h, l2)) / (2.0 * h) / l2;
        let t2 = (w(l1, l2 + h) - w(l1, l2 - h)) / (2.0 * h) / l1;
        let (g, n) = rotated_sheet(&q, l1 * l1, l2 * l2);
        let tau = stress(&m, &g, &n);
        let (ta, tb) = principal_tensions(&tau, &n);
        let (e1, e2) = (t1.max(t2), t1.min(t2));
        let tol = 1e-7 * (gs + ta.abs() + tb.abs());
        prop_assert!((ta - e1).abs() <= tol && (tb - e2).abs() <= tol,
            "({}, {}) vs FD ({}, {})", ta, tb, e1, e2);
        // Directly in the sheet axes too: τ : (Q e1 e1 Qᵀ) = T1.
        let e1e1 = mat_to_sym(&matmul(&matmul(&q, &[[1.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]), &transpose(&q)));
        prop_assert!((ddot(&tau, &e1e1) - t1).abs() <= tol);
    }

    /// The Jacobian, including the mixed-derivative terms, matches finite differences of the
    /// stress for a general (non-in-plane) perturbation of `G_s` and an oblique normal.
    #[test]
    fn jacobian_matches_finite_differences(
        gs in 0.1f64..10.0, psi in 0.0f64..=1.0,
        l1 in 0.5f64..=2.0, l2 in 0.5f64..=2.0,
        axis_z in -1.0f64..=1.0, axis_phi in 0.0f64..std::f64::consts::TAU,
        angle in 0.0f64..std::f64::consts::TAU,
    ) {
        let m = law(gs, psi);
        let q = rodrigues(sphere(axis_z, axis_phi), angle);
        let (g, n) = rotated_sheet(&q, l1 * l1, l2 * l2);
        let (tau, j) = stress_and_jacobian(&m, &g, &n);
        prop_assert_eq!(tau, stress(&m, &g, &n));
        let jmax = j.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
        let h = 1e-6;
        for b in 0..6 {
            let (mut gp, mut gm) = (g, g);
            gp[b] += h;
            gm[b] -= h;
            let (tp, tm) = (stress(&m, &gp, &n), stress(&m, &gm, &n));
            for a in 0..6 {
                let fd = (tp[a] - tm[a]) / (2.0 * h);
                prop_assert!((fd - j[a][b]).abs() <= 1e-6 * jmax);
            }
        }
    }
}

/// `ψ = 0` reproduces the library's neo-Hookean law with `E_s = 3 G_s` (stress and Jacobian).
#[test]
fn psi_zero_is_neo_hookean() {
    let m = law(0.7, 0.0);
    let nh = NeoHookean::new(2.1).unwrap();
    let q = rodrigues([0.48, 0.6, 0.64], 1.1);
    let (g, n) = rotated_sheet(&q, 1.7, 0.6);
    let (ta, ja) = stress_and_jacobian(&m, &g, &n);
    let (tb, jb) = stress_and_jacobian(&nh, &g, &n);
    for a in 0..6 {
        assert!((ta[a] - tb[a]).abs() < 1e-13);
        for b in 0..6 {
            assert!((ja[a][b] - jb[a][b]).abs() < 1e-12);
        }
    }
    assert_eq!(jacobian(&m, &g, &n), ja);
}

/// Small-strain moduli: shear `G_s`, and area modulus `3 G_s` for every `ψ` (the membrane of
/// an incompressible Mooney–Rivlin solid), with a stress-free reference state.
#[test]
fn small_strain_moduli_and_reference_state() {
    for psi in [0.0, 0.3, 1.0] {
        let m = law(2.0, psi);
        let (mu, k) = small_strain_moduli(&m);
        assert!((mu - 2.0).abs() < 1e-14 && (k - 6.0).abs() < 1e-13, "{psi}: {mu} {k}");
        let [w1, w2] = m.gradient(1.0, 1.0);
        assert!((w1 + w2).abs() < 1e-15);
        let n = [0.0, 0.6, 0.8];
        let p = eulermembrane::tensor::projector(&n);
        assert!(stress(&m, &p, &n).iter().all(|x| x.abs() < 1e-14));
    }
}

/// The generic uniaxial solver works for the user law: `T2 = 0` at the returned `λ2`, and `T1`
/// equals `(1/λ2) ∂W/∂λ1` by finite differences of the energy.
#[test]
fn uniaxial_tension_of_custom_law() {
    let m = law(1.0, 0.4);
    for lambda1 in [0.7, 1.2, 1.8] {
        let (t1, l2) = uniaxial_tension(&m, lambda1).unwrap();
        let g = [lambda1 * lambda1, l2 * l2, 0.0, 0.0, 0.0, 0.0];
        let e3 = [0.0, 0.0, 1.0];
        let inv = tension_invariants(&m, &g, &e3);
        let tau = stress(&m, &g, &e3);
        assert!(tau[1].abs() < 1e-13, "T2 = {}", tau[1]);
        let w = |a: f64| m.energy(a * a + l2 * l2 - 1.0, a * a * l2 * l2);
        let h = 1e-6;
        let fd = (w(lambda1 + h) - w(lambda1 - h)) / (2.0 * h) / l2;
        assert!((t1 - fd).abs() < 1e-8, "{t1} vs {fd}");
        assert!((inv.dilation - lambda1 * l2).abs() < 1e-14);
    }
}

/// The same law in `f32`, through a trait object: the API is generic over the float type.
#[test]
fn custom_law_in_f32() {
    let m: &dyn SurfaceLaw<f32> = &MooneyRivlin { gs: 1.0f32, psi: 0.5 };
    let g: Sym<f32> = [1.44, 1.0, 0.0, 0.0, 0.0, 0.0];
    let n = [0.0f32, 0.0, 1.0];
    let tau = stress(m, &g, &n);
    let m64 = law(1.0, 0.5);
    let tau64 = stress(&m64, &[1.44, 1.0, 0.0, 0.0, 0.0, 0.0], &[0.0, 0.0, 1.0]);
    for c in 0..6 {
        assert!((tau[c] as f64 - tau64[c]).abs() < 1e-5);
    }
    assert_eq!(m.name(), "mooney_rivlin");
}
