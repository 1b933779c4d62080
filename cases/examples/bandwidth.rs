//! Memory bandwidth of this machine, STREAM style: `copy` (`a = b`) and `triad`
//! (`a = b + s c`) over three arrays of `--mb` MiB each (default 128, far beyond the caches),
//! with 1 and 2 threads (rayon pools), `--reps` repetitions (default 20). Bytes are counted as
//! STREAM does (2 or 3 arrays per pass; the write-allocate read of `a` is not counted). Prints
//! the best and the median rate of each, in wall time and in CPU time (bytes per second that
//! the threads were on a core, i.e. bytes over CPU time / threads): on a shared machine the wall
//! rate measures the queue, the CPU rate what the memory delivers while we run.
//!
//! `cargo run --release --example bandwidth -- --mb 128 --reps 20`
use eulermembrane_cases as common;
use rayon::prelude::*;
use std::time::Instant;

fn main() {
    let args = common::Args::parse(include_str!("bandwidth.rs"));
    let mb: usize = args.get("mb", 128);
    let reps: usize = args.get("reps", 20);
    let len = mb * (1 << 20) / 8;
    let mut a = vec![0.0f64; len];
    let b: Vec<f64> = (0..len).map(|i| i as f64).collect();
    let c: Vec<f64> = (0..len).map(|i| (i % 7) as f64).collect();
    let chunk = 1 << 16;
    let mut rows = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        for (name, arrays) in [("copy", 2.0), ("triad", 3.0)] {
            let (mut rates, mut cpu_rates): (Vec<f64>, Vec<f64>) = (0..reps)
                .map(|_| {
                    let (t0, c0) = (Instant::now(), common::process_cpu_seconds());
                    pool.install(|| {
                        let it = a.par_chunks_mut(chunk).zip(b.par_chunks(chunk)).zip(c.par_chunks(chunk));
                        if name == "copy" {
                            it.for_each(|((a, b), _)| a.copy_from_slice(b));
                        } else {
                            it.for_each(|((a, b), c)| {
                                for ((x, &y), &z) in a.iter_mut().zip(b).zip(c) {
                                    *x = y + 3.0 * z;
                                }
                            });
                        }
                    });
                    let bytes = arrays * 8.0 * len as f64;
                    let cpu = (common::process_cpu_seconds() - c0) / threads as f64;
                    (bytes / t0.elapsed().as_secs_f64() / 1e9, bytes / cpu / 1e9)
                })
                .unzip();
            std::hint::black_box(&a);
            rates.sort_by(f64::total_cmp);
            cpu_rates.sort_by(f64::total_cmp);
            let (best, median) = (rates[reps - 1], rates[reps / 2]);
            let (cpu_best, cpu_median) = (cpu_rates[reps - 1], cpu_rates[reps / 2]);
            println!(
                "{name:>5}, {threads} thread(s): wall best {best:.1} GB/s, median {median:.1} GB/s; \
                 on-CPU best {cpu_best:.1} GB/s, median {cpu_median:.1} GB/s"
            );
            rows.push((format!("{name}_{threads}t_best_gbs"), format!("{best:.1}")));
            rows.push((format!("{name}_{threads}t_median_gbs"), format!("{median:.1}")));
            rows.push((format!("{name}_{threads}t_cpu_median_gbs"), format!("{cpu_median:.1}")));
        }
    }
    let rows: Vec<(&str, String)> = rows.iter().map(|(k, v)| (k.as_str(), v.clone())).collect();
    common::result(&rows);
}
