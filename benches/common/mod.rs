//! What the benches share: a criterion [`Measurement`] of the CPU time of the whole process.
//!
//! The 2-core development machine is shared with other people's compilers and runs (load
//! averages of 10-20 are common), so wall time measures mostly the queue. The CPU time that
//! this process's threads actually ran (the sum of `/proc/self/task/*/schedstat`, in
//! nanoseconds, Linux only) is much less sensitive to it; cache sharing and frequency changes
//! still leak in. Run the benches with `RAYON_NUM_THREADS=1` to read single-core costs.

use criterion::Throughput;
use criterion::measurement::{Measurement, ValueFormatter};

/// CPU time of all threads of the process, in nanoseconds.
pub struct CpuTime;

/// Sum of the on-CPU time of the process's threads, in nanoseconds.
fn cpu_ns() -> u64 {
    let tasks = std::fs::read_dir("/proc/self/task").expect("/proc/self/task (Linux only)");
    tasks
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}

impl Measurement for CpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        cpu_ns()
    }
    fn end(&self, start: u64) -> u64 {
        cpu_ns().saturating_sub(start)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuFormatter
    }
}

/// Formats CPU nanoseconds like criterion's wall-time formatter, with "cpu" in the units.
struct CpuFormatter;

impl ValueFormatter for CpuFormatter {
    fn scale_values(&self, ns: f64, values: &mut [f64]) -> &'static str {
        let (factor, unit) = if ns < 1e3 {
            (1.0, "ns cpu")
        } else if ns < 1e6 {
            (1e-3, "µs cpu")
        } else if ns < 1e9 {
            (1e-6, "ms cpu")
        } else {
            (1e-9, "s cpu")
        };
        values.iter_mut().for_each(|v| *v *= factor);
        unit
    }

    fn scale_throughputs(&self, typical: f64, throughput: &Throughput, values: &mut [f64]) -> &'static str {
        let per_ns = match *throughput {
            Throughput::Elements(e) | Throughput::ElementsAndBytes { elements: e, .. } => e as f64,
            Throughput::Bytes(b) | Throughput::BytesDecimal(b) => b as f64,
            Throughput::Bits(b) => b as f64,
        };
        let rate = per_ns * 1e9 / typical;
        let (den, unit) = if rate < 1e3 {
            (1.0, "/cpu-s")
        } else if rate < 1e6 {
            (1e3, "K/cpu-s")
        } else {
            (1e6, "M/cpu-s")
        };
        values.iter_mut().for_each(|v| *v = per_ns * 1e9 / *v / den);
        unit
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

/// A criterion configured with [`CpuTime`].
pub fn criterion() -> criterion::Criterion<CpuTime> {
    criterion::Criterion::default().with_measurement(CpuTime)
}
