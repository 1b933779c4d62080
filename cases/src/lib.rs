//! # eulermembrane-cases
//!
//! The validation tooling of `eulermembrane`, kept out of the library: the examples (in this
//! crate's `examples/`) and the integration tests that run the paper's cases use it, a user of
//! the library does not need it.
//!
//! - [`plot`]: a small, dependency-free SVG plotting builder ([`plot::Figure`]) for the line
//!   plots, marker plots and contour plots that the examples write next to their CSV output, and
//!   marching squares ([`plot::contour_segments`]) to draw an interface from a sampled field;
//! - [`csv`]: time series and profiles written with full precision ([`csv::CsvWriter`],
//!   [`csv::write_columns`]), read back ([`csv::read_columns`]), and published reference curves
//!   read from two-column files ([`csv::read_xy`]);
//! - the cases shared by the examples and the tests: [`flows`] (Taylor-Green, channel and
//!   two-layer flows against their exact solutions), [`vortex`] (the single vortex of Sec. 3.1),
//!   [`shear`] (the capsule in shear of Sec. 3.3) and [`stability`] (the hard cases of the
//!   stability suite);
//! - at the crate root, what every example's `main` uses: its flags ([`Args`], read from the
//!   example's own header), the options of the membrane terms they choose ([`Terms`]), the
//!   `RESULT` line ([`result`], [`num`]), progress lines, CPU time and the reference data folder
//!   `cases/reference` ([`reference_dir`]).
#![warn(missing_docs)]

use eulermembrane::membrane::{bending::BendingForm, law::SurfaceLaw, strain::StrainAdvection};
use eulermembrane::simulation::{Bending, BendingCoupling, Elasticity, MembraneCoupling, Traction};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

pub mod cost;
pub mod csv;
mod files;
pub mod flows;
pub mod plot;
pub mod shear;
pub mod stability;
pub mod vortex;

/// What an example's body returns.
pub type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

