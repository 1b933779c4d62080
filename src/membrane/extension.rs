//! The sharp membrane velocity: every point of the smoothed shell moves with the fluid velocity
//! at the closest point of the surface `phi = 1/2`, and the membrane force acts there.
//!
//! # Why
//!
//! In the paper's coupling the membrane is a shell a few cells thick: each layer of the shell
//! carries its own `G_s` with the fluid velocity at that layer, and the force `∇·(δ τ)` acts
//! across the shell. A tank-treading membrane shears its shell (the velocity's kink across a
//! sharp membrane, `[μ ∂v/∂n] = −f_t`, is spread over the shell), the layers take different
//! deformation histories, and the capsule responds as if its membrane were softer than it is
//! (docs/validation/shear_capsule.md). A sharp membrane has one velocity per surface point.
//!
//! # The map
//!
//! [`SurfaceExtension`] is the linear map `M` from the fluid velocity `v` (staggered) to the
//! membrane velocity `u = M v` (staggered, on the same faces). On the faces around the band
//!
//! ```text
//! u(x_f) = v(x_f) + P(x_f) (v(x_Γ) − v(x_f)),     x_Γ = x_f − s n,   s = ψ h / β,
//! ```
//!
//! component by component (`v` of another component than the face's, and `v(x_Γ)`, by trilinear
//! interpolation on that component's faces): the tangential part of the velocity is the one at
//! the closest surface point `x_Γ`, the normal part the local one. `s` is the signed distance of
//! the MTHINC profile `φ = (1 + tanh(β s / h)) / 2` (`ψ = atanh(2 φ − 1)`, positive inside) and
//! `n` the unit normal pointing into the capsule (both averaged from the two cells of the face).
//! Elsewhere `u = v`. Every layer of the shell then slides with the surface, so that it is
//! sheared and strained as the surface is.
//!
//! Only the tangential part is taken from the surface: it is the part with the kink (the normal
//! velocity is smooth across a membrane), and a map that takes the normal part from the surface
//! too leaves grid-scale normal wrinkles of `φ`, which `v` carries, unseen by the membrane: in
//! shear at 4 cells per radius they grew until the surface area was 14 % above the smooth
//! shape's by `t` = 6.
//!
//! The membrane force on the fluid is the transpose: a force `F` that does work on `u` acts on
//! the fluid as `Mᵀ F` (each face's tangential force spread around its closest point with the
//! same weights). So `Σ (Mᵀ F)·v = Σ F·u`: the force's power on the fluid is the stress power on
//! the membrane's own velocity, the identity the smoothed coupling keeps with `M = I`. The
//! quasi-implicit operator `D_hᵀ K D_h` of (2.35) becomes `Mᵀ D_hᵀ K D_h M`, still symmetric
//! positive semi-definite. `phi` keeps its volume-conserving transport with `v`.
//!
//! The trilinear interpolation at `x_Γ` rounds off the kink of the tangential velocity over
//! about two cells: under a tangential surface force the membrane moves at 0.74 / 0.86 of the
//! Stokes speed at 4 / 8 cells per radius. A read that is exact across the kink (extrapolated
//! from both sides) reaches 0.93 / 0.97 but makes capsules in shear worse, so the map keeps the
//! trilinear read (docs/validation/surface_mobility.md).
//!
//! # The outer layers
//!
//! Sliding with the surface is not enough for the layers far from it: where the shell's inner
//! layers reach the medial axis of a thin part they are crushed. A map built
//! [`with_outer_layers`](SurfaceExtension::with_outer_layers) also carries the
//! [`OuterLayers`] of the shell: their `G_s` is the surface's, and their stress acts on the
//! core (`Traction::SharpResampled`).
//!
//! Not in the paper: an immersed-boundary-like interpolation and spreading at the closest
//! points, without markers (every shell cell is its own sample of the surface).

