//! The bending force as the exact gradient of a discrete bending energy (not in the paper).
//!
//! The paper's force `∇·(q̃ n)` (2.16)-(2.17) is a chain of four discrete derivatives that is
//! not the derivative of any discrete energy, so nothing bounds the work it does on the fluid
//! by an energy. This module builds the force the other way round. It takes the discrete
//! energy
//!
//! ```text
//! E_h(φ) = Σ_band ½ E_b δ |κ − κ_R P|² h³,     δ = |∇_h φ|,  κ = −P (∇_h n) P,  n = ∇_h ψ/|∇_h ψ|,
//! ```
//!
//! the same quantities as [`super::bending`] (so that `∂E/∂κ = m̃ = E_b (δ κ − κ̃_R P)`, the
//! moment (2.17)), with `ψ = atanh(2φ − 1)` and the reference mean curvature
//! `κ_R = κ̃_R/δ` carried by the material. Its exact derivative with respect to the cell
//! values, `μ = ∂E_h/∂φ / h³` (and `ν = ∂E_h/∂κ_R / h³ = −tr m̃`), gives the force density on
//! the faces
//!
//! ```text
//! f_d(face between c and c + e_d) = ½ Σ_{c, c + e_d} (μ ∂_d φ + ν ∂_d κ_R)      (central ∂_d),
//! ```
//!
//! whose power `Σ f·v h³` is exactly `−dE_h/dt` when `φ` and `κ_R` are transported by
//! `∂_t + v·∇` with central differences and the cell velocity the mean of its faces. The
//! transport of the crate is MTHINC, not that, so the balance holds to the transport's
//! error; but the force can no longer pump energy into the grid scale on its own. In the
//! continuum it is the variational derivative of `∫ ½ E_b |κ − κ_R P|² dA`, the energy whose
//! moment is (2.8): the same force as Pozrikidis' at linear order.
//!
//! Cost: one pass per band layer (the normal on `halo(1)`, the moment on the band, and the
//! adjoint back through the normal, `ψ` and `δ` to `halo(3)`); the face force lives on the
//! faces of `halo(4)`.

use super::band::Band;
use crate::Real;
use crate::grid::{Field, Grid};
use crate::tensor::{Mat3, Vec3};
use rayon::prelude::*;

/// Cells per rayon task.
const MIN_CELLS_PER_TASK: usize = 256;

/// Work arrays of the energy-gradient bending force, sized by the band.
#[derive(Debug, Clone, Default)]
pub(crate) struct EnergyGradient<T> {
    /// `(n, |∇ψ|)` per cell of `halo(1)`.
    normal: Vec<(Vec3<T>, T)>,
    /// Per band cell: `m̃`, `∂e/∂δ`, `∂e/∂n` (own cell) and `ν ∇κ_R`.
    moment: Vec<Mat3<T>>,
    ddelta: Vec<T>,
    dnormal_self: Vec<Vec3<T>>,
    reference_term: Vec<Vec3<T>>,
    /// `∂E/∂∇ψ` per cell of `halo(1)`.
    dgrad: Vec<Vec3<T>>,
    /// `μ` per cell of `halo(3)`.
    mu: Vec<T>,
    /// Energy of the last evaluation (`E_h`).
    pub(crate) energy: T,
}

