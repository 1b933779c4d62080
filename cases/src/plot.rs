//! Figures as standalone SVG, written by hand: no plotting dependency.
//!
//! A [`Figure`] holds axes (linear or log10 each, automatic 1-2-5 ticks or decades, optional
//! explicit ranges, grid lines), a legend and any number of series: lines, markers, both, or
//! disjoint segments (for contour plots, see [`contour_segments`]). Colours come from a fixed
//! colour-blind-safe palette ([`PALETTE`], after Okabe & Ito) unless a series overrides them.
//! [`Figure::to_svg`] gives the document as a string, [`Figure::save`] writes it; [`Panels`]
//! places several figures side by side in one SVG.
//!
//! Points with a NaN or infinite coordinate (and, on a log axis, a non-positive one) are
//! skipped and break a line in two. Empty series, all-NaN data, a zero data range or a
//! nonsensical explicit range give a figure with sensible axes, never a panic.
//!
//! ```
//! use eulermembrane_cases::plot::{Figure, LineStyle, Scale};
//! # fn main() -> eulermembrane::Result<()> {
//! let n: Vec<f64> = vec![16.0, 32.0, 64.0, 128.0];
//! let err: Vec<f64> = n.iter().map(|n| 3.0 / (n * n)).collect();
//! let slope: Vec<f64> = n.iter().map(|n| 1.0 / (n * n)).collect();
//! let mut fig = Figure::new("Convergence")
//!     .x_label("cells along the diameter N")
//!     .y_label("L1 error")
//!     .x_scale(Scale::Log10)
//!     .y_scale(Scale::Log10);
//! fig.line_markers(&n, &err, "phi");
//! fig.line(&n, &slope, "second order").style(LineStyle::Dashed);
//! fig.save(std::env::temp_dir().join("eulermembrane_doc_plot/convergence.svg"))?;
//! # Ok(())
//! # }
//! ```

use crate::files::write_file;
use eulermembrane::Result;
use std::fmt::{self, Write as _};
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Styles
// ---------------------------------------------------------------------------------------------

/// An sRGB colour.
///
/// ```
/// use eulermembrane_cases::plot::Color;
/// let c = Color::rgb(0, 114, 178);
/// assert_eq!(c.to_string(), "#0072b2");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Color {
    /// Red, 0-255.
    pub r: u8,
    /// Green, 0-255.
    pub g: u8,
    /// Blue, 0-255.
    pub b: u8,
}

impl Color {
    /// The colour with the given red, green and blue components.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Color;
    /// assert_eq!(Color::rgb(255, 0, 0), Color { r: 255, g: 0, b: 0 });
    /// ```
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Color { r, g, b }
    }

    /// Black.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Color;
    /// assert_eq!(Color::BLACK.to_string(), "#000000");
    /// ```
    pub const BLACK: Color = Color::rgb(0, 0, 0);

    /// A mid grey, for reference curves that should stay in the background.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Color;
    /// assert_eq!(Color::GREY.to_string(), "#888888");
    /// ```
    pub const GREY: Color = Color::rgb(136, 136, 136);
}

impl fmt::Display for Color {
    /// `#rrggbb`, as SVG and CSS read it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{:02x}{:02x}{:02x}", self.r, self.g, self.b)
    }
}

/// The automatic series colours, in order: the Okabe-Ito palette, distinguishable with the
/// common colour-vision deficiencies, with its yellow moved last (it is faint on white).
///
/// ```
/// use eulermembrane_cases::plot::PALETTE;
/// assert_eq!(PALETTE[0].to_string(), "#0072b2"); // blue
/// assert_eq!(PALETTE[1].to_string(), "#d55e00"); // vermillion
/// ```
pub const PALETTE: [Color; 8] = [
    Color::rgb(0x00, 0x72, 0xB2), // blue
    Color::rgb(0xD5, 0x5E, 0x00), // vermillion
    Color::rgb(0x00, 0x9E, 0x73), // bluish green
    Color::rgb(0xCC, 0x79, 0xA7), // reddish purple
    Color::rgb(0xE6, 0x9F, 0x00), // orange
    Color::rgb(0x56, 0xB4, 0xE9), // sky blue
    Color::rgb(0x00, 0x00, 0x00), // black
    Color::rgb(0xF0, 0xE4, 0x42), // yellow
];

/// Axis scale.
///
/// ```
/// use eulermembrane_cases::plot::{Figure, Scale};
/// let fig = Figure::new("error").y_scale(Scale::Log10);
/// # let _ = fig;
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis with 1-2-5 ticks.
    #[default]
    Linear,
    /// Base-10 logarithmic axis with decade ticks (1-2-5 ticks on a short range).
    Log10,
}

/// How a line is stroked.
///
/// ```
/// use eulermembrane_cases::plot::{Figure, LineStyle};
/// let mut fig = Figure::new("");
/// fig.line(&[0.0, 1.0], &[0.0, 1.0], "exact").style(LineStyle::Dotted);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LineStyle {
    /// Continuous line.
    #[default]
    Solid,
    /// Dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Alternating dashes and dots.
    DashDot,
}

/// Marker shape.
///
/// Series with markers get shapes automatically in the order `Circle`, `Square`, `Triangle`,
/// `Diamond`, `TriangleDown`, unless set with [`Series::marker`].
///
/// ```
/// use eulermembrane_cases::plot::{Figure, Marker};
/// let mut fig = Figure::new("");
/// fig.markers(&[1.0, 2.0], &[1.0, 4.0], "data").marker(Marker::Triangle);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// Circle.
    Circle,
    /// Square.
    Square,
    /// Triangle pointing up.
    Triangle,
    /// Diamond (square on its corner).
    Diamond,
    /// Triangle pointing down.
    TriangleDown,
}

const AUTO_MARKERS: [Marker; 5] =
    [Marker::Circle, Marker::Square, Marker::Triangle, Marker::Diamond, Marker::TriangleDown];

/// Where the legend goes.
///
/// ```
/// use eulermembrane_cases::plot::{Figure, Legend};
/// let fig = Figure::new("").legend(Legend::BottomRight);
/// # let _ = fig;
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Legend {
    /// The inner corner of the plot area that covers the fewest data points.
    #[default]
    Best,
    /// Upper right corner.
    TopRight,
    /// Upper left corner.
    TopLeft,
    /// Lower right corner.
    BottomRight,
    /// Lower left corner.
    BottomLeft,
    /// No legend.
    Hidden,
}

// ---------------------------------------------------------------------------------------------
// Series
// ---------------------------------------------------------------------------------------------

const DEFAULT_WIDTH: f64 = 1.75;
const DEFAULT_MARKER_SIZE: f64 = 3.5;

/// One data series of a [`Figure`], returned by the figure's series methods so that its style
/// can be adjusted in a chain.
///
/// ```
/// use eulermembrane_cases::plot::{Color, Figure, LineStyle, Marker};
/// let mut fig = Figure::new("");
/// fig.line_markers(&[0.0, 1.0, 2.0], &[1.0, 0.5, 0.2], "run A")
///     .color(Color::BLACK)
///     .style(LineStyle::DashDot)
///     .width(1.0)
///     .marker(Marker::Square)
///     .marker_size(4.0)
///     .filled(false);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    label: String,
    points: Vec<(f64, f64)>,
    segments: Vec<[(f64, f64); 2]>,
    show_line: bool,
    show_markers: bool,
    style: LineStyle,
    width: f64,
    marker: Option<Marker>,
    marker_size: f64,
    filled: bool,
    color: Option<Color>,
}

impl Series {
    fn new(label: &str, points: Vec<(f64, f64)>, show_line: bool, show_markers: bool) -> Self {
        Series {
            label: label.to_string(),
            points,
            segments: Vec::new(),
            show_line,
            show_markers,
            style: LineStyle::Solid,
            width: DEFAULT_WIDTH,
            marker: None,
            marker_size: DEFAULT_MARKER_SIZE,
            filled: true,
            color: None,
        }
    }

