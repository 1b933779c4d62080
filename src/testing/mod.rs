//! Checks for membrane laws, for users' own [`SurfaceLaw`]s as for the crate's (behind the
//! `testing` feature).
//!
//! A [`SurfaceLaw`] gives the energy `W_s(c1, c2)` per unit reference area as a function of the
//! invariants (2.3) of the surface left Cauchy–Green tensor, with its gradient `[W_1, W_2]` and
//! Hessian `[W_11, W_12, W_22]` (`W_i = ∂W_s/∂c_i`); the crate derives the stress (2.4), the
//! Jacobian (2.33) and the quasi-implicit term `H` (2.35) from them. A mistake in a derivative
//! does not stop a simulation: it makes it wrong. [`check_law`] finds such mistakes:
//!
//! ```
//! use eulermembrane::membrane::law::SurfaceLaw;
//! use eulermembrane::testing::{Property, check_law};
//!
//! /// Membrane Mooney–Rivlin law (Barthès-Biesel et al. 2002), psi = 0.3, G_s = 1.
//! struct MooneyRivlin;
//! impl SurfaceLaw<f64> for MooneyRivlin {
//!     fn name(&self) -> &str { "mooney_rivlin" }
//!     fn energy(&self, c1: f64, c2: f64) -> f64 {
//!         0.5 * (0.7 * (c1 - 2.0 + 1.0 / c2) + 0.3 * ((c1 + 1.0) / c2 + c2 - 3.0))
//!     }
//!     fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] {
//!         let r = 1.0 / c2;
//!         [0.5 * (0.7 + 0.3 * r), 0.5 * (-0.7 * r * r + 0.3 * (1.0 - (c1 + 1.0) * r * r))]
//!     }
//!     fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
//!         let r = 1.0 / c2;
//!         [0.0, -0.15 * r * r, (1.0 + 0.3 * c1) * r * r * r]
//!     }
//! }
//!
//! let report = check_law(&MooneyRivlin)?;
//! assert_eq!(report.moduli, (1.0, 3.0)); // shear G_s, area modulus 3 G_s
//! let hessian = report.worst(Property::Hessian).unwrap();
//! assert!(hessian.error <= hessian.tolerance);
//! # Ok::<(), eulermembrane::testing::LawCheckError>(())
//! ```
//!
//! and names the property that fails, where and by how much:
//!
//! ```
//! # use eulermembrane::membrane::{law::NeoHookean, law::SurfaceLaw};
//! # use eulermembrane::testing::{LawCheckError, Property, check_law};
//! /// The neo-Hookean law (2.5) with a wrong power of c2 in W_22 (right at c2 = 1).
//! struct Wrong(NeoHookean<f64>);
//! impl SurfaceLaw<f64> for Wrong {
//!     fn name(&self) -> &str { "wrong" }
//!     fn energy(&self, c1: f64, c2: f64) -> f64 { self.0.energy(c1, c2) }
//!     fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] { self.0.gradient(c1, c2) }
//!     fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
//!         let [a, b, c] = self.0.hessian(c1, c2);
//!         [a, b, c * c2]
//!     }
//! }
//! match check_law(&Wrong(NeoHookean::new(3.0)?)) {
//!     Err(LawCheckError::Failed { law, measure }) => {
//!         assert_eq!((law.as_str(), measure.property), ("wrong", Property::Hessian));
//!         assert!(measure.error > 1.0, "{measure}"); // relative error |1 - c2|/c2 = 15
//!     }
//!     other => panic!("{other:?}"),
//! }
//! # Ok::<(), eulermembrane::Error>(())
//! ```
//!
//! # What is checked
//!
//! First the reference state, by [`check_stress_free`] (stress free at `G_s = P`, positive
//! small-strain moduli `μ`, `K` of [`small_strain_moduli`]). Then, at each of the 50
//! [`sample_probes`] (in-plane principal stretches in `[0.5, 2]`), every [`Property`], each as
//! a dimensionless error against its [`tolerance`](Property::tolerance). Derivatives are
//! compared with central finite differences; the errors are relative, with the modulus
//! `M = μ + K` (shear plus area-dilation modulus at small strain) as a floor of the scale, so
//! that a component that vanishes (`W_11` of (2.5)) or a stress that vanishes (at rest) is
//! measured against the stiffness of the law. The checks are in `f64`: check a law that is
//! generic over [`Real`](crate::Real) at `T = f64`.
//!
//! Tolerances were set from the worst errors of the paper's laws (2.5) and (2.6) and of the
//! membrane Mooney–Rivlin law, over these probes and 4096 random ones ([`arb_probe`]); each is
//! about ten times the worst measured or more, and far below the error of a wrong sign or
//! factor (order one). See [`Property::tolerance`] for the table. Keep `W_s(1, 1) = 0`: the
//! round-off of the differences grows with the size of the energy.
//!
//! # Property tests
//!
//! The same checks, at random probes, with [proptest](https://docs.rs/proptest): [`check_at`]
//! at an [`arb_probe`] (or [`arb_state`], [`arb_rotation`], [`arb_velocity_gradient`]), and
//! [`check_derivatives`] at any `(c1, c2)`. [`LawCheckError`] is a `std::error::Error`, which
//! proptest turns into a failing case, so `?` works in a `proptest!` body:
//!
//! ```
//! use eulermembrane::membrane::law::Skalak;
//! use eulermembrane::testing::{arb_probe, check_at, config};
//! use proptest::prelude::*;
//!
//! proptest! {
//!     #![proptest_config(config())]
//!     // In a test file, put #[test] here.
//!     fn skalak_passes(es in 0.1f64..10.0, alpha in 0.0f64..50.0, probe in arb_probe()) {
//!         check_at(&Skalak::new(es, alpha)?, &probe)?;
//!     }
//! }
//! # skalak_passes();
//! ```

