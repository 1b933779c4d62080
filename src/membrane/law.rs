//! Surface strain-energy laws W_s(c1, c2): eqs (2.3), (2.5), (2.6).
//!
//! A hyperelastic membrane is described by its strain energy per unit *reference* area,
//! `W_s(c1, c2)`, a function of the two invariants of the surface left Cauchy–Green tensor
//! `B_s` (eq. (2.3)):
//!
//! ```text
//! c1 = tr(B_s) − 1                      = λ1² + λ2² − 1      (= I1 + 1)
//! c2 = ½ (tr(B_s)² − tr(B_s²))          = λ1² λ2²           (= I2 + 1 = J_s²)
//! ```
//!
//! where `λ1, λ2` are the principal in-plane stretches and `J_s = λ1 λ2 = √c2` is the ratio of
//! current to reference area. The stress (2.4) and its Jacobian (App. B) need only the first and
//! second partial derivatives of `W_s`; they are computed once, generically, in
//! [`super::stress`](mod@super::stress). A new law therefore implements [`SurfaceLaw`] — the energy, its gradient
//! and its Hessian in `(c1, c2)` — and gets the stress, the Jacobian, the quasi-implicit term
//! `H` and the simple-loading solvers of [`super::loading`] for free.
//!
//! Two laws of the paper are provided:
//! - [`NeoHookean`], eq. (2.5): `W_s = (E_s/6)(c1 + 1/c2 − 2)`, the Eggleton & Popel
//!   (thin-sheet, volume-conserving) neo-Hookean membrane with shear modulus `G_s = E_s/3`;
//! - [`Skalak`], eq. (2.6): `W_s = (E_s/8)(c1² + α c2² − 2(α+1) c2 + α + 1)`, with shear
//!   modulus `G_s = E_s/2` and area-dilation parameter `α`.
//!
//! Relation to the usual Skalak form. With `I1 = c1 − 1`, `I2 = c2 − 1`,
//! `I1² + 2 I1 − 2 I2 + C I2² = c1² − 1 − 2 c2 + 2 + C (c2² − 2 c2 + 1)
//! = c1² + C c2² − 2 (C + 1) c2 + C + 1`, so (2.6) is exactly
//! `(G_s/4)(I1² + 2 I1 − 2 I2 + C I2²)` with `G_s = E_s/2` and **`α = C`**: the
//! area-dilation coefficient `C = 1` of Barthès-Biesel et al. (2002) is `α = 1`.
//!
//! Small-strain moduli (see [`small_strain_moduli`]): linearising (2.4) about `B_s = P`
//! gives the planar Hooke law `τ = 2 μ ε + λ_L tr(ε) P` with
//! `μ = 2 W_1` and area-dilation modulus `K = μ + λ_L = 4 (W_11 + 2 W_12 + W_22) − 2 W_1`,
//! all derivatives at `(c1, c2) = (1, 1)`, provided the reference state is stress free,
//! `W_1 + W_2 = 0` there. Neo-Hookean: `μ = E_s/3`, `K = E_s = 3 μ`. Skalak:
//! `μ = E_s/2`, `K = μ (1 + 2α)`.

use std::sync::Arc;

use crate::Real;
use crate::error::{Error, Result, positive};
use crate::tensor::projector;

