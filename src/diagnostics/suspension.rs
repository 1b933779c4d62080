//! Suspension diagnostics for many capsules: the particle stress of the membranes (Batchelor
//! 1970), the effective viscosity of a sheared suspension from the walls and from the particle
//! stress, the normal stress differences, the deformation and orientation of every capsule, and
//! the cell-free layer of a channel.
//!
//! # The particle stress
//!
//! The fluid obeys `rho Dv/Dt = div sigma + f` with `sigma = -p I + mu(x) (grad v + grad v^T)`,
//! viscosity `mu` outside the capsules and `lambda mu` inside, and `f` the force density (per
//! unit volume) that the membranes exert **on the fluid**: in this crate the face force an
//! [`Effect`](crate::simulation::effect::Effect) adds, e.g. `f = div(delta tau)` of the in-plane
//! elasticity ([`crate::membrane::force`]). For Stokes flow of force-free particles, Batchelor
//! (1970) writes the bulk stress of a volume `V` as
//!
//! ```text
//! <sigma> = -<p> I + mu <grad v + grad v^T> + Sigma_p,      Sigma_p = (1/V) sum_c S_c,
//! S_c = int_{A_c} [ sym((sigma . n) (x - x_c)) - mu (v n + n v) ] dA       (n outward, sigma outside)
//! ```
//!
//! For a capsule, the membrane's balance `(sigma_out - sigma_in) . n = -f_s` (`f_s`: the force per
//! unit area the membrane exerts on the fluid, `f = f_s delta_s`), Stokes flow inside
//! (`div sigma_in = 0`, `sigma_in = -p I + lambda mu (grad v + grad v^T)`) and the divergence
//! theorem turn the surface integral into
//!
//! ```text
//! S_c = - int sym((x - x_c) (x) f) dV  +  (lambda - 1) mu int_{V_c} (grad v + grad v^T) dV  -  (int_{V_c} p dV) I
//! ```
//!
//! (Ramanujan & Pozrikidis 1998; Pozrikidis 1992, ch. 7; Bagchi & Kalluri 2010 write the same
//! with the traction jump `Delta f = -f_s`). The isotropic last term is absorbed into the mean
//! pressure and **not** computed: only the deviatoric part of `Sigma_p` has a meaning in an
//! incompressible suspension (the shear stress and the normal stress differences below do not
//! depend on it). `x_c` is the centroid (3.5); it is immaterial for a force-free capsule, and
//! [`CapsuleStresslet::force`] and [`CapsuleStresslet::torque`] report how force- and
//! torque-free the given force is.
//!
//! The same result in the one-fluid terms of the grid: with the mixture
//! `mu(x) = mu + (mu_in - mu) sum_c phi_c` (2.25) and `f = sum_c div(delta_c tau_c)`, the volume
//! average of the total stress `sigma + sum_c delta_c tau_c` is `-<p> I + mu <grad v + grad v^T>`
//! plus `(1/V) sum_c [int delta_c tau_c dV + (mu_in - mu) int phi_c (grad v + grad v^T) dV]`, and
//! `int delta tau dV = -int x (x) div(delta tau) dV` by parts (compact support): the two terms
//! above.
//!
//! **What is computed** ([`particle_stress`]), all in `f64`, for each capsule `c`:
//!
//! ```text
//! S_c^m = - sym(M_c),   M_c[a][b] = sum_{faces of component b owned by c} r_a f_b dx dy dz,
//!                       r = minimum image of (x_face - x_c) on periodic axes
//! S_c^v = (mu_in - mu_out) sum_cells clamp(phi_c, 0, 1) (grad_h v + grad_h v^T) dx dy dz
//! Sigma_p = (1/V) sum_c (S_c^m + S_c^v),       V = the box volume
//! ```
//!
//! with `grad_h v` the cell-centred velocity gradient of the membrane mechanics
//! ([`grad_v_at_cell`]), `S_c^v` only when a [`ViscosityContrast`] is given (it is zero for
//! `lambda = 1`). Component `b` of `f` lives on the lower faces normal to `b` at
//! [`Grid::face_center`]; faces on a wall are skipped (the solver ignores them). For the crate's
//! in-plane force, whose face divergence is the exact negative adjoint of the cell-centred
//! gradient, `S_c^m` is the discrete `sum delta tau dx dy dz` **to round-off** (tested below), so
//! the membrane part is exactly the stress the membrane carries in the discrete model. Its
//! antisymmetric part is reported as the torque `sum r x f dV`.
//!
//! **Which capsule a face belongs to.** The caller passes one force field (the sum over the
//! capsules) and every capsule's `phi`. A face with a non-zero force goes to the capsule whose
//! interface is nearest, measured by `q_c = |ln(phi_c / (1 - phi_c))|` of `phi_c` averaged over
//! the two cells that share the face (for the profile of the smoothed VOF function,
//! `phi = sigma(2 beta s / h)`, `q` is `2 beta |s| / h`, the distance `s` to the surface
//! `phi = 1/2` in units of the interface width, the same for every capsule). Where capsules
//! are apart, the force around capsule `c`'s band (a few cells from its `phi = 1/2`, where
//! `phi_c` is far from 0 and 1 and every other `phi` saturated) is `c`'s. Ties go to the lower
//! index. A face at which every capsule has `phi < 1e-9` or `phi > 1 - 1e-9` (about ten cells
//! from every surface at `beta = 1`; exactly 0 or 1 counts as saturated) is owned by none: its
//! force is reported in [`ParticleStress::unassigned_force`] and left out. Faces where two
//! capsules or more have `1e-6 <= phi <= 1 - 1e-6` (shells within about seven cells of each
//! other) are counted in [`ParticleStress::shared_faces`]: there the split is by distance
//! only, and the per-capsule stresslets mix (their sum does not, for force-free capsules).
//!
//! Periodic boxes: `r` is wrapped into `[-L/2, L/2)` about each centroid, as in the
//! [module docs](super); each capsule must span less than half the period.
//!
//! # Effective viscosity of a sheared suspension
//!
//! In a shear frame ([`ShearFrame`]: flow axis `x`, gradient axis `y`, vorticity axis `z`, any
//! permutation of the grid axes):
//!
//! - from the particle stress ([`ParticleStress::shear_rheology`]):
//!   `mu_eff = mu (1 + Sigma_xy / (mu gamma_dot)) = mu + Sigma_xy / gamma_dot`,
//!   `N1 = Sigma_xx - Sigma_yy`, `N2 = Sigma_yy - Sigma_zz` (the solvent's `mu <grad v + grad
//!   v^T>` has no normal stress differences in a mean simple shear);
//! - from the walls of a Couette box ([`wall_shear_stress`]): the walls are normal to the
//!   gradient axis and slide along the flow axis (which must be periodic) at `U_lo` and `U_hi`;
//!   the applied shear rate is `gamma_dot = (U_hi - U_lo) / H` ([`couette_shear_rate`], `H` the
//!   wall distance); on each wall the shear stress `sigma_xy = mu du/dy` (`dv/dx = 0` on a
//!   no-slip wall) is averaged over the wall, with the scheme's own wall flux (that of the
//!   viscous operator, [`crate::fluid::momentum`], with the ghost `2 U_wall - u`):
//!
//!   ```text
//!   sigma_xy(lower) = mean_{i,k} mu_e (u_{i,0,k} - U_lo) / (h_y / 2)
//!   sigma_xy(upper) = mean_{i,k} mu_e (U_hi - u_{i,n-1,k}) / (h_y / 2)
//!   mu_e = (mu_{i-1} + mu_i) / 2 of the cells next to the wall (the edge viscosity there)
//!   mu_eff = (sigma_xy(lower) + sigma_xy(upper)) / (2 gamma_dot)
//!   ```
//!
//!   `y` increases from the lower wall to the upper one, so both stresses have the sign of
//!   `gamma_dot` in a Couette flow. The derivative is one-sided (first order at a curved
//!   profile, exact for a linear one), but it is the flux the scheme applies, so at a steady
//!   state the plane-averaged momentum balance makes it exact: summing the discrete x-momentum
//!   over planes, weighted by `y`, gives `sigma_xy(wall) = mu gamma_dot + Sigma_xy` for a
//!   force-free, torque-free membrane force at `lambda = 1` up to inertia (`-rho <u' v'>`),
//!   which the test `the_two_viscosities_agree_at_a_steady_stokes_state` checks. (On the upper
//!   wall the flow solver currently takes the edge viscosity of the edge one cell below, not
//!   `mu_e` above; the two differ only where the viscosity varies next to that wall, a capsule
//!   within a few cells of it.)
//!
//! # Shapes and the cell-free layer
//!
//! [`capsule_shapes`] gives every capsule's centroid, volume, Taylor deformation `D` and
//! inclination of its section in the flow-gradient plane ([`taylor_deformation`]) and its
//! ellipsoid of inertia ([`ellipsoid_fit`], 3D grids). [`cell_free_layer`] measures, for a
//! channel, the distance from each wall to the nearest point where some capsule has
//! `phi >= 1/2`, line by line across the channel, averaged over the wall (Fedosov et al. 2010
//! define the cell-free layer from the outer edge of the red cells in the same way).
//!
//! # References
//! - G. K. Batchelor, *The stress system in a suspension of force-free particles*, J. Fluid
//!   Mech. 41 (1970) 545-570.
//! - C. Pozrikidis, *Boundary Integral and Singularity Methods for Linearized Viscous Flow*,
//!   Cambridge University Press (1992), ch. 7.
//! - S. Ramanujan & C. Pozrikidis, *Deformation of liquid capsules enclosed by elastic
//!   membranes in simple shear flow*, J. Fluid Mech. 361 (1998) 117-143.
//! - P. Bagchi & R. M. Kalluri, *Rheology of a dilute suspension of liquid-filled elastic
//!   capsules*, Phys. Rev. E 81 (2010) 056320.
//! - D. A. Fedosov, B. Caswell, A. S. Popel & G. E. Karniadakis, *Blood flow and cell-free
//!   layer in microvessels*, Microcirculation 17 (2010) 615-628.
//!
//! # Getting the membrane force of a state
//!
//! [`Simulation::membrane_force`](crate::simulation::Simulation::membrane_force) adds the force
//! density of the membranes at the current state (elasticity, bending and contact, through the
//! sharp traction's spreading where it is used) to a staggered field of the grid: the force
//! whose first moment [`particle_stress`] takes.

use super::ellipsoid::{EllipsoidFit, ellipsoid_fit};
use super::reduce::{check_field, check_vector, frames, reduce_cells};
use super::taylor::{TaylorDeformation, section_axes, taylor_deformation};
use super::volume::{centroid, volume};
use crate::fluid::momentum::Coefficient;
use crate::grid::ops::grad_v_at_cell;
use crate::grid::{Field, Grid, VectorField};
use crate::tensor::Mat3;
use crate::{Error, Real, Result};

/// A face whose every capsule has `phi` outside `[UNASSIGNED_PHI, 1 - UNASSIGNED_PHI]` is owned
/// by none.
const UNASSIGNED_PHI: f64 = 1e-9;
/// Faces where two capsules or more have `phi` within `[SHARED_PHI, 1 - SHARED_PHI]` are shared.
const SHARED_PHI: f64 = 1e-6;

