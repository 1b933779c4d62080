//! Matrix-free Krylov solvers: preconditioned conjugate gradients (symmetric positive definite
//! operators, the variable-density pressure equation) and right-preconditioned BiCGStab (the
//! momentum predictor (2.35), non-symmetric once the membrane term H enters).
//!
//! Operators and preconditioners are narrow traits ([`LinOp`], [`Precond`]); the workspace is
//! allocated once ([`KrylovWorkspace`]) and the iteration allocates nothing. Each solve returns
//! [`KrylovInfo`] or [`Error::NoConvergence`].

use super::linalg::InteriorVector;
use crate::grid::Grid;
use crate::{Error, Real, Result};

/// A linear operator `y = A x` on interior values. `apply` may fill the ghost layers of `x`
/// (the boundary closure of the operator) before reading them.
pub trait LinOp<T: Real, V> {
    /// Writes `A x` into the interior of `y`.
    ///
    /// # Errors
    /// Whatever keeps an operator from being applied (e.g. an extra term of the predictor that
    /// fails); the solve that called it returns the error.
    fn apply(&self, x: &mut V, y: &mut V) -> Result<()>;
}

/// A preconditioner `z = M^-1 r`.
pub trait Precond<T: Real, V> {
    /// Writes `M^-1 r` into the interior of `z`.
    fn apply(&mut self, r: &V, z: &mut V);
}

/// The identity preconditioner.
pub struct Identity;

impl<T: Real, V: InteriorVector<T>> Precond<T, V> for Identity {
    fn apply(&mut self, r: &V, z: &mut V) {
        z.assign(r);
    }
}

/// Stopping rule of a Krylov solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KrylovParams {
    /// Relative residual `|b - A x| / |b|` to reach.
    pub tolerance: f64,
    /// Iteration limit; reaching it is an error.
    pub max_iterations: usize,
}

impl Default for KrylovParams {
    /// `tolerance = 1e-8`, `max_iterations = 500`.
    fn default() -> Self {
        KrylovParams { tolerance: 1e-8, max_iterations: 500 }
    }
}

impl KrylovParams {
    /// Checks the rule: a tolerance in `(0, 1)` and at least one iteration; errors name the
    /// setting `name`.
    pub(crate) fn validate(&self, name: &'static str) -> Result<()> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(Error::invalid(
                name,
                format!("tolerance {}", self.tolerance),
                "a tolerance in (0, 1)",
            ));
        }
        if self.max_iterations == 0 {
            return Err(Error::invalid(name, "max_iterations 0", "max_iterations >= 1"));
        }
        Ok(())
    }
}

/// What a converged solve reports (also what a [`MomentumSolver`](super::momentum::MomentumSolver) or a
/// [`PressureSolver`](super::projection::PressureSolver) returns).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KrylovInfo {
    /// Iterations performed (operator applications: 1 per CG and 2 per BiCGStab iteration;
    /// sweeps for SOR).
    pub iterations: usize,
    /// Final relative residual (relative change for SOR).
    pub residual: f64,
}

/// Work vectors of the Krylov solvers, allocated once.
pub struct KrylovWorkspace<V> {
    r: V,
    rhat: V,
    p: V,
    v: V,
    t: V,
    /// A preconditioned vector: BiCGStab's `p hat`, then its `s hat`; PCG's `z`.
    z: V,
}

impl<V> KrylovWorkspace<V> {
    /// A workspace for vectors like those of `grid`.
    pub fn new<T: Real>(grid: &Grid<T>) -> Self
    where
        V: InteriorVector<T>,
    {
        KrylovWorkspace {
            r: V::zeros_like(grid),
            rhat: V::zeros_like(grid),
            p: V::zeros_like(grid),
            v: V::zeros_like(grid),
            t: V::zeros_like(grid),
            z: V::zeros_like(grid),
        }
    }
}

fn no_convergence(solver: &'static str, it: usize, res: f64, tol: f64) -> Error {
    Error::NoConvergence { solver, iterations: it, residual: res, tolerance: tol }
}

/// `|b|`, or `None` after setting `x = 0` when `b = 0` (the solution, found without iterating).
fn nonzero_rhs_norm<T: Real, V: InteriorVector<T>>(grid: &Grid<T>, b: &V, x: &mut V) -> Option<T> {
    let bnorm = b.norm(grid);
    if bnorm == T::zero() {
        x.axpby(grid, T::zero(), b, T::zero());
        None
    } else {
        Some(bnorm)
    }
}

