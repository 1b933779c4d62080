//! The energy budget of Sec. 3.2 (Fig. 6), as reusable pieces:
//!
//! ```text
//! E_kinetic  = sum rho |v_c|^2 / 2 dV              (v_c: the velocity averaged to cell centres)
//! E_elastic  = sum delta W_s dV                      (W_s per unit area, from the membrane law)
//! E_viscous  = int_0^t Phi dt',  Phi = sum mu grad v : grad v dV    (the paper's form)
//!                                or  Phi = sum 2 mu D : D dV,  D = (grad v + grad v^T)/2
//! E_body     = - int_0^t P dt',  P = sum_faces v . F dV           (power of a face force F)
//! E_total    = E_kinetic + E_elastic + E_viscous + E_body           (conserved)
//! ```
//!
//! The two dissipation forms agree for a divergence-free velocity with periodic or no-slip
//! boundaries (`int grad v : grad v^T dV = int (div v)^2 dV = 0`); locally, and with walls moving
//! or variable `mu`, they differ, and `2 mu D : D` is the true dissipation.
//! `grad v` is [`grad_v_at_cell`] (compact differences on the
//! diagonal, two-cell central differences of centre averages off it): a diagnostic, not the
//! exact dissipation of the stepper's viscous operator, so a discrete budget closes to
//! `O(h^2)`, not to round-off.
//!
//! [`EnergyBudget`] integrates `Phi` and `P` in time by the trapezoid rule from samples taken at
//! successive times and reports the total, as in Fig. 6.

use super::reduce::{check_field, check_vector, finite_or, sum_cells};
use crate::fluid::momentum::Coefficient;
use crate::fluid::momentum::{ViscosityView, is_wall_face, viscous_at};
use crate::grid::ops::{grad_v_at_cell, velocity_at_cell};
use crate::grid::{Field, Grid, VectorField};
use crate::{Error, Real, Result};

fn check_coefficient<T: Real>(grid: &Grid<T>, name: &'static str, c: &Coefficient<T>) -> Result<()> {
    match c {
        Coefficient::Uniform(x) => {
            crate::error::finite(name, *x)?;
            Ok(())
        }
        Coefficient::Field(f) => check_field(grid, name, f),
    }
}

fn velocity_fields<T: Real>(v: &VectorField<T>) -> [(&'static str, &Field<T>); 3] {
    [("v.u", &v.c[0]), ("v.v", &v.c[1]), ("v.w", &v.c[2])]
}

fn with_coefficient<'a, T: Real>(
    mut f: Vec<(&'static str, &'a Field<T>)>,
    name: &'static str,
    c: &'a Coefficient<T>,
) -> Vec<(&'static str, &'a Field<T>)> {
    if let Coefficient::Field(x) = c {
        f.push((name, x));
    }
    f
}

/// Kinetic energy `sum rho |v_c|^2 / 2 dV`, with `v_c` the staggered velocity averaged to cell
/// centres ([`velocity_at_cell`], which reads the upper faces: ghosts filled) and `rho` uniform
/// or per cell (e.g. [`Materials::rho`](crate::fluid::momentum::Materials)).
///
/// Errors: a field not on `grid`; a non-finite value.
pub fn kinetic_energy<T: Real>(grid: &Grid<T>, v: &VectorField<T>, rho: &Coefficient<T>) -> Result<f64> {
    check_vector(grid, "v", v)?;
    check_coefficient(grid, "rho", rho)?;
    let s = sum_cells(grid, |idx, _| {
        let c = velocity_at_cell(grid, v, idx);
        let v2 = c.iter().map(|x| x.f64() * x.f64()).sum::<f64>();
        [0.5 * rho.at(idx).f64() * v2]
    });
    let [s] = finite_or(s, grid, &with_coefficient(velocity_fields(v).to_vec(), "rho", rho))?;
    Ok(s * grid.cell_volume().f64())
}

/// Which contraction [`viscous_dissipation`] sums.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DissipationForm {
    /// `mu grad v : grad v`, as written in Sec. 3.2.
    #[default]
    GradGrad,
    /// `2 mu D : D`, `D = (grad v + grad v^T)/2`: the local dissipation of a Newtonian fluid.
    StrainRate,
    /// `- sum_faces v . div_h(mu (grad_h v + grad_h v^T))`: minus the power of the stepper's
    /// own discrete viscous operator (walls at rest, or periodic). The discrete momentum
    /// equation then balances kinetic energy against this rate up to the time discretisation,
    /// so it is the form to use in an energy budget of the solver.
    Discrete,
}

