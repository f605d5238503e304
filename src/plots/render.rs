//! Drawing of charts onto any plotters backend (bitmap or SVG).

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{plot_err, Chart, Layout, RefLine, Scatter, Series, Style, FONT};
use crate::error::{Error, Result};

/// Okabe–Ito colour-blind-safe palette (yellow replaced by grey, which
/// reads better on white).
const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
    RGBColor(120, 120, 120), // grey
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

const LINE_WIDTH: u32 = 2;

/// Font sizes and margins scaled to the drawing area (1.0 at 1000×650).
struct Metrics {
    title: f64,
    desc: f64,
    tick: f64,
    legend: f64,
    point_label: f64,
    margin: u32,
    x_area: u32,
    y_area: u32,
}

fn metrics<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> Metrics {
    let (w, h) = area.dim_in_pixel();
    let s = (w as f64 / 1000.0).min(h as f64 / 650.0).clamp(0.5, 3.0);
    Metrics {
        title: 30.0 * s,
        desc: 22.0 * s,
        tick: 18.0 * s,
        legend: 19.0 * s,
        point_label: 17.0 * s,
        margin: (18.0 * s) as u32,
        x_area: (60.0 * s) as u32,
        y_area: (95.0 * s) as u32,
    }
}

/// Check lengths and indices before anything is drawn.
pub(super) fn validate_chart(c: &Chart) -> Result<()> {
    for (i, s) in c.series.iter().enumerate() {
        let name = || format!("chart '{}', series {} ('{}')", c.title, i, s.label);
        if s.x.len() != s.y.len() {
            return Err(Error::msg(format!(
                "{}: x has {} values but y has {}",
                name(),
                s.x.len(),
                s.y.len()
            )));
        }
        if let Some((lo, hi)) = &s.band {
            if lo.len() != s.x.len() || hi.len() != s.x.len() {
                return Err(Error::msg(format!(
                    "{}: the band has {} lower and {} upper values for {} x values",
                    name(),
                    lo.len(),
                    hi.len(),
                    s.x.len()
                )));
            }
        }
    }
    if let Some((a, b)) = c.fill_between {
        let n = c.series.len();
        if a >= n || b >= n {
            return Err(Error::msg(format!(
                "chart '{}': fill_between ({a}, {b}) names a series that does not exist ({n} series)",
                c.title
            )));
        }
    }
    Ok(())
}

