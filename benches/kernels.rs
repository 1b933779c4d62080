//! The kernels of one coupled step, each alone, on a sphere of radius 0.25 in a periodic unit
//! box under a divergence-free swirl, at 32^3 and 64^3 in f64 and f32:
//!
//! - `mthinc_step`: one AB2 step of `phi` (MTHINC reconstruction and fluxes (2.41)-(2.48));
//! - `mthinc_convolved_step`: the same with the convolved curvature `kappa_R tilde` (2.44);
//! - `geometry`: normals, `delta` and the membrane band from `phi` (what the step derives);
//! - `stress_jacobian`: `tau` and `J` on the band (2.32)-(2.34);
//! - `elastic_force`: the explicit in-plane force `div(delta tau)` on the faces;
//! - `bending`: the bending stress and its force on the faces (2.16)-(2.17);
//! - `gs_transport`: one step of `G_s` (2.40);
//! - `predictor_apply`: `P x` of (2.35), uniform materials; `_mixture_membrane`: viscosity
//!   ratio 5 inside and the quasi-implicit membrane term;
//! - `krylov_solve_mixture_membrane`: BiCGStab on that operator (Helmholtz FFT
//!   preconditioner, tolerance 1e-8 in f64 and 1e-5 in f32) from `v^n`; `_two`: the same with
//!   the two-viscosity preconditioner (`HelmholtzPrecond::set_two`);
//! - `poisson_direct`: the uniform-density projection (one FFT solve); `poisson_pcg`: density
//!   ratio 2 inside (PCG with the FFT preconditioner).
//!
//! Then `band_cost`: the band kernels at N = 32, 64, 128 for the same sphere (f64), against the
//! whole-box `predictor_apply`: band work grows like N^2, box work like N^3.
//!
//! Last `helmholtz_channel`: the direct Helmholtz and Poisson solves in a channel (walls in y),
//! where the tridiagonal solves along y replace one FFT.
//!
//! `cargo bench --bench kernels`. Times are CPU time (see `common`); throughput is cells of the
//! whole box per CPU second.

mod common;

use common::CpuTime;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use eulermembrane::Real;
use eulermembrane::fluid::krylov::bicgstab;
use eulermembrane::fluid::momentum::Predictor;
use eulermembrane::fluid::projection::Projection;
use eulermembrane::fluid::spectral::{Location, SpectralSolver};
use eulermembrane::fluid::{
    forcing::Forcing,
    krylov::{KrylovParams, KrylovWorkspace, LinOp},
    momentum::{Coefficient, HelmholtzPrecond, Materials},
};
use eulermembrane::grid::{Boundary, Field, Grid, SymField, VectorField};
use eulermembrane::interface::geometry::{PhiRange, delta_in_band};
use eulermembrane::interface::shapes::{Smoothing, Sphere, smoothed_fields};
use eulermembrane::interface::{
    advect::{AdvectionParams, Advector, Carried},
    geometry::{Geometry, NormalScheme},
};
use eulermembrane::membrane::{
    band::Band,
    bending::BendingStress,
    force::InPlaneElasticity,
    law::Skalak,
    strain::{StrainTransport, fill_projector},
};
use std::hint::black_box;
use std::time::Duration;

/// The fields of a capsule after one derivation from `phi`.
struct Setup<T: Real> {
    grid: Grid<T>,
    phi: Field<T>,
    kt: Field<T>,
    normal: [Field<T>; 3],
    delta: Field<T>,
    band: Band<T>,
    geometry: Geometry<T>,
    gs: SymField<T>,
    v: VectorField<T>,
    dt: T,
}

fn geometry_band<T: Real>() -> PhiRange<T> {
    let tiny = T::lit(1e-10).max(T::epsilon() * T::lit(4.0));
    PhiRange { lower: tiny, upper: T::one() - tiny }
}

/// Normals, `delta` and the band from `phi`, as the coupled step derives them.
fn derive<T: Real>(s: &mut Setup<T>) {
    let g = &s.grid;
    s.geometry.update(g, &s.phi);
    s.geometry.normals(g, &s.phi, geometry_band(), &mut s.normal);
    s.normal.iter_mut().for_each(|f| f.fill_ghosts(g));
    delta_in_band(g, &s.phi, geometry_band(), &mut s.delta);
    s.delta.fill_ghosts(g);
    s.band.rebuild(g, &s.delta).unwrap();
}

