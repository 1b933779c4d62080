//! Two soft capsules pushed head-on against each other from a gap of one cell: with [`Contact`]
//! the film between their membranes opens and holds while the push goes on; without it the
//! film thins.
//!
//! (At this resolution, five cells per radius, the smoothed membranes themselves resist the
//! draining of a film a few cells thick: the fluid within a membrane's shell carries its force.
//! The film drains slowly, so the test starts in contact range and compares the two runs.)

use eulermembrane::Result;
use eulermembrane::grid::{Grid, VectorField};
use eulermembrane::interface::shapes::Sphere;
use eulermembrane::membrane::law::NeoHookean;
use eulermembrane::simulation::{
    Phase, Scene,
    contact::{Contact, min_gap_cells},
    effect::{Effect, StepState},
};

/// Cells per unit length.
const N: f64 = 16.0;

/// A force density `g` along x (force per unit volume) on the fluid inside capsule `c`,
/// `phi_c g` averaged to the faces: the capsule is driven like a heavy drop.
struct Push {
    c: usize,
    g: f64,
}

impl Effect<f64> for Push {
    fn name(&self) -> &str {
        "push"
    }
    fn add_force(
        &self,
        state: &StepState<f64>,
        _: &VectorField<f64>,
        out: &mut VectorField<f64>,
    ) -> Result<()> {
        let grid = state.grid;
        let phi = state.membrane(self.c)?.phi;
        let sx = grid.strides()[0];
        for (i, j, k) in grid.cells() {
            let idx = grid.idx_u(i, j, k);
            out.c[0].values_mut()[idx] += 0.5 * (phi.values()[idx] + phi.values()[idx - sx]) * self.g;
        }
        Ok(())
    }
}

/// What a run measured: the gap in cells at the start, its smallest value and its value at the
/// end.
struct Run {
    start: f64,
    min: f64,
    end: f64,
}

/// Two capsules of radius 5 cells, one cell apart along x in a periodic box of 40 x 20 x 20
/// cells, pushed together by `g = 20` (each with a force 2.6 = 20 times its volume) for 150
/// steps of `dt = 4e-3`.
fn collide(contact: Option<Contact<f64>>) -> Result<Run> {
    let grid = Grid::<f64>::periodic([40, 20, 20], [0.0; 3], [2.5, 1.25, 1.25])?;
    let (r, gap) = (5.0 / N, 1.0 / N);
    let x = 1.25 - r - 0.5 * gap;
    let g = 20.0;
    let mut scene = Scene::new(grid, Phase::new(1.0, 1.0)?)
        .capsule(Sphere::new([x, 0.625, 0.625], r)?)
        .capsule(Sphere::new([2.5 - x, 0.625, 0.625], r)?)
        .elasticity(NeoHookean::new(2.0)?)
        .effect(Push { c: 0, g })
        .effect(Push { c: 1, g: -g });
    let with = contact.is_some();
    if let Some(c) = contact {
        scene = scene.effect(c);
    }
    let mut sim = scene.build()?;
    let start = min_gap_cells(&sim).unwrap_or(f64::NAN);
    let mut run = Run { start, min: start, end: start };
    for _ in 0..150 {
        sim.step(4e-3)?;
        run.end = min_gap_cells(&sim).unwrap_or(f64::NAN);
        run.min = run.min.min(run.end);
    }
    println!(
        "contact {with}: gap {:.4} at the start, min {:.4}, end {:.4} cells; centroids {:.3} {:.3} cells",
        run.start,
        run.min,
        run.end,
        sim.centroid(0)?[0] * N,
        sim.centroid(1)?[0] * N
    );
    Ok(run)
}

#[test]
fn contact_keeps_colliding_capsules_apart() -> Result<()> {
    let clock = std::time::Instant::now();
    let with = collide(Some(Contact::new(200.0, 2.0)?))?;
    let without = collide(None)?;
    println!("{:.1} s", clock.elapsed().as_secs_f64());
    // Both start at the gap of the shapes (1.055 cells: psi of the cell averages).
    assert!((with.start - 1.0).abs() < 0.1 && with.start == without.start);
    // With contact the gap never falls below where it started and ends wider.
    assert!(with.min >= with.start - 1e-3, "min gap {:.4} < {:.4}", with.min, with.start);
    assert!(with.end > with.start + 0.03, "{:.4}", with.end);
    // Without it the film thins.
    assert!(without.end < without.start - 0.03, "{:.4}", without.end);
    assert!(with.end > without.end + 0.08, "{:.4} against {:.4}", with.end, without.end);
    Ok(())
}