/// Viscous dissipation rate `Phi = sum mu grad v : grad v dV` (or `sum 2 mu D : D dV`, or minus
/// the power of the stepper's viscous operator, see [`DissipationForm`]), with `grad v` from
/// [`grad_v_at_cell`] (one ghost layer of `v` filled) and `mu` uniform or per cell.
///
/// Errors: a field not on `grid`; a non-finite value.
pub fn viscous_dissipation<T: Real>(
    grid: &Grid<T>,
    v: &VectorField<T>,
    mu: &Coefficient<T>,
    form: DissipationForm,
) -> Result<f64> {
    check_vector(grid, "v", v)?;
    check_coefficient(grid, "mu", mu)?;
    let view = ViscosityView::new(grid, mu, None);
    let s = sum_cells(grid, |idx, ijk| {
        if form == DissipationForm::Discrete {
            let power = (0..3)
                .filter(|&c| !is_wall_face(grid, c, ijk))
                .map(|c| v.c[c].data[idx].f64() * viscous_at(grid, &view, v, c, idx).f64())
                .sum::<f64>();
            return [-power];
        }
        let g = grad_v_at_cell(grid, v, idx);
        let mut c = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let gij = g[i][j].f64();
                c += if form == DissipationForm::GradGrad {
                    gij * gij
                } else {
                    let d = 0.5 * (gij + g[j][i].f64());
                    2.0 * d * d
                };
            }
        }
        [mu.at(idx).f64() * c]
    });
    let [s] = finite_or(s, grid, &with_coefficient(velocity_fields(v).to_vec(), "mu", mu))?;
    Ok(s * grid.cell_volume().f64())
}

/// Power of a force density given on the faces, `P = sum_d sum_faces v_d F_d dV` over the
/// interior face indices `0..n` of each component (on a wall axis the upper wall face, where
/// the normal velocity vanishes, is left out). `E_body = - int P dt` in Sec. 3.2.
///
/// Errors: a field not on `grid`; a non-finite value.
pub fn body_force_power<T: Real>(grid: &Grid<T>, v: &VectorField<T>, force: &VectorField<T>) -> Result<f64> {
    check_vector(grid, "v", v)?;
    check_vector(grid, "force", force)?;
    let s = sum_cells(grid, |idx, _| {
        [(0..3).map(|d| v.c[d].data[idx].f64() * force.c[d].data[idx].f64()).sum::<f64>()]
    });
    let mut fields = velocity_fields(v).to_vec();
    fields.extend([("force[0]", &force.c[0]), ("force[1]", &force.c[1]), ("force[2]", &force.c[2])]);
    let [s] = finite_or(s, grid, &fields)?;
    Ok(s * grid.cell_volume().f64())
}

/// Elastic (strain) energy of the membrane, `sum delta W_s dV`, with `w_s` the surface energy
/// density of the membrane law per unit area at cell centres (zero or anything off the band:
/// `delta` selects the surface).
///
/// Errors: a field not on `grid`; a non-finite value.
pub fn elastic_energy<T: Real>(grid: &Grid<T>, delta: &Field<T>, w_s: &Field<T>) -> Result<f64> {
    check_field(grid, "delta", delta)?;
    check_field(grid, "w_s", w_s)?;
    let s = sum_cells(grid, |idx, _| {
        let d = delta.data[idx].f64();
        [if d == 0.0 { 0.0 } else { d * w_s.data[idx].f64() }]
    });
    let [s] = finite_or(s, grid, &[("delta", delta), ("w_s", w_s)])?;
    Ok(s * grid.cell_volume().f64())
}

/// The instantaneous quantities of the budget at one time: what a driver measures each step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyState {
    /// Time.
    pub time: f64,
    /// Kinetic energy ([`kinetic_energy`]).
    pub kinetic: f64,
    /// Elastic energy ([`elastic_energy`]); zero without a membrane.
    pub elastic: f64,
    /// Dissipation rate `Phi >= 0` ([`viscous_dissipation`]).
    pub dissipation_rate: f64,
    /// Power `P` of the external forces ([`body_force_power`]); zero without forcing.
    pub body_power: f64,
    /// `int Phi dt` and `int P dt` since a fixed start, accumulated by the stepper itself (see
    /// [`StepIntegrals`]); `None` lets [`EnergyBudget`] integrate the rates by the trapezoid rule.
    pub integrals: Option<StepIntegrals>,
}

