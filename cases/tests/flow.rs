//! The flow stepper against analytic solutions at small N (the large runs are the examples
//! `taylor_green`, `channel_flow`, `two_layer_couette`, `solver_compare`).
use eulermembrane::fluid::{
    forcing::Forcing,
    krylov::KrylovParams,
    momentum::{Coefficient, Materials},
    sor::SorParams,
    stepper::{FlowConfig, FlowStepper, PredictorSolver},
};
use eulermembrane::grid::{Boundary, Field, Grid, VectorField, ops::par_interior_update};
use eulermembrane::{Error, Real};
use eulermembrane_cases::flows;

fn order(e1: f64, e2: f64) -> f64 {
    (e1 / e2).log2()
}

#[test]
fn taylor_green_is_second_order_with_krylov_and_sor() {
    for solver in [PredictorSolver::default(), PredictorSolver::Sor(SorParams::default())] {
        let (e16, _) = flows::taylor_green(16, 0.5, solver);
        let (e32, _) = flows::taylor_green(32, 0.5, solver);
        let p = order(e16, e32);
        assert!(p >= 1.9, "order {p} ({e16:.3e} -> {e32:.3e}) with {solver:?}");
        assert!(e32 < 2e-4, "{e32}");
    }
}

#[test]
fn poiseuille_and_couette_reach_the_exact_steady_profiles() {
    let (mu, f) = (1.0, 1.0);
    let mut errs = Vec::new();
    for n in [8usize, 16] {
        let dt = 2.0 / (n * n) as f64;
        let p = flows::poiseuille(n, mu, f, dt, 3.0);
        errs.push(flows::rel_max_err(&p, |y| flows::poiseuille_exact(y, f64::INFINITY, mu, f)));
        let c = flows::couette(n, mu, 1.0, dt, 3.0);
        let ec = flows::rel_max_err(&c, |y| flows::couette_exact(y, f64::INFINITY, mu, 1.0));
        assert!(ec < 1e-6, "couette n={n}: {ec}");
    }
    assert!(errs[1] < 4e-3, "{errs:?}");
    assert!(order(errs[0], errs[1]) > 1.9, "{errs:?}");
}

#[test]
fn start_up_transients_follow_the_series_solutions() {
    let (mu, t) = (1.0, 0.05);
    let p = flows::poiseuille(16, mu, 1.0, 2e-4, t);
    let ep = flows::rel_max_err(&p, |y| flows::poiseuille_exact(y, t, mu, 1.0));
    let c = flows::couette(16, mu, 1.0, 2e-4, t);
    let ec = flows::rel_max_err(&c, |y| flows::couette_exact(y, t, mu, 1.0));
    assert!(ep < 1.2e-2 && ec < 5e-3, "poiseuille {ep:.3e} couette {ec:.3e}");
}

#[test]
fn two_layer_couette_converges_to_the_sharp_interface_profile() {
    let (mu1, mu2, yi) = (5.0, 1.0, 0.5 + 1.0 / 30.0);
    let e: Vec<f64> = [8usize, 16]
        .iter()
        .map(|&n| {
            let prof = flows::two_layer_couette(n, mu1, mu2, yi);
            flows::rel_max_err(&prof, |y| flows::two_layer_exact(y, mu1, mu2, yi))
        })
        .collect();
    assert!(e[1] < 6e-2 && e[1] < e[0], "{e:?}");
}

/// Gravity `rho g` on a stably stratified fluid between walls: the exact solution is rest with
/// a hydrostatic pressure; the variable-density PCG projection must keep it.
struct Gravity {
    rho: Field<f64>,
    g: f64,
}

impl Forcing<f64> for Gravity {
    fn add(
        &self,
        grid: &Grid<f64>,
        _: f64,
        _: &VectorField<f64>,
        out: &mut VectorField<f64>,
    ) -> eulermembrane::Result<()> {
        let sy = grid.strides()[1];
        let rho = self.rho.values();
        par_interior_update(grid, out.c[1].values_mut(), |idx, _, j, _, f| {
            if j == 0 { f } else { f - self.g * 0.5 * (rho[idx] + rho[idx - sy]) }
        });
        Ok(())
    }
}

