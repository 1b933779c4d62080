//! A membrane that wrinkles instead of carrying compression: the tension-field (relaxed)
//! energy of any [`SurfaceLaw`].
//!
//! A membrane without bending stiffness cannot carry a compressive tension: under compression
//! it buckles into wrinkles at no cost, and its mean (macroscopic) response is that of the
//! *relaxed* energy (Pipkin 1986; Steigmann 1990). With the principal squared stretches
//! `x1 = λ1² ≥ x2 = λ2²` and the tensions `T_i ∝ ∂W/∂x_i`:
//!
//! - **taut** (`∂W/∂x2 ≥ 0`: both tensions non-negative): `W̃ = W`;
//! - **wrinkled** (`∂W/∂x2 < 0 < T1` at the natural width): `W̃ = W(x1, x2*(x1))`, where the
//!   natural width `x2*` solves `∂W/∂x2 (x1, x2*) = 0` — the compressed direction takes the
//!   stretch at which its tension vanishes, and the membrane carries a uniaxial tension along
//!   the wrinkles;
//! - **slack** (no natural width with a positive tension along `x1`): `W̃ = 0`.
//!
//! `W̃` depends on `(c1, c2)` through `x1 = (c1 + 1 + √d) / 2`, `d = (c1 + 1)² − 4 c2 = (x1 −
//! x2)²`, in the wrinkled state, so that its gradient and Hessian in `(c1, c2)` (what the stress
//! (2.4) and the Jacobian of App. B need) follow by the chain rule from `f1 = ∂W/∂x1` at the
//! natural width and its total derivative `f1' = W_{x1x1} − W_{x1x2}² / W_{x2x2}`. `W̃` is
//! continuously differentiable (its stress is continuous) across the taut–wrinkled boundary;
//! its Hessian jumps there.
//!
//! Not in the paper. Its role here: the discrete membrane of the sharp coupling develops
//! compressive tensions in layers of its shell that a smooth membrane would not carry.

use super::law::SurfaceLaw;
use crate::Real;

/// The tension-field (relaxed) energy of the law `L` (see the [module docs](self)).
///
/// ```
/// use eulermembrane::membrane::{law::NeoHookean, law::SurfaceLaw, wrinkling::TensionField};
///
/// let law = TensionField::new(NeoHookean::new(1.0)?);
/// // Uniaxial stretch x1 = 1.44 at the natural width x2 = 1 / 1.2 of the neo-Hookean law:
/// // the same energy as the law itself there.
/// let (x1, x2) = (1.44_f64, 1.0 / 1.2);
/// let (c1, c2) = (x1 + x2 - 1.0, x1 * x2);
/// assert!((law.energy(c1, c2) - law.inner().energy(c1, c2)).abs() < 1e-12);
/// // Compressed further across (x2 = 0.5): the relaxed energy does not change.
/// let (c1w, c2w) = (x1 + 0.5 - 1.0, x1 * 0.5);
/// assert!((law.energy(c1w, c2w) - law.energy(c1, c2)).abs() < 1e-12);
/// // Both directions compressed: slack, no energy.
/// assert_eq!(law.energy(0.9 + 0.8 - 1.0, 0.9 * 0.8), 0.0);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct TensionField<L> {
    law: L,
    name: String,
}

impl<L> TensionField<L> {
    /// The relaxed energy of `law`.
    pub fn new<T: Real>(law: L) -> Self
    where
        L: SurfaceLaw<T>,
    {
        let name = format!("tension_field_{}", law.name());
        TensionField { law, name }
    }

    /// The law that is relaxed.
    pub fn inner(&self) -> &L {
        &self.law
    }
}

/// The state of a point of the membrane under the relaxed energy.
enum State<T> {
    Taut,
    /// Wrinkled: the larger squared stretch `x1`, `√d = x1 − x2`, and the natural width `x2*`.
    Wrinkled {
        x1: T,
        root: T,
        x2n: T,
    },
    Slack,
}

/// Squared-stretch derivatives of `W` at `(x1, x2)` from its `(c1, c2)` derivatives:
/// `[∂W/∂x1, ∂W/∂x2]` and `[∂²W/∂x1², ∂²W/∂x1∂x2, ∂²W/∂x2²]`.
fn x_derivatives<T: Real, L: SurfaceLaw<T>>(law: &L, x1: T, x2: T) -> ([T; 2], [T; 3]) {
    let ([w1, w2], [w11, w12, w22]) = law.derivatives(x1 + x2 - T::one(), x1 * x2);
    let g = [w1 + w2 * x2, w1 + w2 * x1];
    let h11 = w11 + T::lit(2.0) * w12 * x2 + w22 * x2 * x2;
    let h12 = w11 + w12 * (x1 + x2) + w22 * x1 * x2 + w2;
    let h22 = w11 + T::lit(2.0) * w12 * x1 + w22 * x1 * x1;
    (g, [h11, h12, h22])
}