mod state;
mod strategies;

use std::fmt;

pub use state::{MembraneState, Probe, SAMPLE_STRETCHES, rotation, sample_probes, sphere_point};
pub use strategies::{
    arb_probe, arb_rotation, arb_state, arb_state_with, arb_unit, arb_velocity_gradient, config,
};

use crate::Error;
use crate::membrane::law::{SurfaceLaw, check_stress_free, small_strain_moduli};
use crate::membrane::stress::{
    energy_density, h_tensor, jacobian, principal_tensions, stress, stress_and_jacobian, stretching,
    surface_kinematics, tension_invariants,
};
use crate::tensor::{
    Sym, ddot, mat_to_sym, matmul, project, projector, rotate, sym_mul_vec, sym_to_mat, transpose,
};
use state::mat_vec;

/// A property of a law that [`check_law`] measures, as a dimensionless error.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Property {
    /// The gradient `[W_1, W_2]` against fourth-order central differences of the energy (step
    /// `1e-5` times `max(1, |c1|)` and `c2`), relative to `max(|W_1|, |W_2|, M)`.
    Gradient,
    /// The Hessian against fourth-order central differences of the gradient, relative to
    /// `max(|W_11|, |W_12|, |W_22|, M)`; both `∂W_1/∂c2` and `∂W_2/∂c1` are compared with
    /// `W_12` (the gradient must be the gradient of one energy).
    Hessian,
    /// [`SurfaceLaw::derivatives`] against [`gradient`](SurfaceLaw::gradient) and
    /// [`hessian`](SurfaceLaw::hessian), and so [`stress_and_jacobian`] against [`stress()`]
    /// (relative, as above): an override of `derivatives` must agree to round-off.
    Derivatives,
    /// `τ = 0` at `G_s = P_R` and at the rigidly rotated `G_s = Q P_R Qᵀ`, `n = Q n_R`
    /// (relative to `M`), and the area ratio `√c2` there is 1.
    ReferenceState,
    /// Major symmetry of the Jacobian at the (rotated) reference state, where it is the
    /// small-strain elasticity tensor `2 W_1 (P ⊠ P) + λ_L P ⊗ P`: per tensor entry,
    /// `∂τ_ij/∂G_kl = ∂τ_kl/∂G_ij`, relative to the largest entry. (Away from the reference
    /// state `∂τ/∂G_s` is not symmetric, and is not checked for it.)
    JacobianSymmetry,
    /// `τ` in-plane: `τ n = 0`, `P τ P = τ` and `τ : D = τ : P D P`, relative to `|τ| + M`
    /// (times `|D|` for the last).
    InPlane,
    /// The principal tensions of [`tension_invariants`] against
    /// `T_i = (2/(λ1 λ2)) (W_1 λ_i² + c2 W_2)` with the principal stretches from `F`
    /// ([`MembraneState::in_plane_stretches`]), relative to `|T1| + |T2| + M`; and the area
    /// ratio `√c2` and energy `W_s(c1, c2)` there (relative to `√c2`, `|W_s| + M`).
    PrincipalTensions,
    /// The stress is the derivative of the energy: for a sheet `G_s = Q diag(λ1², λ2², 0) Qᵀ`,
    /// `T1 = (1/λ2) ∂W/∂λ1` and `T2 = (1/λ1) ∂W/∂λ2` by central differences (step `1e-6 λ_i`)
    /// of [`energy_density`], relative to `|T1| + |T2| + M`.
    EnergyDerivative,
    /// Objectivity: `τ(Q G_s Qᵀ, Q n) = Q τ(G_s, n) Qᵀ`, relative to `|τ| + M`.
    Objectivity,
    /// The Jacobian (2.33) against central differences of `τ(G_s)` at fixed `n`, column by
    /// column (step `1e-6 max|G_s|`), relative to its largest entry.
    Jacobian,
    /// Power identity `dW_s/dt = √c2 τ : D` along `F(t) = (I + t L) F`, `D = (L + Lᵀ)/2`, the
    /// left side by central differences (step `1e-6/max|L|`) of [`energy_density`], relative
    /// to `(√c2 |τ| + M) |D|`.
    PowerIdentity,
    /// `H(∇v, G_s, J)` of (2.35) against the central difference of `τ` along
    /// `G_s + ε (∇vᵀ G_s + G_s ∇v)`, relative to `max|J| max|R|`; and [`stretching`] `R`
    /// against its matrix form (relative to `max|G_s| max|∇v|`).
    HTensor,
}

