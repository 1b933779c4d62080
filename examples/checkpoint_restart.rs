//! # Checkpoint and restart: a restored run continues bit for bit
//!
//! ```sh
//! cargo run --release --example checkpoint_restart      # about 1 s on 2 cores
//! ```
//!
//! A long run should survive a crash, a time limit on a cluster, or a change of plan. This
//! example shows how:
//! 1. run a capsule in shear flow for 20 steps, write a checkpoint (`Simulation::checkpoint`:
//!    one file with the whole state), and keep going for 20 more steps;
//! 2. build a *second* simulation from the same scene, `restore` the checkpoint into it, and run
//!    the same 20 steps;
//! 3. compare the two end states value by value: the velocity, the pressure, the capsule's
//!    `phi` and `G_s`, and the Taylor deformation `D` of the capsule. A restart is exact, not
//!    approximate: every value has the same bits;
//! 4. write a ParaView snapshot of the end state (`Simulation::write_vti`).
//!
//! Files, in `out/checkpoint_restart/` under the directory you run it from (the repository
//! root with the command above; created if missing):
//! - `state.ckpt`: the checkpoint after step 20;
//! - `capsule.vti`: the end state. To look at it, open it in ParaView (File > Open, then
//!   Apply) and colour by `velocity` or `pressure`; the capsule is the `phi = 0.5` surface
//!   (Filters > Contour on `phi`, value 0.5), and a Slice normal to y through the centre shows
//!   the sheared flow around it. The membrane's principal tensions are the fields `t1`, `t2`.
//!
//! A checkpoint is restored only into a scene with the same physics: the phases, the traction
//! (`Elasticity::traction`, `Simulation::traction`) and every effect's `describe()` line must match
//! (`Simulation::physics`), or `restore` returns an error naming `checkpoint physics` that
//! shows both lines. The grid must match too. The numerical solvers may differ.
//!
//! ## What it prints, and what to expect
//!
//! The step count, time and `D` of each run, the error of a scene with a stiffer membrane that
//! refuses the checkpoint, how many values were compared, then
//!
//! ```text
//! RESULT steps=40 t=0.2000 d_continued=9.3159e-2 d_restored=9.3159e-2 values_compared=217800 values_differing=0 bit_identical=true
//! ```
//!
//! (`D` measured on this machine). The tolerance is zero: the example returns an error if
//! any compared value differs in any bit, if `D` differs, or if the step count or time differ.

use eulermembrane::diagnostics::{taylor::taylor_deformation, volume::centroid};
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{Phase, Scene, Simulation};
use std::path::Path;

/// The scene, built the same way for both runs: a capsule of radius 0.4 (3.2 cells) between
/// two walls at z = -1 and z = 1 that move at -1 and +1 along x (shear rate 1), periodic in x
/// and y, with a neo-Hookean membrane of modulus `es`. Library defaults otherwise
/// (`Settings::default()`).
fn build(es: f64) -> Result<Simulation<f64>, Box<dyn std::error::Error>> {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
    let grid = Grid::<f64>::new([24, 16, 24], [-1.5, -1.0, -1.0], [1.5, 1.0, 1.0], bc)?;
    let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?) // rho, mu
        .capsule(Sphere::new([0.0; 3], 0.4)?)
        .elasticity(NeoHookean::new(es)?) // E_s = 3 G_s
        .build()?;
    // Start from the undisturbed shear. (`restore` will overwrite this with the saved flow.)
    sim.set_velocity(|x| [x[2], 0.0, 0.0])?;
    Ok(sim)
}

/// Taylor deformation `D = (L - B) / (L + B)` of the capsule's section through its centroid in
/// the x-z plane (the plane of the shear; normal to axis 1, y).
fn deformation(sim: &Simulation<f64>) -> Result<f64, Box<dyn std::error::Error>> {
    let phi = sim.phi(0)?;
    let c = centroid(sim.grid(), phi)?;
    Ok(taylor_deformation(sim.grid(), phi, c, 1)?.deformation)
}

