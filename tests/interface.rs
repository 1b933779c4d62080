//! Integration tests of the interface module: conservation, robustness, the paper's Table 1 at
//! N = 32, a 3D translation, shapes and their volumes, geometry integrals, errors.

use eulermembrane::grid::{Field, Grid, VectorField};
use eulermembrane::interface::advect::{AdvectionParams, Advector, Carried, cfl_number};
use eulermembrane::interface::geometry::{Geometry, NormalScheme, PhiRange, delta_in_band};
use eulermembrane::interface::mthinc::{CellQuadrature, Reconstruction, cell_average, solve_offset};
use eulermembrane::interface::shapes::{
    Biconcave, Circle, Ellipse, Ellipsoid, Shape, SignedDistanceFn, Smoothing, Sphere, convolved_curvature,
    smoothed_fields, smoothed_phi,
};
use eulermembrane::{Error, Real};
use proptest::prelude::*;
use std::f64::consts::PI;

/// A discretely divergence-free 3D velocity: u, v from a stream function at the cell edges
/// parallel to z (varying with z), w = 0.
fn swirl<T: Real>(g: &Grid<T>, amp: f64) -> VectorField<T> {
    let h = g.h().map(|x| x.f64());
    let psi = |i: isize, j: isize, k: isize| {
        let (x, y, z) = (i as f64 * h[0], j as f64 * h[1], (k as f64 + 0.5) * h[2]);
        amp * (2.0 * PI * x).sin() * (2.0 * PI * y).cos() * (1.0 + 0.3 * (2.0 * PI * z).cos()) / (2.0 * PI)
    };
    let mut v = VectorField::zeros(g);
    for (i, j, k) in g.cells() {
        let (i, j, k) = (i as isize, j as isize, k as isize);
        let id = g.idx(i, j, k);
        v.c[0].values_mut()[id] = T::lit((psi(i, j + 1, k) - psi(i, j, k)) / h[1]);
        v.c[1].values_mut()[id] = T::lit(-(psi(i + 1, j, k) - psi(i, j, k)) / h[0]);
    }
    v.fill_ghosts(g);
    v
}

fn interior_min_max(g: &Grid<f64>, f: &Field<f64>) -> (f64, f64) {
    g.cells()
        .map(|(i, j, k)| f.values()[g.idx_u(i, j, k)])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)))
}

#[test]
fn conservation_to_round_off_in_3d() {
    let g = Grid::<f64>::periodic([20, 20, 20], [0.0; 3], [1.0; 3]).unwrap();
    let s = Ellipsoid::new([0.45, 0.5, 0.55], [0.25, 0.18, 0.15]).unwrap();
    let (mut phi, mut kt) = smoothed_fields(&g, &s, &Smoothing::default()).unwrap();
    let v = swirl(&g, 1.0);
    let dt = 0.2 / cfl_number(&g, &v, 1.0);
    assert!(cfl_number(&g, &v, dt) <= 0.2 + 1e-12);
    let m0 = phi.interior_sum(&g);
    for scheme in [NormalScheme::Youngs, NormalScheme::Atanh4] {
        let p = AdvectionParams { normals: scheme, ..Default::default() };
        let mut adv = Advector::new(&g, p, Carried::PhiAndCurvature).unwrap();
        for _ in 0..15 {
            let info = adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
            assert!(info.profile_cells > 0 && info.max_iterations < 10, "{info:?}");
        }
        let drift = ((phi.interior_sum(&g) - m0) / m0).abs();
        assert!(drift < 1e-13, "{scheme:?} drift {drift:e}");
    }
    let (lo, hi) = interior_min_max(&g, &phi);
    assert!(lo > -1e-3 && hi < 1.0 + 1e-3, "{lo} {hi}");
}