/// The `main` of an example: on error prints `error: ...` to stderr and exits with status 1.
pub fn exit_on_error(result: BoxResult<()>) {
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// Command-line flags `--key value` and bare `--flag`, checked against the example's header.
///
/// The header (the leading `//!` lines of the example's source) is the one place an example's
/// flags are described: `--help` prints it, and a flag it does not name is refused with exit
/// status 2 before anything runs, so a misspelt flag never silently runs the default case.
pub struct Args {
    map: HashMap<String, String>,
    known: Vec<String>,
}

impl Args {
    /// Parses `std::env::args()` against `source`, the example's own text
    /// (`include_str!("name.rs")`): every `--name` of its header is a known flag.
    pub fn parse(source: &str) -> Self {
        let help = header(source);
        let argv: Vec<String> = std::env::args().skip(1).collect();
        match Self::from_list(&help, &argv) {
            Ok(Some(args)) => args,
            Ok(None) => {
                println!("{help}");
                std::process::exit(0)
            }
            Err(msg) => {
                eprintln!("error: {msg}\n(`--help` lists the flags)");
                std::process::exit(2)
            }
        }
    }

    /// Parses `argv` against the header `help`; `None` where it asks for the help text.
    fn from_list(help: &str, argv: &[String]) -> Result<Option<Self>, String> {
        let known = flag_names(help);
        let mut map = HashMap::new();
        let mut i = 0;
        while i < argv.len() {
            let key = match argv[i].strip_prefix("--") {
                Some("help") => return Ok(None),
                Some(key) if known.iter().any(|k| k == key) => key,
                Some(key) => return Err(format!("unknown flag --{key}")),
                None if argv[i] == "-h" => return Ok(None),
                None => return Err(format!("unexpected argument `{}` (flags start with --)", argv[i])),
            };
            let has_value = i + 1 < argv.len() && !argv[i + 1].starts_with("--");
            let value = if has_value { argv[i + 1].clone() } else { String::new() };
            if map.insert(key.to_string(), value).is_some() {
                return Err(format!("--{key} given twice"));
            }
            i += if has_value { 2 } else { 1 };
        }
        Ok(Some(Args { map, known }))
    }

    /// The value of `key`, which the header must name (a fault of the example, not of its user).
    fn raw(&self, key: &str) -> Option<&String> {
        assert!(self.known.iter().any(|k| k == key), "the example's header does not describe --{key}");
        self.map.get(key)
    }

    /// A flag's value parsed as `T`, or `default`; exits with a message on a bad value.
    pub fn get<T: std::str::FromStr>(&self, key: &str, default: T) -> T {
        self.opt(key).unwrap_or(default)
    }

    /// A flag's value if given; exits with a message on a bad value.
    pub fn opt<T: std::str::FromStr>(&self, key: &str) -> Option<T> {
        self.raw(key).map(|v| parse_or_exit(key, v, None))
    }

    /// A comma-separated flag value (`--n 32,64`) parsed as a list of `T`, if given; exits with
    /// a message naming the flag on a bad item.
    pub fn list<T: std::str::FromStr>(&self, key: &str) -> Option<Vec<T>> {
        self.raw(key)
            .map(|text| text.split(',').map(|item| parse_or_exit(key, text, Some(item.trim()))).collect())
    }

    /// Whether a bare flag is present.
    pub fn flag(&self, key: &str) -> bool {
        self.raw(key).is_some()
    }

    /// `Bending::coupling` from `--bending-coupling semi-implicit|explicit` (default
    /// semi-implicit, the library's) and `--bending-alpha` (1).
    ///
    /// # Errors
    /// Any other coupling name.
    pub fn bending_coupling(&self) -> BoxResult<BendingCoupling> {
        match self.get("bending-coupling", "semi-implicit".to_string()).as_str() {
            "explicit" => Ok(BendingCoupling::Explicit),
            "semi-implicit" => Ok(BendingCoupling::SemiImplicit { alpha: self.get("bending-alpha", 1.0) }),
            other => Err(format!("--bending-coupling {other}: explicit or semi-implicit").into()),
        }
    }

    /// `Elasticity::coupling` from `--membrane-coupling quasi-implicit|explicit` (default
    /// quasi-implicit, the library's and the paper's).
    ///
    /// # Errors
    /// Any other coupling name.
    pub fn membrane_coupling(&self) -> BoxResult<MembraneCoupling> {
        match self.get("membrane-coupling", "quasi-implicit".to_string()).as_str() {
            "quasi-implicit" => Ok(MembraneCoupling::QuasiImplicit),
            "explicit" => Ok(MembraneCoupling::Explicit),
            other => Err(format!("--membrane-coupling {other}: quasi-implicit or explicit").into()),
        }
    }

    /// `Settings::strain_advection` from `--strain-advection upwind3|upwind5` (default upwind3,
    /// the library's and the paper's).
    ///
    /// # Errors
    /// Any other scheme name.
    pub fn strain_advection(&self) -> BoxResult<StrainAdvection> {
        match self.get("strain-advection", "upwind3".to_string()).as_str() {
            "upwind3" => Ok(StrainAdvection::Upwind3),
            "upwind5" => Ok(StrainAdvection::Upwind5),
            other => Err(format!("--strain-advection {other}: upwind3 or upwind5").into()),
        }
    }

    /// `Elasticity::traction` from `--traction sharp-resampled|sharp|smoothed` (`default` without it).
    ///
    /// # Errors
    /// Any other traction name.
    pub fn traction(&self, default: Traction) -> BoxResult<Traction> {
        match self.raw("traction") {
            Some(name) => Ok(Traction::from_name(name)?),
            None => Ok(default),
        }
    }

    /// The output folder (`--out`, default `out/<name>`), created.
    pub fn out_dir(&self, name: &str) -> PathBuf {
        let dir = PathBuf::from(self.raw("out").cloned().unwrap_or_else(|| format!("out/{name}")));
        if let Err(e) = std::fs::create_dir_all(&dir) {
            eprintln!("error: cannot create {}: {e}", dir.display());
            std::process::exit(1);
        }
        dir
    }
}

/// The value `text` of flag `--key`, or its list item `item`, parsed as `T`; exits with status 2
/// and a message naming the flag (and the item) where it is not one.
fn parse_or_exit<T: std::str::FromStr>(key: &str, text: &str, item: Option<&str>) -> T {
    item.unwrap_or(text).parse().unwrap_or_else(|_| {
        match item {
            None => eprintln!("error: --{key} {text}: not a valid value"),
            Some(item) => eprintln!("error: --{key} {text}: `{item}` is not a valid item"),
        }
        std::process::exit(2)
    })
}

/// The leading `//!` lines of an example's source, without the markers.
fn header(source: &str) -> String {
    let lines: Vec<&str> = source
        .lines()
        .map_while(|l| l.strip_prefix("//!"))
        .map(|l| l.strip_prefix(' ').unwrap_or(l))
        .collect();
    lines.join("\n")
}

/// Every `--name` in `help` (letters, digits and `-` after the dashes). On a line that shows a
/// `cargo` command, only what follows its `-- ` separator counts (not `--release`).
fn flag_names(help: &str) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for line in help.lines() {
        let line = match line.contains("cargo ") {
            true => line.split_once("-- ").map_or("", |(_, after)| after),
            false => line,
        };
        for (at, _) in line.match_indices("--") {
            let name: String =
                line[at + 2..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '-').collect();
            if name.starts_with(|c: char| c.is_ascii_alphabetic()) && !names.contains(&name) {
                names.push(name);
            }
        }
    }
    names
}

