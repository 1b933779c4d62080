//! The diagnostics against closed forms: volume and centroid (3.5) of smoothed spheres, the area
//! `sum delta dV` and its transport (3.7), spherical-harmonic modes (3.3), the Taylor deformation
//! of an ellipsoid section, the energy budget of a Taylor-Green vortex, velocity profiles.
//! Each test prints the measured errors (run with `--nocapture` to see them).

use eulermembrane::diagnostics::{
    area::{AreaTracker, area_from_delta, dilation_rate},
    energy::{
        DissipationForm, EnergyBudget, EnergyState, body_force_power, elastic_energy, kinetic_energy,
        viscous_dissipation,
    },
    modes::{ModeWeight, mode_amplitudes, surface_modes},
    profile::{ProfileAxes, Span, streamwise_profile},
    taylor::{fit_ellipse, section_contour, taylor_deformation},
    volume::{centroid, volume},
};
use eulermembrane::fluid::{
    momentum::{Coefficient, Materials},
    stepper::{FlowConfig, FlowStepper},
};
use eulermembrane::grid::{Boundary, Field, Grid, VectorField};
use eulermembrane::{Error, Real};
use std::f64::consts::PI;

/// The logistic profile `1 / (1 + exp(-x))` = `(1 + tanh(x/2)) / 2`.
fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// Minimum-image displacement `x - c` on a periodic box of period `l` per axis.
fn min_image(x: [f64; 3], c: [f64; 3], l: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|d| {
        let dx = x[d] - c[d];
        dx - l[d] * (dx / l[d]).round()
    })
}

fn norm(x: [f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// Cell averages of `f` (3-point Gauss rule per axis, 27 points per cell), ghosts included.
fn cell_average<T: Real>(grid: &Grid<T>, f: impl Fn([f64; 3]) -> f64) -> Field<T> {
    let h = grid.h().map(|x| x.f64());
    let g = [-(0.6f64).sqrt() / 2.0, 0.0, (0.6f64).sqrt() / 2.0];
    let w = [5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0];
    Field::from_cell_fn(grid, |c| {
        let c = c.map(|x| x.f64());
        let mut s = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                for e in 0..3 {
                    let x = [c[0] + g[a] * h[0], c[1] + g[b] * h[1], c[2] + g[e] * h[2]];
                    s += w[a] * w[b] * w[e] * f(x);
                }
            }
        }
        T::lit(s)
    })
}

/// `delta = |grad phi|` and the inward normals `grad phi / |grad phi|` by central differences
/// (`phi` sampled with its ghosts).
fn delta_and_normals(grid: &Grid<f64>, phi: &Field<f64>) -> (Field<f64>, [Field<f64>; 3]) {
    let st = grid.strides();
    let h = grid.h();
    let mut delta = Field::zeros(grid);
    let mut n: [Field<f64>; 3] = std::array::from_fn(|_| Field::zeros(grid));
    for (i, j, k) in grid.cells() {
        let id = grid.idx_u(i, j, k);
        let g: [f64; 3] =
            std::array::from_fn(|d| (phi.values()[id + st[d]] - phi.values()[id - st[d]]) / (2.0 * h[d]));
        let m = norm(g);
        delta.values_mut()[id] = m;
        for d in 0..3 {
            n[d].values_mut()[id] = if m > 0.0 { g[d] / m } else { 0.0 };
        }
    }
    (delta, n)
}

/// A periodic cube `[lo, hi]^3` of `n^3` cells.
fn cube(n: usize, lo: f64, hi: f64) -> Grid<f64> {
    Grid::periodic([n; 3], [lo; 3], [hi; 3]).unwrap()
}

/// Volume of the logistic sphere `phi = logistic((r0 - r)/eps)`: `4 pi/3 (r0^3 + pi^2 eps^2 r0)`
/// (Sommerfeld; exponentially small terms dropped).
fn smoothed_sphere_volume(r0: f64, eps: f64) -> f64 {
    4.0 * PI / 3.0 * (r0.powi(3) + PI * PI * eps * eps * r0)
}

