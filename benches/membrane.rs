//! Membrane kernels on the band of a sphere of radius 16 cells in a 64³ periodic box (`β = 1`,
//! `ε = 0.01`, `n` from central differences of `ψ = atanh(2φ − 1)`): band rebuild, stress and
//! Jacobian evaluation, explicit force, implicit term, bending, `G_s` transport.
//!
//! `cargo bench --bench membrane` (needs `[[bench]] name = "membrane" harness = false`).

use criterion::{Criterion, criterion_group, criterion_main};
use eulermembrane::fluid::{forcing::Forcing, momentum::ImplicitTerm};
use eulermembrane::grid::{Field, Grid, SymField, VectorField};
use eulermembrane::membrane::{
    band::Band,
    bending::BendingStress,
    force::InPlaneElasticity,
    law::Skalak,
    strain::{StrainTransport, fill_projector},
};
use std::hint::black_box;
use std::time::Duration;

struct Scene {
    grid: Grid<f64>,
    normal: [Field<f64>; 3],
    delta: Field<f64>,
    kr: Field<f64>,
    gs: SymField<f64>,
    v: VectorField<f64>,
}

fn scene() -> Scene {
    let n = 64;
    let radius = 16.0;
    let grid = Grid::periodic([n; 3], [0.0; 3], [n as f64; 3]).unwrap();
    let c = [32.13, 31.79, 32.07];
    let dist = |x: [f64; 3]| ((x[0] - c[0]).powi(2) + (x[1] - c[1]).powi(2) + (x[2] - c[2]).powi(2)).sqrt();
    let mut phi = Field::from_cell_fn(&grid, |x| 0.5 * (1.0 + (radius - dist(x)).tanh()));
    phi.fill_ghosts(&grid);
    let lim = 1.0 - 1e-12;
    let psi: Vec<f64> = phi.values().iter().map(|&p| (2.0 * p - 1.0).clamp(-lim, lim).atanh()).collect();
    let st = grid.strides();
    let mut delta = Field::zeros(&grid);
    let mut normal = [Field::zeros(&grid), Field::zeros(&grid), Field::zeros(&grid)];
    for (i, j, k) in grid.cells() {
        let idx = grid.idx_u(i, j, k);
        let gp: [f64; 3] =
            std::array::from_fn(|d| 0.5 * (phi.values()[idx + st[d]] - phi.values()[idx - st[d]]));
        let gq: [f64; 3] = std::array::from_fn(|d| 0.5 * (psi[idx + st[d]] - psi[idx - st[d]]));
        delta.values_mut()[idx] = (gp[0] * gp[0] + gp[1] * gp[1] + gp[2] * gp[2]).sqrt();
        let m = (gq[0] * gq[0] + gq[1] * gq[1] + gq[2] * gq[2]).sqrt();
        for d in 0..3 {
            normal[d].values_mut()[idx] = if m > 0.0 { gq[d] / m } else { 0.0 };
        }
    }
    delta.fill_ghosts(&grid);
    normal.iter_mut().for_each(|f| f.fill_ghosts(&grid));
    let mut kr = Field::from_cell_fn(&grid, |x| 1.0 / dist(x).max(1.0));
    kr.values_mut().iter_mut().zip(delta.values()).for_each(|(k, d)| *k *= d);
    let mut gs = SymField::zeros(&grid);
    fill_projector(&grid, &normal, &mut gs);
    for comp in gs.c.iter_mut() {
        comp.values_mut().iter_mut().for_each(|x| *x *= 1.1);
    }
    let mut v = VectorField::from_fn(&grid, |x| {
        let w = std::f64::consts::TAU / 64.0;
        [0.1 * (w * x[1]).sin(), 0.05 * (w * x[2]).cos(), 0.02 * (w * x[0]).sin()]
    });
    v.fill_ghosts(&grid);
    Scene { grid, normal, delta, kr, gs, v }
}

fn membrane(c: &mut Criterion) {
    let s = scene();
    let g = &s.grid;
    let mut band = Band::new(g, 0.01).unwrap();
    band.rebuild(g, &s.delta).unwrap();
    eprintln!(
        "64^3 box, sphere R = 16 cells, eps = 0.01: {} band cells, halo(1) {}, halo(2) {}, halo(4) {} (box {})",
        band.len(),
        band.halo(1).len(),
        band.halo(2).len(),
        band.halo(4).len(),
        g.cell_count()
    );
    let law = Skalak::new(1.0, 10.0).unwrap();
    let mut group = c.benchmark_group("membrane_64_r16");
    group.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2));

    group.bench_function("band_rebuild", |b| b.iter(|| band.rebuild(g, black_box(&s.delta)).unwrap()));

    let mut e = InPlaneElasticity::new(g, law);
    group.bench_function("stress_jacobian", |b| {
        b.iter(|| e.evaluate(g, &band, black_box(&s.gs), &s.normal, &s.delta, 1e-3).unwrap())
    });
    e.evaluate(g, &band, &s.gs, &s.normal, &s.delta, 1e-3).unwrap();
    let mut out = VectorField::zeros(g);
    group.bench_function("explicit_force", |b| {
        let f = e.forcing(&band).unwrap();
        b.iter(|| f.add(g, 0.0, black_box(&s.v), &mut out))
    });
    group.bench_function("stress_jacobian_and_force", |b| {
        b.iter(|| {
            e.evaluate(g, &band, black_box(&s.gs), &s.normal, &s.delta, 1e-3).unwrap();
            e.forcing(&band).unwrap().add(g, 0.0, &s.v, &mut out).unwrap();
        })
    });
    group.bench_function("implicit_add_apply", |b| {
        let imp = e.implicit(&band).unwrap();
        b.iter(|| imp.add_apply(g, black_box(&s.v), &mut out))
    });

    let mut bend = BendingStress::new(g, 0.01).unwrap();
    group.bench_function("bending_evaluate", |b| {
        b.iter(|| bend.evaluate(g, &band, black_box(&s.normal), &s.delta, &s.kr).unwrap())
    });

    let mut tr = StrainTransport::new(g).unwrap();
    let mut gs = s.gs.clone();
    group.bench_function("strain_step", |b| {
        b.iter(|| tr.step(g, &band, 1e-4, black_box(&s.v), &s.v, &s.normal, &mut gs).unwrap())
    });
    group.finish();
}

criterion_group!(benches, membrane);
criterion_main!(benches);
