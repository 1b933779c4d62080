//! A decomposed grid's ghost filling against the whole grid's: every stored value of every part
//! (interior and ghosts) after a fill equals the whole grid's value at that cell, bit for bit,
//! for scalars, staggered velocities (walls moving on another axis) and tensors; sums over the
//! parts agree with the whole grid's to round-off and are identical on every part. The parts
//! are threads of this process ([`LocalParts`]); `tests/mpi.rs` runs the same checks on MPI
//! ranks.

mod parts;

use eulermembrane::grid::{Decomposition, Exchange, Grid, LocalParts};
use parts::{LOCATIONS, Whole, cases, check_part, field, flow_on, four_solves, grid, max_difference};
use std::sync::Arc;

/// Runs `check(part grid, whole grid)` on every part of `whole` split by `d`, one thread each.
fn on_parts(whole: &Grid<f64>, d: Decomposition, check: impl Fn(&Grid<f64>) -> Result<(), String> + Sync) {
    let results: Vec<Result<(), String>> = std::thread::scope(|s| {
        let handles: Vec<_> = LocalParts::new(d.parts())
            .into_iter()
            .map(|ex| {
                let check = &check;
                s.spawn(move || {
                    let part =
                        whole.split(d, Arc::new(ex) as Arc<dyn Exchange>).map_err(|e| e.to_string())?;
                    check(&part)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("a part's thread")).collect()
    });
    for (p, r) in results.into_iter().enumerate() {
        if let Err(e) = r {
            panic!("{d:?}, part {p}: {e}");
        }
    }
}

#[test]
fn a_part_fills_its_ghosts_as_the_whole_grid() {
    for (whole, d) in cases(&[1, 2, 3]) {
        let fields = Whole::new(&whole);
        on_parts(&whole, d, |part| check_part(part, &whole, &fields));
    }
}

#[test]
fn sums_over_the_parts_agree_with_the_whole_grid() {
    for (whole, d) in cases(&[1, 2, 3]) {
        let f = field(&whole, 0);
        let total = f.interior_sum(&whole);
        let sums = std::sync::Mutex::new(Vec::new());
        on_parts(&whole, d, |part| {
            let f = field(part, 0);
            let [s, n] = part.sum_over_parts([f.interior_sum(part), part.cell_count() as f64]);
            sums.lock().unwrap().push((s, n));
            Ok(())
        });
        let sums = sums.into_inner().unwrap();
        assert!(sums.iter().all(|x| x.0.to_bits() == sums[0].0.to_bits()), "{d:?}: {sums:?}");
        assert_eq!(sums[0].1, whole.cell_count() as f64);
        assert!((sums[0].0 - total).abs() < 1e-12, "{d:?}: {} against {total}", sums[0].0);
    }
}

#[test]
fn a_part_lies_where_its_cells_lie_in_the_whole_grid() {
    let whole = grid(Some(2));
    on_parts(&whole, Decomposition::slabs(1, 3).unwrap(), |part| {
        let o = part.offset();
        let (a, b) =
            (part.cell_center(0, 0, 0), whole.cell_center(o[0] as isize, o[1] as isize, o[2] as isize));
        let close = a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-14);
        if part.h() != whole.h() || part.global_cells() != whole.n() || !close {
            return Err(format!("part at {o:?}: centre {a:?} against {b:?}"));
        }
        Ok(())
    });
}

#[test]
fn the_direct_solver_on_parts_is_the_whole_grids() {
    for wall in [None, Some(0), Some(1), Some(2)] {
        let whole = grid(wall);
        for location in LOCATIONS {
            let expected = four_solves(&whole, location).unwrap();
            let scale = expected.iter().flat_map(|x| x.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
            for axis in (0..3).filter(|&a| Some(a) != wall) {
                for parts in 1..=3 {
                    on_parts(&whole, Decomposition::slabs(axis, parts).unwrap(), |part| {
                        let got = four_solves(part, location)?;
                        for (m, (g, e)) in got.iter().zip(&expected).enumerate() {
                            let diff = max_difference(part, g, &whole, e);
                            if diff > 1e-13 * scale {
                                return Err(format!("{location:?}, solve {m}: {diff:e} (scale {scale:e})"));
                            }
                        }
                        Ok(())
                    });
                }
            }
        }
    }
}

#[test]
fn the_flow_step_on_parts_is_the_whole_grids() {
    for wall in [None, Some(2), Some(0)] {
        let whole = grid(wall);
        let (v, p) = flow_on(&whole, 6).unwrap();
        let scale = v.c.iter().flat_map(|c| c.values().iter()).fold(0.0f64, |m, x| m.max(x.abs()));
        for axis in (0..3).filter(|&a| Some(a) != wall) {
            for parts in [2, 3] {
                on_parts(&whole, Decomposition::slabs(axis, parts).unwrap(), |part| {
                    let (pv, pp) = flow_on(part, 6)?;
                    for c in 0..3 {
                        let diff = max_difference(part, pv.c[c].values(), &whole, v.c[c].values());
                        if diff > 1e-11 * scale {
                            return Err(format!(
                                "walls {wall:?}: velocity {c} differs by {diff:e} (scale {scale:e})"
                            ));
                        }
                    }
                    let diff = max_difference(part, pp.values(), &whole, p.values());
                    if diff > 1e-9 {
                        return Err(format!("walls {wall:?}: pressure differs by {diff:e}"));
                    }
                    Ok(())
                });
            }
        }
    }
}

#[test]
fn what_is_not_decomposed_refuses_a_part() {
    use eulermembrane::fluid::momentum::Materials;
    use eulermembrane::fluid::stepper::{FlowConfig, FlowStepper, PredictorSolver};
    use eulermembrane::interface::shapes::Sphere;
    use eulermembrane::simulation::{Phase, Scene};
    let whole = grid(Some(2));
    on_parts(&whole, Decomposition::slabs(0, 2).unwrap(), |part| {
        let sor = FlowConfig { predictor: PredictorSolver::Sor(Default::default()), ..FlowConfig::default() };
        let e = FlowStepper::new(part, Materials::uniform(1.0, 1.0).unwrap(), sor)
            .err()
            .ok_or("SOR on a part")?;
        if !e.to_string().contains("SOR") {
            return Err(format!("SOR refused with {e}"));
        }
        let scene = Scene::new(part.clone(), Phase::new(1.0, 1.0).unwrap())
            .capsule(Sphere::new([0.65, -0.4, 1.25], 0.3).unwrap());
        let e = scene.build().err().ok_or("a scene on a part")?;
        if !e.to_string().contains("capsules are not decomposed") {
            return Err(format!("the scene refused with {e}"));
        }
        Ok(())
    });
}
