//! The in-plane membrane force on the staggered grid: the terms of (2.35) that come from the
//! in-plane stress,
//!
//! ```text
//! explicit (right-hand side):  f = ∇·( δ (τⁿ + (Δt/4) H(vⁿ, G_sⁿ, Jⁿ)) )
//! implicit (predictor):        (P v*) += −(Δt/4) ∇·( δ H(v*, G_sⁿ, Jⁿ) )
//! ```
//!
//! with `δ = |∇φ|` (2.26), `τ = τ(G_s, n)` (2.4), `J = ∂τ/∂G_s` (2.33) and
//! `H(v, G_s, J) = J : (∇vᵀ·G_s + G_s·∇v)` (B.6), all from [`super::stress`](mod@super::stress). This is the
//! Crank–Nicolson in-plane stress `½ ∇·(δ (τⁿ + τ*))` of (2.31) with the linearisation (2.32) and
//! the rate (2.34); `∇·(δ τ)` itself is the modified form (2.16) of `δ f`.
//!
//! # Where things live
//!
//! `δ`, `n`, `G_s`, `τ`, `J` and `H` live at cell centres and are evaluated on the band cells of
//! a [`Band`] only (`δ h ≥ ε`; zero elsewhere). The force lives on the faces, where the pressure
//! gradient lives: component `c` on the lower face of cell `m` normal to axis `c`. With
//! `S = δ τ` (or `δ H`) at cell centres,
//!
//! ```text
//! f_c(m) = [S_cc(m) − S_cc(m − e_c)] / h_c
//!        + Σ_{a≠c} [S_ac(m + e_a) + S_ac(m + e_a − e_c) − S_ac(m − e_a) − S_ac(m − e_a − e_c)] / (4 h_a),
//! ```
//!
//! i.e. the normal components differenced across the face, and the shear components averaged to
//! the cell edges (four cells) and differenced across the face: the stencil of the viscous
//! stress in [`crate::fluid::momentum`]. It is non-zero only on the faces of
//! [`Band::halo`]`(1)`. Why this form:
//!
//! - it is exactly the negative adjoint of the cell-centred velocity gradient
//!   [`grad_v_at_cell`] used for `H` and for the stretching of `G_s` in [`super::strain`]:
//!   `Σ_faces f·w ΔV = −Σ_cells S : ∇_h w ΔV` for every face field `w` (periodic box). So the
//!   power of the membrane force is the discrete stress power, as in the continuum, and the
//!   implicit operator `−(Δt/4) ∇_h·(δ J : R(∇_h ·))` has the structure `D_hᵀ K D_h`;
//! - the total force on a periodic box vanishes exactly (the sum telescopes);
//! - a membrane in its reference state (`G_s = P`, `τ = 0` to round-off) gives a zero force to
//!   round-off; a uniformly tensed sphere (`τ = T P`) gives a force whose integral across the
//!   band is the Laplace jump `2T/R` up to the discretisation of `n` and `δ`, where normal
//!   errors enter only quadratically (see `tests/membrane_grid.rs`).
//!
//! # Use in a step
//!
//! 1. [`Band::rebuild`] from `δ^{n+1}`;
//! 2. [`InPlaneElasticity::evaluate`] with `G_sⁿ`, `n^{n+1}`, `δ^{n+1}` and `Δt`: `τ` and `J'`
//!    per band cell (the only call that evaluates the law);
//! 3. pass [`InPlaneElasticity::forcing`] as (part of) the [`Forcing`] and
//!    [`InPlaneElasticity::implicit`] as the [`ImplicitTerm`] of
//!    [`FlowStepper::step`](crate::fluid::stepper::FlowStepper::step).
//!
//! Neither the forcing nor the implicit term allocate after the first step at a given band size
//! (their scratch grows with the band and keeps its capacity).

use super::band::Band;
use super::law::SurfaceLaw;
use super::outer_layers::OuterLayers;
use super::stress::{Jacobian, h_tensor, jacobian_apply, stress_and_jacobian, stretching};
use crate::error::positive;
use crate::fluid::{forcing::Forcing, momentum::ImplicitTerm};
use crate::grid::ops::{cell_vector, grad_v_at_cell};
use crate::grid::{Field, Grid, SymField, VectorField};
use crate::tensor::{Mat3, Sym, sym_to_mat};
use crate::{Error, Real, Result};
use rayon::prelude::*;
use std::sync::Mutex;