use super::band::{Band, band_spacing};
use super::outer_layers::OuterLayers;
use crate::grid::{Field, GHOST, Grid, VectorField};
use crate::interface::geometry::psi_of;
use crate::{Error, Real, Result};
use rayon::prelude::*;
use std::sync::Mutex;

/// Faces per rayon task.
const MIN_FACES_PER_TASK: usize = 256;

/// A point as a cell of the cell-centred lattice and its offset in it: `x = lower + (base + t +
/// 1/2) h` per axis, `0 <= t < 1` (so that the stencils of all three components follow without
/// a floor).
#[derive(Debug, Clone, Copy)]
pub(super) struct Point<T> {
    base: [isize; 3],
    t: [T; 3],
}

impl<T: Real> Point<T> {
    pub(super) fn new(grid: &Grid<T>, x: &[T; 3]) -> Option<Self> {
        let (h, lower) = (grid.h(), grid.lower());
        let mut p = Point { base: [0; 3], t: [T::zero(); 3] };
        for a in 0..3 {
            let xi = (x[a] - lower[a]) / h[a] - T::lit(0.5);
            let fl = xi.floor();
            p.base[a] = fl.to_isize()?;
            p.t[a] = xi - fl;
        }
        Some(p)
    }
}

/// One face of the map: `u_c = v_c(x_Γ) − n_c n·(v(x_Γ) − v(x_f))` (component `c` of the
/// face's list).
#[derive(Debug, Clone, Copy)]
struct Row<T> {
    /// The face: the interior storage index of its cell (the face is the cell's lower face).
    face: usize,
    /// The face's position `x_f`.
    at: Point<T>,
    /// Its closest surface point `x_Γ`.
    surface: Point<T>,
    /// The unit normal (into the capsule); zero where none is defined (then `u = v`).
    n: [T; 3],
}

/// The map `u = M v` from the fluid velocity to the membrane velocity (see the
/// [module docs](self)), rebuilt from `phi` and the normals whenever the band is.
pub struct SurfaceExtension<T> {
    grid: Grid<T>,
    beta: T,
    /// Per component: one row per cell of `halo(2)`, for the cell's lower face.
    rows: [Vec<Row<T>>; 3],
    /// `(face, ghost)` pairs: the periodic ghost images of the faces (of the same cells, so
    /// the same storage indices, for every component).
    images: Vec<(usize, usize)>,
    generation: u64,
    scratch: Mutex<Scratch<T>>,
    /// The shell's outer layers, where asked for.
    layers: Option<OuterLayers<T>>,
}

impl<T> std::fmt::Debug for SurfaceExtension<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceExtension")
            .field("faces", &self.rows.each_ref().map(Vec::len))
            .field("generation", &self.generation)
            .finish()
    }
}

/// The membrane velocity and the force on it, on the faces of the map, and the values of one
/// component of `u` before they are written.
struct Scratch<T> {
    u: VectorField<T>,
    f: VectorField<T>,
    values: Vec<T>,
}

impl<T: Real> SurfaceExtension<T> {
    /// An empty map for `grid` with the profile sharpness `beta` (`beta' = beta / h`, (2.42)).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `beta` unless it is finite and `> 0`.
    pub fn new(grid: &Grid<T>, beta: T) -> Result<Self> {
        crate::error::positive("beta", beta)?;
        Ok(SurfaceExtension {
            grid: grid.clone(),
            beta,
            rows: Default::default(),
            images: Vec::new(),
            generation: 0,
            scratch: Mutex::new(Scratch {
                u: VectorField::zeros(grid),
                f: VectorField::zeros(grid),
                values: Vec::new(),
            }),
            layers: None,
        })
    }

    /// The same map, also carrying the shell's [`OuterLayers`], rebuilt with it.
    pub fn with_outer_layers(mut self) -> Self {
        // `beta` was checked by `new`.
        self.layers = OuterLayers::new(&self.grid, self.beta).ok();
        self
    }