/// Walls along y: the normal velocity vanishes on the wall faces, phi's ghosts are mirrored, and
/// the volume is still conserved to round-off. The curvature tensors of a sphere are P / R.
#[test]
fn walls_and_curvature_tensors() {
    use eulermembrane::grid::{Boundary, SymField};
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::wall()];
    let g = Grid::<f64>::new([20, 20, 20], [0.0; 3], [1.0; 3], bc).unwrap();
    let s = Sphere::new([0.5, 0.3, 0.5], 0.2).unwrap();
    let (mut phi, mut kt) = smoothed_fields(&g, &s, &Smoothing::default()).unwrap();
    let v = VectorField::from_stream_function(&g, |x| (2.0 * PI * x[0]).sin() * (PI * x[1]).sin() / PI);
    let dt = 0.25 / cfl_number(&g, &v, 1.0);
    let m0 = phi.interior_sum(&g);
    let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    for _ in 0..30 {
        adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
    }
    assert!(((phi.interior_sum(&g) - m0) / m0).abs() < 1e-13);

    let g = Grid::<f64>::periodic([24, 24, 24], [0.0; 3], [1.0; 3]).unwrap();
    let c = [0.51, 0.5, 0.48];
    let phi = smoothed_phi(&g, &Sphere::new(c, 0.3).unwrap(), &Smoothing::default()).unwrap();
    let mut geo = Geometry::new(&g, NormalScheme::Deconvolved);
    geo.update(&g, &phi);
    let mut kap = SymField::zeros(&g);
    geo.curvature_tensors(&g, &phi, PhiRange::new(0.2, 0.8).unwrap(), &mut kap);
    for (i, j, k) in g.cells() {
        let id = g.idx_u(i, j, k);
        if phi.values()[id] > 0.2 && phi.values()[id] < 0.8 {
            let x = g.cell_center(i as isize, j as isize, k as isize);
            let d: Vec<f64> = (0..3).map(|q| x[q] - c[q]).collect();
            let r = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            let n = [d[0] / r, d[1] / r, d[2] / r];
            let p = eulermembrane::tensor::projector(&n);
            for (comp, pq) in kap.c.iter().zip(p) {
                assert!((comp.values()[id] - pq / r).abs() < 0.02 / r);
            }
        }
    }
}

#[test]
fn saturated_flat_and_rough_fields_stay_finite() {
    let g = Grid::<f64>::periodic([12, 12, 12], [0.0; 3], [1.0; 3]).unwrap();
    let v = swirl(&g, 1.0);
    let dt = 0.25 / cfl_number(&g, &v, 1.0);
    // Constant 0, 1, 1/2; a sharp 0/1 step; pseudo-random values in [0, 1].
    let rnd = |x: [f64; 3]| {
        let t = (x[0] * 12.9898 + x[1] * 78.233 + x[2] * 37.719).sin() * 43758.5453;
        t - t.floor()
    };
    let fields: Vec<Field<f64>> = vec![
        Field::from_cell_fn(&g, |_| 0.0),
        Field::from_cell_fn(&g, |_| 1.0),
        Field::from_cell_fn(&g, |_| 0.5),
        Field::from_cell_fn(&g, |x| if x[0] < 0.5 { 1.0 } else { 0.0 }),
        Field::from_cell_fn(&g, rnd),
    ];
    for (case, f0) in fields.into_iter().enumerate() {
        let mut phi = f0.clone();
        let mut kt = f0.clone();
        let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
        let m0 = phi.interior_sum(&g);
        for _ in 0..10 {
            adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
        }
        assert!(phi.first_non_finite(&g).is_none() && kt.first_non_finite(&g).is_none());
        assert!((phi.interior_sum(&g) - m0).abs() <= 1e-12 * m0.max(1.0), "case {case}");
        if case < 3 {
            // A uniform field stays uniform (its fluxes are v * phi, v divergence-free).
            let (lo, hi) = interior_min_max(&g, &phi);
            assert!(hi - lo < 1e-13, "case {case}: {lo} {hi}");
        }
    }
}