/// A hyperelastic surface (membrane) strain-energy law `W_s(c1, c2)`.
///
/// `W_s` is the strain energy per unit **reference** area; `c1`, `c2` are the invariants (2.3)
/// (see the [module docs](self)). Implementors provide the energy and its first and second
/// partial derivatives; everything else (stress (2.4), Jacobian (B.1)–(B.5), `H` (B.6), the
/// simple-loading solvers) is derived from them. The mixed derivative `W_c1c2` is used in
/// general (the paper's (B.4) assumes it vanishes, which holds for (2.5) and (2.6) only).
///
/// Requirements for a physically meaningful law (not checked by the trait; checked by
/// [`check_stress_free`], and with the derivatives against finite differences by
/// `eulermembrane::testing::check_law` behind the `testing` feature):
/// - stress-free reference state: `W_c1(1, 1) + W_c2(1, 1) = 0`
///   (otherwise `τ ≠ 0` at `G_s = P`);
/// - positive small-strain shear and area moduli (see [`small_strain_moduli`]).
///
/// The trait is implemented for `&L`, `Box<L>` and `Arc<L>` of any law `L` (also
/// `dyn SurfaceLaw<T>`), so that a boxed or shared law can be passed where a law is expected.
///
/// The derivatives are called only with `c2 > 0`. Implementations must not panic.
///
/// # Example: a user law
///
/// ```
/// use eulermembrane::membrane::law::{SurfaceLaw, small_strain_moduli};
///
/// /// Area-only law W = (K/2)(√c2 − 1)² plus a neo-Hookean shear part.
/// struct MyLaw { es: f64, k: f64 }
///
/// impl SurfaceLaw<f64> for MyLaw {
///     fn name(&self) -> &str { "my_law" }
///     fn energy(&self, c1: f64, c2: f64) -> f64 {
///         self.es / 6.0 * (c1 + 1.0 / c2 - 2.0) + 0.5 * self.k * (c2.sqrt() - 1.0).powi(2)
///     }
///     fn gradient(&self, _c1: f64, c2: f64) -> [f64; 2] {
///         let s = c2.sqrt();
///         [self.es / 6.0, -self.es / (6.0 * c2 * c2) + 0.5 * self.k * (s - 1.0) / s]
///     }
///     fn hessian(&self, _c1: f64, c2: f64) -> [f64; 3] {
///         let s = c2.sqrt();
///         [0.0, 0.0, self.es / (3.0 * c2 * c2 * c2) + 0.25 * self.k / (c2 * s)]
///     }
/// }
///
/// let law = MyLaw { es: 3.0, k: 2.0 };
/// let (shear, area) = small_strain_moduli(&law);
/// assert!((shear - 1.0).abs() < 1e-14);         // G_s = E_s / 3
/// assert!((area - (3.0 + 2.0)).abs() < 1e-14);  // E_s + K
/// ```
pub trait SurfaceLaw<T: Real>: Send + Sync {
    /// A short snake_case name for output (e.g. `"neo_hookean"`).
    fn name(&self) -> &str;

    /// Strain energy per unit reference area, `W_s(c1, c2)`.
    fn energy(&self, c1: T, c2: T) -> T;

    /// First derivatives `[∂W/∂c1, ∂W/∂c2]` (the `W_{s,c1}`, `W_{s,c2}` of (B.5)).
    fn gradient(&self, c1: T, c2: T) -> [T; 2];

    /// Second derivatives `[∂²W/∂c1², ∂²W/∂c1∂c2, ∂²W/∂c2²]`.
    fn hessian(&self, c1: T, c2: T) -> [T; 3];

    /// Gradient and Hessian together. The default calls [`gradient`](Self::gradient) and
    /// [`hessian`](Self::hessian); override it when the two share expensive sub-expressions.
    #[inline]
    fn derivatives(&self, c1: T, c2: T) -> ([T; 2], [T; 3]) {
        (self.gradient(c1, c2), self.hessian(c1, c2))
    }
}

/// Small-strain moduli `(μ, K)` of a law: the planar shear modulus `μ = 2 W_1` and the
/// area-dilation modulus `K = 4 (W_11 + 2 W_12 + W_22) − 2 W_1`, derivatives taken at the
/// reference state `(c1, c2) = (1, 1)`.
///
/// Derivation: about `B_s = P`, with in-plane strain `ε` (`B_s ≈ P + 2ε`), one has
/// `dc1 = dc2 = 2 tr ε`, and (2.4) linearises to `τ = 4 W_1 ε + 4 (W_11 + 2 W_12 + W_22 − W_1)
/// tr(ε) P` when `W_1 + W_2 = 0`, i.e. `μ = 2 W_1` and `λ_L = 4 (W_11 + 2 W_12 + W_22 − W_1)`;
/// an isotropic tension then reads `T = K ΔA/A` with `K = μ + λ_L`. The reference state is
/// stable iff `μ > 0` and `K > 0`.
pub fn small_strain_moduli<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L) -> (T, T) {
    let one = T::one();
    let ([w1, _], [w11, w12, w22]) = law.derivatives(one, one);
    let two = T::lit(2.0);
    let four = T::lit(4.0);
    (two * w1, four * (w11 + two * w12 + w22) - two * w1)
}