/// Time integrals of the dissipation rate and of the external power accumulated step by step at
/// the midpoint velocity `v^{n+1/2} = (v^n + v^{n+1})/2`:
/// `dt Phi(v^{n+1/2})` and `dt f^n . v^{n+1/2}`.
///
/// With the Crank-Nicolson viscous term of (2.31) these are the terms of the discrete scheme's
/// own kinetic-energy balance, `rho (|v^{n+1}|^2 - |v^n|^2)/2 = (v^{n+1} - v^n) . rho v^{n+1/2}`.
/// The trapezoid rule on the rates at the time levels instead adds
/// `dt Phi(v^{n+1} - v^n)/4` per step: nothing in a slow evolution, but a spurious jump where
/// the flow starts or a force switches on or off (the first step of the squashed sphere).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepIntegrals {
    /// `sum_steps dt Phi(v^{n+1/2})`.
    pub dissipated: f64,
    /// `sum_steps dt f^n . v^{n+1/2}` over the external (body and surface) forces.
    pub work: f64,
}

/// One point of the budget history (the curves of Fig. 6).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergySample {
    /// Time.
    pub time: f64,
    /// `E_kinetic`.
    pub kinetic: f64,
    /// `E_elastic`.
    pub elastic: f64,
    /// `E_viscous = int_0^t Phi dt` (trapezoid rule over the recorded times).
    pub dissipated: f64,
    /// `int_0^t P dt`, the work done by the external forces (`E_body = -work`).
    pub work: f64,
    /// `E_total = kinetic + elastic + dissipated - work`.
    pub total: f64,
}

/// Accumulates the energy budget of Sec. 3.2 from [`EnergyState`]s recorded at increasing times.
///
/// ```
/// use eulermembrane::diagnostics::{energy::EnergyBudget, energy::EnergyState};
/// // Kinetic energy decaying as exp(-2t): the dissipated energy makes up for it.
/// let mut budget = EnergyBudget::new();
/// for k in 0..=100 {
///     let t = 0.01 * k as f64;
///     let e = (-2.0 * t).exp();
///     budget.record(EnergyState { time: t, kinetic: e, dissipation_rate: 2.0 * e, ..Default::default() })?;
/// }
/// assert!(budget.drift() < 1e-4);
/// # Ok::<(), eulermembrane::Error>(())
/// ```
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnergyBudget {
    samples: Vec<EnergySample>,
    last: Option<EnergyState>,
}

impl EnergyBudget {
    /// An empty budget: the first recorded state is time zero of the integrals.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the state at a later time, integrating `Phi` and `P` since the previous state, and
    /// returns the new sample. Where both states carry [`StepIntegrals`] their difference is
    /// used; otherwise the trapezoid rule on the rates.
    ///
    /// Errors: a non-finite value; a time not later than the previous one. The budget is then
    /// left unchanged.
    pub fn record(&mut self, state: EnergyState) -> Result<EnergySample> {
        let names = ["time", "kinetic", "elastic", "dissipation_rate", "body_power"];
        let vals = [state.time, state.kinetic, state.elastic, state.dissipation_rate, state.body_power];
        for (name, x) in names.into_iter().zip(vals) {
            crate::error::finite(name, x)?;
        }
        if let Some(i) = state.integrals {
            crate::error::finite("integrals.dissipated", i.dissipated)?;
            crate::error::finite("integrals.work", i.work)?;
        }
        let (dissipated, work) = match (&self.last, self.samples.last()) {
            (Some(p), Some(s)) => {
                if state.time <= p.time {
                    return Err(Error::invalid(
                        "time",
                        state.time,
                        "a time later than the previously recorded one",
                    ));
                }
                let dt = state.time - p.time;
                match (p.integrals, state.integrals) {
                    (Some(a), Some(b)) => {
                        (s.dissipated + b.dissipated - a.dissipated, s.work + b.work - a.work)
                    }
                    _ => (
                        s.dissipated + 0.5 * dt * (p.dissipation_rate + state.dissipation_rate),
                        s.work + 0.5 * dt * (p.body_power + state.body_power),
                    ),
                }
            }
            _ => (0.0, 0.0),
        };
        let sample = EnergySample {
            time: state.time,
            kinetic: state.kinetic,
            elastic: state.elastic,
            dissipated,
            work,
            total: state.kinetic + state.elastic + dissipated - work,
        };
        self.samples.push(sample);
        self.last = Some(state);
        Ok(sample)
    }

    /// Every sample recorded so far, in time order.
    pub fn samples(&self) -> &[EnergySample] {
        &self.samples
    }

    /// The latest sample.
    pub fn latest(&self) -> Option<&EnergySample> {
        self.samples.last()
    }

    /// Largest departure of `E_total` from its first value, `max_t |E_total(t) - E_total(0)|`
    /// (zero with fewer than two samples).
    pub fn drift(&self) -> f64 {
        let Some(first) = self.samples.first() else { return 0.0 };
        self.samples.iter().map(|s| (s.total - first.total).abs()).fold(0.0, f64::max)
    }
}
