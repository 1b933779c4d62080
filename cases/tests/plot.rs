//! Plotting, marching squares and CSV: the SVG is well formed and says what it should, ticks
//! are right on both scales, contours of a circle close and sit on the circle, tables survive
//! a round trip bit for bit, published reference curves read, and neither the plotter nor the
//! CSV writer panics on bad input.

use eulermembrane::Error;
use eulermembrane_cases::csv::{CsvWriter, format_f64, read_columns, read_xy, write_columns};
use eulermembrane_cases::plot::{
    Color, Figure, Legend, LineStyle, Marker, Panels, Scale, contour_segments, linear_ticks, log_ticks,
};
use proptest::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// A scratch directory for this test binary, under the target directory's `tmp/`.
fn scratch(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("test-output/plot").join(name)
}

/// Checks that the tags of `svg` nest properly; returns the element names seen.
fn check_well_formed(svg: &str) -> Vec<String> {
    assert!(svg.starts_with("<svg"), "does not start with <svg: {}", &svg[..40.min(svg.len())]);
    assert!(svg.trim_end().ends_with("</svg>"));
    for bad in ["NaN", "inf"] {
        if let Some(k) = svg.find(bad) {
            panic!("non-finite number in the SVG: {}", &svg[k.saturating_sub(200)..k + 20]);
        }
    }
    let mut stack: Vec<String> = Vec::new();
    let mut seen = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        let end = rest[start..].find('>').expect("unclosed <") + start;
        let tag = &rest[start + 1..end];
        assert!(!tag.contains('<'), "'<' inside a tag: {tag}");
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack.pop().unwrap_or_else(|| panic!("</{name}> without opening tag"));
            assert_eq!(open, name.trim(), "mismatched tags");
        } else {
            let name = tag.split_whitespace().next().unwrap_or("").trim_end_matches('/');
            seen.push(name.to_string());
            if !tag.ends_with('/') {
                stack.push(name.to_string());
            }
        }
        // Text between tags holds no raw '>' or unescaped '&'.
        let next = rest[end + 1..].find('<').map_or(rest.len(), |n| n + end + 1);
        let text = &rest[end + 1..next];
        assert!(!text.contains('>'), "raw '>' in text {text:?}");
        for (k, _) in text.match_indices('&') {
            let entity = &text[k..];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"].iter().any(|e| entity.starts_with(e)),
                "unescaped & in {text:?}"
            );
        }
        rest = &rest[end + 1..];
    }
    assert!(stack.is_empty(), "unclosed tags: {stack:?}");
    seen
}

/// `phi`-like field `r0 - |x - c|` sampled on an n x n grid over [-1, 1]^2.
fn circle_field(n: usize, r0: f64, c: (f64, f64)) -> (Vec<f64>, f64) {
    let h = 2.0 / (n - 1) as f64;
    let mut v = vec![0.0; n * n];
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (-1.0 + i as f64 * h, -1.0 + j as f64 * h);
            v[i + n * j] = r0 - (x - c.0).hypot(y - c.1);
        }
    }
    (v, h)
}

/// Chains oriented segments into loops (end of one = start of the next, exactly); returns the
/// loops as point lists, or panics if a chain does not close.
fn chain_loops(segments: &[[(f64, f64); 2]]) -> Vec<Vec<(f64, f64)>> {
    let key = |p: (f64, f64)| (p.0.to_bits(), p.1.to_bits());
    let mut by_start: HashMap<(u64, u64), usize> = HashMap::new();
    for (k, s) in segments.iter().enumerate() {
        assert!(by_start.insert(key(s[0]), k).is_none(), "two segments start at {:?}", s[0]);
    }
    let mut used = vec![false; segments.len()];
    let mut loops = Vec::new();
    for first in 0..segments.len() {
        if used[first] {
            continue;
        }
        let mut points = Vec::new();
        let mut k = first;
        while !used[k] {
            used[k] = true;
            points.push(segments[k][0]);
            k = *by_start.get(&key(segments[k][1])).expect("open contour: no segment continues");
        }
        assert_eq!(k, first, "chain joins another loop midway");
        loops.push(points);
    }
    loops
}