    /// Sets the colour, instead of the next one from [`PALETTE`].
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Color, Figure};
    /// let mut fig = Figure::new("");
    /// fig.line(&[0.0, 1.0], &[0.0, 1.0], "").color(Color::rgb(200, 0, 0));
    /// assert!(fig.to_svg().contains("#c80000"));
    /// ```
    pub fn color(&mut self, color: Color) -> &mut Self {
        self.color = Some(color);
        self
    }

    /// Sets the line style (of the line or segments; a markers-only series stays without line).
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, LineStyle};
    /// let mut fig = Figure::new("");
    /// fig.line(&[0.0, 1.0], &[0.0, 1.0], "").style(LineStyle::Dashed);
    /// assert!(fig.to_svg().contains("stroke-dasharray"));
    /// ```
    pub fn style(&mut self, style: LineStyle) -> &mut Self {
        self.style = style;
        self
    }

    /// Sets the line width in pixels (default 1.75); a non-finite or non-positive width is
    /// ignored.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("");
    /// fig.line(&[0.0, 1.0], &[0.0, 1.0], "").width(3.0);
    /// assert!(fig.to_svg().contains("stroke-width=\"3\""));
    /// ```
    pub fn width(&mut self, width: f64) -> &mut Self {
        if width.is_finite() && width > 0.0 {
            self.width = width;
        }
        self
    }

    /// Sets the marker shape, and shows markers on a series that had none.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Marker};
    /// let mut fig = Figure::new("");
    /// fig.line(&[0.0, 1.0], &[0.0, 1.0], "").marker(Marker::Diamond);
    /// ```
    pub fn marker(&mut self, marker: Marker) -> &mut Self {
        self.marker = Some(marker);
        self.show_markers = true;
        self
    }

    /// Sets the marker size: the radius of the circle marker in pixels (default 3.5); other
    /// shapes have about the same area. A non-finite or non-positive size is ignored.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("");
    /// fig.markers(&[0.0, 1.0], &[0.0, 1.0], "").marker_size(5.0);
    /// ```
    pub fn marker_size(&mut self, size: f64) -> &mut Self {
        if size.is_finite() && size > 0.0 {
            self.marker_size = size;
        }
        self
    }

    /// Filled markers (the default) or open ones, which let a line or other markers show
    /// through: the usual way to draw reference data over a computed curve.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("");
    /// fig.markers(&[0.0, 1.0], &[0.0, 1.0], "Pozrikidis (1995)").filled(false);
    /// ```
    pub fn filled(&mut self, filled: bool) -> &mut Self {
        self.filled = filled;
        self
    }

    /// Point pairs and segment endpoints, for the range and the legend placement.
    fn all_points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.points.iter().copied().chain(self.segments.iter().flat_map(|s| s.iter().copied()))
    }
}

// ---------------------------------------------------------------------------------------------
// Figure
// ---------------------------------------------------------------------------------------------

#[derive(Clone, Debug, Default, PartialEq)]
struct AxisSpec {
    label: String,
    scale: Scale,
    range: Option<(f64, f64)>,
}

/// A 2-D plot, built step by step and rendered to a standalone SVG document.
///
/// Axis settings are builder methods that take and return the figure; series methods take
/// `&mut self` and return the new [`Series`] for styling. Defaults: 640 x 480 pixels, linear
/// axes ranging over the data with a 4 % margin, grid lines on, legend in the best corner.
///
/// ```
/// use eulermembrane_cases::plot::{Figure, Legend};
/// let t: Vec<f64> = (0..50).map(|k| 0.1 * k as f64).collect();
/// let d: Vec<f64> = t.iter().map(|t| 0.3 * (1.0 - (-t).exp())).collect();
/// let mut fig = Figure::new("Taylor deformation")
///     .x_label("γ̇t")
///     .y_label("D")
///     .legend(Legend::BottomRight);
/// fig.line(&t, &d, "N = 32");
/// let svg = fig.to_svg();
/// assert!(svg.starts_with("<svg") && svg.contains("Taylor deformation"));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    title: String,
    width: f64,
    height: f64,
    x: AxisSpec,
    y: AxisSpec,
    grid: bool,
    legend: Legend,
    equal_aspect: bool,
    series: Vec<Series>,
}

impl Default for Figure {
    fn default() -> Self {
        Figure::new("")
    }
}

impl Figure {
    /// An empty 640 x 480 figure with the given title (empty for none).
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let svg = Figure::new("nothing yet").to_svg();
    /// assert!(svg.contains("width=\"640\""));
    /// ```
    pub fn new(title: impl Into<String>) -> Self {
        Figure {
            title: title.into(),
            width: 640.0,
            height: 480.0,
            x: AxisSpec::default(),
            y: AxisSpec::default(),
            grid: true,
            legend: Legend::Best,
            equal_aspect: false,
            series: Vec::new(),
        }
    }

    /// Sets the size in pixels; each is clamped to 120..=10000 (a non-finite value keeps the
    /// default).
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let svg = Figure::new("").size(800.0, 400.0).to_svg();
    /// assert!(svg.contains("viewBox=\"0 0 800 400\""));
    /// ```
    pub fn size(mut self, width: f64, height: f64) -> Self {
        let clamp = |v: f64, default: f64| {
            if v.is_finite() { v.clamp(120.0, 1e4) } else { default }
        };
        self.width = clamp(width, self.width).round();
        self.height = clamp(height, self.height).round();
        self
    }