#[test]
fn variable_density_pcg_keeps_a_hydrostatic_fluid_at_rest() {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::wall()];
    let grid = Grid::new([8, 16, 4], [0.0; 3], [1.0; 3], bc).unwrap();
    let mut rho =
        Field::from_cell_fn(&grid, |x: [f64; 3]| 1.0 + 4.0 * (0.5 - 0.5 * ((x[1] - 0.5) * 10.0).tanh()));
    rho.fill_ghosts(&grid);
    let materials = Materials { rho: Coefficient::Field(rho.clone()), mu: Coefficient::Uniform(0.1) };
    let config =
        FlowConfig { poisson: KrylovParams { tolerance: 1e-12, max_iterations: 200 }, ..Default::default() };
    let mut s = FlowStepper::new(&grid, materials, config).unwrap();
    let gravity = Gravity { rho, g: 9.81 };
    let mut pcg_iters = 0;
    for _ in 0..5 {
        pcg_iters = s.step(0.01, &gravity, None).unwrap().poisson_iterations;
    }
    assert!(pcg_iters > 0);
    let vmax = (0..3)
        .flat_map(|d| grid.cells().map(move |(i, j, k)| (d, i, j, k)))
        .map(|(d, i, j, k)| s.velocity().c[d].values()[grid.idx_u(i, j, k)].abs())
        .fold(0.0, f64::max);
    assert!(vmax < 1e-9, "spurious velocity {vmax:e}");
}

#[test]
fn a_failed_step_leaves_the_state_untouched() {
    let grid = Grid::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
    let krylov = KrylovParams { tolerance: 1e-14, max_iterations: 1 };
    let config = FlowConfig { predictor: PredictorSolver::Krylov(krylov), ..Default::default() };
    let mu = Field::from_cell_fn(&grid, |x: [f64; 3]| 10.0 + 40.0 * (6.0 * x[0]).sin().powi(2));
    let materials = Materials { rho: Coefficient::Uniform(1.0), mu: Coefficient::Field(mu) };
    let mut s = FlowStepper::new(&grid, materials, config).unwrap();
    s.set_velocity(|x: [f64; 3]| [(6.0 * x[1]).sin(), (6.0 * x[2]).sin(), (6.0 * x[0]).sin()]).unwrap();
    let before = s.velocity().clone();
    let err = s.step(0.1, &(), None).unwrap_err();
    assert!(matches!(err, Error::NoConvergence { solver: "BiCGStab", .. }), "{err}");
    assert_eq!(s.velocity(), &before);
    assert_eq!(s.steps(), 0);
    assert_eq!(s.time(), 0.0);
}

#[test]
fn bad_input_is_refused_with_named_parameters() {
    let grid = Grid::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
    let msg = |e: Error| e.to_string();
    assert!(msg(Materials::uniform(1.0, -1.0).unwrap_err()).contains("mu"));
    assert!(msg(Materials::uniform(0.0, 1.0).unwrap_err()).contains("rho"));
    let mut s =
        FlowStepper::new(&grid, Materials::uniform(1.0, 1.0).unwrap(), FlowConfig::default()).unwrap();
    assert!(msg(s.step(-0.1, &(), None).unwrap_err()).contains("dt"));
    assert!(msg(s.step(f64::NAN, &(), None).unwrap_err()).contains("dt"));
    let bad_sor = FlowConfig {
        predictor: PredictorSolver::Sor(SorParams { omega: 2.5, ..Default::default() }),
        ..Default::default()
    };
    assert!(
        msg(FlowStepper::new(&grid, Materials::uniform(1.0, 1.0).unwrap(), bad_sor).err().unwrap())
            .contains("omega")
    );
    assert!(s.set_velocity(|_| [f64::NAN, 0.0, 0.0]).is_err());
    // Two wall axes: the direct pressure solver cannot handle it.
    let mut bc = [[Boundary::wall(); 2]; 3];
    bc[0] = [Boundary::Periodic; 2];
    let g2 = Grid::new([8, 8, 8], [0.0; 3], [1.0; 3], bc).unwrap();
    let e =
        FlowStepper::new(&g2, Materials::uniform(1.0, 1.0).unwrap(), FlowConfig::default()).err().unwrap();
    assert!(matches!(e, Error::Unsupported { .. }), "{e}");
    let mut bad = Materials::uniform(1.0, 1.0).unwrap();
    bad.mu = Coefficient::Field(Field::from_cell_fn(&grid, |x| x[0] - 0.5));
    assert!(msg(s.set_materials(bad).unwrap_err()).contains("mu"));
}

