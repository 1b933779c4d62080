//! Time-step limits of the membrane terms, measured (the paper leaves `dt` to trial and error,
//! see the remark after (2.40)).
//!
//! # The rule
//!
//! In the viscous regime of the paper's capsule flows (`Re <= 1`), an in-plane membrane mode of
//! wavelength `~h` relaxes at the rate `K / (mu h)` (the membrane's stiffest small-strain
//! modulus `K` over the viscous resistance of the fluid on both sides), and a bending mode at
//! `E_b / (mu h^3)`. With the stress explicit in time a step must stay below a fixed multiple
//! of these times. Measured by bisection on a stiff capsule in a slow shear flow
//! (`cases/examples/stability.rs --mode sweep`, `docs/stability.md`), for `K = E_s` from `2.5e4` to
//! `4e5`, `h` from `1/6` to `1/3`, `mu` from 25 to 400, `rho = 1`:
//!
//! - explicit in-plane stress ([`MembraneCoupling::Explicit`]): blows up above
//!   `20.7`–`23.6 mu h / K` at every point (18.2 at a viscosity ratio of 5) with the paper's
//!   smoothed traction, above `12.3`–`16` with the re-sampled sharp one (`--traction
//!   sharp-resampled`, the points of `K` and `h`), so the rule is `dt <= C_EXPLICIT mu h / K`
//!   with [`C_EXPLICIT`];
//! - quasi-implicit stress (2.32)–(2.35) ([`MembraneCoupling::QuasiImplicit`], the default):
//!   stable up to `146`–`1024 mu h / K` (the limit falls more slowly than `1 / K`, so its
//!   ratio to the explicit one grows from 8 to 43 with `K`; the re-sampled sharp traction
//!   `362`–`1024`); rule
//!   `dt <= C_QUASI_IMPLICIT mu h / K` with [`C_QUASI_IMPLICIT`];
//! - explicit bending ([`BendingCoupling::Explicit`]): `dt <= C_BENDING mu h^3 / E_b` with
//!   [`C_BENDING`] (the strong bending case of the suite, a stiff capsule with `E_b' = 0.0375`
//!   in shear, is stable at `0.22` and fails at `0.29 mu h^3 / E_b`; a soft capsule,
//!   `E_s = 100`, at `0.48`-`0.92`);
//! - semi-implicit bending ([`BendingCoupling::SemiImplicit`], the default; its stiff part in
//!   the predictor, [`BendingImplicit`](crate::membrane::bending_implicit::BendingImplicit)): the soft capsule
//!   is stable to `9.9`-`16.7 mu h^2 / E_b` (38 to 73 times the explicit limit at `h = 1/4`
//!   and `1/6`), where the predictor stops converging; rule `dt <= C_BENDING_SEMI_IMPLICIT mu
//!   h^2 / E_b` with [`C_BENDING_SEMI_IMPLICIT`].
//!
//! `mu` is the mean of the inner and outer viscosities, `h` the smallest spacing, `K` the
//! area-dilation modulus of the law (the larger small-strain modulus, see
//! [`small_strain_moduli`](crate::membrane::law::small_strain_moduli); `K = E_s` for [`NeoHookean`](crate::membrane::law::NeoHookean)).
//! The constants keep a margin of 1.2–1.7 below the smallest measured limits.
//!
//! Two limits are not in this rule: advection (the shear cases of the suite fail near a CFL
//! number `max|v| dt / h` of 0.35–0.4, whatever the coupling; see
//! [`StepReport`](super::StepReport)), and the slow accumulation of membrane strain in long
//! runs on coarse grids (the elastic energy of a tank-treading capsule grows steadily when the
//! capsule radius is 3–4 cells, and the run eventually fails whatever `dt`): refine the grid.
//!
//! A step whose `dt` exceeds [`Simulation::membrane_dt_limit`] (the smallest limit of the
//! scene's effects: these rules, and a user effect's own [`Effect::dt_limit`]) is taken, and its
//! [`StepReport`](super::StepReport) carries a
//! [`StepWarning::DtAboveLimit`](super::StepWarning::DtAboveLimit) (the library never prints).

use super::{
    BendingCoupling, MembraneCoupling, Simulation,
    effect::{Effect, Setup},
};
use crate::error::positive;
use crate::{Error, Real, Result};

/// `C` of the explicit in-plane rule `dt <= C mu h / K` (measured limits 18.2–23.6 with the
/// smoothed traction, 12.3–16 with the re-sampled sharp one).
pub const C_EXPLICIT: f64 = 10.0;
/// `C` of the quasi-implicit in-plane rule `dt <= C mu h / K` (measured limits 146–1024).
pub const C_QUASI_IMPLICIT: f64 = 100.0;
/// `C` of the explicit bending rule `dt <= C mu h^3 / E_b` (smallest measured limit 0.22).
pub const C_BENDING: f64 = 0.15;
/// `C` of the semi-implicit bending rule `dt <= C mu h^2 / E_b` (smallest measured limit 9.9).
pub const C_BENDING_SEMI_IMPLICIT: f64 = 6.0;

/// The largest `dt` the in-plane membrane stress allows (see the [module docs](self)):
/// `C mu h / k` with `C` = [`C_QUASI_IMPLICIT`] or [`C_EXPLICIT`].
///
/// `mu`: mean viscosity of the fluids on both sides; `h`: smallest grid spacing; `k`: the
/// stiffest small-strain modulus of the membrane law.
///
/// # Errors
/// Any argument not finite and `> 0`.
pub fn membrane_dt_limit(mu: f64, h: f64, k: f64, coupling: MembraneCoupling) -> Result<f64> {
    positive("mu", mu)?;
    positive("h", h)?;
    positive("k", k)?;
    let c = match coupling {
        MembraneCoupling::QuasiImplicit => C_QUASI_IMPLICIT,
        MembraneCoupling::Explicit => C_EXPLICIT,
    };
    Ok(c * mu * h / k)
}