    /// Sets the x-axis label.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// assert!(Figure::new("").x_label("time").to_svg().contains(">time<"));
    /// ```
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x.label = label.into();
        self
    }

    /// Sets the y-axis label.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// assert!(Figure::new("").y_label("energy").to_svg().contains(">energy<"));
    /// ```
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y.label = label.into();
        self
    }

    /// Sets the x-axis scale.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Scale};
    /// let fig = Figure::new("").x_scale(Scale::Log10);
    /// # let _ = fig;
    /// ```
    pub fn x_scale(mut self, scale: Scale) -> Self {
        self.x.scale = scale;
        self
    }

    /// Sets the y-axis scale.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Scale};
    /// let fig = Figure::new("").y_scale(Scale::Log10);
    /// # let _ = fig;
    /// ```
    pub fn y_scale(mut self, scale: Scale) -> Self {
        self.y.scale = scale;
        self
    }

    /// Fixes the x-axis range (no margin added). The bounds may come in either order; a range
    /// with a non-finite bound, or a non-positive one on a log axis, is ignored and the data
    /// range used instead; equal bounds are widened.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let fig = Figure::new("").x_range(0.0, 10.0);
    /// # let _ = fig;
    /// ```
    pub fn x_range(mut self, min: f64, max: f64) -> Self {
        self.x.range = Some((min, max));
        self
    }

    /// Fixes the y-axis range; as [`x_range`](Figure::x_range).
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let fig = Figure::new("").y_range(-1.0, 1.0);
    /// # let _ = fig;
    /// ```
    pub fn y_range(mut self, min: f64, max: f64) -> Self {
        self.y.range = Some((min, max));
        self
    }

    /// One data unit spans as many pixels on both axes (the ranges are widened to fill the plot
    /// area), so that circles look round: for shapes and contour plots.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let fig = Figure::new("capsule outline").equal_aspect(true);
    /// # let _ = fig;
    /// ```
    pub fn equal_aspect(mut self, on: bool) -> Self {
        self.equal_aspect = on;
        self
    }

    /// Shows or hides grid lines at the ticks (shown by default).
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let fig = Figure::new("").grid(false);
    /// # let _ = fig;
    /// ```
    pub fn grid(mut self, on: bool) -> Self {
        self.grid = on;
        self
    }

    /// Sets the legend position ([`Legend::Best`] by default). Series with an empty label are
    /// left out of the legend; without any labelled series there is no legend.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Legend};
    /// let fig = Figure::new("").legend(Legend::Hidden);
    /// # let _ = fig;
    /// ```
    pub fn legend(mut self, legend: Legend) -> Self {
        self.legend = legend;
        self
    }

    /// Adds a line through the points `(xs[k], ys[k])` (up to the shorter length).
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("");
    /// fig.line(&[0.0, 1.0, 2.0], &[0.0, 1.0, 4.0], "x²");
    /// ```
    pub fn line(&mut self, xs: &[f64], ys: &[f64], label: &str) -> &mut Series {
        self.push(Series::new(label, zip(xs, ys), true, false))
    }

    /// Adds markers at the points `(xs[k], ys[k])`, without line.
    ///
    /// A list of pairs, e.g. from [`read_xy`](crate::csv::read_xy), is split with
    /// `unzip`:
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let reference = vec![(0.1, 0.02), (0.5, 0.08), (1.0, 0.11)];
    /// let (t, d): (Vec<f64>, Vec<f64>) = reference.into_iter().unzip();
    /// let mut fig = Figure::new("");
    /// fig.markers(&t, &d, "Ramanujan & Pozrikidis (1998)").filled(false);
    /// ```
    pub fn markers(&mut self, xs: &[f64], ys: &[f64], label: &str) -> &mut Series {
        self.push(Series::new(label, zip(xs, ys), false, true))
    }

    /// Adds a line with a marker at each point.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("");
    /// fig.line_markers(&[16.0, 32.0, 64.0], &[1e-2, 2.6e-3, 6.4e-4], "error");
    /// ```
    pub fn line_markers(&mut self, xs: &[f64], ys: &[f64], label: &str) -> &mut Series {
        self.push(Series::new(label, zip(xs, ys), true, true))
    }

    /// Adds disjoint line segments `[(x0, y0), (x1, y1)]`, drawn in one colour and style: a
    /// contour from [`contour_segments`], or any set of strokes.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("").equal_aspect(true);
    /// fig.segments(vec![[(0.0, 0.0), (1.0, 0.0)], [(0.0, 1.0), (1.0, 1.0)]], "two strokes");
    /// ```
    pub fn segments(&mut self, segments: impl Into<Vec<[(f64, f64); 2]>>, label: &str) -> &mut Series {
        let mut series = Series::new(label, Vec::new(), true, false);
        series.segments = segments.into();
        self.push(series)
    }

    /// Renders the figure as a standalone SVG document.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// let mut fig = Figure::new("sine");
    /// let x: Vec<f64> = (0..100).map(|k| 0.1 * k as f64).collect();
    /// let y: Vec<f64> = x.iter().map(|x| x.sin()).collect();
    /// fig.line(&x, &y, "sin x");
    /// let svg = fig.to_svg();
    /// assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    /// ```
    pub fn to_svg(&self) -> String {
        let mut out = String::with_capacity(16 * 1024);
        let (w, h) = (self.width, self.height);
        let _ = writeln!(
            out,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" \
             viewBox=\"0 0 {w} {h}\" font-family=\"{FONT}\">"
        );
        self.render(&mut out, "f");
        out.push_str("</svg>\n");
        out
    }

    /// Writes the SVG document to `path`, creating the parent directories.
    ///
    /// Errors: [`Error::Io`](eulermembrane::Error::Io) naming the path if a directory or the file cannot
    /// be written.
    ///
    /// ```
    /// use eulermembrane_cases::plot::Figure;
    /// # fn main() -> eulermembrane::Result<()> {
    /// let path = std::env::temp_dir().join("eulermembrane_doc_save/sub/figure.svg");
    /// Figure::new("saved").save(&path)?;
    /// assert!(path.exists());
    /// # Ok(())
    /// # }
    /// ```
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        write_file(path.as_ref(), &self.to_svg())
    }

    fn push(&mut self, series: Series) -> &mut Series {
        self.series.push(series);
        let last = self.series.len() - 1;
        &mut self.series[last]
    }
}

fn zip(xs: &[f64], ys: &[f64]) -> Vec<(f64, f64)> {
    xs.iter().copied().zip(ys.iter().copied()).collect()
}

// ---------------------------------------------------------------------------------------------
// Panels
// ---------------------------------------------------------------------------------------------

/// Several figures side by side (row by row, `columns` per row) in one SVG document.
///
/// Each figure keeps its own size; a column is as wide as its widest figure and a row as tall
/// as its tallest.
///
/// ```
/// use eulermembrane_cases::plot::{Figure, Panels};
/// let mut left = Figure::new("(a) shape").size(400.0, 400.0).equal_aspect(true);
/// left.line(&[-1.0, 1.0, 1.0, -1.0, -1.0], &[-1.0, -1.0, 1.0, 1.0, -1.0], "");
/// let mut right = Figure::new("(b) deformation").size(400.0, 400.0);
/// right.line(&[0.0, 1.0, 2.0], &[0.0, 0.2, 0.25], "D");
/// let mut panels = Panels::new(2);
/// panels.push(left).push(right);
/// let svg = panels.to_svg();
/// assert!(svg.contains("width=\"800\"") && svg.contains("(b) deformation"));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Panels {
    columns: usize,
    figures: Vec<Figure>,
}

impl Panels {
    /// An empty set of panels with `columns` figures per row (0 is taken as 1).
    ///
    /// ```
    /// use eulermembrane_cases::plot::Panels;
    /// let panels = Panels::new(3);
    /// assert!(panels.to_svg().starts_with("<svg"));
    /// ```
    pub fn new(columns: usize) -> Self {
        Panels { columns: columns.max(1), figures: Vec::new() }
    }

    /// Appends a figure.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Panels};
    /// let mut panels = Panels::new(1);
    /// panels.push(Figure::new("top")).push(Figure::new("bottom"));
    /// assert!(panels.to_svg().contains("height=\"960\""));
    /// ```
    pub fn push(&mut self, figure: Figure) -> &mut Self {
        self.figures.push(figure);
        self
    }

    /// Renders all figures into one SVG document.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Panels};
    /// let mut panels = Panels::new(2);
    /// panels.push(Figure::new("a")).push(Figure::new("b")).push(Figure::new("c"));
    /// let svg = panels.to_svg();
    /// assert!(svg.contains("width=\"1280\"") && svg.contains("height=\"960\""));
    /// ```
    pub fn to_svg(&self) -> String {
        let cols = self.columns;
        let rows = self.figures.len().div_ceil(cols);
        let mut col_w = vec![0.0_f64; cols];
        let mut row_h = vec![0.0_f64; rows];
        for (k, fig) in self.figures.iter().enumerate() {
            col_w[k % cols] = col_w[k % cols].max(fig.width);
            row_h[k / cols] = row_h[k / cols].max(fig.height);
        }
        let w: f64 = col_w.iter().sum::<f64>().max(1.0);
        let h: f64 = row_h.iter().sum::<f64>().max(1.0);
        let mut out = String::with_capacity(32 * 1024);
        let _ = writeln!(
            out,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" \
             viewBox=\"0 0 {w} {h}\" font-family=\"{FONT}\">"
        );
        let _ = writeln!(out, "<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>");
        for (k, fig) in self.figures.iter().enumerate() {
            let x: f64 = col_w[..k % cols].iter().sum();
            let y: f64 = row_h[..k / cols].iter().sum();
            let _ =
                writeln!(out, "<svg x=\"{x}\" y=\"{y}\" width=\"{}\" height=\"{}\">", fig.width, fig.height);
            fig.render(&mut out, &format!("p{k}"));
            out.push_str("</svg>\n");
        }
        out.push_str("</svg>\n");
        out
    }

    /// Writes the SVG document to `path`, creating the parent directories.
    ///
    /// Errors: [`Error::Io`](eulermembrane::Error::Io) naming the path.
    ///
    /// ```
    /// use eulermembrane_cases::plot::{Figure, Panels};
    /// # fn main() -> eulermembrane::Result<()> {
    /// let mut panels = Panels::new(2);
    /// panels.push(Figure::new("a")).push(Figure::new("b"));
    /// panels.save(std::env::temp_dir().join("eulermembrane_doc_panels/ab.svg"))?;
    /// # Ok(())
    /// # }
    /// ```
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        write_file(path.as_ref(), &self.to_svg())
    }
}

