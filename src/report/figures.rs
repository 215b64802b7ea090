//! The report's figures, drawn with plotters into an SVG (inlined in the HTML page) and a
//! PNG each. The PNG backend renders text with DejaVu Sans embedded in the binary, so a
//! machine without system fonts draws readable axes; the SVG leaves text to the browser.

use crate::input::units::DisplayUnit;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

const SIZE: (u32, u32) = (720, 440);
pub(super) const FONT: &str = "sans-serif";
/// Text sizes in pixels of the 720 × 440 figure, which the page shows 580 wide: plotters
/// draws a size-s font at s/1.24 px, so the tick labels read at about 11 px on the page.
pub(super) const TITLE: f64 = 22.0;
pub(super) const AXIS: f64 = 19.0;
const TICKS: f64 = 17.0;
pub(super) const SMALL: f64 = 16.0;
pub(super) const BLUE: RGBColor = RGBColor(43, 76, 126);
pub(super) const ORANGE: RGBColor = RGBColor(221, 132, 82);
const GREY: RGBColor = RGBColor(120, 120, 120);

/// Registers the embedded font for the bitmap backend (once per process).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/DejaVuSans.ttf");
        if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_err() {
            eprintln!("warning: the embedded font did not load; PNG figures will lack text");
        }
    });
}

/// Tick labels with enough digits to tell ticks apart over the range [lo, hi].
fn tick_format(lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    let span = (hi - lo).abs().max(f64::MIN_POSITIVE);
    let big = lo.abs().max(hi.abs());
    let digits = (-(span / 5.0).log10()).ceil().clamp(0.0, 9.0) as usize;
    move |v: &f64| {
        if big >= 1e5 || (big > 0.0 && big < 1e-3) {
            format!("{v:.3e}")
        } else {
            format!("{v:.digits$}")
        }
    }
}

/// The range [lo, hi] padded by 5 % (or ±1 when flat).
fn padded(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi > lo {
        let p = 0.05 * (hi - lo);
        (lo - p, hi + p)
    } else {
        let p = if lo == 0.0 { 1.0 } else { 0.01 * lo.abs() };
        (lo - p, hi + p)
    }
}

pub(super) type DrawResult<DB> =
    Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A figure that draws on any plotters backend.
pub trait Figure {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB>;
}

/// Writes `stem.svg` and `stem.png`; returns the SVG path.
pub fn save(figure: &impl Figure, stem: &Path) -> anyhow::Result<PathBuf> {
    register_font();
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    {
        let area = SVGBackend::new(&svg, SIZE).into_drawing_area();
        figure
            .draw(&area)
            .map_err(|e| anyhow::anyhow!("drawing {}: {e:?}", svg.display()))?;
        area.present()
            .map_err(|e| anyhow::anyhow!("writing {}: {e:?}", svg.display()))?;
    }
    {
        let area = BitMapBackend::new(&png, SIZE).into_drawing_area();
        figure
            .draw(&area)
            .map_err(|e| anyhow::anyhow!("drawing {}: {e:?}", png.display()))?;
        area.present()
            .map_err(|e| anyhow::anyhow!("writing {}: {e:?}", png.display()))?;
    }
    Ok(svg)
}

/// Histogram of an output as a density, with the fitted normal, the mean, mean ± 3σ and
/// the specification limits.
pub struct HistogramFigure<'a> {
    pub title: String,
    pub scale: DisplayUnit,
    pub name: &'a str,
    /// Successful values (SI).
    pub values: &'a [f64],
    pub mean: f64,
    pub sd: f64,
    pub limits: (Option<f64>, Option<f64>),
}