fn setup<T: Real>(n: usize) -> Setup<T> {
    let grid = Grid::<T>::periodic([n; 3], [T::zero(); 3], [T::one(); 3]).unwrap();
    let sphere = Sphere::new([0.503, 0.497, 0.501], 0.25).unwrap();
    let (mut phi, kt) = smoothed_fields(&grid, &sphere, &Smoothing::default()).unwrap();
    phi.fill_ghosts(&grid);
    let tau = T::TAU();
    let mut v = VectorField::from_stream_function(&grid, |x| {
        T::lit(0.5) * (tau * x[0]).sin() * (tau * x[1]).cos() / tau
    });
    v.fill_ghosts(&grid);
    let mut s = Setup {
        normal: std::array::from_fn(|_| Field::zeros(&grid)),
        delta: Field::zeros(&grid),
        band: Band::new(&grid, T::lit(0.01)).unwrap(),
        geometry: Geometry::new(&grid, NormalScheme::Atanh4),
        gs: SymField::zeros(&grid),
        dt: T::lit(0.2) / T::from_usize(n).unwrap(),
        grid,
        phi,
        kt,
        v,
    };
    derive(&mut s);
    // A strained membrane: G_s = 1.1 P.
    fill_projector(&s.grid, &s.normal, &mut s.gs);
    s.gs.c.iter_mut().for_each(|c| c.values_mut().iter_mut().for_each(|x| *x *= T::lit(1.1)));
    s.gs.fill_ghosts(&s.grid);
    s
}

fn configure(group: &mut criterion::BenchmarkGroup<'_, CpuTime>, cells: usize) {
    group
        .throughput(Throughput::Elements(cells as u64))
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1500));
}