/// Band cells per rayon task (a Jacobian is a few hundred flops).
const MIN_CELLS_PER_TASK: usize = 128;

/// `Σ_a ∂_a S_ac` on the lower face of cell `m` normal to `c`, with `S` at cell centres given by
/// `s(p)[a][c]` (see the [module docs](self) for the stencil). `ih` holds `1/h`.
#[inline(always)]
pub(crate) fn face_divergence<T: Real>(
    st: &[usize; 3],
    ih: &[T; 3],
    c: usize,
    m: usize,
    s: impl Fn(usize) -> Mat3<T>,
) -> T {
    let sc = st[c];
    let mut f = (s(m)[c][c] - s(m - sc)[c][c]) * ih[c];
    let quarter = T::lit(0.25);
    for a in (0..3).filter(|&a| a != c) {
        let sa = st[a];
        let up = s(m + sa)[a][c] + s(m + sa - sc)[a][c];
        let dn = s(m - sa)[a][c] + s(m - sa - sc)[a][c];
        f += quarter * (up - dn) * ih[a];
    }
    f
}

/// `[f_x, f_y, f_z]` on the three lower faces of cell `m`: the stencil of [`face_divergence`]
/// with each of the sixteen cells it reads looked up once. `s(p)` gives the tensor at cell `p`
/// (zero off its support) in any storage, `comp(&S, a, c)` its component `S_ac`.
#[inline(always)]
pub(crate) fn face_divergence3<T: Real, S>(
    st: &[usize; 3],
    ih: &[T; 3],
    m: usize,
    s: impl Fn(usize) -> S,
    comp: impl Fn(&S, usize, usize) -> T,
) -> [T; 3] {
    let [sx, sy, sz] = *st;
    let s0 = s(m);
    let sm = [s(m - sx), s(m - sy), s(m - sz)];
    let sp = [s(m + sx), s(m + sy), s(m + sz)];
    // S(m - e_a - e_c) for the pairs (0,1), (1,2), (2,0).
    let smm = [s(m - sx - sy), s(m - sy - sz), s(m - sz - sx)];
    let pair = |a: usize, c: usize| {
        if a + c == 1 {
            0
        } else if a + c == 3 {
            1
        } else {
            2
        }
    };
    let quarter = T::lit(0.25);
    let mut out = [T::zero(); 3];
    for (c, o) in out.iter_mut().enumerate() {
        let mut f = (comp(&s0, c, c) - comp(&sm[c], c, c)) * ih[c];
        for a in (0..3).filter(|&a| a != c) {
            let spm = s(m + st[a] - st[c]);
            let up = comp(&sp[a], a, c) + comp(&spm, a, c);
            let dn = comp(&sm[a], a, c) + comp(&smm[pair(a, c)], a, c);
            f += quarter * (up - dn) * ih[a];
        }
        *o = f;
    }
    out
}

/// Component `(a, c)` of a [`Sym`].
#[inline(always)]
pub(crate) fn sym_comp<T: Real>(s: &Sym<T>, a: usize, c: usize) -> T {
    s[crate::tensor::sym_index(a, c)]
}

/// Adds the face forces `f` (one `[f_x, f_y, f_z]` per entry of `cells`, on the lower faces of
/// that cell) to `out`.
pub(crate) fn scatter_add<T: Real>(cells: &[usize], f: &[[T; 3]], out: &mut VectorField<T>) {
    for (&m, fm) in cells.iter().zip(f) {
        for c in 0..3 {
            out.c[c].data[m] += fm[c];
        }
    }
}

/// The state of one band cell at the last evaluation.
#[derive(Debug, Clone, Copy)]
struct CellState<T> {
    delta: T,
    g: Sym<T>,
    tau: Sym<T>,
    jac: Jacobian<T>,
}

impl<T: Real> CellState<T> {
    fn zero() -> Self {
        let z = T::zero();
        CellState { delta: z, g: [z; 6], tau: [z; 6], jac: [[z; 6]; 6] }
    }
}

/// Scratch of the face-force evaluation: `S` per band cell and the face forces per cell of
/// `halo(1)`.
#[derive(Debug, Default)]
struct Scratch<T> {
    s: Vec<Sym<T>>,
    f: Vec<[T; 3]>,
}

/// The in-plane elasticity of one membrane law on the grid: the stress `τ` and Jacobian `J'` per
/// band cell, and the explicit and implicit force terms of (2.35) built from them (see the
/// [module docs](self)).
pub struct InPlaneElasticity<T: Real, L: SurfaceLaw<T>> {
    law: L,
    grid: Grid<T>,
    dt: T,
    generation: u64,
    state: Vec<CellState<T>>,
    scratch: Mutex<Scratch<T>>,
}