/// `|ln(p / (1 - p))|` at `p`: the distance proxy of the ownership rule.
fn logit_distance(p: f64) -> f64 {
    if p > 0.0 && p < 1.0 { (p.ln() - (-p).ln_1p()).abs() } else { f64::INFINITY }
}

/// The flow, gradient and vorticity axes of a simple shear (see the [module docs](self)).
///
/// ```
/// use eulermembrane::diagnostics::suspension::ShearFrame;
/// // Flow along x, velocity gradient along z (the shear box of Sec. 3.3): vorticity along y.
/// let frame = ShearFrame::new(0, 2)?;
/// assert_eq!((frame.flow(), frame.gradient(), frame.vorticity()), (0, 2, 1));
/// assert!(ShearFrame::new(1, 1).is_err() && ShearFrame::new(3, 0).is_err());
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShearFrame {
    flow: usize,
    gradient: usize,
}

impl ShearFrame {
    /// The frame with the flow along `flow_axis` and the velocity gradient along
    /// `gradient_axis`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `flow_axis` or `gradient_axis` for an axis above 2,
    /// naming `gradient_axis` when it equals the flow axis.
    pub fn new(flow_axis: usize, gradient_axis: usize) -> Result<Self> {
        if flow_axis > 2 {
            return Err(Error::invalid("flow_axis", flow_axis, "0, 1 or 2"));
        }
        if gradient_axis > 2 {
            return Err(Error::invalid("gradient_axis", gradient_axis, "0, 1 or 2"));
        }
        if gradient_axis == flow_axis {
            return Err(Error::invalid(
                "gradient_axis",
                format!("{gradient_axis}, the flow axis too"),
                "an axis other than the flow axis",
            ));
        }
        Ok(ShearFrame { flow: flow_axis, gradient: gradient_axis })
    }

    /// The flow axis `x`.
    pub fn flow(&self) -> usize {
        self.flow
    }

    /// The gradient axis `y`.
    pub fn gradient(&self) -> usize {
        self.gradient
    }

    /// The vorticity axis `z`, the third one.
    pub fn vorticity(&self) -> usize {
        3 - self.flow - self.gradient
    }
}

/// The viscosities inside and outside the capsules and the velocity, for the contrast term
/// `(mu_in - mu_out) int phi_c (grad v + grad v^T) dV` of the particle stress (see the
/// [module docs](self)).
#[derive(Debug, Clone, Copy)]
pub struct ViscosityContrast<'a, T> {
    /// The velocity (staggered, one ghost layer filled, as
    /// [`Simulation::velocity`](crate::simulation::Simulation::velocity) has it).
    pub velocity: &'a VectorField<T>,
    /// Viscosity `mu` of the suspending fluid.
    pub mu_outside: f64,
    /// Viscosity `lambda mu` inside the capsules.
    pub mu_inside: f64,
}

/// The stresslet of one capsule (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CapsuleStresslet {
    /// Centroid `x_c` (3.5), inside the box.
    pub centroid: [f64; 3],
    /// Volume `sum phi dV`.
    pub volume: f64,
    /// The membrane part `S_c^m = -sum sym(r (x) f) dV` over the capsule's faces.
    pub membrane: Mat3<f64>,
    /// The viscosity-contrast part `S_c^v = (mu_in - mu_out) sum phi_c (grad v + grad v^T) dV`
    /// (zero without a [`ViscosityContrast`]).
    pub viscous: Mat3<f64>,
    /// Net force `sum f dV` on the capsule's faces (zero for a free capsule).
    pub force: [f64; 3],
    /// Net torque `sum r x f dV` about the centroid (the antisymmetric part of the first moment;
    /// zero for a torque-free membrane force).
    pub torque: [f64; 3],
    /// Faces with a non-zero force that the capsule owns.
    pub faces: usize,
}

impl CapsuleStresslet {
    /// The stresslet `S_c = S_c^m + S_c^v` (without its undetermined isotropic pressure part).
    pub fn stresslet(&self) -> Mat3<f64> {
        std::array::from_fn(|a| std::array::from_fn(|b| self.membrane[a][b] + self.viscous[a][b]))
    }
}

/// The particle stress of a suspension and its parts (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleStress {
    /// One stresslet per capsule, in the order of the `phis` given.
    pub capsules: Vec<CapsuleStresslet>,
    /// `Sigma_p = (1/V) sum_c S_c`, symmetric; its isotropic part is not meaningful.
    pub stress: Mat3<f64>,
    /// The box volume `V`.
    pub box_volume: f64,
    /// `sum_c V_c / V`.
    pub volume_fraction: f64,
    /// `sum |f| dV` (component by component) over every face with a force.
    pub total_force: f64,
    /// `sum |f| dV` over the faces owned by no capsule, left out of `stress`.
    pub unassigned_force: f64,
    /// Faces with a non-zero force near two capsules or more, split by distance only.
    pub shared_faces: usize,
}

/// What the particle stress says about a simple shear (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShearRheology {
    /// The applied shear rate `gamma_dot`.
    pub shear_rate: f64,
    /// The particle shear stress `Sigma_xy`.
    pub shear_stress: f64,
    /// `mu_eff = mu + Sigma_xy / gamma_dot`.
    pub viscosity: f64,
    /// `mu_eff / mu`.
    pub relative_viscosity: f64,
    /// First normal stress difference `N1 = Sigma_xx - Sigma_yy`.
    pub n1: f64,
    /// Second normal stress difference `N2 = Sigma_yy - Sigma_zz`.
    pub n2: f64,
}

impl ParticleStress {
    /// The effective viscosity `mu + Sigma_xy / gamma_dot` and the normal stress differences in
    /// `frame`, for a suspending fluid of viscosity `mu` sheared at `shear_rate` (for a Couette
    /// box, [`couette_shear_rate`]).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `mu` unless it is finite and `> 0`, naming
    /// `shear_rate` unless it is finite and not zero.
    ///
    /// ```
    /// use eulermembrane::diagnostics::suspension::{ParticleStress, ShearFrame};
    /// // A particle stress with Sigma_xz = 0.1, Sigma_xx = 0.05 in a shear along x, z.
    /// let mut s = [[0.0; 3]; 3];
    /// (s[0][2], s[2][0], s[0][0]) = (0.1, 0.1, 0.05);
    /// let p = ParticleStress {
    ///     capsules: vec![],
    ///     stress: s,
    ///     box_volume: 1.0,
    ///     volume_fraction: 0.0,
    ///     total_force: 0.0,
    ///     unassigned_force: 0.0,
    ///     shared_faces: 0,
    /// };
    /// let r = p.shear_rheology(ShearFrame::new(0, 2)?, 2.0, 0.5)?;
    /// assert!((r.viscosity - 2.2).abs() < 1e-15 && (r.relative_viscosity - 1.1).abs() < 1e-15);
    /// assert_eq!((r.n1, r.n2), (0.05, 0.0));
    /// assert!(p.shear_rheology(ShearFrame::new(0, 2)?, 2.0, 0.0).is_err());
    /// # Ok::<(), eulermembrane::Error>(())
    /// ```
    pub fn shear_rheology(&self, frame: ShearFrame, mu: f64, shear_rate: f64) -> Result<ShearRheology> {
        if !(mu.is_finite() && mu > 0.0) {
            return Err(Error::invalid("mu", mu, "a finite number > 0"));
        }
        if !(shear_rate.is_finite() && shear_rate != 0.0) {
            return Err(Error::invalid("shear_rate", shear_rate, "a finite number other than 0"));
        }
        let (x, y, z) = (frame.flow(), frame.gradient(), frame.vorticity());
        let s = &self.stress;
        let shear_stress = 0.5 * (s[x][y] + s[y][x]);
        let viscosity = mu + shear_stress / shear_rate;
        Ok(ShearRheology {
            shear_rate,
            shear_stress,
            viscosity,
            relative_viscosity: viscosity / mu,
            n1: s[x][x] - s[y][y],
            n2: s[y][y] - s[z][z],
        })
    }
}

