//! A user-defined membrane law, written with the public API only, gets the stress (2.4), the
//! Jacobian (2.33) and the simple-loading solvers for free — and is checked here with the
//! `eulermembrane::testing` harness, exactly as a downstream crate would check its own law.
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

use eulermembrane::membrane::law::check_stress_free;
use eulermembrane::membrane::{
    law::{NeoHookean, SurfaceLaw, small_strain_moduli},
    loading::uniaxial_tension,
    stress::{jacobian, stress, stress_and_jacobian, tension_invariants},
};
use eulermembrane::tensor::Sym;
use eulermembrane::testing::{
    LawCheckError, MembraneState, Property, arb_probe, check_at, check_derivatives, check_law, config,
    rotation,
};
use eulermembrane::{Error, positive};
use eulermembrane::{Real, Result};
use proptest::prelude::*;

/// Membrane Mooney–Rivlin law (see the file docs). Generic over the float type.
#[derive(Debug, Clone, Copy)]
struct MooneyRivlin<T> {
    gs: T,
    psi: T,
}

impl<T: Real> MooneyRivlin<T> {
    /// Shear modulus `gs > 0`, `0 ≤ psi ≤ 1`, validated as the crate validates its own laws.
    fn new(gs: T, psi: T) -> Result<Self> {
        if !(psi >= T::zero() && psi <= T::one()) {
            return Err(Error::invalid("psi", psi, "a number in [0, 1]"));
        }
        Ok(Self { gs: positive("gs", gs)?, psi })
    }
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
    MooneyRivlin::new(gs, psi).unwrap()
}

/// The whole check of a user law: reference state, derivatives against finite differences of
/// the energy, stress, Jacobian, `H`, objectivity and power at 50 fixed probes.
#[test]
fn mooney_rivlin_passes_the_law_check() {
    for (gs, psi) in [(0.1, 0.0), (1.0, 0.3), (10.0, 1.0)] {
        let report = check_law(&law(gs, psi)).unwrap();
        assert_eq!(report.points, 50);
        assert!(report.worst(Property::Hessian).unwrap().error < 2e-9, "{report}");
    }
}

proptest! {
    #![proptest_config(config())]

    /// The law's own derivatives agree with finite differences of its energy, also at
    /// invariants that no pair of stretches reaches.
    #[test]
    fn derivatives_match_energy(
        gs in 0.1f64..10.0, psi in 0.0f64..=1.0, c1 in 0.3f64..8.0, c2 in 0.1f64..8.0,
    ) {
        check_derivatives(&law(gs, psi), c1, c2)?;
    }

    /// Every property of the harness at random states (stretches in [0.5, 2], oblique normals,
    /// random rotations and velocity gradients): among them the tensions are the derivatives
    /// of the energy, and the Jacobian, mixed-derivative terms included, matches finite
    /// differences of the stress.
    #[test]
    fn passes_at_random_probes(gs in 0.1f64..10.0, psi in 0.0f64..=1.0, probe in arb_probe()) {
        let report = check_at(&law(gs, psi), &probe)?;
        // With the default `derivatives`, `stress_and_jacobian` gives exactly `stress`.
        prop_assert_eq!(report.worst(Property::Derivatives).map(|m| m.error), Some(0.0));
    }
}

/// The harness refuses a law with a sign error in its Hessian, naming the property, and a law
/// that is not stress free at rest, naming the law.
#[test]
fn wrong_laws_are_refused() {
    /// `W_12` with the wrong sign (the moduli stay positive, so only the check finds it).
    struct SignError(MooneyRivlin<f64>);
    impl SurfaceLaw<f64> for SignError {
        fn name(&self) -> &str {
            "mooney_rivlin_sign_error"
        }
        fn energy(&self, c1: f64, c2: f64) -> f64 {
            self.0.energy(c1, c2)
        }
        fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] {
            self.0.gradient(c1, c2)
        }
        fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
            let [a, b, c] = self.0.hessian(c1, c2);
            [a, -b, c]
        }
    }
    match check_law(&SignError(law(1.0, 0.3))) {
        Err(LawCheckError::Failed { law, measure }) => {
            assert_eq!((law.as_str(), measure.property), ("mooney_rivlin_sign_error", Property::Hessian));
            // 2 |W_12| relative to the largest second derivative, W_22, at the first probe: 2.2e-2.
            assert!(measure.error > 1e-2 && measure.tolerance == 2e-9, "{measure}");
        }
        other => panic!("{other:?}"),
    }

    /// `W_2` without the `ψ` term: a tension `τ = ψ G_s P` at rest.
    struct Tense(MooneyRivlin<f64>);
    impl SurfaceLaw<f64> for Tense {
        fn name(&self) -> &str {
            "mooney_rivlin_tense"
        }
        fn energy(&self, c1: f64, c2: f64) -> f64 {
            self.0.energy(c1, c2)
        }
        fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] {
            let [a, b] = self.0.gradient(c1, c2);
            [a, b - 0.5 * self.0.gs * self.0.psi]
        }
        fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
            self.0.hessian(c1, c2)
        }
    }
    let tense = Tense(law(1.0, 0.3));
    let e = check_law(&tense).unwrap_err().to_string();
    assert!(e.contains("`law`") && e.contains("`mooney_rivlin_tense`") && e.contains("stress free"), "{e}");
    assert_eq!(LawCheckError::Invalid(check_stress_free(&tense).unwrap_err()).to_string(), e);
}

/// The constructor refuses bad parameters with the crate's errors.
#[test]
fn constructor_validates() {
    for (gs, psi, name) in
        [(0.0, 0.5, "gs"), (f64::NAN, 0.5, "gs"), (1.0, 1.5, "psi"), (1.0, f64::NAN, "psi")]
    {
        match MooneyRivlin::new(gs, psi) {
            Err(Error::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{other:?}"),
        }
    }
}

/// `ψ = 0` reproduces the library's neo-Hookean law with `E_s = 3 G_s` (stress and Jacobian).
#[test]
fn psi_zero_is_neo_hookean() {
    let m = law(0.7, 0.0);
    let nh = NeoHookean::new(2.1).unwrap();
    let q = rotation([0.48, 0.6, 0.64], 1.1);
    let s = MembraneState::stretched(
        q,
        [1.7f64.sqrt(), 0.6f64.sqrt(), 1.0],
        rotation([0.0, 0.0, 1.0], 0.0),
        [0.0, 0.0, 1.0],
    )
    .unwrap();
    let (g, n) = (s.g(), s.n());
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
        check_stress_free(&m).unwrap();
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
    let m: &dyn SurfaceLaw<f32> = &MooneyRivlin::new(1.0f32, 0.5).unwrap();
    check_stress_free(m).unwrap();
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
