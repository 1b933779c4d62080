//! One interface-advection step on a 64^3 periodic grid holding a sphere of radius 16 cells
//! (MTHINC for `phi`, convolved-curvature advection for `kappa_R tilde`), under a discretely
//! divergence-free swirl, for each normal construction; plus the reconstruction alone and a
//! field-level geometry update.
//!
//! Needs `[[bench]] name = "advection" harness = false` in Cargo.toml. Run:
//! `cargo bench --bench advection`. Throughput is reported in cells per second (the whole box).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use eulermembrane::grid::{Grid, VectorField};
use eulermembrane::interface::geometry::Geometry;
use eulermembrane::interface::shapes::{Smoothing, Sphere, smoothed_fields};
use eulermembrane::interface::{
    advect::{AdvectionParams, Advector, Carried},
    geometry::NormalScheme,
};
use std::f64::consts::PI;

fn setup() -> (Grid<f64>, VectorField<f64>) {
    let n = 64;
    let g = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
    let v = VectorField::from_stream_function(&g, |x| {
        (2.0 * PI * x[0]).sin() * (2.0 * PI * x[1]).cos() / (2.0 * PI)
    });
    (g, v)
}

fn bench(c: &mut Criterion) {
    let (g, v) = setup();
    let sphere = Sphere::new([0.5; 3], 0.25).unwrap();
    let (phi0, kt0) = smoothed_fields(&g, &sphere, &Smoothing::default()).unwrap();
    let dt = 0.2 / 64.0;
    let mut group = c.benchmark_group("advection_64cubed_sphere_r16");
    group.throughput(Throughput::Elements(g.cell_count() as u64));
    group.sample_size(20);
    for scheme in [NormalScheme::Youngs, NormalScheme::Atanh4] {
        let params = AdvectionParams { normals: scheme, ..Default::default() };
        for curvature in [false, true] {
            let mut adv =
                Advector::new(&g, params, if curvature { Carried::PhiAndCurvature } else { Carried::Phi })
                    .unwrap();
            let (mut phi, mut kt) = (phi0.clone(), kt0.clone());
            let name = format!("step_{}_{}", scheme.name(), if curvature { "phi_kappa" } else { "phi" });
            group.bench_function(&name, |b| {
                b.iter(|| {
                    // Restart from the initial fields so the band does not drift.
                    phi.copy_from(&phi0);
                    kt.copy_from(&kt0);
                    if curvature {
                        adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap()
                    } else {
                        adv.step(&g, &v, dt, &mut phi, None).unwrap()
                    }
                })
            });
        }
        let mut adv = Advector::new(&g, params, Carried::PhiAndCurvature).unwrap();
        group.bench_function(format!("reconstruct_{}", scheme.name()), |b| {
            b.iter(|| adv.reconstruct(&g, &phi0, Some(&kt0)).unwrap())
        });
    }
    for scheme in [NormalScheme::Atanh4, NormalScheme::Deconvolved] {
        let mut geo = Geometry::new(&g, scheme);
        group.bench_function(format!("geometry_update_{}", scheme.name()), |b| {
            b.iter(|| geo.update(&g, &phi0))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
