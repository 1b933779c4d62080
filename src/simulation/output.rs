//! Output of a [`Simulation`]: ParaView snapshots (`.vti`) and checkpoints of the whole state.

use super::{Simulation, Traction};
use crate::Real;
use crate::grid::ops::cell_vector;
use crate::grid::{Field, SymField, Window};
use crate::io::checkpoint::{CheckpointReader, CheckpointWriter};
use crate::io::vtk::VtiWriter;
use crate::membrane::stress::tension_invariants;
use crate::{Error, Result};
use std::path::Path;

impl<T: Real> Simulation<T> {
    /// The scene's physics in one line: the phases, the capsules' [`Traction`] (one name where
    /// they share it, else one a capsule, comma-separated) and every effect's
    /// [`describe`](super::Effect::describe), as checkpoints record it.
    pub fn physics(&self) -> String {
        let names: Vec<&str> = self.capsules.iter().map(|c| c.traction().name()).collect();
        let traction = match names.first() {
            None => Traction::Smoothed.name().to_string(),
            Some(first) if names.iter().all(|n| n == first) => first.to_string(),
            Some(_) => names.join(","),
        };
        let mut s = format!(
            "outside rho={:e} mu={:e}; inside rho={:e} mu={:e}; traction={traction}",
            self.outside.rho.f64(),
            self.outside.mu.f64(),
            self.inside.rho.f64(),
            self.inside.mu.f64(),
        );
        for e in &self.effects {
            s.push_str("; ");
            s.push_str(&e.describe());
        }
        s
    }

    /// The numerical strategies in one line, by their names: the normal estimator, each
    /// capsule's interface transport, the momentum and the pressure solvers, e.g.
    /// `normals=atanh4; transport=mthinc; momentum=bicgstab; pressure=spectral_pcg`.
    /// Checkpoints record it beside the physics (a run may continue with other solvers, so a
    /// restore does not compare it).
    pub fn numerics(&self) -> String {
        let transports: Vec<&str> = self.capsules.iter().map(|c| c.transport.name()).collect();
        format!(
            "normals={}; transport={}; momentum={}; pressure={}",
            self.normals.name(),
            transports.join(","),
            self.flow.momentum_solver().name(),
            self.flow.pressure_solver().name()
        )
    }

    /// Writes a ParaView snapshot (VTK XML image data, raw appended binary) of the whole grid:
    /// `phi` (all capsules together, and per capsule when there are several), the velocity at
    /// cell centres, the pressure, `delta`, and with elasticity the principal tensions `t1`,
    /// `t2` and the area dilation `j_s` on the membrane bands (summed where two bands overlap).
    /// Pair it with a [`PvdSeries`](crate::io::vtk::PvdSeries) for a time series.
    pub fn write_vti(&self, path: impl AsRef<Path>) -> Result<()> {
        let g = &self.grid;
        let caps = &self.capsules;
        // The capsules' box fields `f` added into one field of the whole grid.
        let total = |f: fn(&super::capsule::Level<T>) -> &Field<T>| -> Result<Field<T>> {
            let mut out = Field::zeros(g);
            for cap in caps {
                cap.boxed.window.add_to(&cap.boxed.grid, f(&cap.cur), g, &mut out)?;
            }
            Ok(out)
        };
        let mut w = VtiWriter::new(g);
        let phi = total(|l| &l.phi)?;
        w.scalar("phi", &phi);
        let mut each = Vec::new();
        if caps.len() > 1 {
            for cap in caps {
                let mut one = Field::zeros(g);
                cap.boxed.window.add_to(&cap.boxed.grid, &cap.cur.phi, g, &mut one)?;
                each.push(one);
            }
        }
        for (c, one) in each.iter().enumerate() {
            w.scalar(&format!("phi_{c}"), one);
        }
        w.vector("velocity", self.flow.velocity()).scalar("pressure", self.flow.pressure());
        let delta = total(|l| &l.delta)?;
        w.scalar("delta", &delta);
        // The in-plane law of each capsule (the first effect that gives one).
        let laws: Vec<_> =
            (0..caps.len()).map(|c| self.effects.iter().find_map(|e| e.surface_law(c))).collect();
        let mut tensions = Vec::new();
        if laws.iter().any(|l| l.is_some()) {
            type Of<T> = fn(&crate::membrane::stress::TensionInvariants<T>) -> T;
            let parts: [(&str, Of<T>); 3] = [("t1", |t| t.t1), ("t2", |t| t.t2), ("j_s", |t| t.dilation)];
            for (name, of) in parts {
                let mut field = Field::zeros(g);
                for (cap, law) in caps.iter().zip(&laws) {
                    let (Some(gs), Some(law)) = (cap.gs.as_ref(), law) else { continue };
                    let (l, bg) = (&cap.cur, &cap.boxed.grid);
                    let mut f = Field::zeros(bg);
                    for &idx in l.band.cells() {
                        let n = cell_vector(&l.normal, idx);
                        f.data[idx] = of(&tension_invariants(*law, &gs.get(idx), &n));
                    }
                    cap.boxed.window.add_to(bg, &f, g, &mut field)?;
                }
                tensions.push((name, field));
            }
        }
        for (name, f) in &tensions {
            w.scalar(name, f);
        }
        w.write(path)
    }

