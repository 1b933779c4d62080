//! Bending of the membrane in the modified form (2.16)–(2.17) of the paper:
//!
//! ```text
//! m̃ = E_b (δ κ − κ̃_R P),        q̃ = (∇·m̃)·P,        force density  ∇·(q̃ n_out),
//! ```
//!
//! with `δ = |∇φ|` (2.26), `κ̃_R = δ κ_R` the convolved reference mean curvature (advected by
//! (2.23)/(2.30) in the interface module, an input here), and the curvature tensor `κ` (2.9a).
//! Appendix A shows that `∇·(q̃ n) = δ (P·∇)·(q n)` with Pozrikidis' transverse shear tension
//! `q = ((P·∇)·m)·P` (2.7) and bending moment `m = E_b (κ − κ_R P)` (2.8).
//!
//! # Sign conventions (stated once for the crate's bending)
//!
//! - `n = ∇φ/|∇φ|` points **into** the capsule (`φ = 1` inside), `P = I − n n`;
//! - `κ = −∇n` (2.9a) with `(∇n)_ij = ∂n_j/∂x_i`. For a sphere of radius `r`, `n = −e_r` and
//!   `κ = P/r`: the curvature of a convex capsule is **positive**, its mean curvature is
//!   `tr(κ)/2 = 1/r`;
//! - `κ_R = −½ tr(∇n_R)` (2.9b): `1/R` for a reference sphere of radius `R`; a flat reference is
//!   `κ_R = 0`;
//! - the force is added on the faces with a plus sign, as `∇·(δ τ)` in [`super::force`].
//!
//! # The sign of the force
//!
//! The force is `∇·(q̃ n_out)` with the **outward** normal `n_out = −n`, while `κ` is built
//! from the inward `n` (positive for a sphere). Read with one normal for both, (2.9a) and
//! (2.16) give the opposite sign, and that force *drives* bending instead of resisting it:
//! for a flat membrane `z = ζ(x)` (`κ_R = 0`, `κ_xx = −ζ''` with the inward normal),
//! `q = (E_b κ_xx)' = −E_b ζ'''` and `∇·(q n) = −E_b ζ'''' n_in = +E_b ζ'''' e_z`: a bump is
//! pushed further out, at a rate growing like `k⁴`. The plate equation needs
//! `f = −E_b ζ'''' e_z`, which is `∇·(q n_out)`: the paper's `n` in `q n` is the outward normal
//! (the orientation under which `κ = −∇n` is negative for a sphere, and `κ − κ_R P` flips
//! with it). Measured on a sphere of 8-16 cells per radius with an `l = 2` shape mode: the
//! normal stiffness of this force is `+23.0` to `+23.7 E_b/R⁴`, against `λ(λ − 2) E_b/R⁴ = 24`
//! (`λ = l(l + 1)`) of the moment law (2.8) in the continuum, and the same with a minus sign
//! with the inward normal. With the inward normal a sphere at rest is unstable from about ten
//! cells per radius, whatever the time step: the bending failures that `docs/validation/membrane_forces.md`
//! records before this was found. See `tests/membrane_grid.rs`.
//!
//! # The reference curvature is a field
//!
//! `κ̃_R` must be `δ` times the **field** `κ_R = −½ tr(∇n_R)` of (2.9b), evaluated where it
//! stands (`1/r` at distance `r` from the centre of a reference sphere: the mean curvature of the
//! level set through the point, see [`mean_curvature_at`]), not the surface value `1/R` carried
//! unchanged along the normals. Both give a zero force for a sphere in the continuum (`m̃` is
//! then isotropic in the tangent plane, so `q̃ = 0`), but with the surface value
//! `m̃ = E_b δ (1/r − 1/R) P` is of size `E_b δ h/R²` across a band one cell wide, and its
//! discrete divergence leaves an error that does not vanish with the grid: measured on a
//! reference sphere with `ψ`-normals, the maximum of the force relative to `E_b δ_max/R³` *grows*
//! like `R/h`, while with the field `κ_R` it decreases at second order (its integral across the
//! band converges in both cases). See `tests/membrane_grid.rs`.
//!
//! # Discretisation
//!
//! All at cell centres, central differences (second order), on the cells of a [`Band`]:
//!
//! 1. on band cells: `κ = −P (∇_h n) P`, `∂_i n_j ≈ (n_j(x + h e_i) − n_j(x − h e_i))/(2h)`,
//!    and `m̃ = E_b (δ κ − κ̃_R P)`; `m̃ = 0` off the band. (2.9a) writes `κ = −P·∇n = −∇n`;
//!    the projection on both sides equals it in the continuum (`(∇n)·n = 0` for a unit normal,
//!    `n·∇n = 0` for a distance-like `φ`) and makes `n·m̃ = m̃·n = 0` exactly, so that the
//!    normal derivative of `δ` (of size `δ/h`) does not multiply the `O(h²)` error of
//!    `n·(∇_h n)`. Measured on a reference sphere (max norm, `R/h` = 16 to 32): order ≈ 1.9 with
//!    both projections or with the left one only, ≈ 1.2–1.5 (and degrading) with none. See
//!    [`curvature_tensor_at`];
//! 2. on `halo(1)`: `(∇·m̃)_l = Σ_k ∂_k m̃_kl` (central), `q̃_j = (∇·m̃)_l P_lj`;
//! 3. on the faces of `halo(2)`: `f_c = Σ_a ∂_a (q̃_a n_c)` with the face stencil of the in-plane
//!    force ([`super::force`]: `a = c` differenced across the face, `a ≠ c` averaged to the
//!    edges).
//!
//! The force depends on `φ` only (not on the velocity): [`BendingStress::evaluate`] computes it once
//! per step (from `n^{n+1}`, `δ^{n+1}`, `κ̃_R^{n+1}` in the paper's (2.35)) and
//! [`BendingStress::forcing`] adds it. A scene without bending creates no [`BendingStress`] and computes or
//! stores none of this: the work arrays are owned here and sized by the band.
//!
//! # Two forms
//!
//! [`BendingForm::EnergyGradient`] ([`BendingStress::evaluate_variational`]) is the exact gradient
//! of a discrete bending energy built from the same moment `m̃`: its power balances the
//! energy's rate of change, so no discrete error can feed a mode. It is the gradient of
//! `∫ ½ E_b |κ − κ_R P|² dA`, which is not Pozrikidis' model: see its docs.

