//! Runs of many steps: [`Simulation::run`] advances to a time and hands every step to
//! [`Observer`]s, which do what a driver's time loop did by hand: progress lines
//! ([`Progress`]), ParaView series ([`VtkSeries`]), checkpoints ([`Checkpoints`]), or a user's
//! own measurements. The library itself never prints: a [`Progress`] writes to the writer it is
//! given.
//!
//! ```
//! use eulermembrane::grid::Grid;
//! use eulermembrane::interface::shapes::Sphere;
//! use eulermembrane::membrane::law::NeoHookean;
//! use eulermembrane::simulation::observer::{Observer, Progress};
//! use eulermembrane::simulation::{Phase, Scene, Simulation, StepReport};
//!
//! /// Records the capsule's volume after every step.
//! struct Volumes(Vec<f64>);
//! impl Observer<f64> for Volumes {
//!     fn observe(&mut self, sim: &Simulation<f64>, _: &StepReport) -> eulermembrane::Result<()> {
//!         self.0.push(sim.volume(0)?);
//!         Ok(())
//!     }
//! }
//!
//! let grid = Grid::<f64>::periodic([16; 3], [0.0; 3], [1.0; 3])?;
//! let mut sim = Scene::new(grid, Phase::new(1.0, 1.0)?)
//!     .capsule(Sphere::new([0.5; 3], 0.25)?)
//!     .elasticity(NeoHookean::new(1.0)?)
//!     .build()?;
//! let mut volumes = Volumes(Vec::new());
//! let mut progress = Progress::new(Vec::new(), 2e-3)?; // a line every 2e-3 time units
//! let summary = sim.run(5e-3, 1e-3, &mut [&mut volumes, &mut progress])?;
//! assert_eq!(summary.steps, 5);
//! assert_eq!(volumes.0.len(), 5);
//! assert!(String::from_utf8(progress.into_inner()).unwrap().contains("t = "));
//! # Ok::<(), eulermembrane::Error>(())
//! ```

use super::{
    Simulation, StepReport,
    timestep::{FixedDt, TimeStepping},
};
use crate::error::positive;
use crate::io::vtk::PvdSeries;
use crate::{Error, Real, Result};
use std::io::Write;
use std::path::PathBuf;

/// Something that watches a [`Simulation::run`]: called before the first step, after every
/// step, and at the end.
pub trait Observer<T: Real> {
    /// Before the first step of a run. Default: nothing.
    ///
    /// # Errors
    /// Any error stops the run before it starts.
    fn start(&mut self, sim: &Simulation<T>) -> Result<()> {
        let _ = sim;
        Ok(())
    }

    /// After every step, with its report.
    ///
    /// # Errors
    /// Any error stops the run after this step (the step stays taken).
    fn observe(&mut self, sim: &Simulation<T>, report: &StepReport) -> Result<()>;

    /// After the last step of a run that reached its end. Default: nothing.
    ///
    /// # Errors
    /// Returned by the run.
    fn finish(&mut self, sim: &Simulation<T>) -> Result<()> {
        let _ = sim;
        Ok(())
    }
}

/// What a [`Simulation::run`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunSummary {
    /// Steps taken by this run.
    pub steps: usize,
    /// The time reached.
    pub time: f64,
    /// Steps whose report carried a warning.
    pub warned_steps: usize,
    /// Attempts rejected and retried smaller (adaptive steps only).
    pub retries: usize,
    /// The report of the last step (`None` if the run took no step).
    pub last: Option<StepReport>,
}

impl<T: Real> Simulation<T> {
    /// Steps of `dt` until the time is within `dt / 2` of `until` ([`FixedDt`]), handing each
    /// step to the `observers` in order (see the [module docs](self)).
    ///
    /// # Errors
    /// `until` or `dt` not finite, `dt <= 0`; the first error of a step (the state is then that
    /// of the last successful step, see [`step`](Self::step)) or of an observer.
    pub fn run(&mut self, until: T, dt: T, observers: &mut [&mut dyn Observer<T>]) -> Result<RunSummary> {
        self.run_with(until, &mut FixedDt::new(dt)?, observers)
    }

    /// Steps chosen by `stepping` (e.g. an [`AdaptiveDt`](super::timestep::AdaptiveDt)) until `until`,
    /// handing each step to the `observers` in order.
    ///
    /// # Errors
    /// `until` not finite; the first error of a step that the policy does not retry (the state
    /// is then that of the last accepted step) or of an observer.
    pub fn run_with(
        &mut self,
        until: T,
        stepping: &mut dyn TimeStepping<T>,
        observers: &mut [&mut dyn Observer<T>],
    ) -> Result<RunSummary> {
        crate::error::finite("until", until)?;
        for o in observers.iter_mut() {
            o.start(self)?;
        }
        let mut summary = RunSummary { time: self.time().f64(), ..Default::default() };
        while let Some(report) = stepping.advance(self, until)? {
            summary.steps += 1;
            summary.time = report.flow.time;
            summary.warned_steps += usize::from(report.warning.is_some());
            summary.retries += report.retries;
            summary.last = Some(report);
            for o in observers.iter_mut() {
                o.observe(self, &report)?;
            }
        }
        for o in observers.iter_mut() {
            o.finish(self)?;
        }
        Ok(summary)
    }
}

/// When something is due: every `interval` time units, at the first step that reaches each
/// multiple of the interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Every {
    interval: f64,
    next: f64,
}

impl Every {
    /// Due at the first step at or past each multiple of `interval`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `interval` unless it is finite and `> 0`.
    pub fn new(interval: f64) -> Result<Self> {
        positive("interval", interval)?;
        Ok(Every { interval, next: interval })
    }