#[test]
fn volume_and_centroid_of_a_cell_averaged_sphere() {
    let g = cube(32, 0.0, 1.0);
    let (r0, eps) = (0.3, 0.5 / 32.0);
    let c = [0.52, 0.47, 0.505];
    let phi: Field<f64> = cell_average(&g, |x| logistic((r0 - norm(min_image(x, c, [1.0; 3]))) / eps));
    let v = volume(&g, &phi).unwrap();
    let v_exact = smoothed_sphere_volume(r0, eps);
    let xc = centroid(&g, &phi).unwrap();
    let ec = norm(min_image(xc, c, [1.0; 3]));
    println!("volume rel err {:.2e}, centroid err {ec:.2e}", (v - v_exact).abs() / v_exact);
    assert!((v - v_exact).abs() < 1e-6 * v_exact, "{v} vs {v_exact}");
    // The cell-averaged phi_ijk times the cell-centre x_ijk is a midpoint rule in x: O(h^2) locally,
    // cancelling over a symmetric body up to the quadrature of the averages.
    assert!(ec < 1e-6, "{xc:?}");
}

#[test]
fn centroid_of_a_sphere_straddling_a_periodic_corner() {
    let g = cube(32, 0.0, 1.0);
    let (r0, eps) = (0.2, 0.5 / 32.0);
    let c = [0.97, 0.015, 0.5];
    let phi: Field<f64> = cell_average(&g, |x| logistic((r0 - norm(min_image(x, c, [1.0; 3]))) / eps));
    let xc = centroid(&g, &phi).unwrap();
    println!("centroid {xc:?} (exact {c:?})");
    for d in 0..3 {
        assert!((xc[d] - c[d]).abs() < 1e-6, "{xc:?}");
        assert!((0.0..1.0).contains(&xc[d]));
    }
    let v = volume(&g, &phi).unwrap();
    assert!((v - smoothed_sphere_volume(r0, eps)).abs() < 1e-6 * v);
    // The same sphere in f32 gives the same volume and centroid to single precision.
    let g32 = Grid::<f32>::periodic([32; 3], [0.0; 3], [1.0; 3]).unwrap();
    let phi32: Field<f32> = cell_average(&g32, |x| logistic((r0 - norm(min_image(x, c, [1.0; 3]))) / eps));
    let v32 = volume(&g32, &phi32).unwrap();
    let xc32 = centroid(&g32, &phi32).unwrap();
    assert!((v32 - v).abs() < 1e-6 * v, "{v32} vs {v}");
    assert!(norm(min_image(xc32, c, [1.0; 3])) < 1e-5, "{xc32:?}");
}

#[test]
fn sums_do_not_depend_on_the_thread_count() {
    let g = cube(40, 0.0, 1.0);
    let phi = Field::from_cell_fn(&g, |x| logistic((0.3 - norm(min_image(x, [0.5; 3], [1.0; 3]))) * 80.0));
    let (delta, _) = delta_and_normals(&g, &phi);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let m = surface_modes(&g, &delta, [0.5; 3], 4, ModeWeight::Area).unwrap();
            (volume(&g, &phi).unwrap(), centroid(&g, &phi).unwrap(), m.amplitudes())
        })
    };
    assert_eq!(run(1), run(2));
    assert_eq!(run(1), run(3));
}

#[test]
fn area_from_delta_converges_to_the_sphere_area() {
    // Profile width eps = h (the cell-averaged MTHINC profile with beta = 1 is about h/2 wide):
    // sum delta dV = (area of the level sets averaged over 0 < phi < 1) + differencing error,
    // both O(h^2).
    let r0 = 0.3;
    let exact = 4.0 * PI * r0 * r0;
    let mut errs = Vec::new();
    for n in [32usize, 64, 128] {
        let g = cube(n, 0.0, 1.0);
        let eps = 1.0 / n as f64;
        let phi = Field::from_cell_fn(&g, |x| logistic((r0 - norm(min_image(x, [0.5; 3], [1.0; 3]))) / eps));
        let (delta, _) = delta_and_normals(&g, &phi);
        let a = area_from_delta(&g, &delta).unwrap();
        // Continuum value of int |grad phi| dV: 4 pi (r0^2 + pi^2 eps^2 / 3).
        let smoothed = 4.0 * PI * (r0 * r0 + PI * PI * eps * eps / 3.0);
        let e = (a - exact).abs() / exact;
        let es = (a - smoothed).abs() / smoothed;
        println!(
            "N = {n}: area {a:.6} (exact {exact:.6}, smoothed profile {smoothed:.6}), rel err {e:.2e} \
             (to the smoothed value {es:.2e})"
        );
        assert!(es < 2e-2 * (32.0 / n as f64).powi(2), "{n}: {es}");
        errs.push(e);
    }
    let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    println!("orders {orders:?}");
    assert!(errs[2] < 3e-3, "{errs:?}");
    assert!(orders[1] > 1.8, "{orders:?}");
}