impl Figure for HistogramFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let k = self.scale.per_si;
        let mut sorted: Vec<f64> = self.values.iter().map(|v| v * k).collect();
        sorted.sort_by(f64::total_cmp);
        let (lo, width, counts) = crate::study::statistics::histogram(&sorted);
        let n = sorted.len().max(1) as f64;
        let (m, s) = (self.mean * k, self.sd * k);
        let mut x_lo = lo.min(m - 3.2 * s);
        let mut x_hi = (lo + width * counts.len() as f64).max(m + 3.2 * s);
        for l in [self.limits.0, self.limits.1].into_iter().flatten() {
            x_lo = x_lo.min(l * k);
            x_hi = x_hi.max(l * k);
        }
        let (x_lo, x_hi) = padded(x_lo, x_hi);
        let density: Vec<f64> = counts.iter().map(|&c| c as f64 / (n * width)).collect();
        let pdf_peak = if s > 0.0 {
            1.0 / (s * (2.0 * std::f64::consts::PI).sqrt())
        } else {
            0.0
        };
        let y_hi = density.iter().fold(pdf_peak, |a, &b| a.max(b)) * 1.12;
        let y_hi = if y_hi > 0.0 { y_hi } else { 1.0 };
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, TITLE))
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(88)
            .build_cartesian_2d(x_lo..x_hi, 0.0..y_hi)?;
        chart
            .configure_mesh()
            .x_desc(self.scale.heading(self.name))
            .y_desc(format!("probability density [1/{}]", self.scale.label).replace(" [1/]", ""))
            .x_label_formatter(&tick_format(x_lo, x_hi))
            .y_label_formatter(&tick_format(0.0, y_hi))
            .y_labels(6)
            .x_labels(7)
            .label_style((FONT, TICKS))
            .axis_desc_style((FONT, AXIS))
            .light_line_style(WHITE)
            .draw()?;
        chart
            .draw_series(density.iter().enumerate().map(|(i, &d)| {
                let x0 = lo + width * i as f64;
                Rectangle::new([(x0, 0.0), (x0 + width, d)], BLUE.mix(0.45).filled())
            }))?
            .label(format!("{} samples", sorted.len()))
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 5), (x + 14, y + 5)], BLUE.mix(0.45).filled())
            });
        if s > 0.0 {
            let pts = (0..=200).map(|i| {
                let x = x_lo + (x_hi - x_lo) * i as f64 / 200.0;
                (x, pdf_peak * (-0.5 * ((x - m) / s).powi(2)).exp())
            });
            chart
                .draw_series(LineSeries::new(pts, ORANGE.stroke_width(2)))?
                .label("fitted normal")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], ORANGE.stroke_width(2)));
        }
        let vline = |x: f64| vec![(x, 0.0), (x, y_hi * 0.95)];
        chart
            .draw_series(std::iter::once(PathElement::new(
                vline(m),
                BLACK.stroke_width(2),
            )))?
            .label("mean")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], BLACK.stroke_width(2)));
        chart
            .draw_series(
                [m - 3.0 * s, m + 3.0 * s]
                    .into_iter()
                    .map(|x| PathElement::new(vline(x), GREY.stroke_width(1))),
            )?
            .label("mean ± 3σ")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], GREY.stroke_width(1)));
        let limits: Vec<f64> = [self.limits.0, self.limits.1]
            .into_iter()
            .flatten()
            .map(|l| l * k)
            .collect();
        if !limits.is_empty() {
            chart
                .draw_series(
                    limits
                        .into_iter()
                        .map(|x| PathElement::new(vline(x), RED.stroke_width(2))),
                )?
                .label("spec limits")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], RED.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(GREY)
            .label_font((FONT, SMALL))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        Ok(())
    }
}

/// Empirical CDF of an output.
pub struct EcdfFigure<'a> {
    pub title: String,
    pub scale: DisplayUnit,
    pub name: &'a str,
    pub values: &'a [f64],
}