impl Property {
    /// Every property, in the order of [`LawReport::worst`].
    pub const ALL: [Property; 12] = [
        Property::Gradient,
        Property::Hessian,
        Property::Derivatives,
        Property::ReferenceState,
        Property::JacobianSymmetry,
        Property::InPlane,
        Property::PrincipalTensions,
        Property::EnergyDerivative,
        Property::Objectivity,
        Property::Jacobian,
        Property::PowerIdentity,
        Property::HTensor,
    ];

    /// A short snake_case name.
    pub fn name(self) -> &'static str {
        match self {
            Property::Gradient => "gradient",
            Property::Hessian => "hessian",
            Property::Derivatives => "derivatives",
            Property::ReferenceState => "reference_state",
            Property::JacobianSymmetry => "jacobian_symmetry",
            Property::InPlane => "in_plane",
            Property::PrincipalTensions => "principal_tensions",
            Property::EnergyDerivative => "energy_derivative",
            Property::Objectivity => "objectivity",
            Property::Jacobian => "jacobian",
            Property::PowerIdentity => "power_identity",
            Property::HTensor => "h_tensor",
        }
    }

    /// The largest error accepted (dimensionless, see each variant).
    ///
    /// Each is about ten times (or more) the worst error measured for the neo-Hookean (2.5)
    /// and Skalak (2.6) laws (`E_s` in `[0.1, 10]`, `α` in `[0, 50]` and up to `10⁴`) and the
    /// membrane Mooney–Rivlin law (`ψ` in `[0, 1]`), over [`sample_probes`], 4096 random
    /// probes and 4096 random `(c1, c2)` in `[0.3, 8) × [0.1, 8)`:
    ///
    /// | property | tolerance | worst measured |
    /// |---|---|---|
    /// | gradient | 2e-9 | 6.7e-11 |
    /// | hessian | 2e-9 | 1.1e-10 |
    /// | derivatives | 1e-13 | 0 |
    /// | reference_state | 1e-14 | 8.9e-16 |
    /// | jacobian_symmetry | 1e-14 | 1.0e-15 |
    /// | in_plane | 1e-14 | 4.3e-16 |
    /// | principal_tensions | 3e-14 | 2.6e-15 |
    /// | energy_derivative | 3e-9 | 2.2e-10 |
    /// | objectivity | 3e-14 | 2.3e-15 |
    /// | jacobian | 1e-6 | 7.3e-9 (`α ≤ 50`), 9.0e-8 (`α = 10⁴`) |
    /// | power_identity | 2e-9 | 1.7e-10 |
    /// | h_tensor | 2e-7 | 4.9e-9 (`α ≤ 50`), 1.5e-8 (`α = 10⁴`) |
    ///
    /// The finite-difference errors are round-off (about `ε |f| / h`); the derivatives in
    /// `(c1, c2)` are compared with fourth-order differences so that the truncation error
    /// stays below it for laws much stiffer than these (e.g. exponential in `c1`). A mistake in
    /// a derivative (a sign, a factor) gives an error of order one.
    pub fn tolerance(self) -> f64 {
        match self {
            Property::Gradient | Property::Hessian => 2e-9,
            Property::Derivatives => 1e-13,
            Property::ReferenceState | Property::JacobianSymmetry | Property::InPlane => 1e-14,
            Property::PrincipalTensions | Property::Objectivity => 3e-14,
            Property::EnergyDerivative => 3e-9,
            Property::Jacobian => 1e-6,
            Property::PowerIdentity => 2e-9,
            Property::HTensor => 2e-7,
        }
    }
}

impl fmt::Display for Property {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One measured error: of which property, how large, against which tolerance, and where.
#[derive(Debug, Clone, PartialEq)]
pub struct Measure {
    /// The property.
    pub property: Property,
    /// The dimensionless error (see [`Property`]).
    pub error: f64,
    /// The tolerance, [`Property::tolerance`].
    pub tolerance: f64,
    /// Where: the invariants `(c1, c2)`, or the probe (state, velocity gradient, rotation).
    pub at: String,
}

impl fmt::Display for Measure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: error {:.3e} (tolerance {:.1e}) at {}",
            self.property, self.error, self.tolerance, self.at
        )
    }
}

/// What a law check measured: the worst error of each property, where it occurred.
#[derive(Debug, Clone, PartialEq)]
pub struct LawReport {
    /// The law's [`SurfaceLaw::name`].
    pub law: String,
    /// Its small-strain moduli `(μ, K)` ([`small_strain_moduli`]).
    pub moduli: (f64, f64),
    /// How many probes (or `(c1, c2)` points, for [`check_derivatives`]) were checked.
    pub points: usize,
    /// The worst error of each property checked, in the order of [`Property::ALL`].
    pub worst: Vec<Measure>,
}