/// The spheroid `r = r0 (1 + e P2(cos theta))` about `c`, sampled as a logistic profile in the
/// radial distance to the surface.
fn spheroid_phi(g: &Grid<f64>, c: [f64; 3], r0: f64, e: f64, eps: f64) -> Field<f64> {
    Field::from_cell_fn(g, |x| {
        let d = min_image(x, c, [1.0; 3]);
        let r = norm(d);
        let ct = if r > 0.0 { d[2] / r } else { 1.0 };
        let rs = r0 * (1.0 + e * 0.5 * (3.0 * ct * ct - 1.0));
        logistic((rs - r) / eps)
    })
}

#[test]
fn modes_of_a_sphere_vanish_beyond_degree_zero() {
    let g = cube(48, 0.0, 1.0);
    let (r0, eps) = (0.3, 1.0 / 48.0);
    let c = [0.503, 0.497, 0.51];
    let phi = spheroid_phi(&g, c, r0, 0.0, eps);
    let (delta, normals) = delta_and_normals(&g, &phi);
    let xc = centroid(&g, &phi).unwrap();
    for (name, w) in [
        ("area", ModeWeight::Area),
        ("radius", ModeWeight::Radius),
        ("solid angle", ModeWeight::SolidAngle { normals: &normals }),
    ] {
        let m = surface_modes(&g, &delta, xc, 6, w).unwrap();
        let r = m.equivalent_radius();
        let amp = m.amplitudes();
        let worst = (1..=6).flat_map(|n| amp[n].clone()).fold(0.0, f64::max) / amp[0][0];
        // The area weight sees the level sets' mean area, 4 pi (r0^2 + pi^2 eps^2 / 3); the
        // radius weights their mean radius, r0.
        let want = if name == "area" { (r0 * r0 + PI * PI * eps * eps / 3.0).sqrt() } else { r0 };
        println!(
            "{name}: equivalent radius {r:.5} (expected {want:.5}, rel err {:.1e}), \
             max |R_nm| / R_00 for n >= 1: {worst:.2e}",
            (r - want).abs() / want
        );
        assert!((r - want).abs() < 2e-3 * want, "{name}: {r}");
        assert!(worst < 2e-3, "{name}: {amp:?}");
    }
}

#[test]
fn modes_of_a_spheroid_give_the_p2_amplitude() {
    let g = cube(64, 0.0, 1.0);
    let (r0, eps) = (0.3, 1.0 / 64.0);
    let c = [0.5, 0.5, 0.5];
    // The expansion (3.2) of r = r0 (1 + e P2) has R_00 = 2 sqrt(pi) r0 and
    // R_20 = sqrt(4 pi / 5) e r0, and nothing else.
    for e in [0.05, 0.2] {
        let phi = spheroid_phi(&g, c, r0, e, eps);
        let (delta, normals) = delta_and_normals(&g, &phi);
        let r20 = (4.0 * PI / 5.0).sqrt() * e * r0;
        let exact = mode_amplitudes(&g, &delta, c, 6, ModeWeight::SolidAngle { normals: &normals }).unwrap();
        let near = mode_amplitudes(&g, &delta, c, 6, ModeWeight::<f64>::Radius).unwrap();
        let err_exact = (exact[2][0] - r20).abs() / r20;
        let err_near = (near[2][0] - r20).abs() / r20;
        let spurious = [1usize, 3, 4, 5, 6].iter().flat_map(|&n| exact[n].clone()).fold(0.0, f64::max) / r20;
        let spurious_m = (1..=2).map(|m| exact[2][m]).fold(0.0, f64::max) / r20;
        println!(
            "e = {e}: R_20 solid angle {:.6} radius {:.6} exact {r20:.6} (rel err {err_exact:.2e}, \
             {err_near:.2e}); other modes / R_20 <= {spurious:.1e}, R_2m / R_20 <= {spurious_m:.1e}; \
             R_00 / (2 sqrt pi) = {:.5}",
            exact[2][0],
            near[2][0],
            exact[0][0] / (2.0 * PI.sqrt())
        );
        assert!(err_exact < 1e-2, "{e}: {err_exact}");
        assert!(spurious < 1e-2 && spurious_m < 1e-3);
        assert!((exact[0][0] / (2.0 * PI.sqrt()) - r0).abs() < 1e-3 * r0);
        // The radius weight is first-order in e.
        assert!(err_near < 1.5 * e, "{e}: {err_near}");
        // (3.3) as printed: the modes of the area density int_S Y dA, checked against a
        // quadrature over the surface r(theta) = r0 (1 + e P2).
        let area = surface_modes(&g, &delta, c, 2, ModeWeight::<f64>::Area).unwrap();
        // The surface integral is averaged over the level sets r = r_s(theta) - eps logit(phi)
        // of the profile (the coarea formula), by the midpoint rule in phi.
        let (mut a00, mut a20) = (0.0, 0.0);
        let (k, levels) = (2000, 400);
        for lv in 0..levels {
            let ph = (lv as f64 + 0.5) / levels as f64;
            let off = -eps * (ph / (1.0 - ph)).ln();
            for q in 0..k {
                let th = (q as f64 + 0.5) * PI / k as f64;
                let (ct, st) = (th.cos(), th.sin());
                let r = r0 * (1.0 + e * 0.5 * (3.0 * ct * ct - 1.0)) + off;
                let dr = -3.0 * r0 * e * ct * st;
                let da = 2.0 * PI * r * (r * r + dr * dr).sqrt() * st * PI / (k * levels) as f64;
                a00 += da / (4.0 * PI).sqrt();
                a20 += da * (2.5f64).sqrt() * 0.5 * (3.0 * ct * ct - 1.0) / (2.0 * PI).sqrt();
            }
        }
        let (e00, e20) = ((area.zonal(0).unwrap() - a00) / a00, (area.zonal(2).unwrap() - a20) / a20);
        println!("   area weight: R_00 rel err {e00:.2e}, R_20 rel err {e20:.2e}");
        assert!(e00.abs() < 1e-3 && e20.abs() < 1e-2, "{e00} {e20}");
    }
}