impl Figure for EcdfFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let mut v: Vec<f64> = self.values.iter().map(|x| x * self.scale.per_si).collect();
        v.sort_by(f64::total_cmp);
        let (lo, hi) = padded(
            v.first().copied().unwrap_or(0.0),
            v.last().copied().unwrap_or(1.0),
        );
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, TITLE))
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(72)
            .build_cartesian_2d(lo..hi, 0.0..1.0)?;
        chart
            .configure_mesh()
            .x_desc(self.scale.heading(self.name))
            .y_desc("fraction of samples ≤ x")
            .x_label_formatter(&tick_format(lo, hi))
            .x_labels(7)
            .label_style((FONT, TICKS))
            .axis_desc_style((FONT, AXIS))
            .draw()?;
        let n = v.len().max(1) as f64;
        let mut pts = vec![(lo, 0.0)];
        for (i, x) in v.iter().enumerate() {
            pts.push((*x, i as f64 / n));
            pts.push((*x, (i + 1) as f64 / n));
        }
        pts.push((hi, 1.0));
        chart.draw_series(LineSeries::new(pts, BLUE.stroke_width(2)))?;
        Ok(())
    }
}

/// A chart of two real axes.
type XyChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A titled chart of y against x on [x0, x1] × [y0, y1] (display units), its axes
/// headed by name and unit.
fn xy_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    (x_name, x_scale): (&str, &DisplayUnit),
    (y_name, y_scale): (&str, &DisplayUnit),
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<XyChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, TITLE))
        .margin(12)
        .x_label_area_size(52)
        .y_label_area_size(88)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(x_scale.heading(x_name))
        .y_desc(y_scale.heading(y_name))
        .x_label_formatter(&tick_format(x0, x1))
        .y_label_formatter(&tick_format(y0, y1))
        .x_labels(6)
        .y_labels(6)
        .label_style((FONT, TICKS))
        .axis_desc_style((FONT, AXIS))
        .draw()?;
    Ok(chart)
}

/// An output against an input, with their correlation in the title.
pub struct ScatterFigure<'a> {
    pub title: String,
    pub x_name: &'a str,
    pub x_scale: DisplayUnit,
    pub y_name: &'a str,
    pub y_scale: DisplayUnit,
    pub points: &'a [(f64, f64)],
}

impl Figure for ScatterFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let pts: Vec<(f64, f64)> = self
            .points
            .iter()
            .map(|(x, y)| (x * self.x_scale.per_si, y * self.y_scale.per_si))
            .collect();
        let range = |f: fn(&(f64, f64)) -> f64| {
            let (lo, hi) = pts
                .iter()
                .map(f)
                .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
            padded(lo, hi)
        };
        let (x0, x1) = range(|p| p.0);
        let (y0, y1) = range(|p| p.1);
        let mut chart = xy_chart(
            area,
            &self.title,
            (self.x_name, &self.x_scale),
            (self.y_name, &self.y_scale),
            (x0, x1),
            (y0, y1),
        )?;
        let radius = if pts.len() > 5000 { 1 } else { 2 };
        chart.draw_series(
            pts.iter()
                .map(|&p| Circle::new(p, radius, BLUE.mix(0.5).filled())),
        )?;
        Ok(())
    }
}

/// One series of bars: a label, a value per input and optional 95 % intervals.
pub struct BarSeries {
    pub label: String,
    pub values: Vec<f64>,
    pub intervals: Option<Vec<(f64, f64)>>,
}

/// Bars per input: one or two series (e.g. first-order and total indices).
pub struct BarsFigure {
    pub title: String,
    pub y_desc: String,
    pub inputs: Vec<String>,
    pub series: Vec<BarSeries>,
}