    /// The shell's outer layers, if the map carries them
    /// ([`with_outer_layers`](Self::with_outer_layers)).
    pub fn outer_layers(&self) -> Option<&OuterLayers<T>> {
        self.layers.as_ref()
    }

    /// Rebuilds the map on the faces of `band.halo(2)` (every face the in-plane force and the
    /// `G_s` transport read) from `phi` and the unit normals `normal` (into the capsule; both
    /// at cell centres, ghosts filled).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `grid` for a band or field of another grid.
    pub fn rebuild(&mut self, band: &Band<T>, phi: &Field<T>, normal: &[Field<T>; 3]) -> Result<()> {
        let grid = &self.grid;
        band.matches(grid)?;
        if phi.data.len() != grid.len() || normal.iter().any(|f| f.data.len() != grid.len()) {
            return Err(Error::invalid("grid", "a field of another grid", "a field of the band's grid"));
        }
        let st = grid.strides();
        let scale = band_spacing(grid) / self.beta;
        let half = T::lit(0.5);
        let cells = band.halo(2);
        let coords = band.coords(2);
        let origin = Point { base: [0; 3], t: [T::zero(); 3] };
        let zero = Row { face: 0, at: origin, surface: origin, n: [T::zero(); 3] };
        for c in 0..3 {
            let sc = st[c];
            let rows = &mut self.rows[c];
            rows.resize(cells.len(), zero);
            rows.par_iter_mut()
                .zip(cells.par_iter().zip(coords.par_iter()))
                .with_min_len(MIN_FACES_PER_TASK)
                .for_each(|(row, (&m, ijk))| {
                    *row = Row { face: m, ..zero };
                    let ijk = ijk.map(|x| x as isize);
                    let x = grid.face_center(c, ijk[0], ijk[1], ijk[2]);
                    let (a, b) = (m, m - sc);
                    let nf: [T; 3] = std::array::from_fn(|d| normal[d].data[a] + normal[d].data[b]);
                    let len = (nf[0] * nf[0] + nf[1] * nf[1] + nf[2] * nf[2]).sqrt();
                    // No normal (or a NaN one): the face keeps u = v.
                    if len.is_nan() || len <= T::lit(1e-6) {
                        return;
                    }
                    let n = nf.map(|x| x / len);
                    let s = half * (psi_of(phi.data[a]) + psi_of(phi.data[b])) * scale;
                    let xg: [T; 3] = std::array::from_fn(|d| x[d] - s * n[d]);
                    let (Some(at), Some(surface)) = (Point::new(grid, &x), Point::new(grid, &xg)) else {
                        return;
                    };
                    if velocity_stencils(grid, &surface).is_some() && velocity_stencils(grid, &at).is_some() {
                        *row = Row { face: m, at, surface, n };
                    }
                });
        }
        self.images.clear();
        for (&m, ijk) in cells.iter().zip(coords) {
            push_images(grid, ijk.map(|x| x as isize), m, &mut self.images);
        }
        if let Some(layers) = self.layers.as_mut() {
            layers.rebuild(band, phi, normal)?;
        }
        self.generation = band.generation();
        Ok(())
    }

    /// The band generation of the last [`rebuild`](Self::rebuild) (0 before the first).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Writes `u = M v` on the faces of the map (and their periodic ghost images); other
    /// entries of `u` are not touched.
    pub fn extend(&self, v: &VectorField<T>, u: &mut VectorField<T>) {
        let mut values = Vec::new();
        self.extend_into(v, u, &mut values);
    }

    /// [`extend`](Self::extend) with `values` as scratch.
    fn extend_into(&self, v: &VectorField<T>, u: &mut VectorField<T>, values: &mut Vec<T>) {
        let grid = &self.grid;
        for c in 0..3 {
            let rows = &self.rows[c];
            values.resize(rows.len(), T::zero());
            values.par_iter_mut().zip(rows.par_iter()).with_min_len(MIN_FACES_PER_TASK).for_each(|(x, r)| {
                *x = row_value(grid, v, c, r);
            });
            let uc = &mut u.c[c].data;
            for (r, &x) in rows.iter().zip(values.iter()) {
                uc[r.face] = x;
            }
            for &(f, g) in &self.images {
                uc[g] = uc[f];
            }
        }
    }