/// `phi` of the ellipsoid with semi-axes `(a, b, c)` along `(x', y, z')`, `x'` tilted by `tilt`
/// from x towards z, centred at `xc`.
fn ellipsoid_phi(g: &Grid<f64>, xc: [f64; 3], axes: [f64; 3], tilt: f64, eps: f64) -> Field<f64> {
    let (ct, st) = (tilt.cos(), tilt.sin());
    let scale = (axes[0] * axes[2]).sqrt();
    Field::from_cell_fn(g, |x| {
        let d = [x[0] - xc[0], x[1] - xc[1], x[2] - xc[2]];
        let (u, w) = (ct * d[0] + st * d[2], -st * d[0] + ct * d[2]);
        let f = ((u / axes[0]).powi(2) + (d[1] / axes[1]).powi(2) + (w / axes[2]).powi(2)).sqrt();
        logistic((1.0 - f) * scale / eps)
    })
}

#[test]
fn taylor_deformation_of_a_tilted_ellipsoid() {
    // Shear-flow box of Sec. 3.3: walls normal to z, periodic x and y; 16 cells per radius
    // (sqrt(L B) = 1, h = 1/16).
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::wall(), Boundary::wall()];
    let g = Grid::new([64, 48, 64], [-2.0, -1.5, -2.0], [2.0, 1.5, 2.0], bc).unwrap();
    let h = 1.0 / 16.0;
    let (l, b) = (1.25, 0.8);
    let d_exact = (l - b) / (l + b);
    for (tilt_deg, centre) in [(30.0f64, [0.03, 0.011, -0.021]), (-12.0, [-0.2, 0.3, 0.1]), (0.0, [0.0; 3])] {
        let phi = ellipsoid_phi(&g, centre, [l, 1.0, b], tilt_deg.to_radians(), 0.5 * h);
        let xc = centroid(&g, &phi).unwrap();
        let t = taylor_deformation(&g, &phi, xc, 1).unwrap();
        let (ed, ea) = ((t.deformation - d_exact).abs() / d_exact, (t.angle_deg - tilt_deg).abs());
        println!(
            "tilt {tilt_deg}: D = {:.5} (exact {d_exact:.5}, rel err {ed:.2e}), angle {:.3} deg (err {ea:.3}), \
             L = {:.4}, B = {:.4}, {} points, rms distance {:.1e}",
            t.deformation, t.angle_deg, t.semi_major, t.semi_minor, t.points, t.rms_distance
        );
        assert!(ed < 1e-2, "{t:?}");
        assert!(ea < 1.0, "{t:?}");
        assert!((t.semi_major - l).abs() < 0.01 * l && (t.semi_minor - b).abs() < 0.01 * b);
        assert!((t.centre[0] - centre[0]).abs() < 0.01 && (t.centre[1] - centre[2]).abs() < 0.01);
    }
}

