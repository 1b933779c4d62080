//! One coupled step with `K` = 0, 1, 4, 16 neo-Hookean spheres at 8 cells per radius in a
//! periodic 64^3 and 128^3 box, each capsule on its box (`CapsuleStorage::Boxed { room: 1.2 }`,
//! the scene of `examples/capsule_cost.rs`, `eulermembrane_cases::cost`). A capsule's share of a
//! step is the slope of the step time in `K`: with capsule-local boxes it does not depend on the
//! grid (docs/performance.md).
//!
//! `cargo bench -p eulermembrane-cases --bench capsule_cost`; CPU time of all threads (see
//! `benches/common` of the core crate).

#[path = "../../benches/common/mod.rs"]
mod common;

use common::CpuTime;
use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};
use eulermembrane::simulation::{CapsuleStorage, Settings, Traction};
use eulermembrane_cases::cost::{periodic_capsules, step};
use std::time::Duration;

const CELLS_PER_RADIUS: f64 = 8.0;

fn capsule_cost(c: &mut Criterion<CpuTime>) {
    let mut group = c.benchmark_group("capsule_cost");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10));
    let settings = Settings { storage: CapsuleStorage::Boxed { room: 1.2 }, ..Settings::default() };
    let dt = step(CELLS_PER_RADIUS);
    for n in [64, 128] {
        for k in [0, 1, 4, 16] {
            let mut sim = periodic_capsules(n, k, CELLS_PER_RADIUS, settings, Traction::default())
                .expect("capsule scene");
            for _ in 0..2 {
                sim.step(dt).expect("step");
            }
            group.bench_function(format!("n{n}_k{k}"), |b| b.iter(|| sim.step(dt).expect("step")));
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = common::criterion();
    targets = capsule_cost
}
criterion_main!(benches);