impl LawReport {
    /// The worst error of `property`, if it was checked.
    pub fn worst(&self, property: Property) -> Option<&Measure> {
        self.worst.iter().find(|m| m.property == property)
    }
}

impl fmt::Display for LawReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "law `{}`: mu = {:e}, K = {:e}, {} points",
            self.law, self.moduli.0, self.moduli.1, self.points
        )?;
        for m in &self.worst {
            writeln!(f, "  {:<20} {:.3e} (tolerance {:.1e})", m.property.name(), m.error, m.tolerance)?;
        }
        Ok(())
    }
}

/// Why a law check failed.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq)]
pub enum LawCheckError {
    /// The law's reference state is refused by [`check_stress_free`] (the error names the law
    /// and the numbers), or an argument of the check is out of range.
    Invalid(Error),
    /// A property exceeds its tolerance.
    Failed {
        /// The law's [`SurfaceLaw::name`].
        law: String,
        /// The failing measurement: property, error, tolerance, where.
        measure: Measure,
    },
}

impl From<Error> for LawCheckError {
    fn from(e: Error) -> Self {
        LawCheckError::Invalid(e)
    }
}

/// So that `check_law(&law)?` works in a function returning the crate's [`Result`](crate::Result):
/// a refused argument stays the [`Error`] it was, a failed property becomes [`Error::User`]
/// with this error's message.
impl From<LawCheckError> for Error {
    fn from(e: LawCheckError) -> Self {
        match e {
            LawCheckError::Invalid(e) => e,
            failed @ LawCheckError::Failed { .. } => Error::user(failed.to_string()),
        }
    }
}

impl fmt::Display for LawCheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LawCheckError::Invalid(e) => e.fmt(f),
            LawCheckError::Failed { law, measure } => write!(f, "law `{law}` fails {measure}"),
        }
    }
}

impl std::error::Error for LawCheckError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            LawCheckError::Invalid(e) => Some(e),
            LawCheckError::Failed { .. } => None,
        }
    }
}

/// Checks a law at its reference state and at the 50 [`sample_probes`]: every [`Property`].
///
/// # Errors
/// [`LawCheckError::Invalid`] if [`check_stress_free`] refuses the law;
/// [`LawCheckError::Failed`] with the first property found beyond its tolerance.
pub fn check_law<L: SurfaceLaw<f64> + ?Sized>(law: &L) -> Result<LawReport, LawCheckError> {
    let mut c = Checker::new(law)?;
    for p in &sample_probes() {
        c.probe(p)?;
    }
    Ok(c.finish())
}

/// Checks a law at its reference state and at one probe (e.g. from [`arb_probe`]): every
/// [`Property`].
///
/// # Errors
/// As [`check_law`].
pub fn check_at<L: SurfaceLaw<f64> + ?Sized>(law: &L, probe: &Probe) -> Result<LawReport, LawCheckError> {
    let mut c = Checker::new(law)?;
    c.probe(probe)?;
    Ok(c.finish())
}

/// Checks a law at its reference state, and its derivatives at one point `(c1, c2)`:
/// [`Property::Gradient`], [`Property::Hessian`], [`Property::Derivatives`]. The point need not
/// come from real stretches.
///
/// # Errors
/// [`LawCheckError::Invalid`] naming `c1` unless it is finite, or `c2` unless it is finite and
/// `> 0`; otherwise as [`check_law`].
///
/// # Example
/// ```
/// use eulermembrane::membrane::law::NeoHookean;
/// use eulermembrane::testing::{Property, check_derivatives};
///
/// let report = check_derivatives(&NeoHookean::new(3.0)?, 2.5, 0.3)?;
/// assert!(report.worst(Property::Gradient).unwrap().error < 1e-8);
/// assert!(check_derivatives(&NeoHookean::new(3.0)?, 2.5, 0.0).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn check_derivatives<L: SurfaceLaw<f64> + ?Sized>(
    law: &L,
    c1: f64,
    c2: f64,
) -> Result<LawReport, LawCheckError> {
    crate::error::finite("c1", c1)?;
    crate::error::positive("c2", c2)?;
    let mut c = Checker::new(law)?;
    c.derivatives(c1, c2)?;
    c.points += 1;
    Ok(c.finish())
}

/// Relative step of the finite differences in `(c1, c2)`.
const STEP_C: f64 = 1e-5;
/// Relative step of the finite differences in `G_s`, stretches and time.
const STEP: f64 = 1e-6;

fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn norm(a: &Sym<f64>) -> f64 {
    ddot(a, a).sqrt()
}

/// `num / den`, with `0 / 0 = 0` (an exact zero is no error).
fn rel(num: f64, den: f64) -> f64 {
    if num == 0.0 { 0.0 } else { num / den }
}

/// Per-tensor-entry weights of the [`Sym`] components (see [`crate::membrane::stress::stress`]).
const SYM_WEIGHT: [f64; 6] = [1.0, 1.0, 1.0, 2.0, 2.0, 2.0];

