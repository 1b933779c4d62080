//! Property tests of the membrane mechanics (eqs (2.3)–(2.6), (2.18), (2.33), (B.1)–(B.7)) for
//! the neo-Hookean (2.5) and Skalak (2.6) laws, and a check of the uniaxial tension against the
//! digitised curves of Barthès-Biesel, Diaz & Dhenin, J. Fluid Mech. 460 (2002).
//!
//! The generic properties (reference state, in-plane stress, principal tensions, Jacobian,
//! objectivity, power identity, `H`) are those of the `eulermembrane::testing` harness, checked
//! at random probes ([`arb_probe`]: `F = R1 diag(λ1, λ2, λ3) R2` with principal stretches in
//! `[0.5, 2]`, a random reference normal, `G_s = F P_R Fᵀ` (2.18) and the Nanson normal, a random
//! velocity gradient and rotation). Laws: neo-Hookean with `E_s ∈ [0.1, 10]`, Skalak with
//! `E_s ∈ [0.1, 10]`, `α ∈ [0, 50]`. 256 cases per property.

use eulermembrane::membrane::{
    law::{NeoHookean, Skalak, SurfaceLaw},
    loading::{equibiaxial_stretch, equibiaxial_tension, uniaxial_tension},
    stress::tension_invariants,
    wrinkling::TensionField,
};
use eulermembrane::testing::{
    MembraneState, Probe, Property, arb_probe, arb_rotation, arb_unit, check_at, check_law, config,
};
use proptest::prelude::*;
use std::path::PathBuf;

/// The two paper laws behind one `Debug` type (proptest values must be `Debug`).
#[derive(Debug, Clone, Copy)]
enum Law {
    Neo(NeoHookean<f64>),
    Sk(Skalak<f64>),
}

impl Law {
    fn get(&self) -> &dyn SurfaceLaw<f64> {
        match self {
            Law::Neo(l) => l,
            Law::Sk(l) => l,
        }
    }
    /// A scale for absolute round-off tolerances.
    fn scale(&self) -> f64 {
        match self {
            Law::Neo(l) => l.es(),
            Law::Sk(l) => l.es() * (1.0 + l.alpha()),
        }
    }
}

prop_compose! {
    fn arb_law()(skalak in any::<bool>(), es in 0.1f64..10.0, alpha in 0.0f64..50.0) -> Law {
        if skalak {
            Law::Sk(Skalak::new(es, alpha).unwrap())
        } else {
            Law::Neo(NeoHookean::new(es).unwrap())
        }
    }
}

/// Whether the relaxed energy of `law` changes regime (taut, wrinkled, slack) within a relative
/// `1e-2` of the probe's `(c1, c2)`: taut where it equals the law's energy, slack where it is
/// zero. Near that boundary the energy is only once differentiable and the harness's
/// fourth-order differences miss its Hessian tolerance (with `1e-3`, 20 000 random probes still
/// found one off by 3.4e-9 against 2e-9, at `(0.9856, 0.9842)`; with `1e-2`, none).
fn near_a_regime_boundary(law: &Law, probe: &Probe) -> bool {
    let k = eulermembrane::membrane::stress::surface_kinematics(&probe.state.g(), &probe.state.n());
    let regime = |c1: f64, c2: f64| {
        let (w, relaxed) = match law {
            Law::Neo(l) => (l.energy(c1, c2), TensionField::new(*l).energy(c1, c2)),
            Law::Sk(l) => (l.energy(c1, c2), TensionField::new(*l).energy(c1, c2)),
        };
        if (relaxed - w).abs() <= 1e-12 * w.abs().max(1e-300) {
            0
        } else if relaxed.abs() <= 1e-300 {
            2
        } else {
            1
        }
    };
    let here = regime(k.c1, k.c2);
    let d = 1e-2;
    [(d, 0.0), (-d, 0.0), (0.0, d), (0.0, -d)]
        .iter()
        .any(|&(a, b)| regime(k.c1 + a * k.c1.abs().max(1.0), k.c2 + b * k.c2.abs().max(1.0)) != here)
}

