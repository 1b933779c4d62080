//! The library as a downstream crate uses it, with the public API only: a user's effect and a
//! user's law in a scene, a custom driver through the two-phase step, a membrane law per capsule,
//! observers, and the checks that refuse what a scene cannot mean.

use eulermembrane::grid::{Boundary, Grid, VectorField};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::{NeoHookean, Skalak, SurfaceLaw};
use eulermembrane::simulation::observer::{Checkpoints, Observer, VtkSeries};
use eulermembrane::simulation::{
    Elasticity, Phase, Scene, Simulation, StepReport, StepWarning,
    effect::{Effect, EnergyRole, StepState},
};
use eulermembrane::{Error, Real, Result};

/// A spring tether: a force per unit area `k (anchor - x)` on the membrane of one capsule,
/// spread as `delta f` on the faces of its band (like every surface force, (2.26)).
struct Tether {
    capsule: usize,
    k: f64,
    anchor: [f64; 3],
}

impl Effect<f64> for Tether {
    fn name(&self) -> &str {
        "tether"
    }
    fn describe(&self) -> String {
        format!("tether capsule={} k={:e} anchor={:?}", self.capsule, self.k, self.anchor)
    }
    fn acts_on(&self, c: usize) -> bool {
        c == self.capsule
    }
    fn add_force(
        &self,
        state: &StepState<f64>,
        _: &VectorField<f64>,
        out: &mut VectorField<f64>,
    ) -> Result<()> {
        let g = state.grid;
        let m = state.membrane(self.capsule)?;
        for (&idx, ijk) in m.band.cells().iter().zip(m.band.coords(0)) {
            let [i, j, k] = ijk.map(|x| x as isize);
            for d in 0..3 {
                let x = g.face_center(d, i, j, k);
                out.c[d].values_mut()[idx] += m.delta.values()[idx] * self.k * (self.anchor[d] - x[d]);
            }
        }
        Ok(())
    }
}

/// A user's law: the membrane Mooney-Rivlin law (Barthès-Biesel, Diaz & Dhenin 2002) in the
/// paper's invariants, `W = (G/2)[(1 - psi)(c1 - 2 + 1/c2) + psi((c1 + 1)/c2 + c2 - 3)]`.
struct MooneyRivlin {
    g: f64,
    psi: f64,
}

impl SurfaceLaw<f64> for MooneyRivlin {
    fn name(&self) -> &str {
        "mooney_rivlin"
    }
    fn energy(&self, c1: f64, c2: f64) -> f64 {
        let r = 1.0 / c2;
        0.5 * self.g * ((1.0 - self.psi) * (c1 - 2.0 + r) + self.psi * ((c1 + 1.0) * r + c2 - 3.0))
    }
    fn gradient(&self, c1: f64, c2: f64) -> [f64; 2] {
        let r = 1.0 / c2;
        let h = 0.5 * self.g;
        [
            h * (1.0 - self.psi + self.psi * r),
            h * (-(1.0 - self.psi) * r * r + self.psi * (1.0 - (c1 + 1.0) * r * r)),
        ]
    }
    fn hessian(&self, c1: f64, c2: f64) -> [f64; 3] {
        let r = 1.0 / c2;
        [0.0, -0.5 * self.g * self.psi * r * r, self.g * (1.0 + self.psi * c1) * r * r * r]
    }
}

fn periodic16() -> Grid<f64> {
    Grid::periodic([16; 3], [0.0; 3], [1.0; 3]).unwrap()
}

fn fluid() -> Phase<f64> {
    Phase::new(1.0, 1.0).unwrap()
}

/// (a) A user's effect and a user's law in one scene: the tether pulls the capsule towards its
/// anchor, and its power is counted as work in the energy budget.
#[test]
fn a_user_effect_and_a_user_law_run_in_a_scene() {
    let build = |tether: bool| {
        let mut s = Scene::new(periodic16(), fluid())
            .capsule(Sphere::new([0.5; 3], 0.25).unwrap())
            .elasticity(MooneyRivlin { g: 1.0, psi: 0.3 });
        if tether {
            s = s.effect(Tether { capsule: 0, k: 2.0, anchor: [0.7, 0.5, 0.5] });
        }
        s.build().unwrap()
    };
    let (mut free, mut pulled) = (build(false), build(true));
    assert_eq!(pulled.effects().len(), 2);
    assert_eq!(pulled.effects()[1].energy_role(), EnergyRole::Work);
    let v0 = pulled.volume(0).unwrap();
    let x0 = pulled.centroid(0).unwrap()[0];
    for _ in 0..20 {
        free.step(2e-3).unwrap();
        pulled.step(2e-3).unwrap();
    }
    let (xf, xp) = (free.centroid(0).unwrap()[0], pulled.centroid(0).unwrap()[0]);
    assert!(xp - x0 > 100.0 * (xf - x0).abs(), "the tether pulls towards x = 0.7: {x0} -> {xp}, free {xf}");
    assert!((pulled.volume(0).unwrap() - v0).abs() < 1e-12 * v0);
    // The tether does work on the fluid (it pulls along the motion); elasticity stores energy.
    let e = pulled.energy().unwrap();
    assert!(e.body_power > 0.0, "tether power {}", e.body_power);
    assert!(free.energy().unwrap().body_power == 0.0);
    assert!(pulled.elastic_energy() >= 0.0);
}