proptest! {
    #[test]
    fn offset_solve_is_robust(
        nx in -1.0f64..1.0, ny in -1.0f64..1.0, nz in -1.0f64..1.0,
        phi in prop_oneof![0.0f64..=1.0, Just(0.0), Just(1.0), Just(1e-9), Just(1.0 - 1e-9)],
        scale in 0.05f64..3.0, gauss in any::<bool>(), planar in any::<bool>(),
    ) {
        let q = if gauss { CellQuadrature::Gauss2 } else { CellQuadrature::ExactAlongNormal };
        let nz = if planar { 0.0 } else { nz };
        let m = (nx * nx + ny * ny + nz * nz).sqrt();
        prop_assume!(m > 1e-3);
        let a = [nx / m * scale, ny / m * scale, nz / m * scale];
        let tiny = 1e-10;
        match solve_offset(a, phi, tiny, q) {
            None => prop_assert!(phi <= tiny || phi >= 1.0 - tiny),
            Some(s) => {
                prop_assert!(s.offset.is_finite() && s.mean_slope > 0.0);
                prop_assert!(s.iterations <= 12, "iterations {}", s.iterations);
                let f = cell_average(a, s.offset, q);
                prop_assert!((f - phi).abs() <= 1e-12 * phi.min(1.0 - phi).max(1e-3), "{f} {phi}");
                let (r, _) = Reconstruction::new(phi, [nx / m, ny / m, nz / m], [scale; 3], tiny, q);
                for axis in 0..3 {
                    for up in [false, true] {
                        let h = r.face_average(axis, up);
                        prop_assert!((0.0..=1.0).contains(&h), "{h}");
                    }
                }
            }
        }
    }
}

/// The paper's Table 1 at N = 32 (one full period): L1 errors within 1.2 times the paper's.
#[test]
fn single_vortex_n32_meets_table_1() {
    let n = 32;
    let h = 1.0 / n as f64;
    let g = Grid::<f64>::periodic([n, n, 1], [0.0; 3], [1.0, 1.0, h]).unwrap();
    let e = Ellipse::new([0.5, 0.75], [0.15, 0.105]).unwrap();
    let (phi0, kt0) = smoothed_fields(&g, &e, &Smoothing::default()).unwrap();
    let (mut phi, mut kt) = (phi0.clone(), kt0.clone());
    let v0 =
        VectorField::from_stream_function(&g, |x| (PI * x[0]).sin().powi(2) * (PI * x[1]).cos().powi(2) / PI);
    let steps = (cfl_umax(&g, &v0) / (0.25 * h)).ceil() as usize;
    let dt = 1.0 / steps as f64;
    let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    let mut v = v0.clone();
    for s in 0..steps {
        let c = (PI * s as f64 * dt).cos();
        for d in 0..2 {
            for (x, y) in v.c[d].values_mut().iter_mut().zip(v0.c[d].values()) {
                *x = c * y;
            }
        }
        adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
    }
    let l1 = |a: &Field<f64>, b: &Field<f64>, sc: f64| {
        g.cells()
            .map(|(i, j, k)| ((a.values()[g.idx_u(i, j, k)] - b.values()[g.idx_u(i, j, k)]) * sc).abs())
            .sum::<f64>()
            / g.cell_count() as f64
    };
    let (lp, lk) = (l1(&phi, &phi0, 1.0), l1(&kt, &kt0, h));
    eprintln!("N=32: L1 phi {lp:.3e} (paper 2.67e-3), L1 kappa_R delta_bar {lk:.3e} (5.66e-2)");
    assert!(lp <= 1.2 * 2.67e-3 && lk <= 1.2 * 5.66e-2);
    let m0 = phi0.interior_sum(&g);
    assert!(((phi.interior_sum(&g) - m0) / m0).abs() < 1e-12);
    let (lo, hi) = interior_min_max(&g, &phi);
    assert!(lo > -1e-3 && hi < 1.0 + 1e-3);
}