impl<T: Real, L: SurfaceLaw<T>> InPlaneElasticity<T, L> {
    /// The in-plane elasticity of `law` on `grid`. Nothing is evaluated yet.
    pub fn new(grid: &Grid<T>, law: L) -> Self {
        InPlaneElasticity {
            law,
            grid: grid.clone(),
            dt: T::zero(),
            generation: 0,
            state: Vec::new(),
            scratch: Mutex::new(Scratch { s: Vec::new(), f: Vec::new() }),
        }
    }

    /// The membrane law.
    pub fn law(&self) -> &L {
        &self.law
    }

    /// Evaluates `τ` (2.4) and `J'` (2.33) in every band cell from `G_s` (`gs`), the unit normal
    /// `normal` (components at cell centres) and `delta = |∇φ|` (cell centres), and records the
    /// step size `dt` used by the `Δt/4` terms of (2.35). In the paper's step these are `G_sⁿ`,
    /// `n^{n+1}` and `δ^{n+1}`. Only interior values at band cells are read.
    ///
    /// # Errors
    /// - [`Error::InvalidParameter`] naming `grid` if `grid` or `band` are not the grid given to
    ///   [`new`](Self::new), naming `dt` unless it is finite and `> 0`, or naming a field of the
    ///   wrong size;
    /// - [`Error::NonFinite`] naming `tau` at the first band cell where `δ` or `τ` is not finite.
    ///
    /// After an error the forcing and implicit term are unavailable until the next successful
    /// evaluation.
    pub fn evaluate(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        gs: &SymField<T>,
        normal: &[Field<T>; 3],
        delta: &Field<T>,
        dt: T,
    ) -> Result<()> {
        self.generation = 0;
        if !grid.same_cells(&self.grid) {
            return Err(Error::invalid(
                "grid",
                format!("{:?} cells", grid.n()),
                "the grid of InPlaneElasticity::new",
            ));
        }
        band.matches(grid)?;
        positive("dt", dt)?;
        let len = grid.len();
        if gs.c.iter().any(|f| f.data.len() != len) {
            return Err(Error::invalid("gs", "a field of another grid", "a field of the band's grid"));
        }
        if normal.iter().any(|f| f.data.len() != len) {
            return Err(Error::invalid("normal", "a field of another grid", "a field of the band's grid"));
        }
        if delta.data.len() != len {
            return Err(Error::invalid("delta", "a field of another grid", "a field of the band's grid"));
        }
        self.state.resize(band.len(), CellState::zero());
        let law = &self.law;
        self.state.par_iter_mut().zip(band.cells().par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(
            |(cs, &idx)| {
                let g = gs.get(idx);
                let n = cell_vector(normal, idx);
                let (tau, jac) = stress_and_jacobian(law, &g, &n);
                *cs = CellState { delta: delta.data[idx], g, tau, jac };
            },
        );
        if let Some(p) =
            self.state.iter().position(|cs| !(cs.delta.is_finite() && cs.tau.iter().all(|x| x.is_finite())))
        {
            let c = band.coords(0)[p];
            return Err(Error::NonFinite {
                field: "tau",
                cell: [c[0] as usize, c[1] as usize, c[2] as usize],
            });
        }
        self.dt = dt;
        self.generation = band.generation();
        Ok(())
    }

    /// The stress `τ` (2.4) of the band cell at `position` (an index into [`Band::cells`]) at the
    /// last evaluation.
    pub fn tau(&self, position: usize) -> Option<Sym<T>> {
        self.state.get(position).map(|cs| cs.tau)
    }

    /// The Jacobian `J'` (2.33) of the band cell at `position` at the last evaluation.
    pub fn jacobian(&self, position: usize) -> Option<Jacobian<T>> {
        self.state.get(position).map(|cs| cs.jac)
    }

    fn check_band(&self, band: &Band<T>) -> Result<()> {
        band.check_generation("InPlaneElasticity", self.generation, "evaluated")
    }

    /// The explicit in-plane force `∇·(δ (τⁿ + (Δt/4) H(vⁿ, G_sⁿ, Jⁿ)))` of (2.35), as a
    /// [`Forcing`] (the velocity it receives is `vⁿ`, ghosts filled).
    ///
    /// # Errors
    /// [`Error::Unsupported`] if the last [`evaluate`](Self::evaluate) was not on this band (or
    /// failed).
    pub fn forcing<'a>(&'a self, band: &'a Band<T>) -> Result<InPlaneForcing<'a, T, L>> {
        self.check_band(band)?;
        Ok(InPlaneForcing { e: self, band, layers: None, quasi_implicit: true })
    }

    /// The fully explicit in-plane force `∇·(δ τⁿ)`, without the linearised `H` terms of
    /// (2.35): the reference against which the quasi-implicit scheme's larger stable time step
    /// is measured. Use it without [`implicit`](Self::implicit).
    ///
    /// # Errors
    /// As [`forcing`](Self::forcing).
    pub fn explicit_forcing<'a>(&'a self, band: &'a Band<T>) -> Result<InPlaneForcing<'a, T, L>> {
        self.check_band(band)?;
        Ok(InPlaneForcing { e: self, band, layers: None, quasi_implicit: false })
    }

    /// The implicit term `−(Δt/4) ∇·(δ H(v*, G_sⁿ, Jⁿ))` of the predictor (2.35), as an
    /// [`ImplicitTerm`].
    ///
    /// # Errors
    /// As [`forcing`](Self::forcing).
    pub fn implicit<'a>(&'a self, band: &'a Band<T>) -> Result<InPlaneImplicit<'a, T, L>> {
        self.check_band(band)?;
        Ok(InPlaneImplicit { e: self, band, layers: None })
    }

    /// `S = δ (a τ + b H(w))` per band cell into the scratch (with `layers`: the outer cells'
    /// rates of `G_s` gathered from the core and their `S` scattered onto it), then the face
    /// forces of `halo(1)` added to `out`.
    fn add_force(
        &self,
        band: &Band<T>,
        layers: Option<&OuterLayers<T>>,
        w: &VectorField<T>,
        a: T,
        b: T,
        out: &mut VectorField<T>,
    ) -> Result<()> {
        let grid = &self.grid;
        w.matches(grid, "velocity")?;
        out.matches(grid, "force")?;
        let mut guard = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        let Scratch { s, f } = &mut *guard;
        s.resize(band.len(), [T::zero(); 6]);
        let with_h = b != T::zero();
        let cells = (self.state.par_iter().zip(band.cells().par_iter())).with_min_len(MIN_CELLS_PER_TASK);
        match layers {
            None => s.par_iter_mut().zip(cells).for_each(|(so, (cs, &idx))| {
                let h = if with_h {
                    h_tensor(&grad_v_at_cell(grid, w, idx), &cs.g, &cs.jac)
                } else {
                    [T::zero(); 6]
                };
                *so = std::array::from_fn(|k| cs.delta * (a * cs.tau[k] + b * h[k]));
            }),
            Some(layers) => {
                if with_h {
                    s.par_iter_mut().zip(cells).for_each(|(so, (cs, &idx))| {
                        *so = stretching(&grad_v_at_cell(grid, w, idx), &cs.g);
                    });
                    layers.gather(s);
                }
                s.par_iter_mut().zip(self.state.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(
                    |(so, cs)| {
                        let h = if with_h { jacobian_apply(&cs.jac, so) } else { [T::zero(); 6] };
                        *so = std::array::from_fn(|k| cs.delta * (a * cs.tau[k] + b * h[k]));
                    },
                );
                layers.scatter(s);
            }
        }
        let st = grid.strides();
        let hh = grid.h();
        let ih = [T::one() / hh[0], T::one() / hh[1], T::one() / hh[2]];
        let cells = band.halo(1);
        f.resize(cells.len(), [T::zero(); 3]);
        let s = &*s;
        let lookup = |p: usize| match band.position_in(p, 0) {
            Some(q) => s[q],
            None => [T::zero(); 6],
        };
        f.par_iter_mut().zip(cells.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(|(fo, &m)| {
            *fo = face_divergence3(&st, &ih, m, lookup, sym_comp);
        });
        scatter_add(cells, f, out);
        Ok(())
    }
}

/// The explicit in-plane force of (2.35) on the faces (a [`Forcing`]); see
/// [`InPlaneElasticity::forcing`].
pub struct InPlaneForcing<'a, T: Real, L: SurfaceLaw<T>> {
    e: &'a InPlaneElasticity<T, L>,
    band: &'a Band<T>,
    layers: Option<&'a OuterLayers<T>>,
    quasi_implicit: bool,
}

impl<'a, T: Real, L: SurfaceLaw<T>> InPlaneForcing<'a, T, L> {
    /// The same force on a shell whose outer layers take `G_s` from the core
    /// ([`OuterLayers`]): their stress acts on the core cells (the transpose of the
    /// re-sampling), and their rate of `G_s` in `H` is the core's.
    ///
    /// # Errors
    /// [`Error::Unsupported`] unless `layers` were built on the force's band.
    pub fn with_outer_layers(mut self, layers: &'a OuterLayers<T>) -> Result<Self> {
        layers.check_band(self.band)?;
        self.layers = Some(layers);
        Ok(self)
    }
}

impl<T: Real, L: SurfaceLaw<T>> Forcing<T> for InPlaneForcing<'_, T, L> {
    fn is_active(&self) -> bool {
        !self.band.is_empty()
    }
    /// Adds `∇·(δ (τⁿ + (Δt/4) H(v, G_sⁿ, Jⁿ)))` on the faces of `halo(1)` (only `∇·(δ τⁿ)`
    /// for the [explicit](InPlaneElasticity::explicit_forcing) force).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `velocity` or `force` for a field of another grid.
    fn add(&self, _grid: &Grid<T>, _time: T, v: &VectorField<T>, out: &mut VectorField<T>) -> Result<()> {
        let q = if self.quasi_implicit { T::lit(0.25) * self.e.dt } else { T::zero() };
        self.e.add_force(self.band, self.layers, v, T::one(), q, out)
    }
}

/// The implicit in-plane term of the predictor (2.35) (an [`ImplicitTerm`]); see
/// [`InPlaneElasticity::implicit`].
pub struct InPlaneImplicit<'a, T: Real, L: SurfaceLaw<T>> {
    e: &'a InPlaneElasticity<T, L>,
    band: &'a Band<T>,
    layers: Option<&'a OuterLayers<T>>,
}