/// The largest `dt` the bending force allows: [`C_BENDING`]` mu h^3 / eb` explicit,
/// [`C_BENDING_SEMI_IMPLICIT`]` mu h^2 / eb` semi-implicit.
///
/// # Errors
/// Any argument not finite and `> 0`.
pub fn bending_dt_limit(mu: f64, h: f64, eb: f64, coupling: BendingCoupling) -> Result<f64> {
    positive("mu", mu)?;
    positive("h", h)?;
    positive("eb", eb)?;
    Ok(match coupling {
        BendingCoupling::Explicit => C_BENDING * mu * h.powi(3) / eb,
        BendingCoupling::SemiImplicit { .. } => C_BENDING_SEMI_IMPLICIT * mu * h.powi(2) / eb,
    })
}

impl<T: Real> Simulation<T> {
    /// The time-step limit of this simulation: the smallest [`Effect::dt_limit`] of its
    /// effects, the paper's membrane effects and a user's own alike ([`membrane_dt_limit`] for
    /// [`Elasticity`](super::Elasticity), [`bending_dt_limit`] for [`Bending`](super::Bending),
    /// with the mean of the two viscosities and the smallest spacing); infinite without a
    /// limiting effect. A step above it carries
    /// [`StepWarning::DtAboveLimit`](super::StepWarning::DtAboveLimit) in its report.
    ///
    /// A limit that is not finite and `> 0` is left out here: [`Scene::build`](super::Scene::build)
    /// and every step refuse it with an error naming the effect.
    pub fn membrane_dt_limit(&self) -> f64 {
        let setup = self.setup();
        self.effects
            .iter()
            .filter_map(|e| e.dt_limit(&setup))
            .filter(|l| l.is_finite() && *l > 0.0)
            .fold(f64::INFINITY, f64::min)
    }

    /// [`membrane_dt_limit`](Self::membrane_dt_limit), refusing an effect's invalid limit (see
    /// [`effects_dt_limit`]).
    pub(crate) fn checked_dt_limit(&self) -> Result<f64> {
        effects_dt_limit(&self.effects, &self.setup())
    }
}

/// The smallest [`Effect::dt_limit`] of `effects` in `setup` (infinite without one).
///
/// # Errors
/// [`Error::InvalidParameter`] naming `dt_limit` and the effect, for a limit that is not finite
/// and `> 0`.
pub(crate) fn effects_dt_limit<T: Real>(effects: &[Box<dyn Effect<T>>], setup: &Setup<'_, T>) -> Result<f64> {
    effects.iter().try_fold(f64::INFINITY, |m, e| match e.dt_limit(setup) {
        None => Ok(m),
        Some(l) if l.is_finite() && l > 0.0 => Ok(m.min(l)),
        Some(l) => Err(Error::invalid(
            "dt_limit",
            format!("{l} from the effect `{}`", e.name()),
            "a finite step > 0 from Effect::dt_limit (None for no limit)",
        )),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule_scales_with_mu_h_over_k_and_quasi_implicit_allows_more() {
        let base = membrane_dt_limit(100.0, 0.25, 1e5, MembraneCoupling::Explicit).unwrap();
        assert!((base - C_EXPLICIT * 2.5e-4).abs() < 1e-15);
        let twice =
            |mu: f64, h: f64, k: f64| membrane_dt_limit(mu, h, k, MembraneCoupling::Explicit).unwrap();
        assert!((twice(200.0, 0.25, 1e5) / base - 2.0).abs() < 1e-12);
        assert!((twice(100.0, 0.5, 1e5) / base - 2.0).abs() < 1e-12);
        assert!((twice(100.0, 0.25, 5e4) / base - 2.0).abs() < 1e-12);
        let quasi = membrane_dt_limit(100.0, 0.25, 1e5, MembraneCoupling::QuasiImplicit).unwrap();
        assert!(quasi >= 3.0 * base, "quasi-implicit {quasi} vs explicit {base}");
        let bend = bending_dt_limit(100.0, 0.5, 2.0, BendingCoupling::Explicit).unwrap();
        assert!((bend - C_BENDING * 100.0 * 0.125 / 2.0).abs() < 1e-12);
        let semi = BendingCoupling::SemiImplicit { alpha: 1.0 };
        let bend_semi = bending_dt_limit(100.0, 0.5, 2.0, semi).unwrap();
        assert!((bend_semi - C_BENDING_SEMI_IMPLICIT * 100.0 * 0.25 / 2.0).abs() < 1e-12);
        // h^2 instead of h^3: the semi-implicit rule gains a factor 2 more per halving of h.
        let fine = bending_dt_limit(100.0, 0.25, 2.0, semi).unwrap();
        assert!((bend_semi / fine - 4.0).abs() < 1e-12 && bend_semi >= 4.0 * bend);
    }

    #[test]
    fn the_rule_refuses_bad_input() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(membrane_dt_limit(bad, 0.1, 1.0, MembraneCoupling::Explicit).is_err());
            assert!(membrane_dt_limit(1.0, bad, 1.0, MembraneCoupling::QuasiImplicit).is_err());
            assert!(membrane_dt_limit(1.0, 0.1, bad, MembraneCoupling::Explicit).is_err());
            assert!(bending_dt_limit(bad, 0.1, 1.0, BendingCoupling::Explicit).is_err());
            assert!(bending_dt_limit(1.0, bad, 1.0, BendingCoupling::Explicit).is_err());
            assert!(bending_dt_limit(1.0, 0.1, bad, BendingCoupling::Explicit).is_err());
        }
    }
}
