//! One whole coupled step ([`Simulation::step`]) of a spherical capsule (radius 0.25) in a
//! stirred periodic unit box, adding one effect at a time: the flow alone (no capsule), the
//! capsule's interface only (MTHINC and the two-phase mixture, no membrane), + in-plane
//! elasticity (Skalak, quasi-implicit), + bending. At 32^3 and 64^3, in f64 and f32.
//!
//! `cargo bench --bench coupled` (needs `[[bench]] name = "coupled" harness = false`).
//! Times are CPU time (see `common`); throughput is cells of the whole box per CPU second, i.e.
//! cell-steps per core-second when run with `RAYON_NUM_THREADS=1`.

mod common;

use common::CpuTime;
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use eulermembrane::Real;
use eulermembrane::grid::Grid;
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::Skalak;
use eulermembrane::simulation::{Phase, Scene, Simulation};
use std::time::Duration;

/// The effects of the scene, in the order they are added.
const CASES: [&str; 4] = ["flow", "interface", "elastic", "elastic_bending"];

fn simulation<T: Real>(n: usize, case: &str) -> Simulation<T> {
    let grid = Grid::<T>::periodic([n; 3], [T::zero(); 3], [T::one(); 3]).unwrap();
    let lit = T::lit;
    let mut scene = Scene::new(grid, Phase::new(T::one(), T::one()).unwrap());
    if case != "flow" {
        scene = scene.capsule(Sphere::new([0.5; 3], 0.25).unwrap());
    }
    if case.starts_with("elastic") {
        scene = scene.elasticity(Skalak::new(lit(1.0), lit(2.0)).unwrap());
    }
    if case == "elastic_bending" {
        scene = scene.bending(lit(1e-3));
    }
    let mut sim = scene.build().unwrap();
    sim.set_velocity(|x| {
        let tau = T::TAU();
        [lit(0.2) * (tau * x[1]).sin(), lit(0.1) * (tau * x[2]).sin(), lit(0.1) * (tau * x[0]).cos()]
    })
    .unwrap();
    // Past the first steps (AB2 start, first solves from zero).
    for _ in 0..3 {
        sim.step(lit(1e-3)).unwrap();
    }
    sim
}

fn bench_type<T: Real>(c: &mut Criterion<CpuTime>, ty: &str) {
    for n in [32, 64] {
        let mut group = c.benchmark_group(format!("coupled_step_{ty}_{n}cubed"));
        group
            .throughput(Throughput::Elements((n * n * n) as u64))
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
        for case in CASES {
            let mut sim = simulation::<T>(n, case);
            let report = sim.step(T::lit(1e-3)).unwrap();
            eprintln!(
                "{ty} {n}^3 {case}: {} band cells, {} profile cells, {} predictor and {} pressure iterations",
                report.band_cells,
                report.profile_cells,
                report.flow.predictor_iterations,
                report.flow.poisson_iterations
            );
            group.bench_function(BenchmarkId::from_parameter(case), |b| {
                b.iter(|| sim.step(T::lit(1e-3)).unwrap())
            });
        }
        group.finish();
    }
}

fn coupled(c: &mut Criterion<CpuTime>) {
    bench_type::<f64>(c, "f64");
    bench_type::<f32>(c, "f32");
}

criterion_group! {
    name = benches;
    config = common::criterion();
    targets = coupled
}
criterion_main!(benches);
