//! # Your own membrane law
//!
//! The library's membranes get their stress from a strain-energy law `W_s(c1, c2)` (the
//! `SurfaceLaw` trait): the stress (2.4), its Jacobian (2.33) (App. B) and the quasi-implicit
//! term `H` (2.35), (B.6) are all derived from the law's energy and its first and second
//! derivatives. This example writes a law the library does not ship, the Evans–Skalak law of
//! red-cell membranes (Evans & Skalak 1980): a shear part that does not care about area plus a
//! separate area-dilation penalty,
//!
//! ```text
//! W_s = G ( (λ1² + λ2²) / (2 λ1 λ2) − 1 ) + (K/2) (λ1 λ2 − 1)²
//!     = G ( (c1 + 1) / (2 √c2) − 1 )      + (K/2) (√c2 − 1)²
//! ```
//!
//! in the invariants (2.3) of the paper (`c1 = λ1² + λ2² − 1`, `c2 = λ1² λ2²`). Its
//! small-strain shear modulus is `G` and its area-dilation modulus is exactly `K`; under an
//! isotropic stretch `λ` the shear part vanishes and the tension is `T = K (λ² − 1)`.
//!
//! The example then
//! 1. checks the law with the `eulermembrane::testing` harness (feature `testing`, which the
//!    library's dev-dependencies enable; a downstream crate adds
//!    `eulermembrane = { version = "...", features = ["testing"] }` to its dev-dependencies):
//!    the reference state is stress free, the gradient and Hessian match finite differences of
//!    the energy, the Jacobian matches finite differences of the stress, `H` of (2.35),
//!    objectivity, the power identity, ... at 50 probe states;
//! 2. checks the library's generic equibiaxial solver against the closed form `K (λ² − 1)`;
//! 3. plugs the law into a `Scene`: a capsule pre-stretched by 5 % at rest in a periodic box
//!    (like `cases/examples/inflated_capsule.rs`), whose tension must be held by the Laplace
//!    pressure jump `Δp = 2 T / r`.
//!
//! Run: `cargo run --release --example custom_law` (no arguments; a few seconds).
//!
//! Prints the harness report (the worst error of each property against its tolerance) and the
//! coupled run's progress to stderr, then one line on stdout:
//!
//! ```text
//! RESULT law=evans_skalak points=50 mu=... k=... gradient_err=... hessian_err=... jacobian_err=... h_tensor_err=... power_err=... worst_of_tolerance=... caught=hessian tension=... tension_closed=... jump=... laplace=... rel_err=... spurious=... wall_s=...
//! ```
//!
//! (`*_err`: the harness's worst dimensionless errors; `worst_of_tolerance`: the largest
//! error / tolerance over all its properties, below 1 when it passes; `caught`: the property
//! that refuses a copy of the law with a sign error in `W_12`.) What to expect (measured): the
//! finite-difference errors are round-off, 3e-11 to 5e-10, at most 0.08 of their tolerances;
//! the generic tension equals the closed form `K (λ² − 1) = 0.15375`; the pressure jump is
//! 0.3107 against `2 T / r = 0.3075`, +1.04 %, with spurious currents of 0.17 % of `T / mu`;
//! about 8 s of CPU. The run fails with an error if the harness rejects the law or accepts
//! the wrong copy, if the tension differs from the closed form by more than 1e-12
//! (relative), or if the jump is more than 3 % from `2 T / r`.

use eulermembrane::Real;
use eulermembrane::grid::Grid;
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::{law::SurfaceLaw, loading::equibiaxial_tension};
use eulermembrane::simulation::{Phase, Scene};
use eulermembrane::testing::{LawCheckError, Property, check_law};
use std::time::Instant;

/// The Evans–Skalak membrane law (see the file header): shear modulus `g`, area-dilation
/// modulus `k`. Generic over the float type, like the library's own laws, so that it also runs
/// in `f32`.
#[derive(Debug, Clone, Copy)]
struct EvansSkalak<T> {
    g: T,
    k: T,
}

impl<T: Real> SurfaceLaw<T> for EvansSkalak<T> {
    /// A short name, used in reports and error messages.
    fn name(&self) -> &str {
        "evans_skalak"
    }