    /// `out += Mᵀ f` for a force `f` that is zero off the faces of the map.
    pub fn spread_add(&self, f: &VectorField<T>, out: &mut VectorField<T>) {
        let grid = &self.grid;
        for c in 0..3 {
            for r in &self.rows[c] {
                let x = f.c[c].data[r.face];
                if x != T::zero() {
                    spread_row(grid, c, r, x, out);
                }
            }
        }
    }

    /// Adds to `out` the force `Mᵀ F` where `F = force(u)` is a force on the membrane velocity
    /// `u = M v` (`force` adds `F` to the zeroed field it receives, on the faces of the map only,
    /// reading `u` there and at their periodic images).
    ///
    /// # Errors
    /// Those of `force`; then `out` is unchanged.
    pub fn pull_back(
        &self,
        v: &VectorField<T>,
        out: &mut VectorField<T>,
        force: impl FnOnce(&VectorField<T>, &mut VectorField<T>) -> Result<()>,
    ) -> Result<()> {
        let mut guard = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        let Scratch { u, f, values } = &mut *guard;
        self.extend_into(v, u, values);
        self.spread_into(f, out, |f| force(u, f))
    }

    /// Adds to `out` the force `Mᵀ F` of a force `F = force()` that does not depend on the
    /// velocity (a prescribed load; `force` adds `F` to the zeroed field it receives, on the
    /// faces of the map only).
    ///
    /// # Errors
    /// Those of `force`; then `out` is unchanged.
    pub fn spread(
        &self,
        out: &mut VectorField<T>,
        force: impl FnOnce(&mut VectorField<T>) -> Result<()>,
    ) -> Result<()> {
        let mut guard = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        self.spread_into(&mut guard.f, out, force)
    }

    /// Zeroes `f` on the faces of the map, lets `force` add to it, and adds `Mᵀ f` to `out`.
    fn spread_into(
        &self,
        f: &mut VectorField<T>,
        out: &mut VectorField<T>,
        force: impl FnOnce(&mut VectorField<T>) -> Result<()>,
    ) -> Result<()> {
        for c in 0..3 {
            for r in &self.rows[c] {
                f.c[c].data[r.face] = T::zero();
            }
        }
        force(f)?;
        self.spread_add(f, out);
        Ok(())
    }

    /// Runs `with(u_a, u_b)` on the membrane velocities `u_a = M a` and `u_b = M b` (e.g. the
    /// fluid velocities at two time levels, for the `G_s` transport), written on the faces of
    /// the map only.
    pub fn with_extended<R>(
        &self,
        a: &VectorField<T>,
        b: &VectorField<T>,
        with: impl FnOnce(&VectorField<T>, &VectorField<T>) -> R,
    ) -> R {
        let mut guard = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        let Scratch { u, f, values } = &mut *guard;
        self.extend_into(a, u, values);
        self.extend_into(b, f, values);
        with(u, f)
    }
}

/// `v_c(x_Γ) − n_c n·(v(x_Γ) − v(x_f))` of one row (`v_c(x_f)` without a normal).
#[inline]
fn row_value<T: Real>(grid: &Grid<T>, v: &VectorField<T>, c: usize, r: &Row<T>) -> T {
    if r.n == [T::zero(); 3] {
        return v.c[c].data[r.face];
    }
    // A row with a normal has every stencil in range (see `rebuild`).
    let (Some(at_surface), Some(at_face)) =
        (velocity_stencils(grid, &r.surface), velocity_stencils(grid, &r.at))
    else {
        return T::zero();
    };
    let interp =
        |d: usize, s: &[(usize, T); 8]| s.iter().fold(T::zero(), |acc, &(i, w)| acc + w * v.c[d].data[i]);
    let surface: [T; 3] = std::array::from_fn(|d| interp(d, &at_surface[d]));
    let mut jump = T::zero();
    for d in 0..3 {
        // v_c at its own face is the stored value.
        let here = if d == c { v.c[c].data[r.face] } else { interp(d, &at_face[d]) };
        jump += r.n[d] * (surface[d] - here);
    }
    surface[c] - r.n[c] * jump
}