/// The particle stress `Sigma_p = (1/V) sum_c S_c` of the capsules `phis` from the membrane
/// force density `force` on the faces (the force on the fluid, all capsules summed), with the
/// viscosity-contrast term when `contrast` is given (see the [module docs](self) for the
/// formulas, the ownership rule and the periodic images).
///
/// # Errors
/// - [`Error::InvalidParameter`] naming `force` or `velocity` for a field of another grid,
///   naming `phis` for a `phi` of another grid or without a capsule (its index in the value),
///   naming `mu_outside` or `mu_inside` unless they are finite and `> 0`;
/// - [`Error::NonFinite`] naming the component of `force` or `velocity`, or `phi`, and the
///   first cell that holds a NaN or an infinity.
///
/// # Example
///
/// A capsule in a Couette box, after a few steps, with its membrane force from
/// [`Simulation::membrane_force`](crate::simulation::Simulation::membrane_force):
///
/// ```
/// use eulermembrane::diagnostics::suspension::{
///     ShearFrame, couette_shear_rate, particle_stress, wall_shear_stress,
/// };
/// use eulermembrane::grid::{Boundary, Grid, VectorField};
/// use eulermembrane::interface::shapes::Sphere;
/// use eulermembrane::membrane::law::NeoHookean;
/// use eulermembrane::simulation::{Phase, Scene};
///
/// // Walls at z = -1 and z = 1 sliding at -1 and +1 along x: shear rate 1.
/// let mut bc = [[Boundary::Periodic; 2]; 3];
/// bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
/// let grid = Grid::<f64>::new([24, 16, 24], [-1.5, -1.0, -1.0], [1.5, 1.0, 1.0], bc)?;
/// let law = NeoHookean::new(10.0)?;
/// let mut sim = Scene::new(grid.clone(), Phase::new(1.0, 1.0)?)
///     .capsule(Sphere::new([0.0; 3], 0.4)?)
///     .elasticity(law)
///     .build()?;
/// sim.set_velocity(|x| [x[2], 0.0, 0.0])?;
/// for _ in 0..10 {
///     sim.step(5e-3)?;
/// }
///
/// // The membrane force div(delta tau) of the current state, on the faces.
/// let mut force = VectorField::zeros(&grid);
/// sim.membrane_force(5e-3, &mut force)?;
///
/// let frame = ShearFrame::new(0, 2)?; // flow along x, gradient along z
/// let stress = particle_stress(&grid, &force, &[sim.phi(0)?], None)?;
/// let c = &stress.capsules[0];
/// assert!(c.force.iter().all(|f| f.abs() < 1e-10) && stress.unassigned_force == 0.0);
/// let rate = couette_shear_rate(&grid, frame)?;
/// let rheology = stress.shear_rheology(frame, 1.0, rate)?;
/// // The membrane, stretched along the extensional axis, thickens the suspension.
/// assert!(rheology.shear_stress > 0.0 && rheology.viscosity > 1.0);
/// // The walls' view (not yet at a steady state after ten steps).
/// let wall = wall_shear_stress(&grid, sim.velocity(), &sim.flow().materials().mu, frame)?;
/// assert!(wall.viscosity > 0.9 && wall.viscosity < 1.2);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn particle_stress<T: Real>(
    grid: &Grid<T>,
    force: &VectorField<T>,
    phis: &[&Field<T>],
    contrast: Option<&ViscosityContrast<'_, T>>,
) -> Result<ParticleStress> {
    check_vector(grid, "force", force)?;
    if let Some((d, cell)) = force.first_non_finite(grid) {
        return Err(Error::NonFinite { field: ["force.x", "force.y", "force.z"][d], cell });
    }
    for (c, phi) in phis.iter().enumerate() {
        check_phi(grid, c, phi)?;
    }
    if let Some(k) = contrast {
        check_vector(grid, "velocity", k.velocity)?;
        for (name, mu) in [("mu_outside", k.mu_outside), ("mu_inside", k.mu_inside)] {
            if !(mu.is_finite() && mu > 0.0) {
                return Err(Error::invalid(name, mu, "a finite number > 0"));
            }
        }
        if let Some((d, cell)) = k.velocity.first_non_finite(grid) {
            return Err(Error::NonFinite { field: ["velocity.x", "velocity.y", "velocity.z"][d], cell });
        }
    }
    let dv = grid.cell_volume().f64();
    let mut centres = Vec::with_capacity(phis.len());
    let mut volumes = Vec::with_capacity(phis.len());
    for (c, phi) in phis.iter().enumerate() {
        centres.push(centroid(grid, phi).map_err(|e| name_capsule(e, c))?);
        volumes.push(volume(grid, phi).map_err(|e| name_capsule(e, c))?);
    }
    let moments = face_moments(grid, force, phis, &centres);
    let viscous = match contrast {
        Some(k) => contrast_integrals(grid, k, phis),
        None => vec![[0.0; 6]; phis.len()],
    };
    let box_volume: f64 = (0..3).map(|d| grid.upper()[d].f64() - grid.lower()[d].f64()).product();
    let mut stress = [[0.0; 3]; 3];
    let mut capsules = Vec::with_capacity(phis.len());
    for c in 0..phis.len() {
        let m = &moments.caps[c];
        let first: Mat3<f64> = std::array::from_fn(|a| std::array::from_fn(|b| m[3 * a + b] * dv));
        let membrane: Mat3<f64> =
            std::array::from_fn(|a| std::array::from_fn(|b| -0.5 * (first[a][b] + first[b][a])));
        let e = &viscous[c];
        let viscous: Mat3<f64> =
            std::array::from_fn(|a| std::array::from_fn(|b| e[crate::tensor::sym_index(a, b)] * dv));
        let torque = [first[1][2] - first[2][1], first[2][0] - first[0][2], first[0][1] - first[1][0]];
        let cap = CapsuleStresslet {
            centroid: centres[c],
            volume: volumes[c],
            membrane,
            viscous,
            force: [m[9] * dv, m[10] * dv, m[11] * dv],
            torque,
            faces: moments.faces[c],
        };
        let s = cap.stresslet();
        for a in 0..3 {
            for b in 0..3 {
                stress[a][b] += s[a][b] / box_volume;
            }
        }
        capsules.push(cap);
    }
    Ok(ParticleStress {
        capsules,
        stress,
        box_volume,
        volume_fraction: volumes.iter().sum::<f64>() / box_volume,
        total_force: moments.total * dv,
        unassigned_force: moments.unassigned * dv,
        shared_faces: moments.shared,
    })
}

/// Checks one capsule's `phi`: on the grid (named `phis` with its index), finite.
fn check_phi<T: Real>(grid: &Grid<T>, c: usize, phi: &Field<T>) -> Result<()> {
    check_field(grid, "phi", phi).map_err(|e| name_capsule(e, c))?;
    if let Some(cell) = phi.first_non_finite(grid) {
        return Err(Error::NonFinite { field: "phi", cell });
    }
    Ok(())
}

/// Renames an [`Error::InvalidParameter`] about one `phi` to `phis`, with the capsule's index.
fn name_capsule(e: Error, c: usize) -> Error {
    match e {
        Error::InvalidParameter { value, allowed, .. } => {
            Error::InvalidParameter { name: "phis", value: format!("phis[{c}]: {value}"), allowed }
        }
        other => other,
    }
}

/// The per-capsule sums of the face pass, in units of one cell volume.
#[derive(Debug, Clone)]
struct FaceSums {
    /// Per capsule: `M[a][b]` at `3 a + b` (`sum r_a f_b`), then `sum f` at 9..12.
    caps: Vec<[f64; 12]>,
    faces: Vec<usize>,
    total: f64,
    unassigned: f64,
    shared: usize,
}

/// The first moments of the face forces per owning capsule (see the [module docs](self)).
fn face_moments<T: Real>(
    grid: &Grid<T>,
    force: &VectorField<T>,
    phis: &[&Field<T>],
    centres: &[[f64; 3]],
) -> FaceSums {
    let n = grid.n();
    let st = grid.strides();
    let h = grid.h().map(|x| x.f64());
    let wall = [0, 1, 2].map(|d| !grid.is_periodic(d));
    // Per capsule and axis: offsets of the cell centres and of the lower faces from x_c.
    let offsets: Vec<[[Vec<f64>; 2]; 3]> = centres
        .iter()
        .map(|&x| {
            let fr = frames(grid, x);
            std::array::from_fn(|d| {
                let cells = fr[d].cells(n[d]);
                let faces = cells.iter().map(|&r| fr[d].wrap(r - 0.5 * h[d])).collect();
                [cells, faces]
            })
        })
        .collect();
    let far = logit_distance(UNASSIGNED_PHI);
    let near = logit_distance(SHARED_PHI);
    let k = phis.len();
    let zero =
        FaceSums { caps: vec![[0.0; 12]; k], faces: vec![0; k], total: 0.0, unassigned: 0.0, shared: 0 };
    reduce_cells(
        grid,
        zero,
        |acc: &mut FaceSums, idx, ijk| {
            for d in 0..3 {
                if wall[d] && ijk[d] == 0 {
                    continue;
                }
                let f = force.c[d].data[idx].f64();
                if f == 0.0 {
                    continue;
                }
                acc.total += f.abs();
                // The cell below the face along d (periodic image at the lower end).
                let below = if ijk[d] == 0 { idx + (n[d] - 1) * st[d] } else { idx - st[d] };
                let (mut best, mut owner, mut close) = (f64::INFINITY, None, 0);
                for (c, phi) in phis.iter().enumerate() {
                    let p = 0.5 * (phi.data[idx].f64() + phi.data[below].f64());
                    let q = logit_distance(p);
                    if q <= near {
                        close += 1;
                    }
                    if q < best {
                        (best, owner) = (q, Some(c));
                    }
                }
                if close > 1 {
                    acc.shared += 1;
                }
                match owner {
                    Some(c) if best < far => {
                        let o = &offsets[c];
                        let r: [f64; 3] = std::array::from_fn(|a| o[a][usize::from(a == d)][ijk[a]]);
                        let m = &mut acc.caps[c];
                        for a in 0..3 {
                            m[3 * a + d] += r[a] * f;
                        }
                        m[9 + d] += f;
                        acc.faces[c] += 1;
                    }
                    _ => acc.unassigned += f.abs(),
                }
            }
        },
        |acc, b| {
            for (x, y) in acc.caps.iter_mut().zip(&b.caps) {
                for (u, v) in x.iter_mut().zip(y) {
                    *u += v;
                }
            }
            for (x, y) in acc.faces.iter_mut().zip(&b.faces) {
                *x += y;
            }
            acc.total += b.total;
            acc.unassigned += b.unassigned;
            acc.shared += b.shared;
        },
    )
}

/// `(mu_in - mu_out) sum phi_c (grad v + grad v^T)` per capsule, components in the order of
/// [`crate::tensor`], in units of one cell volume.
fn contrast_integrals<T: Real>(
    grid: &Grid<T>,
    k: &ViscosityContrast<'_, T>,
    phis: &[&Field<T>],
) -> Vec<[f64; 6]> {
    let jump = k.mu_inside - k.mu_outside;
    let sums = reduce_cells(
        grid,
        vec![[0.0; 6]; phis.len()],
        |acc: &mut Vec<[f64; 6]>, idx, _| {
            let w: Vec<f64> = phis.iter().map(|p| p.data[idx].f64().clamp(0.0, 1.0)).collect();
            if w.iter().all(|&x| x == 0.0) {
                return;
            }
            let g = grad_v_at_cell(grid, k.velocity, idx);
            let e: [f64; 6] = std::array::from_fn(|s| {
                let (a, b) = crate::tensor::SYM_PAIRS[s];
                g[a][b].f64() + g[b][a].f64()
            });
            for (x, &wc) in acc.iter_mut().zip(&w) {
                for (u, v) in x.iter_mut().zip(e) {
                    *u += wc * v;
                }
            }
        },
        |acc, b| {
            for (x, y) in acc.iter_mut().zip(b) {
                for (u, v) in x.iter_mut().zip(y) {
                    *u += v;
                }
            }
        },
    );
    sums.into_iter().map(|s| s.map(|x| jump * x)).collect()
}

/// Checks that `frame` describes a Couette box of `grid`: walls normal to the gradient axis, a
/// periodic flow axis. Returns the wall velocities along the flow axis and the wall distance.
fn couette<T: Real>(grid: &Grid<T>, frame: ShearFrame) -> Result<(f64, f64, f64)> {
    let (x, y) = (frame.flow(), frame.gradient());
    if grid.is_periodic(y) {
        return Err(Error::invalid(
            "gradient_axis",
            format!("{y}, a periodic axis of the grid"),
            "the axis normal to the walls of a Couette box",
        ));
    }
    if !grid.is_periodic(x) {
        return Err(Error::invalid(
            "flow_axis",
            format!("{x}, an axis that ends in walls"),
            "a periodic axis along which the walls slide",
        ));
    }
    let bc = grid.bc(y);
    let (lo, hi) = (bc[0].velocity()[x].f64(), bc[1].velocity()[x].f64());
    let height = grid.upper()[y].f64() - grid.lower()[y].f64();
    Ok((lo, hi, height))
}

/// The shear rate `gamma_dot = (U_hi - U_lo) / H` that the walls of a Couette box apply: the
/// walls normal to `frame.gradient()`, sliding along `frame.flow()` at `U_lo` (lower wall) and
/// `U_hi`, `H` apart.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `gradient_axis` if that axis is periodic, `flow_axis` if
/// it ends in walls, `grid` if the walls do not slide apart (`U_hi = U_lo`).
///
/// ```
/// use eulermembrane::diagnostics::suspension::{ShearFrame, couette_shear_rate};
/// use eulermembrane::grid::{Boundary, Grid};
/// let mut bc = [[Boundary::Periodic; 2]; 3];
/// bc[1] = [Boundary::Wall { velocity: [-0.5, 0.0, 0.0] }, Boundary::Wall { velocity: [1.5, 0.0, 0.0] }];
/// let grid = Grid::<f64>::new([8, 8, 1], [0.0; 3], [1.0, 4.0, 0.125], bc)?;
/// assert_eq!(couette_shear_rate(&grid, ShearFrame::new(0, 1)?)?, 0.5);
/// assert!(couette_shear_rate(&grid, ShearFrame::new(1, 0)?).is_err()); // x has no walls
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn couette_shear_rate<T: Real>(grid: &Grid<T>, frame: ShearFrame) -> Result<f64> {
    let (lo, hi, height) = couette(grid, frame)?;
    let rate = (hi - lo) / height;
    if !(rate != 0.0 && rate.is_finite()) {
        return Err(Error::invalid(
            "grid",
            format!(
                "walls normal to axis {} sliding at {lo} and {hi} along axis {}",
                frame.gradient(),
                frame.flow()
            ),
            "a Couette box: walls normal to the gradient axis sliding apart along the flow axis",
        ));
    }
    Ok(rate)
}