impl<L> TensionField<L> {
    fn state<T: Real>(&self, c1: T, c2: T) -> State<T>
    where
        L: SurfaceLaw<T>,
    {
        let half = T::lit(0.5);
        let s = c1 + T::one();
        let root = (s * s - T::lit(4.0) * c2).max(T::zero()).sqrt();
        let (x1, x2) = (half * (s + root), half * (s - root));
        if x2.is_nan() || x2 <= T::zero() {
            return State::Taut;
        }
        let (g, _) = x_derivatives(&self.law, x1, x2);
        // Round-off about the equal-stretch states (the reference state among them) must not
        // decide: within 64 epsilon of zero the tension counts as zero.
        let tiny = T::lit(64.0) * T::epsilon() * (g[0].abs() + g[1].abs());
        if g[1] >= -tiny {
            return State::Taut;
        }
        if root <= T::lit(1e-6) * s {
            // Equal stretches, both tensions negative: compressed every way.
            return State::Slack;
        }
        // The natural width: dW/dx2 (x1, x2*) = 0 for x2* in (x2, ...); dW/dx2 grows with x2
        // for a law that is stable in uniaxial tension. Bracket it, then bisect.
        let at = |y: T| x_derivatives(&self.law, x1, y).0[1];
        let (mut lo, mut hi) = (x2, x1.max(x2 * T::lit(2.0)));
        let mut grow = 0;
        while at(hi) < T::zero() {
            lo = hi;
            hi *= T::lit(2.0);
            grow += 1;
            if grow > 60 {
                return State::Slack;
            }
        }
        for _ in 0..200 {
            let mid = half * (lo + hi);
            if at(mid) < T::zero() {
                lo = mid
            } else {
                hi = mid
            }
            if hi - lo <= T::epsilon() * T::lit(4.0) * hi {
                break;
            }
        }
        let x2n = half * (lo + hi);
        // A positive tension along x1 at the natural width, and x1 the larger stretch there.
        let (gn, _) = x_derivatives(&self.law, x1, x2n);
        if gn[0].is_nan() || gn[0] <= T::zero() || x2n >= x1 {
            return State::Slack;
        }
        State::Wrinkled { x1, root, x2n }
    }
}

impl<T: Real, L: SurfaceLaw<T>> SurfaceLaw<T> for TensionField<L> {
    fn name(&self) -> &str {
        &self.name
    }

    fn energy(&self, c1: T, c2: T) -> T {
        match self.state(c1, c2) {
            State::Taut => self.law.energy(c1, c2),
            State::Wrinkled { x1, x2n, .. } => self.law.energy(x1 + x2n - T::one(), x1 * x2n),
            State::Slack => T::zero(),
        }
    }

    fn gradient(&self, c1: T, c2: T) -> [T; 2] {
        self.derivatives(c1, c2).0
    }

    fn hessian(&self, c1: T, c2: T) -> [T; 3] {
        self.derivatives(c1, c2).1
    }