/// `out += x Mᵀ e_row`: the transpose of [`row_value`] for a force `x` on the row's face.
#[inline]
fn spread_row<T: Real>(grid: &Grid<T>, c: usize, r: &Row<T>, x: T, out: &mut VectorField<T>) {
    if r.n == [T::zero(); 3] {
        out.c[c].data[r.face] += x;
        return;
    }
    // A row with a normal has every stencil in range (see `rebuild`).
    let (Some(at_surface), Some(at_face)) =
        (velocity_stencils(grid, &r.surface), velocity_stencils(grid, &r.at))
    else {
        return;
    };
    for d in 0..3 {
        let to_surface = if d == c { T::one() } else { T::zero() } - r.n[c] * r.n[d];
        let to_face = r.n[c] * r.n[d];
        for &(i, wi) in &at_surface[d] {
            out.c[d].data[i] += x * to_surface * wi;
        }
        if d == c {
            out.c[c].data[r.face] += x * to_face;
        } else {
            for &(i, wi) in &at_face[d] {
                out.c[d].data[i] += x * to_face * wi;
            }
        }
    }
}

/// The storage offsets and weights of the two lattice planes around `p` along axis `a`, for
/// values staggered half a cell lower along `a` (`staggered`: a velocity component `a`) or
/// cell-centred (periodic axes wrapped to the interior; `None` if a wall axis would leave the
/// stored range).
#[inline]
fn planes<T: Real>(grid: &Grid<T>, p: &Point<T>, a: usize, staggered: bool) -> Option<([usize; 2], [T; 2])> {
    let na = grid.n()[a] as isize;
    let sa = grid.strides()[a];
    let g = GHOST as isize;
    if na == 1 {
        // A flat axis: one layer, no interpolation.
        return Some(([g as usize * sa; 2], [T::one(), T::zero()]));
    }
    let half = T::lit(0.5);
    let (i0, t) = match (staggered, p.t[a] < half) {
        (false, _) => (p.base[a], p.t[a]),
        (true, true) => (p.base[a], p.t[a] + half),
        (true, false) => (p.base[a] + 1, p.t[a] - half),
    };
    let periodic = grid.is_periodic(a);
    let wrap = |i: isize| -> Option<usize> {
        let (i, ok) = match periodic {
            true => {
                let i = if i < 0 {
                    i + na
                } else if i >= na {
                    i - na
                } else {
                    i
                };
                (i, (0..na).contains(&i))
            }
            false => (i, (-g..na + g).contains(&i)),
        };
        ok.then_some((i + g) as usize * sa)
    };
    Some(([wrap(i0)?, wrap(i0 + 1)?], [T::one() - t, t]))
}

/// The trilinear stencil of the planes `axes` (one pair per axis, from [`planes`]).
#[inline]
fn stencil<T: Real>(axes: [([usize; 2], [T; 2]); 3]) -> [(usize, T); 8] {
    let [(o0, w0), (o1, w1), (o2, w2)] = axes;
    std::array::from_fn(|k| {
        let (i, j, l) = (k & 1, (k >> 1) & 1, (k >> 2) & 1);
        (o0[i] + o1[j] + o2[l], w0[i] * w1[j] * w2[l])
    })
}