impl Figure for BarsFigure {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let n = self.inputs.len();
        let mut y_hi: f64 = 0.0;
        let mut y_lo: f64 = 0.0;
        for BarSeries {
            values: v,
            intervals: ci,
            ..
        } in &self.series
        {
            for (i, x) in v.iter().enumerate() {
                if x.is_finite() {
                    y_hi = y_hi.max(*x);
                    y_lo = y_lo.min(*x);
                }
                if let Some(ci) = ci {
                    y_hi = y_hi.max(ci[i].1);
                    y_lo = y_lo.min(ci[i].0);
                }
            }
        }
        let y_hi = if y_hi > 0.0 { y_hi * 1.15 } else { 1.0 };
        let y_lo = if y_lo < 0.0 { y_lo * 1.15 } else { 0.0 };
        let inputs = self.inputs.clone();
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, TITLE))
            .margin(12)
            .x_label_area_size(55)
            .y_label_area_size(72)
            .build_cartesian_2d(0.0..n as f64, y_lo..y_hi)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n.max(1) * 2 + 1)
            .x_label_formatter(&move |x: &f64| {
                let i = (x - 0.5).round();
                if (x - 0.5 - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < inputs.len() {
                    inputs[i as usize].clone()
                } else {
                    String::new()
                }
            })
            .y_desc(&self.y_desc)
            .y_label_formatter(&|v| format!("{v:.2}"))
            .label_style((FONT, SMALL))
            .axis_desc_style((FONT, AXIS))
            .draw()?;
        let m = self.series.len().max(1) as f64;
        let colors = [BLUE, ORANGE];
        for (s, series) in self.series.iter().enumerate() {
            let (label, values, ci) = (&series.label, &series.values, &series.intervals);
            let color = colors[s % 2];
            let left = |i: usize| i as f64 + 0.1 + 0.8 * s as f64 / m;
            let w = 0.8 / m;
            chart
                .draw_series(
                    values
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| v.is_finite())
                        .map(|(i, &v)| {
                            Rectangle::new([(left(i), 0.0), (left(i) + w, v)], color.filled())
                        }),
                )?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled())
                });
            if let Some(ci) = ci {
                chart.draw_series(ci.iter().enumerate().map(|(i, &(a, b))| {
                    let x = left(i) + w / 2.0;
                    PathElement::new(vec![(x, a), (x, b)], BLACK.stroke_width(2))
                }))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(GREY)
            .label_font((FONT, SMALL))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        Ok(())
    }
}

/// Running mean (with its 95 % band) and running σ of an output against the sample
/// count, in sample-id order.
pub struct ConvergenceFigure<'a> {
    pub title: String,
    pub scale: DisplayUnit,
    pub name: &'a str,
    pub values: &'a [f64],
}