    /// Whether the step that reached `time` is due (and if so, moves on to the next multiple).
    /// A tolerance of `1e-9` intervals absorbs the rounding of sums of `dt`.
    pub fn due(&mut self, time: f64) -> bool {
        if time + 1e-9 * self.interval < self.next {
            return false;
        }
        while self.next <= time + 1e-9 * self.interval {
            self.next += self.interval;
        }
        true
    }

    /// Starts counting from `time` (a restarted run).
    fn start_at(&mut self, time: f64) {
        self.next = ((time / self.interval + 1e-9).floor() + 1.0) * self.interval;
    }
}

/// Writes a progress line every `interval` time units (and a line for the first step of a run
/// whose report carries a [`StepWarning`](super::StepWarning)) to a writer of the caller's choice (e.g.
/// `std::io::stderr()`).
pub struct Progress<W: Write> {
    out: W,
    every: Every,
    warned: bool,
}

impl<W: Write> Progress<W> {
    /// Progress to `out` every `interval` time units.
    ///
    /// # Errors
    /// `interval` not finite and `> 0`.
    pub fn new(out: W, interval: f64) -> Result<Self> {
        Ok(Progress { out, every: Every::new(interval)?, warned: false })
    }

    /// The writer back (e.g. a `Vec<u8>` to read what was written).
    pub fn into_inner(self) -> W {
        self.out
    }
}

impl<T: Real, W: Write> Observer<T> for Progress<W> {
    fn start(&mut self, sim: &Simulation<T>) -> Result<()> {
        self.every.start_at(sim.time().f64());
        self.warned = false;
        Ok(())
    }
    fn observe(&mut self, _: &Simulation<T>, r: &StepReport) -> Result<()> {
        let io = |e: std::io::Error| Error::Io { path: "progress".into(), message: e.to_string() };
        if self.every.due(r.flow.time) {
            writeln!(
                self.out,
                "t = {:.4}  step {}  cfl {:.3}  predictor {} its  band {} cells",
                r.flow.time, r.flow.step, r.flow.cfl, r.flow.predictor_iterations, r.band_cells
            )
            .map_err(io)?;
        }
        if let Some(w) = r.warning.filter(|_| !self.warned) {
            self.warned = true;
            writeln!(self.out, "warning at step {}: {w}", r.flow.step).map_err(io)?;
        }
        Ok(())
    }
}

/// Writes a ParaView snapshot ([`Simulation::write_vti`]) every `interval` time units into a
/// folder, as `snapshot_NNNN.vti`, and the series `series.pvd` that ParaView opens.
pub struct VtkSeries {
    dir: PathBuf,
    every: Every,
    series: PvdSeries,
}

impl VtkSeries {
    /// Snapshots into `dir` (created if missing) every `interval` time units, and one of the
    /// state at the start of the run.
    ///
    /// # Errors
    /// `interval` not finite and `> 0`.
    pub fn new(dir: impl Into<PathBuf>, interval: f64) -> Result<Self> {
        Ok(VtkSeries { dir: dir.into(), every: Every::new(interval)?, series: PvdSeries::new() })
    }

    fn write<T: Real>(&mut self, sim: &Simulation<T>) -> Result<()> {
        let name = format!("snapshot_{:04}.vti", self.series.len());
        sim.write_vti(self.dir.join(&name))?;
        self.series.push(sim.time().f64(), name);
        self.series.write(self.dir.join("series.pvd"))
    }
}

impl<T: Real> Observer<T> for VtkSeries {
    fn start(&mut self, sim: &Simulation<T>) -> Result<()> {
        std::fs::create_dir_all(&self.dir)
            .map_err(|e| Error::Io { path: self.dir.display().to_string(), message: e.to_string() })?;
        self.every.start_at(sim.time().f64());
        self.write(sim)
    }
    fn observe(&mut self, sim: &Simulation<T>, r: &StepReport) -> Result<()> {
        if self.every.due(r.flow.time) { self.write(sim) } else { Ok(()) }
    }
}

/// Writes a checkpoint ([`Simulation::checkpoint`]) to one file every `interval` time units and
/// at the end of the run, so that a long run can be resumed with [`Simulation::restore`].
pub struct Checkpoints {
    path: PathBuf,
    every: Every,
}

impl Checkpoints {
    /// Checkpoints to `path` every `interval` time units.
    ///
    /// # Errors
    /// `interval` not finite and `> 0`.
    pub fn new(path: impl Into<PathBuf>, interval: f64) -> Result<Self> {
        Ok(Checkpoints { path: path.into(), every: Every::new(interval)? })
    }
}

impl<T: Real> Observer<T> for Checkpoints {
    fn start(&mut self, sim: &Simulation<T>) -> Result<()> {
        self.every.start_at(sim.time().f64());
        Ok(())
    }
    fn observe(&mut self, sim: &Simulation<T>, r: &StepReport) -> Result<()> {
        if self.every.due(r.flow.time) { sim.checkpoint(&self.path) } else { Ok(()) }
    }
    fn finish(&mut self, sim: &Simulation<T>) -> Result<()> {
        sim.checkpoint(&self.path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fires_once_per_interval_whatever_the_rounding() {
        let mut e = Every::new(0.1).unwrap();
        let mut fired = Vec::new();
        let mut t = 0.0;
        for step in 1..=100 {
            t += 0.01;
            if e.due(t) {
                fired.push(step);
            }
        }
        assert_eq!(fired, (1..=10).map(|k| 10 * k).collect::<Vec<_>>());
        let mut e = Every::new(0.25).unwrap();
        e.start_at(0.5);
        assert!(!e.due(0.6) && e.due(0.75) && !e.due(0.8) && e.due(1.1));
        assert!(Every::new(0.0).is_err() && Every::new(f64::NAN).is_err());
    }
}