/// Maximal runs of consecutive points whose coordinates are all finite.
fn finite_runs(x: &[f64], ys: &[&[f64]]) -> Vec<Vec<usize>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for i in 0..x.len() {
        if x[i].is_finite() && ys.iter().all(|y| y[i].is_finite()) {
            cur.push(i);
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Axis limits covering `v` (finite values; positive ones on a log axis),
/// widened by `pad` of the span (of the decades on a log axis) each side.
fn axis_range(v: &[f64], log: bool, pad: f64) -> (f64, f64) {
    let usable = v
        .iter()
        .copied()
        .filter(|x| x.is_finite() && (!log || *x > 0.0));
    let (lo, hi) = usable.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    if lo > hi {
        return if log { (1.0, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (mut l, mut h) = (lo.log10(), hi.log10());
        if h - l < 1e-9 {
            l -= 0.5;
            h += 0.5;
        }
        let p = (h - l) * pad;
        (10f64.powf(l - p), 10f64.powf(h + p))
    } else {
        let span = hi - lo;
        if span <= 1e-12 * lo.abs().max(hi.abs()) {
            let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
            (lo - d, hi + d)
        } else if !span.is_finite() {
            (lo, hi)
        } else {
            (lo - pad * span, hi + pad * span)
        }
    }
}

/// Tick labels for linear axes: the value with at most six decimals and
/// no trailing zeros (`200`, not `200.0`; `0.25`), negative values with
/// their sign, never `-0`.
pub(super) fn linear_tick(v: &f64) -> String {
    let v = *v;
    if !v.is_finite() {
        return format!("{v}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// How many tick labels to ask plotters for on a linear axis over
/// `lo..hi`: about eight, and more where the axis crosses zero with a
/// tenth or more of its span on the short side, so that side gets a
/// labelled tick too (a shear axis from -130 to 1100 N labelled 0, 200,
/// ... left its negative values unlabelled).
pub(super) fn label_count(lo: f64, hi: f64) -> usize {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return 8;
    }
    let short = if lo < 0.0 && hi > 0.0 {
        (-lo).min(hi)
    } else {
        span
    };
    // The 1-2-5 step plotters would take for 8 labels, made no larger than
    // the short side when that side is a tenth of the span or more.
    let nice = |x: f64| {
        let p = 10f64.powf(x.log10().floor());
        [5.0, 2.0, 1.0]
            .into_iter()
            .map(|m| m * p)
            .find(|s| *s <= x)
            .unwrap_or(p)
    };
    let mut step = nice(span / 7.0);
    if short < step && short >= 0.1 * span {
        step = nice(short);
    }
    ((span / step).floor() as usize + 1).clamp(2, 16)
}

/// Tick labels for logarithmic axes: at most 4 significant digits,
/// scientific notation outside 1e-3..1e5.
pub(super) fn log_tick(v: &f64) -> String {
    let v = *v;
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        // 1.000e-5 -> 1e-5
        match s.split_once('e') {
            Some((m, e)) => {
                let m = m.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{e}")
            }
            None => s,
        }
    } else {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

fn line_style(style: Style) -> ShapeStyle {
    color(style.color).stroke_width(LINE_WIDTH)
}

/// Pixels already used by the drawing (lines sampled every few pixels,
/// boxes as grids), to place the legend where it hides least.
#[derive(Default)]
struct Occupancy {
    pts: Vec<(i32, i32)>,
}

impl Occupancy {
    fn polyline(&mut self, p: &[(i32, i32)]) {
        for w in p.windows(2) {
            let (a, b) = (w[0], w[1]);
            let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) / 4).clamp(1, 2000);
            for k in 0..n {
                let t = k as f64 / n as f64;
                self.pts.push((
                    a.0 + ((b.0 - a.0) as f64 * t) as i32,
                    a.1 + ((b.1 - a.1) as f64 * t) as i32,
                ));
            }
        }
        self.pts.extend(p.last());
    }
    fn rect(&mut self, (x0, y0): (i32, i32), (x1, y1): (i32, i32)) {
        for x in (x0.min(x1)..=x0.max(x1)).step_by(4) {
            for y in (y0.min(y1)..=y0.max(y1)).step_by(4) {
                self.pts.push((x, y));
            }
        }
    }
}

/// Inner padding of the legend box.
fn legend_pad(m: &Metrics) -> u32 {
    m.margin / 2
}

const LEGEND_ICON: u32 = 34;

/// The corner of the plotting area (position relative to it) where a legend
/// with these labels covers the fewest occupied pixels; upper right on ties.
fn legend_position<DB: DrawingBackend, CT: CoordTranslate>(
    plot: &DrawingArea<DB, CT>,
    occ: &Occupancy,
    labels: &[&str],
    m: &Metrics,
) -> SeriesLabelPosition {
    let font = TextStyle::from((FONT, m.legend).into_font());
    let text_w = labels
        .iter()
        .map(|l| plot.estimate_text_size(l, &font).map_or(0, |s| s.0 as i32))
        .max()
        .unwrap_or(0);
    let pad = legend_pad(m) as i32;
    let w = text_w + LEGEND_ICON as i32 + 2 * pad;
    let h = (labels.len() as f64 * 1.25 * m.legend) as i32 + 2 * pad;
    let (xr, yr) = plot.get_pixel_range();
    let (pw, ph) = (xr.end - xr.start, yr.end - yr.start);
    let gap = 8;
    let candidates = [
        (pw - w - gap, gap),
        (gap, gap),
        (gap, ph - h - gap),
        (pw - w - gap, ph - h - gap),
        ((pw - w) / 2, gap),
    ];
    let covered = |&(x, y): &(i32, i32)| {
        occ.pts
            .iter()
            .filter(|&&(px, py)| {
                let (px, py) = (px - xr.start, py - yr.start);
                px >= x - 3 && px <= x + w + 3 && py >= y - 3 && py <= y + h + 3
            })
            .count()
    };
    let mut best = candidates[0];
    let mut best_n = covered(&best);
    for c in &candidates[1..] {
        let n = covered(c);
        if n < best_n {
            best = *c;
            best_n = n;
        }
    }
    SeriesLabelPosition::Coordinate(best.0.max(0), best.1.max(0))
}

fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    ch: &mut ChartContext<'a, DB, CT>,
    pos: SeriesLabelPosition,
    m: &Metrics,
) -> Result<()> {
    ch.configure_series_labels()
        .position(pos)
        .margin(legend_pad(m))
        .legend_area_size(LEGEND_ICON)
        .label_font((FONT, m.legend))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.5))
        .draw()
        .map_err(plot_err)
}

/// A legend entry of a line chart: its label and how its icon is drawn.
enum Entry<'a> {
    /// The shaded area between two series.
    Fill(&'a str),
    /// A series: its style and whether it has a band.
    Line(&'a str, Style, bool),
}

impl Entry<'_> {
    fn label(&self) -> &str {
        match self {
            Entry::Fill(l) | Entry::Line(l, _, _) => l,
        }
    }
}

/// Draw one line chart filling `area`: the plot, and its legend in a column
/// right of it, outside the data.
pub(super) fn chart<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, c: &Chart) -> Result<()> {
    chart_in(area, c, None, None)
}

/// The legend column's width of chart `c` drawn in `area` (0 without a
/// legend).
fn legend_width<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, c: &Chart) -> u32 {
    let m = metrics(area);
    let font = TextStyle::from((FONT, m.legend).into_font());
    let pad = legend_pad(&m);
    let (w, _) = area.dim_in_pixel();
    let labels: Vec<&str> = std::iter::once(c.fill_label.as_str())
        .filter(|l| c.fill_between.is_some() && !l.is_empty())
        .chain(
            c.series
                .iter()
                .map(|s| s.label.as_str())
                .filter(|l| !l.is_empty()),
        )
        .collect();
    if labels.is_empty() {
        return 0;
    }
    let text_w = labels
        .iter()
        .map(|l| area.estimate_text_size(l, &font).map_or(0, |s| s.0))
        .max()
        .unwrap_or(0);
    (text_w + LEGEND_ICON + 3 * pad + m.margin).min(w * 9 / 20)
}