impl<'a, T: Real, L: SurfaceLaw<T>> InPlaneImplicit<'a, T, L> {
    /// The same term on a shell whose outer layers take `G_s` from the core, as
    /// [`InPlaneForcing::with_outer_layers`]: the operator becomes `D_hᵀ Aᵀ K A D_h`.
    /// [`apply_at`](ImplicitTerm::apply_at) (for SOR) still reads the cells' own rates.
    ///
    /// # Errors
    /// [`Error::Unsupported`] unless `layers` were built on the term's band.
    pub fn with_outer_layers(mut self, layers: &'a OuterLayers<T>) -> Result<Self> {
        layers.check_band(self.band)?;
        self.layers = Some(layers);
        Ok(self)
    }
}

impl<T: Real, L: SurfaceLaw<T>> ImplicitTerm<T> for InPlaneImplicit<'_, T, L> {
    /// Adds `−(Δt/4) ∇·(δ H(x, G_sⁿ, Jⁿ))` on the faces of `halo(1)` (ghosts of `x` filled).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `velocity` or `force` for a field of another grid.
    fn add_apply(&self, _grid: &Grid<T>, x: &VectorField<T>, y: &mut VectorField<T>) -> Result<()> {
        let q = -T::lit(0.25) * self.e.dt;
        self.e.add_force(self.band, self.layers, x, T::zero(), q, y)
    }

    /// The same at one face, recomputing `δ H` at the ten cells of the stencil (for SOR).
    fn apply_at(&self, _grid: &Grid<T>, x: &VectorField<T>, c: usize, idx: usize) -> T {
        let band = self.band;
        if band.position_in(idx, 1).is_none() {
            return T::zero();
        }
        let e = self.e;
        let grid = &e.grid;
        let q = -T::lit(0.25) * e.dt;
        let hh = grid.h();
        let ih = [T::one() / hh[0], T::one() / hh[1], T::one() / hh[2]];
        face_divergence(&grid.strides(), &ih, c, idx, |p| match band.position_in(p, 0) {
            Some(b) => {
                let cs = &e.state[b];
                let h = h_tensor(&grad_v_at_cell(grid, x, p), &cs.g, &cs.jac);
                let s: Sym<T> = std::array::from_fn(|k| q * cs.delta * h[k]);
                sym_to_mat(&s)
            }
            None => [[T::zero(); 3]; 3],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::membrane::law::NeoHookean;
    use crate::tensor::projector;

    /// Face divergence is the negative adjoint of `grad_v_at_cell` on a periodic box.
    #[test]
    fn divergence_is_minus_adjoint_of_cell_gradient() {
        let g = Grid::<f64>::periodic([6, 5, 4], [0.0; 3], [1.0, 0.9, 0.7]).unwrap();
        let mut w = VectorField::from_fn(&g, |x| {
            [(7.0 * x[1]).sin() + x[2], (3.0 * x[0] + 2.0 * x[2]).cos(), (5.0 * x[0] * x[1]).sin()]
        });
        w.fill_ghosts(&g);
        let mut s = SymField::zeros(&g);
        for (i, j, k) in g.cells() {
            let id = g.idx_u(i, j, k);
            let a = (i + 2 * j + 3 * k) as f64;
            s.set(id, &[a.sin(), a.cos(), (2.0 * a).sin(), (0.5 * a).cos(), (3.0 * a).sin(), a * 0.1]);
        }
        s.fill_ghosts(&g);
        let st = g.strides();
        let ih = [1.0 / g.h()[0], 1.0 / g.h()[1], 1.0 / g.h()[2]];
        let (mut lhs, mut rhs) = (0.0, 0.0);
        for (i, j, k) in g.cells() {
            let m = g.idx_u(i, j, k);
            for c in 0..3 {
                lhs += w.c[c].data[m] * face_divergence(&st, &ih, c, m, |p| sym_to_mat(&s.get(p)));
            }
            let gv = grad_v_at_cell(&g, &w, m);
            let sm = sym_to_mat(&s.get(m));
            for a in 0..3 {
                for b in 0..3 {
                    rhs -= sm[a][b] * gv[a][b];
                }
            }
        }
        assert!((lhs - rhs).abs() < 1e-10 * rhs.abs().max(1.0), "{lhs} vs {rhs}");
    }

    #[test]
    fn specialised_kernel_matches_generic() {
        let g = Grid::<f64>::periodic([5, 6, 7], [0.0; 3], [1.0, 1.3, 0.8]).unwrap();
        let mut s = SymField::zeros(&g);
        for (i, j, k) in g.cells() {
            let a = (3 * i + 5 * j + 7 * k) as f64;
            s.set(
                g.idx_u(i, j, k),
                &[a.sin(), a.cos(), (0.3 * a).sin(), (0.7 * a).cos(), (1.3 * a).sin(), 0.01 * a],
            );
        }
        s.fill_ghosts(&g);
        let st = g.strides();
        let ih = [1.0 / g.h()[0], 1.0 / g.h()[1], 1.0 / g.h()[2]];
        for (i, j, k) in g.cells() {
            let m = g.idx_u(i, j, k);
            let fast = face_divergence3(&st, &ih, m, |p| s.get(p), sym_comp);
            for c in 0..3 {
                let slow = face_divergence(&st, &ih, c, m, |p| sym_to_mat(&s.get(p)));
                assert!((fast[c] - slow).abs() < 1e-12, "{c}: {} vs {slow}", fast[c]);
            }
        }
    }

    #[test]
    fn needs_evaluation_on_the_same_band() {
        let g = Grid::<f64>::periodic([8, 8, 8], [0.0; 3], [1.0; 3]).unwrap();
        let mut band = Band::new(&g, 0.1).unwrap();
        let mut delta = Field::zeros(&g);
        delta.data[g.idx_u(4, 4, 4)] = 100.0;
        band.rebuild(&g, &delta).unwrap();
        let mut e = InPlaneElasticity::new(&g, NeoHookean::new(1.0).unwrap());
        assert!(e.forcing(&band).is_err());
        let n = [Field::zeros(&g), Field::zeros(&g), Field::from_cell_fn(&g, |_| 1.0)];
        let mut gs = SymField::zeros(&g);
        gs.set(g.idx_u(4, 4, 4), &projector(&[0.0, 0.0, 1.0]));
        assert!(e.evaluate(&g, &band, &gs, &n, &delta, 0.0).is_err());
        e.evaluate(&g, &band, &gs, &n, &delta, 0.1).unwrap();
        assert!(e.forcing(&band).is_ok() && e.implicit(&band).is_ok());
        band.rebuild(&g, &delta).unwrap();
        assert!(e.forcing(&band).is_err());
        let g2 = Grid::<f64>::periodic([8, 8, 4], [0.0; 3], [1.0; 3]).unwrap();
        let b2 = Band::new(&g2, 0.1).unwrap();
        assert!(e.evaluate(&g2, &b2, &gs, &n, &delta, 0.1).is_err());
    }
}
