//! Times flow steps on an n^3 shear box (for profiling): `--n 64 --steps 10`.
mod common;
use eulermembrane::fluid::{FlowConfig, FlowStepper, Materials};
use eulermembrane::grid::{Boundary, Grid};

fn main() {
    let args = common::Args::parse();
    let n: usize = args.get("n", 64);
    let steps: usize = args.get("steps", 10);
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
    let t0 = std::time::Instant::now();
    let mut iters = 0;
    for _ in 0..steps {
        iters += s.step(dt, &(), None).unwrap().predictor_iterations;
    }
    let secs = t0.elapsed().as_secs_f64() / steps as f64;
    let cells = (n * n * n) as f64;
    println!(
        "n={n}: {:.1} ms/step, {:.2} M cell-steps/s, {:.1} BiCGStab its/step",
        secs * 1e3,
        cells / secs / 1e6,
        iters as f64 / steps as f64
    );
    common::result(&[("n", n.to_string()), ("ms_per_step", format!("{:.1}", secs * 1e3))]);
}