    /// `W_s(c1, c2)`, energy per unit *reference* area. With `s = √c2 = λ1 λ2` (the area
    /// ratio): `W = G ((c1 + 1)/(2 s) − 1) + (K/2)(s − 1)²`; zero at rest (`c1 = c2 = 1`), as the
    /// harness asks (it keeps the round-off of its finite differences small).
    fn energy(&self, c1: T, c2: T) -> T {
        let (one, half) = (T::one(), T::lit(0.5));
        let s = c2.sqrt();
        self.g * ((c1 + one) * half / s - one) + half * self.k * (s - one) * (s - one)
    }

    /// `[∂W/∂c1, ∂W/∂c2]` (the `W_{s,c1}`, `W_{s,c2}` of (B.5)):
    /// `W_1 = G / (2 s)`, `W_2 = (K/2)(1 − 1/s) − G (c1 + 1) / (4 s³)`.
    /// At rest `W_1 + W_2 = 0`: the reference state is stress free.
    fn gradient(&self, c1: T, c2: T) -> [T; 2] {
        self.derivatives(c1, c2).0
    }

    /// `[∂²W/∂c1², ∂²W/∂c1∂c2, ∂²W/∂c2²]`: `W_11 = 0`, `W_12 = −G / (4 s³)`,
    /// `W_22 = K / (4 s³) + 3 G (c1 + 1) / (8 s⁵)`. Unlike (2.5) and (2.6) the mixed derivative
    /// is not zero: the library keeps the term that the paper's (B.4) drops.
    fn hessian(&self, c1: T, c2: T) -> [T; 3] {
        self.derivatives(c1, c2).1
    }

    /// Both at once (the stress and Jacobian call this), sharing `s` and its powers. The
    /// harness checks that it agrees with `gradient` and `hessian` (property `derivatives`).
    fn derivatives(&self, c1: T, c2: T) -> ([T; 2], [T; 3]) {
        let (one, two, four, eight) = (T::one(), T::lit(2.0), T::lit(4.0), T::lit(8.0));
        let s = c2.sqrt();
        let s3 = s * s * s;
        let s5 = s3 * s * s;
        let a = c1 + one; // λ1² + λ2²
        let gradient = [self.g / (two * s), self.k / two * (one - one / s) - self.g * a / (four * s3)];
        let hessian = [
            T::zero(),
            -self.g / (four * s3),
            self.k / (four * s3) + T::lit(3.0) * self.g * a / (eight * s5),
        ];
        (gradient, hessian)
    }
}

/// The law with a mistake: the mixed derivative `W_12` with the wrong sign.
struct SignError(EvansSkalak<f64>);

