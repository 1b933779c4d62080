//! # Your own time loop: accept a step only when you like it
//!
//! ```sh
//! cargo run --release --example custom_driver      # about 6 s on 2 cores
//! ```
//!
//! `Simulation::step(dt)` is two phases, and a driver can call them itself:
//! - `prepare(dt)` computes the step *beside* the state and returns its report (Courant number,
//!   solver iterations, warnings); `proposed_velocity()` and `proposed_phi(c)` show the
//!   proposal. The state is untouched;
//! - `commit()` makes the proposal the state, or `discard()` forgets it (the state stays exactly
//!   as it was, to the bit), and the driver may try another `dt`.
//!
//! This example's driver accepts a step only if no velocity on the grid changes by more than
//! 1 % of the wall speed and the capsule's volume stays put; otherwise it discards the step and
//! retries with half the step. After an accepted step it proposes the next `dt` from how close
//! the change came to the limit (the change is about proportional to `dt`), so retries are rare.
//! It counts the retries.
//!
//! The case: a capsule (radius 0.4, 3.2 cells) in the shear between two walls moving at -1 and
//! +1, starting as a sphere in the undisturbed shear and run to `t = 1`, while its deformation
//! `D` grows from 0 to about 0.3. The same case runs three times:
//! 1. with this driver (largest step 0.05);
//! 2. with the library's adaptive stepper `AdaptiveDt` (same largest step; it keeps the
//!    Courant number near 0.3 and `dt` below the membrane's stability limit, and retries failed
//!    steps);
//! 3. with plain fixed steps `dt = 2.5e-3` (`Simulation::run`), as the reference for `D`
//!    (doubling this step changes `D` by only 1.4e-4, or 5e-4 of `D`).
//!
//! ## What it prints, and what to expect
//!
//! The driver's rejected attempts and every 5th accepted step, a line per run (steps, retries,
//! `D` at `t = 1`, wall time), then
//!
//! ```text
//! RESULT custom_steps=44 custom_retries=5 adaptive_steps=30 adaptive_retries=2 d_reference=2.4528e-1 d_custom=2.4610e-1 d_adaptive=2.4737e-1 err_custom=3.34e-3 err_adaptive=8.51e-3
//! ```
//!
//! (measured on this machine; `err_*` is `|D - D_reference| / D_reference`). The stricter
//! driver takes about 1.5 times the steps of `AdaptiveDt` and cuts its error in `D` by 2.5. The example
//! returns an error if `err_custom > 6e-3` or `err_adaptive > 1e-2` (measured 3.3e-3 and
//! 8.5e-3), or if an accepted step of the driver broke its own criterion.

use eulermembrane::Error;
use eulermembrane::diagnostics::{
    taylor::taylor_deformation,
    volume::{centroid, volume},
};
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{Phase, Scene, Simulation, timestep::AdaptiveDt};
use std::time::Instant;

/// The run's end time.
const T_END: f64 = 1.0;
/// The largest step, for the driver and for `AdaptiveDt`.
const MAX_DT: f64 = 0.05;
/// The driver's criterion: no velocity changes by more than this in one step (the walls move
/// at speed 1, so this is 1 % of the wall speed).
const MAX_VELOCITY_CHANGE: f64 = 0.01;
/// The driver's second criterion: the capsule's relative volume change in one step. The
/// library's interface transport (MTHINC) conserves volume to round-off (about 1e-16 a step
/// here), so this never rejects a step in this example; it would guard a transport of your own
/// (`Scene::interface_transport`).
const MAX_VOLUME_CHANGE: f64 = 1e-9;

/// The case, built afresh for each run: walls at z = -1 and z = 1 moving at -1 and +1 along x
/// (shear rate 1), periodic in x and y, a neo-Hookean capsule of radius 0.4 at the centre,
/// starting from the undisturbed shear. Library defaults otherwise (`Settings::default()`).
fn build() -> eulermembrane::Result<Simulation<f64>> {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
    let grid = Grid::<f64>::new([24, 16, 24], [-1.5, -1.0, -1.0], [1.5, 1.0, 1.0], bc)?;
    let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?) // rho, mu
        .capsule(Sphere::new([0.0; 3], 0.4)?)
        .elasticity(NeoHookean::new(10.0)?) // E_s = 3 G_s: capillary number mu a / G_s = 0.12
        .build()?;
    sim.set_velocity(|x| [x[2], 0.0, 0.0])?;
    Ok(sim)
}

/// Taylor deformation `D` of the capsule's section through its centroid in the x-z plane.
fn deformation(sim: &Simulation<f64>) -> eulermembrane::Result<f64> {
    let phi = sim.phi(0)?;
    let c = centroid(sim.grid(), phi)?;
    Ok(taylor_deformation(sim.grid(), phi, c, 1)?.deformation)
}

/// The largest change of any velocity component over the interior faces between the state and
/// the prepared step (`None` when no step is prepared).
fn max_velocity_change(sim: &Simulation<f64>) -> Option<f64> {
    let (g, now, next) = (sim.grid(), sim.velocity(), sim.proposed_velocity()?);
    let mut largest: f64 = 0.0;
    for (i, j, k) in g.cells() {
        let idx = g.idx_u(i, j, k);
        for d in 0..3 {
            largest = largest.max((next.c[d].values()[idx] - now.c[d].values()[idx]).abs());
        }
    }
    Some(largest)
}

/// What the driver did.
struct DriverSummary {
    steps: usize,
    retries: usize,
    /// The largest velocity change of an accepted step (must be within the criterion).
    worst_change: f64,
}