fn shoelace(points: &[(f64, f64)]) -> f64 {
    let n = points.len();
    0.5 * (0..n)
        .map(|k| {
            let (a, b) = (points[k], points[(k + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
}

/// The shear reference curves of this package, where the examples find them.
fn reference_dir() -> PathBuf {
    eulermembrane_cases::reference_dir(None, "shear_neo_hookean").expect("cases/reference/shear_neo_hookean")
}

// ---------------------------------------------------------------------------------------------
// SVG
// ---------------------------------------------------------------------------------------------

#[test]
fn svg_is_well_formed_and_carries_its_labels() {
    let t: Vec<f64> = (0..60).map(|k| 0.1 * k as f64).collect();
    let d: Vec<f64> = t.iter().map(|t| 0.38 * (1.0 - (-1.5 * t).exp())).collect();
    let mut fig =
        Figure::new("Capsule <in> shear & more").x_label("γ̇t").y_label("Taylor D").size(700.0, 500.0);
    fig.line(&t, &d, "N = 32");
    fig.line(&t, &d.iter().map(|d| 0.9 * d).collect::<Vec<_>>(), "N = 16").style(LineStyle::Dashed);
    fig.markers(&[1.0, 2.0, 4.0], &[0.3, 0.35, 0.38], "Ramanujan & Pozrikidis")
        .filled(false)
        .marker(Marker::Triangle);
    fig.segments(vec![[(0.0, 0.1), (1.0, 0.1)]], "").color(Color::GREY);
    let svg = fig.to_svg();
    let tags = check_well_formed(&svg);
    for label in ["Capsule &lt;in&gt; shear &amp; more", "γ̇t", "Taylor D", "N = 32", "N = 16"] {
        assert!(svg.contains(label), "missing {label}");
    }
    assert!(svg.contains("Ramanujan &amp; Pozrikidis"));
    assert!(svg.contains("width=\"700\"") && svg.contains("height=\"500\""));
    assert!(svg.contains("stroke-dasharray"));
    assert!(svg.contains("clip-path"));
    // Two palette colours for the first two series, the override for the segments.
    assert!(svg.contains("#0072b2") && svg.contains("#d55e00") && svg.contains("#888888"));
    assert!(tags.iter().filter(|t| *t == "text").count() > 10, "tick labels missing");
    // Linear x ticks 0..6 over t in [0, 5.9]: labels 0, 1, ..., 5 (or a subset).
    assert!(svg.contains(">0</text>") && svg.contains(">4</text>"));
}

#[test]
fn log_ticks_are_decades_or_one_two_five() {
    assert_eq!(log_ticks(1e-3, 1e2, 10), vec![1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0]);
    assert_eq!(log_ticks(2e-3, 3e2, 10), vec![1e-2, 1e-1, 1.0, 10.0, 100.0]);
    assert_eq!(log_ticks(1e2, 1e-3, 10), log_ticks(1e-3, 1e2, 10), "order of bounds");
    // Too many decades for the budget: every third.
    assert_eq!(log_ticks(1e-12, 1.0, 5), vec![1e-12, 1e-9, 1e-6, 1e-3, 1.0]);
    // Less than two decades: 1-2-5.
    assert_eq!(log_ticks(1.0, 10.0, 8), vec![1.0, 2.0, 5.0, 10.0]);
    assert_eq!(log_ticks(0.03, 0.6, 8), vec![0.05, 0.1, 0.2, 0.5]);
    // Very short range: linear.
    assert_eq!(log_ticks(3.0, 5.0, 5), vec![3.0, 3.5, 4.0, 4.5, 5.0]);
    // Nothing sensible to tick.
    assert!(log_ticks(-1.0, 10.0, 5).is_empty());
    assert!(log_ticks(f64::NAN, 10.0, 5).is_empty());
    for (lo, hi, max) in [(1e-9, 1e9, 6), (0.5, 7e7, 4), (1e-300, 1e300, 8), (7.0, 7.5, 5)] {
        let ticks = log_ticks(lo, hi, max);
        assert!(!ticks.is_empty() && ticks.len() <= max, "{lo}..{hi}: {ticks:?}");
        assert!(ticks.iter().all(|&t| t >= lo * (1.0 - 1e-9) && t <= hi * (1.0 + 1e-9)));
        assert!(ticks.windows(2).all(|w| w[0] < w[1]));
    }
}

#[test]
fn log_axes_render_decade_labels() {
    let n = [8.0, 16.0, 32.0, 64.0, 128.0, 256.0];
    let err: Vec<f64> = n.iter().map(|n: &f64| 5.0 / n.powi(2)).collect();
    let mut fig =
        Figure::new("convergence").x_scale(Scale::Log10).y_scale(Scale::Log10).x_label("N").y_label("error");
    fig.line_markers(&n, &err, "phi");
    let svg = fig.to_svg();
    check_well_formed(&svg);
    // y from 7.6e-5 to 7.8e-2: decade labels 10^-4 .. 10^-2 with superscripts and minus signs.
    for e in ["\u{2212}4", "\u{2212}3", "\u{2212}2"] {
        assert!(svg.contains(&format!(">{e}</tspan>")), "missing 10^{e}");
    }
    // x from 8 to 256, less than three decades: 1-2-5 ticks in plain numbers.
    assert!(svg.contains(">10</text>") && svg.contains(">100</text>"));
}

#[test]
fn linear_ticks_are_nice_and_inside() {
    assert_eq!(linear_ticks(0.0, 10.0, 6), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
    assert_eq!(linear_ticks(-1.0, 1.0, 5), vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
    assert_eq!(linear_ticks(2.0, 2.0, 5), vec![2.0]);
    assert!(linear_ticks(0.0, f64::INFINITY, 5).is_empty());
    for (lo, hi, max) in
        [(0.013, 0.0171, 5), (-3e7, 4.2e8, 7), (1.0, 1.0 + 1e-12, 4), (-0.5, 1e-3, 2), (5.0, -5.0, 9)]
    {
        let ticks = linear_ticks(lo, hi, max);
        let (lo, hi) = (lo.min(hi), lo.max(hi));
        assert!(ticks.len() >= 2 && ticks.len() <= max.max(2), "{lo}..{hi}: {ticks:?}");
        let tol = 1e-9 * (hi - lo);
        assert!(ticks.iter().all(|&t| t >= lo - tol && t <= hi + tol), "{ticks:?}");
        let step = ticks[1] - ticks[0];
        let mantissa = step / 10f64.powf(step.log10().floor());
        assert!(
            [1.0, 2.0, 5.0, 10.0].iter().any(|m| (mantissa - m).abs() < 1e-3),
            "step {step} is not 1-2-5"
        );
    }
}

#[test]
fn degenerate_data_gives_a_figure_not_a_panic() {
    let nan = f64::NAN;
    let inf = f64::INFINITY;
    let cases: Vec<Figure> = vec![
        Figure::new(""),
        {
            let mut f = Figure::new("empty series");
            f.line(&[], &[], "nothing");
            f.markers(&[], &[], "");
            f.segments(Vec::new(), "no segments");
            f
        },
        {
            let mut f = Figure::new("all invalid").y_scale(Scale::Log10);
            f.line_markers(&[nan, inf, -inf], &[nan, 1.0, 2.0], "bad");
            f
        },
        {
            let mut f = Figure::new("zero range");
            f.line(&[1.0, 1.0, 1.0], &[3.0, 3.0, 3.0], "constant");
            f
        },
        {
            let mut f = Figure::new("zero at zero").equal_aspect(true);
            f.markers(&[0.0], &[0.0], "origin");
            f
        },
        {
            let mut f = Figure::new("log of non-positive")
                .x_scale(Scale::Log10)
                .y_scale(Scale::Log10)
                .x_range(-1.0, 0.0)
                .y_range(0.0, 0.0);
            f.line(&[-1.0, 0.0, 1.0, 10.0], &[0.0, -2.0, 1.0, 1e-3], "mixed");
            f
        },
        {
            let mut f = Figure::new("bad ranges").x_range(nan, 1.0).y_range(5.0, 5.0);
            f.line(&[0.0, 1.0, 2.0], &[1.0, 2.0], "short ys");
            f
        },
        {
            let mut f = Figure::new("extremes").size(nan, -5.0);
            f.line(&[-1e308, 1e308], &[f64::MIN_POSITIVE, 1e-320], "huge").width(-1.0).marker_size(nan);
            f
        },
        {
            let mut f = Figure::new("tiny span");
            f.line(&[1.0, 1.0 + 1e-15], &[-1e-310, 1e-310], "tiny");
            f
        },
        {
            let mut f = Figure::new("a gap breaks the line").legend(Legend::TopLeft);
            f.line(&[0.0, 1.0, 2.0, 3.0, 4.0], &[0.0, 1.0, nan, 3.0, 4.0], "gap");
            f
        },
    ];
    for (k, fig) in cases.iter().enumerate() {
        let svg = fig.to_svg();
        check_well_formed(&svg);
        fig.save(scratch(&format!("degenerate/{k}.svg"))).unwrap();
    }
    // A NaN splits the line into two runs: two "M" commands in its path.
    let svg = cases.last().unwrap().to_svg();
    let path = svg.lines().find(|l| l.contains("stroke=\"#0072b2\"")).unwrap();
    assert_eq!(path.matches('M').count(), 2, "{path}");
}

#[test]
fn equal_aspect_keeps_circles_round() {
    let t: Vec<f64> = (0..=64).map(|k| 2.0 * PI * k as f64 / 64.0).collect();
    let (x, y): (Vec<f64>, Vec<f64>) = t.iter().map(|t| (3.0 * t.cos(), t.sin())).unzip();
    let mut fig = Figure::new("").size(600.0, 300.0).equal_aspect(true).legend(Legend::Hidden);
    fig.line(&x, &y, "");
    let svg = fig.to_svg();
    check_well_formed(&svg);
    // Pixel extents of the ellipse: width / height = 3.
    let d = svg.lines().find(|l| l.starts_with("<path d=\"M") && l.contains("#0072b2")).unwrap();
    let d = &d[d.find("d=\"").unwrap() + 3..];
    let d = &d[..d.find('"').unwrap()];
    let nums: Vec<f64> =
        d.split(['M', 'L', ' ']).filter(|s| !s.is_empty()).map(|s| s.parse().unwrap()).collect();
    let xs: Vec<f64> = nums.iter().step_by(2).copied().collect();
    let ys: Vec<f64> = nums.iter().skip(1).step_by(2).copied().collect();
    let extent =
        |v: &[f64]| v.iter().fold(f64::MIN, |m, &a| m.max(a)) - v.iter().fold(f64::MAX, |m, &a| m.min(a));
    let ratio = extent(&xs) / extent(&ys);
    assert!((ratio - 3.0).abs() < 0.02, "aspect ratio {ratio}");
}

#[test]
fn panels_nest_figures() {
    let mut a = Figure::new("left").size(300.0, 200.0);
    a.line(&[0.0, 1.0], &[0.0, 1.0], "a");
    let mut b = Figure::new("right").size(400.0, 250.0);
    b.markers(&[0.0, 1.0], &[1.0, 0.0], "b");
    let mut panels = Panels::new(2);
    panels.push(a).push(b).push(Figure::new("below"));
    let svg = panels.to_svg();
    let tags = check_well_formed(&svg);
    assert_eq!(tags.iter().filter(|t| *t == "svg").count(), 4);
    assert!(svg.contains("width=\"1040\"") && svg.contains("height=\"730\""));
    // Clip-path ids differ between panels.
    assert!(svg.contains("id=\"p0-clip\"") && svg.contains("id=\"p1-clip\""));
}

#[test]
fn save_creates_directories_and_reports_the_path() {
    let dir = scratch("save");
    let _ = std::fs::remove_dir_all(&dir);
    let path = dir.join("deep/er/fig.svg");
    Figure::new("saved").save(&path).unwrap();
    assert!(std::fs::read_to_string(&path).unwrap().starts_with("<svg"));
    // A file where a directory should be: the error names the path.
    let blocker = dir.join("file");
    std::fs::write(&blocker, "x").unwrap();
    let bad = blocker.join("fig.svg");
    match Figure::new("").save(&bad) {
        Err(Error::Io { path, .. }) => assert!(path.contains("file"), "{path}"),
        other => panic!("expected Error::Io, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// Marching squares
// ---------------------------------------------------------------------------------------------

#[test]
fn circle_contour_lies_on_the_circle_and_closes() {
    let n = 201;
    let r0 = 0.6173; // not a grid distance, so no corner sits exactly on the level
    let (v, h) = circle_field(n, r0, (0.031, -0.017));
    let segments = contour_segments(n, n, -1.0, -1.0, h, h, &v, 0.0);
    assert!(segments.len() > 100);
    for [a, b] in &segments {
        for p in [a, b] {
            let r = (p.0 - 0.031).hypot(p.1 + 0.017);
            assert!((r - r0).abs() < 1e-3, "point {p:?} at radius {r}");
        }
    }
    let loops = chain_loops(&segments);
    assert_eq!(loops.len(), 1, "one closed loop");
    // Values above the level (inside) on the left: counter-clockwise, area ~ pi r^2.
    let area = shoelace(&loops[0]);
    assert!((area - PI * r0 * r0).abs() < 2e-3 * PI * r0 * r0, "area {area}");
    // The complementary field runs the other way.
    let minus: Vec<f64> = v.iter().map(|v| -v).collect();
    let loops = chain_loops(&contour_segments(n, n, -1.0, -1.0, h, h, &minus, 0.0));
    assert!(shoelace(&loops[0]) < 0.0);
}

#[test]
fn two_circles_and_a_coarse_grid_give_closed_loops() {
    // Two disjoint discs on a coarse, anisotropic grid: two loops.
    let (nx, ny) = (37, 23);
    let (dx, dy) = (2.0 / (nx - 1) as f64, 2.0 / (ny - 1) as f64);
    let mut v = vec![0.0; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            let (x, y) = (-1.0 + i as f64 * dx, -1.0 + j as f64 * dy);
            let d1 = 0.35 - (x + 0.45).hypot(y);
            let d2 = 0.3 - (x - 0.5).hypot(y - 0.1);
            v[i + nx * j] = d1.max(d2);
        }
    }
    let loops = chain_loops(&contour_segments(nx, ny, -1.0, -1.0, dx, dy, &v, 0.0));
    assert_eq!(loops.len(), 2);
    assert!(loops.iter().all(|l| shoelace(l) > 0.0));
}

#[test]
fn saddle_follows_the_asymptotic_decider() {
    // Corners a, b, c, d (counter-clockwise from lower left) = 1, 0, 1, 0 with level 0.4:
    // bilinear saddle value 0.5 > 0.4, so the two corners above join: the segments cut off
    // the corners below, b = (1, 0) and d = (0, 1).
    let values = [1.0, 0.0, 0.0, 1.0]; // row-major: (0,0), (1,0), (0,1), (1,1)
    let segs = contour_segments(2, 2, 0.0, 0.0, 1.0, 1.0, &values, 0.4);
    assert_eq!(segs.len(), 2);
    let near = |p: (f64, f64), q: (f64, f64)| (p.0 - q.0).hypot(p.1 - q.1) < 1e-12;
    let cuts = |corner: (f64, f64)| {
        segs.iter().any(|[a, b]| {
            let mid = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
            (mid.0 - corner.0).hypot(mid.1 - corner.1) < 0.5
        })
    };
    assert!(cuts((1.0, 0.0)) && cuts((0.0, 1.0)));
    assert!(segs.iter().any(|[a, b]| near(*a, (0.6, 0.0)) && near(*b, (1.0, 0.4))));
    // With level 0.6 (saddle value below) they separate: the corners above are cut off.
    let segs = contour_segments(2, 2, 0.0, 0.0, 1.0, 1.0, &values, 0.6);
    assert_eq!(segs.len(), 2);
    let cuts = |corner: (f64, f64)| {
        segs.iter().any(|[a, b]| {
            let mid = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
            (mid.0 - corner.0).hypot(mid.1 - corner.1) < 0.5
        })
    };
    assert!(cuts((0.0, 0.0)) && cuts((1.0, 1.0)));
}

#[test]
fn contour_of_bad_input_is_empty_or_partial() {
    assert!(contour_segments(0, 5, 0.0, 0.0, 1.0, 1.0, &[], 0.0).is_empty());
    assert!(contour_segments(1, 5, 0.0, 0.0, 1.0, 1.0, &[1.0; 5], 0.0).is_empty());
    assert!(contour_segments(3, 3, 0.0, 0.0, 0.0, 1.0, &[1.0; 9], 0.0).is_empty());
    assert!(contour_segments(3, 3, 0.0, 0.0, 1.0, 1.0, &[1.0; 9], f64::NAN).is_empty());
    // Short slice: only complete rows are used.
    let values = [0.0, 1.0, 0.0, 1.0, 0.0];
    assert_eq!(contour_segments(2, 3, 0.0, 0.0, 1.0, 1.0, &values, 0.5).len(), 1);
    // A NaN corner skips its cells only.
    let mut v = vec![0.0; 16];
    v[5] = 1.0;
    v[15] = f64::NAN;
    let segs = contour_segments(4, 4, 0.0, 0.0, 1.0, 1.0, &v, 0.5);
    assert_eq!(chain_loops(&segs).len(), 1);
}

// ---------------------------------------------------------------------------------------------
// CSV
// ---------------------------------------------------------------------------------------------

#[test]
fn csv_round_trip_is_exact() {
    let path = scratch("csv/round_trip.csv");
    let tricky = [
        0.1 + 0.2,
        -0.0,
        1e-300,
        5e-324,
        -1.7976931348623157e308,
        123_456_789.123_456_79,
        1.0 / 3.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        2.5e-5,
    ];
    let mut csv = CsvWriter::create(&path, &["k", "value", "square"]).unwrap();
    for (k, &x) in tricky.iter().enumerate() {
        csv.row(&[k as f64, x, x * x]).unwrap();
    }
    assert!(matches!(csv.row(&[1.0, 2.0]), Err(Error::InvalidParameter { .. })));
    csv.finish().unwrap();
    let table = read_columns(&path).unwrap();
    assert_eq!(table.names, ["k", "value", "square"]);
    assert_eq!(table.rows(), tricky.len());
    for (k, &x) in tricky.iter().enumerate() {
        let (got, sq) = (table.column("value").unwrap()[k], table.column("square").unwrap()[k]);
        assert!(got.to_bits() == x.to_bits() || (got.is_nan() && x.is_nan()), "{x} -> {got}");
        let want = x * x;
        assert!(sq.to_bits() == want.to_bits() || (sq.is_nan() && want.is_nan()));
    }
    assert_eq!(format_f64(1e20), "1e20");
    assert_eq!(format_f64(-2.5), "-2.5");

    let cols = scratch("csv/columns.csv");
    let x = [0.0, 0.5, 1.0];
    let y = [1.0, 0.25, 0.0];
    write_columns(&cols, &[("x", &x), ("y", &y)]).unwrap();
    assert_eq!(std::fs::read_to_string(&cols).unwrap(), "x,y\n0,1\n0.5,0.25\n1,0\n");
    assert!(write_columns(&cols, &[("x", &x), ("y", &y[..2])]).is_err());
    assert!(write_columns(&cols, &[]).is_err());
    assert!(CsvWriter::create(&cols, &["a,b"]).is_err());
}

#[test]
fn read_xy_skips_comments_and_names_bad_lines() {
    let path = scratch("csv/xy.csv");
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, "# digitised\n\n1, 2\r\n 3.5 ,4e-3\n  # indented comment\n-1,0\n").unwrap();
    assert_eq!(read_xy(&path).unwrap(), vec![(1.0, 2.0), (3.5, 4e-3), (-1.0, 0.0)]);

    std::fs::write(&path, "1, 2\n3, four\n").unwrap();
    match read_xy(&path) {
        Err(Error::Io { path: p, message }) => {
            assert!(p.ends_with("xy.csv"), "{p}");
            assert!(message.contains("line 2") && message.contains("four"), "{message}");
        }
        other => panic!("expected Error::Io, got {other:?}"),
    }
    std::fs::write(&path, "1, 2\n3\n").unwrap();
    let err = read_xy(&path).unwrap_err().to_string();
    assert!(err.contains("line 2") && err.contains("xy.csv"), "{err}");

    let missing = scratch("csv/does_not_exist.csv");
    match read_xy(&missing) {
        Err(Error::Io { path, .. }) => assert!(path.ends_with("does_not_exist.csv")),
        other => panic!("expected Error::Io, got {other:?}"),
    }
}

#[test]
fn reads_published_reference_curve() {
    let path = reference_dir().join("ramanujan_pozrikidis_1998_ca_0.1.csv");
    let points = read_xy(&path).unwrap();
    assert!(points.len() > 10, "{} points", points.len());
    // Late-time D about 0.384 (reference README).
    let late = points.last().unwrap().1;
    assert!((late - 0.384).abs() < 0.02, "late D = {late}");
    assert!(points.iter().all(|&(t, d)| t >= 0.0 && (0.0..0.6).contains(&d)));
}

// ---------------------------------------------------------------------------------------------
// Figures to look at
// ---------------------------------------------------------------------------------------------

/// Writes the kinds of figure the examples make to `target/tmp/test-output/plot/`, for a person
/// to look at: reference curves with markers and a model line, a log-log convergence plot, a
/// contour plot with equal aspect, and the three as panels.
#[test]
fn example_figures_are_written() {
    let dir = reference_dir();
    let mut shear = Figure::new("Neo-Hookean capsule in simple shear")
        .x_label("γ̇t")
        .y_label("Taylor deformation D")
        .legend(Legend::BottomRight);
    for (k, ca) in ["0.025", "0.05", "0.1", "0.2"].iter().enumerate() {
        let pts = read_xy(dir.join(format!("ramanujan_pozrikidis_1998_ca_{ca}.csv"))).unwrap();
        let (t, d): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
        let late = *d.last().unwrap();
        let model: Vec<f64> = t.iter().map(|t| late * (1.0 - (-1.2 * t).exp())).collect();
        shear.markers(&t, &d, &format!("Ramanujan & Pozrikidis, Ca = {ca}")).filled(false);
        let style = [LineStyle::Solid, LineStyle::Dashed, LineStyle::Dotted, LineStyle::DashDot];
        shear.line(&t, &model, "").style(style[k]).color(Color::GREY).width(1.25);
    }
    let n = [16.0, 32.0, 64.0, 128.0, 256.0];
    let e1: Vec<f64> = n.iter().map(|n: &f64| 2.0 / n.powi(2) * (1.0 + 3.0 / n)).collect();
    let e2: Vec<f64> = n.iter().map(|n: &f64| 0.5 / n).collect();
    let slope2: Vec<f64> = n.iter().map(|n: &f64| 1.0 / n.powi(2)).collect();
    let mut conv = Figure::new("Resolution study")
        .x_label("cells along the diameter N")
        .y_label("relative error")
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10);
    conv.line_markers(&n, &e1, "volume");
    conv.line_markers(&n, &e2, "curvature");
    conv.line(&n, &slope2, "N⁻²").style(LineStyle::Dashed).color(Color::BLACK).width(1.0);

    let m = 121;
    let h = 2.0 / (m - 1) as f64;
    let mut shape = Figure::new("Capsule outline, φ = 0.5").x_label("x / a").y_label("y / a");
    shape = shape.equal_aspect(true);
    let mut field = vec![0.0; m * m];
    for (level, label) in [(0.0_f64, "t = 0"), (0.35, "t = 2")] {
        for j in 0..m {
            for i in 0..m {
                let (x, y) = (-1.0 + i as f64 * h, -1.0 + j as f64 * h);
                let (s, c) = (0.6 * level).sin_cos();
                let (u, w) = (c * x + s * y, -s * x + c * y);
                let (ax, ay) = (0.6 * (1.0 + level), 0.6 / (1.0 + level));
                field[i + m * j] = 1.0 - (u / ax).hypot(w / ay);
            }
        }
        shape.segments(contour_segments(m, m, -1.0, -1.0, h, h, &field, 0.0), label);
    }

    let out = scratch("figures");
    shear.save(out.join("shear.svg")).unwrap();
    conv.save(out.join("convergence.svg")).unwrap();
    shape.save(out.join("shape.svg")).unwrap();
    let mut panels = Panels::new(3);
    panels.push(shear.size(480.0, 400.0)).push(conv.size(420.0, 400.0));
    panels.push(shape.size(400.0, 400.0));
    panels.save(out.join("panels.svg")).unwrap();
    for name in ["shear.svg", "convergence.svg", "shape.svg", "panels.svg"] {
        check_well_formed(&std::fs::read_to_string(out.join(name)).unwrap());
    }
}

// ---------------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------------

/// Runs `f`, failing the test if it panics.
fn no_panic<R>(what: &str, f: impl FnOnce() -> R) -> R {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(_) => panic!("{what} panicked"),
    }
}

/// Runs `f`, which must return an error with a message (and not panic).
fn refused<T>(what: &str, f: impl FnOnce() -> eulermembrane::Result<T>) {
    match no_panic(what, f) {
        Ok(_) => panic!("{what} accepted an invalid input"),
        Err(e) => assert!(!e.to_string().is_empty(), "{what}: empty message"),
    }
}

/// Non-finite numbers.
fn non_finite() -> impl Strategy<Value = f64> {
    prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn csv_headers_are_checked(name in "[a-z]{0,4}[,\"\n\r][a-z]{0,4}") {
        let dir = scratch(&format!("bad_header_{}", std::process::id()));
        refused("CsvWriter::create", || CsvWriter::create(dir.join("a.csv"), &["x", &name]));
        refused("CsvWriter::create", || CsvWriter::create(dir.join("b.csv"), &[]));
        let mut w = CsvWriter::create(dir.join("c.csv"), &["x", "y"]).unwrap();
        refused("CsvWriter::row", || w.row(&[1.0]));
        prop_assert!(w.row(&[1.0, f64::NAN]).is_ok());
        drop(w);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn plots_take_any_numbers_without_panicking(
        xs in proptest::collection::vec(prop_oneof![any::<f64>(), non_finite()], 0..20),
        ys in proptest::collection::vec(prop_oneof![any::<f64>(), non_finite()], 0..20),
        w in any::<f64>(),
        h in any::<f64>(),
        r in (any::<f64>(), any::<f64>()),
        log in any::<bool>(),
    ) {
        // The plot builders clamp or ignore invalid values (documented) rather than erring.
        let svg = no_panic("Figure", || {
            let scale = if log { Scale::Log10 } else { Scale::Linear };
            let mut fig = Figure::new("t").size(w, h).x_range(r.0, r.1).y_range(r.1, r.0).x_scale(scale).y_scale(scale);
            fig.line(&xs, &ys, "a").width(w).marker_size(h);
            fig.markers(&ys, &xs, "b");
            fig.to_svg()
        });
        prop_assert!(svg.starts_with("<svg") && !svg.contains("NaN") && !svg.contains("inf"));
    }
}
