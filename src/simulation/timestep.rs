//! How a run chooses its steps: a fixed `dt` ([`FixedDt`]) or an adaptive one
//! ([`AdaptiveDt`]), both behind [`TimeStepping`], which [`Simulation::run_with`] drives.
//!
//! # The adaptive rule
//!
//! Each step [`AdaptiveDt`] takes the smallest of
//! - the largest step the user allows (`max_dt`, the `dt` a fixed run would take);
//! - the advective limit `cfl h / max|v|`, with `max|v| / h` of the current velocity
//!   ([`FlowStepper::cfl`](crate::fluid::stepper::FlowStepper::cfl)`(1)`) and `cfl` the target Courant
//!   number (default [`AdaptiveDt::DEFAULT_CFL`]);
//! - `safety` times the effects' limits ([`Simulation::membrane_dt_limit`]: the in-plane and
//!   bending rules of [`stability`](super::stability), and a user effect's own
//!   [`Effect::dt_limit`](super::Effect::dt_limit));
//! - `growth` times the last step (so that `dt` recovers gradually after a cut);
//! - the time left to `until` (the run lands on it).
//!
//! A step is then prepared, and rejected (discarded and tried again smaller, up to `retries`
//! times) when
//! - it fails ([`Error::Step`]: a solver that does not converge, a non-finite value, a band at a
//!   wall): `dt` is halved (but for an [`Error::InvalidParameter`], e.g. a capsule that outgrew
//!   its box, which no step size meets: that error is returned at once);
//! - its Courant number exceeds twice the target: `dt` is scaled to the target;
//! - its predictor needed more than [`AdaptiveDt::ITERATION_SURGE`] times the median
//!   iterations of the recent steps (the first sign of a growing instability in the membrane
//!   terms, well before the solver fails): `dt` is halved.
//!
//! The report of the accepted step counts the rejected attempts
//! ([`StepReport::retries`]) and, when the velocity `max|v|` has grown by more than
//! `velocity_growth` within the recent steps, carries [`StepWarning::VelocityGrowth`]: the
//! step follows it (the Courant target shrinks `dt`), and the caller learns of it.
//!
//! ```
//! use eulermembrane::grid::Grid;
//! use eulermembrane::interface::shapes::Sphere;
//! use eulermembrane::membrane::law::NeoHookean;
//! use eulermembrane::simulation::{timestep::AdaptiveDt, Phase, Scene};
//!
//! let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
//! let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
//!     .capsule(Sphere::new([0.5; 3], 0.25)?)
//!     .elasticity(NeoHookean::new(1.0)?)
//!     .build()?;
//! sim.set_velocity(|x| [0.2 * (x[2] - 0.5), 0.0, 0.0])?;
//! let mut stepping = AdaptiveDt::new(0.05)?.cfl(0.2)?;
//! let summary = sim.run_with(0.1, &mut stepping, &mut [])?;
//! assert!((summary.time - 0.1).abs() < 1e-12); // lands on `until`
//! assert!(summary.steps >= 2);
//! # Ok::<(), eulermembrane::Error>(())
//! ```

use super::{Simulation, StepReport, StepWarning};
use crate::error::positive;
use crate::{Error, Real, Result};

/// A policy for the steps of a run: [`FixedDt`], [`AdaptiveDt`], or a user's own.
pub trait TimeStepping<T: Real> {
    /// Takes one step towards `until` and returns its report, or `None` when `until` is
    /// reached (then nothing is done).
    ///
    /// # Errors
    /// A step that fails (and that the policy does not retry); the state is then that of the
    /// last accepted step.
    fn advance(&mut self, sim: &mut Simulation<T>, until: T) -> Result<Option<StepReport>>;
}

/// Steps of one size `dt`, until the time is within `dt / 2` of `until` (the last step is not
/// shortened, so the run may end up to `dt / 2` before or after `until`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedDt<T>(T);

impl<T: Real> FixedDt<T> {
    /// Steps of `dt`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `dt` unless it is finite and `> 0`.
    pub fn new(dt: T) -> Result<Self> {
        positive("dt", dt)?;
        Ok(FixedDt(dt))
    }
}

impl<T: Real> TimeStepping<T> for FixedDt<T> {
    fn advance(&mut self, sim: &mut Simulation<T>, until: T) -> Result<Option<StepReport>> {
        if sim.time() + T::lit(0.5) * self.0 >= until {
            return Ok(None);
        }
        sim.step(self.0).map(Some)
    }
}

/// Adaptive steps from the measured limits (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct AdaptiveDt {
    max_dt: f64,
    min_dt: f64,
    cfl: f64,
    safety: f64,
    growth: f64,
    retries: usize,
    velocity_growth: f64,
    /// `dt` of the last accepted step.
    last_dt: Option<f64>,
    /// Ring buffer of the recent steps' `(max|v| / h, predictor iterations)`.
    recent: Vec<(f64, usize)>,
    next: usize,
    /// Scratch for the median of the iterations.
    scratch: Vec<usize>,
    rejected: usize,
}

