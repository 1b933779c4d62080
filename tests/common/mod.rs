//! Helpers shared by the integration tests of the membrane laws.
#![allow(dead_code)]

use eulermembrane::tensor::{Mat3, Vec3};

/// Rotation by `angle` about the unit `axis` (Rodrigues' formula).
pub fn rodrigues(axis: Vec3<f64>, angle: f64) -> Mat3<f64> {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

/// The point of the unit sphere at height `z` and azimuth `phi` (uniform sampling of directions
/// when `z` and `phi` are uniform).
pub fn sphere(z: f64, phi: f64) -> Vec3<f64> {
    let r = (1.0 - z * z).max(0.0).sqrt();
    [r * phi.cos(), r * phi.sin(), z]
}