struct Checker<'a, L: ?Sized> {
    law: &'a L,
    /// The modulus scale `M = μ + K`.
    m: f64,
    moduli: (f64, f64),
    points: usize,
    worst: [Option<Measure>; 12],
}

impl<'a, L: SurfaceLaw<f64> + ?Sized> Checker<'a, L> {
    fn new(law: &'a L) -> Result<Self, LawCheckError> {
        check_stress_free(law)?;
        let moduli = small_strain_moduli(law);
        Ok(Self { law, m: moduli.0 + moduli.1, moduli, points: 0, worst: Default::default() })
    }

    fn finish(self) -> LawReport {
        LawReport {
            law: self.law.name().to_string(),
            moduli: self.moduli,
            points: self.points,
            worst: self.worst.into_iter().flatten().collect(),
        }
    }

    /// Records `error` for `property`; fails beyond the tolerance (a NaN fails too).
    fn record(
        &mut self,
        property: Property,
        error: f64,
        at: &dyn Fn() -> String,
    ) -> Result<(), LawCheckError> {
        let tolerance = property.tolerance();
        let measure = || Measure { property, error, tolerance, at: at() };
        if matches!(error.partial_cmp(&tolerance), None | Some(std::cmp::Ordering::Greater)) {
            return Err(LawCheckError::Failed { law: self.law.name().to_string(), measure: measure() });
        }
        let slot = &mut self.worst[property as usize];
        if slot.as_ref().is_none_or(|m| error > m.error) {
            *slot = Some(measure());
        }
        Ok(())
    }

    fn derivatives(&mut self, c1: f64, c2: f64) -> Result<(), LawCheckError> {
        let law = self.law;
        let at = || format!("(c1, c2) = ({c1:e}, {c2:e})");
        let (h1, h2) = (STEP_C * c1.abs().max(1.0), STEP_C * c2);
        let w = |a, b| law.energy(a, b);
        let g = |a, b| law.gradient(a, b);
        let [w1, w2] = g(c1, c2);
        let [w11, w12, w22] = law.hessian(c1, c2);
        let gs = max_abs(&[w1, w2]).max(self.m);
        let hs = max_abs(&[w11, w12, w22]).max(self.m);

        // Fourth-order central differences: (8 (f(x+h) - f(x-h)) - (f(x+2h) - f(x-2h))) / (12 h).
        let fd =
            |f: &dyn Fn(f64) -> f64, h: f64| (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h);
        let fd1 = fd(&|e| w(c1 + e, c2), h1);
        let fd2 = fd(&|e| w(c1, c2 + e), h2);
        self.record(Property::Gradient, max_abs(&[w1 - fd1, w2 - fd2]) / gs, &at)?;

        let d1: [f64; 2] = std::array::from_fn(|i| fd(&|e| g(c1 + e, c2)[i], h1));
        let d2: [f64; 2] = std::array::from_fn(|i| fd(&|e| g(c1, c2 + e)[i], h2));
        let err = max_abs(&[w11 - d1[0], w12 - d1[1], w12 - d2[0], w22 - d2[1]]) / hs;
        self.record(Property::Hessian, err, &at)?;

        let ([v1, v2], [v11, v12, v22]) = law.derivatives(c1, c2);
        let err = (max_abs(&[v1 - w1, v2 - w2]) / gs).max(max_abs(&[v11 - w11, v12 - w12, v22 - w22]) / hs);
        self.record(Property::Derivatives, err, &at)
    }