use super::band::Band;
use super::force::{face_divergence3, scatter_add};
use crate::error::positive;
use crate::fluid::forcing::Forcing;
use crate::grid::ops::{cell_vector, grad_cell_vector_at};
use crate::grid::{Field, Grid, VectorField};
use crate::tensor::{Mat3, Vec3, matmul, projector, sym_to_mat};
use crate::{Error, Real, Result};
use rayon::prelude::*;

/// Cells per rayon task.
const MIN_CELLS_PER_TASK: usize = 256;

/// The projected curvature tensor `κ = −P (∇_h n) P` at the centre of cell `idx`, from the unit
/// normal at cell centres (ghosts filled) by central differences: `κ[i][j]`, with
/// `(∇_h n)[i][j] ≈ ∂n_j/∂x_i`. Positive for a sphere with the inward normal (`κ = P/r`).
#[inline]
pub fn curvature_tensor_at<T: Real>(grid: &Grid<T>, normal: &[Field<T>; 3], idx: usize) -> Mat3<T> {
    let gn = grad_cell_vector_at(grid, normal, idx).map(|row| row.map(|x| -x));
    let p = sym_to_mat(&projector(&cell_vector(normal, idx)));
    matmul(&matmul(&p, &gn), &p)
}

/// The mean curvature `tr(κ)/2` of [`curvature_tensor_at`] at the centre of cell `idx` (`1/r` for a
/// sphere with the inward normal): with a reference normal field, the reference mean curvature
/// `κ_R = −½ tr(∇n_R)` of (2.9b), e.g. to initialise `κ̃_R = δ κ_R` from the initial shape.
#[inline]
pub fn mean_curvature_at<T: Real>(grid: &Grid<T>, normal: &[Field<T>; 3], idx: usize) -> T {
    let k = curvature_tensor_at(grid, normal, idx);
    T::lit(0.5) * (k[0][0] + k[1][1] + k[2][2])
}

/// `q̃ = (∇·m̃)·P` at cell `idx` (central differences), with `m̃` at cell centres given by `mt`
/// (zero off the band) and `P` from the unit normal.
#[inline]
pub(crate) fn shear_tension_at<T: Real>(
    grid: &Grid<T>,
    normal: &[Field<T>; 3],
    idx: usize,
    mt: impl Fn(usize) -> Mat3<T>,
) -> Vec3<T> {
    let st = grid.strides();
    let h = grid.h();
    let mut div = [T::zero(); 3];
    for k in 0..3 {
        let (up, dn) = (mt(idx + st[k]), mt(idx - st[k]));
        let ih2 = T::lit(0.5) / h[k];
        for l in 0..3 {
            div[l] += (up[k][l] - dn[k][l]) * ih2;
        }
    }
    let p = sym_to_mat(&projector(&cell_vector(normal, idx)));
    std::array::from_fn(|j| div[0] * p[0][j] + div[1] * p[1][j] + div[2] * p[2][j])
}