// ---------------------------------------------------------------------------------------------
// Ticks
// ---------------------------------------------------------------------------------------------

/// Tick values for a linear axis over `[lo, hi]`: multiples of a step `1, 2 or 5 x 10^k`,
/// the smallest step giving at most `max_ticks` ticks (at least 2 are allowed) inside the range.
///
/// Returns no ticks for a non-finite bound, and the single value for `lo == hi`.
///
/// ```
/// use eulermembrane_cases::plot::linear_ticks;
/// assert_eq!(linear_ticks(0.0, 1.0, 6), vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8, 1.0]);
/// assert_eq!(linear_ticks(-3.0, 7.5, 5), vec![-2.0, 0.0, 2.0, 4.0, 6.0]);
/// assert_eq!(linear_ticks(-3.0, 7.5, 4), vec![0.0, 5.0]);
/// ```
pub fn linear_ticks(lo: f64, hi: f64, max_ticks: usize) -> Vec<f64> {
    linear_ticks_step(lo, hi, max_ticks).0
}

/// Ticks and the step between them (0 when there is no step).
fn linear_ticks_step(lo: f64, hi: f64, max_ticks: usize) -> (Vec<f64>, f64) {
    if !lo.is_finite() || !hi.is_finite() {
        return (Vec::new(), 0.0);
    }
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let span = hi - lo;
    if span <= 0.0 {
        return (vec![lo], 0.0);
    }
    if !span.is_finite() {
        return (vec![lo, hi], 0.0);
    }
    let max = max_ticks.max(2);
    let mut base = 10f64.powf((span / (max - 1) as f64).log10().floor());
    for _ in 0..8 {
        for m in [1.0, 2.0, 5.0] {
            let step = m * base;
            if !(step > 0.0 && step.is_finite()) {
                continue;
            }
            let first = (lo / step - 1e-9).ceil();
            let last = (hi / step + 1e-9).floor();
            let n = last - first + 1.0;
            if n.is_finite() && n >= 0.0 && n <= max as f64 {
                let ticks = (0..n as usize)
                    .map(|c| {
                        let v = (first + c as f64) * step;
                        if v.abs() < 1e-9 * step { 0.0 } else { v }
                    })
                    .collect();
                return (ticks, step);
            }
        }
        base *= 10.0;
    }
    (vec![lo, hi], 0.0)
}

/// Tick values for a log10 axis over `[lo, hi]` (both > 0): powers of ten (every decade, or
/// every 2nd, 3rd, 5th... when more than `max_ticks` decades), or on a range of less than two
/// decades the values `1, 2, 5 x 10^k`, or on a range too short for those, linear ticks.
///
/// Returns no ticks if a bound is not finite and positive.
///
/// ```
/// use eulermembrane_cases::plot::log_ticks;
/// assert_eq!(log_ticks(0.5, 2000.0, 8), vec![1.0, 10.0, 100.0, 1000.0]);
/// assert_eq!(log_ticks(1e-12, 1.0, 5), vec![1e-12, 1e-9, 1e-6, 1e-3, 1.0]);
/// assert_eq!(log_ticks(0.15, 1.1, 8), vec![0.2, 0.5, 1.0]);
/// assert_eq!(log_ticks(3.0, 5.0, 5), vec![3.0, 3.5, 4.0, 4.5, 5.0]);
/// ```
pub fn log_ticks(lo: f64, hi: f64, max_ticks: usize) -> Vec<f64> {
    log_ticks_kind(lo, hi, max_ticks).0
}

/// How the ticks of a log axis were chosen (which decides their labels).
#[derive(Clone, Copy, Debug, PartialEq)]
enum LogTicks {
    /// Powers of ten, every `step`-th decade.
    Decades(i32),
    /// `1, 2, 5 x 10^k`.
    OneTwoFive,
    /// Linear ticks with this step.
    Linear(f64),
}

/// `m x 10^k`, correctly rounded.
fn pow10(m: u32, k: i32) -> f64 {
    format!("{m}e{k}").parse().unwrap_or(f64::NAN)
}

fn log_ticks_kind(lo: f64, hi: f64, max_ticks: usize) -> (Vec<f64>, LogTicks) {
    let ok = |v: f64| v.is_finite() && v > 0.0;
    if !ok(lo) || !ok(hi) {
        return (Vec::new(), LogTicks::Decades(1));
    }
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let max = max_ticks.max(2);
    let (a, b) = (lo.log10(), hi.log10());
    let kmin = (a - 1e-9).ceil() as i32;
    let kmax = (b + 1e-9).floor() as i32;
    let decades = kmax - kmin + 1;
    if decades < 3 {
        let (lo_tol, hi_tol) = (lo * (1.0 - 1e-9), hi * (1.0 + 1e-9));
        let mut ticks = Vec::new();
        for k in (a.floor() as i32 - 1)..=(b.ceil() as i32 + 1) {
            for m in [1, 2, 5] {
                let v = pow10(m, k);
                if v >= lo_tol && v <= hi_tol {
                    ticks.push(v);
                }
            }
        }
        if ticks.len() >= 2 && ticks.len() <= max {
            return (ticks, LogTicks::OneTwoFive);
        }
    }
    if decades >= 2 {
        let mut step = 1;
        for s in [1, 2, 3, 5, 10, 20, 30, 50, 100, 200, 300, 500, 1000] {
            step = s;
            if (kmin..=kmax).filter(|k| k.rem_euclid(s) == 0).count() <= max {
                break;
            }
        }
        let ticks = (kmin..=kmax).filter(|k| k.rem_euclid(step) == 0).map(|k| pow10(1, k));
        return (ticks.collect(), LogTicks::Decades(step));
    }
    let (ticks, step) = linear_ticks_step(lo, hi, max);
    (ticks.into_iter().filter(|&v| v > 0.0).collect(), LogTicks::Linear(step))
}

/// Unlabelled ticks of a log axis: `m x 10^k` for m = 2..9 (and 1 when not labelled).
fn log_minor_ticks(lo: f64, hi: f64, kind: LogTicks, major: &[f64]) -> Vec<f64> {
    let allowed = match kind {
        LogTicks::Decades(1) | LogTicks::OneTwoFive => true,
        LogTicks::Decades(_) | LogTicks::Linear(_) => false,
    };
    if !(allowed && lo > 0.0 && hi > lo) || hi / lo > 1e12 {
        return Vec::new();
    }
    let mut minor = Vec::new();
    for k in (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32) {
        for m in 1..=9 {
            let v = pow10(m, k);
            let labelled = major.iter().any(|&t| (t - v).abs() <= 1e-9 * v);
            if v >= lo && v <= hi && !labelled {
                minor.push(v);
            }
        }
    }
    minor
}

/// A tick label: `mantissa`, or `mantissa x 10^exp`, or `10^exp` when the mantissa is empty.
#[derive(Clone, Debug, PartialEq)]
struct Label {
    mantissa: String,
    exp: Option<i32>,
}

impl Label {
    fn plain(s: String) -> Self {
        Label { mantissa: s, exp: None }
    }

    /// Estimated width in pixels at font size `fs`.
    fn width(&self, fs: f64) -> f64 {
        let m = self.mantissa.chars().count() as f64;
        match self.exp {
            None => m * CHAR_W * fs,
            Some(e) => {
                let times = if self.mantissa.is_empty() { 0.0 } else { 1.0 };
                let e_chars = e.to_string().chars().count() as f64;
                (m + times + 2.0) * CHAR_W * fs + e_chars * CHAR_W * SUP_SCALE * fs
            }
        }
    }

    fn write(&self, out: &mut String, fs: f64) {
        escape_into(out, &self.mantissa);
        if let Some(e) = self.exp {
            if !self.mantissa.is_empty() {
                out.push('×');
            }
            let _ = write!(
                out,
                "10<tspan dy=\"{}\" font-size=\"{}\">{}</tspan>",
                P(-0.4 * fs),
                P(SUP_SCALE * fs),
                minus(&e.to_string())
            );
        }
    }
}