#[test]
fn taylor_deformation_in_2d_and_across_a_periodic_boundary() {
    // A 2D grid (one cell in z): the section normal to z, an ellipse centred near the corner.
    let g = Grid::<f64>::periodic([96, 96, 1], [0.0; 3], [6.0, 6.0, 1.0 / 16.0]).unwrap();
    let (l, b, tilt) = (1.2, 0.9, 0.6f64);
    let c = [5.9, 0.2, 0.0];
    let phi = Field::from_cell_fn(&g, |x| {
        let d = min_image(x, c, [6.0, 6.0, 1.0]);
        let (u, w) = (tilt.cos() * d[0] + tilt.sin() * d[1], -tilt.sin() * d[0] + tilt.cos() * d[1]);
        logistic((1.0 - ((u / l).powi(2) + (w / b).powi(2)).sqrt()) * 16.0)
    });
    let xc = centroid(&g, &phi).unwrap();
    let t = taylor_deformation(&g, &phi, xc, 2).unwrap();
    let d_exact = (l - b) / (l + b);
    println!(
        "2D: D = {:.5} (exact {d_exact:.5}), angle {:.3} deg, centre {:?}",
        t.deformation, t.angle_deg, t.centre
    );
    assert!((t.deformation - d_exact).abs() < 1e-2 * d_exact);
    assert!((t.angle_deg - tilt.to_degrees()).abs() < 1.0);
    assert!((t.centre[0] - c[0]).abs() < 0.01 && (t.centre[1] - c[1]).abs() < 0.01, "{t:?}");
}

