//! [`Method::ShakenLattice`](super::Method::ShakenLattice): the capsules on the widest lattice
//! the room holds, then shaken by hard-sphere Monte Carlo moves.

use super::{Bins, Orientation, Placed, Placement, Rotation, Xoshiro256StarStar};
use crate::{Error, Result};

/// The acceptance ratio the step of the moves is steered to (between 0.3 and 0.5).
const ACCEPTANCE: (f64, f64) = (0.3, 0.5);

impl Placement {
    /// The spacing of `n` lattice sites along axis `d` of the room `lo..hi`: the period over
    /// `n` on a periodic axis; on a walled axis the sites at both ends (`inf` for one site).
    fn site_spacing(&self, d: usize, n: usize, lo: f64, hi: f64) -> f64 {
        match (self.domain.periodic[d], n) {
            (true, _) => (hi - lo) / n as f64,
            (false, 1) => f64::INFINITY,
            (false, _) => (hi - lo) / (n - 1) as f64,
        }
    }

    /// The lattice of at least `count` sites whose smallest spacing is largest (fewest sites
    /// among equals), with that spacing.
    fn widest_lattice(&self, count: usize, lo: [f64; 3], hi: [f64; 3]) -> ([usize; 3], f64) {
        let mut best = ([count, 1, 1], 0.0);
        for n0 in 1..=count {
            for n1 in 1..=count.div_ceil(n0) {
                let n = [n0, n1, count.div_ceil(n0 * n1)];
                let s =
                    (0..3).map(|d| self.site_spacing(d, n[d], lo[d], hi[d])).fold(f64::INFINITY, f64::min);
                let sites = n[0] * n[1] * n[2];
                if s > best.1 || (s == best.1 && sites < best.0.iter().product()) {
                    best = (n, s);
                }
            }
        }
        best
    }

    /// Places the capsules on the widest lattice, `count` of its sites drawn at random, and
    /// shakes them with `sweeps` sweeps of hard-sphere Monte Carlo moves.
    pub(super) fn place_shaken(&self, count: usize, sweeps: usize) -> Result<Placed> {
        let dom = &self.domain;
        let proto = &self.prototype;
        let diameter = 2.0 * proto.bounding_radius() + self.gap;
        // Between the walls less the bounding radius for random orientations: every
        // orientation then clears the walls.
        let rb = proto.bounding_radius();
        let (lo, hi) = self.centre_room(|d| if proto.random() { rb } else { proto.wall_extent(d) });
        let (n, spacing) = self.widest_lattice(count, lo, hi);
        if spacing < diameter {
            let (name, value) = self.target_name();
            return Err(Error::invalid(
                name,
                format!(
                    "{value} ({count} capsules: the widest lattice of the room, {n:?} sites, spaces them \
                     {spacing:.4} apart, less than the bounding diameter plus the gap {diameter:.4})"
                ),
                "a count a lattice of the room holds: fewer or smaller capsules, a smaller gap or wall \
                 distance, or a larger box",
            ));
        }
        let site = |d: usize, i: usize| match (dom.periodic[d], n[d]) {
            (true, m) => lo[d] + (i as f64 + 0.5) * (hi[d] - lo[d]) / m as f64,
            (false, 1) => 0.5 * (lo[d] + hi[d]),
            (false, m) => lo[d] + i as f64 * self.site_spacing(d, m, lo[d], hi[d]),
        };
        let mut sites: Vec<[f64; 3]> = Vec::with_capacity(n[0] * n[1] * n[2]);
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    sites.push([site(0, i), site(1, j), site(2, k)]);
                }
            }
        }
        // `count` of the sites at random (a partial Fisher-Yates shuffle).
        let mut rng = Xoshiro256StarStar::new(self.seed);
        for p in 0..count {
            let q = p + (rng.next_u64() % (sites.len() - p) as u64) as usize;
            sites.swap(p, q);
        }
        sites.truncate(count);
        let mut centers = sites;
        let rotations: Vec<Rotation> = (0..count)
            .map(|_| match proto.orientation() {
                Orientation::Fixed(r) => r,
                Orientation::Random => Rotation::random(&mut rng),
            })
            .collect();
        let mut bins = Bins::new(dom, diameter, count);
        for (i, &c) in centers.iter().enumerate() {
            bins.insert(c, i);
        }
        // Moves of up to `step` along each axis, steered to the acceptance ratio.
        let mut step = 0.5 * (spacing - diameter).max(0.05 * diameter);
        let mut attempts = count;
        for _ in 0..sweeps {
            let mut accepted = 0;
            for i in 0..count {
                attempts += 1;
                let old = centers[i];
                let mut c: [f64; 3] = std::array::from_fn(|d| old[d] + step * rng.next_symmetric());
                let inside = (0..3).all(|d| dom.periodic[d] || (lo[d]..=hi[d]).contains(&c[d]));
                if !inside {
                    continue;
                }
                for d in 0..3 {
                    if dom.periodic[d] {
                        let l = dom.upper[d] - dom.lower[d];
                        c[d] -= l * ((c[d] - dom.lower[d]) / l).floor();
                    }
                }
                bins.remove(old, i);
                if bins.conflicts(dom, c, &centers, diameter) {
                    bins.insert(old, i);
                    continue;
                }
                bins.insert(c, i);
                centers[i] = c;
                accepted += 1;
            }
            let ratio = accepted as f64 / count as f64;
            if ratio > ACCEPTANCE.1 {
                step *= 1.1;
            } else if ratio < ACCEPTANCE.0 {
                step *= 0.9;
            }
            step = step.min(0.5 * diameter);
        }
        Ok(Placed { domain: *dom, prototype: *proto, centers, rotations, attempts })
    }
}