/// Replaces the hyphen of negative numbers by a typographic minus sign.
fn minus(s: &str) -> String {
    s.replace('-', "\u{2212}")
}

/// `v` with `decimals` decimals, without a negative zero.
fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    let negative_zero = s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.');
    minus(if negative_zero { &s[1..] } else { &s })
}

/// Decimals needed to show a multiple of `step` (a 1-2-5 value) exactly.
fn decimals_for(step: f64) -> usize {
    if step > 0.0 && step.is_finite() {
        (-(step.log10() + 1e-6).floor()).clamp(0.0, 15.0) as usize
    } else {
        0
    }
}

/// `v` as `mantissa x 10^exp`, with the mantissa resolved to `resolution`.
fn scientific(v: f64, resolution: f64) -> Label {
    if v == 0.0 || !v.is_finite() {
        return Label::plain("0".into());
    }
    let mut e = v.abs().log10().floor() as i32;
    let digits = |e: i32| {
        if resolution > 0.0 && resolution.is_finite() {
            (e - (resolution.log10() + 1e-6).floor() as i32).clamp(0, 12) as usize
        } else {
            0
        }
    };
    let mut mantissa = v / 10f64.powi(e);
    if (format!("{:.*}", digits(e), mantissa.abs())).starts_with("10") {
        e += 1;
        mantissa = v / 10f64.powi(e);
    }
    let mut s = format!("{:.*}", digits(e), mantissa);
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    Label { mantissa: minus(&s), exp: Some(e) }
}

fn linear_labels(ticks: &[f64], step: f64) -> Vec<Label> {
    let max_abs = ticks.iter().fold(0.0_f64, |m, t| m.max(t.abs()));
    let step = if step > 0.0 { step } else { max_abs };
    if max_abs >= 1e5 || (max_abs > 0.0 && max_abs < 1e-3) {
        ticks.iter().map(|&t| scientific(t, step)).collect()
    } else {
        ticks.iter().map(|&t| Label::plain(fixed(t, decimals_for(step)))).collect()
    }
}

fn log_labels(ticks: &[f64], kind: LogTicks) -> Vec<Label> {
    match kind {
        LogTicks::Decades(_) => ticks
            .iter()
            .map(|t| Label { mantissa: String::new(), exp: Some(t.log10().round() as i32) })
            .collect(),
        LogTicks::OneTwoFive => ticks
            .iter()
            .map(|&t| {
                if !(1e-3..1e5).contains(&t) {
                    scientific(t, t)
                } else {
                    Label::plain(fixed(t, decimals_for(t)))
                }
            })
            .collect(),
        LogTicks::Linear(step) => linear_labels(ticks, step),
    }
}

// ---------------------------------------------------------------------------------------------
// Layout
// ---------------------------------------------------------------------------------------------

const FONT: &str = "DejaVu Sans, Helvetica, Arial, sans-serif";
const FS_TICK: f64 = 12.0;
const FS_LABEL: f64 = 14.0;
const FS_TITLE: f64 = 15.0;
const FS_LEGEND: f64 = 12.0;
/// Average glyph width over font size (DejaVu Sans digits are 0.64 em, letters narrower).
const CHAR_W: f64 = 0.6;
const SUP_SCALE: f64 = 0.75;
const TICK_LEN: f64 = 5.0;
const MARGIN: f64 = 10.0;
const TEXT: &str = "#222222";
const AXIS: &str = "#333333";
const GRID: &str = "#e3e3e3";
/// Pixel coordinates are clamped to this magnitude, so far outliers stay valid SVG numbers.
const PX_LIMIT: f64 = 1e6;

/// A coordinate or length written with at most two decimals.
struct P(f64);

impl fmt::Display for P {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0.is_finite() { self.0.clamp(-PX_LIMIT, PX_LIMIT) } else { 0.0 };
        let r = (v * 100.0).round() / 100.0;
        write!(f, "{}", if r == 0.0 { 0.0 } else { r })
    }
}

fn escape_into(out: &mut String, s: &str) {
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\t' => out.push(' '),
            c => out.push(c),
        }
    }
}

fn text_width(s: &str, fs: f64) -> f64 {
    s.chars().count() as f64 * CHAR_W * fs
}

/// The coordinate in the axis' transformed space (log10 on a log axis), if drawable.
fn transform(scale: Scale, v: f64) -> Option<f64> {
    match scale {
        Scale::Linear if v.is_finite() => Some(v),
        Scale::Log10 if v.is_finite() && v > 0.0 => Some(v.log10()),
        _ => None,
    }
}

/// An axis ready to draw: range and ticks in transformed space.
#[derive(Debug)]
struct AxisLayout {
    lo: f64,
    hi: f64,
    ticks: Vec<(f64, Label)>,
    minor: Vec<f64>,
}

impl AxisLayout {
    fn frac(&self, t: f64) -> f64 {
        (t - self.lo) / (self.hi - self.lo)
    }

    fn max_label_width(&self) -> f64 {
        self.ticks.iter().fold(0.0, |m, (_, l)| m.max(l.width(FS_TICK)))
    }
}

/// Widens a degenerate range around its centre.
fn widen(lo: f64, hi: f64, scale: Scale) -> (f64, f64) {
    let scale_of = lo.abs().max(hi.abs());
    if hi - lo > 1e-12 * scale_of && hi - lo > 1e-300 {
        return (lo, hi);
    }
    let c = 0.5 * (lo + hi);
    let half = match scale {
        Scale::Log10 => 0.5,
        // Around zero (or a subnormal centre, whose tenth would not widen anything): unit width.
        Scale::Linear if c.abs() < 1e-290 => 1.0,
        Scale::Linear => 0.1 * c.abs(),
    };
    (c - half, c + half)
}

/// The axis range in transformed space: the explicit one if usable, else the data range with a
/// 4 % margin, else a unit range.
fn resolve_range(spec: &AxisSpec, data: Option<(f64, f64)>) -> (f64, f64) {
    let limit = match spec.scale {
        Scale::Linear => 1e300,
        Scale::Log10 => 300.0,
    };
    let clamp = |(lo, hi): (f64, f64)| (lo.clamp(-limit, limit), hi.clamp(-limit, limit));
    if let Some((a, b)) = spec.range
        && let (Some(a), Some(b)) = (transform(spec.scale, a), transform(spec.scale, b))
    {
        let (lo, hi) = clamp((a.min(b), a.max(b)));
        return widen(lo, hi, spec.scale);
    }
    match data {
        Some(range) => {
            let (lo, hi) = clamp(range);
            let (lo, hi) = widen(lo, hi, spec.scale);
            let pad = 0.04 * (hi - lo);
            (lo - pad, hi + pad)
        }
        None => (0.0, 1.0),
    }
}

fn axis_layout(scale: Scale, (lo, hi): (f64, f64), len: f64, horizontal: bool) -> AxisLayout {
    let per_tick = if horizontal { 55.0 } else { 38.0 };
    let mut max = ((len / per_tick).floor() as usize).clamp(2, 12);
    loop {
        let (values, labels, minor) = match scale {
            Scale::Linear => {
                let (v, step) = linear_ticks_step(lo, hi, max);
                let labels = linear_labels(&v, step);
                (v, labels, Vec::new())
            }
            Scale::Log10 => {
                let (a, b) = (10f64.powf(lo), 10f64.powf(hi));
                let (v, kind) = log_ticks_kind(a, b, max);
                let labels = log_labels(&v, kind);
                let minor = log_minor_ticks(a, b, kind, &v);
                let t = |v: &f64| v.log10();
                (v.iter().map(t).collect(), labels, minor.iter().map(t).collect())
            }
        };
        let eps = 1e-9 * (hi - lo);
        let ticks: Vec<(f64, Label)> =
            values.into_iter().zip(labels).filter(|(t, _)| *t >= lo - eps && *t <= hi + eps).collect();
        // Fewer ticks when labels would touch.
        let crowded = ticks.windows(2).any(|w| {
            let gap = (w[1].0 - w[0].0).abs() / (hi - lo) * len;
            let need = if horizontal {
                0.5 * (w[0].1.width(FS_TICK) + w[1].1.width(FS_TICK)) + 12.0
            } else {
                FS_TICK + 6.0
            };
            gap < need
        });
        if crowded && max > 2 {
            max -= 1;
            continue;
        }
        return AxisLayout { lo, hi, ticks, minor };
    }
}