impl Figure for ConvergenceFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let k = self.scale.per_si;
        // Welford's running mean and variance
        let (mut mean, mut m2) = (0.0, 0.0);
        let mut rows = Vec::with_capacity(self.values.len());
        for (i, v) in self.values.iter().enumerate() {
            let x = v * k;
            let n = (i + 1) as f64;
            let d = x - mean;
            mean += d / n;
            m2 += d * (x - mean);
            let sd = if i > 0 { (m2 / (n - 1.0)).sqrt() } else { 0.0 };
            rows.push((n, mean, sd));
        }
        // from the 2nd sample (or the 2 % mark) on, at most ~2000 points
        let start = (rows.len() / 50).max(1).min(rows.len());
        let stride = rows.len().div_ceil(2000).max(1);
        let shown: Vec<(f64, f64, f64)> = rows[start..]
            .iter()
            .step_by(stride)
            .chain(rows.last())
            .copied()
            .collect();
        let shown = &shown[..];
        let (title_area, rest) = area.split_vertically(30);
        title_area.titled(&self.title, (FONT, TITLE))?;
        let (top, bottom) = rest.split_vertically(rest.dim_in_pixel().1 / 2);
        let n_max = rows.len().max(2) as f64;
        let band = |r: &(f64, f64, f64)| 1.96 * r.2 / r.0.sqrt();
        let (lo, hi) = shown.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
            (a.min(r.1 - band(r)), b.max(r.1 + band(r)))
        });
        let (lo, hi) = padded(lo, hi);
        let mut c1 = ChartBuilder::on(&top)
            .margin(8)
            .x_label_area_size(20)
            .y_label_area_size(88)
            .build_cartesian_2d(1.0..n_max, lo..hi)?;
        c1.configure_mesh()
            .y_desc(format!("mean{}", unit_suffix(&self.scale)))
            .y_label_formatter(&tick_format(lo, hi))
            .y_labels(5)
            .x_label_formatter(&|_| String::new())
            .label_style((FONT, SMALL))
            .axis_desc_style((FONT, TICKS))
            .draw()?;
        c1.draw_series(std::iter::once(Polygon::new(
            shown
                .iter()
                .map(|r| (r.0, r.1 + band(r)))
                .chain(shown.iter().rev().map(|r| (r.0, r.1 - band(r))))
                .collect::<Vec<_>>(),
            BLUE.mix(0.15).filled(),
        )))?;
        c1.draw_series(LineSeries::new(
            shown.iter().map(|r| (r.0, r.1)),
            BLUE.stroke_width(2),
        ))?;
        let (slo, shi) = shown
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), r| (a.min(r.2), b.max(r.2)));
        let (slo, shi) = padded(slo, shi);
        let mut c2 = ChartBuilder::on(&bottom)
            .margin(8)
            .x_label_area_size(48)
            .y_label_area_size(88)
            .build_cartesian_2d(1.0..n_max, slo..shi)?;
        c2.configure_mesh()
            .x_desc("samples")
            .y_desc(format!("σ{}", unit_suffix(&self.scale)))
            .y_label_formatter(&tick_format(slo, shi))
            .y_labels(5)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, SMALL))
            .axis_desc_style((FONT, TICKS))
            .draw()?;
        c2.draw_series(LineSeries::new(
            shown.iter().map(|r| (r.0, r.2)),
            ORANGE.stroke_width(2),
        ))?;
        Ok(())
    }
}

fn unit_suffix(s: &DisplayUnit) -> String {
    if s.label.is_empty() {
        String::new()
    } else {
        format!(" [{}]", s.label)
    }
}

/// Histogram of log10 of a positive diagnostic (max penetration, solver residual).
pub struct LogHistogramFigure<'a> {
    pub title: String,
    pub x_desc: String,
    pub values: &'a [f64],
}

impl Figure for LogHistogramFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let mut logs: Vec<f64> = self.values.iter().map(|v| v.max(1e-20).log10()).collect();
        logs.sort_by(f64::total_cmp);
        let (lo, width, counts) = crate::study::statistics::histogram(&logs);
        let (x0, x1) = padded(lo, lo + width * counts.len() as f64);
        let y1 = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.1;
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, TITLE))
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(72)
            .build_cartesian_2d(x0..x1, 0.0..y1)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_desc)
            .y_desc("samples")
            .x_label_formatter(&tick_format(x0, x1))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, SMALL))
            .axis_desc_style((FONT, AXIS))
            .draw()?;
        chart.draw_series(counts.iter().enumerate().map(|(i, &c)| {
            let a = lo + width * i as f64;
            Rectangle::new([(a, 0.0), (a + width, c as f64)], GREY.mix(0.6).filled())
        }))?;
        Ok(())
    }
}

/// A log-axis tick label shown only at the given mantissas of each decade (1, 2, 5 × 10ᵏ),
/// so that plotters' dense logarithmic ticks do not overlap.
fn decade_tick(x: f64, mantissas: &[f64]) -> String {
    let k = x.log10().floor();
    let m = x / 10f64.powf(k);
    if !mantissas.iter().any(|&t| (m - t).abs() < 1e-6 * t) {
        return String::new();
    }
    if (-3.0..=4.0).contains(&k) {
        format!("{}", (x * 1e6).round() / 1e6)
    } else {
        format!("{x:.0e}")
    }
}

/// A fidelity's point on the work–precision diagram.
#[derive(Clone, Copy, Debug)]
pub struct WorkPoint {
    /// Wall time per sample (ms).
    pub cost: f64,
    pub error: f64,
    /// Its step is error-controlled (`step_control`).
    pub adaptive: bool,
}