/// A custom driver with an adaptive step: prepare, look at the proposal, then commit or discard
/// and retry. Discarding leaves the state bit for bit; prepare + commit is `step`.
#[test]
fn a_custom_driver_uses_the_two_phase_step() {
    let scene = || {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
        let grid = Grid::new([16, 8, 16], [-1.0, -0.5, -1.0], [1.0, 0.5, 1.0], bc).unwrap();
        let mut sim = Scene::new(grid, fluid())
            .capsule(Sphere::new([0.0; 3], 0.35).unwrap())
            .elasticity(NeoHookean::new(4.0).unwrap())
            .build()
            .unwrap();
        sim.set_velocity(|x| [x[2], 0.0, 0.0]).unwrap();
        sim
    };
    let (mut driven, mut plain) = (scene(), scene());
    assert!(driven.commit().is_err(), "nothing prepared yet");
    let snapshot =
        |s: &Simulation<f64>| (s.velocity().c[0].values().to_vec(), s.phi(0).unwrap().values().to_vec());
    let before = snapshot(&driven);
    // A step too large for the driver's Courant limit is discarded and halved.
    let mut dt = 0.4;
    let mut tries = 0;
    let report = loop {
        tries += 1;
        let r = driven.prepare(dt).unwrap();
        assert!(driven.proposed_velocity().is_some() && driven.proposed_phi(0).unwrap().is_some());
        if r.flow.cfl <= 0.1 {
            break driven.commit().unwrap();
        }
        driven.discard();
        assert_eq!(snapshot(&driven), before, "a discarded step leaves the state as it was");
        assert!(driven.proposed_velocity().is_none());
        dt *= 0.5;
    };
    assert!(tries > 1 && report.flow.cfl <= 0.1, "{tries} tries, cfl {}", report.flow.cfl);
    assert!(driven.commit().is_err(), "a step is committed once");
    let r = plain.step(dt).unwrap();
    assert_eq!(r, report);
    assert_eq!(snapshot(&driven), snapshot(&plain), "prepare + commit is step, to the bit");
}

/// A law per capsule: a stiff and a soft capsule side by side in a shear flow; the soft one
/// deforms more. Each capsule carries only the fields its effects need.
#[test]
fn each_capsule_has_its_own_membrane() {
    let mut bc = [[Boundary::Periodic; 2]; 3];
    bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
    let grid = Grid::new([32, 16, 16], [-2.0, -0.5, -1.0], [2.0, 0.5, 1.0], bc).unwrap();
    let mut sim = Scene::new(grid, fluid())
        .capsule(Sphere::new([-1.0, 0.0, 0.0], 0.35).unwrap())
        .capsule(Sphere::new([1.0, 0.0, 0.0], 0.35).unwrap())
        .effect(Elasticity::new(NeoHookean::new(200.0).unwrap()).only([0]))
        .effect(Elasticity::new(Skalak::new(0.2, 2.0).unwrap()).only([1]))
        .build()
        .unwrap();
    assert!(sim.gs(0).unwrap().is_some() && sim.gs(1).unwrap().is_some());
    sim.set_velocity(|x| [x[2], 0.0, 0.0]).unwrap();
    // The deformation from the capsule's spread along x: its second moment over a sphere's.
    let spread = |sim: &Simulation<f64>, c: usize| {
        let g = sim.grid();
        let phi = sim.phi(c).unwrap();
        let x0 = sim.centroid(c).unwrap()[0];
        let (mut m, mut v) = (0.0, 0.0);
        for (i, j, k) in g.cells() {
            let p = phi.values()[g.idx_u(i, j, k)];
            let x = g.cell_center(i as isize, j as isize, k as isize)[0] - x0;
            m += p * x * x;
            v += p;
        }
        m / v
    };
    let (stiff0, soft0) = (spread(&sim, 0), spread(&sim, 1));
    for _ in 0..60 {
        sim.step(5e-3).unwrap();
    }
    let (stiff, soft) = (spread(&sim, 0) / stiff0 - 1.0, spread(&sim, 1) / soft0 - 1.0);
    println!("growth of the spread along x: stiff {stiff:.4e}, soft {soft:.4e}");
    assert!(soft > 2.0 * stiff && soft > 0.0, "soft {soft} stiff {stiff}");

    // A membrane effect on a capsule that does not exist is refused, naming the effect.
    let bad = Scene::new(periodic16(), fluid())
        .capsule(Sphere::new([0.5; 3], 0.25).unwrap())
        .effect(Elasticity::new(NeoHookean::new(1.0).unwrap()).only([1]))
        .build();
    assert!(matches!(bad, Err(Error::InvalidParameter { name: "elasticity", .. })), "{:?}", bad.err());
    // A capsule no effect needs G_s on carries none.
    let sim = Scene::new(periodic16(), fluid())
        .capsule(Sphere::new([0.3, 0.5, 0.5], 0.15).unwrap())
        .capsule(Sphere::new([0.7, 0.5, 0.5], 0.15).unwrap())
        .effect(Elasticity::new(NeoHookean::new(1.0).unwrap()).only([0]))
        .build()
        .unwrap();
    assert!(sim.gs(0).unwrap().is_some() && sim.gs(1).unwrap().is_none());
}