/// Steps 2 and 3 of the [module docs](self): from `m̃` per band cell, `q̃` on `halo(1)` into `q`
/// and the face force `∇·(q̃ n_out)` on the faces of `halo(2)` into `f`, with the outward normal
/// `n_out = −n` (see "The sign of the force").
pub(crate) fn face_force_of_moment<T: Real>(
    grid: &Grid<T>,
    band: &Band<T>,
    normal: &[Field<T>; 3],
    m: &[Mat3<T>],
    q: &mut Vec<Vec3<T>>,
    f: &mut Vec<[T; 3]>,
) {
    let zero3 = [[T::zero(); 3]; 3];
    let mt = |p: usize| match band.position_in(p, 0) {
        Some(b) => m[b],
        None => zero3,
    };
    let cells1 = band.halo(1);
    q.resize(cells1.len(), [T::zero(); 3]);
    q.par_iter_mut()
        .zip(cells1.par_iter())
        .with_min_len(MIN_CELLS_PER_TASK)
        .for_each(|(qo, &idx)| *qo = shear_tension_at(grid, normal, idx, mt));
    let q = &*q;
    // (q̃, n_out) at a cell, zero off halo(1); Q_ac = q̃_a (n_out)_c.
    let qn = |p: usize| match band.position_in(p, 1) {
        Some(b) => (q[b], cell_vector(normal, p).map(|x| -x)),
        None => ([T::zero(); 3], [T::zero(); 3]),
    };
    let comp = |v: &(Vec3<T>, Vec3<T>), a: usize, c: usize| v.0[a] * v.1[c];
    let st = grid.strides();
    let h = grid.h();
    let ih: [T; 3] = std::array::from_fn(|d| T::one() / h[d]);
    let cells2 = band.halo(2);
    f.resize(cells2.len(), [T::zero(); 3]);
    f.par_iter_mut()
        .zip(cells2.par_iter())
        .with_min_len(MIN_CELLS_PER_TASK)
        .for_each(|(fo, &idx)| *fo = face_divergence3(&st, &ih, idx, qn, comp));
}

/// The bending of the membrane: `m̃`, `q̃` and the face force `∇·(q̃ n)` on a band (see the
/// [module docs](self)).
#[derive(Debug, Clone)]
pub struct BendingStress<T> {
    eb: T,
    grid: Grid<T>,
    generation: u64,
    /// `m̃` per band cell.
    m: Vec<Mat3<T>>,
    /// `q̃` per cell of `halo(1)`.
    q: Vec<Vec3<T>>,
    /// Face force per cell of `halo(2)` (on its three lower faces).
    f: Vec<[T; 3]>,
    /// Work arrays of [`evaluate_variational`](Self::evaluate_variational).
    energy: super::bending_energy::EnergyGradient<T>,
    /// Halo whose lower faces carry `f` (2, or 4 after `evaluate_variational`).
    face_halo: usize,
}

/// Which discrete bending force [`BendingStress`] evaluates.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BendingForm {
    /// The paper's `∇·(q̃ n)` (2.16)-(2.17) ([`BendingStress::evaluate`]).
    #[default]
    Divergence,
    /// The exact gradient of the discrete energy `Σ ½ E_b δ |κ − κ_R P|² h³` with the same
    /// moment `m̃` ([`BendingStress::evaluate_variational`]; not in the paper). It cannot do work on
    /// the fluid that the energy does not pay for.
    EnergyGradient,
}

impl BendingForm {
    /// The form named `divergence` or `energy` (command-line flags).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `bending_form` for any other name.
    pub fn from_name(s: &str) -> Result<Self> {
        match s {
            "divergence" => Ok(BendingForm::Divergence),
            "energy" => Ok(BendingForm::EnergyGradient),
            _ => Err(Error::invalid("bending_form", s, "divergence or energy")),
        }
    }
}

impl<T: Real> BendingStress<T> {
    /// Bending with modulus `eb` (`E_b`) on `grid`. Nothing is evaluated or allocated yet.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `eb` unless it is finite and `> 0` (a membrane without
    /// bending simply has no `BendingStress`).
    pub fn new(grid: &Grid<T>, eb: T) -> Result<Self> {
        positive("eb", eb)?;
        Ok(BendingStress {
            eb,
            grid: grid.clone(),
            generation: 0,
            m: Vec::new(),
            q: Vec::new(),
            f: Vec::new(),
            energy: Default::default(),
            face_halo: 2,
        })
    }