/// Relative tolerance of [`check_stress_free`] on the stress at rest, in machine epsilons:
/// `|W_1 + W_2| ≤ 256 ε (|W_1| + |W_2|)` at `(c1, c2) = (1, 1)` (f64: 5.7e-14; f32: 3.1e-5).
/// The paper's laws give exactly zero; a law with a mistake gives a residual of order one.
const STRESS_FREE_EPS: f64 = 256.0;

/// Refuses a law whose reference state is not a stable, stress-free state: a cheap check (one
/// evaluation of the derivatives), for wherever a law is accepted, e.g. when a scene is built.
///
/// Checks, at the reference state `(c1, c2) = (1, 1)` (`G_s = P`, no deformation):
/// - the gradient and Hessian are finite;
/// - the stress (2.4) at `G_s = P`, computed by [`stress`](super::stress::stress), which is
///   `τ = 2 (W_1 + W_2) P`, vanishes: `|W_1 + W_2| ≤ 256 ε (|W_1| + |W_2|)` (round-off only;
///   `ε` the machine epsilon of `T`);
/// - the small-strain moduli of [`small_strain_moduli`] are positive: shear `μ = 2 W_1 > 0` and
///   area dilation `K > 0` (otherwise the reference state is unstable).
///
/// It does not check the derivatives against the energy: `eulermembrane::testing::check_law`
/// (feature `testing`) does.
///
/// # Errors
/// [`Error::InvalidParameter`] with name `"law"`, a value that names the law (its
/// [`SurfaceLaw::name`]) and the offending numbers, and the requirement as allowed.
///
/// # Example
/// ```
/// use eulermembrane::membrane::law::{NeoHookean, SurfaceLaw, check_stress_free};
///
/// assert!(check_stress_free(&NeoHookean::new(3.0)?).is_ok());
///
/// /// A neo-Hookean law with a sign error in W_2: under tension at rest.
/// struct Wrong;
/// impl SurfaceLaw<f64> for Wrong {
///     fn name(&self) -> &str { "wrong" }
///     fn energy(&self, c1: f64, c2: f64) -> f64 { 0.5 * (c1 - 1.0 / c2 - 2.0) }
///     fn gradient(&self, _c1: f64, c2: f64) -> [f64; 2] { [0.5, 0.5 / (c2 * c2)] }
///     fn hessian(&self, _c1: f64, c2: f64) -> [f64; 3] { [0.0, 0.0, -1.0 / (c2 * c2 * c2)] }
/// }
/// let e = check_stress_free(&Wrong).unwrap_err().to_string();
/// assert!(e.contains("`law`") && e.contains("`wrong`") && e.contains("stress free"), "{e}");
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn check_stress_free<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L) -> Result<()> {
    let one = T::one();
    let ([w1, w2], [w11, w12, w22]) = law.derivatives(one, one);
    if ![w1, w2, w11, w12, w22].iter().all(|x| x.is_finite()) {
        return Err(Error::invalid(
            "law",
            format!(
                "`{}` with gradient [{w1:e}, {w2:e}] and Hessian [{w11:e}, {w12:e}, {w22:e}] at \
                 (c1, c2) = (1, 1)",
                law.name()
            ),
            "a law with finite first and second derivatives at the reference state (c1, c2) = (1, 1)",
        ));
    }
    // The reference state G_s = P of a flat sheet with normal e3: τ = 2 (W_1 + W_2) P.
    let n = [T::zero(), T::zero(), one];
    let tension = super::stress::stress(law, &projector(&n), &n)[0];
    let terms = T::lit(2.0) * (w1.abs() + w2.abs());
    // A NaN residual is refused too.
    let bound = T::lit(STRESS_FREE_EPS) * T::eps() * terms;
    if matches!(tension.abs().partial_cmp(&bound), None | Some(std::cmp::Ordering::Greater)) {
        return Err(Error::invalid(
            "law",
            format!(
                "`{}` with stress tau = {tension:e} P at rest (tau = 2 (W_1 + W_2) P, \
                 W_1 = {w1:e}, W_2 = {w2:e} at (c1, c2) = (1, 1))",
                law.name()
            ),
            "a law whose reference state G_s = P is stress free: W_1 + W_2 = 0 at (c1, c2) = (1, 1), \
             to 256 machine epsilons of |W_1| + |W_2|",
        ));
    }
    let (mu, k) = small_strain_moduli(law);
    if !(mu > T::zero() && k > T::zero()) {
        return Err(Error::invalid(
            "law",
            format!(
                "`{}` with small-strain shear modulus mu = {mu:e} and area modulus K = {k:e}",
                law.name()
            ),
            "a law with a stable reference state: mu = 2 W_1 > 0 and K = 4 (W_11 + 2 W_12 + W_22) - 2 W_1 > 0 \
             at (c1, c2) = (1, 1)",
        ));
    }
    Ok(())
}