/// The options of the membrane terms a case builds, the library's defaults by default: each
/// term owns its own ([`Elasticity::traction`], [`Elasticity::coupling`], [`Bending::form`],
/// [`Bending::coupling`]), and the examples' flags choose them together.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Terms {
    /// The elasticity's traction (`--traction`).
    pub traction: Traction,
    /// The coupling of the elasticity's stress to the predictor.
    pub coupling: MembraneCoupling,
    /// The bending force's form (`--bending-form`).
    pub bending_form: BendingForm,
    /// The coupling of the bending force to the predictor (`--bending-coupling`).
    pub bending_coupling: BendingCoupling,
}

impl Terms {
    /// The elasticity with `law` and these options.
    pub fn elasticity<T: eulermembrane::Real>(&self, law: impl SurfaceLaw<T> + 'static) -> Elasticity<T> {
        Elasticity::new(law).traction(self.traction).coupling(self.coupling)
    }

    /// The bending with modulus `eb` and these options.
    ///
    /// # Errors
    /// Those of [`Bending::new`].
    pub fn bending<T: eulermembrane::Real>(&self, eb: T) -> eulermembrane::Result<Bending<T>> {
        Ok(Bending::new(eb)?.form(self.bending_form).coupling(self.bending_coupling))
    }
}

/// Observed order of convergence between two errors at resolutions `n1 < n2`.
pub fn order(e1: f64, e2: f64, n1: f64, n2: f64) -> f64 {
    (e1 / e2).ln() / (n2 / n1).ln()
}

/// Prints the machine-readable RESULT line.
pub fn result(pairs: &[(&str, String)]) {
    let body: Vec<String> = pairs.iter().map(|(k, v)| format!("{k}={v}")).collect();
    println!("RESULT {}", body.join(" "));
}

/// Formats a number for a RESULT line.
pub fn num(x: f64) -> String {
    format!("{x:.4e}")
}

/// The folder `sub` of the published reference data: `cases/reference/<sub>` of this package
/// (see its README for the sources), unless `given` (a folder laid out the same way).
///
/// Errors: a message naming the folder when it does not exist.
pub fn reference_dir(given: Option<PathBuf>, sub: &str) -> Result<PathBuf, Box<dyn std::error::Error>> {
    let d = given.unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("reference")).join(sub);
    match d.is_dir() {
        true => Ok(d),
        false => Err(format!("reference data folder {} not found; pass --reference DIR", d.display()).into()),
    }
}

