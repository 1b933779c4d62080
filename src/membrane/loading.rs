//! Simple loadings of a flat membrane, for any [`SurfaceLaw`]: uniaxial tension (`T2 = 0`) and
//! equibiaxial tension, computed through the generic stress (2.4) and Jacobian (2.33).
//!
//! The membrane lies in the `x1 x2` plane (`n = e3`) with principal stretches `λ1`, `λ2`
//! along `e1`, `e2`, i.e. `G_s = diag(λ1², λ2², 0)`. These solvers are the generic
//! counterparts of the closed forms [`NeoHookean::uniaxial_tension`],
//! [`Skalak::uniaxial_tension`] and the `equibiaxial_tension` methods (derived in their docs),
//! and the tests hold them equal to 1e-10 (f64). They are also how a user checks a new law
//! against published tension–strain curves.
//!
//! [`NeoHookean::uniaxial_tension`]: super::law::NeoHookean::uniaxial_tension
//! [`Skalak::uniaxial_tension`]: super::law::Skalak::uniaxial_tension

use super::law::SurfaceLaw;
use super::stress::stress_and_jacobian;
use crate::Real;
use crate::error::{Error, Result, positive};
use crate::tensor::{Sym, Vec3, XX, YY};

/// Most bracket expansions (halvings or doublings of the stretch) before giving up.
const MAX_EXPAND: usize = 60;
/// Most safeguarded Newton iterations.
const MAX_ITER: usize = 200;

#[inline]
fn e3<T: Real>() -> Vec3<T> {
    [T::zero(), T::zero(), T::one()]
}

#[inline]
fn diag<T: Real>(a: T, b: T) -> Sym<T> {
    let z = T::zero();
    [a, b, z, z, z, z]
}

/// Finds the root of an increasing function `f` on `(0, ∞)`, starting from `x = 1`.
///
/// `f` returns the value and the derivative. The bracket is grown geometrically from 1, then a
/// Newton iteration is safeguarded by bisection. Returns `None` if no sign change is found.
fn solve_increasing<T: Real>(f: impl Fn(T) -> (T, T)) -> Option<T> {
    let zero = T::zero();
    let two = T::lit(2.0);
    let (mut lo, mut hi) = (T::one(), T::one());
    let (f1, _) = f(T::one());
    if f1 == zero {
        return Some(T::one());
    }
    if f1 > zero {
        let mut found = false;
        for _ in 0..MAX_EXPAND {
            lo /= two;
            let (v, _) = f(lo);
            if v < zero {
                found = true;
                break;
            }
            if v == zero {
                return Some(lo);
            }
            hi = lo;
        }
        if !found {
            return None;
        }
    } else {
        let mut found = false;
        for _ in 0..MAX_EXPAND {
            hi *= two;
            let (v, _) = f(hi);
            if v > zero {
                found = true;
                break;
            }
            if v == zero {
                return Some(hi);
            }
            lo = hi;
        }
        if !found {
            return None;
        }
    }
    // Invariant: f(lo) < 0 < f(hi).
    let tol = T::lit(4.0) * T::eps();
    let mut x = T::lit(0.5) * (lo + hi);
    for _ in 0..MAX_ITER {
        let (v, dv) = f(x);
        if v == zero || !v.is_finite() {
            return v.is_finite().then_some(x);
        }
        if v < zero {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - v / dv;
        let next = if dv > zero && newton > lo && newton < hi { newton } else { T::lit(0.5) * (lo + hi) };
        if (next - x).abs() <= tol * x || hi - lo <= tol * x {
            return Some(next);
        }
        x = next;
    }
    Some(x)
}

/// Uniaxial tension at principal stretch `lambda1`, for any law: returns `(T1, λ2)` such that
/// the lateral tension vanishes, `T2 = τ22(G_s = diag(λ1², λ2², 0), n = e3) = 0`.
///
/// `λ2` is found by a safeguarded Newton iteration on `T2(λ2)`, with the slope
/// `dT2/dλ2 = 2 λ2 J'_(22,22)` from the generic Jacobian; `T1 = τ11` at the root. Assumes, as
/// for every stable law, that `T2` increases with `λ2`.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `lambda1` unless it is finite and `> 0`;
/// [`Error::NoConvergence`] if no `λ2` in `[2^-60, 2^60]` makes `T2` change sign.
pub fn uniaxial_tension<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L, lambda1: T) -> Result<(T, T)> {
    let lambda1 = positive("lambda1", lambda1)?;
    let n = e3();
    let l1s = lambda1 * lambda1;
    let t2 = |l2: T| {
        let (tau, j) = stress_and_jacobian(law, &diag(l1s, l2 * l2), &n);
        (tau[YY], T::lit(2.0) * l2 * j[YY][YY])
    };
    let l2 = solve_increasing(t2).ok_or(Error::NoConvergence {
        solver: "uniaxial_tension (bracketing T2 = 0)",
        iterations: MAX_EXPAND,
        residual: f64::NAN,
        tolerance: 0.0,
    })?;
    let tau = stress_and_jacobian(law, &diag(l1s, l2 * l2), &n).0;
    Ok((tau[XX], l2))
}