/// Both laws pass the harness at its 50 fixed probes, at the ends of the parameter ranges.
#[test]
fn paper_laws_pass_the_law_check() {
    for es in [0.1, 10.0] {
        check_law(&NeoHookean::new(es).unwrap()).unwrap();
        for alpha in [0.0, 1.0, 50.0] {
            check_law(&Skalak::new(es, alpha).unwrap()).unwrap();
        }
    }
}

proptest! {
    #![proptest_config(config())]

    /// The tension-field relaxation of both laws passes every property of the harness at
    /// random probes, taut, wrinkled or slack (the fixed probes of `check_law` include states
    /// on the boundary between them, where the relaxed energy is only once differentiable and
    /// the harness's finite differences of the Hessian do not apply).
    #[test]
    fn tension_field_laws_pass_at_random_probes(law in arb_law(), probe in arb_probe()) {
        // Probes whose finite differences in (c1, c2) straddle that boundary are left out.
        prop_assume!(!near_a_regime_boundary(&law, &probe));
        match law {
            Law::Neo(l) => { check_at(&TensionField::new(l), &probe)?; }
            Law::Sk(l) => { check_at(&TensionField::new(l), &probe)?; }
        }
    }

    /// Every property of the harness at a random probe: `τ = 0` at `G_s = P` and at any rigid
    /// rotation of the reference plane (with area ratio 1); `τ` in-plane (`τ n = 0`,
    /// `P τ P = τ`, `τ : D = τ : P D P`); the principal tensions equal the principal-stretch
    /// formula `T_i = (2/(λ1 λ2)) (W_1 λ_i² + c2 W_2)`, with the stretches from `F`; the
    /// tensions of a sheet are derivatives of its energy; the Jacobian (2.33) equals finite
    /// differences of `τ(G_s)`, and is symmetric at rest; objectivity; the power identity
    /// `dW_s/dt = √c2 τ : D`; `H` (B.6)–(B.7) equals the derivative of `τ` along
    /// `G_s + ε (∇vᵀ G_s + G_s ∇v)`. See `eulermembrane::testing::Property`.
    #[test]
    fn paper_laws_pass_at_random_probes(law in arb_law(), probe in arb_probe()) {
        let report = check_at(law.get(), &probe)?;
        // `stress_and_jacobian` gives exactly `stress` and `jacobian`, and `derivatives`
        // exactly `gradient` and `hessian`.
        prop_assert_eq!(report.worst(Property::Derivatives).map(|m| m.error), Some(0.0));
    }

    /// The paper's laws have zero energy at rest, also under a rigid rotation `F = Q` of the
    /// reference plane (the harness does not ask it of a law: an energy offset is harmless).
    #[test]
    fn reference_energy_is_zero(law in arb_law(), n in arb_unit(), q in arb_rotation()) {
        let l = law.get();
        let s = MembraneState::new(q, n)?;
        let inv = tension_invariants(l, &s.g(), &s.n());
        prop_assert!(inv.energy.abs() <= 1e-13 * law.scale() && (inv.dilation - 1.0).abs() <= 1e-14);
    }

    /// Uniaxial tension by the generic solver (stress code + safeguarded Newton on `T2 = 0`)
    /// equals the closed forms of both laws to relative 1e-10.
    #[test]
    fn uniaxial_matches_closed_forms(
        es in 0.1f64..10.0, alpha in 0.0f64..50.0, lambda1 in 0.5f64..=2.0,
    ) {
        let nh = NeoHookean::new(es).unwrap();
        let sk = Skalak::new(es, alpha).unwrap();
        let check = |(t, l2): (f64, f64), (tc, l2c): (f64, f64), gs: f64| {
            (t - tc).abs() <= 1e-10 * tc.abs() + 1e-14 * gs && (l2 - l2c).abs() <= 1e-12 * l2c
        };
        prop_assert!(check(
            uniaxial_tension(&nh, lambda1).unwrap(), nh.uniaxial_tension(lambda1), nh.shear_modulus()
        ));
        prop_assert!(check(
            uniaxial_tension(&sk, lambda1).unwrap(), sk.uniaxial_tension(lambda1), sk.shear_modulus()
        ));
    }

    /// Equibiaxial tension by the generic stress code equals the closed forms, and the inverse
    /// solver recovers the stretch under tension (`λ ≥ 1`; in compression the Skalak response is
    /// not monotone: `T → −G_s` as `λ → 0`, past a minimum, so it has no unique inverse).
    #[test]
    fn equibiaxial_matches_closed_forms(
        es in 0.1f64..10.0, alpha in 0.0f64..50.0, lambda in 0.5f64..=2.0,
    ) {
        let nh = NeoHookean::new(es).unwrap();
        let sk = Skalak::new(es, alpha).unwrap();
        let (tn, ts) = (nh.equibiaxial_tension(lambda), sk.equibiaxial_tension(lambda));
        prop_assert!((equibiaxial_tension(&nh, lambda).unwrap() - tn).abs() <= 1e-10 * tn.abs() + 1e-14 * es);
        prop_assert!((equibiaxial_tension(&sk, lambda).unwrap() - ts).abs() <= 1e-10 * ts.abs() + 1e-14 * es);
        if lambda >= 1.0 {
            let ls = equibiaxial_stretch(&sk, ts).unwrap();
            prop_assert!((ls - lambda).abs() <= 1e-10 * lambda);
            let ln = equibiaxial_stretch(&nh, tn).unwrap();
            prop_assert!((ln - lambda).abs() <= 1e-9 * lambda);
        }
    }

    /// Under a fixed positive equibiaxial tension, the Skalak area dilation `λ²` falls strictly
    /// as `α` rises (the small-strain area modulus is `G_s (1 + 2α)`).
    #[test]
    fn skalak_dilation_falls_with_alpha(
        es in 0.1f64..10.0, alpha in 0.0f64..100.0, dalpha in 0.01f64..50.0, t in 0.01f64..5.0,
    ) {
        let a = Skalak::new(es, alpha).unwrap();
        let b = Skalak::new(es, alpha + dalpha).unwrap();
        let tension = t * a.shear_modulus();
        let (la, lb) = (equibiaxial_stretch(&a, tension).unwrap(), equibiaxial_stretch(&b, tension).unwrap());
        prop_assert!(lb * lb < la * la, "alpha {} -> {}: {} vs {}", alpha, alpha + dalpha, la * la, lb * lb);
        prop_assert!(la > 1.0);
    }
}