/// Every value the state is made of, in one list of named arrays: velocity components,
/// pressure, `phi` and the six components of `G_s` (padded arrays, ghost cells included).
fn state_arrays(sim: &Simulation<f64>) -> eulermembrane::Result<Vec<(String, &[f64])>> {
    let mut arrays: Vec<(String, &[f64])> = Vec::new();
    for (d, f) in sim.velocity().c.iter().enumerate() {
        arrays.push((format!("velocity[{d}]"), f.values()));
    }
    arrays.push(("pressure".into(), sim.pressure().values()));
    arrays.push(("phi".into(), sim.phi(0)?.values()));
    if let Some(gs) = sim.gs(0)? {
        for (k, f) in gs.c.iter().enumerate() {
            arrays.push((format!("G_s[{k}]"), f.values()));
        }
    }
    Ok(arrays)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = Path::new("out/checkpoint_restart");
    std::fs::create_dir_all(out)?;
    let checkpoint = out.join("state.ckpt");
    let (dt, first, second) = (5e-3, 20, 20);
    let es = 10.0; // the membrane's modulus E_s

    // 1. The uninterrupted run: 20 steps, a checkpoint, 20 more steps.
    let mut continued = build(es)?;
    for _ in 0..first {
        continued.step(dt)?;
    }
    continued.checkpoint(&checkpoint)?; // atomic: a crash mid-write leaves the old file
    println!(
        "run A: checkpoint at step {} (t = {:.4}) in {}",
        continued.steps(),
        continued.time(),
        checkpoint.display()
    );
    for _ in 0..second {
        continued.step(dt)?;
    }

    // 2. The restarted run: a fresh simulation from the same scene, the saved state restored
    //    (time, step count, flow with its history, phi, G_s, ...), then the same steps.
    let mut restored = build(es)?;
    restored.restore(&checkpoint)?;
    println!("run B: restored at step {} (t = {:.4})", restored.steps(), restored.time());
    for _ in 0..second {
        restored.step(dt)?;
    }

    //    A checkpoint is refused by a scene with other physics, e.g. a stiffer membrane: the
    //    error names `checkpoint physics` and the simulation is left as it was.
    match build(2.0 * es)?.restore(&checkpoint) {
        Err(e) => println!("a scene with E_s = {} refuses it: {e}", 2.0 * es),
        Ok(()) => return Err("a checkpoint was restored into a scene with other physics".into()),
    }

    // 3. Compare the end states, bit for bit (`to_bits` also tells -0.0 from 0.0, and would
    //    catch a NaN, which `==` never equals).
    let (d_a, d_b) = (deformation(&continued)?, deformation(&restored)?);
    println!("run A: step {} t = {:.4} D = {d_a:.6e}", continued.steps(), continued.time());
    println!("run B: step {} t = {:.4} D = {d_b:.6e}", restored.steps(), restored.time());
    let (a, b) = (state_arrays(&continued)?, state_arrays(&restored)?);
    let (mut compared, mut differing) = (0, 0);
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        let n = x.iter().zip(y.iter()).filter(|(p, q)| p.to_bits() != q.to_bits()).count();
        if n > 0 {
            println!("  {name}: {n} values differ");
        }
        compared += x.len();
        differing += n;
    }
    let same_clock = continued.steps() == restored.steps() && continued.time() == restored.time();
    let identical = differing == 0 && a.len() == b.len() && d_a.to_bits() == d_b.to_bits() && same_clock;
    println!("compared {compared} values in {} arrays: {differing} differ", a.len());

    // 4. A ParaView snapshot of the end state.
    let vti = out.join("capsule.vti");
    restored.write_vti(&vti)?;
    println!("wrote {} (open it in ParaView)", vti.display());

    println!(
        "RESULT steps={} t={:.4} d_continued={d_a:.4e} d_restored={d_b:.4e} values_compared={compared} \
         values_differing={differing} bit_identical={identical}",
        restored.steps(),
        restored.time()
    );
    if !identical {
        return Err("the restored run is not bit-for-bit identical to the uninterrupted one".into());
    }
    Ok(())
}