impl SurfaceLaw<f64> for SignError {
    fn name(&self) -> &str {
        "evans_skalak_sign_error"
    }
    fn energy(&self, c1: f64, c2: f64) -> f64 {
        self.0.energy(c1, c2)
    }
    fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] {
        self.0.gradient(c1, c2)
    }
    fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
        let [w11, w12, w22] = self.0.hessian(c1, c2);
        [w11, -w12, w22]
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let clock = Instant::now();
    // The moduli of the library's Skalak law (2.6) with E_s = 1, alpha = 1 (G_s = E_s / 2,
    // K = G_s (1 + 2 alpha)): the two laws agree at small strain and differ at large strain.
    let law = EvansSkalak { g: 0.5, k: 1.5 };

    // --- 1. The harness ----------------------------------------------------------------------
    // `check_law` first refuses a law whose rest state is stressed or unstable (`mu`, `K` > 0),
    // then measures every property at 50 probe states (principal stretches in [0.5, 2], oblique
    // normals, rotations, velocity gradients). It returns an error naming the first property
    // beyond its tolerance; a sign or factor mistake in a derivative gives an error of order 1.
    let report = check_law(&law)?;
    eprint!("{report}");
    let err = |p: Property| report.worst(p).map_or(f64::NAN, |m| m.error);
    let worst_of_tolerance = report.worst.iter().map(|m| m.error / m.tolerance).fold(0.0, f64::max);
    let (mu, k) = report.moduli; // the small-strain moduli the harness found: G and K
    if (mu - law.g).abs() > 1e-12 || (k - law.k).abs() > 1e-12 {
        return Err(format!("small-strain moduli ({mu}, {k}), expected ({}, {})", law.g, law.k).into());
    }
    // What it catches: the same law with the sign of W_12 flipped. Its rest state is still
    // stress free and stable (only the area modulus changes, from K to K + 4 G), so a
    // simulation would run, wrongly; the harness finds that the Hessian is not the derivative
    // of the gradient, and names the property.
    let caught = match check_law(&SignError(law)) {
        Err(LawCheckError::Failed { measure, .. }) => {
            eprintln!("a sign error in W_12 is refused: {measure}");
            measure.property
        }
        other => return Err(format!("the harness accepted a wrong Hessian: {other:?}").into()),
    };

    // --- 2. A closed form --------------------------------------------------------------------
    // The library solves simple loadings for any law from its stress (2.4). Under the
    // pre-stretch below (lambda1 = lambda2 = lambda) the shear part is zero and T = K (λ² − 1).
    let lambda = 1.05;
    let tension = equibiaxial_tension(&law, lambda)?;
    let tension_closed = law.k * (lambda * lambda - 1.0);
    if (tension / tension_closed - 1.0).abs() > 1e-12 {
        return Err(format!("equibiaxial tension {tension:e}, closed form {tension_closed:e}").into());
    }

    // --- 3. The law in a coupled run -----------------------------------------------------------
    // A capsule of radius 1 at rest in the periodic box [-2, 2]^3, 32 cells a side (8 cells per
    // radius), rho = mu = 1. `prestretch` sets G_s = lambda^2 P on the membrane: its reference
    // (unstressed) shape is 5 % smaller than its shape, so it pulls inwards with the tension T,
    // and the fluid inside must push back with the pressure jump 2 T / r (Laplace). The law goes
    // in exactly where a library law would; the default settings.
    let n = 32;
    let (radius, mu_fluid) = (1.0, 1.0);
    let grid = Grid::<f64>::periodic([n; 3], [-2.0; 3], [2.0; 3])?;
    let h = 4.0 / n as f64;
    let mut sim = Scene::new(grid, Phase::new(1.0, mu_fluid)?)
        .capsule(Sphere::new([0.0; 3], radius)?)
        .elasticity(law)
        .build()?;
    sim.prestretch(0, lambda)?;
    // 40 fixed steps of h / 4 from rest (the set-up of docs/validation/inflated_capsule.md):
    // the pressure settles at once, the small spurious currents decay.
    let (steps, dt) = (40, 0.25 * h);
    let summary = sim.run(steps as f64 * dt, dt, &mut [])?;
    eprintln!(
        "coupled run: {} steps to t = {:.3} ({:.1} s)",
        summary.steps,
        summary.time,
        clock.elapsed().as_secs_f64()
    );

    // The jump: mean pressure well inside (phi > 0.999) minus mean pressure well outside
    // (phi < 0.001), over the cells of the grid. `idx_u` is the index of cell (i, j, k) in a
    // field's data.
    let g = sim.grid();
    let (phi, p) = (sim.phi(0)?, sim.pressure());
    let (mut inside, mut outside) = ((0.0, 0.0), (0.0, 0.0));
    for (i, j, kk) in g.cells() {
        let idx = g.idx_u(i, j, kk);
        if phi.values()[idx] > 0.999 {
            inside = (inside.0 + p.values()[idx], inside.1 + 1.0);
        } else if phi.values()[idx] < 0.001 {
            outside = (outside.0 + p.values()[idx], outside.1 + 1.0);
        }
    }
    let jump = inside.0 / inside.1 - outside.0 / outside.1;
    let laplace = 2.0 * tension / radius;
    let rel_err = jump / laplace - 1.0;
    // Spurious currents: the largest velocity over the velocity scale T / mu (zero in the
    // continuum: the capsule is at rest).
    let vmax = sim.velocity().c.iter().flat_map(|c| c.values().iter()).fold(0.0f64, |m, v| m.max(v.abs()));
    let spurious = vmax / (tension / mu_fluid);

    println!(
        "RESULT law={} points={} mu={mu:.4e} k={k:.4e} gradient_err={:.3e} hessian_err={:.3e} \
         jacobian_err={:.3e} h_tensor_err={:.3e} power_err={:.3e} worst_of_tolerance={worst_of_tolerance:.3e} caught={caught} \
         tension={tension:.6e} tension_closed={tension_closed:.6e} jump={jump:.5e} laplace={laplace:.5e} \
         rel_err={rel_err:.4e} spurious={spurious:.3e} wall_s={:.1}",
        report.law,
        report.points,
        err(Property::Gradient),
        err(Property::Hessian),
        err(Property::Jacobian),
        err(Property::HTensor),
        err(Property::PowerIdentity),
        clock.elapsed().as_secs_f64()
    );
    if rel_err.abs() > 0.03 {
        return Err(format!(
            "pressure jump {jump:.5} is {:.2} % from Laplace 2T/r = {laplace:.5}",
            100.0 * rel_err
        )
        .into());
    }
    Ok(())
}