/// The trilinear stencil at the point `p` of the values of velocity component `d` (`Some`) or
/// of cell-centred values (`None`) (periodic axes wrapped to the interior; `None` if a wall
/// axis would leave the stored range).
#[inline]
pub(super) fn trilinear<T: Real>(grid: &Grid<T>, d: Option<usize>, p: &Point<T>) -> Option<[(usize, T); 8]> {
    Some(stencil([
        planes(grid, p, 0, d == Some(0))?,
        planes(grid, p, 1, d == Some(1))?,
        planes(grid, p, 2, d == Some(2))?,
    ]))
}

/// The trilinear stencils at the point `p` of the three velocity components, from the planes
/// of each axis computed once (cell-centred and staggered); `None` as [`trilinear`].
#[inline]
fn velocity_stencils<T: Real>(grid: &Grid<T>, p: &Point<T>) -> Option<[[(usize, T); 8]; 3]> {
    let centred = [planes(grid, p, 0, false)?, planes(grid, p, 1, false)?, planes(grid, p, 2, false)?];
    let staggered = [planes(grid, p, 0, true)?, planes(grid, p, 1, true)?, planes(grid, p, 2, true)?];
    Some(std::array::from_fn(|d| {
        stencil(std::array::from_fn(|a| if a == d { staggered[a] } else { centred[a] }))
    }))
}