fn taylor_green_f32(n: usize) -> f64 {
    let l = 2.0 * std::f32::consts::PI;
    let h = l / n as f32;
    let grid = Grid::<f32>::periodic([n, n, 1], [0.0; 3], [l, l, h]).unwrap();
    let mut s =
        FlowStepper::new(&grid, Materials::uniform(1.0f32, 0.1).unwrap(), FlowConfig::default()).unwrap();
    let e = |t: f32| (-0.2 * t).exp();
    s.set_velocity(|x| [x[0].sin() * x[1].cos(), -x[0].cos() * x[1].sin(), 0.0]).unwrap();
    let dt = 0.25 * h;
    let steps = (0.5 / dt).round() as usize;
    for _ in 0..steps {
        s.step(dt, &(), None).unwrap();
    }
    let t = steps as f32 * dt;
    grid.cells()
        .map(|(i, j, k)| {
            let x = grid.face_center(0, i as isize, j as isize, k as isize);
            (s.velocity().c[0].values()[grid.idx_u(i, j, k)] - x[0].sin() * x[1].cos() * e(t)).abs().f64()
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_stepper_runs_in_f32() {
    let e = taylor_green_f32(32);
    assert!(e < 5e-3, "{e}");
}

#[test]
fn a_restarted_run_is_bit_for_bit_identical() {
    use eulermembrane::io::checkpoint::{CheckpointReader, CheckpointWriter};
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[1] = [Boundary::wall(), Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
    let grid = Grid::new([8, 8, 4], [0.0; 3], [1.0; 3], bc).unwrap();
    let mu = Field::from_cell_fn(&grid, |x: [f64; 3]| 0.1 + 0.05 * (6.0 * x[1]).sin().powi(2));
    let materials = Materials { rho: Coefficient::Uniform(1.0), mu: Coefficient::Field(mu) };
    let make = || FlowStepper::new(&grid, materials.clone(), FlowConfig::default()).unwrap();
    let force = eulermembrane::fluid::forcing::BodyForce::new([0.5, 0.0, 0.1]).unwrap();
    let mut a = make();
    a.set_velocity(|x| [0.0, 0.1 * (6.0 * x[0]).sin(), 0.0]).unwrap();
    for _ in 0..4 {
        a.step(0.01, &force, None).unwrap();
    }
    let path = std::env::temp_dir().join(format!("em_restart_{}.ckpt", std::process::id()));
    let mut w = CheckpointWriter::new();
    a.checkpoint(&mut w, "flow.");
    w.save(&path).unwrap();
    for _ in 0..4 {
        a.step(0.01, &force, None).unwrap();
    }
    let mut b = make();
    b.restore(&CheckpointReader::open(&path).unwrap(), "flow.").unwrap();
    std::fs::remove_file(&path).unwrap();
    for _ in 0..4 {
        b.step(0.01, &force, None).unwrap();
    }
    assert_eq!(a.steps(), b.steps());
    assert_eq!(a.time().to_bits(), b.time().to_bits());
    for d in 0..3 {
        assert!(
            a.velocity().c[d]
                .values()
                .iter()
                .zip(b.velocity().c[d].values())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        );
    }
    assert!(a.pressure().values().iter().zip(b.pressure().values()).all(|(x, y)| x.to_bits() == y.to_bits()));
}