#[test]
fn taylor_deformation_refuses_what_is_not_an_ellipse() {
    // Three points.
    let e = fit_ellipse(&[[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]).unwrap_err();
    assert!(matches!(e, Error::InvalidParameter { name: "points", .. }), "{e}");
    // A hyperbola x^2 - y^2 = 1 sampled on both branches.
    let hyp: Vec<[f64; 2]> = (-5..=5)
        .flat_map(|k| {
            let t = 0.2 * k as f64;
            [[t.cosh(), t.sinh()], [-t.cosh(), t.sinh()]]
        })
        .collect();
    assert!(matches!(fit_ellipse(&hyp), Err(Error::Unsupported { .. })));
    // A blob of a few cells gives fewer than 6 crossings; an empty field none.
    let g = cube(16, 0.0, 1.0);
    let mut phi = Field::zeros(&g);
    let id = g.idx_u(8, 8, 8);
    phi.values_mut()[id] = 1.0;
    let pts = section_contour(&g, &phi, [0.5 + 1.0 / 32.0; 3], 1, 0.5).unwrap();
    assert_eq!(pts.len(), 4);
    assert!(taylor_deformation(&g, &phi, [0.5 + 1.0 / 32.0; 3], 1).is_err());
    assert!(taylor_deformation(&g, &Field::zeros(&g), [0.5; 3], 1).is_err());
    assert!(taylor_deformation(&g, &phi, [0.5; 3], 3).is_err());
    let mut bad = phi.clone();
    bad.values_mut()[id] = f64::NAN;
    assert!(matches!(taylor_deformation(&g, &bad, [0.5 + 1.0 / 32.0; 3], 1), Err(Error::NonFinite { .. })));
}

/// The Taylor-Green field `u = sin x cos y cos z`, `v = -cos x sin y cos z`, `w = 0` on
/// `[0, 2 pi]^3`.
fn taylor_green(g: &Grid<f64>) -> VectorField<f64> {
    VectorField::from_fn(g, |x| {
        [x[0].sin() * x[1].cos() * x[2].cos(), -x[0].cos() * x[1].sin() * x[2].cos(), 0.0]
    })
}

#[test]
fn kinetic_energy_and_dissipation_of_taylor_green() {
    let mu = 0.3;
    let mut prev = [f64::INFINITY; 3];
    for n in [16usize, 32] {
        let g = cube(n, 0.0, 2.0 * PI);
        let v = taylor_green(&g);
        let h = 2.0 * PI / n as f64;
        let p3 = PI.powi(3);
        // Discrete closed forms: centre averages scale the field by cos(h/2); compact
        // differences by s1 = sin(h/2)/(h/2); centre-averaged two-cell differences by
        // s2 = cos(h/2) sin(h)/h. Continuum: pi^3 and 6 pi^3 mu.
        let (s1, s2) = ((h / 2.0).sin() / (h / 2.0), (h / 2.0).cos() * h.sin() / h);
        let ke = kinetic_energy(&g, &v, &Coefficient::Uniform(1.0)).unwrap();
        let ke_d = p3 * (h / 2.0).cos().powi(2);
        let dgg = viscous_dissipation(&g, &v, &Coefficient::Uniform(mu), DissipationForm::GradGrad).unwrap();
        let dgg_d = mu * p3 * (2.0 * s1 * s1 + 4.0 * s2 * s2);
        let dsr =
            viscous_dissipation(&g, &v, &Coefficient::Uniform(mu), DissipationForm::StrainRate).unwrap();
        let dsr_d = mu * p3 * (4.0 * s1 * s1 + 2.0 * s2 * s2);
        let errs = [
            (ke - p3).abs() / p3,
            (dgg - 6.0 * mu * p3).abs() / (6.0 * mu * p3),
            (dsr - 6.0 * mu * p3).abs() / (6.0 * mu * p3),
        ];
        println!(
            "N = {n}: KE {ke:.6} (pi^3 {p3:.6}), grad v:grad v {dgg:.6}, 2D:D {dsr:.6} (6 mu pi^3 {:.6}); \
             relative errors to the continuum {:?}",
            6.0 * mu * p3,
            errs.map(|e| format!("{e:.2e}"))
        );
        assert!((ke - ke_d).abs() < 1e-12 * ke_d);
        assert!((dgg - dgg_d).abs() < 1e-12 * dgg_d);
        assert!((dsr - dsr_d).abs() < 1e-12 * dsr_d);
        // The stepper's own operator: the field is discretely divergence free and every
        // component has wavenumber 1 along each axis, so div_h(mu (grad_h v + grad_h v^T))
        // = mu Lap_h v = -3 mu s1^2 v, and the face sums of sin^2 are exact: 6 mu pi^3 s1^2.
        let ddi = viscous_dissipation(&g, &v, &Coefficient::Uniform(mu), DissipationForm::Discrete).unwrap();
        let ddi_d = 6.0 * mu * p3 * s1 * s1;
        assert!((ddi - ddi_d).abs() < 1e-12 * ddi_d, "discrete {ddi} vs {ddi_d}");
        for (e, p) in errs.iter().zip(&mut prev) {
            assert!(*e < *p / 3.5, "not second order: {e} after {p}");
            *p = *e;
        }
        // A cell-wise density field gives the same as the uniform one.
        let rho = Coefficient::Field(Field::from_cell_fn(&g, |_| 2.0));
        assert!((kinetic_energy(&g, &v, &rho).unwrap() - 2.0 * ke).abs() < 1e-12 * ke);
    }
}

#[test]
fn body_force_power_and_elastic_energy() {
    let g = cube(16, 0.0, 1.0);
    let v = VectorField::from_fn(&g, |_| [1.0, 2.0, -1.0]);
    let f = VectorField::from_fn(&g, |_| [3.0, 1.0, 0.5]);
    let p = body_force_power(&g, &v, &f).unwrap();
    assert!((p - 4.5).abs() < 1e-12, "{p}");
    let phi = Field::from_cell_fn(&g, |x| logistic((0.3 - norm(min_image(x, [0.5; 3], [1.0; 3]))) * 32.0));
    let (delta, _) = delta_and_normals(&g, &phi);
    let w = Field::from_cell_fn(&g, |_| 2.5);
    let e = elastic_energy(&g, &delta, &w).unwrap();
    assert!((e - 2.5 * area_from_delta(&g, &delta).unwrap()).abs() < 1e-12 * e);
}

#[test]
fn energy_budget_of_a_decaying_taylor_green_vortex_closes() {
    // 2D Taylor-Green decaying under the flow stepper: E_kin + int Phi dt stays constant to the
    // O(h^2) difference between the diagnostic gradient and the stepper's viscous operator.
    let n = 32;
    let g = Grid::<f64>::periodic([n, n, 1], [0.0; 3], [2.0 * PI, 2.0 * PI, 2.0 * PI / n as f64]).unwrap();
    let mu = 0.05;
    let mut flow = FlowStepper::new(&g, Materials::uniform(1.0, mu).unwrap(), FlowConfig::default()).unwrap();
    flow.set_velocity(|x| [x[0].sin() * x[1].cos(), -x[0].cos() * x[1].sin(), 0.0]).unwrap();
    let rho = Coefficient::Uniform(1.0);
    let muc = Coefficient::Uniform(mu);
    let mut budget = EnergyBudget::new();
    let dt = 0.02;
    for step in 0..=100 {
        if step > 0 {
            flow.step(dt, &(), None).unwrap();
        }
        let v = flow.velocity();
        budget
            .record(EnergyState {
                time: flow.time(),
                kinetic: kinetic_energy(&g, v, &rho).unwrap(),
                dissipation_rate: viscous_dissipation(&g, v, &muc, DissipationForm::GradGrad).unwrap(),
                ..Default::default()
            })
            .unwrap();
    }
    let first = budget.samples()[0];
    let last = *budget.latest().unwrap();
    let rel = budget.drift() / first.kinetic;
    println!(
        "E_kin {:.5} -> {:.5}, dissipated {:.5}, total drift / E_kin(0) = {rel:.2e}",
        first.kinetic, last.kinetic, last.dissipated
    );
    assert!(last.kinetic < 0.9 * first.kinetic);
    assert!(rel < 1e-4, "{rel}");
    // Time must advance.
    let t = last.time;
    assert!(budget.record(EnergyState { time: t, ..Default::default() }).is_err());
    assert_eq!(budget.samples().len(), 101);
}

/// With step integrals the budget takes their differences, not the trapezoid of the rates.
#[test]
fn budget_uses_step_integrals_when_given() {
    use eulermembrane::diagnostics::energy::StepIntegrals;
    let mut budget = EnergyBudget::new();
    let state = |t: f64, d: f64, w: f64| EnergyState {
        time: t,
        kinetic: 1.0,
        dissipation_rate: 100.0, // ignored when integrals are given
        integrals: Some(StepIntegrals { dissipated: d, work: w }),
        ..Default::default()
    };
    budget.record(state(0.0, 5.0, 7.0)).unwrap();
    let s = budget.record(state(0.5, 5.25, 7.5)).unwrap();
    assert_eq!((s.dissipated, s.work), (0.25, 0.5));
    assert_eq!(s.total, 1.0 + 0.25 - 0.5);
    // A non-finite integral is refused and leaves the budget as it was.
    assert!(budget.record(state(1.0, f64::NAN, 0.0)).is_err());
    assert_eq!(budget.samples().len(), 2);
}

/// Area of the prolate spheroid with equatorial semi-axis `b` and polar semi-axis `c > b`.
fn prolate_area(b: f64, c: f64) -> f64 {
    let e = (1.0 - b * b / (c * c)).sqrt();
    2.0 * PI * b * b * (1.0 + c / (b * e) * e.asin())
}

#[test]
fn area_tracker_follows_a_sphere_stretched_by_uniaxial_extension() {
    // v = (-x/2, -y/2, z): a sphere of radius r0 becomes the spheroid (r0 e^{-t/2}, r0 e^{t}).
    // Every level set of phi is a material surface, so (3.7) tracks the area ratio exactly up to
    // the time step and the differencing of delta and n.
    let g = Grid::<f64>::periodic([32, 32, 40], [-0.5, -0.5, -0.625], [0.5, 0.5, 0.625]).unwrap();
    let r0 = 0.25;
    let eps = 1.0 / 32.0;
    let phi_at = |t: f64| {
        let (b, c) = (r0 * (-0.5 * t).exp(), r0 * t.exp());
        Field::from_cell_fn(&g, move |x| {
            let f = ((x[0] * x[0] + x[1] * x[1]) / (b * b) + x[2] * x[2] / (c * c)).sqrt();
            logistic((1.0 - f) * r0 / eps)
        })
    };
    let v = VectorField::from_fn(&g, |x| [-0.5 * x[0], -0.5 * x[1], x[2]]);
    let (d0, n0) = delta_and_normals(&g, &phi_at(0.0));
    let rate0 = dilation_rate(&g, &d0, &n0, &v).unwrap();
    let mut tracker = AreaTracker::from_delta(&g, &d0).unwrap();
    let (dt, steps) = (0.005, 60);
    for s in 0..steps {
        let (d, nrm) = delta_and_normals(&g, &phi_at(s as f64 * dt));
        tracker.step(&g, &d, &nrm, &v, dt).unwrap();
    }
    let t = tracker.time();
    let exact = prolate_area(r0 * (-0.5 * t).exp(), r0 * t.exp()) / (4.0 * PI * r0 * r0);
    let (d_end, _) = delta_and_normals(&g, &phi_at(t));
    let measured = area_from_delta(&g, &d_end).unwrap() / tracker.initial();
    println!(
        "t = {t}: tracked s/s0 = {:.5}, measured sum delta dV ratio = {measured:.5}, exact {exact:.5}; \
         initial rate / s0 = {:.1e}",
        tracker.relative(),
        rate0 / tracker.initial()
    );
    assert_eq!(tracker.steps(), steps);
    assert!(rate0.abs() < 1e-3 * tracker.initial());
    assert!(((tracker.relative() - 1.0) / (exact - 1.0) - 1.0).abs() < 0.05);
    assert!((tracker.relative() - exact).abs() < 2e-3);
    assert!((measured - exact).abs() < 2e-3);
    assert!(tracker.step(&g, &d_end, &n0, &v, -1.0).is_err());
    assert_eq!(tracker.steps(), steps);
}

#[test]
fn streamwise_profiles_of_couette_and_poiseuille_flows() {
    // Channel: walls at y = 0 (at rest) and y = 1 (moving at U = 2), periodic x and z.
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::Wall { velocity: [2.0, 0.0, 0.0] }];
    let g = Grid::<f64>::new([8, 16, 4], [0.0; 3], [1.0, 1.0, 0.5], bc).unwrap();
    let ys = [0.0, 0.01, 0.25, 0.5, 0.77, 1.0];
    let mut couette = VectorField::from_fn(&g, |x| [2.0 * x[1], 0.0, 0.0]);
    couette.fill_ghosts(&g);
    let p = streamwise_profile(&g, &couette, ProfileAxes::default(), &ys, Span::Average).unwrap();
    for (y, u) in ys.iter().zip(&p) {
        assert!((u - 2.0 * y).abs() < 1e-12, "{y}: {u}");
    }
    // Poiseuille u = 4 y (1 - y) (walls at rest), sampled at one spanwise position: linear
    // interpolation between cell centres is exact to h^2/2 |u''|/4.
    bc[1] = [Boundary::wall(), Boundary::wall()];
    let g = Grid::<f64>::new([8, 16, 4], [0.0; 3], [1.0, 1.0, 0.5], bc).unwrap();
    let mut pois = VectorField::from_fn(&g, |x| [4.0 * x[1] * (1.0 - x[1]) * (1.0 + 0.1 * x[2]), 0.0, 0.0]);
    pois.fill_ghosts(&g);
    let z = 0.3;
    let p = streamwise_profile(&g, &pois, ProfileAxes::default(), &ys, Span::At(z)).unwrap();
    let h = 1.0 / 16.0;
    for (y, u) in ys.iter().zip(&p) {
        let exact = 4.0 * y * (1.0 - y) * (1.0 + 0.1 * z);
        assert!((u - exact).abs() <= h * h * 1.1 + 1e-12, "{y}: {u} vs {exact}");
    }
    assert!(streamwise_profile(&g, &pois, ProfileAxes::default(), &[1.5], Span::Average).is_err());
    let same = ProfileAxes { streamwise: 1, wall_normal: 1 };
    assert!(streamwise_profile(&g, &pois, same, &ys, Span::Average).is_err());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let g = cube(8, 0.0, 1.0);
    let other = cube(10, 0.0, 1.0);
    let small = Field::zeros(&other);
    let phi = Field::from_cell_fn(&g, |x| logistic((0.3 - norm(min_image(x, [0.5; 3], [1.0; 3]))) * 16.0));
    assert!(matches!(volume(&g, &small), Err(Error::InvalidParameter { name: "phi", .. })));
    assert!(centroid(&g, &small).is_err());
    assert!(centroid(&g, &Field::zeros(&g)).is_err());
    assert!(area_from_delta(&g, &small).is_err());
    assert!(surface_modes(&g, &phi, [0.5; 3], 65, ModeWeight::<f64>::Area).is_err());
    assert!(surface_modes(&g, &phi, [f64::NAN; 3], 2, ModeWeight::<f64>::Area).is_err());
    let mut nan = phi.clone();
    nan.values_mut()[g.idx_u(1, 2, 3)] = f64::NAN;
    assert_eq!(volume(&g, &nan), Err(Error::NonFinite { field: "phi", cell: [1, 2, 3] }));
    assert!(matches!(centroid(&g, &nan), Err(Error::NonFinite { .. })));
    let v = VectorField::zeros(&other);
    assert!(kinetic_energy(&g, &v, &Coefficient::Uniform(1.0)).is_err());
    assert!(kinetic_energy(&g, &VectorField::zeros(&g), &Coefficient::Uniform(f64::NAN)).is_err());
    assert!(AreaTracker::new(-1.0).is_err());
    assert!(
        EnergyBudget::new().record(EnergyState { kinetic: f64::INFINITY, ..Default::default() }).is_err()
    );
}