/// Appends the periodic ghost images `(m, ghost)` of the face of the cell with interior
/// coordinates `ijk` (storage index `m`).
fn push_images<T: Real>(grid: &Grid<T>, ijk: [isize; 3], m: usize, images: &mut Vec<(usize, usize)>) {
    let n = grid.n();
    let g = GHOST as isize;
    let shifts = |d: usize| -> [Option<isize>; 3] {
        let nd = n[d] as isize;
        if !grid.is_periodic(d) {
            return [Some(0), None, None];
        }
        let up = (ijk[d] < g).then_some(nd);
        let down = (ijk[d] >= nd - g).then_some(-nd);
        [Some(0), up, down]
    };
    let (sx, sy, sz) = (shifts(0), shifts(1), shifts(2));
    for dx in sx.iter().flatten() {
        for dy in sy.iter().flatten() {
            for dz in sz.iter().flatten() {
                if (*dx, *dy, *dz) != (0, 0, 0) {
                    images.push((m, grid.idx(ijk[0] + dx, ijk[1] + dy, ijk[2] + dz)));
                }
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A sphere of radius 0.2 at the centre of a periodic unit box of `n^3` cells: the MTHINC
    /// profile `phi`, its inward normals, and the band of `delta = |grad phi|`.
    pub(in crate::membrane) fn sphere(n: usize) -> (Grid<f64>, Field<f64>, [Field<f64>; 3], Band<f64>) {
        let g = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
        let h = 1.0 / n as f64;
        let dist =
            |x: [f64; 3]| 0.2 - ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
        let mut phi = Field::from_cell_fn(&g, |x| 0.5 * (1.0 + (dist(x) / h).tanh()));
        let mut delta = Field::from_cell_fn(&g, |x| 0.5 / h / (dist(x) / h).cosh().powi(2));
        let mut normal: [Field<f64>; 3] = std::array::from_fn(|d| {
            Field::from_cell_fn(&g, |x| {
                let r = ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
                -(x[d] - 0.5) / r
            })
        });
        phi.fill_ghosts(&g);
        delta.fill_ghosts(&g);
        for f in normal.iter_mut() {
            f.fill_ghosts(&g);
        }
        let mut band = Band::new(&g, 0.01).unwrap();
        band.rebuild(&g, &delta).unwrap();
        (g, phi, normal, band)
    }

    fn map(n: usize) -> (Grid<f64>, SurfaceExtension<f64>) {
        let (g, phi, normal, band) = sphere(n);
        let mut m = SurfaceExtension::new(&g, 1.0).unwrap();
        m.rebuild(&band, &phi, &normal).unwrap();
        assert_eq!(m.generation(), band.generation());
        assert!(m.rows.iter().all(|r| r.len() > 1000));
        (g, m)
    }

    /// A reproducible pseudo-random number in [-1, 1).
    pub(in crate::membrane) fn noise(k: usize) -> f64 {
        let x = (k as u64).wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn spreading_is_the_transpose_of_the_extension() {
        let (g, m) = map(32);
        let mut v = VectorField::zeros(&g);
        for (c, f) in v.c.iter_mut().enumerate() {
            for (i, x) in f.data.iter_mut().enumerate() {
                *x = noise(3 * i + c);
            }
        }
        let mut force = VectorField::zeros(&g);
        for c in 0..3 {
            for (k, r) in m.rows[c].iter().enumerate() {
                force.c[c].data[r.face] = noise(7 * k + c + 11);
            }
        }
        let mut u = VectorField::zeros(&g);
        m.extend(&v, &mut u);
        let mut spread = VectorField::zeros(&g);
        m.spread_add(&force, &mut spread);
        let lhs: f64 = (0..3)
            .map(|c| m.rows[c].iter().map(|r| force.c[c].data[r.face] * u.c[c].data[r.face]).sum::<f64>())
            .sum();
        let rhs: f64 =
            (0..3).map(|c| spread.c[c].data.iter().zip(&v.c[c].data).map(|(a, b)| a * b).sum::<f64>()).sum();
        assert!((lhs - rhs).abs() <= 1e-12 * lhs.abs().max(1.0), "{lhs} vs {rhs}");
    }

    #[test]
    fn linear_velocities_keep_their_normal_part_and_take_the_surface_tangential_part() {
        let (g, m) = map(32);
        let a = [[0.3, -1.1, 0.4], [0.7, 0.2, -0.5], [-0.6, 0.9, 0.1]];
        let b = [0.2, -0.4, 0.8];
        let lin = |x: [f64; 3], c: usize| b[c] + (0..3).map(|d| a[c][d] * x[d]).sum::<f64>();
        let mut v = VectorField::zeros(&g);
        let n = g.n()[0] as isize;
        for c in 0..3 {
            for k in -3..n + 3 {
                for j in -3..n + 3 {
                    for i in -3..n + 3 {
                        v.c[c].data[g.idx(i, j, k)] = lin(g.face_center(c, i, j, k), c);
                    }
                }
            }
        }
        let mut u = VectorField::zeros(&g);
        m.extend(&v, &mut u);
        let mut worst = 0.0f64;
        for c in 0..3 {
            for r in &m.rows[c] {
                let f = r.face;
                // Back from the storage index to the face's position.
                let dims = g.dims();
                let (i, j, k) = (f % dims[0], (f / dims[0]) % dims[1], f / (dims[0] * dims[1]));
                let x = g.face_center(c, i as isize - 3, j as isize - 3, k as isize - 3);
                let r = ((x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) + (x[2] - 0.5).powi(2)).sqrt();
                let nrm = [-(x[0] - 0.5) / r, -(x[1] - 0.5) / r, -(x[2] - 0.5) / r];
                // The closest point on the sphere; the map uses psi h / beta, exact for this phi.
                let s = 0.2 - r;
                let xg: [f64; 3] = std::array::from_fn(|d| x[d] - s * nrm[d]);
                let dv: [f64; 3] = std::array::from_fn(|d| lin(xg, d) - lin(x, d));
                let ndv: f64 = (0..3).map(|d| nrm[d] * dv[d]).sum();
                let expected = lin(x, c) + dv[c] - nrm[c] * ndv;
                // Faces within three cells of the surface (the band's): deeper faces of the map
                // approach the centre, where the normals are not defined.
                if s.abs() < 3.0 / 32.0 {
                    worst = worst.max((u.c[c].data[f] - expected).abs());
                }
            }
        }
        // The face takes the mean normal and distance of its two cells: O(h^2 / R) (1.3e-3 here).
        assert!(worst < 2e-3, "largest deviation {worst}");
    }
}