/// Observers: a user's observer sees every step, a VTK series and checkpoints are written, and
/// a checkpoint is restored only into a scene with the same physics.
#[test]
fn observers_watch_a_run_and_checkpoints_record_the_physics() {
    struct Count(usize, Vec<Option<StepWarning>>);
    impl<T: Real> Observer<T> for Count {
        fn observe(&mut self, _: &Simulation<T>, r: &StepReport) -> Result<()> {
            self.0 += 1;
            self.1.push(r.warning);
            Ok(())
        }
    }
    let dir = std::env::temp_dir().join(format!("eulermembrane_observers_{}", std::process::id()));
    let scene = |es: f64| {
        Scene::new(periodic16(), fluid())
            .capsule(Sphere::new([0.5; 3], 0.25).unwrap())
            .elasticity(NeoHookean::new(es).unwrap())
            .build()
            .unwrap()
    };
    let mut sim = scene(1.0);
    let mut count = Count(0, Vec::new());
    let mut vtk = VtkSeries::new(dir.join("vtk"), 2e-3).unwrap();
    let mut ckpt = Checkpoints::new(dir.join("state.ckpt"), 1.0).unwrap();
    let summary = sim.run(4e-3, 1e-3, &mut [&mut count, &mut vtk, &mut ckpt]).unwrap();
    assert_eq!((summary.steps, count.0), (4, 4));
    assert!((summary.time - 4e-3).abs() < 1e-15);
    assert!(count.1.iter().all(|w| w.is_none()), "dt far below the limit: no warning");
    let pvd = std::fs::read_to_string(dir.join("vtk/series.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 3, "t = 0, 2e-3, 4e-3");
    // The final checkpoint restores into the same physics, bit for bit...
    let mut same = scene(1.0);
    same.restore(dir.join("state.ckpt")).unwrap();
    assert_eq!(same.velocity().c[0].values(), sim.velocity().c[0].values());
    // ...and is refused by another capillary number, naming the mismatch.
    let e = scene(2.0).restore(dir.join("state.ckpt"));
    assert!(matches!(e, Err(Error::InvalidParameter { name: "checkpoint physics", .. })), "{e:?}");
    // A step above the membrane's stability limit is taken, and its report says so.
    let mut stiff = scene(1e4);
    let limit = stiff.membrane_dt_limit();
    let r = stiff.step(2.0 * limit).unwrap();
    assert!(matches!(r.warning, Some(StepWarning::DtAboveLimit { limit: l, .. }) if l == limit));
    std::fs::remove_dir_all(&dir).ok();
}

/// What a new user might try and the grid cannot carry: a capsule that overlaps its own periodic
/// image, and a capsule smaller than a cell, are refused by `build`, naming the capsule.
#[test]
fn capsules_the_grid_cannot_carry_are_refused() {
    let g = Grid::<f64>::periodic([16; 3], [0.0; 3], [4.0; 3]).unwrap(); // h = 0.25
    let build = |r: f64| Scene::new(g.clone(), fluid()).capsule(Sphere::new([2.0; 3], r).unwrap()).build();
    for r in [2.5, 0.2] {
        let e = build(r);
        assert!(
            matches!(e, Err(Error::InvalidParameter { name: "capsule", .. })),
            "radius {r}: {:?}",
            e.err()
        );
    }
    assert!(build(1.0).is_ok());
}