/// Forwards every method, the overridable [`SurfaceLaw::derivatives`] included.
macro_rules! forward_surface_law {
    ($($ptr:ty),*) => {$(
        impl<T: Real, L: SurfaceLaw<T> + ?Sized> SurfaceLaw<T> for $ptr {
            fn name(&self) -> &str {
                (**self).name()
            }
            #[inline]
            fn energy(&self, c1: T, c2: T) -> T {
                (**self).energy(c1, c2)
            }
            #[inline]
            fn gradient(&self, c1: T, c2: T) -> [T; 2] {
                (**self).gradient(c1, c2)
            }
            #[inline]
            fn hessian(&self, c1: T, c2: T) -> [T; 3] {
                (**self).hessian(c1, c2)
            }
            #[inline]
            fn derivatives(&self, c1: T, c2: T) -> ([T; 2], [T; 3]) {
                (**self).derivatives(c1, c2)
            }
        }
    )*};
}

forward_surface_law!(&L, Box<L>, Arc<L>);

/// Neo-Hookean membrane, eq. (2.5): `W_s = (E_s/6)(c1 + 1/c2 − 2)`.
///
/// This is the Eggleton & Popel form, with shear modulus `G_s = E_s/3`. Principal tensions
/// `T_i = (G_s/(λ1 λ2)) (λ_i² − 1/(λ1 λ2)²)`. Closed forms for simple loadings:
/// [`NeoHookean::uniaxial_tension`], [`NeoHookean::equibiaxial_tension`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean<T> {
    es: T,
}

impl<T: Real> NeoHookean<T> {
    /// A neo-Hookean law with elastic modulus `es` = `E_s` of (2.5) (`= 3 G_s`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `es` unless it is finite and `> 0`.
    pub fn new(es: T) -> Result<Self> {
        Ok(Self { es: positive("es", es)? })
    }

    /// The modulus `E_s` of (2.5).
    #[inline]
    pub fn es(&self) -> T {
        self.es
    }

    /// The membrane shear modulus `G_s = E_s/3`.
    #[inline]
    pub fn shear_modulus(&self) -> T {
        self.es / T::lit(3.0)
    }

    /// Closed form of uniaxial tension (`T2 = 0`) at principal stretch `lambda1`:
    /// returns `(T1, λ2)`.
    ///
    /// From `T2 = 0`: `λ2² = 1/(λ1 λ2)²`, so `λ2 = λ1^{-1/2}`; then `λ1 λ2 = λ1^{1/2}` and
    /// `T1 = (G_s/λ1^{1/2})(λ1² − 1/λ1) = G_s (λ1^{3/2} − λ1^{-3/2})`.
    /// Valid for `lambda1 > 0` (NaN otherwise).
    pub fn uniaxial_tension(&self, lambda1: T) -> (T, T) {
        let s = lambda1.sqrt();
        let l32 = lambda1 * s;
        (self.shear_modulus() * (l32 - l32.recip()), s.recip())
    }