    /// Writes the whole state (flow with its time history, every capsule's `phi`,
    /// `kappa_R tilde`, `G_s`, reference-area target and AB2 histories) atomically to `path`.
    /// A simulation restored from it by [`restore`](Self::restore) continues bit for bit like
    /// the uninterrupted one.
    pub fn checkpoint(&self, path: impl AsRef<Path>) -> Result<()> {
        let mut w = CheckpointWriter::new();
        self.flow.checkpoint(&mut w, "flow.");
        w.text("physics", &self.physics()).text("numerics", &self.numerics());
        w.number("capsules", self.capsules.len() as f64);
        for (c, cap) in self.capsules.iter().enumerate() {
            let p = format!("capsule{c}.");
            let win = &cap.boxed.window;
            for (d, (f, n)) in win.first().into_iter().zip(win.size()).enumerate() {
                w.number(&format!("{p}first{d}"), f as f64);
                w.number(&format!("{p}size{d}"), n as f64);
            }
            w.array(&format!("{p}phi"), &cap.cur.phi.data);
            if let Some(k) = &cap.cur.kappa {
                w.array(&format!("{p}kappa"), &k.data);
            }
            if let Some(gs) = &cap.gs {
                for (k, f) in gs.c.iter().enumerate() {
                    w.array(&format!("{p}gs{k}"), &f.data);
                }
            }
            if let Some(target) = cap.reference_target {
                w.number(&format!("{p}reference_target"), target);
            }
            cap.transport.checkpoint(&mut w, &p);
            if let Some((cells, tend)) = cap.strain.as_ref().and_then(|s| s.history()) {
                let cells: Vec<f64> = cells.iter().map(|&i| i as f64).collect();
                let flat: Vec<T> = tend.iter().flat_map(|t| t.iter().copied()).collect();
                w.number(&format!("{p}strain_count"), cells.len() as f64);
                w.array(&format!("{p}strain_cells"), &cells).array(&format!("{p}strain_tendencies"), &flat);
            }
        }
        w.save(path)
    }

