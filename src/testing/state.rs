//! Membrane states at a point, built from a deformation gradient, and the fixed set of probes
//! that [`check_law`](super::check_law) visits.

use std::fmt;

use crate::tensor::{Mat3, Sym, Vec3, dot, mat_to_sym, matmul, projector, sym_to_mat, transpose};
use crate::{Error, Result};

/// The rotation by `angle` (radians) about the unit vector `axis` (Rodrigues' formula). The
/// axis is used as given: a non-unit axis gives a matrix that is not a rotation.
pub fn rotation(axis: Vec3<f64>, angle: f64) -> Mat3<f64> {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

/// The point of the unit sphere at height `z` (in `[-1, 1]`) and azimuth `phi`: directions are
/// uniformly distributed when `z` and `phi` are (Archimedes).
pub fn sphere_point(z: f64, phi: f64) -> Vec3<f64> {
    let r = (1.0 - z * z).max(0.0).sqrt();
    [r * phi.cos(), r * phi.sin(), z]
}

/// The cofactor matrix `cof(F) = det(F) F⁻ᵀ`.
fn cofactor(f: &Mat3<f64>) -> Mat3<f64> {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let (i1, i2, j1, j2) = ((i + 1) % 3, (i + 2) % 3, (j + 1) % 3, (j + 2) % 3);
            f[i1][j1] * f[i2][j2] - f[i1][j2] * f[i2][j1]
        })
    })
}

pub(crate) fn mat_vec(a: &Mat3<f64>, v: &Vec3<f64>) -> Vec3<f64> {
    std::array::from_fn(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

/// A membrane element deformed by `F` from a flat reference plane of unit normal `n_R`:
/// `G_s = F P_R Fᵀ` (2.18), `P_R = I − n_R n_R`, and the current normal by Nanson's formula,
/// `n = cof(F) n_R / |cof(F) n_R|`. `G_s` is then in-plane with respect to `n` (`G_s n = 0`),
/// as in a simulation, and the area ratio is `J_s = √c2 = |cof(F) n_R|`.
///
/// # Example
/// ```
/// use eulermembrane::testing::{MembraneState, rotation};
///
/// // A sheet in the plane z = 0 stretched by 2 along x and 1/2 along y, then rotated.
/// let q = rotation([0.0, 0.0, 1.0], 0.3);
/// let s = MembraneState::stretched(q, [2.0, 0.5, 1.0], rotation([1.0, 0.0, 0.0], 0.0), [0.0, 0.0, 1.0])?;
/// let (l1, l2) = s.in_plane_stretches();
/// assert!((l1 - 2.0).abs() < 1e-14 && (l2 - 0.5).abs() < 1e-14);
/// assert!((s.n()[2] - 1.0).abs() < 1e-15);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MembraneState {
    f: Mat3<f64>,
    n_ref: Vec3<f64>,
    g: Sym<f64>,
    n: Vec3<f64>,
}

impl MembraneState {
    /// The state of deformation gradient `f` and unit reference normal `n_ref`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `n_ref` unless it is finite with `||n_ref| − 1| ≤ 1e-12`,
    /// or naming `f` unless it is finite and keeps area: `|cof(F) n_R| > 1e-12 |F|²`.
    pub fn new(f: Mat3<f64>, n_ref: Vec3<f64>) -> Result<Self> {
        if !(n_ref.iter().all(|x| x.is_finite()) && (dot(&n_ref, &n_ref).sqrt() - 1.0).abs() <= 1e-12) {
            return Err(Error::invalid(
                "n_ref",
                format!("{n_ref:?}"),
                "a finite unit vector (|n_ref| - 1 within 1e-12)",
            ));
        }
        let f2: f64 = f.iter().flatten().map(|x| x * x).sum();
        let js = {
            let c = mat_vec(&cofactor(&f), &n_ref);
            dot(&c, &c).sqrt()
        };
        if !(f2.is_finite() && js > 1e-12 * f2) {
            return Err(Error::invalid(
                "f",
                format!("{f:?}"),
                "a finite deformation gradient that keeps the area of the reference plane: \
                 |cof(F) n_ref| > 1e-12 |F|^2",
            ));
        }
        Ok(Self::from_parts(f, n_ref))
    }

    /// `F = R1 diag(l) R2` applied to the plane of unit normal `n_ref`: principal stretches `l`
    /// between two rotations (`r1`, `r2` should be rotations; they are used as given).
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn stretched(r1: Mat3<f64>, l: [f64; 3], r2: Mat3<f64>, n_ref: Vec3<f64>) -> Result<Self> {
        Self::new(stretch_between(&r1, l, &r2), n_ref)
    }

    /// Without the checks of [`new`](Self::new), for arguments valid by construction.
    pub(crate) fn from_parts(f: Mat3<f64>, n_ref: Vec3<f64>) -> Self {
        let pr = sym_to_mat(&projector(&n_ref));
        let g = mat_to_sym(&matmul(&matmul(&f, &pr), &transpose(&f)));
        let c = mat_vec(&cofactor(&f), &n_ref);
        let s = dot(&c, &c).sqrt();
        Self { f, n_ref, g, n: c.map(|x| x / s) }
    }

    /// The state after a further deformation `a` (`F → a F`); `a` must keep area.
    pub(crate) fn then(&self, a: &Mat3<f64>) -> Self {
        Self::from_parts(matmul(a, &self.f), self.n_ref)
    }

    /// The deformation gradient `F`.
    pub fn f(&self) -> Mat3<f64> {
        self.f
    }

    /// The unit normal `n_R` of the reference plane.
    pub fn n_ref(&self) -> Vec3<f64> {
        self.n_ref
    }

    /// The surface deformation tensor `G_s = F P_R Fᵀ` (2.18), tensor components.
    pub fn g(&self) -> Sym<f64> {
        self.g
    }

    /// The current unit normal `n ∝ cof(F) n_R` (Nanson).
    pub fn n(&self) -> Vec3<f64> {
        self.n
    }

    /// The principal in-plane stretches `(λ1, λ2)`, `λ1 ≥ λ2`: the square roots of the
    /// eigenvalues of the metric `C_ab = (F t_a)·(F t_b)` of an orthonormal basis `t_1`, `t_2`
    /// of the reference plane (computed from `F`, independently of `G_s`).
    pub fn in_plane_stretches(&self) -> (f64, f64) {
        let nr = self.n_ref;
        let e = if nr[0].abs() < 0.6 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let t1 = unit(crate::tensor::cross(&nr, &e));
        let t2 = crate::tensor::cross(&nr, &t1);
        let (a, b) = (mat_vec(&self.f, &t1), mat_vec(&self.f, &t2));
        let (caa, cbb, cab) = (dot(&a, &a), dot(&b, &b), dot(&a, &b));
        let m = 0.5 * (caa + cbb);
        let r = (0.25 * (caa - cbb).powi(2) + cab * cab).sqrt();
        ((m + r).sqrt(), (m - r).max(0.0).sqrt())
    }
}

impl fmt::Display for MembraneState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (l1, l2) = self.in_plane_stretches();
        write!(
            f,
            "F = {:?}, n_ref = {:?} (in-plane stretches {l1:.4}, {l2:.4}; G_s = {:?}, n = {:?})",
            self.f, self.n_ref, self.g, self.n
        )
    }
}