/// On-CPU time of all threads of the process in seconds (`/proc/self/task/*/schedstat`, Linux;
/// panics elsewhere). Unlike [`cpu_seconds`] it counts every rayon worker.
pub fn process_cpu_seconds() -> f64 {
    let tasks = std::fs::read_dir("/proc/self/task").expect("/proc/self/task (Linux only)");
    let ns: u64 = tasks
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum();
    ns as f64 * 1e-9
}

/// CPU seconds (user + system) the calling thread has used, from `/proc/thread-self/stat`
/// (Linux; NaN elsewhere). Inside a one-thread rayon pool every parallel loop of the library
/// runs on that thread, so differences measure a run's cost independently of the machine's load.
pub fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap_or_default();
    // Fields after the parenthesised command name start at field 3 (state); utime and stime
    // are fields 14 and 15, in clock ticks of 1/100 s.
    let fields: Vec<&str> = stat.rsplit_once(')').map_or(vec![], |(_, r)| r.split_whitespace().collect());
    let tick = |k: usize| fields.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (tick(11) + tick(12)) / 100.0
}

/// Whether step `s` of a run of `steps` steps is a progress step: every 5 % and the last one.
/// The cadence of [`progress`], and of the flushes of the examples' CSV files.
pub fn progress_due(s: usize, steps: usize) -> bool {
    s.is_multiple_of((steps / 20).max(1)) || s == steps
}

/// Prints a progress line of a run of `steps` steps to stderr at each [`progress_due`] step:
/// step, time, `extra`, elapsed and remaining wall time.
pub fn progress(s: usize, steps: usize, t: f64, clock: &std::time::Instant, extra: &str) {
    progress_since(0, s, steps, t, clock, extra);
}

/// [`progress`] for a run that started (or restarted) at step `first`, when `clock` started:
/// the remaining time is estimated from the steps made since then.
pub fn progress_since(first: usize, s: usize, steps: usize, t: f64, clock: &std::time::Instant, extra: &str) {
    if progress_due(s, steps) {
        progress_line(first, s, steps, t, clock, extra);
    }
}

/// The line of [`progress_since`], printed whether or not the step is a [`progress_due`] one
/// (for runs that choose their own progress times).
pub fn progress_line(first: usize, s: usize, steps: usize, t: f64, clock: &std::time::Instant, extra: &str) {
    let el = clock.elapsed().as_secs_f64();
    eprintln!(
        "  step {s}/{steps} t={t:.3} {extra} ({el:.0} s, ~{:.0} s left)",
        el * (steps - s) as f64 / (s - first).max(1) as f64
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(argv: &[&str]) -> Result<Option<Args>, String> {
        let help = "Flags: `--n N`, `--box LX,LY,LZ`, `--sweep`.\nRun: `cargo run --release -- --n 8`.";
        Args::from_list(help, &argv.iter().map(|a| a.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn flags_values_and_lists() {
        let Ok(Some(a)) = args(&["--n", "64", "--box", "8, 4,16", "--sweep"]) else { panic!("parse failed") };
        assert_eq!(a.get("n", 32), 64);
        assert!(a.flag("sweep"));
        assert_eq!(a.list::<f64>("box"), Some(vec![8.0, 4.0, 16.0]));
        let Ok(Some(b)) = args(&[]) else { panic!("parse failed") };
        assert_eq!(b.get("n", 32), 32);
        assert_eq!(b.list::<f64>("box"), None);
        assert!(!b.flag("sweep"));
    }

    #[test]
    fn unknown_repeated_and_help() {
        let error = |argv: &[&str]| args(argv).err().unwrap_or_default();
        assert!(error(&["--release"]).contains("--release"));
        assert!(error(&["--n", "1", "--n", "2"]).contains("twice"));
        assert!(error(&["64"]).contains("`64`"));
        assert!(matches!(args(&["--help"]), Ok(None)));
    }
}