    fn probe(&mut self, p: &Probe) -> Result<(), LawCheckError> {
        let (law, m) = (self.law, self.m);
        let at = || p.to_string();
        let s = &p.state;
        let (g, n) = (s.g(), s.n());
        let kin = surface_kinematics(&g, &n);
        self.derivatives(kin.c1, kin.c2)?;
        self.points += 1;
        let q = p.rotation;
        let tau = stress(law, &g, &n);
        let tau_max = max_abs(&tau);

        // Reference state, as given and rigidly rotated; the Jacobian's symmetry there.
        let nr = s.n_ref();
        let rigid = MembraneState::from_parts(q, nr);
        let (tau_r, j_r) = stress_and_jacobian(law, &rigid.g(), &rigid.n());
        let tau_p = stress(law, &projector(&nr), &nr);
        let dilation = surface_kinematics(&rigid.g(), &rigid.n()).c2.sqrt();
        let err = (max_abs(&tau_r).max(max_abs(&tau_p)) / m).max((dilation - 1.0).abs());
        self.record(Property::ReferenceState, err, &at)?;
        let per_entry: [[f64; 6]; 6] =
            std::array::from_fn(|a| std::array::from_fn(|b| j_r[a][b] / SYM_WEIGHT[b]));
        let asym: Vec<f64> = (0..36).map(|k| per_entry[k / 6][k % 6] - per_entry[k % 6][k / 6]).collect();
        self.record(Property::JacobianSymmetry, rel(max_abs(&asym), max_abs(per_entry.as_flattened())), &at)?;

        // In-plane stress, also as seen by the power.
        let l = transpose(&p.grad_v);
        let d = mat_to_sym(&l);
        let pn = projector(&n);
        let ptp = project(&pn, &tau);
        let tn = sym_mul_vec(&tau, &n);
        let off: Vec<f64> = tn.iter().copied().chain((0..6).map(|c| ptp[c] - tau[c])).collect();
        let power_off = ddot(&tau, &project(&pn, &d)) - ddot(&tau, &d);
        let err = (max_abs(&off) / (tau_max + m)).max(rel(power_off.abs(), (norm(&tau) + m) * norm(&d)));
        self.record(Property::InPlane, err, &at)?;

        // Principal tensions from the principal stretches of F.
        let (l1, l2) = s.in_plane_stretches();
        let (m1, m2) = (l1 * l1, l2 * l2);
        let (c1, c2) = (m1 + m2 - 1.0, m1 * m2);
        let [w1, w2] = law.gradient(c1, c2);
        let f = 2.0 / c2.sqrt();
        let (ta, tb) = (f * (w1 * m1 + c2 * w2), f * (w1 * m2 + c2 * w2));
        let (ta, tb) = (ta.max(tb), ta.min(tb));
        let inv = tension_invariants(law, &g, &n);
        let w = law.energy(c1, c2);
        let err = (max_abs(&[inv.t1 - ta, inv.t2 - tb]) / (ta.abs() + tb.abs() + m))
            .max((inv.dilation - c2.sqrt()).abs() / c2.sqrt())
            .max((inv.energy - w).abs() / (w.abs() + m));
        self.record(Property::PrincipalTensions, err, &at)?;

        // The tensions of a rotated sheet are derivatives of its energy.
        let sheet = |a: f64, b: f64| {
            let dg = [[a * a, 0.0, 0.0], [0.0, b * b, 0.0], [0.0; 3]];
            (mat_to_sym(&matmul(&matmul(&q, &dg), &transpose(&q))), [q[0][2], q[1][2], q[2][2]])
        };
        let w_sheet = |a, b| {
            let (gs, ns) = sheet(a, b);
            energy_density(law, &gs, &ns)
        };
        let (h1, h2) = (STEP * l1, STEP * l2);
        let t1 = (w_sheet(l1 + h1, l2) - w_sheet(l1 - h1, l2)) / (2.0 * h1) / l2;
        let t2 = (w_sheet(l1, l2 + h2) - w_sheet(l1, l2 - h2)) / (2.0 * h2) / l1;
        let (gs, ns) = sheet(l1, l2);
        let tau_s = stress(law, &gs, &ns);
        let (sa, sb) = principal_tensions(&tau_s, &ns);
        let e1e1 = mat_to_sym(&matmul(&matmul(&q, &[[1.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]), &transpose(&q)));
        let err = max_abs(&[sa - t1.max(t2), sb - t1.min(t2), ddot(&tau_s, &e1e1) - t1])
            / (sa.abs() + sb.abs() + m);
        self.record(Property::EnergyDerivative, err, &at)?;

        // Objectivity.
        let tq = stress(law, &rotate(&q, &g), &mat_vec(&q, &n));
        let expect = rotate(&q, &tau);
        let diff: Vec<f64> = (0..6).map(|c| tq[c] - expect[c]).collect();
        self.record(Property::Objectivity, max_abs(&diff) / (tau_max + m), &at)?;

        // Jacobian against finite differences of the stress.
        let (tau2, j) = stress_and_jacobian(law, &g, &n);
        let diff: Vec<f64> = (0..6).map(|c| tau2[c] - tau[c]).collect();
        let j_other = jacobian(law, &g, &n);
        let jdiff: Vec<f64> = (0..36).map(|k| j_other[k / 6][k % 6] - j[k / 6][k % 6]).collect();
        let jmax = max_abs(j.as_flattened());
        self.record(
            Property::Derivatives,
            (max_abs(&diff) / (tau_max + m)).max(rel(max_abs(&jdiff), jmax)),
            &at,
        )?;
        let h = STEP * max_abs(&g);
        let mut worst = 0.0f64;
        for b in 0..6 {
            let (mut gp, mut gm) = (g, g);
            gp[b] += h;
            gm[b] -= h;
            let (tp, tm) = (stress(law, &gp, &n), stress(law, &gm, &n));
            for a in 0..6 {
                worst = worst.max(((tp[a] - tm[a]) / (2.0 * h) - j[a][b]).abs());
            }
        }
        self.record(Property::Jacobian, rel(worst, jmax), &at)?;

        // Power identity dW/dt = √c2 τ : D along F(t) = (I + t L) F.
        let lmax = max_abs(l.as_flattened());
        if lmax > 0.0 {
            let ht = STEP / lmax;
            let w_at = |t: f64| {
                let a: [[f64; 3]; 3] = std::array::from_fn(|i| {
                    std::array::from_fn(|k| t * l[i][k] + if i == k { 1.0 } else { 0.0 })
                });
                let st = s.then(&a);
                energy_density(law, &st.g(), &st.n())
            };
            let fd = (w_at(ht) - w_at(-ht)) / (2.0 * ht);
            let sc2 = kin.c2.sqrt();
            let power = sc2 * ddot(&tau, &d);
            self.record(
                Property::PowerIdentity,
                (fd - power).abs() / ((sc2 * norm(&tau) + m) * norm(&d)),
                &at,
            )?;
        }

        // H against the directional derivative of τ, and R against its matrix form.
        let gv = p.grad_v;
        let hh = h_tensor(&gv, &g, &j);
        let r = stretching(&gv, &g);
        let gm = sym_to_mat(&g);
        let rm = {
            let (a, b) = (matmul(&transpose(&gv), &gm), matmul(&gm, &gv));
            mat_to_sym(&std::array::from_fn(|i| std::array::from_fn(|k| a[i][k] + b[i][k])))
        };
        let rdiff: Vec<f64> = (0..6).map(|c| r[c] - rm[c]).collect();
        let err_r = rel(max_abs(&rdiff), max_abs(&g) * max_abs(gv.as_flattened()));
        let rmax = max_abs(&r);
        let eps = STEP * max_abs(&g) / (1e-3 + rmax);
        let shifted = |e: f64| -> Sym<f64> { std::array::from_fn(|c| g[c] + e * r[c]) };
        let (tp, tm) = (stress(law, &shifted(eps), &n), stress(law, &shifted(-eps), &n));
        let hdiff: Vec<f64> = (0..6).map(|c| (tp[c] - tm[c]) / (2.0 * eps) - hh[c]).collect();
        self.record(Property::HTensor, rel(max_abs(&hdiff), jmax * rmax).max(err_r), &at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::membrane::law::{NeoHookean, Skalak};

    /// The neo-Hookean law (2.5) with one derivative changed.
    struct Broken {
        nh: NeoHookean<f64>,
        gradient_factor: f64,
        hessian_power: bool,
        override_derivatives: bool,
    }

    impl Broken {
        fn new() -> Self {
            Self {
                nh: NeoHookean::new(3.0).unwrap(),
                gradient_factor: 1.0,
                hessian_power: false,
                override_derivatives: false,
            }
        }
    }

    impl SurfaceLaw<f64> for Broken {
        fn name(&self) -> &str {
            "broken"
        }
        fn energy(&self, c1: f64, c2: f64) -> f64 {
            self.nh.energy(c1, c2)
        }
        fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] {
            let [a, b] = self.nh.gradient(c1, c2);
            // A wrong factor away from the reference state only (stress free, same moduli).
            [a, b * (1.0 + (self.gradient_factor - 1.0) * (c2 - 1.0).powi(2))]
        }
        fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
            // W_22 = E_s/(3 c2³), or with a wrong power of c2.
            let [a, b, c] = self.nh.hessian(c1, c2);
            [a, b, if self.hessian_power { c * c2 } else { c }]
        }
        fn derivatives(&self, c1: f64, c2: f64) -> ([f64; 2], [f64; 3]) {
            let (g, [a, b, c]) = (self.gradient(c1, c2), self.hessian(c1, c2));
            if self.override_derivatives { (g, [a, b + 1e-3, c]) } else { (g, [a, b, c]) }
        }
    }

    fn failed(r: Result<LawReport, LawCheckError>) -> (String, Measure) {
        match r {
            Err(LawCheckError::Failed { law, measure }) => (law, measure),
            other => panic!("expected a failed property, got {other:?}"),
        }
    }

    #[test]
    fn paper_laws_pass_every_property_at_every_probe() {
        let laws: [Box<dyn SurfaceLaw<f64>>; 5] = [
            Box::new(NeoHookean::new(0.1).unwrap()),
            Box::new(NeoHookean::new(10.0).unwrap()),
            Box::new(Skalak::new(2.0, 0.0).unwrap()),
            Box::new(Skalak::new(0.1, 50.0).unwrap()),
            Box::new(Skalak::new(1.0, 1e4).unwrap()),
        ];
        for law in &laws {
            let report = check_law(law).unwrap();
            assert_eq!(report.points, 50);
            assert_eq!(report.law, law.name());
            let props: Vec<Property> = report.worst.iter().map(|m| m.property).collect();
            assert_eq!(props, Property::ALL);
            for m in &report.worst {
                assert!(m.error <= m.tolerance && m.tolerance == m.property.tolerance(), "{m}");
            }
            let text = report.to_string();
            assert!(text.contains("h_tensor") && text.contains(law.name()), "{text}");
        }
        let (mu, k) = check_law(&NeoHookean::new(3.0).unwrap()).unwrap().moduli;
        assert!((mu - 1.0).abs() < 1e-15 && (k - 3.0).abs() < 1e-15);
    }

    #[test]
    fn a_failed_check_converts_into_the_crate_error() {
        fn checked(law: &dyn SurfaceLaw<f64>) -> crate::Result<(f64, f64)> {
            Ok(check_law(law)?.moduli)
        }
        let mut law = Broken::new();
        law.gradient_factor = 1.01;
        let e = checked(&law).unwrap_err();
        assert!(matches!(e, Error::User { .. }), "{e:?}");
        assert!(e.to_string().starts_with("law `broken` fails gradient: error"), "{e}");
        let (mu, k) = checked(&NeoHookean::new(3.0).unwrap()).unwrap();
        assert!((mu - 1.0).abs() < 1e-15 && (k - 3.0).abs() < 1e-15);
        // A refused argument stays the error it was.
        let bad = Error::invalid("E_s", "-1", "a finite number > 0");
        assert_eq!(Error::from(LawCheckError::Invalid(bad.clone())), bad);
        // And an I/O error through `?` keeps its message.
        let io: Error = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file").into();
        assert_eq!(io.to_string(), "I/O error: no such file");
    }

    #[test]
    fn wrong_laws_are_refused_naming_the_property() {
        let mut law = Broken::new();
        law.hessian_power = true;
        let (name, m) = failed(check_law(&law));
        assert_eq!((name.as_str(), m.property), ("broken", Property::Hessian));
        // c2 W_22 against W_22 at the first probe, c2 = 1/16: relative to the (wrong) value
        // returned, the error is (1 - c2)/c2 = 15.
        assert!((m.error - 15.0).abs() < 1e-6, "{m}");
        assert!(m.at.starts_with("(c1, c2) = ("), "{m}");

        let mut law = Broken::new();
        law.gradient_factor = 1.01;
        let e = check_law(&law).unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with("law `broken` fails gradient: error"), "{text}");
        assert!(text.contains("tolerance 2.0e-9"), "{text}");

        let mut law = Broken::new();
        law.override_derivatives = true;
        assert_eq!(failed(check_law(&law)).1.property, Property::Derivatives);

        // Not stress free: refused by check_stress_free before any probe.
        struct Tense;
        impl SurfaceLaw<f64> for Tense {
            fn name(&self) -> &str {
                "tense"
            }
            fn energy(&self, c1: f64, c2: f64) -> f64 {
                c1 + 0.5 * c2 * c2
            }
            fn gradient(&self, _c1: f64, c2: f64) -> [f64; 2] {
                [1.0, c2]
            }
            fn hessian(&self, _c1: f64, _c2: f64) -> [f64; 3] {
                [0.0, 0.0, 1.0]
            }
        }
        match check_law(&Tense) {
            Err(LawCheckError::Invalid(Error::InvalidParameter { name, value, allowed })) => {
                assert_eq!(name, "law");
                assert!(value.contains("`tense`") && allowed.contains("stress free"), "{value} {allowed}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn check_derivatives_validates_its_point() {
        let nh = NeoHookean::new(1.0).unwrap();
        let report = check_derivatives(&nh, 0.4, 6.0).unwrap();
        assert_eq!((report.points, report.worst.len()), (1, 3));
        for (c1, c2, name) in
            [(f64::NAN, 1.0, "c1"), (1.0, 0.0, "c2"), (1.0, -1.0, "c2"), (1.0, f64::INFINITY, "c2")]
        {
            match check_derivatives(&nh, c1, c2) {
                Err(LawCheckError::Invalid(Error::InvalidParameter { name: n, .. })) => assert_eq!(n, name),
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn sample_probes_are_fixed_and_span_the_stretches() {
        let probes = sample_probes();
        assert_eq!(probes, sample_probes());
        assert_eq!(probes.len(), 50);
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for p in &probes {
            let (l1, l2) = p.state.in_plane_stretches();
            (lo, hi) = (lo.min(l2), hi.max(l1));
            assert!(l2 >= 0.5 - 1e-12 && l1 <= 2.0 + 1e-12, "{p}");
        }
        assert!((lo - 0.5).abs() < 1e-12 && (hi - 2.0).abs() < 1e-12);
        // The aligned probe of (1, 1) is a rigid rotation: G_s = n-projector.
        let rigid = &probes[2 * (2 * 5 + 2)].state;
        let p = projector(&rigid.n());
        assert!((0..6).all(|c| (rigid.g()[c] - p[c]).abs() < 1e-15));
    }

    #[test]
    fn membrane_state_refuses_bad_input() {
        let id = rotation([0.0, 0.0, 1.0], 0.0);
        assert!(MembraneState::new(id, [0.0, 0.0, 1.0]).is_ok());
        let name = |r: crate::Result<MembraneState>| match r {
            Err(Error::InvalidParameter { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        assert_eq!(name(MembraneState::new(id, [0.0, 0.0, 2.0])), "n_ref");
        assert_eq!(name(MembraneState::new(id, [f64::NAN, 0.0, 1.0])), "n_ref");
        // Flattens the reference plane onto a line.
        assert_eq!(name(MembraneState::stretched(id, [1.0, 0.0, 1.0], id, [0.0, 0.0, 1.0])), "f");
        assert_eq!(name(MembraneState::stretched(id, [1.0, f64::INFINITY, 1.0], id, [0.0, 0.0, 1.0])), "f");
    }
}