/// Work–precision diagram of `mc-study converge`: each output's error against the wall
/// time per sample, one point per fidelity, both axes logarithmic, with the target: a
/// circle for a fixed step, a triangle for an adaptive one.
pub struct WorkPrecisionFigure {
    pub title: String,
    pub y_desc: String,
    /// (output name, one point per fidelity) per output.
    pub series: Vec<(String, Vec<WorkPoint>)>,
    pub target: f64,
}

impl Figure for WorkPrecisionFigure {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        // a zero error (an output the rung reproduces exactly) is drawn at the floor
        let finite: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|(_, p)| p.iter().map(|w| (w.cost, w.error)))
            .filter(|(c, e)| c.is_finite() && *c > 0.0 && e.is_finite() && *e > 0.0)
            .collect();
        let (mut c0, mut c1, mut e0, mut e1) = (f64::MAX, f64::MIN, self.target, self.target);
        for &(c, e) in &finite {
            (c0, c1, e0, e1) = (c0.min(c), c1.max(c), e0.min(e), e1.max(e));
        }
        if finite.is_empty() {
            (c0, c1) = (1.0, 10.0);
        }
        let floor = e0 / 2.0;
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, TITLE))
            .margin(12)
            .x_label_area_size(52)
            .y_label_area_size(88)
            .build_cartesian_2d(
                (c0 / 1.3..c1 * 1.3).log_scale(),
                (floor / 1.5..e1 * 2.0).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("wall time per sample [ms]")
            .y_desc(&self.y_desc)
            .x_label_formatter(&|x| decade_tick(*x, &[1.0, 2.0, 5.0]))
            .y_label_formatter(&|y| decade_tick(*y, &[1.0]))
            .label_style((FONT, TICKS))
            .axis_desc_style((FONT, AXIS))
            .draw()?;
        chart
            .draw_series(LineSeries::new(
                [(c0 / 1.3, self.target), (c1 * 1.3, self.target)],
                RED.stroke_width(2),
            ))?
            .label(format!("target {:.0e}", self.target))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], RED.stroke_width(2)));
        for (i, (name, points)) in self.series.iter().enumerate() {
            let colour = Palette99::pick(i).to_rgba();
            let pts: Vec<((f64, f64), bool)> = points
                .iter()
                .filter(|w| w.cost.is_finite() && w.cost > 0.0 && w.error.is_finite())
                .map(|w| ((w.cost, w.error.max(floor)), w.adaptive))
                .collect();
            let fixed = pts.iter().filter(|p| !p.1);
            chart
                .draw_series(fixed.map(|&(p, _)| Circle::new(p, 4, colour.filled())))?
                .label(name.as_str())
                .legend(move |(x, y)| Circle::new((x + 7, y), 4, colour.filled()));
            let adaptive = pts.iter().filter(|p| p.1);
            chart
                .draw_series(adaptive.map(|&(p, _)| TriangleMarker::new(p, 6, colour.filled())))?;
        }
        if self.series.iter().flat_map(|(_, p)| p).any(|p| p.adaptive) {
            chart
                .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label("circles: fixed step; triangles: adaptive (step_control)")
                .legend(|(x, y)| TriangleMarker::new((x + 7, y), 6, BLACK.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, SMALL))
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        Ok(())
    }
}

/// A curve's population against x: the 5–95 % band, the median, the nominal run and the
/// measured points, each where it has values.
pub struct CurveFigure<'a> {
    pub title: String,
    pub x_name: &'a str,
    pub x_scale: DisplayUnit,
    pub y_name: &'a str,
    pub y_scale: DisplayUnit,
    /// Each grid point (SI) with the band's (low, median, high) there, NaN where the
    /// curves have no value.
    pub band: Vec<(f64, f64, f64, f64)>,
    /// The nominal run on the grid (SI; NaN where it has no value).
    pub nominal: Option<Vec<(f64, f64)>>,
    /// Measured points (SI).
    pub reference: &'a [(f64, f64)],
}