/// The x range of a chart's data (None without finite points).
fn x_extent(c: &Chart) -> Option<(f64, f64)> {
    let xs = c
        .series
        .iter()
        .flat_map(|s| s.x.iter())
        .filter(|x| x.is_finite());
    xs.fold(None, |r, &x| match r {
        None => Some((x, x)),
        Some((a, b)) => Some((f64::min(a, x), f64::max(b, x))),
    })
}

/// [`chart`] with the legend column `legend` pixels wide and the x axis
/// spanning `x_span` (panels of one figure share both, so that their plots
/// have one width and their time axes line up), else its own.
fn chart_in<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    c: &Chart,
    legend: Option<u32>,
    x_span: Option<(f64, f64)>,
) -> Result<()> {
    area.fill(&WHITE).map_err(plot_err)?;
    let m = metrics(area);

    let mut entries: Vec<Entry> = Vec::new();
    if c.fill_between.is_some() && !c.fill_label.is_empty() {
        entries.push(Entry::Fill(&c.fill_label));
    }
    for s in &c.series {
        if !s.label.is_empty() {
            entries.push(Entry::Line(&s.label, s.style, s.band.is_some()));
        }
    }
    let (w, _) = area.dim_in_pixel();
    let legend_w = legend.unwrap_or_else(|| legend_width(area, c));
    // The title spans the whole figure (the legend column included),
    // shrunk to fit its width.
    let body = if c.title.is_empty() {
        area.clone()
    } else {
        let mut size = m.title;
        let fits = |size: f64| {
            let font = TextStyle::from((FONT, size).into_font());
            area.estimate_text_size(&c.title, &font)
                .map_or(true, |(tw, _)| tw + 2 * m.margin <= w)
        };
        while size > 10.0 && !fits(size) {
            size *= 0.9;
        }
        let title_h = (1.6 * size) as u32 + m.margin / 2;
        let (title_area, rest) = area.split_vertically(title_h);
        let font =
            TextStyle::from((FONT, size).into_font()).pos(Pos::new(HPos::Center, VPos::Center));
        let (tw, th) = title_area.dim_in_pixel();
        title_area
            .draw(&Text::new(
                c.title.clone(),
                ((tw / 2) as i32, (th as i32 + m.margin as i32 / 2) / 2),
                font,
            ))
            .map_err(plot_err)?;
        rest
    };
    let (plot_area, legend_area) = body.split_horizontally(w - legend_w);

    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for s in &c.series {
        for i in 0..s.x.len() {
            let mut vals = vec![s.y[i]];
            if let Some((lo, hi)) = &s.band {
                vals.extend([lo[i], hi[i]]);
            }
            let finite: Vec<f64> = vals.into_iter().filter(|v| v.is_finite()).collect();
            if s.x[i].is_finite() && !finite.is_empty() {
                xs.push(s.x[i]);
                ys.extend(finite);
            }
        }
    }
    if let Some((a, b)) = x_span {
        xs.extend([a, b]);
    }
    let (x0, x1) = axis_range(&xs, false, 0.0);
    let (y0, y1) = axis_range(&ys, false, 0.05);

    let mut builder = ChartBuilder::on(&plot_area);
    builder
        .margin(m.margin)
        .x_label_area_size(m.x_area)
        .y_label_area_size(m.y_area);
    let mut ch = builder
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_err)?;
    ch.configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .x_label_formatter(&linear_tick)
        .y_label_formatter(&linear_tick)
        .y_labels(label_count(y0, y1))
        .label_style((FONT, m.tick))
        .axis_desc_style((FONT, m.desc))
        .bold_line_style(BLACK.mix(0.12))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(plot_err)?;

    let mut occ = Occupancy::default();

    // Shaded area between two series: forward along one, back along the other.
    if let Some((a, b)) = c.fill_between {
        let (sa, sb) = (&c.series[a], &c.series[b]);
        let fwd =
            sa.x.iter()
                .zip(&sa.y)
                .filter(|(x, y)| x.is_finite() && y.is_finite());
        let back =
            sb.x.iter()
                .zip(&sb.y)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .rev();
        let poly: Vec<(f64, f64)> = fwd.chain(back).map(|(x, y)| (*x, *y)).collect();
        let fill = BLACK.mix(0.16).filled();
        ch.draw_series(std::iter::once(Polygon::new(poly, fill)))
            .map_err(plot_err)?;
    }

    // Bands behind all lines.
    for s in &c.series {
        if let Some((lo, hi)) = &s.band {
            let fill = color(s.style.color).mix(0.22).filled();
            for run in finite_runs(&s.x, &[lo, hi]) {
                let poly: Vec<(f64, f64)> = run
                    .iter()
                    .map(|&i| (s.x[i], lo[i]))
                    .chain(run.iter().rev().map(|&i| (s.x[i], hi[i])))
                    .collect();
                ch.draw_series(std::iter::once(Polygon::new(poly, fill)))
                    .map_err(plot_err)?;
            }
        }
    }

    for s in &c.series {
        draw_line(&mut ch, s, &mut occ)?;
    }

    if !entries.is_empty() {
        // The legend's rows start level with the plot's top edge.
        let top = ch.plotting_area().get_pixel_range().1.start - legend_area.get_base_pixel().1;
        draw_side_legend(&legend_area, &entries, top, &m)?;
    }
    Ok(())
}