    /// Restores a state written by [`checkpoint`](Self::checkpoint) into a simulation built
    /// from the same scene. The state is replaced only if everything could be read, except the
    /// interface transports' histories
    /// ([`InterfaceTransport::restore`](crate::interface::advect::InterfaceTransport::restore)), read
    /// last: a transport that refuses its entries leaves the fields restored and the error
    /// returned.
    ///
    /// # Errors
    /// [`Error::Io`] for an unreadable or malformed file; [`Error::InvalidParameter`] for a
    /// checkpoint of another grid or scene: `checkpoint physics` with the checkpoint's and the
    /// scene's [`physics`](Self::physics) when they differ (a checkpoint written before the
    /// physics recorded the traction is refused so, saying so), `checkpoint capsules` with
    /// both counts.
    pub fn restore(&mut self, path: impl AsRef<Path>) -> Result<()> {
        let r = CheckpointReader::open(path)?;
        let physics = r.text("physics")?;
        let scene = self.physics();
        if physics != scene {
            // Older checkpoints record no traction: which one ran is unknown.
            let old = if physics.contains("; traction=") {
                ""
            } else {
                " (written before checkpoints recorded the traction, so its traction is unknown)"
            };
            return Err(Error::invalid(
                "checkpoint physics",
                format!("`{physics}`{old}; this scene's is `{scene}`"),
                "the physics of the scene it is restored into (Simulation::physics)",
            ));
        }
        let count = r.number("capsules")?;
        if count != self.capsules.len() as f64 {
            return Err(Error::invalid(
                "checkpoint capsules",
                format!("{count}; this scene has {}", self.capsules.len()),
                "the capsule count of this scene",
            ));
        }
        // Read everything first.
        let mut read = Vec::with_capacity(self.capsules.len());
        for (c, cap) in self.capsules.iter().enumerate() {
            let p = format!("capsule{c}.");
            // Where its box was and how large (a box follows its capsule and grows with it;
            // checkpoints written before boxes grew record no size: the scene's).
            let window = match r.has(&format!("{p}first0")) {
                false => cap.boxed.window.clone(),
                true => {
                    let (mut first, mut size) = ([0isize; 3], cap.boxed.window.size());
                    for d in 0..3 {
                        first[d] = r.number(&format!("{p}first{d}"))? as isize;
                        let name = format!("{p}size{d}");
                        if r.has(&name) {
                            size[d] = r.number(&name)? as usize;
                        }
                    }
                    Window::new(&self.grid, first, size)?
                }
            };
            let g = &window.grid(&self.grid);
            let len = g.len();
            let field = |name: &str| -> Result<Field<T>> { Ok(Field { data: r.array(name, len)? }) };
            let phi = field(&format!("{p}phi"))?;
            let kappa = match &cap.cur.kappa {
                Some(_) => Some(field(&format!("{p}kappa"))?),
                None => None,
            };
            let gs = match &cap.gs {
                Some(_) => {
                    let mut s = SymField::zeros(g);
                    for (k, f) in s.c.iter_mut().enumerate() {
                        *f = field(&format!("{p}gs{k}"))?;
                    }
                    Some(s)
                }
                None => None,
            };
            let strain = if r.has(&format!("{p}strain_count")) {
                let count = r.number(&format!("{p}strain_count"))? as usize;
                let cells: Vec<f64> = r.array(&format!("{p}strain_cells"), count)?;
                let flat: Vec<T> = r.array(&format!("{p}strain_tendencies"), 6 * count)?;
                let tend: Vec<[T; 6]> = flat.chunks_exact(6).map(|c| std::array::from_fn(|k| c[k])).collect();
                Some((cells.iter().map(|&x| x as usize).collect::<Vec<usize>>(), tend))
            } else {
                None
            };
            // A target only where this scene conserves the reference area (older checkpoints
            // lack it: the build's target stays).
            let target_name = format!("{p}reference_target");
            let target = if cap.reference_target.is_some() && r.has(&target_name) {
                Some(r.number(&target_name)?)
            } else {
                None
            };
            read.push((window, phi, kappa, gs, strain, target));
        }
        // Then replace: the flow first (it validates the grid), then the capsules.
        self.flow.restore(&r, "flow.")?;
        let mut resized = Vec::new();
        for (c, (cap, (window, phi, kappa, gs, strain, target))) in
            self.capsules.iter_mut().zip(read).enumerate()
        {
            if window.size() != cap.boxed.window.size() {
                // A box that grew in the run: the capsule's storage made there first.
                cap.regrow(&self.grid, window.clone(), &self.settings, self.normals.as_mut())?;
                resized.push(c);
            }
            cap.boxed.grid = window.grid(&self.grid);
            cap.boxed.window = window;
            if target.is_some() {
                cap.reference_target = target;
            }
            cap.cur.phi = phi;
            cap.cur.kappa = kappa;
            cap.gs = gs;
            cap.cur.derive(&cap.boxed.grid, self.normals.as_mut())?;
            cap.transport.restore(&r, &format!("capsule{c}."))?;
            if let Some(s) = cap.strain.as_mut() {
                match strain {
                    Some((cells, tend)) => s.restore_history(&cells, &tend)?,
                    None => s.reset_history(),
                }
            }
        }
        self.capsule_grids = self.capsules.iter().map(|c| c.boxed.grid.clone()).collect();
        self.box_resized(&resized)?;
        if let Some(v) = self.v_old.as_mut() {
            v.copy_from(self.flow.velocity());
        }
        Ok(())
    }
}