/// Pixel geometry of a rendered figure.
#[derive(Debug)]
struct Layout {
    left: f64,
    top: f64,
    pw: f64,
    ph: f64,
    x: AxisLayout,
    y: AxisLayout,
    xs: Scale,
    ys: Scale,
}

impl Layout {
    /// Pixel position of a data point, if drawable.
    fn px(&self, (x, y): (f64, f64)) -> Option<(f64, f64)> {
        let tx = transform(self.xs, x)?;
        let ty = transform(self.ys, y)?;
        let px = self.left + self.x.frac(tx) * self.pw;
        let py = self.top + (1.0 - self.y.frac(ty)) * self.ph;
        (px.is_finite() && py.is_finite())
            .then(|| (px.clamp(-PX_LIMIT, PX_LIMIT), py.clamp(-PX_LIMIT, PX_LIMIT)))
    }
}

impl Figure {
    /// Range of the drawable data in transformed space, per axis.
    fn data_ranges(&self) -> [Option<(f64, f64)>; 2] {
        let mut ranges: [Option<(f64, f64)>; 2] = [None, None];
        for (x, y) in self.series.iter().flat_map(Series::all_points) {
            if let (Some(tx), Some(ty)) = (transform(self.x.scale, x), transform(self.y.scale, y)) {
                for (r, t) in ranges.iter_mut().zip([tx, ty]) {
                    *r = Some(r.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t))));
                }
            }
        }
        ranges
    }

    fn layout(&self) -> Layout {
        let (w, h) = (self.width, self.height);
        let top = if self.title.is_empty() { 14.0 } else { 14.0 + FS_TITLE + 12.0 };
        let x_label_h = if self.x.label.is_empty() { 0.0 } else { FS_LABEL + 8.0 };
        let bottom = TICK_LEN + 4.0 + FS_TICK + x_label_h + MARGIN;
        let y_label_w = if self.y.label.is_empty() { 0.0 } else { FS_LABEL + 8.0 };
        let [data_x, data_y] = self.data_ranges();
        let (mut left, mut right) = (50.0_f64, 20.0_f64);
        let mut tries = 0;
        loop {
            let pw = (w - left - right).max(20.0);
            let ph = (h - top - bottom).max(20.0);
            let mut xr = resolve_range(&self.x, data_x);
            let mut yr = resolve_range(&self.y, data_y);
            if self.equal_aspect {
                let unit = ((xr.1 - xr.0) / pw).max((yr.1 - yr.0) / ph);
                let fit = |(lo, hi): (f64, f64), len: f64| {
                    let c = 0.5 * (lo + hi);
                    (c - 0.5 * unit * len, c + 0.5 * unit * len)
                };
                xr = fit(xr, pw);
                yr = fit(yr, ph);
            }
            let x = axis_layout(self.x.scale, xr, pw, true);
            let y = axis_layout(self.y.scale, yr, ph, false);
            let need_left = (MARGIN + y_label_w + y.max_label_width() + 4.0 + TICK_LEN).ceil().max(30.0);
            let last_half = x
                .ticks
                .last()
                .filter(|(t, _)| x.frac(*t) > 0.98)
                .map_or(0.0, |(_, l)| 0.5 * l.width(FS_TICK));
            let need_right = (last_half + 6.0).max(20.0).ceil();
            tries += 1;
            if (need_left == left && need_right == right) || tries == 4 {
                return Layout { left, top, pw, ph, x, y, xs: self.x.scale, ys: self.y.scale };
            }
            left = need_left;
            right = need_right;
        }
    }

    /// Colour and marker shape of each series.
    ///
    /// Palette colours and automatic markers go, in order, to the series that do not set
    /// their own.
    fn resolved_styles(&self) -> Vec<(Color, Marker)> {
        let (mut color_count, mut marker_count) = (0, 0);
        self.series
            .iter()
            .map(|s| {
                let color = s.color.unwrap_or_else(|| {
                    color_count += 1;
                    PALETTE[(color_count - 1) % PALETTE.len()]
                });
                let marker = match (s.marker, s.show_markers) {
                    (Some(m), _) => m,
                    (None, true) => {
                        marker_count += 1;
                        AUTO_MARKERS[(marker_count - 1) % AUTO_MARKERS.len()]
                    }
                    (None, false) => Marker::Circle,
                };
                (color, marker)
            })
            .collect()
    }

    /// Writes the figure's elements (without the outer `<svg>` tag); `id` prefixes element ids.
    fn render(&self, out: &mut String, id: &str) {
        let lay = self.layout();
        let (w, h) = (self.width, self.height);
        let (x0, y0) = (lay.left, lay.top);
        let (x1, y1) = (x0 + lay.pw, y0 + lay.ph);
        let styles = self.resolved_styles();
        let xpx = |t: f64| x0 + lay.x.frac(t) * lay.pw;
        let ypx = |t: f64| y0 + (1.0 - lay.y.frac(t)) * lay.ph;

        let _ = writeln!(out, "<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>");
        let _ = writeln!(
            out,
            "<defs><clipPath id=\"{id}-clip\"><rect x=\"{}\" y=\"{}\" width=\"{}\" \
             height=\"{}\"/></clipPath></defs>",
            P(x0),
            P(y0),
            P(lay.pw),
            P(lay.ph)
        );

        // Grid, at the labelled ticks.
        if self.grid {
            let mut d = String::new();
            for (t, _) in &lay.x.ticks {
                let _ = write!(d, "M{} {}V{}", P(xpx(*t)), P(y0), P(y1));
            }
            for (t, _) in &lay.y.ticks {
                let _ = write!(d, "M{} {}H{}", P(x0), P(ypx(*t)), P(x1));
            }
            if !d.is_empty() {
                let _ = writeln!(out, "<path d=\"{d}\" fill=\"none\" stroke=\"{GRID}\" stroke-width=\"1\"/>");
            }
        }

        // Series, clipped to the plot area.
        let _ = writeln!(out, "<g clip-path=\"url(#{id}-clip)\">");
        for (s, &(color, marker)) in self.series.iter().zip(&styles) {
            if s.show_line {
                let mut d = String::new();
                let mut pen_down = false;
                for &p in &s.points {
                    match lay.px(p) {
                        Some((px, py)) => {
                            let cmd = if pen_down { 'L' } else { 'M' };
                            let _ = write!(d, "{cmd}{} {}", P(px), P(py));
                            pen_down = true;
                        }
                        None => pen_down = false,
                    }
                }
                for seg in &s.segments {
                    if let (Some(a), Some(b)) = (lay.px(seg[0]), lay.px(seg[1])) {
                        let _ = write!(d, "M{} {}L{} {}", P(a.0), P(a.1), P(b.0), P(b.1));
                    }
                }
                if !d.is_empty() {
                    let _ = write!(out, "<path d=\"{d}\" ");
                    stroke_attrs(out, color, s.style, s.width);
                    out.push_str("/>\n");
                }
            }
            if s.show_markers {
                let mut d = String::new();
                for &p in &s.points {
                    if let Some(c) = lay.px(p) {
                        marker_path(&mut d, marker, c, s.marker_size);
                    }
                }
                if !d.is_empty() {
                    let _ = write!(out, "<path d=\"{d}\" ");
                    marker_attrs(out, color, s.filled);
                    out.push_str("/>\n");
                }
            }
        }
        out.push_str("</g>\n");

        // Frame and ticks.
        let _ = writeln!(
            out,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"{AXIS}\" \
             stroke-width=\"1\"/>",
            P(x0),
            P(y0),
            P(lay.pw),
            P(lay.ph)
        );
        let mut d = String::new();
        for (t, _) in &lay.x.ticks {
            let _ = write!(d, "M{} {}v{}", P(xpx(*t)), P(y1), TICK_LEN);
        }
        for (t, _) in &lay.y.ticks {
            let _ = write!(d, "M{} {}h{}", P(x0), P(ypx(*t)), -TICK_LEN);
        }
        for &t in &lay.x.minor {
            let _ = write!(d, "M{} {}v{}", P(xpx(t)), P(y1), 0.6 * TICK_LEN);
        }
        for &t in &lay.y.minor {
            let _ = write!(d, "M{} {}h{}", P(x0), P(ypx(t)), -0.6 * TICK_LEN);
        }
        if !d.is_empty() {
            let _ = writeln!(out, "<path d=\"{d}\" stroke=\"{AXIS}\" stroke-width=\"1\"/>");
        }

        // Tick labels.
        let _ = writeln!(out, "<g font-size=\"{FS_TICK}\" fill=\"{TEXT}\">");
        let x_base = y1 + TICK_LEN + 3.0 + 0.8 * FS_TICK;
        for (t, label) in &lay.x.ticks {
            let _ = write!(out, "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">", P(xpx(*t)), P(x_base));
            label.write(out, FS_TICK);
            out.push_str("</text>\n");
        }
        for (t, label) in &lay.y.ticks {
            let _ = write!(
                out,
                "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">",
                P(x0 - TICK_LEN - 4.0),
                P(ypx(*t) + 0.35 * FS_TICK)
            );
            label.write(out, FS_TICK);
            out.push_str("</text>\n");
        }
        out.push_str("</g>\n");

        // Axis labels and title.
        if !self.x.label.is_empty() {
            let y = x_base + 8.0 + FS_LABEL;
            let _ = write!(
                out,
                "<text x=\"{}\" y=\"{}\" font-size=\"{FS_LABEL}\" fill=\"{TEXT}\" \
                 text-anchor=\"middle\">",
                P(0.5 * (x0 + x1)),
                P(y)
            );
            escape_into(out, &self.x.label);
            out.push_str("</text>\n");
        }
        if !self.y.label.is_empty() {
            let _ = write!(
                out,
                "<text transform=\"translate({} {}) rotate(-90)\" font-size=\"{FS_LABEL}\" \
                 fill=\"{TEXT}\" text-anchor=\"middle\">",
                P(MARGIN + 0.8 * FS_LABEL),
                P(0.5 * (y0 + y1))
            );
            escape_into(out, &self.y.label);
            out.push_str("</text>\n");
        }
        if !self.title.is_empty() {
            let _ = write!(
                out,
                "<text x=\"{}\" y=\"{}\" font-size=\"{FS_TITLE}\" font-weight=\"bold\" \
                 fill=\"{TEXT}\" text-anchor=\"middle\">",
                P(0.5 * (x0 + x1)),
                P(14.0 + 0.8 * FS_TITLE)
            );
            escape_into(out, &self.title);
            out.push_str("</text>\n");
        }

        self.render_legend(out, &lay, &styles);
    }

    fn render_legend(&self, out: &mut String, lay: &Layout, styles: &[(Color, Marker)]) {
        if self.legend == Legend::Hidden {
            return;
        }
        let entries: Vec<(&Series, Color, Marker)> = self
            .series
            .iter()
            .zip(styles)
            .filter(|(s, _)| !s.label.is_empty())
            .map(|(s, &(c, m))| (s, c, m))
            .collect();
        if entries.is_empty() {
            return;
        }
        const ROW: f64 = 18.0;
        const SAMPLE: f64 = 28.0;
        const PAD: f64 = 8.0;
        let text_w = entries.iter().fold(0.0_f64, |m, e| m.max(text_width(&e.0.label, FS_LEGEND)));
        let bw = (PAD + SAMPLE + 6.0 + text_w + PAD).min(lay.pw.max(40.0));
        let bh = 6.0 + ROW * entries.len() as f64 + 2.0;
        let inset = 8.0;
        let corner = |l: Legend| {
            let right = lay.left + lay.pw - inset - bw;
            let bottom = lay.top + lay.ph - inset - bh;
            let (l_x, t_y) = (lay.left + inset, lay.top + inset);
            match l {
                Legend::TopLeft => (l_x, t_y),
                Legend::BottomRight => (right, bottom),
                Legend::BottomLeft => (l_x, bottom),
                _ => (right, t_y),
            }
        };
        let (bx, by) = match self.legend {
            Legend::Best => {
                let samples = self.occupancy(lay);
                let candidates = [Legend::TopRight, Legend::TopLeft, Legend::BottomRight, Legend::BottomLeft];
                let mut best = (usize::MAX, corner(Legend::TopRight));
                for c in candidates {
                    let (bx, by) = corner(c);
                    let count = samples
                        .iter()
                        .filter(|(x, y)| {
                            *x >= bx - 4.0 && *x <= bx + bw + 4.0 && *y >= by - 4.0 && *y <= by + bh + 4.0
                        })
                        .count();
                    if count < best.0 {
                        best = (count, (bx, by));
                    }
                }
                best.1
            }
            other => corner(other),
        };
        let _ = writeln!(
            out,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" rx=\"3\" fill=\"white\" \
             fill-opacity=\"0.9\" stroke=\"#bbbbbb\" stroke-width=\"1\"/>",
            P(bx),
            P(by),
            P(bw),
            P(bh)
        );
        for (k, (s, color, marker)) in entries.into_iter().enumerate() {
            let cy = by + 4.0 + ROW * (k as f64 + 0.5);
            let (sx0, sx1) = (bx + PAD, bx + PAD + SAMPLE);
            if s.show_line {
                let _ = write!(out, "<path d=\"M{} {}H{}\" ", P(sx0), P(cy), P(sx1));
                stroke_attrs(out, color, s.style, s.width);
                out.push_str("/>\n");
            }
            if s.show_markers {
                let mut d = String::new();
                marker_path(&mut d, marker, (0.5 * (sx0 + sx1), cy), s.marker_size);
                let _ = write!(out, "<path d=\"{d}\" ");
                marker_attrs(out, color, s.filled);
                out.push_str("/>\n");
            }
            let _ = write!(
                out,
                "<text x=\"{}\" y=\"{}\" font-size=\"{FS_LEGEND}\" fill=\"{TEXT}\">",
                P(sx1 + 6.0),
                P(cy + 0.35 * FS_LEGEND)
            );
            escape_into(out, &s.label);
            out.push_str("</text>\n");
        }
    }

    /// Pixel positions that the data covers: points, and samples along lines every few pixels.
    fn occupancy(&self, lay: &Layout) -> Vec<(f64, f64)> {
        let mut samples = Vec::new();
        let along = |a: (f64, f64), b: (f64, f64), samples: &mut Vec<(f64, f64)>| {
            let len = (b.0 - a.0).hypot(b.1 - a.1);
            let n = (len / 6.0).ceil().clamp(1.0, 200.0) as usize;
            for k in 0..=n {
                let t = k as f64 / n as f64;
                samples.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
            }
        };
        for s in &self.series {
            let mut prev: Option<(f64, f64)> = None;
            for &p in &s.points {
                let q = lay.px(p);
                match (s.show_line, prev, q) {
                    (true, Some(a), Some(b)) => along(a, b, &mut samples),
                    (_, _, Some(b)) => samples.push(b),
                    _ => {}
                }
                prev = q;
            }
            for seg in &s.segments {
                if let (Some(a), Some(b)) = (lay.px(seg[0]), lay.px(seg[1])) {
                    along(a, b, &mut samples);
                }
            }
        }
        samples
    }
}

