//! [proptest](https://docs.rs/proptest) strategies for membrane states.

use std::f64::consts::TAU;
use std::ops::RangeInclusive;

use proptest::prelude::*;

use super::state::{MembraneState, Probe, rotation, sphere_point, stretch_between};
use crate::tensor::{Mat3, Vec3};
use crate::{Error, Result};

/// The configuration of the crate's own property tests: 256 cases per property.
///
/// # Example
/// ```
/// assert_eq!(eulermembrane::testing::config().cases, 256);
/// ```
pub fn config() -> ProptestConfig {
    ProptestConfig::with_cases(256)
}

/// Unit vectors, uniformly distributed on the sphere.
///
/// # Example
/// ```
/// use eulermembrane::testing::arb_unit;
/// use proptest::prelude::*;
///
/// proptest!(|(n in arb_unit())| {
///     prop_assert!((n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0).abs() < 1e-15);
/// });
/// ```
pub fn arb_unit() -> impl Strategy<Value = Vec3<f64>> {
    (-1.0f64..=1.0, 0.0f64..TAU).prop_map(|(z, phi)| sphere_point(z, phi))
}

/// Rotations: a uniform axis ([`arb_unit`]) and a uniform angle in `[0, 2π)`.
///
/// # Example
/// ```
/// use eulermembrane::tensor::{matmul, transpose};
/// use eulermembrane::testing::arb_rotation;
/// use proptest::prelude::*;
///
/// proptest!(|(q in arb_rotation())| {
///     let qqt = matmul(&q, &transpose(&q));
///     for i in 0..3 {
///         for j in 0..3 {
///             let delta = if i == j { 1.0 } else { 0.0 };
///             prop_assert!((qqt[i][j] - delta).abs() < 1e-14);
///         }
///     }
/// });
/// ```
pub fn arb_rotation() -> impl Strategy<Value = Mat3<f64>> {
    (arb_unit(), 0.0f64..TAU).prop_map(|(axis, angle)| rotation(axis, angle))
}

/// Membrane states with principal stretches in `[0.5, 2]`: see [`arb_state_with`].
///
/// # Example
/// ```
/// use eulermembrane::membrane::stress::surface_kinematics;
/// use eulermembrane::testing::arb_state;
/// use proptest::prelude::*;
///
/// proptest!(|(s in arb_state())| {
///     let (l1, l2) = s.in_plane_stretches();
///     prop_assert!(0.5 - 1e-12 <= l2 && l2 <= l1 && l1 <= 2.0 + 1e-12);
///     // The area ratio: √c2 = λ1 λ2.
///     let c2 = surface_kinematics(&s.g(), &s.n()).c2;
///     prop_assert!((c2.sqrt() - l1 * l2).abs() < 1e-12);
/// });
/// ```
pub fn arb_state() -> impl Strategy<Value = MembraneState> {
    state_in(0.5, 2.0)
}

/// Membrane states `F = R1 diag(λ1, λ2, λ3) R2` with the three stretches uniform in
/// `stretches`, random rotations ([`arb_rotation`]) and a random reference normal
/// ([`arb_unit`]); then `G_s = F P_R Fᵀ` and the Nanson normal (see [`MembraneState`]). The
/// in-plane principal stretches lie in the same range.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `stretches` unless `0 < start ≤ end < ∞`.
///
/// # Example
/// ```
/// use eulermembrane::testing::arb_state_with;
/// use proptest::prelude::*;
///
/// let small = arb_state_with(0.9..=1.1)?;
/// proptest!(|(s in small)| {
///     let (l1, l2) = s.in_plane_stretches();
///     prop_assert!(0.9 - 1e-12 <= l2 && l1 <= 1.1 + 1e-12);
/// });
/// assert!(arb_state_with(0.0..=1.0).is_err());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn arb_state_with(stretches: RangeInclusive<f64>) -> Result<impl Strategy<Value = MembraneState>> {
    let (lo, hi) = stretches.into_inner();
    if !(lo > 0.0 && lo <= hi && hi.is_finite()) {
        return Err(Error::invalid(
            "stretches",
            format!("{lo}..={hi}"),
            "a range 0 < start <= end < infinity",
        ));
    }
    Ok(state_in(lo, hi))
}

fn state_in(lo: f64, hi: f64) -> impl Strategy<Value = MembraneState> {
    (arb_rotation(), [lo..=hi, lo..=hi, lo..=hi], arb_rotation(), arb_unit())
        .prop_map(|(r1, l, r2, n_ref)| MembraneState::from_parts(stretch_between(&r1, l, &r2), n_ref))
}

/// Velocity gradients with entries uniform in `[-1, 1]`.
///
/// # Example
/// ```
/// use eulermembrane::testing::arb_velocity_gradient;
/// use proptest::prelude::*;
///
/// proptest!(|(gv in arb_velocity_gradient())| {
///     prop_assert!(gv.iter().flatten().all(|x| x.abs() <= 1.0));
/// });
/// ```
pub fn arb_velocity_gradient() -> impl Strategy<Value = Mat3<f64>> {
    let row = || [-1.0f64..=1.0, -1.0f64..=1.0, -1.0f64..=1.0];
    [row(), row(), row()]
}

/// Probes for [`check_at`](super::check_at): an [`arb_state`], an [`arb_velocity_gradient`]
/// and an [`arb_rotation`].
///
/// # Example
/// ```
/// use eulermembrane::membrane::law::NeoHookean;
/// use eulermembrane::testing::{arb_probe, check_at};
/// use proptest::prelude::*;
///
/// let law = NeoHookean::new(1.0)?;
/// proptest!(|(p in arb_probe())| {
///     check_at(&law, &p)?;
/// });
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn arb_probe() -> impl Strategy<Value = Probe> {
    (arb_state(), arb_velocity_gradient(), arb_rotation()).prop_map(|(state, grad_v, rotation)| Probe {
        state,
        grad_v,
        rotation,
    })
}
