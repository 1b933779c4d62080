//! Property tests of the membrane mechanics (eqs (2.3)–(2.6), (2.18), (2.33), (B.1)–(B.7)) for
//! the neo-Hookean (2.5) and Skalak (2.6) laws, and a check of the uniaxial tension against the
//! digitised curves of Barthès-Biesel, Diaz & Dhenin, J. Fluid Mech. 460 (2002).
//!
//! Random states: a deformation gradient `F = R1 diag(λ1, λ2, λ3) R2` with principal stretches
//! in `[0.5, 2]` and random rotations, a random reference normal `n_R`, and then
//! `G_s = F P_R Fᵀ` (2.18) and `n = cof(F) n_R / |cof(F) n_R|` (Nanson), which is the current
//! normal of the deformed material plane. Laws: neo-Hookean with `E_s ∈ [0.1, 10]`, Skalak with
//! `E_s ∈ [0.1, 10]`, `α ∈ [0, 50]`. 256 cases per property.

mod common;
use common::{rodrigues, sphere};
use eulermembrane::membrane::{
    NeoHookean, Skalak, SurfaceLaw, energy_density, equibiaxial_stretch, equibiaxial_tension, h_tensor,
    jacobian, stress, stress_and_jacobian, stretching, surface_kinematics, tension_invariants,
    uniaxial_tension,
};
use eulermembrane::tensor::{
    Mat3, Sym, Vec3, ddot, dot, mat_to_sym, matmul, projector, sym_mul_vec, sym_to_mat, transpose,
};
use proptest::prelude::*;
use std::f64::consts::TAU;
use std::path::PathBuf;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

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
    fn es(&self) -> f64 {
        match self {
            Law::Neo(l) => l.es(),
            Law::Sk(l) => l.es(),
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

#[derive(Debug, Clone, Copy)]
struct State {
    f: Mat3<f64>,
    n_ref: Vec3<f64>,
}

impl State {
    fn g(&self) -> Sym<f64> {
        g_of(&self.f, &self.n_ref)
    }
    fn n(&self) -> Vec3<f64> {
        normal_of(&self.f, &self.n_ref)
    }
}

fn cofactor(f: &Mat3<f64>) -> Mat3<f64> {
    let mut c = [[0.0; 3]; 3];
    for (i, row) in c.iter_mut().enumerate() {
        for (j, cij) in row.iter_mut().enumerate() {
            let (i1, i2, j1, j2) = ((i + 1) % 3, (i + 2) % 3, (j + 1) % 3, (j + 2) % 3);
            *cij = f[i1][j1] * f[i2][j2] - f[i1][j2] * f[i2][j1];
        }
    }
    c
}

fn mat_vec(a: &Mat3<f64>, v: &Vec3<f64>) -> Vec3<f64> {
    std::array::from_fn(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

fn unit(v: Vec3<f64>) -> Vec3<f64> {
    let s = dot(&v, &v).sqrt();
    [v[0] / s, v[1] / s, v[2] / s]
}

/// `G_s = F P_R Fᵀ`, eq. (2.18).
fn g_of(f: &Mat3<f64>, n_ref: &Vec3<f64>) -> Sym<f64> {
    let pr = sym_to_mat(&projector(n_ref));
    mat_to_sym(&matmul(&matmul(f, &pr), &transpose(f)))
}

/// Current normal by Nanson's formula, `n ∝ cof(F) n_R`.
fn normal_of(f: &Mat3<f64>, n_ref: &Vec3<f64>) -> Vec3<f64> {
    unit(mat_vec(&cofactor(f), n_ref))
}

/// `Q A Qᵀ` for symmetric `A`.
fn rotate(q: &Mat3<f64>, a: &Sym<f64>) -> Sym<f64> {
    mat_to_sym(&matmul(&matmul(q, &sym_to_mat(a)), &transpose(q)))
}

fn norm(a: &Sym<f64>) -> f64 {
    ddot(a, a).sqrt()
}

fn max_abs(a: &Sym<f64>) -> f64 {
    a.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn add(a: &Sym<f64>, b: &Sym<f64>, s: f64) -> Sym<f64> {
    std::array::from_fn(|c| a[c] + s * b[c])
}

prop_compose! {
    fn arb_unit()(z in -1.0f64..=1.0, phi in 0.0f64..TAU) -> Vec3<f64> {
        sphere(z, phi)
    }
}

prop_compose! {
    fn arb_rotation()(axis in arb_unit(), angle in 0.0f64..TAU) -> Mat3<f64> {
        rodrigues(axis, angle)
    }
}

prop_compose! {
    fn arb_state()(
        r1 in arb_rotation(),
        r2 in arb_rotation(),
        l in [0.5f64..=2.0, 0.5f64..=2.0, 0.5f64..=2.0],
        n_ref in arb_unit(),
    ) -> State {
        let d = [[l[0], 0.0, 0.0], [0.0, l[1], 0.0], [0.0, 0.0, l[2]]];
        State { f: matmul(&matmul(&r1, &d), &r2), n_ref }
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

fn config() -> ProptestConfig {
    ProptestConfig::with_cases(256)
}

// ---------------------------------------------------------------------------------------------
// Properties
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(config())]

    /// The reference (stress-free) state: `G_s = P` for any unit normal, and more generally any
    /// rigid rotation `F = Q` of the reference plane (`G_s = Q P_R Qᵀ`, `n = Q n_R`), gives
    /// `τ = 0`, `W = 0` and area dilation 1.
    #[test]
    fn reference_state_is_stress_free(law in arb_law(), n in arb_unit(), q in arb_rotation()) {
        let l = law.get();
        let tol = 1e-13 * law.scale();
        let p = projector(&n);
        prop_assert!(max_abs(&stress(l, &p, &n)) <= tol);
        let (g, nq) = (g_of(&q, &n), normal_of(&q, &n));
        prop_assert!(max_abs(&stress(l, &g, &nq)) <= tol);
        let inv = tension_invariants(l, &g, &nq);
        prop_assert!(inv.energy.abs() <= tol && (inv.dilation - 1.0).abs() <= 1e-14);
    }

    /// `τ` is symmetric (by construction: [`Sym`] stores one off-diagonal per pair) and in-plane:
    /// `τ n = 0` and `P τ P = τ`.
    #[test]
    fn stress_is_in_plane(law in arb_law(), s in arb_state()) {
        let (g, n) = (s.g(), s.n());
        let tau = stress(law.get(), &g, &n);
        let tol = 1e-12 * (max_abs(&tau) + law.es());
        prop_assert!(sym_mul_vec(&tau, &n).iter().all(|x| x.abs() <= tol));
        let ptp = eulermembrane::tensor::project(&projector(&n), &tau);
        prop_assert!((0..6).all(|c| (ptp[c] - tau[c]).abs() <= tol));
    }

    /// The principal tensions equal the principal-stretch formula
    /// `T_i = (2/(λ1 λ2)) (W_1 λ_i² + c2 W_2)`, with `λ1²`, `λ2²` computed independently as the
    /// eigenvalues of the 2x2 metric `C_ab = (F t_a)·(F t_b)` of an orthonormal basis
    /// `t_1, t_2` of the reference plane; the dilation equals `λ1 λ2` and `W = W(c1, c2)`.
    #[test]
    fn principal_tensions_match_principal_stretches(law in arb_law(), s in arb_state()) {
        let l = law.get();
        let nr = s.n_ref;
        let e = if nr[0].abs() < 0.6 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let t1 = unit(cross(&nr, &e));
        let t2 = cross(&nr, &t1);
        let (a, b) = (mat_vec(&s.f, &t1), mat_vec(&s.f, &t2));
        let (caa, cbb, cab) = (dot(&a, &a), dot(&b, &b), dot(&a, &b));
        let m = 0.5 * (caa + cbb);
        let r = (0.25 * (caa - cbb).powi(2) + cab * cab).sqrt();
        let (mu1, mu2) = (m + r, m - r);
        let c2 = mu1 * mu2;
        let c1 = mu1 + mu2 - 1.0;
        let [w1, w2] = l.gradient(c1, c2);
        let f = 2.0 / c2.sqrt();
        let (ta, tb) = (f * (w1 * mu1 + c2 * w2), f * (w1 * mu2 + c2 * w2));
        let (ta, tb) = (ta.max(tb), ta.min(tb));
        let inv = tension_invariants(l, &s.g(), &s.n());
        let tol = 1e-9 * (ta.abs() + tb.abs()) + 1e-12 * law.scale();
        prop_assert!((inv.t1 - ta).abs() <= tol, "T1 {} vs {}", inv.t1, ta);
        prop_assert!((inv.t2 - tb).abs() <= tol, "T2 {} vs {}", inv.t2, tb);
        prop_assert!((inv.dilation - c2.sqrt()).abs() <= 1e-12 * c2.sqrt());
        let w = l.energy(c1, c2);
        prop_assert!((inv.energy - w).abs() <= 1e-10 * (w.abs() + law.scale()));
    }

    /// The Jacobian `J'` of (2.33) equals central finite differences of `τ(G_s)` at fixed `n`,
    /// column by column (column `b` perturbs the [`Sym`] component `b`, i.e. both `G_kl` and
    /// `G_lk` for off-diagonals), to relative 1e-6 in the max norm.
    #[test]
    fn jacobian_matches_finite_differences(law in arb_law(), s in arb_state()) {
        let l = law.get();
        let (g, n) = (s.g(), s.n());
        let (tau, j) = stress_and_jacobian(l, &g, &n);
        prop_assert_eq!(tau, stress(l, &g, &n));
        prop_assert_eq!(j, jacobian(l, &g, &n));
        let jmax = j.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let h = 1e-6 * max_abs(&g);
        for b in 0..6 {
            let (mut gp, mut gm) = (g, g);
            gp[b] += h;
            gm[b] -= h;
            let (tp, tm) = (stress(l, &gp, &n), stress(l, &gm, &n));
            for a in 0..6 {
                let fd = (tp[a] - tm[a]) / (2.0 * h);
                prop_assert!(
                    (fd - j[a][b]).abs() <= 1e-6 * jmax,
                    "J[{}][{}] = {} but FD {}", a, b, j[a][b], fd
                );
            }
        }
    }

    /// Objectivity: `τ(Q G_s Qᵀ, Q n) = Q τ(G_s, n) Qᵀ` for any rotation `Q`.
    #[test]
    fn stress_is_objective(law in arb_law(), s in arb_state(), q in arb_rotation()) {
        let l = law.get();
        let (g, n) = (s.g(), s.n());
        let tau = stress(l, &g, &n);
        let tq = stress(l, &rotate(&q, &g), &mat_vec(&q, &n));
        let expect = rotate(&q, &tau);
        let tol = 1e-11 * (max_abs(&tau) + law.es());
        prop_assert!((0..6).all(|c| (tq[c] - expect[c]).abs() <= tol));
    }

    /// Power identity. Let `F(t) = (I + t L) F` (velocity gradient `L`, `L_ij = ∂v_i/∂x_j`, so
    /// `∇v = Lᵀ` in the paper's notation), `G_s(t) = F(t) P_R F(t)ᵀ`, `n(t) ∝ cof(F(t)) n_R`.
    /// Then, with `D = (L + Lᵀ)/2` and `D_s = P D P`,
    ///
    /// `d/dt W_s(c1(t), c2(t)) |_{t=0} = √c2 τ : D = √c2 τ : D_s`.
    ///
    /// Derivation: `n·F P_R = 0` (Nanson), so `G_s(t)` is in-plane and `B_s(t) = G_s(t)`;
    /// `Ġ = L G + G Lᵀ` gives `ċ1 = tr Ġ = 2 G:D` and `ċ2 = tr G tr Ġ − G:Ġ = 2 (tr G G − G²):D`;
    /// by Cayley–Hamilton in the plane, `G² − tr G G + c2 P = 0`, hence
    /// `Ẇ = 2 (W_1 G + c2 W_2 P) : D = √c2 τ : D` by (2.4). The left side is evaluated by
    /// central differences of [`energy_density`] (which projects with `P(t)` itself).
    #[test]
    fn power_identity(
        law in arb_law(),
        s in arb_state(),
        lv in [[-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0],
               [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0],
               [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0]],
    ) {
        let l = law.get();
        let w_at = |t: f64| {
            let mut a = lv;
            for (i, row) in a.iter_mut().enumerate() {
                for x in row.iter_mut() {
                    *x *= t;
                }
                row[i] += 1.0;
            }
            let ft = matmul(&a, &s.f);
            energy_density(l, &g_of(&ft, &s.n_ref), &normal_of(&ft, &s.n_ref))
        };
        let h = 1e-6;
        let fd = (w_at(h) - w_at(-h)) / (2.0 * h);
        let (g, n) = (s.g(), s.n());
        let tau = stress(l, &g, &n);
        let c2 = surface_kinematics(&g, &n).c2;
        let d = mat_to_sym(&lv);
        let ds = eulermembrane::tensor::project(&projector(&n), &d);
        let power = c2.sqrt() * ddot(&tau, &d);
        let tol = 1e-6 * c2.sqrt() * norm(&tau) * norm(&d) + 1e-8 * w_at(0.0).abs();
        prop_assert!((fd - power).abs() <= tol, "dW/dt {} vs sqrt(c2) tau:D {}", fd, power);
        // tau is in-plane, so projecting D changes nothing but round-off: two sums of products
        // of the same terms, equal to within a few eps of sum |tau_ij D_ij| <= |tau| |D|.
        let round_off = 1e-13 * c2.sqrt() * norm(&tau) * norm(&d);
        prop_assert!((c2.sqrt() * ddot(&tau, &ds) - power).abs() <= round_off + 1e-12 * power.abs());
    }

    /// `H(∇v, G_s, J)` of (B.6)–(B.7) equals the central difference of `τ` along
    /// `G_s(ε) = G_s + ε (∇vᵀ G_s + G_s ∇v)`, with `∇v[i][j] = ∂v_j/∂x_i`.
    #[test]
    fn h_matches_directional_derivative(
        law in arb_law(),
        s in arb_state(),
        gv in [[-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0],
               [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0],
               [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0]],
    ) {
        let l = law.get();
        let (g, n) = (s.g(), s.n());
        let j = jacobian(l, &g, &n);
        let h = h_tensor(&gv, &g, &j);
        let r = stretching(&gv, &g);
        // R = ∇vᵀ G + G ∇v written with full matrices.
        let gm = sym_to_mat(&g);
        let rm = mat_to_sym(&{
            let a = matmul(&transpose(&gv), &gm);
            let b = matmul(&gm, &gv);
            std::array::from_fn::<_, 3, _>(|i| std::array::from_fn::<_, 3, _>(|k| a[i][k] + b[i][k]))
        });
        prop_assert!((0..6).all(|c| (r[c] - rm[c]).abs() <= 1e-13 * (1.0 + max_abs(&rm))));
        let eps = 1e-6 * max_abs(&g) / (1e-3 + max_abs(&r));
        let (tp, tm) = (stress(l, &add(&g, &r, eps), &n), stress(l, &add(&g, &r, -eps), &n));
        let jmax = j.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let tol = 1e-6 * jmax * max_abs(&r) + 1e-12 * law.scale();
        for c in 0..6 {
            let fd = (tp[c] - tm[c]) / (2.0 * eps);
            prop_assert!((fd - h[c]).abs() <= tol, "H[{}] = {} vs FD {}", c, h[c], fd);
        }
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

fn cross(a: &Vec3<f64>, b: &Vec3<f64>) -> Vec3<f64> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

// ---------------------------------------------------------------------------------------------
// Barthès-Biesel, Diaz & Dhenin (2002): uniaxial tension T1/G_s against e1 = (λ1² − 1)/2
// ---------------------------------------------------------------------------------------------

/// Locates `shared/reference/uniaxial_stretch/<file>`: beside the checkout (CI, and the main
/// checkout), or two levels up (a git worktree under `wt/`).
fn reference_file(file: &str) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let candidates = [root.join("../shared"), root.join("shared"), root.join("../../shared")];
    for c in &candidates {
        let p = c.join("reference/uniaxial_stretch").join(file);
        if p.is_file() {
            return p;
        }
    }
    panic!("reference data {file} not found under {candidates:?} (expected shared/ beside the checkout)");
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
/// solver. Conventions (shared/reference/README.md): neo-Hookean `E_s = 3 G_s`; Skalak
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