fn kernels_of<T: Real>(c: &mut Criterion<CpuTime>, ty: &str, n: usize) {
    let mut s = setup::<T>(n);
    let g = s.grid.clone();
    eprintln!("{ty} {n}^3: {} band cells of {} ", s.band.len(), g.cell_count());
    let mut group = c.benchmark_group(format!("kernels_{ty}_{n}cubed"));
    configure(&mut group, g.cell_count());
    let lit = T::lit;

    for curvature in [false, true] {
        let mut adv = Advector::new(
            &g,
            AdvectionParams::default(),
            if curvature { Carried::PhiAndCurvature } else { Carried::Phi },
        )
        .unwrap();
        let (mut phi, mut kt) = (s.phi.clone(), s.kt.clone());
        let name = if curvature { "mthinc_convolved_step" } else { "mthinc_step" };
        group.bench_function(name, |b| {
            b.iter(|| {
                // Restart from the same fields so the band does not drift.
                phi.copy_from(&s.phi);
                kt.copy_from(&s.kt);
                adv.step(&g, &s.v, s.dt, &mut phi, curvature.then_some(&mut kt)).unwrap()
            })
        });
    }
    group.bench_function("geometry", |b| b.iter(|| derive(black_box(&mut s))));

    let mut elastic = InPlaneElasticity::new(&g, Skalak::new(lit(1.0), lit(2.0)).unwrap());
    // Evaluated once here too, for runs that filter out `stress_jacobian`.
    elastic.evaluate(&g, &s.band, &s.gs, &s.normal, &s.delta, s.dt).unwrap();
    group.bench_function("stress_jacobian", |b| {
        b.iter(|| elastic.evaluate(&g, &s.band, black_box(&s.gs), &s.normal, &s.delta, s.dt).unwrap())
    });
    let mut out = VectorField::zeros(&g);
    group.bench_function("elastic_force", |b| {
        let f = elastic.forcing(&s.band).unwrap();
        b.iter(|| f.add(&g, T::zero(), black_box(&s.v), &mut out))
    });
    let mut bending = BendingStress::new(&g, lit(1e-3)).unwrap();
    group.bench_function("bending", |b| {
        b.iter(|| {
            bending.evaluate(&g, &s.band, black_box(&s.normal), &s.delta, &s.kt).unwrap();
            bending.forcing(&s.band).unwrap().add(&g, T::zero(), &s.v, &mut out).unwrap();
        })
    });
    let mut transport = StrainTransport::new(&g).unwrap();
    let mut gs = s.gs.clone();
    group.bench_function("gs_transport", |b| {
        b.iter(|| {
            gs.copy_from(&s.gs);
            transport.step(&g, &s.band, s.dt, black_box(&s.v), &s.v, &s.normal, &mut gs).unwrap()
        })
    });

    // The fluid: uniform materials, and a viscosity ratio 5 (density ratio 2 for the Poisson
    // equation) inside the capsule.
    let uniform = Materials::uniform(T::one(), T::one()).unwrap();
    let mixture = Materials::mixture(&g, &s.phi, (T::one(), lit(5.0)), (T::one(), T::one())).unwrap();
    let heavy = Materials::mixture(&g, &s.phi, (lit(2.0), T::one()), (T::one(), T::one())).unwrap();
    let implicit = elastic.implicit(&s.band).unwrap();
    let mut x = s.v.clone();
    let mut y = VectorField::zeros(&g);
    let plain = Predictor::new(&g, s.dt, &uniform, None);
    group.bench_function("predictor_apply", |b| b.iter(|| plain.apply(black_box(&mut x), &mut y)));
    let coupled = Predictor::new(&g, s.dt, &mixture, Some(&implicit));
    group.bench_function("predictor_apply_mixture_membrane", |b| {
        b.iter(|| coupled.apply(black_box(&mut x), &mut y))
    });

    // Right-hand side: the operator applied to a perturbed v^n; the solve starts from v^n.
    let mut target = VectorField::from_fn(&g, |p| {
        let w = (T::TAU() * p[2]).sin() * lit(0.01);
        [w, -w, w]
    });
    for (t, v) in target.c.iter_mut().zip(&s.v.c) {
        t.values_mut().iter_mut().zip(v.values()).for_each(|(a, b)| *a += *b);
    }
    let mut rhs = VectorField::zeros(&g);
    coupled.apply(&mut target, &mut rhs).unwrap();
    let mut pc = HelmholtzPrecond::new(&g).unwrap();
    pc.set(T::one() / s.dt, lit(2.5));
    let mut ws = KrylovWorkspace::new(&g);
    let params = KrylovParams { tolerance: if ty == "f32" { 1e-5 } else { 1e-8 }, ..Default::default() };
    let mut sol = s.v.clone();
    let its = bicgstab(&g, &coupled, &mut pc, &rhs, &mut sol, &mut ws, params).unwrap().iterations;
    eprintln!("{ty} {n}^3: krylov_solve_mixture_membrane takes {its} operator applications");
    group.bench_function("krylov_solve_mixture_membrane", |b| {
        b.iter(|| {
            sol.copy_from(&s.v);
            bicgstab(&g, &coupled, &mut pc, black_box(&rhs), &mut sol, &mut ws, params).unwrap()
        })
    });
    // The same solve with the two-viscosity preconditioner (HelmholtzPrecond::set_two).
    let Coefficient::Field(mu) = &mixture.mu else { unreachable!("a viscosity ratio 5 gives a field") };
    let mut pc2 = HelmholtzPrecond::new(&g).unwrap();
    pc2.set_two(T::one() / s.dt, lit(0.5), T::one(), lit(5.0), mu);
    sol.copy_from(&s.v);
    let its = bicgstab(&g, &coupled, &mut pc2, &rhs, &mut sol, &mut ws, params).unwrap().iterations;
    eprintln!("{ty} {n}^3: krylov_solve_mixture_membrane_two takes {its} operator applications");
    group.bench_function("krylov_solve_mixture_membrane_two", |b| {
        b.iter(|| {
            sol.copy_from(&s.v);
            bicgstab(&g, &coupled, &mut pc2, black_box(&rhs), &mut sol, &mut ws, params).unwrap()
        })
    });

    let mut psi = Field::zeros(&g);
    let mut v_new = VectorField::zeros(&g);
    let mut projection = Projection::new(&g, params).unwrap();
    group.bench_function("poisson_direct", |b| {
        b.iter(|| projection.project(&g, &uniform.rho, s.dt, black_box(&s.v), &mut psi, &mut v_new).unwrap())
    });
    let mut vstar = s.v.clone();
    for c in vstar.c.iter_mut() {
        c.values_mut().iter_mut().zip(s.phi.values()).for_each(|(a, p)| *a += lit(0.01) * *p);
    }
    vstar.fill_ghosts(&g);
    let its = projection.project(&g, &heavy.rho, s.dt, &vstar, &mut psi, &mut v_new).unwrap().iterations;
    eprintln!("{ty} {n}^3: poisson_pcg takes {its} iterations");
    group.bench_function("poisson_pcg", |b| {
        b.iter(|| projection.project(&g, &heavy.rho, s.dt, black_box(&vstar), &mut psi, &mut v_new).unwrap())
    });
    group.finish();
}

fn kernels(c: &mut Criterion<CpuTime>) {
    for n in [32, 64] {
        kernels_of::<f64>(c, "f64", n);
        kernels_of::<f32>(c, "f32", n);
    }
}