/// Solves `A x = b` by right-preconditioned BiCGStab, starting from the given `x`.
pub fn bicgstab<T: Real, V: InteriorVector<T>>(
    grid: &Grid<T>,
    op: &impl LinOp<T, V>,
    pc: &mut impl Precond<T, V>,
    b: &V,
    x: &mut V,
    ws: &mut KrylovWorkspace<V>,
    params: KrylovParams,
) -> Result<KrylovInfo> {
    let tol = T::lit(params.tolerance);
    let Some(bnorm) = nonzero_rhs_norm(grid, b, x) else { return Ok(KrylovInfo::default()) };
    let KrylovWorkspace { r, rhat, p, v, t, z } = ws;
    // r = b - A x
    op.apply(x, r)?;
    r.axpby(grid, T::one(), b, -T::one());
    let mut res = r.norm(grid) / bnorm;
    if !res.is_finite() {
        return Err(no_convergence("BiCGStab", 0, res.f64(), params.tolerance));
    }
    if res <= tol {
        return Ok(KrylovInfo { iterations: 0, residual: res.f64() });
    }
    rhat.assign(r);
    p.assign(r);
    let mut rho = rhat.dot(grid, r);
    // Each vector update below is one fused pass that also takes the sums needed next.
    for it in 1..=params.max_iterations {
        // `z` holds `p hat` until `x` has taken its part, then `s hat`.
        pc.apply(p, z);
        op.apply(z, v)?;
        let rv = rhat.dot(grid, v);
        if rv == T::zero() || !rv.is_finite() {
            return Err(no_convergence("BiCGStab (breakdown)", it, res.f64(), params.tolerance));
        }
        let alpha = rho / rv;
        // s = r - alpha v, and |s|^2: `s` takes `r`'s storage (`r` is not read again before it
        // is rebuilt from `s`), so that `r` below holds `s` until the update of `r`.
        let [ss, _] = r.update_reduce(grid, [v], |r, [v]| {
            let s = -alpha * v + r;
            (s, [s * s, T::zero()])
        });
        // x += alpha p hat (the first half of x += alpha p hat + omega s hat).
        x.axpby(grid, alpha, z, T::one());
        let snorm = ss.sqrt() / bnorm;
        if snorm <= tol {
            return Ok(KrylovInfo { iterations: it, residual: snorm.f64() });
        }
        pc.apply(r, z);
        op.apply(z, t)?;
        let [tt, ts] = t.reduce(grid, [r], |t, [s]| [t * t, t * s]);
        let omega = if tt > T::zero() { ts / tt } else { T::zero() };
        // x += omega s hat
        x.axpby(grid, omega, z, T::one());
        // r = s - omega t, |r|^2 and rhat . r
        let [rr, rho_new] = r.update_reduce(grid, [t, rhat], |s, [t, rh]| {
            let r = -omega * t + s;
            (r, [r * r, rh * r])
        });
        res = rr.sqrt() / bnorm;
        if !res.is_finite() {
            return Err(no_convergence("BiCGStab", it, res.f64(), params.tolerance));
        }
        if res <= tol {
            return Ok(KrylovInfo { iterations: it, residual: res.f64() });
        }
        if omega == T::zero() || rho == T::zero() {
            return Err(no_convergence("BiCGStab (breakdown)", it, res.f64(), params.tolerance));
        }
        let beta = (rho_new / rho) * (alpha / omega);
        rho = rho_new;
        // p = r + beta (p - omega v)
        p.update(grid, [v, r], |p, [v, r]| r + (-omega * beta * v + beta * p));
    }
    Err(no_convergence("BiCGStab", params.max_iterations, res.f64(), params.tolerance))
}

/// Solves `A x = b` for symmetric positive (semi-)definite `A` by preconditioned conjugate
/// gradients, starting from the given `x`.
pub fn pcg<T: Real, V: InteriorVector<T>>(
    grid: &Grid<T>,
    op: &impl LinOp<T, V>,
    pc: &mut impl Precond<T, V>,
    b: &V,
    x: &mut V,
    ws: &mut KrylovWorkspace<V>,
    params: KrylovParams,
) -> Result<KrylovInfo> {
    let tol = T::lit(params.tolerance);
    let Some(bnorm) = nonzero_rhs_norm(grid, b, x) else { return Ok(KrylovInfo::default()) };
    let KrylovWorkspace { r, p, v: ap, z, .. } = ws;
    op.apply(x, r)?;
    r.axpby(grid, T::one(), b, -T::one());
    let mut res = r.norm(grid) / bnorm;
    if res <= tol {
        return Ok(KrylovInfo { iterations: 0, residual: res.f64() });
    }
    pc.apply(r, z);
    p.assign(z);
    let mut rz = r.dot(grid, z);
    for it in 1..=params.max_iterations {
        op.apply(p, ap)?;
        let pap = p.dot(grid, ap);
        if pap <= T::zero() || !pap.is_finite() {
            return Err(no_convergence("PCG (breakdown)", it, res.f64(), params.tolerance));
        }
        let alpha = rz / pap;
        x.axpby(grid, alpha, p, T::one());
        let [rr, _] = r.update_reduce(grid, [ap], |r, [ap]| {
            let r = -alpha * ap + r;
            (r, [r * r, T::zero()])
        });
        res = rr.sqrt() / bnorm;
        if res <= tol {
            return Ok(KrylovInfo { iterations: it, residual: res.f64() });
        }
        pc.apply(r, z);
        let rz_new = r.dot(grid, z);
        let beta = rz_new / rz;
        rz = rz_new;
        p.axpby(grid, T::one(), z, beta);
    }
    Err(no_convergence("PCG", params.max_iterations, res.f64(), params.tolerance))
}
