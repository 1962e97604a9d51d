//! The paper's figures 2-5 as one image: hub angle with its reference, hub velocity, root
//! strain and mid-span strain against time. PNG or SVG, chosen by the file's extension.

use beam_sim::sim::SimResult;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Why a plot was not drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file's extension names no format we draw.
    #[error("plot file {} must end in .png or .svg", .0.display())]
    Extension(PathBuf),
    /// The backend failed (plotters' errors are generic over the backend: kept as text).
    #[error("drawing: {0}")]
    Draw(String),
}

/// `Ok` when `path` ends in `.png` or `.svg` (checked before any work is done).
pub fn check_extension(path: &Path) -> Result<(), PlotError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png" | "svg") => Ok(()),
        _ => Err(PlotError::Extension(path.to_path_buf())),
    }
}

/// Draws with `$draw(&root)` on a PNG or SVG backend chosen by `$path`'s extension.
macro_rules! render {
    ($path:expr, $size:expr, $draw:ident ( $($arg:expr),* )) => {{
        check_extension($path)?;
        let is_png = $path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if is_png {
            let root = BitMapBackend::new($path, $size).into_drawing_area();
            $draw($($arg,)* &root)?;
            root.present().map_err(|e| PlotError::Draw(e.to_string()))
        } else {
            let root = SVGBackend::new($path, $size).into_drawing_area();
            $draw($($arg,)* &root)?;
            root.present().map_err(|e| PlotError::Draw(e.to_string()))
        }
    }};
}

/// Draws `run` into `path` (`.png` or `.svg`), titled `title`: the paper's figures 2-5
/// (hub angle with its reference, hub velocity, root and mid-span strain) and the torque.
pub fn plot(run: &SimResult, title: &str, path: &Path) -> Result<(), PlotError> {
    render!(path, (1200, 1300), draw(run, title))
}

/// A drive's recorded telemetry (`beam drive --record`): hub angle with its reference,
/// torque and root strain against time, into `path` (`.png` or `.svg`).
pub fn plot_records(
    records: &[beam_wire::command::Record],
    ts_s: f64,
    title: &str,
    path: &Path,
) -> Result<(), PlotError> {
    render!(path, (1200, 900), draw_records(records, ts_s, title))
}

fn draw_records<DB: DrawingBackend>(
    records: &[beam_wire::command::Record],
    ts_s: f64,
    title: &str,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let first = records.first().map_or(0, |r| r.tick);
    let col = |f: fn(&beam_wire::command::Record) -> f64| {
        records
            .iter()
            .map(|r| (r.tick.wrapping_sub(first) as f64 * ts_s, f(r)))
            .collect::<Vec<_>>()
    };
    let figures: Vec<Figure> = vec![
        (
            "Hub angle",
            "deg",
            vec![
                (
                    "reference",
                    col(|r| (r.theta_ref_rad as f64).to_degrees()),
                    RED,
                ),
                ("hub", col(|r| (r.theta_rad as f64).to_degrees()), BLUE),
            ],
        ),
        (
            "Torque",
            "N m",
            vec![("torque", col(|r| r.torque_nm as f64), BLUE)],
        ),
        (
            "Root strain",
            "microstrain",
            vec![("root", col(|r| r.strain as f64 * 1e6), BLUE)],
        ),
    ];
    draw_figures(title, figures, (3, 1), root)
}

/// One panel of [`plot_panels`]: its name, its unit and its curves (label, points).
pub type Panel<'a> = (&'a str, &'a str, Vec<(&'a str, Vec<(f64, f64)>)>);

/// Panels of labelled curves against time (`beam replay`'s measured-against-model
/// figures): each panel a name, a unit and its curves (label, points), stacked in one
/// column, the first curve of a panel in blue, the second in red.
pub fn plot_panels(title: &str, panels: Vec<Panel>, path: &Path) -> Result<(), PlotError> {
    let rows = panels.len().max(1);
    let figures: Vec<Figure> = panels
        .into_iter()
        .map(|(name, unit, curves)| {
            let series = curves
                .into_iter()
                .enumerate()
                .map(|(i, (label, pts))| (label, pts, [BLUE, RED, GREEN][i % 3]))
                .collect();
            (name, unit, series)
        })
        .collect();
    render!(
        path,
        (1200, 300 * rows as u32),
        draw_figures(title, figures, (rows, 1))
    )
}

type Series<'a> = (&'a str, Vec<(f64, f64)>, RGBColor);
/// A panel: its name, its unit and its series.
type Figure<'a> = (&'a str, &'a str, Vec<Series<'a>>);