/// The band kernels of a fixed sphere against the box size.
fn band_cost(c: &mut Criterion<CpuTime>) {
    let mut group = c.benchmark_group("band_cost_f64");
    configure(&mut group, 1);
    for n in [32, 64, 128] {
        let mut s = setup::<f64>(n);
        let g = s.grid.clone();
        eprintln!("band_cost N = {n}: {} band cells, {} halo(2) cells", s.band.len(), s.band.halo(2).len());
        let mut elastic = InPlaneElasticity::new(&g, Skalak::new(1.0, 2.0).unwrap());
        let mut bending = BendingStress::new(&g, 1e-3).unwrap();
        let mut transport = StrainTransport::new(&g).unwrap();
        let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
        let (mut phi, mut kt, mut gs) = (s.phi.clone(), s.kt.clone(), s.gs.clone());
        let mut out = VectorField::zeros(&g);
        group.bench_function(BenchmarkId::new("mthinc_convolved_step", n), |b| {
            b.iter(|| {
                phi.copy_from(&s.phi);
                kt.copy_from(&s.kt);
                adv.step(&g, &s.v, s.dt, &mut phi, Some(&mut kt)).unwrap()
            })
        });
        group.bench_function(BenchmarkId::new("geometry", n), |b| b.iter(|| derive(black_box(&mut s))));
        group.bench_function(BenchmarkId::new("stress_jacobian_force", n), |b| {
            b.iter(|| {
                elastic.evaluate(&g, &s.band, black_box(&s.gs), &s.normal, &s.delta, s.dt).unwrap();
                elastic.forcing(&s.band).unwrap().add(&g, 0.0, &s.v, &mut out).unwrap();
            })
        });
        group.bench_function(BenchmarkId::new("bending", n), |b| {
            b.iter(|| {
                bending.evaluate(&g, &s.band, black_box(&s.normal), &s.delta, &s.kt).unwrap();
                bending.forcing(&s.band).unwrap().add(&g, 0.0, &s.v, &mut out).unwrap();
            })
        });
        group.bench_function(BenchmarkId::new("gs_transport", n), |b| {
            b.iter(|| {
                gs.copy_from(&s.gs);
                transport.step(&g, &s.band, s.dt, black_box(&s.v), &s.v, &s.normal, &mut gs).unwrap()
            })
        });
        let uniform = Materials::uniform(1.0, 1.0).unwrap();
        let op = Predictor::new(&g, s.dt, &uniform, None);
        let (mut x, mut y) = (s.v.clone(), VectorField::zeros(&g));
        group.bench_function(BenchmarkId::new("predictor_apply", n), |b| {
            b.iter(|| op.apply(black_box(&mut x), &mut y))
        });
    }
    group.finish();
}

/// The direct Helmholtz solve with a wall axis (the red cells' channel: walls in y, periodic x
/// and z), where the tridiagonal solves run along y: one component, a pair of components in one
/// complex solve, and the pressure Poisson problem.
fn helmholtz_channel_of<T: Real>(c: &mut Criterion<CpuTime>, ty: &str, n: usize) {
    let wall = Boundary::Wall { velocity: [T::zero(); 3] };
    let per = Boundary::Periodic;
    let g = Grid::<T>::new([n; 3], [T::zero(); 3], [T::one(); 3], [[per, per], [wall, wall], [per, per]])
        .unwrap();
    let mut group = c.benchmark_group(format!("helmholtz_channel_{ty}_{n}cubed"));
    configure(&mut group, g.cell_count());
    let b1 = Field::from_cell_fn(&g, |x| (T::TAU() * x[0]).sin() * x[1] * (T::one() - x[1]) + x[2]);
    let b2 = Field::from_cell_fn(&g, |x| (T::TAU() * x[2]).cos() * x[1]);
    let (mut x1, mut x2) = (Field::zeros(&g), Field::zeros(&g));
    let (sigma, c_visc) = (T::lit(1000.0), T::lit(0.025));
    let mut vel = SpectralSolver::new(&g, Location::Velocity(0)).unwrap();
    group.bench_function("velocity_solve", |b| {
        b.iter(|| vel.solve(&g, sigma, c_visc, black_box(b1.values()), x1.values_mut()))
    });
    group.bench_function("velocity_solve_pair", |b| {
        b.iter(|| {
            vel.solve_pair(
                &g,
                sigma,
                c_visc,
                [black_box(b1.values()), b2.values()],
                [x1.values_mut(), x2.values_mut()],
            )
        })
    });
    let mut pressure = SpectralSolver::new(&g, Location::CellNeumann).unwrap();
    group.bench_function("pressure_solve", |b| {
        b.iter(|| pressure.solve(&g, T::zero(), T::one(), black_box(b1.values()), x1.values_mut()))
    });
    group.finish();
}

fn helmholtz_channel(c: &mut Criterion<CpuTime>) {
    for n in [32, 64] {
        helmholtz_channel_of::<f64>(c, "f64", n);
        helmholtz_channel_of::<f32>(c, "f32", n);
    }
}

criterion_group! {
    name = benches;
    config = common::criterion();
    targets = kernels, band_cost, helmholtz_channel
}
criterion_main!(benches);
