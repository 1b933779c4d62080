//! (feature `mpi`) The parts of a decomposed grid as the ranks of an MPI communicator, through
//! the `mpi` crate (the system's MPI library: OpenMPI or MPICH).

use super::decomposition::Exchange;
use crate::{Error, Result};
use mpi::Count;
use mpi::datatype::{Partition, PartitionMut};
use mpi::environment::Threading;
use mpi::point_to_point::send_receive_into_with_tags;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::CommunicatorCollectives;
use std::sync::Mutex;

/// Tags of the two messages of a [`swap`](Exchange::swap).
const DOWN: i32 = 1;
const UP: i32 = 2;

/// The ranks of an MPI communicator as the parts of a decomposed grid: part `p` is rank `p`.
///
/// MPI must have been initialised with at least [`Threading::Serialized`] (e.g.
/// `mpi::initialize_with_threading(Threading::Serialized)`): the exchange serialises its own
/// calls, which may come from any thread.
///
/// ```no_run
/// use eulermembrane::grid::{Decomposition, Grid, MpiExchange};
/// use mpi::environment::Threading;
/// use std::sync::Arc;
///
/// let (universe, _) = mpi::initialize_with_threading(Threading::Serialized).unwrap();
/// let exchange = MpiExchange::new(universe.world())?;
/// let whole = Grid::<f64>::periodic([64, 64, 64], [0.0; 3], [1.0; 3])?;
/// let parts = exchange.parts_count();
/// let mine = whole.split(Decomposition::slabs(2, parts)?, Arc::new(exchange))?;
/// # Ok::<(), eulermembrane::Error>(())
/// ```
pub struct MpiExchange {
    comm: Mutex<SimpleCommunicator>,
    part: usize,
    parts: usize,
}

// SAFETY: the communicator is a handle that MPI allows any thread to use when MPI runs with
// `Threading::Serialized` or above (checked in `new`) and calls are not concurrent, which the
// mutex around it ensures.
unsafe impl Send for MpiExchange {}
// SAFETY: as for `Send`: every use of the communicator holds the mutex.
unsafe impl Sync for MpiExchange {}

impl std::fmt::Debug for MpiExchange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MpiExchange {{ rank: {}, size: {} }}", self.part, self.parts)
    }
}

impl MpiExchange {
    /// The ranks of `comm`. Errors: MPI initialised with less than [`Threading::Serialized`].
    pub fn new(comm: SimpleCommunicator) -> Result<Self> {
        let threading = mpi::environment::threading_support();
        if threading < Threading::Serialized {
            return Err(Error::invalid(
                "MPI threading",
                format!("{threading:?}"),
                "Serialized or Multiple (mpi::initialize_with_threading)",
            ));
        }
        let (part, parts) = (comm.rank() as usize, comm.size() as usize);
        Ok(MpiExchange { comm: Mutex::new(comm), part, parts })
    }

    /// The number of ranks (the parts a [`Decomposition`](super::Decomposition) must have).
    pub fn parts_count(&self) -> usize {
        self.parts
    }
}

impl Exchange for MpiExchange {
    fn part(&self) -> usize {
        self.part
    }

    fn parts(&self) -> usize {
        self.parts
    }

    fn swap(
        &self,
        lower: usize,
        upper: usize,
        to_lower: &[f64],
        to_upper: &[f64],
        from_lower: &mut [f64],
        from_upper: &mut [f64],
    ) {
        let comm = self.comm.lock().expect("the communicator");
        let (lo, hi) = (comm.process_at_rank(lower as i32), comm.process_at_rank(upper as i32));
        send_receive_into_with_tags(to_lower, &lo, DOWN, from_upper, &hi, DOWN);
        send_receive_into_with_tags(to_upper, &hi, UP, from_lower, &lo, UP);
    }

    fn all_gather(&self, mine: &[f64], all: &mut [f64]) {
        self.comm.lock().expect("the communicator").all_gather_into(mine, all);
    }

    fn all_to_all(&self, send: &[f64], send_counts: &[usize], recv: &mut [f64], recv_counts: &[usize]) {
        let table = |counts: &[usize]| -> (Vec<Count>, Vec<Count>) {
            let c: Vec<Count> = counts.iter().map(|&x| x as Count).collect();
            let d = c.iter().scan(0, |at, &x| Some(std::mem::replace(at, *at + x))).collect();
            (c, d)
        };
        let ((sc, sd), (rc, rd)) = (table(send_counts), table(recv_counts));
        let comm = self.comm.lock().expect("the communicator");
        comm.all_to_all_varcount_into(&Partition::new(send, sc, sd), &mut PartitionMut::new(recv, rc, rd));
    }
}