    /// The bending modulus `E_b`.
    pub fn eb(&self) -> T {
        self.eb
    }

    /// Evaluates `m̃` on the band, `q̃` on `halo(1)` and the face force on `halo(2)` from the unit
    /// normal `normal` (cell centres, ghosts filled), `delta = |∇φ|` and `kappa_r_tilde`
    /// (`κ̃_R = δ κ_R`), all at the same time level (`n+1` in (2.35)).
    ///
    /// # Errors
    /// - [`Error::InvalidParameter`] naming `grid` (not the grid of [`new`](Self::new) or of
    ///   the band) or a field of the wrong size;
    /// - [`Error::NonFinite`] naming `bending force` at the first cell of `halo(2)` with a
    ///   non-finite force. After an error the forcing is unavailable until the next successful
    ///   evaluation.
    pub fn evaluate(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        normal: &[Field<T>; 3],
        delta: &Field<T>,
        kappa_r_tilde: &Field<T>,
    ) -> Result<()> {
        self.begin(grid, band)?;
        let len = grid.len();
        if normal.iter().any(|f| f.data.len() != len) {
            return Err(Error::invalid("normal", "a field of another grid", "a field of the band's grid"));
        }
        if delta.data.len() != len || kappa_r_tilde.data.len() != len {
            return Err(Error::invalid(
                "delta or kappa_r_tilde",
                "a field of another grid",
                "a field of the band's grid",
            ));
        }
        let eb = self.eb;

        // 1. m̃ on the band.
        let band_cells = band.cells();
        self.m.resize(band_cells.len(), [[T::zero(); 3]; 3]);
        self.m.par_iter_mut().zip(band_cells.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(
            |(mo, &idx)| {
                let kappa = curvature_tensor_at(grid, normal, idx);
                let p = sym_to_mat(&projector(&cell_vector(normal, idx)));
                let (d, kr) = (delta.data[idx], kappa_r_tilde.data[idx]);
                *mo = std::array::from_fn(|i| std::array::from_fn(|j| eb * (d * kappa[i][j] - kr * p[i][j])));
            },
        );

        // 2.-3. q̃ on halo(1), the face force on halo(2).
        face_force_of_moment(grid, band, normal, &self.m, &mut self.q, &mut self.f);
        self.finish(band, 2)
    }

    /// Common entry of the evaluations: invalidates the last force and checks `grid` and `band`.
    fn begin(&mut self, grid: &Grid<T>, band: &Band<T>) -> Result<()> {
        self.generation = 0;
        if !grid.same_cells(&self.grid) {
            return Err(Error::invalid(
                "grid",
                format!("{:?} cells", grid.n()),
                "the grid of BendingStress::new",
            ));
        }
        band.matches(grid)
    }

    /// Common end of the evaluations: refuses a non-finite face force (per cell of
    /// `halo(face_halo)`), then records where the force lives and the band it belongs to.
    fn finish(&mut self, band: &Band<T>, face_halo: usize) -> Result<()> {
        if let Some(p) = self.f.iter().position(|f| !f.iter().all(|x| x.is_finite())) {
            let c = band.coords(face_halo)[p];
            return Err(Error::NonFinite {
                field: "bending force",
                cell: [c[0] as usize, c[1] as usize, c[2] as usize],
            });
        }
        self.face_halo = face_halo;
        self.generation = band.generation();
        Ok(())
    }

    /// Evaluates the bending force of [`BendingForm::EnergyGradient`]: the exact gradient of the
    /// discrete energy
    ///
    /// ```text
    /// E_h(φ) = Σ_band ½ E_b δ |κ − κ_R P|² h³,   δ = |∇_h φ|,  κ = −P (∇_h n) P,  n = ∇_h ψ/|∇_h ψ|,
    /// ```
    ///
    /// built from the same quantities as [`evaluate`](Self::evaluate) (its `∂E/∂κ` is the
    /// moment `m̃ = E_b (δ κ − κ̃_R P)` of (2.17)), with `ψ = atanh(2φ − 1)` and the reference
    /// mean curvature `κ_R = κ̃_R/δ` carried by the material. With `μ = ∂E_h/∂φ / h³` (by reverse
    /// differentiation through `δ`, `ψ`, `n` and `κ`) and `ν = −tr m̃`, the force density on the
    /// face between cells `c` and `c + e_d` is `½ Σ (μ ∂_d φ + ν ∂_d κ_R)` over the two cells
    /// (central `∂_d`). Its power `Σ f·v h³` is exactly `−dE_h/dt` when `φ` and `κ_R` move by
    /// `∂_t + v·∇` (central, cell velocity the mean of its faces); the crate's MTHINC transport
    /// differs from that by its truncation error. So the force cannot feed a mode that the
    /// energy does not pay for.
    ///
    /// It is not Pozrikidis' force (2.7)-(2.10), which is not the gradient of an energy. The two
    /// agree for short waves (`E_b k⁴` on a flat membrane); on a sphere the normal stiffness of
    /// a shape mode `l` is `(λ − 1)(λ − 2) E_b/R⁴` here against `λ(λ − 2) E_b/R⁴` for
    /// Pozrikidis (`λ = l(l + 1)`: 20 against 24 for `l = 2`, the mode of a capsule in shear);
    /// a `cos θ` variation of `κ_R` is forced at second order in its amplitude here, at first
    /// order by Pozrikidis; the tangential force is zero here when `κ_R` is uniform along the
    /// surface. See `tests/membrane_grid.rs`.
    ///
    /// `phi` needs its ghosts filled; `fourth`: the fourth-order `∇ψ` of
    /// [`crate::interface::geometry::NormalScheme::Atanh4`] (else the second-order one of `Atanh2`). The
    /// force lives on the faces of `halo(4)`; the cost is a few passes over `halo(3)`.
    ///
    /// # Errors
    /// As [`evaluate`](Self::evaluate).
    pub fn evaluate_variational(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        phi: &Field<T>,
        kappa_r_tilde: &Field<T>,
        fourth: bool,
    ) -> Result<()> {
        self.begin(grid, band)?;
        if phi.data.len() != grid.len() || kappa_r_tilde.data.len() != grid.len() {
            return Err(Error::invalid(
                "phi or kappa_r_tilde",
                "a field of another grid",
                "a field of the band's grid",
            ));
        }
        self.energy.evaluate(grid, band, phi, kappa_r_tilde, self.eb, fourth, &mut self.f);
        self.finish(band, 4)
    }

    /// The discrete bending energy `E_h` of the last
    /// [`evaluate_variational`](Self::evaluate_variational) (0 before one).
    pub fn energy(&self) -> T {
        self.energy.energy
    }

    /// `m̃` of the band cell at `position` (an index into [`Band::cells`]).
    pub fn moment(&self, position: usize) -> Option<Mat3<T>> {
        self.m.get(position).copied()
    }

    /// `q̃` of the cell at `position` of [`Band::halo`]`(1)`.
    pub fn shear_tension(&self, position: usize) -> Option<Vec3<T>> {
        self.q.get(position).copied()
    }

    /// The face force on the three lower faces of the cell at `position` of
    /// [`Band::halo`]`(2)`.
    pub fn face_force(&self, position: usize) -> Option<[T; 3]> {
        self.f.get(position).copied()
    }

    /// The bending force `∇·(q̃ n)` as a [`Forcing`] (it ignores the velocity).
    ///
    /// # Errors
    /// [`Error::Unsupported`] if the last [`evaluate`](Self::evaluate) was not on this band (or
    /// the band was rebuilt since, or the evaluation failed).
    pub fn forcing<'a>(&'a self, band: &'a Band<T>) -> Result<BendingForcing<'a, T>> {
        band.check_generation("BendingStress", self.generation, "evaluated")?;
        Ok(BendingForcing { b: self, band })
    }
}

/// The bending force on the faces (a [`Forcing`]); see [`BendingStress::forcing`].
#[derive(Debug, Clone, Copy)]
pub struct BendingForcing<'a, T> {
    b: &'a BendingStress<T>,
    band: &'a Band<T>,
}

impl<T: Real> Forcing<T> for BendingForcing<'_, T> {
    fn is_active(&self) -> bool {
        !self.band.is_empty()
    }
    /// Adds the force evaluated by [`BendingStress::evaluate`] on the faces of `halo(2)`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `force` if `out` is not a field of the bending's grid.
    fn add(&self, _grid: &Grid<T>, _time: T, _v: &VectorField<T>, out: &mut VectorField<T>) -> Result<()> {
        out.matches(&self.b.grid, "force")?;
        scatter_add(self.band.halo(self.b.face_halo), &self.b.f, out);
        Ok(())
    }
}