    /// Closed form of the isotropic tension under equibiaxial stretch `lambda`
    /// (`λ1 = λ2 = λ`): `T = G_s (1 − λ^{-6})`. It saturates at `G_s = E_s/3` as `λ → ∞`.
    /// Valid for `lambda > 0`.
    pub fn equibiaxial_tension(&self, lambda: T) -> T {
        let l2 = lambda * lambda;
        self.shear_modulus() * (T::one() - (l2 * l2 * l2).recip())
    }
}

impl<T: Real> SurfaceLaw<T> for NeoHookean<T> {
    fn name(&self) -> &str {
        "neo_hookean"
    }

    #[inline]
    fn energy(&self, c1: T, c2: T) -> T {
        self.es / T::lit(6.0) * (c1 + c2.recip() - T::lit(2.0))
    }

    #[inline]
    fn gradient(&self, _c1: T, c2: T) -> [T; 2] {
        let k = self.es / T::lit(6.0);
        let r = c2.recip();
        [k, -k * r * r]
    }

    #[inline]
    fn hessian(&self, _c1: T, c2: T) -> [T; 3] {
        let k = self.es / T::lit(6.0);
        let r = c2.recip();
        [T::zero(), T::zero(), T::lit(2.0) * k * r * r * r]
    }

    #[inline]
    fn derivatives(&self, _c1: T, c2: T) -> ([T; 2], [T; 3]) {
        let k = self.es / T::lit(6.0);
        let r = c2.recip();
        let kr2 = k * r * r;
        ([k, -kr2], [T::zero(), T::zero(), T::lit(2.0) * kr2 * r])
    }
}

/// Skalak membrane, eq. (2.6): `W_s = (E_s/8)(c1² + α c2² − 2(α+1) c2 + α + 1)`.
///
/// Shear modulus `G_s = E_s/2`; `α` equals the area-dilation coefficient `C` of the usual form
/// `(G_s/4)(I1² + 2 I1 − 2 I2 + C I2²)` (see the [module docs](self)); the small-strain
/// area-dilation modulus is `K = G_s (1 + 2α)`. Principal tensions
/// `T_1 = G_s (λ1/λ2)(λ1² − 1 + α λ2² (λ1² λ2² − 1))` and symmetrically for `T_2`.
///
/// Allowed `α`: finite and `≥ 0`. Honest account of the limits: the reference state is
/// linearly stable for `α > −1/2` (`K > 0`), not merely `α > −1`; but for any `α < 0` the term
/// `α c2²` makes the energy unbounded below under large area dilation (equibiaxially
/// `W ~ (E_s/8) α λ⁸ → −∞`), so the isotropic tension reaches a maximum and the membrane
/// "fails" at finite stretch. Such a law is rejected; `α = 0` (no area penalty beyond the
/// shear term) is accepted and stable (`K = G_s`). Red blood cells use `α ≫ 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Skalak<T> {
    es: T,
    alpha: T,
}

impl<T: Real> Skalak<T> {
    /// A Skalak law with modulus `es` = `E_s` (`= 2 G_s`) and area-dilation parameter `alpha`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `es` unless it is finite and `> 0`, or naming `alpha`
    /// unless it is finite and `≥ 0` (see the type docs for why negative `α` is refused).
    pub fn new(es: T, alpha: T) -> Result<Self> {
        let es = positive("es", es)?;
        if !(alpha.is_finite() && alpha >= T::zero()) {
            return Err(Error::invalid(
                "alpha",
                alpha,
                "a finite number >= 0 (alpha < 0 makes the Skalak energy unbounded below \
                 under area dilation)",
            ));
        }
        Ok(Self { es, alpha })
    }

    /// The modulus `E_s` of (2.6).
    #[inline]
    pub fn es(&self) -> T {
        self.es
    }

    /// The area-dilation parameter `α` of (2.6) (the `C` of Barthès-Biesel et al.).
    #[inline]
    pub fn alpha(&self) -> T {
        self.alpha
    }

    /// The membrane shear modulus `G_s = E_s/2`.
    #[inline]
    pub fn shear_modulus(&self) -> T {
        self.es * T::lit(0.5)
    }