// ---------------------------------------------------------------------------------------------
// Barthès-Biesel, Diaz & Dhenin (2002): uniaxial tension T1/G_s against e1 = (λ1² − 1)/2
// ---------------------------------------------------------------------------------------------

/// `cases/reference/uniaxial_stretch/<file>` of the checkout (the workspace's reference data).
fn reference_file(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("cases/reference/uniaxial_stretch").join(file)
}

fn read_points(file: &str) -> Vec<(f64, f64)> {
    let path = reference_file(file);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split(',').map(|x| x.trim().parse::<f64>().unwrap());
            (it.next().unwrap(), it.next().unwrap())
        })
        .collect()
}

/// `(e1, published T1/G_s, model T1/G_s)` for one law with `G_s = 1`, the model by the generic
/// solver. Conventions (cases/reference/README.md): neo-Hookean `E_s = 3 G_s`; Skalak
/// `G_s = E_s/2` and `C = α = 1` (module docs of `membrane::law` for the derivation).
fn compare(file: &str, law: &dyn SurfaceLaw<f64>) -> Vec<(f64, f64, f64)> {
    read_points(file)
        .into_iter()
        .map(|(e1, y)| {
            let lambda1 = (1.0 + 2.0 * e1).sqrt();
            (e1, y, uniaxial_tension(law, lambda1).unwrap().0)
        })
        .collect()
}

const NEO_FILE: &str = "barthes_biesel_2002_neo_hookean.csv";
const SKALAK_FILE: &str = "barthes_biesel_2002_skalak.csv";

fn neo() -> NeoHookean<f64> {
    NeoHookean::new(3.0).unwrap()
}

fn skalak_c1() -> Skalak<f64> {
    Skalak::new(2.0, 1.0).unwrap()
}

