//! A decomposed grid's ghost filling against the whole grid's: every stored value of every part
//! (interior and ghosts) after a fill equals the whole grid's value at that cell, bit for bit,
//! for scalars, staggered velocities (walls moving on another axis) and tensors; sums over the
//! parts agree with the whole grid's to round-off and are identical on every part. The parts
//! are threads of this process ([`LocalParts`]); `tests/mpi.rs` runs the same checks on MPI
//! ranks.

mod parts;

use eulermembrane::grid::{Decomposition, Exchange, Grid, LocalParts};
use parts::{Whole, cases, check_part, field, grid};
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