    /// Closed form of uniaxial tension (`T2 = 0`) at principal stretch `lambda1`:
    /// returns `(T1, λ2)`.
    ///
    /// `T2 = 0` reads `λ2² − 1 + α λ1² (λ1² λ2² − 1) = 0`, linear in `λ2²`:
    /// `λ2² = (1 + α λ1²)/(1 + α λ1⁴)`. Then `λ1² λ2² − 1 = (λ1² − 1)/(1 + α λ1⁴)` and
    /// `T1 = G_s (λ1/λ2)(λ1² − 1)(1 + α λ2²/(1 + α λ1⁴))`. Valid for `lambda1 > 0`.
    pub fn uniaxial_tension(&self, lambda1: T) -> (T, T) {
        let one = T::one();
        let a = self.alpha;
        let l1s = lambda1 * lambda1;
        let den = one + a * l1s * l1s;
        let l2s = (one + a * l1s) / den;
        let l2 = l2s.sqrt();
        let t1 = self.shear_modulus() * (lambda1 / l2) * (l1s - one) * (one + a * l2s / den);
        (t1, l2)
    }

    /// Closed form of the isotropic tension under equibiaxial stretch `lambda`:
    /// `T = G_s (λ² − 1)(1 + α λ² (λ² + 1))`. Valid for `lambda > 0`.
    pub fn equibiaxial_tension(&self, lambda: T) -> T {
        let one = T::one();
        let l2 = lambda * lambda;
        self.shear_modulus() * (l2 - one) * (one + self.alpha * l2 * (l2 + one))
    }
}

impl<T: Real> SurfaceLaw<T> for Skalak<T> {
    fn name(&self) -> &str {
        "skalak"
    }

    #[inline]
    fn energy(&self, c1: T, c2: T) -> T {
        let one = T::one();
        let a = self.alpha;
        self.es / T::lit(8.0) * (c1 * c1 + a * c2 * c2 - T::lit(2.0) * (a + one) * c2 + a + one)
    }

    #[inline]
    fn gradient(&self, c1: T, c2: T) -> [T; 2] {
        let k = self.es * T::lit(0.25);
        [k * c1, k * (self.alpha * c2 - self.alpha - T::one())]
    }

    #[inline]
    fn hessian(&self, _c1: T, _c2: T) -> [T; 3] {
        let k = self.es * T::lit(0.25);
        [k, T::zero(), k * self.alpha]
    }
}