/// The legend of a line chart in its own column: one row per entry, an
/// icon (line, dashes, band swatch or shaded box) and the label.
fn draw_side_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[Entry],
    top: i32,
    m: &Metrics,
) -> Result<()> {
    let font =
        TextStyle::from((FONT, m.legend).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    let pad = legend_pad(m) as i32;
    let row_h = (1.5 * m.legend) as i32;
    let icon = LEGEND_ICON as i32;
    let half = (0.35 * m.legend) as i32;
    for (k, e) in entries.iter().enumerate() {
        let y = top + pad + row_h / 2 + k as i32 * row_h;
        let x = pad;
        match e {
            Entry::Fill(_) => {
                area.draw(&Rectangle::new(
                    [(x, y - half), (x + icon - pad, y + half)],
                    BLACK.mix(0.16).filled(),
                ))
                .map_err(plot_err)?;
            }
            Entry::Line(_, style, band) => {
                let w = icon - pad;
                if *band {
                    area.draw(&Rectangle::new(
                        [(x, y - half), (x + w, y + half)],
                        color(style.color).mix(0.22).filled(),
                    ))
                    .map_err(plot_err)?;
                }
                let (a, b) = if style.dashed {
                    (w * 9 / 26, w * 16 / 26)
                } else {
                    (w / 2, w / 2)
                };
                area.draw(&PathElement::new(
                    vec![(x, y), (x + a, y)],
                    line_style(*style),
                ))
                .map_err(plot_err)?;
                area.draw(&PathElement::new(
                    vec![(x + b, y), (x + w, y)],
                    line_style(*style),
                ))
                .map_err(plot_err)?;
            }
        }
        area.draw(&Text::new(
            e.label().to_string(),
            (x + icon + pad, y),
            font.clone(),
        ))
        .map_err(plot_err)?;
    }
    Ok(())
}

fn draw_line<DB: DrawingBackend>(
    ch: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    s: &Series,
    occ: &mut Occupancy,
) -> Result<()> {
    for run in finite_runs(&s.x, &[&s.y]) {
        let pts: Vec<(f64, f64)> = run.iter().map(|&i| (s.x[i], s.y[i])).collect();
        occ.polyline(&pts.iter().map(|p| ch.backend_coord(p)).collect::<Vec<_>>());
        if pts.len() == 1 {
            // A lone point between gaps would be invisible as a line.
            ch.draw_series(std::iter::once(Circle::new(
                pts[0],
                LINE_WIDTH + 1,
                color(s.style.color).filled(),
            )))
            .map_err(plot_err)?;
        } else if s.style.dashed {
            ch.draw_series(DashedLineSeries::new(pts, 10, 7, line_style(s.style)))
                .map_err(plot_err)?;
        } else {
            ch.draw_series(LineSeries::new(pts, line_style(s.style)))
                .map_err(plot_err)?;
        }
    }
    Ok(())
}

/// Charts in a grid of panels, row by row.
pub(super) fn panels<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    charts: &[Chart],
    layout: Layout,
) -> Result<()> {
    area.fill(&WHITE).map_err(plot_err)?;
    let cells = area.split_evenly((layout.rows, layout.cols));
    let (legends, spans) = shared_axes(&cells, charts, layout);
    for (k, (c, cell)) in charts.iter().zip(cells.iter()).enumerate() {
        chart_in(cell, c, Some(legends[k]), spans[k])?;
    }
    Ok(())
}