/// Every digitised point lies within 3% *of the curve's full scale* (the largest model tension
/// over the digitised range, ≈ 1.84 G_s for neo-Hookean and ≈ 5.58 G_s for Skalak) of the
/// model: the usual accuracy measure for points read off a figure. Measured: neo-Hookean 2.90%,
/// Skalak 1.87%. Pointwise relative errors are reported in
/// [`bb2002_pointwise_relative_errors`].
#[test]
fn bb2002_uniaxial_within_3_percent_of_full_scale() {
    for (file, law) in [(NEO_FILE, &neo() as &dyn SurfaceLaw<f64>), (SKALAK_FILE, &skalak_c1())] {
        let pts = compare(file, law);
        assert!(pts.len() > 40, "{file}: {} points", pts.len());
        let full = pts.iter().fold(0.0f64, |m, p| m.max(p.2));
        for &(e1, y, t) in &pts {
            let err = (y - t).abs() / full;
            assert!(
                err <= 0.03,
                "{file}: e1 = {e1}: published {y}, model {t}, {:.2}% of full scale",
                100.0 * err
            );
        }
    }
}

/// Pointwise relative errors `|y − T1|/T1`, reported honestly rather than hidden by a wider
/// tolerance. All points are within 3% except those listed here (index in the CSV file,
/// e1, error), which this test pins so that the list stays true:
///
/// - neo-Hookean: #0 (e1 = 0.001: 107%, the published T1 is even negative), #2 (0.041: 12.6%),
///   #3 (0.060: 8.9%), #4 (0.077: 9.5%), #5 (0.095: 8.0%), #7 (0.132: 4.8%), #8 (0.153: 4.4%),
///   #9 (0.142: 4.8%), #10 (0.167: 3.5%), #38 (0.661: 3.08%), #48 (0.853: 3.11%);
/// - Skalak (C = 1): #0 (e1 = 0.002: 323%), #1 (0.018: 49%), #2 (0.042: 14%), #3 (0.062: 12.5%),
///   #4 (0.083: 9.7%), #5 (0.101: 8.1%), #6 (0.117: 7.7%), #7 (0.136: 7.0%), #8 (0.156: 6.1%),
///   #10 (0.193: 4.3%).
///
/// Reading: at small strain the absolute scatter of the digitised points is about ±0.02 G_s
/// (the Skalak curve does not even pass through the origin: +0.02 at e1 = 0.002), which is
/// a large fraction of a small tension; at large strain the neo-Hookean points lie a steady
/// 2–3% and the Skalak points 1.3–1.9% above the model, which looks like an axis-calibration
/// bias of the digitisation (the curve shapes agree). No model change brings both ends within
/// 3%: the slope at the origin is fixed by G_s and the laws (3 G_s for both laws here).
#[test]
fn bb2002_pointwise_relative_errors() {
    let cases: [(&str, &dyn SurfaceLaw<f64>, &[usize]); 2] = [
        (NEO_FILE, &neo(), &[0, 2, 3, 4, 5, 7, 8, 9, 10, 38, 48]),
        (SKALAK_FILE, &skalak_c1(), &[0, 1, 2, 3, 4, 5, 6, 7, 8, 10]),
    ];
    for (file, law, outliers) in cases {
        for (k, &(e1, y, t)) in compare(file, law).iter().enumerate() {
            let rel = (y - t).abs() / t.abs();
            if outliers.contains(&k) {
                assert!(rel > 0.03, "{file} #{k} (e1 = {e1}) is now within 3% ({rel}): update the list");
            } else {
                assert!(
                    rel <= 0.03,
                    "{file} #{k} (e1 = {e1}): published {y}, model {t}, {:.2}%",
                    100.0 * rel
                );
            }
        }
    }
}

/// The model is not trivially close: the closed forms of the two laws differ from each other
/// by far more than 3% over the digitised range, so the checks above discriminate between them.
#[test]
fn bb2002_curves_discriminate_the_laws() {
    let pts = compare(SKALAK_FILE, &neo());
    let worst = pts.iter().map(|&(_, y, t)| (y - t).abs() / y.abs()).fold(0.0f64, f64::max);
    assert!(worst > 0.5, "{worst}");
}