/// The mean shear stress on the two walls of a Couette box and the effective viscosity it gives
/// (see [`wall_shear_stress`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallShearStress {
    /// Mean `sigma_xy = mu du/dy` on the lower wall (`y` increasing into the box).
    pub lower: f64,
    /// Mean `sigma_xy` on the upper wall.
    pub upper: f64,
    /// The applied shear rate `(U_hi - U_lo) / H`.
    pub shear_rate: f64,
    /// `mu_eff = (lower + upper) / (2 shear_rate)`.
    pub viscosity: f64,
}

/// The mean shear stress on both walls of a Couette box, from the velocity `v` and the
/// (mixture) viscosity `mu` (e.g. `&sim.flow().materials().mu`), and the effective viscosity
/// `(sigma_xy(lower) + sigma_xy(upper)) / (2 gamma_dot)`; `frame.gradient()` is the wall-normal
/// axis (see the [module docs](self) for the stencil, the scheme's own wall flux).
///
/// # Errors
/// Those of [`couette_shear_rate`]; [`Error::InvalidParameter`] naming `velocity` or `mu` for a
/// field of another grid, `mu` for a uniform viscosity that is not finite and `> 0`;
/// [`Error::NonFinite`] naming `velocity` or `mu` and the first cell next to a wall where the
/// stress is not finite.
///
/// ```
/// use eulermembrane::diagnostics::suspension::{ShearFrame, wall_shear_stress};
/// use eulermembrane::fluid::momentum::Coefficient;
/// use eulermembrane::grid::{Boundary, Grid, VectorField};
/// // Walls at y = 0 and y = 2 sliding at 0 and 3 along x: shear rate 1.5.
/// let mut bc = [[Boundary::Periodic; 2]; 3];
/// bc[1] = [Boundary::wall(), Boundary::Wall { velocity: [3.0, 0.0, 0.0] }];
/// let grid = Grid::<f64>::new([8, 16, 4], [0.0; 3], [1.0, 2.0, 0.5], bc)?;
/// let v = VectorField::from_fn(&grid, |x| [1.5 * x[1], 0.0, 0.0]);
/// let w = wall_shear_stress(&grid, &v, &Coefficient::Uniform(0.7), ShearFrame::new(0, 1)?)?;
/// assert!((w.viscosity - 0.7).abs() < 1e-14 && (w.lower - 1.05).abs() < 1e-14);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn wall_shear_stress<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    mu: &Coefficient<T>,
    frame: ShearFrame,
) -> Result<WallShearStress> {
    let shear_rate = couette_shear_rate(grid, frame)?;
    let (lo, hi, _) = couette(grid, frame)?;
    check_vector(grid, "velocity", v)?;
    match mu {
        Coefficient::Field(f) => check_field(grid, "mu", f)?,
        Coefficient::Uniform(m) => {
            if !(m.is_finite() && *m > T::zero()) {
                return Err(Error::invalid("mu", *m, "a finite number > 0"));
            }
        }
    }
    let (x, y, z) = (frame.flow(), frame.gradient(), frame.vorticity());
    let n = grid.n();
    let hy = grid.h()[y].f64();
    let u = &v.c[x];
    let mut sums = [0.0; 2];
    for (side, s) in sums.iter_mut().enumerate() {
        let jw = if side == 0 { 0 } else { n[y] - 1 };
        for kz in 0..n[z] {
            for ix in 0..n[x] {
                let at = |i: usize| {
                    let mut ijk = [0; 3];
                    (ijk[x], ijk[y], ijk[z]) = (i, jw, kz);
                    (ijk, grid.idx_u(ijk[0], ijk[1], ijk[2]))
                };
                let (cell, idx) = at(ix);
                let (_, prev) = at((ix + n[x] - 1) % n[x]);
                let m = 0.5 * (mu.at(idx).f64() + mu.at(prev).f64());
                let uw = u.data[idx].f64();
                let du = if side == 0 { uw - lo } else { hi - uw };
                let t = m * du / (0.5 * hy);
                if !t.is_finite() {
                    let field = if uw.is_finite() { "mu" } else { "velocity" };
                    return Err(Error::NonFinite { field, cell });
                }
                *s += t;
            }
        }
    }
    let count = (n[x] * n[z]) as f64;
    let (lower, upper) = (sums[0] / count, sums[1] / count);
    Ok(WallShearStress { lower, upper, shear_rate, viscosity: 0.5 * (lower + upper) / shear_rate })
}

/// The shape of one capsule in a shear frame (see [`capsule_shapes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CapsuleShape {
    /// Centroid (3.5), inside the box.
    pub centroid: [f64; 3],
    /// Volume `sum phi dV`.
    pub volume: f64,
    /// Taylor deformation of the section through the centroid in the flow-gradient plane
    /// ([`taylor_deformation`] with the vorticity axis as `normal_axis`); its `angle_deg` is
    /// measured from the lower-numbered in-plane axis, see `inclination_deg` for the shear
    /// frame's.
    pub section: TaylorDeformation,
    /// Inclination of the section's major axis from the flow axis towards the gradient axis,
    /// degrees in `(-90, 90]` (positive along the extensional axis of a positive shear).
    pub inclination_deg: f64,
    /// The ellipsoid of inertia ([`ellipsoid_fit`]); `None` on a 2D grid.
    pub ellipsoid: Option<EllipsoidFit>,
}

/// Folds an angle in degrees into `(-90, 90]` (an axis has no direction).
fn fold_axis_angle(a: f64) -> f64 {
    let mut a = a % 180.0;
    if a > 90.0 {
        a -= 180.0;
    } else if a <= -90.0 {
        a += 180.0;
    }
    a
}

/// The deformation and orientation of every capsule at once: for each `phi`, its centroid and
/// volume, the Taylor deformation `D = (L - B)/(L + B)` of its section in the flow-gradient
/// plane of `frame` with the inclination from the flow axis towards the gradient axis, and (3D
/// grids) its ellipsoid of inertia.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `phis` for a `phi` of another grid or without a capsule
/// (its index in the value), naming `frame` on a 2D grid unless the vorticity axis is z;
/// [`Error::NonFinite`] naming `phi`; [`Error::Unsupported`] naming `capsule_shapes` (with the
/// capsule's index and the cause) where a section or an ellipsoid cannot be fitted.
///
/// ```
/// use eulermembrane::diagnostics::suspension::{ShearFrame, capsule_shapes};
/// use eulermembrane::grid::Grid;
/// use eulermembrane::interface::shapes::{Ellipsoid, Smoothing, Sphere, smoothed_phi};
/// let g = Grid::<f64>::periodic([32, 16, 16], [-2.0, -1.0, -1.0], [2.0, 1.0, 1.0])?;
/// let a = smoothed_phi(&g, &Ellipsoid::new([-1.0, 0.0, 0.0], [0.6, 0.4, 0.4])?, &Smoothing::default())?;
/// let b = smoothed_phi(&g, &Sphere::new([1.0, 0.0, 0.0], 0.45)?, &Smoothing::default())?;
/// let shapes = capsule_shapes(&g, &[&a, &b], ShearFrame::new(0, 2)?)?;
/// assert!((shapes[0].section.deformation - 0.2).abs() < 0.02 && shapes[0].inclination_deg.abs() < 1e-6);
/// assert!(shapes[1].section.deformation < 1e-3);
/// assert!((shapes[1].centroid[0] - 1.0).abs() < 1e-9);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn capsule_shapes<T: Real>(
    grid: &Grid<T>,
    phis: &[&Field<T>],
    frame: ShearFrame,
) -> Result<Vec<CapsuleShape>> {
    let normal = frame.vorticity();
    if grid.is_2d() && normal != 2 {
        return Err(Error::invalid(
            "frame",
            format!("vorticity axis {normal} on a 2D grid"),
            "flow and gradient axes 0 and 1 (the plane of a 2D grid)",
        ));
    }
    let [p, _] = section_axes(normal).unwrap_or([0, 1]);
    let fit_error = |c: usize, e: Error| match e {
        Error::Unsupported { component, detail } => Error::Unsupported {
            component: "capsule_shapes",
            detail: format!("capsule {c}: {component}: {detail}"),
        },
        other => name_capsule(other, c),
    };
    let mut out = Vec::with_capacity(phis.len());
    for (c, phi) in phis.iter().enumerate() {
        check_phi(grid, c, phi)?;
        let centre = centroid(grid, phi).map_err(|e| name_capsule(e, c))?;
        let vol = volume(grid, phi).map_err(|e| name_capsule(e, c))?;
        let section = taylor_deformation(grid, phi, centre, normal).map_err(|e| fit_error(c, e))?;
        // The section angle is from axis p towards the other in-plane axis.
        let inclination_deg =
            if p == frame.flow() { section.angle_deg } else { fold_axis_angle(90.0 - section.angle_deg) };
        let ellipsoid =
            if grid.is_2d() { None } else { Some(ellipsoid_fit(grid, phi).map_err(|e| fit_error(c, e))?) };
        out.push(CapsuleShape { centroid: centre, volume: vol, section, inclination_deg, ellipsoid });
    }
    Ok(out)
}

/// The cell-free layer along one wall (see [`cell_free_layer`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallLayer {
    /// Mean distance from the wall to the first point where some capsule has `phi >= 1/2`,
    /// over the lines across the channel that meet a capsule (`None` if none does).
    pub mean: Option<f64>,
    /// The smallest of those distances (`None` if no line meets a capsule).
    pub min: Option<f64>,
    /// Lines across the channel that meet a capsule.
    pub lines: usize,
    /// Lines that meet none (left out of the mean).
    pub empty_lines: usize,
}

/// The cell-free layers along the two walls of a channel (see [`cell_free_layer`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellFreeLayer {
    /// Along the wall at the lower end of the wall axis.
    pub lower: WallLayer,
    /// Along the wall at the upper end.
    pub upper: WallLayer,
}