/// Each panel's legend width and x span: the panels of one column share the
/// widest legend (so their plots have one width and one left and right
/// edge) and the x range of all their data (stacked panels share their x
/// axis, as their time axes then line up).
pub(super) fn shared_axes<DB: DrawingBackend>(
    cells: &[DrawingArea<DB, Shift>],
    charts: &[Chart],
    layout: Layout,
) -> (Vec<u32>, Vec<Option<(f64, f64)>>) {
    let n = charts.len().min(cells.len());
    let own: Vec<u32> = (0..n)
        .map(|k| legend_width(&cells[k], &charts[k]))
        .collect();
    let cols = layout.cols.max(1);
    let legends = (0..n)
        .map(|k| {
            (0..n)
                .filter(|j| j % cols == k % cols)
                .map(|j| own[j])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let spans = (0..n)
        .map(|k| {
            (0..n)
                .filter(|j| j % cols == k % cols)
                .filter_map(|j| x_extent(&charts[j]))
                .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
        })
        .collect();
    (legends, spans)
}

/// Draw a scatter chart filling `area`.
pub(super) fn scatter<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s: &Scatter,
) -> Result<()> {
    area.fill(&WHITE).map_err(plot_err)?;
    let usable = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    let drawable: Vec<usize> = (0..s.points.len())
        .filter(|&i| usable(s.points[i].x, s.log_x) && usable(s.points[i].y, s.log_y))
        .collect();
    let mut xs: Vec<f64> = drawable.iter().map(|&i| s.points[i].x).collect();
    let mut ys: Vec<f64> = drawable.iter().map(|&i| s.points[i].y).collect();
    for r in &s.reference {
        match r {
            RefLine::Horizontal { value, .. } => ys.push(*value),
            RefLine::Vertical { value, .. } => xs.push(*value),
        }
    }
    // Logarithmic axes are drawn as linear axes over log10 of the values,
    // with our own ticks (plotters' LogCoord leaves the part below the
    // first full decade unlabelled).
    let (x0, x1) = axis_range(&xs, s.log_x, 0.08);
    let (y0, y1) = axis_range(&ys, s.log_y, 0.08);
    let (tx0, tx1) = if s.log_x {
        (x0.log10(), x1.log10())
    } else {
        (x0, x1)
    };
    let (ty0, ty1) = if s.log_y {
        (y0.log10(), y1.log10())
    } else {
        (y0, y1)
    };
    let xa = Axis::new(x0, x1, s.log_x);
    let ya = Axis::new(y0, y1, s.log_y);
    if s.key.is_empty() {
        return scatter_body(area, s, &drawable, (tx0, tx1, ty0, ty1), xa, ya);
    }
    // A key column right of the plot, as wide as its longest line.
    let m = metrics(area);
    let font = TextStyle::from((FONT, m.point_label).into_font());
    let key_w = s
        .key
        .iter()
        .map(|l| area.estimate_text_size(l, &font).map_or(0, |(w, _)| w))
        .max()
        .unwrap_or(0)
        + 2 * m.margin;
    let (w, _) = area.dim_in_pixel();
    let key_w = key_w.min(w / 2);
    let (plot, key) = area.split_horizontally(w - key_w);
    scatter_body(&plot, s, &drawable, (tx0, tx1, ty0, ty1), xa, ya)?;
    let line_h = (1.3 * m.point_label) as i32;
    let top = (m.title * 2.0) as i32;
    for (k, line) in s.key.iter().enumerate() {
        key.draw(&Text::new(
            line.clone(),
            (m.margin as i32 / 2, top + k as i32 * line_h),
            font.clone(),
        ))
        .map_err(plot_err)?;
    }
    Ok(())
}

/// A chart axis over f64: linear (plotters' own ticks and labels) or
/// logarithmic, drawn linearly over log10 of the values with ticks from
/// [`log_ticks`] labelled with the values themselves.
struct Axis {
    inner: RangedCoordf64,
    log_ticks: Option<Vec<f64>>,
}

impl Axis {
    /// Axis over `lo..hi` in data units (both > 0 if `log`).
    fn new(lo: f64, hi: f64, log: bool) -> Self {
        if log {
            Axis {
                inner: (lo.log10()..hi.log10()).into(),
                log_ticks: Some(log_ticks(lo, hi)),
            }
        } else {
            Axis {
                inner: (lo..hi).into(),
                log_ticks: None,
            }
        }
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;
    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }
    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        match &self.log_ticks {
            None => self.inner.key_points(hint),
            Some(_) if hint.weight().allow_light_points() => Vec::new(),
            Some(t) => t.clone(),
        }
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

impl ValueFormatter<f64> for Axis {
    fn format_ext(&self, value: &f64) -> String {
        match self.log_ticks {
            None => linear_tick(value),
            Some(_) => log_tick(&10f64.powf(*value)),
        }
    }
}

/// Tick positions (log10 of the values) of a logarithmic axis over
/// `lo..hi`: 1, 2, 5 × 10^k; only 10^k over more than three decades (every
/// other decade over more than eight); 1..9 × 10^k within one decade; five
/// evenly spaced ticks if that still gives fewer than two.
pub(super) fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let (l, h) = (lo.log10(), hi.log10());
    let decades = h - l;
    let (mantissas, step): (&[f64], i32) = if decades > 8.0 {
        (&[1.0], 2)
    } else if decades > 3.0 {
        (&[1.0], 1)
    } else if decades >= 1.0 {
        (&[1.0, 2.0, 5.0], 1)
    } else {
        (&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 1)
    };
    let mut ticks = Vec::new();
    let mut k = l.floor() as i32;
    while k as f64 <= h.ceil() {
        for m in mantissas {
            let t = m.log10() + k as f64;
            if t >= l - 1e-9 && t <= h + 1e-9 {
                ticks.push(t);
            }
        }
        k += step;
    }
    if ticks.len() < 2 && decades.is_finite() {
        ticks = (0..5).map(|i| l + decades * i as f64 / 4.0).collect();
    }
    ticks
}

/// `(x0, x1, y0, y1)`: the axis limits in chart coordinates (log10 of the
/// values on logarithmic axes).
fn scatter_body<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s: &Scatter,
    drawable: &[usize],
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    x_spec: Axis,
    y_spec: Axis,
) -> Result<()> {
    let m = metrics(area);
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(m.margin)
        .x_label_area_size(m.x_area)
        .y_label_area_size(m.y_area);
    if !s.title.is_empty() {
        builder.caption(&s.title, (FONT, m.title));
    }
    let mut ch = builder
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(plot_err)?;
    // Data to chart coordinates (log10 on logarithmic axes).
    let tx = |v: f64| if s.log_x { v.log10() } else { v };
    let ty = |v: f64| if s.log_y { v.log10() } else { v };
    ch.configure_mesh()
        .x_desc(&s.x_label)
        .y_desc(&s.y_label)
        .label_style((FONT, m.tick))
        .axis_desc_style((FONT, m.desc))
        .bold_line_style(BLACK.mix(0.12))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(plot_err)?;

    let plot_px = ch.plotting_area().get_pixel_range();
    let text_size = |text: &str, font: &TextStyle| {
        area.estimate_text_size(text, font)
            .map_or((0, 0), |(w, h)| (w as i32, h as i32))
    };
    let mut occ = Occupancy::default();

    // Reference lines; a vertical one labelled at its top, a horizontal one
    // at its right end.
    let ref_color = RGBColor(90, 90, 90);
    let ref_font = TextStyle::from((FONT, m.point_label).into_font()).color(&ref_color);
    for r in &s.reference {
        let (pts, label, at, right) = match r {
            RefLine::Horizontal { value, label } => {
                let v = ty(*value);
                (vec![(x0, v), (x1, v)], label, (x1, v), false)
            }
            RefLine::Vertical { value, label } => {
                let v = tx(*value);
                (vec![(v, y1), (v, y0)], label, (v, y1), true)
            }
        };
        if !(pts[0].0.is_finite() && pts[0].1.is_finite()) {
            continue;
        }
        let px: Vec<(i32, i32)> = pts.iter().map(|p| ch.backend_coord(p)).collect();
        occ.polyline(&px);
        ch.draw_series(DashedLineSeries::new(
            pts,
            8,
            6,
            ref_color.stroke_width(LINE_WIDTH),
        ))
        .map_err(plot_err)?;
        if !label.is_empty() {
            let at_px = ch.backend_coord(&at);
            let above = matches!(r, RefLine::Horizontal { .. });
            let size = text_size(label, &ref_font);
            let (pos, offset, bx) = place_label(at_px, size, &plot_px, right, above, (6, 4));
            occ.rect(bx.0, bx.1);
            ch.draw_series(std::iter::once(
                EmptyElement::at(at) + Text::new(label.clone(), offset, ref_font.pos(pos)),
            ))
            .map_err(plot_err)?;
        }
    }

    // Pareto front among the drawable points.
    let mut on_front = vec![false; s.points.len()];
    if s.pareto {
        let sub: Vec<(f64, f64)> = drawable
            .iter()
            .map(|&i| (s.points[i].x, s.points[i].y))
            .collect();
        let front: Vec<usize> = super::pareto_front(&sub)
            .into_iter()
            .map(|k| drawable[k])
            .collect();
        for &i in &front {
            on_front[i] = true;
        }
        let pts: Vec<(f64, f64)> = front
            .iter()
            .map(|&i| (tx(s.points[i].x), ty(s.points[i].y)))
            .collect();
        occ.polyline(&pts.iter().map(|p| ch.backend_coord(p)).collect::<Vec<_>>());
        let front_style = BLACK.mix(0.55).stroke_width(LINE_WIDTH);
        ch.draw_series(LineSeries::new(pts, front_style))
            .map_err(plot_err)?
            .label("Pareto front")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 26, y)], front_style));
    }

    // Markers (filled on the front, hollow otherwise) with their labels,
    // right of and above the point unless that leaves the plot.
    let label_font = TextStyle::from((FONT, m.point_label).into_font());
    for &i in drawable {
        let p = &s.points[i];
        let c = color(p.color);
        let marker = if on_front[i] {
            c.filled()
        } else {
            c.stroke_width(LINE_WIDTH)
        };
        let at = (tx(p.x), ty(p.y));
        let at_px = ch.backend_coord(&at);
        occ.rect((at_px.0 - 6, at_px.1 - 6), (at_px.0 + 6, at_px.1 + 6));
        let size = text_size(&p.label, &label_font);
        let (pos, offset, bx) = place_label(at_px, size, &plot_px, true, true, (9, 4));
        if !p.label.is_empty() {
            occ.rect(bx.0, bx.1);
        }
        ch.draw_series(std::iter::once(
            EmptyElement::at(at)
                + Circle::new((0, 0), 6, marker)
                + Text::new(p.label.clone(), offset, label_font.pos(pos)),
        ))
        .map_err(plot_err)?;
    }

    if s.pareto {
        let pos = legend_position(ch.plotting_area(), &occ, &["Pareto front"], &m);
        draw_legend(&mut ch, pos, &m)?;
    }
    Ok(())
}