/// The user's time loop: prepare, judge, then commit or discard and halve.
fn run_custom(sim: &mut Simulation<f64>) -> eulermembrane::Result<DriverSummary> {
    let mut summary = DriverSummary { steps: 0, retries: 0, worst_change: 0.0 };
    let mut dt = MAX_DT;
    while T_END - sim.time() > 1e-12 {
        // Land on T_END exactly.
        let step = dt.min(T_END - sim.time());
        if step < 1e-6 {
            return Err(Error::user(format!(
                "custom driver: no acceptable step down to dt = {step:.2e} at t = {:.4}",
                sim.time()
            )));
        }
        let volume_now = volume(sim.grid(), sim.phi(0)?)?;
        // Phase 1: compute the step beside the state. A step that fails (a solver that does
        // not converge, a non-finite value) is an `Error::Step` and leaves nothing prepared:
        // treat it like a rejected step. Any other error is a mistake in the call: stop.
        let report = match sim.prepare(step) {
            Ok(report) => report,
            Err(e @ Error::Step { .. }) => {
                println!("  t = {:.4}: dt = {step:.3e} failed ({e}); retrying with half", sim.time());
                summary.retries += 1;
                dt = 0.5 * step;
                continue;
            }
            Err(e) => return Err(e),
        };
        // Judge the proposal: the velocity change, and the volume of the proposed phi.
        let change = max_velocity_change(sim).unwrap_or(f64::INFINITY);
        let volume_next = match sim.proposed_phi(0)? {
            Some(phi) => volume(sim.grid(), phi)?,
            None => f64::INFINITY, // nothing prepared: cannot happen after a successful prepare
        };
        let volume_change = (volume_next - volume_now).abs() / volume_now;
        if change > MAX_VELOCITY_CHANGE || volume_change > MAX_VOLUME_CHANGE {
            // Phase 2, no: forget the proposal (the state is as before `prepare`) and retry.
            sim.discard();
            println!(
                "  t = {:.4}: dt = {step:.3e} rejected (velocity change {change:.2e}, volume \
                 change {volume_change:.1e}); retrying with half",
                sim.time()
            );
            summary.retries += 1;
            dt = 0.5 * step;
            continue;
        }
        // Phase 2, yes: make it the state.
        sim.commit()?;
        summary.steps += 1;
        summary.worst_change = summary.worst_change.max(change);
        if summary.steps.is_multiple_of(5) {
            println!(
                "  t = {:.4}: step {} dt = {step:.3e} velocity change {change:.2e} Courant {:.3}",
                sim.time(),
                summary.steps,
                report.flow.cfl
            );
        }
        // The next step: the change is about proportional to dt, so aim at 80 % of the limit,
        // growing by at most 1.5 per step and never above MAX_DT.
        let aim = 0.8 * MAX_VELOCITY_CHANGE / change.max(1e-300);
        dt = (step * aim.min(1.5)).min(MAX_DT);
    }
    Ok(summary)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // 1. The user's driver.
    println!("custom driver (velocity change <= {MAX_VELOCITY_CHANGE} per step):");
    let clock = Instant::now();
    let mut sim = build()?;
    let custom = run_custom(&mut sim)?;
    let d_custom = deformation(&sim)?;
    println!(
        "custom driver: {} steps, {} retries, D = {d_custom:.5e} at t = {:.4} ({:.1} s)",
        custom.steps,
        custom.retries,
        sim.time(),
        clock.elapsed().as_secs_f64()
    );

    // 2. The library's adaptive stepper, through `run_with` (no observers here).
    let clock = Instant::now();
    let mut sim = build()?;
    let mut adaptive = AdaptiveDt::new(MAX_DT)?;
    let run = sim.run_with(T_END, &mut adaptive, &mut [])?;
    let d_adaptive = deformation(&sim)?;
    println!(
        "AdaptiveDt:    {} steps, {} retries, D = {d_adaptive:.5e} at t = {:.4} ({:.1} s)",
        run.steps,
        run.retries,
        sim.time(),
        clock.elapsed().as_secs_f64()
    );

    // 3. The reference: small fixed steps.
    let clock = Instant::now();
    let mut sim = build()?;
    let reference = sim.run(T_END, 2.5e-3, &mut [])?;
    let d_reference = deformation(&sim)?;
    println!(
        "fixed steps:   {} steps of 2.5e-3, D = {d_reference:.5e} at t = {:.4} ({:.1} s)",
        reference.steps,
        sim.time(),
        clock.elapsed().as_secs_f64()
    );

    let err_custom = (d_custom - d_reference).abs() / d_reference;
    let err_adaptive = (d_adaptive - d_reference).abs() / d_reference;
    println!(
        "RESULT custom_steps={} custom_retries={} adaptive_steps={} adaptive_retries={} \
         d_reference={d_reference:.4e} d_custom={d_custom:.4e} d_adaptive={d_adaptive:.4e} \
         err_custom={err_custom:.2e} err_adaptive={err_adaptive:.2e}",
        custom.steps, custom.retries, run.steps, run.retries
    );

    // The checks (tolerances measured, see the header).
    if custom.worst_change > MAX_VELOCITY_CHANGE {
        return Err(format!("the driver accepted a velocity change of {:.3e}", custom.worst_change).into());
    }
    if err_custom > 6e-3 {
        return Err(format!("custom driver: D off the reference by {err_custom:.2e} (allowed 6e-3)").into());
    }
    if err_adaptive > 1e-2 {
        return Err(format!("AdaptiveDt: D off the reference by {err_adaptive:.2e} (allowed 1e-2)").into());
    }
    Ok(())
}