fn cfl_umax(g: &Grid<f64>, v: &VectorField<f64>) -> f64 {
    g.cells()
        .flat_map(|(i, j, k)| {
            let id = g.idx_u(i, j, k);
            [v.c[0].values()[id].abs(), v.c[1].values()[id].abs()]
        })
        .fold(0.0, f64::max)
}

/// A sphere carried diagonally through a periodic box for one period keeps its volume and
/// shape.
#[test]
fn sphere_translated_through_periodic_box() {
    let n = 16;
    let g = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
    let s = Sphere::new([0.5; 3], 0.3).unwrap();
    let (phi0, kt0) = smoothed_fields(&g, &s, &Smoothing::default()).unwrap();
    let (mut phi, mut kt) = (phi0.clone(), kt0.clone());
    let mut v = VectorField::from_fn(&g, |_| [1.0, 1.0, 1.0]);
    v.fill_ghosts(&g);
    let steps = 3 * 4 * n; // summed Courant number 0.25
    let dt = 1.0 / steps as f64;
    assert!((cfl_number(&g, &v, dt) - 0.25).abs() < 1e-12);
    let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    for _ in 0..steps {
        adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
    }
    let m0 = phi0.interior_sum(&g);
    assert!(((phi.interior_sum(&g) - m0) / m0).abs() < 1e-12);
    let l1 = g
        .cells()
        .map(|(i, j, k)| (phi.values()[g.idx_u(i, j, k)] - phi0.values()[g.idx_u(i, j, k)]).abs())
        .sum::<f64>()
        / g.cell_count() as f64;
    eprintln!("translated sphere N=16: L1 phi {l1:.3e}");
    assert!(l1 < 1e-2, "{l1}");
}

#[test]
fn f32_advection_is_stable_and_conservative() {
    let g = Grid::<f32>::periodic([16, 16, 1], [0.0; 3], [1.0, 1.0, 1.0 / 16.0]).unwrap();
    let c = Circle::new([0.5, 0.5], 0.25).unwrap();
    let (mut phi, mut kt) = smoothed_fields(&g, &c, &Smoothing::default()).unwrap();
    let v = swirl(&g, 1.0);
    let dt = 0.25 / cfl_number(&g, &v, 1.0);
    let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    let m0 = phi.interior_sum(&g);
    for _ in 0..40 {
        adv.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
    }
    assert!(((phi.interior_sum(&g) - m0) / m0).abs() < 1e-5);
}