impl AdaptiveDt {
    /// Default target Courant number `max|v| dt / h`. The capsule cases stay accurate (their
    /// `D` within 0.5 % of a run at a quarter of the step) and stable up to about 0.5 with the
    /// damped viscous scheme (`docs/stability.md`).
    pub const DEFAULT_CFL: f64 = 0.3;
    /// Recent steps remembered for the surge tests.
    pub const WINDOW: usize = 20;
    /// A step whose predictor needs more than this many times the median iterations of the
    /// recent steps is retried at half the step.
    pub const ITERATION_SURGE: f64 = 4.0;

    /// Adaptive steps of at most `max_dt`, with the defaults: Courant target
    /// [`DEFAULT_CFL`](Self::DEFAULT_CFL), safety 1 on the effects' limits (they already keep
    /// a margin), growth 1.2 per step, 8 retries, smallest step `max_dt / 1e4`, a velocity
    /// growth warning at a factor 2.
    ///
    /// # Choosing
    /// The defaults are the validated ones: the capsule cases (`examples/capsule_in_shear.rs`,
    /// `cases/examples/shear_capsule.rs`) run `AdaptiveDt::new(0.05)` with the Courant target
    /// 0.3 and nothing else changed. `max_dt` only caps the step: the Courant target and the
    /// effects' limits ([`Simulation::membrane_dt_limit`]) set it below the cap (in
    /// `capsule_in_shear` the walls' speed does: `0.3 h / max|v|` = 0.0125); lower the cap
    /// where the output needs a finer time resolution. Lower the Courant target
    /// (e.g. 0.15) for a convergence check; raise it no further than about 0.5, where the
    /// capsule cases stop being stable (`docs/stability.md`).
    ///
    /// ```
    /// use eulermembrane::simulation::timestep::AdaptiveDt;
    ///
    /// let stepping = AdaptiveDt::new(0.05)?; // the validated default: Courant target 0.3
    /// let careful = AdaptiveDt::new(0.05)?.cfl(0.15)?; // half the step, for a convergence check
    /// # let _ = (stepping, careful);
    /// # Ok::<(), eulermembrane::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `max_dt` unless it is finite and `> 0`.
    pub fn new(max_dt: f64) -> Result<Self> {
        positive("max_dt", max_dt)?;
        Ok(AdaptiveDt {
            max_dt,
            min_dt: max_dt * 1e-4,
            cfl: Self::DEFAULT_CFL,
            safety: 1.0,
            growth: 1.2,
            retries: 8,
            velocity_growth: 2.0,
            last_dt: None,
            recent: Vec::with_capacity(Self::WINDOW),
            next: 0,
            scratch: Vec::with_capacity(Self::WINDOW),
            rejected: 0,
        })
    }

    /// The target Courant number `max|v| dt / h`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `cfl` unless `0 < cfl <= 1`.
    pub fn cfl(mut self, cfl: f64) -> Result<Self> {
        if !(cfl > 0.0 && cfl <= 1.0) {
            return Err(Error::invalid("cfl", cfl, "a Courant number in (0, 1]"));
        }
        self.cfl = cfl;
        Ok(self)
    }

    /// The fraction of the effects' limits ([`Simulation::membrane_dt_limit`]) a step may take.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `safety` unless `0 < safety <= 1`.
    pub fn safety(mut self, safety: f64) -> Result<Self> {
        if !(safety > 0.0 && safety <= 1.0) {
            return Err(Error::invalid("safety", safety, "a fraction in (0, 1]"));
        }
        self.safety = safety;
        Ok(self)
    }

    /// The largest factor by which `dt` may grow from one step to the next.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `growth` unless `1 <= growth <= 10`.
    pub fn growth(mut self, growth: f64) -> Result<Self> {
        if !(1.0..=10.0).contains(&growth) {
            return Err(Error::invalid("growth", growth, "a factor in [1, 10]"));
        }
        self.growth = growth;
        Ok(self)
    }

    /// How many times a step is tried again smaller before its error is returned, and the
    /// smallest step tried.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `min_dt` unless `0 < min_dt <= max_dt`.
    pub fn retries(mut self, retries: usize, min_dt: f64) -> Result<Self> {
        if !(min_dt > 0.0 && min_dt <= self.max_dt) {
            return Err(Error::invalid("min_dt", min_dt, "a step in (0, max_dt]"));
        }
        self.retries = retries;
        self.min_dt = min_dt;
        Ok(self)
    }

    /// The factor of growth of `max|v|` within the recent steps above which a step's report
    /// carries [`StepWarning::VelocityGrowth`].
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `velocity_growth` unless it is finite and `> 1`.
    pub fn velocity_growth(mut self, factor: f64) -> Result<Self> {
        if !(factor.is_finite() && factor > 1.0) {
            return Err(Error::invalid("velocity_growth", factor, "a finite factor > 1"));
        }
        self.velocity_growth = factor;
        Ok(self)
    }