/// The cell-free layer of a channel with walls normal to `wall_axis`: on every line of cell
/// centres across the channel (one per cell of the wall), the distance from each wall to the
/// first point where `max_c phi_c >= 1/2`, averaged over the lines that meet a capsule.
///
/// Along a line, `max_c phi_c` is interpolated linearly between cell centres, and taken
/// constant between the wall and the first centre (the zero-gradient ghost of a scalar): a
/// capsule with `phi >= 1/2` in the first cell is at distance 0. Lines that meet no capsule
/// are counted in [`WallLayer::empty_lines`] and left out of the mean; for a dense suspension
/// they are few, for a few cells the mean is that of the wall area the cells shadow.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `wall_axis` for an axis above 2 or a periodic one, naming
/// `phis` for a `phi` of another grid (its index in the value); [`Error::NonFinite`] naming
/// `phi`.
///
/// ```
/// use eulermembrane::diagnostics::suspension::cell_free_layer;
/// use eulermembrane::grid::{Boundary, Grid};
/// use eulermembrane::interface::shapes::{Smoothing, Sphere, smoothed_phi};
/// // A channel with walls at y = 0 and y = 2; a sphere of radius 0.5 at height 0.8, centred on
/// // a line of cell centres across the channel.
/// let mut bc = [[Boundary::Periodic; 2]; 3];
/// bc[1] = [Boundary::wall(), Boundary::wall()];
/// let g = Grid::<f64>::new([16, 32, 16], [-1.0, 0.0, -1.0], [1.0, 2.0, 1.0], bc)?;
/// let phi = smoothed_phi(&g, &Sphere::new([0.0625, 0.8, 0.0625], 0.5)?, &Smoothing::default())?;
/// let layer = cell_free_layer(&g, &[&phi], 1)?;
/// // The nearest point of the sphere is 0.3 from the lower wall and 0.7 from the upper one.
/// assert!((layer.lower.min.unwrap() - 0.3).abs() < 0.01 && (layer.upper.min.unwrap() - 0.7).abs() < 0.01);
/// assert!(layer.lower.empty_lines > 0 && layer.lower.lines > 0);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub fn cell_free_layer<T: Real>(
    grid: &Grid<T>,
    phis: &[&Field<T>],
    wall_axis: usize,
) -> Result<CellFreeLayer> {
    if wall_axis > 2 {
        return Err(Error::invalid("wall_axis", wall_axis, "0, 1 or 2"));
    }
    if grid.is_periodic(wall_axis) {
        return Err(Error::invalid(
            "wall_axis",
            format!("{wall_axis}, a periodic axis"),
            "an axis that ends in walls (the channel's wall-normal axis)",
        ));
    }
    for (c, phi) in phis.iter().enumerate() {
        check_phi(grid, c, phi)?;
    }
    let [a, b] = section_axes(wall_axis).unwrap_or([0, 1]);
    let n = grid.n();
    let h = grid.h()[wall_axis].f64();
    let nw = n[wall_axis];
    // Distances from each wall, per line.
    let mut lower = Vec::new();
    let mut upper = Vec::new();
    let mut empty = 0;
    let mut line = vec![0.0; nw];
    for ib in 0..n[b] {
        for ia in 0..n[a] {
            for (kw, s) in line.iter_mut().enumerate() {
                let mut ijk = [0; 3];
                (ijk[a], ijk[b], ijk[wall_axis]) = (ia, ib, kw);
                let idx = grid.idx_u(ijk[0], ijk[1], ijk[2]);
                *s = phis.iter().map(|p| p.data[idx].f64()).fold(0.0, f64::max);
            }
            match first_crossing(line.iter().copied()) {
                Some(d) => {
                    lower.push(d * h);
                    upper.push(first_crossing(line.iter().rev().copied()).unwrap_or(d) * h);
                }
                None => empty += 1,
            }
        }
    }
    let layer = |d: &[f64]| WallLayer {
        mean: (!d.is_empty()).then(|| d.iter().sum::<f64>() / d.len() as f64),
        min: d.iter().copied().reduce(f64::min),
        lines: d.len(),
        empty_lines: empty,
    };
    Ok(CellFreeLayer { lower: layer(&lower), upper: layer(&upper) })
}

