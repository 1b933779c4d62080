//! The flow step of the shear cases on MPI ranks, without a capsule: the box of
//! `shear_capsule` (`[-4, 4] x [-2, 2] x [-4, 4]` on `(N, N/2, N)` cells, periodic in x and y,
//! walls `z = ±4` moving at `±4`, `rho` = 1, `mu` = 100), started from the undisturbed shear plus
//! a perturbation, stepped `--steps` times at `dt` = `--dt`, each rank holding one slab of the
//! grid split along `--axis` (`grid::Decomposition`, `grid::MpiExchange`).
//!
//! Prints `RESULT ranks=P n=N axis=A steps=S s_per_step=... cpu_s_per_step=... kinetic=...`
//! (rank 0): the wall time of a step after the first (the first is timed apart: it builds the
//! solvers' work arrays), the process's CPU time per step on rank 0, and the kinetic energy
//! `sum u^2 / 2` over the whole grid, which every rank count must give to round-off.
//!
//! Flags: `--n` (64), `--steps` (10), `--dt` (0.005: about the mean step of the N = 128 shear
//! runs), `--axis` (0, or 1; z holds the walls).
//!
//! `cargo build --release --features mpi --example flow_ranks`, then
//! `mpirun -np 2 target/release/examples/flow_ranks --n 128` (needs the `mpi` feature: an MPI
//! library and libclang, `apt-get install libopenmpi-dev openmpi-bin libclang-dev`).
use eulermembrane::fluid::momentum::Materials;
use eulermembrane::fluid::stepper::{FlowConfig, FlowStepper};
use eulermembrane::grid::{Boundary, Decomposition, Exchange, Grid, MpiExchange};
use eulermembrane_cases as common;
use mpi::environment::Threading;
use mpi::traits::Communicator;
use std::sync::Arc;
use std::time::Instant;

fn main() {
    common::exit_on_error(run());
}

fn run() -> common::BoxResult<()> {
    let args = common::Args::parse(include_str!("flow_ranks.rs"));
    let (n, steps, dt, axis) =
        (args.get("n", 64usize), args.get("steps", 10usize), args.get("dt", 0.005), args.get("axis", 0usize));
    let (universe, _) =
        mpi::initialize_with_threading(Threading::Serialized).ok_or("MPI could not be initialised")?;
    let rank = universe.world().rank();
    let exchange: Arc<dyn Exchange> = Arc::new(MpiExchange::new(universe.world())?);
    let parts = exchange.parts();
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-4.0, 0.0, 0.0] }, Boundary::Wall { velocity: [4.0, 0.0, 0.0] }];
    let whole = Grid::<f64>::new([n, n / 2, n], [-4.0, -2.0, -4.0], [4.0, 2.0, 4.0], bc)?;
    let grid = whole.split(Decomposition::slabs(axis, parts)?, exchange)?;
    let mut flow = FlowStepper::new(&grid, Materials::uniform(1.0, 100.0)?, FlowConfig::default())?;
    flow.set_velocity(|x: [f64; 3]| {
        let bump = (-(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])).exp();
        [x[2] + 0.5 * bump * x[1], -0.5 * bump * x[0], 0.0]
    })?;
    flow.step(dt, &(), None)?;
    let (clock, cpu) = (Instant::now(), common::process_cpu_seconds());
    for _ in 1..steps.max(2) {
        flow.step(dt, &(), None)?;
    }
    let taken = (steps.max(2) - 1) as f64;
    let (wall, cpu) = (clock.elapsed().as_secs_f64() / taken, (common::process_cpu_seconds() - cpu) / taken);
    let v = flow.velocity();
    let local: f64 = (0..3)
        .map(|d| {
            grid.cells()
                .map(|(i, j, k)| v.c[d].at(&grid, i as isize, j as isize, k as isize).powi(2))
                .sum::<f64>()
        })
        .sum();
    let [kinetic] = grid.sum_over_parts([0.5 * local]);
    let [wall] = grid.max_over_parts([wall]);
    if rank == 0 {
        common::result(&[
            ("ranks", parts.to_string()),
            ("n", n.to_string()),
            ("axis", axis.to_string()),
            ("steps", steps.to_string()),
            ("s_per_step", common::num(wall)),
            ("cpu_s_per_step", common::num(cpu)),
            ("kinetic", format!("{kinetic:.12e}")),
        ]);
    }
    Ok(())
}