    /// Attempts rejected so far (failed or over a limit), over all steps.
    pub fn rejected(&self) -> usize {
        self.rejected
    }

    /// The step the rule proposes now for `sim` (before any rejection), at most the time left
    /// to `until`.
    pub fn propose<T: Real>(&self, sim: &Simulation<T>, until: T) -> f64 {
        self.propose_within(sim, until, sim.membrane_dt_limit())
    }

    /// [`propose`](Self::propose) with the effects' limit `limit`.
    fn propose_within<T: Real>(&self, sim: &Simulation<T>, until: T, limit: f64) -> f64 {
        let mut dt = self.max_dt.min(self.safety * limit);
        let rate = sim.flow().cfl(T::one());
        if rate > 0.0 {
            dt = dt.min(self.cfl / rate);
        }
        if let Some(last) = self.last_dt {
            dt = dt.min(self.growth * last);
        }
        let left = (until - sim.time()).f64();
        // A last step within 1e-9 of its size of the end is taken to the end.
        if left < dt * (1.0 + 1e-9) { left } else { dt }
    }

    /// The median predictor iterations of the recent steps (`None` before any step).
    fn median_iterations(&mut self) -> Option<usize> {
        if self.recent.is_empty() {
            return None;
        }
        self.scratch.clear();
        self.scratch.extend(self.recent.iter().map(|&(_, it)| it));
        let mid = self.scratch.len() / 2;
        Some(*self.scratch.select_nth_unstable(mid).1)
    }

    /// Why the prepared step with `report` is rejected, and the factor for the next try.
    fn rejection(&mut self, report: &StepReport) -> Option<f64> {
        let info = &report.flow;
        if info.cfl > 2.0 * self.cfl {
            return Some(self.cfl / info.cfl);
        }
        let median = self.median_iterations()?;
        let surge = Self::ITERATION_SURGE * median.max(5) as f64;
        (info.predictor_iterations as f64 > surge).then_some(0.5)
    }

    /// Records an accepted step; returns the growth of `max|v|` over the recent steps.
    fn record(&mut self, report: &StepReport) -> f64 {
        let rate = report.flow.cfl / report.flow.dt;
        let smallest = self.recent.iter().map(|&(r, _)| r).fold(f64::INFINITY, f64::min);
        let entry = (rate, report.flow.predictor_iterations);
        if self.recent.len() < Self::WINDOW {
            self.recent.push(entry);
        } else {
            self.recent[self.next] = entry;
        }
        self.next = (self.next + 1) % Self::WINDOW;
        self.last_dt = Some(report.flow.dt);
        if smallest.is_finite() && smallest > 0.0 { rate / smallest } else { 1.0 }
    }
}

impl<T: Real> TimeStepping<T> for AdaptiveDt {
    fn advance(&mut self, sim: &mut Simulation<T>, until: T) -> Result<Option<StepReport>> {
        let left = (until - sim.time()).f64();
        if left <= 1e-12 * self.max_dt {
            return Ok(None);
        }
        // An effect's invalid limit is refused here, naming the effect (not as a step of 0).
        let mut dt = self.propose_within(sim, until, sim.checked_dt_limit()?);
        let mut retries = 0;
        loop {
            let outcome = sim.prepare(T::lit(dt));
            let factor = match &outcome {
                Ok(report) => self.rejection(report),
                // A parameter the step cannot meet (e.g. a capsule that outgrew its box) fails
                // at any step size.
                Err(Error::Step { source, .. }) if !matches!(**source, Error::InvalidParameter { .. }) => {
                    Some(0.5)
                }
                Err(_) => None,
            };
            match (outcome, factor) {
                (Ok(_), None) => break,
                (Err(e), None) => return Err(e),
                (outcome, Some(f)) => {
                    sim.discard();
                    if retries >= self.retries || dt * f < self.min_dt {
                        return match outcome {
                            Err(e) => Err(e),
                            Ok(report) => Err(Error::Unsupported {
                                component: "AdaptiveDt",
                                detail: format!(
                                    "no acceptable step down to dt = {dt:.3e} at t = {:.6e} (Courant \
                                     number {:.3}, {} predictor iterations): lower `min_dt` or \
                                     raise `retries`, or refine the grid",
                                    sim.time().f64(),
                                    report.flow.cfl,
                                    report.flow.predictor_iterations
                                ),
                            }),
                        };
                    }
                    retries += 1;
                    self.rejected += 1;
                    dt *= f;
                }
            }
        }
        let mut report = sim.commit()?;
        report.retries = retries;
        let growth = self.record(&report);
        // One warning a report: the step's own (Courant number, effects' limit) comes first.
        if growth > self.velocity_growth && report.warning.is_none() {
            report.warning = Some(StepWarning::VelocityGrowth { factor: growth, steps: self.recent.len() });
        }
        Ok(Some(report))
    }
}