fn draw<DB: DrawingBackend>(
    run: &SimResult,
    title: &str,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let s = &run.samples;
    let col =
        |f: fn(&beam_sim::sim::Sample) -> f64| s.iter().map(|x| (x.t, f(x))).collect::<Vec<_>>();
    let figures: [Figure; 5] = [
        (
            "Hub angle",
            "deg",
            vec![
                ("reference", col(|x| x.theta_ref.to_degrees()), RED),
                ("hub", col(|x| x.theta.to_degrees()), BLUE),
            ],
        ),
        (
            "Hub velocity",
            "deg/s",
            vec![("hub", col(|x| x.omega.to_degrees()), BLUE)],
        ),
        (
            "Root strain",
            "microstrain",
            vec![("root", col(|x| x.root_strain * 1e6), BLUE)],
        ),
        (
            "Mid-span strain",
            "microstrain",
            vec![("mid", col(|x| x.mid_strain * 1e6), BLUE)],
        ),
        ("Torque", "N m", vec![("torque", col(|x| x.torque), BLUE)]),
    ];
    draw_figures(title, figures.into(), (3, 2), root)
}

/// The panels of `figures` on a `grid` (rows, columns), under `title`.
fn draw_figures<DB: DrawingBackend>(
    title: &str,
    figures: Vec<Figure>,
    grid: (usize, usize),
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(title, ("sans-serif", 24))
        .map_err(|e| err(&e))?;
    let panels = root.split_evenly(grid);
    let t_end = figures
        .iter()
        .flat_map(|(_, _, series)| series.iter().flat_map(|(_, v, _)| v.last().map(|p| p.0)))
        .fold(1e-3, f64::max);
    for (area, (name, unit, series)) in panels.iter().zip(figures) {
        let (lo, hi) = series
            .iter()
            .flat_map(|(_, v, _)| v.iter().map(|p| p.1))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
                (a.min(y), b.max(y))
            });
        let (lo, hi) = if lo.is_finite() && hi > lo {
            (lo, hi)
        } else {
            (lo.min(0.0) - 1.0, hi.max(0.0) + 1.0)
        };
        let pad = 0.05 * (hi - lo);
        let mut chart = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("time, s")
            .y_desc(unit)
            .draw()
            .map_err(|e| err(&e))?;
        for (label, data, color) in series {
            chart
                .draw_series(LineSeries::new(data, color.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    Ok(())
}

/// One histogram panel: a title, the x unit, and the two samples to compare.
pub struct HistogramPanel<'a> {
    /// Panel title.
    pub title: &'a str,
    /// Unit of the values.
    pub unit: &'a str,
    /// The designed controller's values.
    pub controller: Vec<f64>,
    /// The baseline's values.
    pub baseline: Vec<f64>,
}

/// Overlaid histograms (designed controller against the baseline), one panel per metric,
/// side by side, into `path` (`.png` or `.svg`).
pub fn histograms(
    title: &str,
    labels: (&str, &str),
    panels: &[HistogramPanel],
    path: &Path,
) -> Result<(), PlotError> {
    let size = (600 * panels.len().max(1) as u32, 500);
    render!(path, size, draw_histograms(title, labels, panels))
}

fn draw_histograms<DB: DrawingBackend>(
    title: &str,
    labels: (&str, &str),
    panels: &[HistogramPanel],
    root: &DrawingArea<DB, Shift>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(title, ("sans-serif", 22))
        .map_err(|e| err(&e))?;
    const BINS: usize = 30;
    for (area, panel) in root
        .split_evenly((1, panels.len().max(1)))
        .iter()
        .zip(panels)
    {
        let all = panel
            .controller
            .iter()
            .chain(&panel.baseline)
            .copied()
            .filter(|v| v.is_finite());
        let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        let (lo, hi) = if lo.is_finite() && hi > lo {
            (lo, hi)
        } else {
            (0.0, 1.0)
        };
        let width = (hi - lo) / BINS as f64;
        let count = |v: &[f64]| {
            let mut c = [0usize; BINS];
            for x in v.iter().filter(|x| x.is_finite()) {
                c[(((x - lo) / width) as usize).min(BINS - 1)] += 1;
            }
            c
        };
        let (a, b) = (count(&panel.controller), count(&panel.baseline));
        let top = a.iter().chain(&b).copied().max().unwrap_or(1).max(1);
        let mut chart = ChartBuilder::on(area)
            .caption(panel.title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(lo..hi, 0usize..top + top / 10 + 1)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(panel.unit)
            .y_desc("cases")
            .draw()
            .map_err(|e| err(&e))?;
        for (counts, color, label) in [(a, BLUE, labels.0), (b, RED, labels.1)] {
            chart
                .draw_series(counts.iter().enumerate().map(|(i, &n)| {
                    let x0 = lo + i as f64 * width;
                    Rectangle::new([(x0, 0), (x0 + width, n)], color.mix(0.45).filled())
                }))
                .map_err(|e| err(&e))?
                .label(label)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.mix(0.45).filled())
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    Ok(())
}