fn stroke_attrs(out: &mut String, color: Color, style: LineStyle, width: f64) {
    let _ = write!(
        out,
        "fill=\"none\" stroke=\"{color}\" stroke-width=\"{}\" stroke-linejoin=\"round\" \
         stroke-linecap=\"round\"",
        P(width)
    );
    // Round caps lengthen each dash by one width; the gaps are set to leave visible space.
    let dashes: &[f64] = match style {
        LineStyle::Solid => return,
        LineStyle::Dashed => &[4.0, 3.5],
        LineStyle::Dotted => &[0.01, 2.6],
        LineStyle::DashDot => &[4.0, 2.8, 0.01, 2.8],
    };
    out.push_str(" stroke-dasharray=\"");
    for (k, d) in dashes.iter().enumerate() {
        let sep = if k > 0 { " " } else { "" };
        let _ = write!(out, "{sep}{}", P(d * width.max(1.0)));
    }
    out.push('"');
}

fn marker_attrs(out: &mut String, color: Color, filled: bool) {
    let fill = if filled { color.to_string() } else { "none".to_string() };
    let _ = write!(out, "fill=\"{fill}\" stroke=\"{color}\" stroke-width=\"1.25\" stroke-linejoin=\"round\"");
}

/// Appends the outline of a marker of size `r` centred on `(cx, cy)` to a path.
fn marker_path(d: &mut String, marker: Marker, (cx, cy): (f64, f64), r: f64) {
    match marker {
        Marker::Circle => {
            let _ = write!(
                d,
                "M{} {}a{r2} {r2} 0 1 0 {} 0a{r2} {r2} 0 1 0 {} 0Z",
                P(cx - r),
                P(cy),
                P(2.0 * r),
                P(-2.0 * r),
                r2 = P(r)
            );
        }
        Marker::Square => {
            let s = 0.886 * r;
            let _ = write!(d, "M{} {}h{}v{}h{}Z", P(cx - s), P(cy - s), P(2.0 * s), P(2.0 * s), P(-2.0 * s));
        }
        Marker::Triangle | Marker::TriangleDown => {
            let sign = if marker == Marker::Triangle { 1.0 } else { -1.0 };
            let c = 1.35 * r;
            let _ = write!(
                d,
                "M{} {}L{} {}L{} {}Z",
                P(cx),
                P(cy - sign * c),
                P(cx + 0.866 * c),
                P(cy + sign * 0.5 * c),
                P(cx - 0.866 * c),
                P(cy + sign * 0.5 * c)
            );
        }
        Marker::Diamond => {
            let c = 1.25 * r;
            let _ = write!(
                d,
                "M{} {}L{} {}L{} {}L{} {}Z",
                P(cx),
                P(cy - c),
                P(cx + c),
                P(cy),
                P(cx),
                P(cy + c),
                P(cx - c),
                P(cy)
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Contours
// ---------------------------------------------------------------------------------------------

/// Marching squares: the iso-line `f = level` of point values `values[i + nx * j]` given at
/// `(x0 + i dx, y0 + j dy)`, `i < nx`, `j < ny`, as disjoint segments.
///
/// On each cell edge whose end values straddle the level (one `> level`, the other `<= level`)
/// the crossing is interpolated linearly; an edge shared by two cells gives bit-identical
/// points in both, so the segments join into polylines and closed loops exactly. Each segment
/// is oriented with the values above the level on its left (for `dx, dy > 0`): a contour of a
/// field that is larger inside a closed curve runs counter-clockwise, and the shoelace formula
/// on it gives the enclosed area with a positive sign.
///
/// The ambiguous saddle cell (diagonal corners above, the others below) is resolved by the
/// asymptotic decider: the corners above the level are joined through the cell when the
/// bilinear interpolant's saddle value is above the level, i.e. when
/// `(a - l)(c - l) > (b - l)(d - l)` for the above pair `a, c` and the below pair `b, d`. This
/// is the topology of the bilinear interpolant, the same from both sides of every edge.
///
/// Cells with a non-finite corner value are skipped. If `values` holds fewer than `nx * ny`
/// values only the complete rows are used; `nx < 2`, `ny < 2`, a zero or non-finite spacing or
/// a non-finite level give no segments.
///
/// ```
/// use eulermembrane_cases::plot::{contour_segments, Figure};
/// // phi = 1 inside the unit circle, sampled on [-2, 2]^2.
/// let n = 41;
/// let h = 4.0 / (n - 1) as f64;
/// let mut phi = vec![0.0; n * n];
/// for j in 0..n {
///     for i in 0..n {
///         let (x, y) = (-2.0 + i as f64 * h, -2.0 + j as f64 * h);
///         phi[i + n * j] = 1.0 - (x * x + y * y).sqrt();
///     }
/// }
/// let segments = contour_segments(n, n, -2.0, -2.0, h, h, &phi, 0.0);
/// assert!(!segments.is_empty());
/// for [a, b] in &segments {
///     assert!((a.0.hypot(a.1) - 1.0).abs() < 1e-2);
///     assert!((b.0.hypot(b.1) - 1.0).abs() < 1e-2);
/// }
/// let mut fig = Figure::new("interface").equal_aspect(true);
/// fig.segments(segments, "phi = 0.5");
/// ```
#[allow(clippy::too_many_arguments)]
pub fn contour_segments(
    nx: usize,
    ny: usize,
    x0: f64,
    y0: f64,
    dx: f64,
    dy: f64,
    values: &[f64],
    level: f64,
) -> Vec<[(f64, f64); 2]> {
    let mut segments = Vec::new();
    let ny = values.len().checked_div(nx).map_or(0, |rows| rows.min(ny));
    let spacing_ok = |h: f64| h.is_finite() && h != 0.0;
    if nx < 2
        || ny < 2
        || !level.is_finite()
        || !x0.is_finite()
        || !y0.is_finite()
        || !spacing_ok(dx)
        || !spacing_ok(dy)
    {
        return segments;
    }
    // Crossing on the edge from grid point (i, j) to (i + 1, j) (horizontal) or (i, j + 1),
    // interpolated from that first point whichever cell asks: shared edges agree exactly.
    let horizontal = |i: usize, j: usize, s0: f64, s1: f64| {
        let t = s0 / (s0 - s1);
        (x0 + (i as f64 + t) * dx, y0 + j as f64 * dy)
    };
    let vertical = |i: usize, j: usize, s0: f64, s1: f64| {
        let t = s0 / (s0 - s1);
        (x0 + i as f64 * dx, y0 + (j as f64 + t) * dy)
    };
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let k = i + nx * j;
            // Corners counter-clockwise from the lower left: a, b, c, d.
            let v = [values[k], values[k + 1], values[k + 1 + nx], values[k + nx]];
            if v.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let s = v.map(|v| v - level);
            let case = s.iter().enumerate().fold(0, |c, (b, &s)| c | (usize::from(s > 0.0) << b));
            if case == 0 || case == 15 {
                continue;
            }
            // Edges: 0 bottom (a-b), 1 right (b-c), 2 top (d-c), 3 left (a-d).
            let edge = |e: usize| match e {
                0 => horizontal(i, j, s[0], s[1]),
                1 => vertical(i + 1, j, s[1], s[2]),
                2 => horizontal(i, j + 1, s[3], s[2]),
                _ => vertical(i, j, s[0], s[3]),
            };
            let pairs: &[(usize, usize)] = match case {
                1 => &[(0, 3)],
                2 => &[(1, 0)],
                3 => &[(1, 3)],
                4 => &[(2, 1)],
                5 if s[0] * s[2] > s[1] * s[3] => &[(0, 1), (2, 3)],
                5 => &[(0, 3), (2, 1)],
                6 => &[(2, 0)],
                7 => &[(2, 3)],
                8 => &[(3, 2)],
                9 => &[(0, 2)],
                10 if s[1] * s[3] > s[0] * s[2] => &[(3, 0), (1, 2)],
                10 => &[(1, 0), (3, 2)],
                11 => &[(1, 2)],
                12 => &[(3, 1)],
                13 => &[(0, 1)],
                _ => &[(3, 0)],
            };
            for &(from, to) in pairs {
                segments.push([edge(from), edge(to)]);
            }
        }
    }
    segments
}