/// The runs of consecutive items that pass `keep` (a curve breaks where it has no value).
fn runs<T: Copy>(items: &[T], keep: impl Fn(&T) -> bool) -> Vec<Vec<T>> {
    let mut out: Vec<Vec<T>> = vec![Vec::new()];
    for it in items {
        match keep(it) {
            true => out.last_mut().expect("one run").push(*it),
            false if !out.last().expect("one run").is_empty() => out.push(Vec::new()),
            false => {}
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

impl Figure for CurveFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        area.fill(&WHITE)?;
        let (kx, ky) = (self.x_scale.per_si, self.y_scale.per_si);
        let nominal = self.nominal.as_deref().unwrap_or(&[]);
        let pieces = runs(&self.band, |b| b.2.is_finite());
        let xs = pieces
            .iter()
            .flatten()
            .map(|b| b.0)
            .chain(nominal.iter().filter(|p| p.1.is_finite()).map(|p| p.0))
            .chain(self.reference.iter().map(|p| p.0));
        let ys = self
            .band
            .iter()
            .flat_map(|b| [b.1, b.3])
            .chain(nominal.iter().map(|p| p.1))
            .chain(self.reference.iter().map(|p| p.1));
        let span = |v: &mut dyn Iterator<Item = f64>, k: f64| {
            let (lo, hi) = v
                .filter(|v| v.is_finite())
                .fold((f64::MAX, f64::MIN), |(a, b), v| {
                    (a.min(v * k), b.max(v * k))
                });
            padded(lo, hi)
        };
        let (x0, x1) = span(&mut xs.into_iter(), kx);
        let (y0, y1) = span(&mut ys.into_iter(), ky);
        let mut chart = xy_chart(
            area,
            &self.title,
            (self.x_name, &self.x_scale),
            (self.y_name, &self.y_scale),
            (x0, x1),
            (y0, y1),
        )?;
        let scaled = |x: f64, y: f64| (x * kx, y * ky);
        for (i, run) in pieces.iter().enumerate() {
            let outline: Vec<(f64, f64)> = run
                .iter()
                .map(|b| scaled(b.0, b.3))
                .chain(run.iter().rev().map(|b| scaled(b.0, b.1)))
                .collect();
            let series = chart.draw_series(std::iter::once(Polygon::new(
                outline,
                BLUE.mix(0.2).filled(),
            )))?;
            if i == 0 {
                series.label("5–95 % band").legend(|(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 16, y + 5)], BLUE.mix(0.2).filled())
                });
            }
        }
        for (i, run) in pieces.iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(
                run.iter().map(|b| scaled(b.0, b.2)),
                BLUE.stroke_width(2),
            ))?;
            if i == 0 {
                series
                    .label("median")
                    .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLUE.stroke_width(2)));
            }
        }
        for (i, run) in runs(nominal, |p| p.1.is_finite()).iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(
                run.iter().map(|p| scaled(p.0, p.1)),
                ORANGE.stroke_width(2),
            ))?;
            if i == 0 {
                series.label("nominal run").legend(|(x, y)| {
                    PathElement::new([(x, y), (x + 16, y)], ORANGE.stroke_width(2))
                });
            }
        }
        if !self.reference.is_empty() {
            chart
                .draw_series(
                    self.reference
                        .iter()
                        .map(|p| Circle::new(scaled(p.0, p.1), 3, BLACK.filled())),
                )?
                .label("measured")
                .legend(|(x, y)| Circle::new((x + 8, y), 3, BLACK.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(GREY)
            .label_font((FONT, SMALL))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_carry_enough_digits() {
        let f = tick_format(10.69, 10.71);
        assert_eq!(f(&10.695), "10.695");
        let f = tick_format(0.0, 500.0);
        assert_eq!(f(&250.0), "250");
    }
}
