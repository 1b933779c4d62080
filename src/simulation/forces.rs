//! The forcing and implicit terms a [`Simulation`](super::Simulation) hands to the flow step:
//! sums over the capsules' membrane terms, and the user's surface force `delta f(x, t)`.

use super::capsule::Level;
use super::scene::{SharedLaw, SurfaceForceFn};
use crate::Real;
use crate::fluid::{Forcing, ImplicitTerm};
use crate::grid::{Grid, VectorField};
use crate::membrane::InPlaneImplicit;

/// The sum of several explicit forcings.
pub(crate) struct SumForcing<'a, T: Real>(pub(crate) Vec<&'a dyn Forcing<T>>);

impl<T: Real> Forcing<T> for SumForcing<'_, T> {
    fn is_active(&self) -> bool {
        self.0.iter().any(|f| f.is_active())
    }
    fn add(&self, grid: &Grid<T>, time: T, v: &VectorField<T>, out: &mut VectorField<T>) {
        for f in self.0.iter().filter(|f| f.is_active()) {
            f.add(grid, time, v, out);
        }
    }
}

/// The sum of the capsules' implicit in-plane terms (2.35).
pub(crate) struct SumImplicit<'a, T: Real>(pub(crate) Vec<InPlaneImplicit<'a, T, SharedLaw<T>>>);

impl<T: Real> ImplicitTerm<T> for SumImplicit<'_, T> {
    fn add_apply(&self, grid: &Grid<T>, x: &VectorField<T>, y: &mut VectorField<T>) {
        for t in &self.0 {
            t.add_apply(grid, x, y);
        }
    }
    fn apply_at(&self, grid: &Grid<T>, x: &VectorField<T>, c: usize, idx: usize) -> T {
        self.0.iter().fold(T::zero(), |s, t| s + t.apply_at(grid, x, c, idx))
    }
}

/// The surface force `delta f(x, t)` on the faces around the membrane band of each capsule, with
/// `delta` cut to the band (`delta h >= epsilon`, like every membrane force) and averaged to the
/// faces.
pub(crate) struct SurfaceForcing<'a, T> {
    pub(crate) f: &'a SurfaceForceFn,
    pub(crate) levels: Vec<&'a Level<T>>,
}

impl<T: Real> Forcing<T> for SurfaceForcing<'_, T> {
    fn add(&self, grid: &Grid<T>, time: T, _: &VectorField<T>, out: &mut VectorField<T>) {
        let st = grid.strides();
        let half = T::lit(0.5);
        let t = time.f64();
        for level in &self.levels {
            let band = &level.band;
            let delta = |idx: usize| if band.contains(idx) { level.delta.data[idx] } else { T::zero() };
            for (&idx, ijk) in band.halo(1).iter().zip(band.coords(1)) {
                let [i, j, k] = ijk.map(|x| x as isize);
                for c in 0..3 {
                    if !grid.is_periodic(c) && ijk[c] == 0 {
                        continue;
                    }
                    let d = half * (delta(idx) + delta(idx - st[c]));
                    if d == T::zero() {
                        continue;
                    }
                    let x = grid.face_center(c, i, j, k).map(|x| x.f64());
                    out.c[c].data[idx] += d * T::lit((self.f)(x, t)[c]);
                }
            }
        }
    }
}