/// Distance, in cells from the wall before the first value, to the first point where the
/// linear interpolant of `values` (at cell centres `k + 1/2`, constant before the first) reaches
/// `1/2`; `None` if it never does.
fn first_crossing(values: impl Iterator<Item = f64>) -> Option<f64> {
    let mut prev: Option<f64> = None;
    for (k, s) in values.enumerate() {
        if s >= 0.5 {
            return Some(match prev {
                None => 0.0,
                Some(p) => k as f64 - 0.5 + (0.5 - p) / (s - p),
            });
        }
        prev = Some(s);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::{
        forcing::Forcing,
        krylov::KrylovParams,
        momentum::Materials,
        stepper::{FlowConfig, FlowStepper, PredictorSolver, ViscousScheme},
    };
    use crate::grid::Boundary;
    use crate::interface::shapes::{Circle, Smoothing, smoothed_phi};
    use crate::membrane::force::{face_divergence3, sym_comp};
    use std::f64::consts::PI;

    /// The delta function of the smoothed profile `H = sigma(2 beta' s)` (`beta' = beta / h`,
    /// [`crate::interface::shapes`]): `dH/ds = 2 beta' sigma (1 - sigma)`, a logistic density
    /// of scale `1 / (2 beta')`, with moments `<s^2> = pi^2 / (12 beta'^2)` and
    /// `<s^4> = 7 pi^4 / (240 beta'^4)`.
    fn delta_s(s: f64, bp: f64) -> f64 {
        let z = 2.0 * bp * s;
        let e = (-z.abs()).exp();
        2.0 * bp * e / ((1.0 + e) * (1.0 + e))
    }

    fn moments(bp: f64) -> (f64, f64) {
        (PI * PI / (12.0 * bp * bp), 7.0 * PI.powi(4) / (240.0 * bp.powi(4)))
    }

    /// Minimum-image displacement `x - c` in a periodic box of side `l`.
    fn image(x: [f64; 3], c: [f64; 3], l: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|d| {
            let r = x[d] - c[d];
            r - l[d] * (r / l[d]).round()
        })
    }

    /// The box `[-1, 1]^3` on `n^3` cells, periodic.
    fn cube(n: usize) -> Grid<f64> {
        Grid::periodic([n; 3], [-1.0; 3], [1.0; 3]).unwrap()
    }

    /// `phi` of a smoothed sphere (for the centroid and the ownership of the faces).
    fn sphere_phi(g: &Grid<f64>, c: [f64; 3], a: f64) -> Field<f64> {
        smoothed_phi(g, &crate::interface::shapes::Sphere::new(c, a).unwrap(), &Smoothing::default()).unwrap()
    }

    /// `f = A r delta_s(a - |r|)` at the faces, `r` the minimum image of `x - c`.
    fn linear_force(g: &Grid<f64>, c: [f64; 3], a: f64, am: Mat3<f64>) -> VectorField<f64> {
        let bp = 1.0 / g.h()[0];
        let l = [0, 1, 2].map(|d| g.upper()[d] - g.lower()[d]);
        VectorField::from_fn(g, |x| {
            let r = image(x, c, l);
            let rho = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            let w = delta_s(a - rho, bp);
            std::array::from_fn(|i| w * (am[i][0] * r[0] + am[i][1] * r[1] + am[i][2] * r[2]))
        })
    }

    fn max_abs_diff(a: &Mat3<f64>, b: &Mat3<f64>) -> f64 {
        (0..9).map(|k| (a[k / 3][k % 3] - b[k / 3][k % 3]).abs()).fold(0.0, f64::max)
    }

    fn matmul(a: &Mat3<f64>, b: &Mat3<f64>) -> Mat3<f64> {
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
    }

    fn transpose(a: &Mat3<f64>) -> Mat3<f64> {
        std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
    }

    /// `(tr S, tr S^2, det S)`.
    fn invariants(s: &Mat3<f64>) -> [f64; 3] {
        let tr = s[0][0] + s[1][1] + s[2][2];
        let s2 = matmul(s, s);
        let det = s[0][0] * (s[1][1] * s[2][2] - s[1][2] * s[2][1])
            - s[0][1] * (s[1][0] * s[2][2] - s[1][2] * s[2][0])
            + s[0][2] * (s[1][0] * s[2][1] - s[1][1] * s[2][0]);
        [tr, s2[0][0] + s2[1][1] + s2[2][2], det]
    }

    /// A symmetric traceless `A`.
    const A: Mat3<f64> = [[0.3, 0.2, -0.1], [0.2, -0.5, 0.15], [-0.1, 0.15, 0.2]];

    /// Uniform tension `T` on a sphere: `f = -(2T/a) n delta_s`, `n` outward. Then
    /// `S = (2T/a) int |r| n n delta_s dV = (8 pi T / (3a)) int rho^3 delta_s(rho - a) drho I
    ///    = (8 pi T / (3a)) (a^3 + 3 a <s^2>) I`: isotropic, `(8 pi / 3) T a^2 I` for a sharp
    /// shell. Measured at N = 32 (h = 1/16, a = 0.5, beta = 1, centre off the grid's symmetry
    /// points): the isotropic part matches the smoothed constant to 8.8e-6 relative (the
    /// midpoint rule on a kernel of width `h / 2`), and differs from the sharp one by 3.856e-2,
    /// `3 <s^2>/a^2` = 3.855e-2 (the smoothing, `(pi^2/4)(h/a)^2`) plus that 9e-6; the
    /// deviatoric part is 2.9e-5 of the isotropic one; the sampled force's net force is 2.6e-5
    /// of `sum |f| dV`, its torque 4.5e-10 of `S`; 2.2e-9 of `sum |f| dV` lies in the kernel's
    /// tails beyond ten cells, owned by none.
    #[test]
    fn a_uniform_tension_gives_an_isotropic_stresslet() {
        let g = cube(32);
        let (c, a, t) = ([0.013, -0.021, 0.007], 0.5, 2.0);
        let bp = 1.0 / g.h()[0];
        let force = VectorField::from_fn(&g, |x| {
            let r = image(x, c, [2.0; 3]);
            let rho = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            let w = -2.0 * t / a * delta_s(a - rho, bp) / rho;
            r.map(|x| w * x)
        });
        let phi = sphere_phi(&g, c, a);
        let p = particle_stress(&g, &force, &[&phi], None).unwrap();
        let s = p.capsules[0].stresslet();
        let iso = (s[0][0] + s[1][1] + s[2][2]) / 3.0;
        let (s2, _) = moments(bp);
        let smoothed = 8.0 * PI * t / (3.0 * a) * (a.powi(3) + 3.0 * a * s2);
        let sharp = 8.0 * PI / 3.0 * t * a * a;
        let dev: Mat3<f64> =
            std::array::from_fn(|i| std::array::from_fn(|j| s[i][j] - if i == j { iso } else { 0.0 }));
        let dev_norm = (0..9).map(|k| dev[k / 3][k % 3].abs()).fold(0.0, f64::max);
        eprintln!(
            "isotropic {iso:.6e}: vs smoothed {:.2e}, vs sharp {:.4e} (3<s2>/a2 = {:.4e}); deviatoric / isotropic {:.1e}",
            iso / smoothed - 1.0,
            iso / sharp - 1.0,
            3.0 * s2 / (a * a),
            dev_norm / iso
        );
        assert!((iso / smoothed - 1.0).abs() < 5e-5);
        assert!((iso / sharp - 1.0 - 3.0 * s2 / (a * a)).abs() < 5e-5);
        assert!(dev_norm < 1e-4 * iso);
        // Force- and torque-free, every face owned.
        let cap = &p.capsules[0];
        let fr = cap.force.iter().fold(0.0f64, |m, x| m.max(x.abs())) / p.total_force;
        let tr = cap.torque.iter().fold(0.0f64, |m, x| m.max(x.abs())) / iso.abs();
        eprintln!("net force {fr:.1e} of sum |f| dV, net torque {tr:.1e} of S");
        assert!(fr < 1e-4 && tr < 1e-4, "{fr} {tr}");
        // The analytic kernel has tails beyond ten cells, where `phi < 1e-9`: owned by none.
        let un = p.unassigned_force / p.total_force;
        eprintln!("unassigned {un:.1e} of sum |f| dV");
        assert!(un < 1e-7 && p.shared_faces == 0, "{un}");
        assert!((p.volume_fraction - cap.volume / 8.0).abs() < 1e-15);
        approx::assert_relative_eq!(p.stress[1][1], s[1][1] / 8.0, max_relative = 1e-14);
    }

    /// `f = A r delta_s` with `A` symmetric and traceless:
    /// `S = -int sym(r (x) A r) delta_s dV = -(4 pi / 3) A int rho^4 delta_s(rho - a) drho`
    /// (`int_{|r| = rho} r r dA = (4 pi rho^4 / 3) I`), i.e. `-(4 pi a^4 / 3) A` for a sharp
    /// shell and `-(4 pi / 3) (a^4 + 6 a^2 <s^2> + <s^4>) A` for the smoothed one. Measured at
    /// N = 32 (h = 1/16, a = 0.5, beta = 1): 2.9e-5 of `|S|` from the smoothed value (the
    /// quadrature of the kernel); from the sharp one the relative error is 7.7817e-2, of which
    /// `6 <s^2>/a^2 + <s^4>/a^4` = 7.7800e-2 is the smoothing (`(pi^2/2)(h/a)^2` to leading
    /// order); net force 3.3e-5 of `sum |f| dV`, torque 2.3e-5 of `|S|`.
    #[test]
    fn a_linear_surface_force_gives_the_analytic_stresslet() {
        let g = cube(32);
        let (c, a) = ([0.013, -0.021, 0.007], 0.5);
        let bp = 1.0 / g.h()[0];
        let force = linear_force(&g, c, a, A);
        let phi = sphere_phi(&g, c, a);
        let p = particle_stress(&g, &force, &[&phi], None).unwrap();
        let s = p.capsules[0].stresslet();
        let (s2, s4) = moments(bp);
        let smoothed_k = -4.0 * PI / 3.0 * (a.powi(4) + 6.0 * a * a * s2 + s4);
        let sharp_k = -4.0 * PI / 3.0 * a.powi(4);
        let expect: Mat3<f64> = A.map(|r| r.map(|x| smoothed_k * x));
        let scale = (0..9).map(|k| expect[k / 3][k % 3].abs()).fold(0.0, f64::max);
        let err = max_abs_diff(&s, &expect) / scale;
        // The measured constant: S_xx / A_xx.
        let k = s[0][0] / A[0][0];
        eprintln!(
            "S = k A: k = {k:.8e}, smoothed {smoothed_k:.8e} (max err {err:.1e} of |S|), sharp {sharp_k:.8e} \
             (rel err {:.4e}; 6<s2>/a2 + <s4>/a4 = {:.4e})",
            k / sharp_k - 1.0,
            6.0 * s2 / (a * a) + s4 / a.powi(4)
        );
        assert!(err < 1e-4, "{err}");
        assert!((k / sharp_k - 1.0 - 6.0 * s2 / (a * a) - s4 / a.powi(4)).abs() < 1e-4);
        let cap = &p.capsules[0];
        let fr = cap.force.iter().fold(0.0f64, |m, x| m.max(x.abs())) / p.total_force;
        let tr = cap.torque.iter().fold(0.0f64, |m, x| m.max(x.abs())) / scale.abs();
        eprintln!("net force {fr:.1e} of sum |f| dV, net torque {tr:.1e} of |S|");
        assert!(fr < 1e-4 && tr < 1e-4, "{fr} {tr}");
    }

    /// The same distribution rotated (`A -> R A R^T`, `R` 37 degrees about (1, 2, 3)) and moved
    /// across the periodic corner of the box: the stresslet is `R S R^T` and its invariants
    /// (`tr S`, `tr S^2`, `det S`) are unchanged within the quadrature error of the sampled
    /// kernel: measured `|S' - R S R^T|` 6.4e-5 of `|S|`, invariants 5.9e-5 (`tr S` against
    /// `|S|`), 1.0e-4 and 1.0e-4 relative. A second capsule in the box gets its own stresslet
    /// (3.6e-5 of `|S|` from its analytic value), although 183 faces lie near both shells.
    #[test]
    fn rotations_and_translations_keep_the_invariants() {
        let g = cube(32);
        let a = 0.45;
        let c0 = [0.013, -0.021, 0.007];
        let p0 = particle_stress(&g, &linear_force(&g, c0, a, A), &[&sphere_phi(&g, c0, a)], None).unwrap();
        let s0 = p0.capsules[0].stresslet();
        // Rodrigues' rotation.
        let (th, ax) = (37f64.to_radians(), [1.0, 2.0, 3.0].map(|x: f64| x / 14f64.sqrt()));
        let k: Mat3<f64> = [[0.0, -ax[2], ax[1]], [ax[2], 0.0, -ax[0]], [-ax[1], ax[0], 0.0]];
        let k2 = matmul(&k, &k);
        let r: Mat3<f64> = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                f64::from(u8::from(i == j)) + th.sin() * k[i][j] + (1.0 - th.cos()) * k2[i][j]
            })
        });
        let ar = matmul(&matmul(&r, &A), &transpose(&r));
        // Across the corner of the box, with a second capsule (the unrotated one) beside it.
        let c1 = [0.97, -0.95, 0.99];
        let c2 = [-0.1, 0.2, -0.15];
        let mut f = linear_force(&g, c1, a, ar);
        let f2 = linear_force(&g, c2, 0.3, A);
        for d in 0..3 {
            for (x, y) in f.c[d].data.iter_mut().zip(&f2.c[d].data) {
                *x += y;
            }
        }
        let (phi1, phi2) = (sphere_phi(&g, c1, a), sphere_phi(&g, c2, 0.3));
        let p = particle_stress(&g, &f, &[&phi1, &phi2], None).unwrap();
        let s1 = p.capsules[0].stresslet();
        let rotated = matmul(&matmul(&r, &s0), &transpose(&r));
        let scale = (0..9).map(|k| s0[k / 3][k % 3].abs()).fold(0.0, f64::max);
        let err = max_abs_diff(&s1, &rotated) / scale;
        eprintln!("rotated: |S' - R S R^T| = {err:.1e} of |S|");
        assert!(err < 1e-4, "{s1:?} {rotated:?}");
        let (i0, i1) = (invariants(&s0), invariants(&s1));
        let rel = [(i1[0] - i0[0]).abs() / scale, (i1[1] / i0[1] - 1.0).abs(), (i1[2] / i0[2] - 1.0).abs()];
        eprintln!("invariants {i0:?} -> {i1:?}: differences {rel:?}");
        assert!(rel.iter().all(|&x| x < 3e-4), "{rel:?}");
        for d in 0..3 {
            assert!((p.capsules[0].centroid[d] - c1[d]).abs() < 1e-6);
        }
        // The second capsule: -(4 pi / 3)(a^4 + 6 a^2 <s^2> + <s^4>) A with a = 0.3.
        let (s2, s4) = moments(1.0 / g.h()[0]);
        let k2c = -4.0 * PI / 3.0 * (0.3f64.powi(4) + 6.0 * 0.09 * s2 + s4);
        let e2: Mat3<f64> = A.map(|r| r.map(|x| k2c * x));
        let err2 = max_abs_diff(&p.capsules[1].stresslet(), &e2) / (k2c.abs() * 0.5);
        eprintln!("second capsule: {err2:.1e} of |S|");
        assert!(err2 < 1e-3, "{err2}");
        // The shells come within 12 cells of each other: some faces are near both (both `phi`
        // in [1e-6, 1 - 1e-6]), and the nearest surface takes them.
        let un = p.unassigned_force / p.total_force;
        eprintln!("shared faces: {}, unassigned {un:.1e} of sum |f| dV", p.shared_faces);
        assert!(un < 1e-7, "{un}");
    }

    /// The crate's in-plane force `div(delta tau)` of a capsule in shear (prestretched, then
    /// five steps): its membrane stresslet is `sum delta tau dV` over the band to round-off
    /// (the face divergence is the negative adjoint of the cell-centred gradient), measured
    /// 1.9e-15 of `|S|`; the net force and torque vanish to round-off.
    #[test]
    fn the_stresslet_of_the_membrane_force_is_the_integral_of_delta_tau() {
        use crate::membrane::{force::InPlaneElasticity, law::NeoHookean};
        use crate::simulation::{Phase, Scene};
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[2] = [Boundary::Wall { velocity: [-1.0, 0.0, 0.0] }, Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
        let grid = Grid::<f64>::new([16, 16, 24], [-1.0, -1.0, -1.5], [1.0, 1.0, 1.5], bc).unwrap();
        let law = NeoHookean::new(4.0).unwrap();
        let mut sim = Scene::new(grid.clone(), Phase::new(1.0, 1.0).unwrap())
            .capsule(crate::interface::shapes::Sphere::new([0.05, 0.0, -0.03], 0.45).unwrap())
            .elasticity(law)
            .build()
            .unwrap();
        sim.prestretch(0, 1.05).unwrap();
        sim.set_velocity(|x| [x[2] / 1.5, 0.0, 0.0]).unwrap();
        for _ in 0..5 {
            sim.step(5e-3).unwrap();
        }
        let band = sim.band(0).unwrap();
        let mut e = InPlaneElasticity::new(&grid, law);
        e.evaluate(
            &grid,
            band,
            sim.gs(0).unwrap().unwrap(),
            sim.normal(0).unwrap(),
            sim.delta(0).unwrap(),
            5e-3,
        )
        .unwrap();
        let mut force = VectorField::zeros(&grid);
        e.explicit_forcing(band).unwrap().add(&grid, 0.0, sim.velocity(), &mut force).unwrap();
        let p = particle_stress(&grid, &force, &[sim.phi(0).unwrap()], None).unwrap();
        let delta = sim.delta(0).unwrap();
        let mut expect = [[0.0; 3]; 3];
        for (pos, &idx) in band.cells().iter().enumerate() {
            let tau = e.tau(pos).unwrap();
            for a in 0..3 {
                for b in 0..3 {
                    expect[a][b] += delta.data[idx] * tau[crate::tensor::sym_index(a, b)] / 512.0;
                }
            }
        }
        let s = p.capsules[0].stresslet();
        let scale = (0..9).map(|k| expect[k / 3][k % 3].abs()).fold(0.0, f64::max);
        let err = max_abs_diff(&s, &expect) / scale;
        eprintln!("S = {s:?}; vs sum delta tau dV: {err:.1e}");
        assert!(err < 1e-12, "{err}");
        let cap = &p.capsules[0];
        assert!(cap.force.iter().chain(&cap.torque).all(|x| x.abs() < 1e-12 * scale), "{cap:?}");
        // Prestretched and sheared: tension (trace > 0) and a positive shear stress.
        assert!(s[0][2] > 0.0 && s[0][0] + s[1][1] + s[2][2] > 0.0);
    }

    /// A pure fluid in a Couette box, the exact linear profile (and after a few steps of the flow
    /// solver, which keeps it): the wall viscosity is `mu` to round-off (measured at most
    /// 2.6e-15 relative), on each wall axis and with the flow along either other axis.
    #[test]
    fn the_wall_viscosity_of_a_pure_fluid_couette_flow_is_mu() {
        let mu = 0.37;
        for (flow, wall) in [(0, 1), (2, 1), (1, 2), (0, 2), (2, 0)] {
            let mut bc = [[Boundary::Periodic; 2]; 3];
            let (mut ulo, mut uhi) = ([0.0; 3], [0.0; 3]);
            (ulo[flow], uhi[flow]) = (-0.4, 0.8);
            bc[wall] = [Boundary::Wall { velocity: ulo }, Boundary::Wall { velocity: uhi }];
            let g = Grid::<f64>::new([8, 12, 10], [0.0, -0.5, 0.2], [1.0, 1.0, 1.2], bc).unwrap();
            let frame = ShearFrame::new(flow, wall).unwrap();
            let rate = couette_shear_rate(&g, frame).unwrap();
            let (lo, hi) = (g.lower()[wall], g.upper()[wall]);
            assert!((rate - 1.2 / (hi - lo)).abs() < 1e-15);
            let mut flow_solver =
                FlowStepper::new(&g, Materials::uniform(1.0, mu).unwrap(), FlowConfig::default()).unwrap();
            flow_solver
                .set_velocity(|x| {
                    let mut v = [0.0; 3];
                    v[flow] = -0.4 + rate * (x[wall] - lo);
                    v
                })
                .unwrap();
            let m = Coefficient::Uniform(mu);
            let w0 = wall_shear_stress(&g, flow_solver.velocity(), &m, frame).unwrap();
            for _ in 0..3 {
                flow_solver.step(1e-2, &(), None).unwrap();
            }
            let w1 = wall_shear_stress(&g, flow_solver.velocity(), &m, frame).unwrap();
            let (e0, e1) = (w0.viscosity / mu - 1.0, w1.viscosity / mu - 1.0);
            eprintln!("flow {flow}, wall {wall}: relative error {e0:.1e} (set), {e1:.1e} (after 3 steps)");
            assert!(e0.abs() < 1e-14 && e1.abs() < 1e-12, "{e0} {e1}");
            assert!((w0.lower - w0.upper).abs() < 1e-14 * mu * rate);
        }
    }

    /// No capsules, no force: `Sigma_p = 0`, `mu_eff = mu` exactly, no normal stress
    /// differences; with capsules and no force or contrast, the same.
    #[test]
    fn the_particle_viscosity_without_capsules_is_mu() {
        let g = cube(8);
        let frame = ShearFrame::new(0, 1).unwrap();
        let zero = VectorField::zeros(&g);
        let p = particle_stress(&g, &zero, &[], None).unwrap();
        let r = p.shear_rheology(frame, 1.3, 0.7).unwrap();
        assert_eq!((r.viscosity, r.relative_viscosity, r.n1, r.n2), (1.3, 1.0, 0.0, 0.0));
        assert_eq!((p.volume_fraction, p.total_force, p.box_volume), (0.0, 0.0, 8.0));
        let phi = sphere_phi(&g, [0.0; 3], 0.5);
        let v = VectorField::from_fn(&g, |x| [x[1], 0.0, 0.0]);
        let k = ViscosityContrast { velocity: &v, mu_outside: 1.3, mu_inside: 1.3 };
        let p = particle_stress(&g, &zero, &[&phi], Some(&k)).unwrap();
        assert_eq!(p.shear_rheology(frame, 1.3, 0.7).unwrap().viscosity, 1.3);
        // Force on faces with no capsule is reported, not assigned.
        let mut f = VectorField::zeros(&g);
        f.c[0].data[g.idx_u(1, 2, 3)] = 0.5;
        let p = particle_stress(&g, &f, &[], None).unwrap();
        assert_eq!((p.unassigned_force, p.total_force), (0.5 / 64.0, 0.5 / 64.0));
    }

    /// A static force `f = div S` on the faces (the crate's stencil of `div(delta tau)`, `S` a
    /// smooth symmetric cell field on a blob) in a 2D Couette box, run to the steady state at
    /// `Re = 5e-5`: the mean wall shear stress is `mu gamma_dot + Sigma_xy` (the discrete
    /// momentum balance), so the two effective viscosities agree: measured 8.2e-9 of the
    /// excess viscosity apart (inertia and the approach to the steady state), the walls 7e-16
    /// apart; the particle stress is `sum S dV / V` to round-off.
    ///
    /// The contrast term of a viscous blob (`lambda = 4`, no force, N = 16, a steady state at
    /// `Re = 5e-4`): the particle viscosity and the lower wall's agree to 4.4e-4 of the excess
    /// viscosity (the cell-centred `phi (grad v + grad v^T)` against the scheme's edge
    /// viscosities; 1.0e-7 at N = 32, measured once: 30 s, too slow for the suite). The upper
    /// wall reads 0.4 % lower at N = 16: the flow solver's edge viscosity on the upper wall is
    /// not the average of the cells beside it but a copy of the edge one cell below (the edge
    /// field's ghosts are filled as a cell-centred scalar, `fluid::momentum::edge_viscosity`);
    /// with that viscosity the upper wall agrees with the lower one to 2e-12. It matters only
    /// where the viscosity varies next to the upper wall.
    #[test]
    fn the_two_viscosities_agree_at_a_steady_stokes_state() {
        struct Static(VectorField<f64>);
        impl Forcing<f64> for Static {
            fn add(
                &self,
                _: &Grid<f64>,
                _: f64,
                _: &VectorField<f64>,
                out: &mut VectorField<f64>,
            ) -> Result<()> {
                for d in 0..3 {
                    for (o, f) in out.c[d].data.iter_mut().zip(&self.0.c[d].data) {
                        *o += f;
                    }
                }
                Ok(())
            }
        }
        let couette_box = |n: usize| {
            let mut bc = [[Boundary::Periodic; 2]; 3];
            bc[1] =
                [Boundary::Wall { velocity: [-0.5, 0.0, 0.0] }, Boundary::Wall { velocity: [0.5, 0.0, 0.0] }];
            Grid::<f64>::new([n, n, 1], [0.0; 3], [1.0, 1.0, 1.0 / n as f64], bc).unwrap()
        };
        let frame = ShearFrame::new(0, 1).unwrap();
        let (rho, mu) = (1e-4, 1.0);
        let config = FlowConfig {
            viscous: ViscousScheme::Theta(1.0),
            predictor: PredictorSolver::Krylov(KrylovParams { tolerance: 1e-14, max_iterations: 500 }),
            ..FlowConfig::default()
        };
        // Steps until the lower wall's stress changes by less than 1e-13 over 100 steps.
        let steady = |flow: &mut FlowStepper<f64>, forcing: &Static, dt: f64| {
            let g = flow.grid().clone();
            let stress =
                |f: &FlowStepper<f64>| wall_shear_stress(&g, f.velocity(), &f.materials().mu, frame).unwrap();
            let mut last = stress(flow).lower;
            for _ in 0..40 {
                for _ in 0..100 {
                    flow.step(dt, forcing, None).unwrap();
                }
                let now = stress(flow).lower;
                if (now - last).abs() < 1e-13 {
                    break;
                }
                last = now;
            }
            stress(flow)
        };
        // 1. The membrane-like force, lambda = 1.
        let g = couette_box(16);
        let blob = |x: [f64; 3]| {
            let r = (x[0] - 0.45).hypot(x[1] - 0.52) / 0.3;
            if r < 1.0 { (0.5 * PI * r).cos().powi(2) } else { 0.0 }
        };
        let t0 = [0.3, -0.1, 0.0, 0.8, 0.0, 0.0]; // xx, yy, zz, xy, yz, zx
        let s: Vec<[f64; 6]> = (0..g.len())
            .map(|idx| {
                let (i, j, k) =
                    (idx % g.dims()[0], (idx / g.dims()[0]) % g.dims()[1], idx / (g.dims()[0] * g.dims()[1]));
                let x = g.cell_center(i as isize - 3, j as isize - 3, k as isize - 3);
                let w = blob(x);
                t0.map(|t| w * t)
            })
            .collect();
        let mut f = VectorField::zeros(&g);
        let ih = g.h().map(|x| 1.0 / x);
        for (i, j, k) in g.cells() {
            let m = g.idx_u(i, j, k);
            let fm = face_divergence3(&g.strides(), &ih, m, |p| s[p], sym_comp);
            for d in 0..3 {
                f.c[d].data[m] = if d == 1 && j == 0 { 0.0 } else { fm[d] };
            }
        }
        // The capsule that owns the force: a smoothed circle on the blob.
        let phi = smoothed_phi(&g, &Circle::new([0.45, 0.52], 0.25).unwrap(), &Smoothing::default()).unwrap();
        let p = particle_stress(&g, &f, &[&phi], None).unwrap();
        assert_eq!(p.unassigned_force, 0.0);
        let volume = 1.0 / 16.0;
        let sum_s: f64 =
            g.cells().map(|(i, j, k)| s[g.idx_u(i, j, k)][3]).sum::<f64>() * g.cell_volume() / volume;
        assert!((p.stress[0][1] - sum_s).abs() < 1e-14 * sum_s.abs(), "{} {sum_s}", p.stress[0][1]);
        let mut flow = FlowStepper::new(&g, Materials::uniform(rho, mu).unwrap(), config).unwrap();
        flow.set_velocity(|x| [x[1] - 0.5, 0.0, 0.0]).unwrap();
        let wall = steady(&mut flow, &Static(f), 2e-4);
        let rate = couette_shear_rate(&g, frame).unwrap();
        let r = p.shear_rheology(frame, mu, rate).unwrap();
        let gap = (wall.viscosity - r.viscosity) / (r.viscosity - mu);
        eprintln!(
            "force: wall mu_eff {:.12} (walls {:.1e} apart), particle {:.12}, gap {gap:.1e} of the excess",
            wall.viscosity,
            wall.lower - wall.upper,
            r.viscosity
        );
        assert!(gap.abs() < 1e-7, "{gap}");
        assert!((wall.lower - wall.upper).abs() < 1e-12);
        // 2. A viscous blob, lambda = 4, no force.
        {
            let (n, tol) = (16, 1e-3);
            let g = couette_box(n);
            let circle = Circle::new([0.45, 0.52], 0.25).unwrap();
            let phi = smoothed_phi(&g, &circle, &Smoothing::default()).unwrap();
            let rho = 1e-3;
            let m = Materials::mixture(&g, &phi, (rho, 4.0 * mu), (rho, mu)).unwrap();
            let mut flow = FlowStepper::new(&g, m, config).unwrap();
            flow.set_velocity(|x| [x[1] - 0.5, 0.0, 0.0]).unwrap();
            let wall = steady(&mut flow, &Static(VectorField::zeros(&g)), 1e-6);
            let k = ViscosityContrast { velocity: flow.velocity(), mu_outside: mu, mu_inside: 4.0 * mu };
            let p = particle_stress(&g, &VectorField::zeros(&g), &[&phi], Some(&k)).unwrap();
            let r = p.shear_rheology(frame, mu, couette_shear_rate(&g, frame).unwrap()).unwrap();
            // The lower wall: see the test's docs for the upper one.
            let gap = (wall.lower / wall.shear_rate - r.viscosity) / (r.viscosity - mu);
            eprintln!(
                "blob N = {n}: lower wall mu_eff {:.8} (upper {:.8}), particle {:.8}, gap {gap:.2e} of the excess, \
                 phi_v = {:.4}, t = {:.1e}",
                wall.lower / wall.shear_rate,
                wall.upper / wall.shear_rate,
                r.viscosity,
                p.volume_fraction,
                flow.time()
            );
            assert!(r.viscosity > mu && gap.abs() < tol, "{gap}");
        }
    }

    /// Two tilted ellipsoids in one box (h = 1/12): each capsule's `D` and inclination, in the
    /// shear frame (x, z) and in the swapped frame (z, x), where the inclination is
    /// `90 - theta`. Measured: section `D` 0.2719 and 0.1421 (exact 0.2727 and 0.1429),
    /// inclinations 25.01 and -40.09 degrees (exact 25 and -40); the ellipsoid of inertia's `D`
    /// is 0.0225 and 0.012 low (the smoothing lengthens the short axes most, see
    /// [`ellipsoid_fit`]).
    #[test]
    fn shapes_of_two_tilted_ellipsoids() {
        let g = Grid::<f64>::periodic([48, 24, 24], [-2.0, -1.0, -1.0], [2.0, 1.0, 1.0]).unwrap();
        let tilted = |c, axes, tilt| crate::diagnostics::ellipsoid::tests::tilted(&g, c, axes, tilt);
        let a = tilted([-1.0, 0.0, 0.05], [0.7, 0.45, 0.4], 25f64.to_radians());
        let b = tilted([1.0, 0.1, -0.1], [0.6, 0.5, 0.45], -40f64.to_radians());
        let shapes = capsule_shapes(&g, &[&a, &b], ShearFrame::new(0, 2).unwrap()).unwrap();
        for (s, (d, angle)) in shapes.iter().zip([(0.3 / 1.1, 25.0), (0.15 / 1.05, -40.0)]) {
            let e = s.ellipsoid.unwrap();
            eprintln!(
                "D {:.4} (exact {d:.4}), inclination {:.2} (exact {angle}), ellipsoid D {:.4}",
                s.section.deformation,
                s.inclination_deg,
                e.deformation()
            );
            assert!((s.section.deformation - d).abs() < 0.02 && (s.inclination_deg - angle).abs() < 1.0);
            assert!((e.deformation() - d).abs() < 0.03);
        }
        let swapped = capsule_shapes(&g, &[&a, &b], ShearFrame::new(2, 0).unwrap()).unwrap();
        for (s, t) in shapes.iter().zip(&swapped) {
            assert!((t.inclination_deg - fold_axis_angle(90.0 - s.inclination_deg)).abs() < 1e-9);
            assert_eq!(s.section.deformation, t.section.deformation);
        }
        // A 2D grid has only the xy-plane.
        let g2 = Grid::<f64>::periodic([16, 16, 1], [-1.0; 3], [1.0, 1.0, 0.125]).unwrap();
        let disc = smoothed_phi(&g2, &Circle::new([0.0; 2], 0.5).unwrap(), &Smoothing::default()).unwrap();
        let s = capsule_shapes(&g2, &[&disc], ShearFrame::new(0, 1).unwrap()).unwrap();
        assert!(s[0].ellipsoid.is_none() && s[0].section.deformation < 0.01);
        assert!(matches!(
            capsule_shapes(&g2, &[&disc], ShearFrame::new(0, 2).unwrap()),
            Err(Error::InvalidParameter { name: "frame", .. })
        ));
    }

    /// A sphere of radius 0.5 in a channel: on every line across the channel that meets it, the
    /// distances from the walls are those of the sphere's surface, `y_c -+ sqrt(a^2 - r^2)`;
    /// the means over those lines are 0.035 h and 0.036 h long at h = 1/16 (the linear
    /// interpolation of `phi` between cell centres).
    #[test]
    fn cell_free_layer_of_a_sphere() {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[1] = [Boundary::wall(), Boundary::wall()];
        let g = Grid::<f64>::new([32, 32, 32], [-1.0, 0.0, -1.0], [1.0, 2.0, 1.0], bc).unwrap();
        let (c, a) = ([0.03, 0.8, -0.02], 0.5);
        let phi = sphere_phi(&g, c, a);
        let layer = cell_free_layer(&g, &[&phi], 1).unwrap();
        // The exact distances on the lines that meet the sphere (phi >= 1/2 somewhere).
        let (mut lo, mut hi, mut lines) = (0.0, 0.0, 0);
        for k in 0..32 {
            for i in 0..32 {
                let x = g.cell_center(i, 0, k);
                if (0..32).any(|j| phi.data[g.idx_u(i as usize, j, k as usize)] >= 0.5) {
                    let r2 = (x[0] - c[0]).powi(2) + (x[2] - c[2]).powi(2);
                    let half = (a * a - r2).max(0.0).sqrt();
                    lo += c[1] - half;
                    hi += 2.0 - c[1] - half;
                    lines += 1;
                }
            }
        }
        let (lo, hi) = (lo / lines as f64, hi / lines as f64);
        let h = 1.0 / 16.0;
        let (elo, ehi) = (layer.lower.mean.unwrap() - lo, layer.upper.mean.unwrap() - hi);
        eprintln!(
            "mean distances: lower err {:.3} h, upper err {:.3} h over {lines} lines",
            elo / h,
            ehi / h
        );
        assert_eq!(layer.lower.lines, lines);
        assert_eq!(layer.lower.lines + layer.lower.empty_lines, 1024);
        assert!(elo.abs() < 0.05 * h && ehi.abs() < 0.05 * h);
        assert!((layer.lower.min.unwrap() - (c[1] - a)).abs() < 0.05 * h);
        // No capsules: nothing to measure.
        let none = cell_free_layer(&g, &[], 1).unwrap();
        assert_eq!((none.lower.mean, none.upper.lines, none.lower.empty_lines), (None, 0, 1024));
    }

    #[test]
    fn bad_inputs_name_the_parameter() {
        let mut bc = [[Boundary::Periodic; 2]; 3];
        bc[1] = [Boundary::wall(), Boundary::Wall { velocity: [1.0, 0.0, 0.0] }];
        let g = Grid::<f64>::new([8, 8, 8], [0.0; 3], [1.0; 3], bc).unwrap();
        let other = Grid::<f64>::periodic([6, 6, 6], [0.0; 3], [1.0; 3]).unwrap();
        fn name<R>(r: Result<R>) -> &'static str {
            match r {
                Err(Error::InvalidParameter { name, .. }) => name,
                Err(e) => panic!("{e}"),
                Ok(_) => panic!("accepted"),
            }
        }
        let zero = VectorField::zeros(&g);
        let alien = VectorField::zeros(&other);
        let phi = sphere_phi(&g, [0.5; 3], 0.25);
        let alien_phi = Field::zeros(&other);
        let empty = Field::zeros(&g);
        assert_eq!(name(particle_stress(&g, &alien, &[&phi], None)), "force");
        assert_eq!(name(particle_stress(&g, &zero, &[&phi, &alien_phi], None)), "phis");
        match particle_stress(&g, &zero, &[&phi, &empty], None) {
            Err(Error::InvalidParameter { name: "phis", value, .. }) => assert!(value.starts_with("phis[1]")),
            other => panic!("{other:?}"),
        }
        let k = ViscosityContrast { velocity: &alien, mu_outside: 1.0, mu_inside: 2.0 };
        assert_eq!(name(particle_stress(&g, &zero, &[&phi], Some(&k))), "velocity");
        let k = ViscosityContrast { velocity: &zero, mu_outside: 1.0, mu_inside: -2.0 };
        assert_eq!(name(particle_stress(&g, &zero, &[&phi], Some(&k))), "mu_inside");
        let mut nan = VectorField::zeros(&g);
        nan.c[2].data[g.idx_u(1, 2, 3)] = f64::NAN;
        assert_eq!(
            particle_stress(&g, &nan, &[&phi], None).unwrap_err(),
            Error::NonFinite { field: "force.z", cell: [1, 2, 3] }
        );
        // Axes.
        assert_eq!(name(ShearFrame::new(0, 0)), "gradient_axis");
        assert_eq!(name(ShearFrame::new(5, 0)), "flow_axis");
        assert_eq!(name(ShearFrame::new(0, 3)), "gradient_axis");
        let (good, periodic_gradient, wall_flow) =
            (ShearFrame::new(0, 1).unwrap(), ShearFrame::new(0, 2).unwrap(), ShearFrame::new(1, 0).unwrap());
        let mu = Coefficient::Uniform(1.0);
        assert_eq!(name(wall_shear_stress(&g, &zero, &mu, periodic_gradient)), "gradient_axis");
        assert_eq!(name(couette_shear_rate(&g, ShearFrame::new(2, 0).unwrap())), "gradient_axis");
        let mut bc2 = [[Boundary::Periodic; 2]; 3];
        bc2[1] = [Boundary::wall(), Boundary::wall()];
        bc2[0] = [Boundary::wall(), Boundary::wall()];
        let duct = Grid::<f64>::new([8, 8, 8], [0.0; 3], [1.0; 3], bc2).unwrap();
        assert_eq!(name(couette_shear_rate(&duct, wall_flow)), "flow_axis");
        assert_eq!(name(couette_shear_rate(&duct, ShearFrame::new(2, 1).unwrap())), "grid");
        assert_eq!(name(wall_shear_stress(&g, &alien, &mu, good)), "velocity");
        assert_eq!(name(wall_shear_stress(&g, &zero, &Coefficient::Field(Field::zeros(&other)), good)), "mu");
        assert_eq!(name(wall_shear_stress(&g, &zero, &Coefficient::Uniform(0.0), good)), "mu");
        let p = particle_stress(&g, &zero, &[&phi], None).unwrap();
        assert_eq!(name(p.shear_rheology(good, 0.0, 1.0)), "mu");
        assert_eq!(name(p.shear_rheology(good, 1.0, f64::NAN)), "shear_rate");
        assert_eq!(name(cell_free_layer(&g, &[&phi], 0)), "wall_axis");
        assert_eq!(name(cell_free_layer(&g, &[&phi], 3)), "wall_axis");
        assert_eq!(name(cell_free_layer(&g, &[&alien_phi], 1)), "phis");
        assert_eq!(name(capsule_shapes(&g, &[&phi, &alien_phi], good)), "phis");
        assert!(matches!(
            capsule_shapes(&g, &[&phi, &empty], good),
            Err(Error::InvalidParameter { name: "phis", .. })
        ));
    }
}