/// Isotropic tension under equibiaxial stretch `lambda` (`G_s = λ² P`, `n = e3`), for any law.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `lambda` unless it is finite and `> 0`.
pub fn equibiaxial_tension<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L, lambda: T) -> Result<T> {
    let lambda = positive("lambda", lambda)?;
    let l2 = lambda * lambda;
    Ok(super::stress::stress(law, &diag(l2, l2), &e3())[XX])
}

/// The equibiaxial stretch `λ` at which the isotropic tension equals `tension`, for any law
/// (the inverse of [`equibiaxial_tension`]); the area dilation is `λ²`.
///
/// The root is bracketed by halving (compression) or doubling (tension) `λ` from 1, then
/// refined by safeguarded Newton. This is unique when the tension increases with `λ`, as it
/// does under tension for stable laws. In compression the response need not be monotone: the
/// Skalak tension has a minimum below `−G_s` for `α > 0` and tends to `−G_s` as `λ → 0`, so a
/// compressive target may have two roots (the one found is the one in the first bracket, not
/// necessarily the stable branch) or none.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `tension` if it is not finite, or if the law cannot reach
/// it for any `λ` in `[2^-60, 2^60]` (e.g. the neo-Hookean tension saturates at
/// `G_s = E_s/3`).
pub fn equibiaxial_stretch<T: Real, L: SurfaceLaw<T> + ?Sized>(law: &L, tension: T) -> Result<T> {
    let tension = crate::error::finite("tension", tension)?;
    let n = e3();
    let f = |l: T| {
        let (tau, j) = stress_and_jacobian(law, &diag(l * l, l * l), &n);
        (tau[XX] - tension, T::lit(2.0) * l * (j[XX][XX] + j[XX][YY]))
    };
    solve_increasing(f).ok_or_else(|| {
        Error::invalid(
            "tension",
            tension,
            "a tension the law reaches under equibiaxial stretch (the neo-Hookean law \
             saturates at G_s = E_s/3)",
        )
    })
}

// Tensor components are indexed by number in the tests, as in the equations.
#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::membrane::law::{NeoHookean, Skalak};

    #[test]
    fn generic_matches_closed_forms() {
        let nh = NeoHookean::new(3.0f64).unwrap();
        let sk = Skalak::new(2.0f64, 1.0).unwrap();
        let sk10 = Skalak::new(2.0f64, 10.0).unwrap();
        for &l in &[0.6, 0.95, 1.001, 1.3, 2.0, 3.5] {
            let (t, l2) = uniaxial_tension(&nh, l).unwrap();
            let (tc, l2c) = nh.uniaxial_tension(l);
            assert!((t - tc).abs() <= 1e-12 * tc.abs() && (l2 - l2c).abs() < 1e-14, "{l}");
            for law in [&sk, &sk10] {
                let (t, l2) = uniaxial_tension(law, l).unwrap();
                let (tc, l2c) = law.uniaxial_tension(l);
                assert!((t - tc).abs() <= 1e-12 * tc.abs() && (l2 - l2c).abs() < 1e-14, "{l}");
                let te = equibiaxial_tension(law, l).unwrap();
                assert!((te - law.equibiaxial_tension(l)).abs() <= 1e-13 * te.abs());
            }
            let te = equibiaxial_tension(&nh, l).unwrap();
            assert!((te - nh.equibiaxial_tension(l)).abs() <= 1e-13 * te.abs());
        }
        assert_eq!(uniaxial_tension(&nh, 1.0).unwrap(), (0.0, 1.0));
    }

    #[test]
    fn inverse_equibiaxial_and_errors() {
        let nh = NeoHookean::new(3.0f64).unwrap();
        let l = equibiaxial_stretch(&nh, 0.5).unwrap();
        assert!((nh.equibiaxial_tension(l) - 0.5).abs() < 1e-14);
        let l = equibiaxial_stretch(&nh, -2.0).unwrap();
        assert!((nh.equibiaxial_tension(l) + 2.0).abs() < 1e-13);
        // Saturation at G_s = 1.
        assert!(matches!(
            equibiaxial_stretch(&nh, 1.5),
            Err(Error::InvalidParameter { name: "tension", .. })
        ));
        assert!(uniaxial_tension(&nh, -1.0).is_err());
        assert!(uniaxial_tension(&nh, f64::NAN).is_err());
        assert!(equibiaxial_tension(&nh, 0.0).is_err());
        assert!(equibiaxial_stretch(&nh, f64::INFINITY).is_err());
    }

    #[test]
    fn f32_generic_solver() {
        let sk = Skalak::new(2.0f32, 1.0).unwrap();
        let (t, l2) = uniaxial_tension(&sk, 1.5f32).unwrap();
        let (tc, l2c) = sk.uniaxial_tension(1.5);
        assert!((t - tc).abs() < 1e-5 * tc && (l2 - l2c).abs() < 1e-6);
    }
}