type PixelBox = ((i32, i32), (i32, i32));

/// Anchor, offset and pixel box of a text of `size` next to pixel `at`:
/// right (or left) of it and above (or below) it by `gap`, as preferred,
/// flipped to the other side where it would leave the plot `(xr, yr)`.
fn place_label(
    at: (i32, i32),
    (w, h): (i32, i32),
    (xr, yr): &(std::ops::Range<i32>, std::ops::Range<i32>),
    prefer_right: bool,
    prefer_above: bool,
    (dx, dy): (i32, i32),
) -> (Pos, (i32, i32), PixelBox) {
    let fits_right = at.0 + dx + w <= xr.end;
    let fits_left = at.0 - dx - w >= xr.start;
    let right = if prefer_right {
        fits_right || !fits_left
    } else {
        !fits_left && fits_right
    };
    let fits_above = at.1 - dy - h >= yr.start;
    let fits_below = at.1 + dy + h <= yr.end;
    let above = if prefer_above {
        fits_above || !fits_below
    } else {
        !fits_below && fits_above
    };
    let (hpos, ox, bx) = if right {
        (HPos::Left, dx, (at.0 + dx, at.0 + dx + w))
    } else {
        (HPos::Right, -dx, (at.0 - dx - w, at.0 - dx))
    };
    let (vpos, oy, by) = if above {
        (VPos::Bottom, -dy, (at.1 - dy - h, at.1 - dy))
    } else {
        (VPos::Top, dy, (at.1 + dy, at.1 + dy + h))
    };
    (Pos::new(hpos, vpos), (ox, oy), ((bx.0, by.0), (bx.1, by.1)))
}