    fn derivatives(&self, c1: T, c2: T) -> ([T; 2], [T; 3]) {
        match self.state(c1, c2) {
            State::Taut => self.law.derivatives(c1, c2),
            State::Slack => ([T::zero(); 2], [T::zero(); 3]),
            State::Wrinkled { x1, root, x2n } => {
                let (g, h) = x_derivatives(&self.law, x1, x2n);
                let f1 = g[0];
                // The total derivative of f1 along the natural width: dx2*/dx1 = -h12 / h22.
                let f11 = h[0] - h[1] * h[1] / h[2];
                // x1(c1, c2) = (s + √d) / 2: first and second derivatives.
                let s = c1 + T::one();
                let d32 = root * root * root;
                let (a1, a2) = (x1 / root, -root.recip());
                let a11 = -T::lit(2.0) * c2 / d32;
                let a12 = s / d32;
                let a22 = -T::lit(2.0) / d32;
                (
                    [f1 * a1, f1 * a2],
                    [f11 * a1 * a1 + f1 * a11, f11 * a1 * a2 + f1 * a12, f11 * a2 * a2 + f1 * a22],
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::membrane::law::{NeoHookean, Skalak};

    fn cs(x1: f64, x2: f64) -> (f64, f64) {
        (x1 + x2 - 1.0, x1 * x2)
    }

    /// Central differences of the energy and of the gradient.
    fn check<L: SurfaceLaw<f64>>(law: &L, x1: f64, x2: f64) {
        let (c1, c2) = cs(x1, x2);
        let (g, h) = law.derivatives(c1, c2);
        let e = 1e-6;
        let fd1 = (law.energy(c1 + e, c2) - law.energy(c1 - e, c2)) / (2.0 * e);
        let fd2 = (law.energy(c1, c2 + e) - law.energy(c1, c2 - e)) / (2.0 * e);
        let scale = g[0].abs() + g[1].abs() + 1e-3;
        assert!((fd1 - g[0]).abs() < 1e-6 * scale, "W_c1 {} vs {fd1} at {x1}, {x2}", g[0]);
        assert!((fd2 - g[1]).abs() < 1e-6 * scale, "W_c2 {} vs {fd2} at {x1}, {x2}", g[1]);
        let gp1 = law.gradient(c1 + e, c2);
        let gm1 = law.gradient(c1 - e, c2);
        let gp2 = law.gradient(c1, c2 + e);
        let gm2 = law.gradient(c1, c2 - e);
        let hs = h.iter().map(|x| x.abs()).sum::<f64>() + 1e-3;
        let fd =
            [(gp1[0] - gm1[0]) / (2.0 * e), (gp2[0] - gm2[0]) / (2.0 * e), (gp2[1] - gm2[1]) / (2.0 * e)];
        let fd12b = (gp1[1] - gm1[1]) / (2.0 * e);
        for (k, (a, b)) in h.iter().zip(fd).enumerate() {
            assert!((a - b).abs() < 1e-5 * hs, "hessian[{k}] {a} vs {b} at {x1}, {x2}");
        }
        assert!((h[1] - fd12b).abs() < 1e-5 * hs);
    }

    #[test]
    fn taut_states_are_the_law() {
        let nh = NeoHookean::new(3.0).unwrap();
        let tf = TensionField::new(nh);
        for (x1, x2) in [(1.0, 1.0), (1.3, 1.1), (1.5, 0.9), (2.0, 0.8)] {
            let (c1, c2) = cs(x1, x2);
            assert_eq!(tf.energy(c1, c2), nh.energy(c1, c2));
            assert_eq!(tf.derivatives(c1, c2), nh.derivatives(c1, c2));
        }
    }

    #[test]
    fn neo_hookean_natural_width_is_exact() {
        // dW/dx2 = k (1 - 1 / (x1 x2^2)) = 0: x2* = x1^(-1/2); W = (E_s / 6)(x1 + 2 / sqrt(x1) - 3).
        let tf = TensionField::new(NeoHookean::new(6.0).unwrap());
        for x1 in [1.1_f64, 1.5, 2.5] {
            for x2 in [0.2, 0.5, 0.9 / x1.sqrt()] {
                let (c1, c2) = cs(x1, x2);
                let exact = x1 + 2.0 / x1.sqrt() - 3.0;
                assert!((tf.energy(c1, c2) - exact).abs() < 1e-12, "{x1} {x2}");
            }
        }
    }

    #[test]
    fn slack_states_have_no_energy() {
        let tf = TensionField::new(NeoHookean::new(1.0).unwrap());
        for (x1, x2) in [(0.9, 0.8), (1.0, 0.5), (0.99, 0.99)] {
            let (c1, c2) = cs(x1, x2);
            assert_eq!(tf.energy(c1, c2), 0.0);
            assert_eq!(tf.derivatives(c1, c2), ([0.0; 2], [0.0; 3]));
        }
    }

    #[test]
    fn derivatives_match_finite_differences_in_wrinkled_states() {
        let nh = TensionField::new(NeoHookean::new(3.0).unwrap());
        let sk = TensionField::new(Skalak::new(2.0, 1.0).unwrap());
        for (x1, x2) in [(1.2, 0.6), (1.6, 0.4), (2.2, 0.5), (1.05, 0.8)] {
            check(&nh, x1, x2);
            check(&sk, x1, x2);
        }
    }

    #[test]
    fn stress_is_continuous_across_the_wrinkling_boundary() {
        let nh = NeoHookean::new(3.0).unwrap();
        let tf = TensionField::new(nh);
        let x1: f64 = 1.7;
        let xn = 1.0 / x1.sqrt();
        let (a, b) = (cs(x1, xn * (1.0 + 1e-7)), cs(x1, xn * (1.0 - 1e-7)));
        let (ga, gb) = (tf.gradient(a.0, a.1), tf.gradient(b.0, b.1));
        assert!((ga[0] - gb[0]).abs() < 1e-5 && (ga[1] - gb[1]).abs() < 1e-5, "{ga:?} {gb:?}");
    }
}