/// Euclidean length.
#[inline(always)]
fn norm3<T: Real>(g: &Vec3<T>) -> T {
    (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
}

/// Derivative of `psi_of` (0 where `phi` is clamped).
#[inline(always)]
fn dpsi<T: Real>(phi: T) -> T {
    let e = crate::interface::geometry::psi_clamp::<T>();
    if phi > e && phi < T::one() - e { T::lit(0.5) / (phi * (T::one() - phi)) } else { T::zero() }
}

/// First-derivative weights along one axis, `(offset, weight)` (times `1/h`): the second- or
/// fourth-order central difference of [`crate::interface::geometry::NormalScheme::Atanh2`] / `Atanh4`.
fn stencil<T: Real>(fourth: bool) -> ([(isize, T); 4], usize) {
    if fourth {
        let (a, b) = (T::lit(8.0 / 12.0), T::lit(1.0 / 12.0));
        ([(1, a), (-1, -a), (2, -b), (-2, b)], 4)
    } else {
        ([(1, T::lit(0.5)), (-1, T::lit(-0.5)), (0, T::zero()), (0, T::zero())], 2)
    }
}

/// `∇_h φ` at `idx` by second-order central differences (the `δ = |∇_h φ|` of (2.26)).
#[inline(always)]
fn grad_phi<T: Real>(ph: &[T], st: &[isize; 3], h: &[T; 3], axes: usize, idx: usize) -> Vec3<T> {
    let mut g = [T::zero(); 3];
    for d in 0..axes {
        g[d] =
            (ph[idx.wrapping_add_signed(st[d])] - ph[idx.wrapping_add_signed(-st[d])]) * T::lit(0.5) / h[d];
    }
    g
}

/// Strides as signed offsets and the number of axes that are differenced.
fn offsets<T: Real>(grid: &Grid<T>) -> ([isize; 3], usize) {
    let s = grid.strides();
    ([s[0] as isize, s[1] as isize, s[2] as isize], if grid.is_2d() { 2 } else { 3 })
}

impl<T: Real> EnergyGradient<T> {
    /// Evaluates the face force into `f` (per cell of `halo(4)`, its three lower faces), with
    /// `κ_R = κ̃_R/δ`. `phi` must have its ghosts filled; `fourth`: fourth-order `∇ψ` (else
    /// second order).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn evaluate(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        phi: &Field<T>,
        kappa_r_tilde: &Field<T>,
        eb: T,
        fourth: bool,
        f: &mut Vec<[T; 3]>,
    ) {
        let (st, axes) = offsets(grid);
        let h = grid.h();
        let kref = |idx: usize| {
            let d = norm3(&grad_phi(&phi.data, &st, &h, axes, idx));
            if d > T::zero() { kappa_r_tilde.data[idx] / d } else { T::zero() }
        };
        self.evaluate_with(grid, band, phi, &kref, eb, fourth, f);
    }

    /// [`evaluate`](Self::evaluate) with the reference mean curvature field `κ_R` given cell by
    /// cell (storage index).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn evaluate_with(
        &mut self,
        grid: &Grid<T>,
        band: &Band<T>,
        phi: &Field<T>,
        kref: &(dyn Fn(usize) -> T + Sync),
        eb: T,
        fourth: bool,
        f: &mut Vec<[T; 3]>,
    ) {
        let (st, axes) = offsets(grid);
        let h = grid.h();
        let ph = &phi.data;
        let at = |idx: usize, off: isize| idx.wrapping_add_signed(off);
        let (w, nw) = stencil::<T>(fourth);
        let w = &w[..nw];
        let half = T::lit(0.5);
        let grad_phi = |idx: usize| grad_phi(ph, &st, &h, axes, idx);
        let psi = |idx: usize| crate::interface::geometry::psi_of(ph[idx]);

        // 1. n = ∇ψ/|∇ψ| on halo(1).
        let cells1 = band.halo(1);
        self.normal.resize(cells1.len(), ([T::zero(); 3], T::zero()));
        self.normal.par_iter_mut().zip(cells1.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(
            |(out, &idx)| {
                let mut g = [T::zero(); 3];
                for d in 0..axes {
                    for &(o, wo) in w {
                        g[d] += wo * psi(at(idx, o * st[d])) / h[d];
                    }
                }
                let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                *out = if len > T::zero() {
                    ([g[0] / len, g[1] / len, g[2] / len], len)
                } else {
                    ([T::zero(); 3], len)
                };
            },
        );

        // 2. On the band: m̃, ∂e/∂δ, ∂e/∂n (own cell), ν ∇κ_R; the energy.
        let nrm = &self.normal;
        let n_at = |idx: usize| band.position_in(idx, 1).map_or([T::zero(); 3], |p| nrm[p].0);
        let bc = band.cells();
        let nb = bc.len();
        self.moment.resize(nb, [[T::zero(); 3]; 3]);
        self.ddelta.resize(nb, T::zero());
        self.dnormal_self.resize(nb, [T::zero(); 3]);
        self.reference_term.resize(nb, [T::zero(); 3]);
        let energy =
            (self.moment.par_iter_mut(), self.ddelta.par_iter_mut(), self.dnormal_self.par_iter_mut())
                .into_par_iter()
                .zip(self.reference_term.par_iter_mut().zip(bc.par_iter()))
                .with_min_len(MIN_CELLS_PER_TASK)
                .map(|((mo, dd, dn), (rt, &idx))| {
                    let n = n_at(idx);
                    let mut dmat = [[T::zero(); 3]; 3];
                    for i in 0..axes {
                        let (up, dw) = (n_at(at(idx, st[i])), n_at(at(idx, -st[i])));
                        for j in 0..3 {
                            dmat[i][j] = (up[j] - dw[j]) * half / h[i];
                        }
                    }
                    let p: Mat3<T> = std::array::from_fn(|i| {
                        std::array::from_fn(|j| if i == j { T::one() } else { T::zero() } - n[i] * n[j])
                    });
                    let pdp = crate::tensor::matmul(&crate::tensor::matmul(&p, &dmat), &p);
                    let g = grad_phi(idx);
                    let delta = norm3(&g);
                    let kr = kref(idx);
                    // A = κ − κ_R P, κ = −P D P.
                    let a: Mat3<T> =
                        std::array::from_fn(|i| std::array::from_fn(|j| -pdp[i][j] - kr * p[i][j]));
                    let mut a2 = T::zero();
                    for i in 0..3 {
                        for j in 0..3 {
                            a2 += a[i][j] * a[i][j];
                        }
                    }
                    let m: Mat3<T> = std::array::from_fn(|i| std::array::from_fn(|j| eb * delta * a[i][j]));
                    *mo = m;
                    *dd = half * eb * a2;
                    // ∂e/∂n_k = (M Dᵀ n)_k + (Mᵀ D n)_k.
                    let dtn: Vec3<T> =
                        std::array::from_fn(|j| dmat[0][j] * n[0] + dmat[1][j] * n[1] + dmat[2][j] * n[2]);
                    let dn_: Vec3<T> =
                        std::array::from_fn(|i| dmat[i][0] * n[0] + dmat[i][1] * n[1] + dmat[i][2] * n[2]);
                    *dn = std::array::from_fn(|k| {
                        (0..3).fold(T::zero(), |acc, j| acc + m[k][j] * dtn[j] + m[j][k] * dn_[j])
                    });
                    // ν ∇κ_R with ν = −tr m̃ (central).
                    let nu = -(m[0][0] + m[1][1] + m[2][2]);
                    let mut gk = [T::zero(); 3];
                    for d in 0..axes {
                        gk[d] = (kref(at(idx, st[d])) - kref(at(idx, -st[d]))) * half / h[d];
                    }
                    *rt = std::array::from_fn(|d| nu * gk[d]);
                    half * eb * delta * a2
                })
                .reduce(T::zero, |x, y| x + y);
        self.energy = energy * h[0] * h[1] * h[2];

        // 3. ∂E/∂∇ψ on halo(1): gather ∂e/∂n from the band, then project.
        let (mom, dns) = (&self.moment, &self.dnormal_self);
        self.dgrad.resize(cells1.len(), [T::zero(); 3]);
        self.dgrad
            .par_iter_mut()
            .zip(cells1.par_iter().zip(nrm.par_iter()))
            .with_min_len(MIN_CELLS_PER_TASK)
            .for_each(|(out, (&idx, &(n, len)))| {
                let mut gn = match band.position_in(idx, 0) {
                    Some(b) => dns[b],
                    None => [T::zero(); 3],
                };
                for i in 0..axes {
                    // This cell is the +e_i neighbour of idx − e_i and the −e_i one of idx + e_i.
                    if let Some(b) = band.position_in(at(idx, -st[i]), 0) {
                        for j in 0..3 {
                            gn[j] -= mom[b][i][j] * half / h[i];
                        }
                    }
                    if let Some(b) = band.position_in(at(idx, st[i]), 0) {
                        for j in 0..3 {
                            gn[j] += mom[b][i][j] * half / h[i];
                        }
                    }
                }
                if len > T::zero() {
                    let ng = n[0] * gn[0] + n[1] * gn[1] + n[2] * gn[2];
                    *out = std::array::from_fn(|k| (gn[k] - ng * n[k]) / len);
                } else {
                    *out = [T::zero(); 3];
                }
            });

        // 4. μ = ∂E/∂φ on halo(3): through ψ (∇ψ stencil) and through δ.
        let (dg, dd) = (&self.dgrad, &self.ddelta);
        let cells3 = band.halo(3);
        self.mu.resize(cells3.len(), T::zero());
        self.mu.par_iter_mut().zip(cells3.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(
            |(out, &idx)| {
                let mut gpsi = T::zero();
                for d in 0..axes {
                    for &(o, wo) in w {
                        // G(c') = Σ_o w_o ψ(c' + o e_d)/h: this cell is c' + o e_d.
                        if let Some(p) = band.position_in(at(idx, -o * st[d]), 1) {
                            gpsi += wo * dg[p][d] / h[d];
                        }
                    }
                }
                let mut g = gpsi * dpsi(ph[idx]);
                for i in 0..axes {
                    for (sign, off) in [(T::one(), -st[i]), (-T::one(), st[i])] {
                        if let Some(b) = band.position_in(at(idx, off), 0) {
                            let c = at(idx, off);
                            let gp = grad_phi(c);
                            let delta = norm3(&gp);
                            if delta > T::zero() {
                                g += sign * dd[b] * gp[i] / delta * half / h[i];
                            }
                        }
                    }
                }
                *out = g;
            },
        );

        // 5. Faces of halo(4): f_d = ½ Σ (μ ∂_d φ + ν ∂_d κ_R) over the two cells.
        let (mu, rt) = (&self.mu, &self.reference_term);
        let cell_term = |idx: usize, d: usize| -> T {
            let mut t = T::zero();
            if let Some(p) = band.position_in(idx, 3) {
                t += mu[p] * (ph[at(idx, st[d])] - ph[at(idx, -st[d])]) * half / h[d];
            }
            if let Some(b) = band.position_in(idx, 0) {
                t += rt[b][d];
            }
            t
        };
        let cells4 = band.halo(4);
        f.resize(cells4.len(), [T::zero(); 3]);
        f.par_iter_mut().zip(cells4.par_iter()).with_min_len(MIN_CELLS_PER_TASK).for_each(|(out, &idx)| {
            *out = std::array::from_fn(|d| {
                if d < axes { half * (cell_term(idx, d) + cell_term(at(idx, -st[d]), d)) } else { T::zero() }
            });
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interface::geometry::delta_at;

    /// `μ = ∂E_h/∂φ / h³` against central finite differences of the energy, on an ellipsoid
    /// with a reference curvature field of another shape (the moment is far from zero).
    #[test]
    fn mu_is_the_derivative_of_the_energy() {
        let n = 20;
        let grid = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
        let h = 1.0 / n as f64;
        let mut phi = Field::from_cell_fn(&grid, |x| {
            let r = ((x[0] - 0.5).powi(2) / 1.2 + (x[1] - 0.5).powi(2) + (x[2] - 0.52).powi(2) / 0.8).sqrt();
            0.5 * (1.0 + ((0.25 - r) / h).tanh())
        });
        phi.fill_ghosts(&grid);
        let kref = |idx: usize| -> f64 {
            let k = idx as f64;
            3.0 + (0.37 * k).sin()
        };
        let mut band = Band::new(&grid, 0.01).unwrap();
        let mut delta = Field::zeros(&grid);
        for (i, j, k) in grid.cells() {
            let idx = grid.idx_u(i, j, k);
            delta.data[idx] = delta_at(&grid, &phi, idx);
        }
        band.rebuild(&grid, &delta).unwrap();
        for fourth in [false, true] {
            let mut e = EnergyGradient::default();
            let mut f = Vec::new();
            e.evaluate_with(&grid, &band, &phi, &kref, 0.1, fourth, &mut f);
            let mu = e.mu.clone();
            let scale = mu.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let mut worst = 0.0f64;
            // Every 7th cell of halo(3): band, edge and outer cells alike.
            for (p, &idx) in band.halo(3).iter().enumerate().step_by(7) {
                // A step relative to phi (1 - phi): psi = atanh(2 phi - 1) is steep where phi is small.
                let eps = 1e-4 * phi.data[idx] * (1.0 - phi.data[idx]);
                let energy = |d: f64| {
                    let mut ph = phi.clone();
                    ph.data[idx] += d;
                    ph.fill_ghosts(&grid);
                    let mut e2 = EnergyGradient::default();
                    e2.evaluate_with(&grid, &band, &ph, &kref, 0.1, fourth, &mut Vec::new());
                    e2.energy
                };
                let fd = (energy(eps) - energy(-eps)) / (2.0 * eps) / h.powi(3);
                worst = worst.max((fd - mu[p]).abs());
            }
            assert!(worst < 1e-5 * scale, "fourth={fourth}: |fd - mu| = {worst:.3e}, max |mu| = {scale:.3e}");
        }
    }

    /// The power of the face force, `Σ f·v h³`, equals `−dE_h/dt` when `φ` and `κ_R` move by
    /// `∂_t + v·∇` (central differences, cell velocity the mean of its faces).
    #[test]
    fn face_force_power_balances_the_energy_rate() {
        let n = 20;
        let grid = Grid::<f64>::periodic([n; 3], [0.0; 3], [1.0; 3]).unwrap();
        let h = 1.0 / n as f64;
        let st = grid.strides();
        let mut phi = Field::from_cell_fn(&grid, |x| {
            let r = ((x[0] - 0.5).powi(2) / 1.2 + (x[1] - 0.5).powi(2) + (x[2] - 0.52).powi(2) / 0.8).sqrt();
            0.5 * (1.0 + ((0.25 - r) / h).tanh())
        });
        phi.fill_ghosts(&grid);
        let mut kappa = Field::from_cell_fn(&grid, |x| 4.0 + (6.0 * x[0]).sin() * (5.0 * x[2]).cos());
        kappa.fill_ghosts(&grid);
        let tau = std::f64::consts::TAU;
        let vel = |d: usize, x: [f64; 3]| {
            (tau * (x[(d + 1) % 3] + 0.1)).sin()
                + 0.5 * (tau * x[(d + 2) % 3]).cos()
                + 0.3 * (tau * x[d]).sin()
        };
        // Face velocity on the lower face of cell (i, j, k) along d.
        let face_v = |d: usize, i: isize, j: isize, k: isize| vel(d, grid.face_center(d, i, j, k));
        let mut delta = Field::zeros(&grid);
        let (mut dphi, mut dkap) = (Field::zeros(&grid), Field::zeros(&grid));
        for (i, j, k) in grid.cells() {
            let idx = grid.idx_u(i, j, k);
            delta.data[idx] = delta_at(&grid, &phi, idx);
            let (i, j, k) = (i as isize, j as isize, k as isize);
            let up = [(i + 1, j, k), (i, j + 1, k), (i, j, k + 1)];
            let (mut a, mut b) = (0.0, 0.0);
            for d in 0..3 {
                let vc = 0.5 * (face_v(d, i, j, k) + face_v(d, up[d].0, up[d].1, up[d].2));
                a -= vc * (phi.data[idx + st[d]] - phi.data[idx - st[d]]) / (2.0 * h);
                b -= vc * (kappa.data[idx + st[d]] - kappa.data[idx - st[d]]) / (2.0 * h);
            }
            dphi.data[idx] = a;
            dkap.data[idx] = b;
        }
        let mut band = Band::new(&grid, 0.01).unwrap();
        band.rebuild(&grid, &delta).unwrap();
        let mut e = EnergyGradient::default();
        let mut f = Vec::new();
        let k0 = |idx: usize| kappa.data[idx];
        e.evaluate_with(&grid, &band, &phi, &k0, 0.1, true, &mut f);
        let mut power = 0.0;
        for (p, c) in band.coords(4).iter().enumerate() {
            let (i, j, k) = (c[0] as isize, c[1] as isize, c[2] as isize);
            for d in 0..3 {
                power += f[p][d] * face_v(d, i, j, k) * h.powi(3);
            }
        }
        let energy = |t: f64| {
            let mut ph = phi.clone();
            let mut ka = kappa.clone();
            for (x, y) in ph.data.iter_mut().zip(&dphi.data) {
                *x += t * y;
            }
            for (x, y) in ka.data.iter_mut().zip(&dkap.data) {
                *x += t * y;
            }
            ph.fill_ghosts(&grid);
            ka.fill_ghosts(&grid);
            let kk = |idx: usize| ka.data[idx];
            let mut e2 = EnergyGradient::default();
            e2.evaluate_with(&grid, &band, &ph, &kk, 0.1, true, &mut Vec::new());
            e2.energy
        };
        let t = 1e-7;
        let rate = (energy(t) - energy(-t)) / (2.0 * t);
        assert!(power.abs() > 1e-3 * e.energy, "a velocity that changes the energy: power {power:.3e}");
        assert!((power + rate).abs() < 1e-6 * power.abs(), "power {power:.6e}, -dE/dt {:.6e}", -rate);
    }
}
