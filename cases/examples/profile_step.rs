//! Times steps, for profiling (e.g. under `perf record`).
//!
//! - `--n 64 --steps 10`: flow steps on an n^3 shear box;
//! - `--scene elastic_bending --n 64 --steps 10 [--f32]`: coupled steps of a sphere of radius
//!   0.25 in a stirred periodic unit box, as `benches/coupled.rs` (scenes `interface`,
//!   `elastic`, `elastic_bending`).
//!
//! Prints wall and CPU time per step (CPU time of all threads: the machine may be shared).
use eulermembrane::Real;
use eulermembrane::fluid::{
    momentum::Materials,
    stepper::{FlowConfig, FlowStepper},
};
use eulermembrane::grid::{Boundary, Grid};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::Skalak;
use eulermembrane::simulation::{Phase, Scene};
use eulermembrane_cases as common;
use std::time::Instant;

fn report(n: usize, steps: usize, wall: f64, cpu: f64, extra: &str) {
    let (secs, cpu) = (wall / steps as f64, cpu / steps as f64);
    let cells = (n * n * n) as f64;
    println!(
        "n={n}: {:.1} ms/step wall, {:.1} ms/step cpu, {:.2} M cell-steps/s wall, {:.2} M cell-steps per cpu-s{extra}",
        secs * 1e3,
        cpu * 1e3,
        cells / secs / 1e6,
        cells / cpu / 1e6
    );
    common::result(&[
        ("n", n.to_string()),
        ("ms_per_step", format!("{:.1}", secs * 1e3)),
        ("cpu_ms_per_step", format!("{:.1}", cpu * 1e3)),
    ]);
}

fn flow(n: usize, steps: usize) {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
    let grid = Grid::new([n, n, n], [0.0; 3], [1.0; 3], bc).unwrap();
    let h = 1.0 / n as f64;
    let dt = 12.8 * h * h;
    let mut s =
        FlowStepper::new(&grid, Materials::uniform(1.0, 1.0).unwrap(), FlowConfig::default()).unwrap();
    s.set_velocity(|x: [f64; 3]| {
        [2.0 * x[2] - 1.0 + 0.1 * (6.0 * x[1]).sin(), 0.1 * (6.0 * x[0]).sin(), 0.0]
    })
    .unwrap();
    let (t0, c0) = (Instant::now(), common::process_cpu_seconds());
    let mut iters = 0;
    for _ in 0..steps {
        iters += s.step(dt, &(), None).unwrap().predictor_iterations;
    }
    let its = format!(", {:.1} BiCGStab its/step", iters as f64 / steps as f64);
    report(n, steps, t0.elapsed().as_secs_f64(), common::process_cpu_seconds() - c0, &its);
}

fn coupled<T: Real>(n: usize, steps: usize, scene: &str) {
    let lit = T::lit;
    let grid = Grid::<T>::periodic([n; 3], [T::zero(); 3], [T::one(); 3]).unwrap();
    let mut sc = Scene::new(grid, Phase::new(T::one(), T::one()).unwrap())
        .capsule(Sphere::new([0.5; 3], 0.25).unwrap());
    if scene.starts_with("elastic") {
        sc = sc.elasticity(Skalak::new(lit(1.0), lit(2.0)).unwrap());
    }
    if scene == "elastic_bending" {
        sc = sc.bending(lit(1e-3));
    }
    let mut sim = sc.build().unwrap();
    sim.set_velocity(|x| {
        let tau = T::TAU();
        [lit(0.2) * (tau * x[1]).sin(), lit(0.1) * (tau * x[2]).sin(), lit(0.1) * (tau * x[0]).cos()]
    })
    .unwrap();
    let dt = lit(1e-3);
    let (t0, c0) = (Instant::now(), common::process_cpu_seconds());
    let mut band = 0;
    for _ in 0..steps {
        band = sim.step(dt).unwrap().band_cells;
    }
    report(
        n,
        steps,
        t0.elapsed().as_secs_f64(),
        common::process_cpu_seconds() - c0,
        &format!(", {band} band cells"),
    );
}

fn main() {
    let args = common::Args::parse(include_str!("profile_step.rs"));
    let n: usize = args.get("n", 64);
    let steps: usize = args.get("steps", 10);
    match args.opt::<String>("scene") {
        None => flow(n, steps),
        Some(scene) if args.flag("f32") => coupled::<f32>(n, steps, &scene),
        Some(scene) => coupled::<f64>(n, steps, &scene),
    }
}