fn unit(v: Vec3<f64>) -> Vec3<f64> {
    let s = dot(&v, &v).sqrt();
    v.map(|x| x / s)
}

pub(crate) fn stretch_between(r1: &Mat3<f64>, l: [f64; 3], r2: &Mat3<f64>) -> Mat3<f64> {
    let d = [[l[0], 0.0, 0.0], [0.0, l[1], 0.0], [0.0, 0.0, l[2]]];
    matmul(&matmul(r1, &d), r2)
}

/// One point of a law check: a deformed state, a velocity gradient (for the power identity and
/// the quasi-implicit term `H`), and a rotation (for objectivity, and for the rigidly rotated
/// reference state).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// The deformed membrane element.
    pub state: MembraneState,
    /// A velocity gradient in the paper's convention, `grad_v[i][j] = ∂v_j/∂x_i`.
    pub grad_v: Mat3<f64>,
    /// A rotation `Q` (proper orthogonal).
    pub rotation: Mat3<f64>,
}

impl fmt::Display for Probe {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} with grad_v = {:?}, Q = {:?}", self.state, self.grad_v, self.rotation)
    }
}

/// The principal stretches of the probes of [`sample_probes`].
pub const SAMPLE_STRETCHES: [f64; 5] = [0.5, 0.7, 1.0, 1.4, 2.0];

/// SplitMix64: a fixed sequence of uniform numbers in `[0, 1)`, so that the probes are the
/// same on every machine and every run.
struct SplitMix(u64);

impl SplitMix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    fn symmetric(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
    }

    fn unit(&mut self) -> Vec3<f64> {
        let z = self.symmetric();
        sphere_point(z, std::f64::consts::TAU * self.uniform())
    }

    fn rotation(&mut self) -> Mat3<f64> {
        let axis = self.unit();
        rotation(axis, std::f64::consts::TAU * self.uniform())
    }
}

/// The deterministic probes of [`check_law`](super::check_law): 50 states, two for each pair
/// `(λ1, λ2)` of [`SAMPLE_STRETCHES`] (so in-plane stretches in `[0.5, 2]`, equal and unequal,
/// the undeformed state included):
/// - `F = R1 diag(λ1, λ2, 1) R2` on the plane of normal `n_R = R2ᵀ e3`, whose in-plane
///   stretches are exactly `λ1`, `λ2`;
/// - `F = R1 diag(λ1, λ2, λ3) R2` on a plane of generic normal, `λ3` cycling through
///   [`SAMPLE_STRETCHES`] (in-plane stretches between 0.5 and 2, with shear between the plane
///   and its normal).
///
/// Rotations, normals and velocity gradients (entries in `[-1, 1]`) come from a fixed
/// pseudo-random sequence.
pub fn sample_probes() -> Vec<Probe> {
    let mut rng = SplitMix(0x5eed_1a55_c0de_2012);
    let mut probes = Vec::with_capacity(2 * SAMPLE_STRETCHES.len().pow(2));
    for (i, &l1) in SAMPLE_STRETCHES.iter().enumerate() {
        for (j, &l2) in SAMPLE_STRETCHES.iter().enumerate() {
            let l3 = SAMPLE_STRETCHES[(i + 2 * j) % SAMPLE_STRETCHES.len()];
            for aligned in [true, false] {
                let (r1, r2) = (rng.rotation(), rng.rotation());
                let (l, n_ref) = if aligned {
                    ([l1, l2, 1.0], mat_vec(&transpose(&r2), &[0.0, 0.0, 1.0]))
                } else {
                    ([l1, l2, l3], rng.unit())
                };
                let grad_v = std::array::from_fn(|_| std::array::from_fn(|_| rng.symmetric()));
                probes.push(Probe {
                    state: MembraneState::from_parts(stretch_between(&r1, l, &r2), n_ref),
                    grad_v,
                    rotation: rng.rotation(),
                });
            }
        }
    }
    probes
}
