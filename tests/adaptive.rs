//! Adaptive time steps (`simulation::timestep::AdaptiveDt`): the rule's limits, landing on the end time,
//! retries of failed steps, and the velocity-growth warning.

use eulermembrane::grid::{Grid, VectorField};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::observer::Observer;
use eulermembrane::simulation::{
    Phase, Scene, Simulation, StepReport, StepWarning,
    effect::{Effect, StepState},
    timestep::AdaptiveDt,
};
use eulermembrane::{Error, Result};

/// Every report of a run.
#[derive(Default)]
struct Reports(Vec<StepReport>);

impl Observer<f64> for Reports {
    fn observe(&mut self, _: &Simulation<f64>, report: &StepReport) -> Result<()> {
        self.0.push(*report);
        Ok(())
    }
}

/// A capsule in a periodic box, in a slow shear-like flow.
fn capsule(n: usize, es: f64) -> Result<Simulation<f64>> {
    let grid = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3])?;
    let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
        .capsule(Sphere::new([0.5; 3], 0.25)?)
        .elasticity(NeoHookean::new(es)?)
        .build()?;
    let tau = std::f64::consts::TAU;
    sim.set_velocity(|x| [0.5 * (tau * x[2]).sin(), 0.0, 0.0])?;
    Ok(sim)
}

#[test]
fn steps_follow_the_courant_target_and_the_membrane_limit_and_land_on_the_end() {
    let mut sim = capsule(16, 1.0).unwrap();
    let limit = sim.membrane_dt_limit();
    let rate0 = sim.flow().cfl(1.0); // max|v| / h of the initial flow
    let mut stepping = AdaptiveDt::new(1.0).unwrap().cfl(0.2).unwrap();
    let mut reports = Reports::default();
    let until = 0.3;
    let summary = sim.run_with(until, &mut stepping, &mut [&mut reports]).unwrap();
    assert!((summary.time - until).abs() < 1e-12, "ended at {}", summary.time);
    assert_eq!(summary.steps, reports.0.len());
    let mut cfl_bound = 0;
    for (k, r) in reports.0.iter().enumerate() {
        let dt = r.flow.dt;
        assert!(dt <= limit * (1.0 + 1e-12), "step {k}: dt {dt} above the membrane limit {limit}");
        // The rule: dt = min(limit, cfl h / max|v| now, 1.2 dt_last, time left); before the
        // first step, that of the initial flow.
        let (by_cfl, rule, left) = match k {
            0 => (0.2 / rate0, limit.min(0.2 / rate0), until),
            _ => {
                let last = &reports.0[k - 1].flow;
                let by_cfl = 0.2 * last.dt / last.cfl;
                (by_cfl, limit.min(by_cfl).min(1.2 * last.dt), until - last.time)
            }
        };
        assert!(dt <= rule.min(left) * (1.0 + 1e-12), "step {k}: dt {dt} above the rule {rule}");
        assert!(dt >= rule.min(left) * (1.0 - 1e-12), "step {k}: dt {dt} below the rule {rule}");
        cfl_bound += usize::from((dt / by_cfl - 1.0).abs() < 1e-12);
    }
    assert!(cfl_bound > 0, "no step limited by the Courant target");
    assert_eq!(summary.retries, 0);
}

/// An effect that refuses steps above `largest` (a stand-in for a solver that fails).
struct Refuses {
    largest: f64,
}

impl Effect<f64> for Refuses {
    fn name(&self) -> &str {
        "refuses"
    }
    fn prepare(&mut self, _: &StepState<'_, f64>, _: &VectorField<f64>, dt: f64) -> Result<()> {
        if dt > self.largest {
            return Err(Error::NoConvergence {
                solver: "test",
                iterations: 1,
                residual: 1.0,
                tolerance: 0.0,
            });
        }
        Ok(())
    }
    fn add_force(
        &self,
        _: &StepState<'_, f64>,
        _: &VectorField<f64>,
        _: &mut VectorField<f64>,
    ) -> Result<()> {
        Ok(())
    }
}

