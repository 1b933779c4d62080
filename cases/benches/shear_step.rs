//! One step of the shear capsule of Sec. 3.3 at 16 cells per radius (`N = 128`, a 128 x 64 x 128
//! box, Ca = 0.05, default settings) with each membrane traction (`Elasticity::traction`): the step
//! `shear_capsule --n 128` takes about 1270 times (the sharp one; `--traction smoothed` the other).
//! The capsule is first run to `t = 0.2` (43 steps of the adaptive step, so that the membrane
//! is loaded and the solvers start from a developed flow); every measured step then has
//! `dt = 0.0047`, the step the adaptive control chooses in that run.
//!
//! `cargo bench -p eulermembrane-cases --bench shear_step`; CPU time of all threads (see
//! `benches/common` of the core crate): with `RAYON_NUM_THREADS=1`, the single-core cost.

#[path = "../../benches/common/mod.rs"]
mod common;

use common::CpuTime;
use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use eulermembrane::simulation::{Settings, Traction, timestep::AdaptiveDt};
use eulermembrane_cases::Terms;
use eulermembrane_cases::shear::{self, ShearCase, Steps};
use std::time::Duration;

fn shear_step(c: &mut Criterion<CpuTime>) {
    let n = 128;
    let case = ShearCase {
        n,
        ca: 0.05,
        eb_prime: 0.0,
        lambda: 1.0,
        dt: 0.05,
        t_end: 0.2,
        steps: Steps::Adaptive { cfl: 0.3 },
        box_radii: ShearCase::PAPER_BOX,
        law: Default::default(),
    };
    let mut group = c.benchmark_group("shear_step");
    group
        .throughput(Throughput::Elements((n * n * n / 2) as u64))
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(12));
    for traction in Traction::ALL {
        let terms = Terms { traction, ..Terms::default() };
        let mut sim = shear::build::<f64>(&case, Settings::default(), terms).expect("shear scene");
        let mut control = AdaptiveDt::new(case.dt).expect("adaptive dt");
        sim.run_with(case.t_end, &mut control, &mut []).expect("developed state");
        let dt = 0.0047;
        let report = sim.step(dt).expect("step");
        eprintln!(
            "shear N = {n}, {}: {} band cells, {} predictor and {} pressure iterations",
            traction.name(),
            report.band_cells,
            report.flow.predictor_iterations,
            report.flow.poisson_iterations
        );
        group.bench_function(format!("n128_ca0.05_{}", traction.name()), |b| {
            b.iter(|| sim.step(dt).expect("step"))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = common::criterion();
    targets = shear_step
}
criterion_main!(benches);