// Tensor components are indexed by number in the tests, as in the equations.
#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn fd_check<L: SurfaceLaw<f64>>(law: &L, c1: f64, c2: f64) {
        let h = 1e-5;
        let [w1, w2] = law.gradient(c1, c2);
        let [w11, w12, w22] = law.hessian(c1, c2);
        let fd1 = (law.energy(c1 + h, c2) - law.energy(c1 - h, c2)) / (2.0 * h);
        let fd2 = (law.energy(c1, c2 + h) - law.energy(c1, c2 - h)) / (2.0 * h);
        let g = |a: f64, b: f64| law.gradient(a, b);
        let fd11 = (g(c1 + h, c2)[0] - g(c1 - h, c2)[0]) / (2.0 * h);
        let fd12 = (g(c1, c2 + h)[0] - g(c1, c2 - h)[0]) / (2.0 * h);
        let fd21 = (g(c1 + h, c2)[1] - g(c1 - h, c2)[1]) / (2.0 * h);
        let fd22 = (g(c1, c2 + h)[1] - g(c1, c2 - h)[1]) / (2.0 * h);
        let scale = 1.0 + w1.abs() + w2.abs() + w11.abs() + w22.abs();
        for (a, b) in [(w1, fd1), (w2, fd2), (w11, fd11), (w12, fd12), (w12, fd21), (w22, fd22)] {
            assert!((a - b).abs() < 1e-8 * scale, "{a} vs {b}");
        }
        let (g2, h2) = law.derivatives(c1, c2);
        assert_eq!(g2, [w1, w2]);
        assert_eq!(h2, [w11, w12, w22]);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let nh = NeoHookean::new(2.0).unwrap();
        let sk = Skalak::new(1.5, 7.0).unwrap();
        for &(c1, c2) in &[(1.0, 1.0), (2.3, 0.7), (0.4, 1.9), (3.0, 4.0)] {
            fd_check(&nh, c1, c2);
            fd_check(&sk, c1, c2);
        }
    }

    #[test]
    fn reference_state_is_stress_free_and_energy_zero() {
        let nh = NeoHookean::new(2.0f64).unwrap();
        let sk = Skalak::new(2.0f64, 3.0).unwrap();
        let [a, b] = nh.gradient(1.0, 1.0);
        assert_eq!(a + b, 0.0);
        let [a, b] = sk.gradient(1.0, 1.0);
        assert_eq!(a + b, 0.0);
        assert_eq!(nh.energy(1.0, 1.0), 0.0);
        assert_eq!(sk.energy(1.0, 1.0), 0.0);
    }

    #[test]
    fn small_strain_moduli_match_known_values() {
        let nh = NeoHookean::new(3.0f64).unwrap();
        let (mu, k) = small_strain_moduli(&nh);
        assert!((mu - 1.0).abs() < 1e-15 && (k - 3.0).abs() < 1e-15);
        let sk = Skalak::new(2.0f64, 4.0).unwrap();
        let (mu, k) = small_strain_moduli(&sk);
        assert!((mu - 1.0).abs() < 1e-15 && (k - 9.0).abs() < 1e-14);
        // Also through a trait object, in f32.
        let law: &dyn SurfaceLaw<f32> = &Skalak::new(2.0f32, 0.0).unwrap();
        let (mu, k) = small_strain_moduli(law);
        assert!((mu - 1.0).abs() < 1e-6 && (k - 1.0).abs() < 1e-6);
    }

    #[test]
    fn constructors_reject_bad_parameters() {
        for es in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            match NeoHookean::new(es) {
                Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "es"),
                other => panic!("expected error, got {other:?}"),
            }
            assert!(Skalak::new(es, 1.0).is_err());
        }
        for alpha in [-0.1, -2.0, f64::NAN, f64::NEG_INFINITY, f64::INFINITY] {
            match Skalak::new(1.0, alpha) {
                Err(Error::InvalidParameter { name, allowed, .. }) => {
                    assert_eq!(name, "alpha");
                    assert!(allowed.contains(">= 0"));
                }
                other => panic!("expected error, got {other:?}"),
            }
        }
        assert!(Skalak::new(1.0, 0.0).is_ok());
        let e = NeoHookean::new(-2.0).unwrap_err().to_string();
        assert!(e.contains("es") && e.contains("-2") && e.contains("> 0"), "{e}");
    }

    /// A law with constant derivatives, for the reference-state checks.
    struct Fixed([f64; 2], [f64; 3]);

    impl SurfaceLaw<f64> for Fixed {
        fn name(&self) -> &str {
            "fixed"
        }
        fn energy(&self, c1: f64, c2: f64) -> f64 {
            self.0[0] * c1 + self.0[1] * c2
        }
        fn gradient(&self, _c1: f64, _c2: f64) -> [f64; 2] {
            self.0
        }
        fn hessian(&self, _c1: f64, _c2: f64) -> [f64; 3] {
            self.1
        }
    }

    #[test]
    fn check_stress_free_accepts_the_paper_laws_and_refuses_bad_ones() {
        check_stress_free(&NeoHookean::new(2.0f64).unwrap()).unwrap();
        check_stress_free(&Skalak::new(2.0f64, 0.0).unwrap()).unwrap();
        check_stress_free(&Skalak::new(1.0f32, 1e4).unwrap()).unwrap();
        // Stress free, stable: mu = 1, K = 4 (1/2) - 1 = 1.
        check_stress_free(&Fixed([0.5, -0.5], [0.0, 0.0, 0.5])).unwrap();
        let refused = |law: &Fixed, what: &str| match check_stress_free(law) {
            Err(Error::InvalidParameter { name, value, allowed }) => {
                assert_eq!(name, "law");
                assert!(value.contains("`fixed`"), "{value}");
                assert!(allowed.contains(what), "{allowed}");
            }
            other => panic!("expected a refusal ({what}), got {other:?}"),
        };
        // Residual tension tau = 2 (W_1 + W_2) P = 0.2 P.
        refused(&Fixed([0.5, -0.4], [0.0, 0.0, 0.5]), "stress free");
        // A residual of 1e-12 of the terms is more than round-off.
        refused(&Fixed([0.5, -0.5 + 1e-12], [0.0, 0.0, 0.5]), "stress free");
        // Negative shear modulus mu = 2 W_1, negative area modulus K.
        refused(&Fixed([-0.5, 0.5], [0.0, 0.0, 0.5]), "mu = 2 W_1 > 0");
        refused(&Fixed([0.5, -0.5], [0.0, 0.0, 0.1]), "K = 4");
        refused(&Fixed([0.5, f64::NAN], [0.0, 0.0, 0.1]), "finite");
        refused(&Fixed([0.5, -0.5], [0.0, f64::INFINITY, 0.1]), "finite");
        let e = check_stress_free(&Fixed([0.5, -0.4], [0.0, 0.0, 0.5])).unwrap_err().to_string();
        assert!(e.contains("W_1 = 5e-1, W_2 = -4e-1"), "{e}");
    }

    #[test]
    fn references_boxes_and_arcs_are_laws() {
        fn moduli<L: SurfaceLaw<f64>>(law: L) -> (String, (f64, f64), f64) {
            (law.name().to_string(), small_strain_moduli(&law), law.energy(1.5, 2.0))
        }
        let sk = Skalak::new(2.0, 4.0).unwrap();
        let expect = moduli(sk);
        assert_eq!(expect.1, (1.0, 9.0));
        assert_eq!(moduli::<&Skalak<f64>>(&sk), expect);
        assert_eq!(moduli(Box::new(sk)), expect);
        assert_eq!(moduli(Arc::new(sk)), expect);
        let boxed: Box<dyn SurfaceLaw<f64>> = Box::new(sk);
        assert_eq!(moduli(&*boxed), expect);
        assert_eq!(moduli(boxed), expect);
        let shared: Arc<dyn SurfaceLaw<f64>> = Arc::new(sk);
        assert_eq!(moduli(Arc::clone(&shared)), expect);
        assert_eq!(moduli(&shared), expect);
        // `derivatives` is forwarded, not recomputed by the default.
        let nh = NeoHookean::new(3.0).unwrap();
        assert_eq!(Box::new(nh).derivatives(0.7, 1.3), nh.derivatives(0.7, 1.3));
        assert_eq!(<&NeoHookean<f64> as SurfaceLaw<f64>>::gradient(&&nh, 0.7, 1.3), nh.gradient(0.7, 1.3));
        assert_eq!(Arc::new(nh).hessian(0.7, 1.3), nh.hessian(0.7, 1.3));
    }

    #[test]
    fn closed_forms_vanish_at_rest_and_agree_for_alpha_zero_small_strain() {
        let nh = NeoHookean::new(3.0f64).unwrap();
        let sk = Skalak::new(2.0f64, 0.0).unwrap();
        assert_eq!(nh.uniaxial_tension(1.0), (0.0, 1.0));
        assert_eq!(sk.uniaxial_tension(1.0), (0.0, 1.0));
        assert_eq!(nh.equibiaxial_tension(1.0), 0.0);
        assert_eq!(sk.equibiaxial_tension(1.0), 0.0);
        // alpha = 0: T2 = 0 gives lambda2 = 1 exactly.
        assert!((sk.uniaxial_tension(1.7).1 - 1.0).abs() < 1e-15);
        // Small-strain uniaxial slope dT1/dε1 = 4 μ (μ + λ_L)/(2 μ + λ_L) = 3 G_s for NH.
        let e = 1e-7;
        let slope = nh.uniaxial_tension(1.0 + e).0 / e;
        assert!((slope - 3.0).abs() < 1e-5, "{slope}");
    }
}