#[test]
fn a_failed_step_is_retried_smaller_and_counted() {
    let grid = Grid::<f64>::periodic([8; 3], [0.0; 3], [1.0; 3]).unwrap();
    let mut sim = Scene::new(grid, Phase::new(1.0, 1.0).unwrap())
        .capsule(Sphere::new([0.5; 3], 0.3).unwrap())
        .effect(Refuses { largest: 3e-3 })
        .build()
        .unwrap();
    let mut stepping = AdaptiveDt::new(1e-2).unwrap();
    let mut reports = Reports::default();
    let summary = sim.run_with(2e-2, &mut stepping, &mut [&mut reports]).unwrap();
    assert!((summary.time - 2e-2).abs() < 1e-12);
    assert!(reports.0.iter().all(|r| r.flow.dt <= 3e-3));
    // 1e-2 -> 5e-3 -> 2.5e-3 on the first step; later steps grow by 1.2 and fail again above 3e-3.
    assert_eq!(reports.0[0].retries, 2);
    assert!((reports.0[0].flow.dt - 2.5e-3).abs() < 1e-15);
    assert_eq!(summary.retries, stepping.rejected());
    assert!(summary.retries >= 2);

    // Out of retries: the error comes back and the state is that of the last accepted step.
    let (t, steps) = (sim.time(), sim.steps());
    let mut strict = AdaptiveDt::new(1e-2).unwrap().retries(1, 1e-3).unwrap();
    let err = sim.run_with(t + 1e-2, &mut strict, &mut []).unwrap_err();
    assert!(matches!(err, Error::Step { .. }), "{err}");
    assert_eq!((sim.time(), sim.steps()), (t, steps));
}

/// A force `k v` on the fluid: the flow grows like `exp(k t / rho)`.
struct Pump {
    k: f64,
}

impl Effect<f64> for Pump {
    fn name(&self) -> &str {
        "pump"
    }
    fn add_force(
        &self,
        _: &StepState<'_, f64>,
        v: &VectorField<f64>,
        out: &mut VectorField<f64>,
    ) -> Result<()> {
        for d in 0..3 {
            for (o, &x) in out.c[d].values_mut().iter_mut().zip(v.c[d].values()) {
                *o += self.k * x;
            }
        }
        Ok(())
    }
}

#[test]
fn an_accelerating_flow_is_reported_as_velocity_growth() {
    let grid = Grid::<f64>::periodic([8; 3], [0.0; 3], [1.0; 3]).unwrap();
    let mut sim = Scene::new(grid, Phase::new(1.0, 1.0).unwrap())
        .capsule(Sphere::new([0.5; 3], 0.3).unwrap())
        .effect(Pump { k: 200.0 })
        .build()
        .unwrap();
    let tau = std::f64::consts::TAU;
    sim.set_velocity(|x| [1e-3 * (tau * x[1]).sin(), 0.0, 0.0]).unwrap();
    let mut stepping = AdaptiveDt::new(2e-3).unwrap();
    let mut reports = Reports::default();
    sim.run_with(0.05, &mut stepping, &mut [&mut reports]).unwrap();
    let warned = reports.0.iter().find_map(|r| match r.warning {
        Some(StepWarning::VelocityGrowth { factor, steps }) => Some((factor, steps)),
        _ => None,
    });
    let (factor, steps) = warned.expect("no VelocityGrowth warning in an exponentially growing flow");
    assert!(factor > 2.0 && steps <= AdaptiveDt::WINDOW, "{factor} {steps}");
}

#[test]
fn bad_settings_name_the_parameter() {
    let name = |e: Error| match e {
        Error::InvalidParameter { name, .. } => name,
        other => panic!("{other}"),
    };
    assert_eq!(name(AdaptiveDt::new(0.0).unwrap_err()), "max_dt");
    assert_eq!(name(AdaptiveDt::new(1.0).unwrap().cfl(1.5).unwrap_err()), "cfl");
    assert_eq!(name(AdaptiveDt::new(1.0).unwrap().safety(0.0).unwrap_err()), "safety");
    assert_eq!(name(AdaptiveDt::new(1.0).unwrap().growth(0.5).unwrap_err()), "growth");
    assert_eq!(name(AdaptiveDt::new(1.0).unwrap().retries(3, 2.0).unwrap_err()), "min_dt");
    assert_eq!(name(AdaptiveDt::new(1.0).unwrap().velocity_growth(1.0).unwrap_err()), "velocity_growth");
}
