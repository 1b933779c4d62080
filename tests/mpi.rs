//! (feature `mpi`) The decomposition checks of `tests/decomposition.rs` on MPI ranks: run under
//! `mpirun -np P` (`.ci/run` runs P = 1, 2 and 4). Each rank is one part; every stored value
//! of every part after a ghost fill equals the whole grid's (each rank also holds the whole
//! grid), sums over the parts are identical on every rank and agree with the whole grid's, and
//! the direct solver and the flow step agree with the whole grid's to round-off.
//! Rank 0 prints `N passed, M failed`; the exit status is non-zero on any failure.

mod parts;

use eulermembrane::grid::{Decomposition, Exchange, MpiExchange};
use mpi::environment::Threading;
use mpi::traits::{Communicator, CommunicatorCollectives};
use parts::{LOCATIONS, Whole, cases, check_part, field, flow_on, four_solves, grid, max_difference};
use std::sync::Arc;

fn main() {
    let (universe, _) = mpi::initialize_with_threading(Threading::Serialized).expect("MPI initialised once");
    let world = universe.world();
    let (rank, size) = (world.rank(), world.size() as usize);
    let exchange: Arc<dyn Exchange> =
        Arc::new(MpiExchange::new(universe.world()).expect("serialized threading"));
    let (mut passed, mut failed) = (0u64, 0u64);
    let mut report = |name: String, r: Result<(), String>| match r {
        Ok(()) => passed += 1,
        Err(e) => {
            failed += 1;
            eprintln!("rank {rank}: {name}: FAILED: {e}");
        }
    };
    // Only splits into `size` parts whose slabs hold 4 cells.
    for (whole, d) in cases(&[size]).into_iter().filter(|(g, d)| g.n()[d.axis()] / size >= 4) {
        let name = format!("{d:?}, walls {:?}", whole.wall_axes());
        let part = match whole.split(d, exchange.clone()) {
            Ok(p) => p,
            Err(e) => {
                report(name, Err(e.to_string()));
                continue;
            }
        };
        let fields = Whole::new(&whole);
        report(format!("ghosts, {name}"), check_part(&part, &whole, &fields));
        let total = field(&whole, 0).interior_sum(&whole);
        let [sum] = part.sum_over_parts([field(&part, 0).interior_sum(&part)]);
        let mut all = vec![0.0f64; size];
        world.all_gather_into(&sum, &mut all[..]);
        let same = all.iter().all(|x| x.to_bits() == sum.to_bits());
        report(
            format!("sum, {name}"),
            if same && (sum - total).abs() < 1e-12 {
                Ok(())
            } else {
                Err(format!("{all:?} against {total}"))
            },
        );
    }
    // The direct solver and the flow step (variable density and viscosity, the Krylov
    // predictor, the projection) against the whole grid's, on each rank's part.
    for wall in [None, Some(2)] {
        let whole = grid(wall);
        let flow = flow_on(&whole, 4).expect("the whole grid's flow");
        let expected: Vec<_> =
            LOCATIONS.iter().map(|&l| four_solves(&whole, l).expect("whole solves")).collect();
        for axis in (0..3).filter(|&a| Some(a) != wall && whole.n()[a] / size >= 4) {
            let d = Decomposition::slabs(axis, size).expect("a decomposition of the ranks");
            let part = whole.split(d, exchange.clone()).expect("a part");
            for (location, e) in LOCATIONS.iter().zip(&expected) {
                let scale = e.iter().flat_map(|x| x.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
                let got = four_solves(&part, *location);
                let worst = got.map(|g| {
                    g.iter().zip(e).map(|(g, e)| max_difference(&part, g, &whole, e)).fold(0.0, f64::max)
                });
                report(
                    format!("solver {location:?}, {d:?}, walls {wall:?}"),
                    match worst {
                        Ok(w) if w <= 1e-13 * scale => Ok(()),
                        Ok(w) => Err(format!("differs by {w:e} (scale {scale:e})")),
                        Err(e) => Err(e),
                    },
                );
            }
            let got = flow_on(&part, 4);
            let worst = got.map(|(v, p)| {
                let dv = (0..3).map(|c| max_difference(&part, v.c[c].values(), &whole, flow.0.c[c].values()));
                (dv.fold(0.0, f64::max), max_difference(&part, p.values(), &whole, flow.1.values()))
            });
            report(
                format!("flow, {d:?}, walls {wall:?}"),
                match worst {
                    Ok((dv, dp)) if dv <= 1e-12 && dp <= 1e-9 => Ok(()),
                    Ok((dv, dp)) => Err(format!("velocity differs by {dv:e}, pressure by {dp:e}")),
                    Err(e) => Err(e),
                },
            );
        }
    }
    let mut totals = [0u64; 2];
    world.all_reduce_into(&[passed, failed], &mut totals, mpi::collective::SystemOperation::sum());
    if rank == 0 {
        println!("mpi ({size} ranks): {} passed, {} failed", totals[0], totals[1]);
    }
    if totals[1] > 0 || totals[0] == 0 {
        std::process::exit(1);
    }
}