#[test]
fn history_restore_reproduces_the_next_step() {
    let g = Grid::<f64>::periodic([12, 12, 12], [0.0; 3], [1.0; 3]).unwrap();
    let s = Sphere::new([0.5; 3], 0.3).unwrap();
    let (mut phi, mut kt) = smoothed_fields(&g, &s, &Smoothing::default()).unwrap();
    let v = swirl(&g, 1.0);
    let dt = 0.2 / cfl_number(&g, &v, 1.0);
    let mut a = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    a.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
    let (dtp, rp, rk) = a.history().unwrap();
    let mut b = Advector::new(&g, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    b.restore_history(dtp, rp, rk).unwrap();
    let (mut p2, mut k2) = (phi.clone(), kt.clone());
    a.step(&g, &v, dt, &mut phi, Some(&mut kt)).unwrap();
    b.step(&g, &v, dt, &mut p2, Some(&mut k2)).unwrap();
    assert!(
        phi.values().iter().zip(p2.values()).all(|(x, y)| x == y) || {
            // ghosts may differ (stale); compare the interiors
            g.cells().all(|(i, j, k)| phi.values()[g.idx_u(i, j, k)] == p2.values()[g.idx_u(i, j, k)])
        }
    );
}

#[test]
fn bad_input_gives_errors_not_panics() {
    let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
    let bad_beta = AdvectionParams { beta: -1.0, ..Default::default() };
    assert!(matches!(Advector::new(&g, bad_beta, Carried::Phi), Err(Error::InvalidParameter { .. })));
    let dec = AdvectionParams { normals: NormalScheme::Deconvolved, ..Default::default() };
    assert!(Advector::new(&g, dec, Carried::Phi).is_err());
    let mut adv = Advector::new(&g, AdvectionParams::default(), Carried::Phi).unwrap();
    let mut phi = Field::zeros(&g);
    let mut kt = Field::zeros(&g);
    let v = VectorField::zeros(&g);
    assert!(adv.step(&g, &v, 0.0, &mut phi, None).is_err());
    assert!(adv.step(&g, &v, f64::NAN, &mut phi, None).is_err());
    assert!(adv.step(&g, &v, 0.1, &mut phi, Some(&mut kt)).is_err());
    let g2 = Grid::<f64>::periodic([8, 8, 4], [0.0; 3], [1.0; 3]).unwrap();
    let mut phi2 = Field::zeros(&g2);
    assert!(adv.step(&g2, &VectorField::zeros(&g2), 0.1, &mut phi2, None).is_err());
    // NaN in the field: reported, not a panic.
    let mut phin = Field::zeros(&g);
    phin.values_mut()[g.idx(3, 3, 3)] = f64::NAN;
    assert!(matches!(adv.step(&g, &v, 0.1, &mut phin, None), Err(Error::NonFinite { .. })));
    assert!(Sphere::new([0.5; 3], 0.0).is_err());
    assert!(Sphere::new([f64::NAN, 0.5, 0.5], 0.1).is_err());
    assert!(Ellipsoid::new([0.5; 3], [0.1, -0.1, 0.1]).is_err());
    assert!(Ellipse::new([0.5; 2], [0.1, 0.0]).is_err());
    assert!(Biconcave::new([0.5; 3], -0.2).is_err());
    assert!(Biconcave::with_coefficients([0.5; 3], 0.2, 3, [0.35, 2.0, -1.1]).is_err());
    assert!(Biconcave::with_coefficients([0.5; 3], 0.2, 0, [-0.35, 2.0, -1.1]).is_err());
    assert!(SignedDistanceFn::new(4, |_: [f64; 3]| 0.0).is_err());
    let s = Sphere::new([0.5; 3], 0.2).unwrap();
    let bad = Smoothing { beta: 0.0, points: 4 };
    assert!(smoothed_phi(&g, &s, &bad).is_err());
    let nan_shape = SignedDistanceFn::new(3, |_: [f64; 3]| f64::NAN).unwrap();
    assert!(smoothed_phi(&g, &nan_shape, &Smoothing::default()).is_err());
    assert!(PhiRange::new(0.5, 0.1).is_err());
    assert!(NormalScheme::from_name("nope").is_err());
}

/// Volume of the smoothed field minus the sharp volume, relative: predicted excess
/// `pi^2/4 (h / R)^2` for a sphere; second-order convergence of the remainder for all shapes.
#[test]
fn shape_volumes_converge() {
    let vol = |n: usize, shape: &dyn Shape| {
        let g = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
        let phi = smoothed_phi(&g, shape, &Smoothing::default()).unwrap();
        phi.interior_sum(&g) * g.cell_volume() / shape.volume().unwrap() - 1.0
    };
    let sphere = Sphere::new([0.51, 0.49, 0.5], 0.3).unwrap();
    for n in [16, 32] {
        let e = vol(n, &sphere);
        let pred = eulermembrane::interface::shapes::smoothed_volume_excess(0.3, 1.0 / n as f64, 1.0);
        assert!((e / pred - 1.0).abs() < 0.05, "sphere n={n}: {e} vs {pred}");
    }
    let shapes: Vec<Box<dyn Shape>> = vec![
        Box::new(Ellipsoid::new([0.5, 0.52, 0.49], [0.35, 0.25, 0.2]).unwrap()),
        Box::new(Biconcave::new([0.5, 0.5, 0.5], 0.35).unwrap()),
    ];
    for s in &shapes {
        let (a, b) = (vol(16, s.as_ref()), vol(32, s.as_ref()));
        eprintln!("volume excess {a:.4} -> {b:.4}");
        assert!(a > 0.0 && b > 0.0 && b < a / 3.0 && b < 0.05, "{a} {b}");
    }
    // 2D: area of an ellipse.
    let area = |n: usize| {
        let g = Grid::<f64>::periodic([n, n, 1], [0.0; 3], [1.0, 1.0, 1.0 / n as f64]).unwrap();
        let e = Ellipse::new([0.5, 0.5], [0.3, 0.2]).unwrap();
        let phi = smoothed_phi(&g, &e, &Smoothing::default()).unwrap();
        phi.interior_sum(&g) / (n * n) as f64 / e.volume().unwrap() - 1.0
    };
    let (a, b) = (area(32), area(64));
    assert!(b > 0.0 && b < a / 3.0, "{a} {b}");
}

/// Geometry integrals on a sphere: int delta dV = area, int kappa_R tilde dV = area / R, and the
/// mean curvature 1/R at the interface (the sign convention).
#[test]
fn geometry_integrals_on_a_sphere() {
    let n = 32;
    let r = 0.3;
    let g = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
    let s = Sphere::new([0.5, 0.49, 0.52], r).unwrap();
    let (phi, kt) = smoothed_fields(&g, &s, &Smoothing::default()).unwrap();
    let area = 4.0 * PI * r * r;
    let mut delta = Field::zeros(&g);
    delta_in_band(&g, &phi, PhiRange::new(0.0, 1.0).unwrap(), &mut delta);
    let sd = delta.interior_sum(&g) * g.cell_volume();
    assert!((sd / area - 1.0).abs() < 0.02, "{sd} {area}");
    let sk = kt.interior_sum(&g) * g.cell_volume();
    assert!((sk / (area / r) - 1.0).abs() < 0.02, "{sk}");
    let k2 = convolved_curvature(&g, &s, &Smoothing::default()).unwrap();
    assert!(k2.values().iter().zip(kt.values()).all(|(a, b)| (a - b).abs() < 1e-12));
    for scheme in NormalScheme::ALL {
        let mut geo = Geometry::new(&g, scheme);
        geo.update(&g, &phi);
        let mut mean = Field::zeros(&g);
        geo.mean_curvature(&g, &phi, PhiRange::new(0.3, 0.7).unwrap(), &mut mean);
        let mut normals = [Field::zeros(&g), Field::zeros(&g), Field::zeros(&g)];
        geo.normals(&g, &phi, PhiRange::new(0.3, 0.7).unwrap(), &mut normals);
        for (i, j, k) in g.cells() {
            let id = g.idx_u(i, j, k);
            if phi.values()[id] > 0.3 && phi.values()[id] < 0.7 {
                let m = mean.values()[id] * r;
                assert!(m > 0.7 && m < 1.3, "{scheme:?} {m}");
                let x = g.cell_center(i as isize, j as isize, k as isize);
                // Inward: n . (x - c) < 0.
                let dot: f64 = (0..3).map(|d| normals[d].values()[id] * (x[d] - [0.5, 0.49, 0.52][d])).sum();
                assert!(dot < 0.0);
            }
        }
    }
}

#[test]
fn biconcave_shape_matches_its_profile() {
    let a = 0.2;
    let b = Biconcave::new([0.0; 3], a).unwrap();
    // On the axis: thickness c1 a; at the rim: x = 0, r = a.
    let sp = b.closest([0.0, 0.0, 0.0]);
    assert!((sp.distance - 0.5 * 0.35 * a).abs() < 1e-9, "{}", sp.distance);
    let sp = b.closest([0.0, 1.2 * a, 0.0]);
    assert!((sp.distance + 0.2 * a).abs() < 1e-9);
    assert!(sp.mean_curvature > 0.0);
    // Points of the profile are at distance zero; the closest point of a nearby point projects
    // back to it.
    for sg in [0.1, 0.5, 0.9] {
        let r = a * f64::sqrt(sg);
        let x = 0.5 * a * (0.35 + 2.003 * sg - 1.123 * sg * sg) * (1.0 - sg).sqrt();
        let p = [x, r * 0.6, r * 0.8];
        assert!(b.signed_distance(p).abs() < 1e-9);
        let q = [x + 0.01 * a, r * 0.6, r * 0.8];
        let sp = b.closest(q);
        let d: f64 = (0..3).map(|k| (sp.point[k] - q[k]).powi(2)).sum::<f64>().sqrt();
        assert!((d - sp.distance.abs()).abs() < 1e-12);
    }
    // Mean curvature by finite differences of the signed distance agrees with the exact one.
    let f =
        SignedDistanceFn::new(3, |x: [f64; 3]| b.signed_distance(x)).unwrap().with_step(1e-4 * a).unwrap();
    for p in [[0.09, 0.05, 0.0], [0.0, 0.0, 0.21], [-0.05, 0.1, 0.1]] {
        let (e, fd) = (b.closest(p), f.closest(p));
        assert!((e.mean_curvature - fd.mean_curvature).abs() < 1e-3 * (1.0 / a), "{p:?}");
    }
}

#[test]
fn periodic_images_are_used() {
    let g = Grid::<f64>::periodic([16, 16, 16], [0.0; 3], [1.0; 3]).unwrap();
    let a = smoothed_phi(&g, &Sphere::new([0.5; 3], 0.2).unwrap(), &Smoothing::default()).unwrap();
    let b = smoothed_phi(&g, &Sphere::new([0.0, 0.5, 0.5], 0.2).unwrap(), &Smoothing::default()).unwrap();
    let (sa, sb) = (a.interior_sum(&g), b.interior_sum(&g));
    assert!((sa - sb).abs() < 1e-9 * sa, "{sa} {sb}");
}

/// A capsule box (a ring along x and z, a segment between the walls along y) carries `phi`
/// through its seams and conserves its sum as the whole grid does, although the flow it
/// gathers differs between its two ends (the seam cells' divergence is the box's closure).
#[test]
fn a_capsule_box_conserves_phi_across_its_seams() {
    use eulermembrane::grid::{Boundary, Window};
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::wall()];
    let g = Grid::<f64>::new([32, 32, 32], [0.0; 3], [1.0; 3], bc).unwrap();
    // Divergence-free, not periodic over the box: the flow at the box's two ends differs.
    let v = VectorField::from_stream_function(&g, |x| (2.0 * PI * x[0]).sin() * (PI * x[1]).sin() / PI);
    let w = Window::new(&g, [-6, 4, 6], [20, 22, 20]).unwrap();
    assert_eq!((w.rings(), w.segments()), ([true, false, true], [false, true, false]));
    let bg = w.grid(&g);
    assert_eq!(bg.seams(), [true; 3]);
    assert_eq!(g.seams(), [false; 3]);
    let mut vb = VectorField::zeros(&bg);
    w.gather_vector(&g, &v, &bg, &mut vb).unwrap();
    let s = Sphere::new([0.1, 0.45, 0.5], 0.15).unwrap();
    let (mut phi, mut kt) = smoothed_fields(&bg, &s, &Smoothing::default()).unwrap();
    // A far tail reaching the seams, as a sheared capsule's does.
    phi.values_mut().iter_mut().for_each(|p| *p += 1e-6);
    let dt = 0.25 / cfl_number(&bg, &vb, 1.0);
    let m0 = phi.interior_sum(&bg);
    let mut adv = Advector::new(&bg, AdvectionParams::default(), Carried::PhiAndCurvature).unwrap();
    for _ in 0..20 {
        adv.step(&bg, &vb, dt, &mut phi, Some(&mut kt)).unwrap();
    }
    let drift = ((phi.interior_sum(&bg) - m0) / m0).abs();
    assert!(drift < 1e-13, "drift {drift:e}");
}
