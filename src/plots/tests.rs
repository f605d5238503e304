use super::*;
use crate::xml::{self, Element};
use std::fs::File;
use std::io::BufReader;

/// A fresh output directory per test under this worktree's `target/`.
fn out_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target")
        .join("plots-test")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Decode a PNG; returns (width, height, RGB pixels).
fn read_png(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let dec = png::Decoder::new(BufReader::new(File::open(path).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    let px = buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, px)
}

fn count_color(px: &[[u8; 3]], c: [u8; 3]) -> usize {
    px.iter().filter(|p| **p == c).count()
}

const BLUE: [u8; 3] = [0, 114, 178];
const VERMILLION: [u8; 3] = [213, 94, 0];

fn all_elements<'a>(e: &'a Element, name: &str, out: &mut Vec<&'a Element>) {
    if e.name == name {
        out.push(e);
    }
    for c in &e.children {
        all_elements(c, name, out);
    }
}

struct Svg {
    root: Element,
}

impl Svg {
    /// Parse with the crate's XML parser (fails on malformed XML).
    fn read(path: &Path) -> Svg {
        let root = xml::parse_file(path).unwrap();
        assert_eq!(root.name, "svg");
        Svg { root }
    }
    fn texts(&self) -> Vec<String> {
        let mut v = Vec::new();
        all_elements(&self.root, "text", &mut v);
        v.iter().map(|e| e.text().trim().to_string()).collect()
    }
    fn has_text(&self, t: &str) -> bool {
        self.texts().iter().any(|s| s == t)
    }
    fn count(&self, name: &str) -> usize {
        let mut v = Vec::new();
        all_elements(&self.root, name, &mut v);
        v.len()
    }
    /// Polylines in colour `stroke` with more than two points (legend icons
    /// are two-point polylines).
    fn data_polylines(&self, stroke: &str) -> usize {
        let mut v = Vec::new();
        all_elements(&self.root, "polyline", &mut v);
        v.iter()
            .filter(|e| {
                e.attr("stroke")
                    .is_some_and(|a| a.eq_ignore_ascii_case(stroke))
            })
            .filter(|e| {
                e.attr("points")
                    .is_some_and(|p| p.split_whitespace().count() > 2)
            })
            .count()
    }
    /// Elements `name` whose `attr` equals `value` (case-insensitive).
    fn count_with(&self, name: &str, attr: &str, value: &str) -> usize {
        let mut v = Vec::new();
        all_elements(&self.root, name, &mut v);
        v.iter()
            .filter(|e| e.attr(attr).is_some_and(|a| a.eq_ignore_ascii_case(value)))
            .count()
    }
}

fn knee_chart() -> Chart {
    let t: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
    let id: Vec<f64> = t.iter().map(|t| 40.0 * (6.0 * t).sin()).collect();
    let so: Vec<f64> = t.iter().map(|t| 35.0 * (6.0 * t).sin() + 3.0).collect();
    Chart {
        title: "Knee flexion moment".into(),
        x_label: "time (s)".into(),
        y_label: "moment (N·m)".into(),
        series: vec![
            Series::new("inverse dynamics", t.clone(), id, Style::color(0)),
            Series::new("static optimization", t, so, Style::dashed(1)),
        ],
        ..Default::default()
    }
}

#[test]
fn line_chart_writes_png_and_svg() {
    let d = out_dir("line");
    let stem = d.join("knee");
    let paths = write(&knee_chart(), &stem).unwrap();
    assert_eq!(paths, vec![d.join("knee.png"), d.join("knee.svg")]);

    let (w, h, px) = read_png(&paths[0]);
    assert_eq!((w, h), (1000, 650));
    // Both curves are drawn in their palette colours.
    assert!(count_color(&px, BLUE) > 500, "solid blue line missing");
    assert!(count_color(&px, VERMILLION) > 200, "dashed line missing");
    // Text renders as glyphs: many dark pixels outside the plotted lines.
    let dark = px.iter().filter(|p| p.iter().all(|&c| c < 60)).count();
    assert!(dark > 2000, "only {dark} dark pixels: text missing?");

    let svg = Svg::read(&paths[1]);
    for t in [
        "Knee flexion moment",
        "time (s)",
        "moment (N·m)",
        "inverse dynamics",
        "static optimization",
    ] {
        assert!(svg.has_text(t), "SVG lacks text {t:?}: {:?}", svg.texts());
    }
    assert_eq!(svg.count("polygon"), 0, "no band, no fill: no polygon");
}

#[test]
fn suffix_is_appended_not_replaced() {
    assert_eq!(
        with_suffix(Path::new("out/fig.v1"), "png"),
        PathBuf::from("out/fig.v1.png")
    );
}

/// Brute-force Pareto front straight from the definition of dominance.
fn front_by_definition(p: &[(f64, f64)]) -> Vec<usize> {
    let ok = |i: usize| p[i].0.is_finite() && p[i].1.is_finite();
    let mut front: Vec<usize> = (0..p.len())
        .filter(|&i| ok(i))
        .filter(|&i| {
            !(0..p.len()).any(|j| {
                ok(j) && j != i && {
                    let (a, b) = (p[j], p[i]);
                    let weakly = a.0 <= b.0 && a.1 <= b.1;
                    // Strictly better somewhere, or an identical earlier point.
                    weakly && (a.0 < b.0 || a.1 < b.1 || j < i)
                }
            })
        })
        .collect();
    front.sort_by(|&a, &b| p[a].0.total_cmp(&p[b].0));
    front
}

#[test]
fn pareto_front_of_hand_made_points() {
    let pts = [
        (1.0, 5.0),      // 0: fastest, worst        -> front
        (2.0, 3.0),      // 1                        -> front
        (3.0, 4.0),      // 2: dominated by 1
        (4.0, 1.0),      // 3: most accurate         -> front
        (2.0, 3.0),      // 4: duplicate of 1        -> not repeated
        (5.0, 1.0),      // 5: same error, slower than 3
        (0.5, f64::NAN), // 6: ignored
        (3.0, 2.0),      // 7                        -> front
        (2.0, 6.0),      // 8: dominated by 1
    ];
    assert_eq!(pareto_front(&pts), vec![0, 1, 7, 3]);
    assert_eq!(front_by_definition(&pts), vec![0, 1, 7, 3]);
    assert!(pareto_front(&[]).is_empty());
    assert_eq!(pareto_front(&[(f64::INFINITY, 1.0), (2.0, 2.0)]), vec![1]);
}

#[test]
fn pareto_front_matches_definition_on_pseudo_random_points() {
    // A small LCG; coordinates on a coarse grid so ties occur.
    let mut s: u64 = 12345;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 33) % 20) as f64
    };
    for _ in 0..50 {
        let pts: Vec<(f64, f64)> = (0..30).map(|_| (next(), next())).collect();
        assert_eq!(pareto_front(&pts), front_by_definition(&pts), "{pts:?}");
    }
}

#[test]
fn band_series_renders_as_filled_polygon() {
    let d = out_dir("band");
    let x: Vec<f64> = (0..50).map(|i| i as f64).collect();
    let y: Vec<f64> = x.iter().map(|x| (x / 8.0).sin()).collect();
    let mut lo: Vec<f64> = y.iter().map(|y| y - 0.3).collect();
    let hi: Vec<f64> = y.iter().map(|y| y + 0.3).collect();
    let mut s = Series::new("mean ± range", x, y, Style::color(2));
    s.band = Some((lo.clone(), hi.clone()));
    let mut chart = Chart {
        title: "Band".into(),
        x_label: "frame".into(),
        y_label: "activation (-)".into(),
        series: vec![s],
        ..Default::default()
    };
    let paths = write(&chart, &d.join("band")).unwrap();
    let svg = Svg::read(&paths[1]);
    assert_eq!(svg.count("polygon"), 1);
    // Filled in the series colour (bluish green).
    assert_eq!(svg.count_with("polygon", "fill", "#009E73"), 1);
    assert!(svg.has_text("mean ± range"));
    let (_, _, px) = read_png(&paths[0]);
    // The band is the series colour at 22 % over white.
    let blend = |c: u8| (255.0 + (c as f64 - 255.0) * 0.22).round() as i32;
    let band = [blend(0), blend(158), blend(115)];
    let n = px
        .iter()
        .filter(|p| (0..3).all(|k| (p[k] as i32 - band[k]).abs() <= 2))
        .count();
    assert!(n > 5000, "only {n} band-coloured pixels");

    // A gap in the band splits it into two polygons.
    lo[20] = f64::NAN;
    chart.series[0].band = Some((lo, hi));
    let paths = write(&chart, &d.join("band_gap")).unwrap();
    assert_eq!(Svg::read(&paths[1]).count("polygon"), 2);
}

#[test]
fn fill_between_two_series() {
    let d = out_dir("fill");
    let x: Vec<f64> = (0..=40).map(|i| i as f64 / 40.0).collect();
    let a: Vec<f64> = x.iter().map(|x| 100.0 * x * (1.0 - x)).collect();
    let b: Vec<f64> = a.iter().map(|a| 0.7 * a).collect();
    let chart = Chart {
        title: "Power".into(),
        x_label: "stance (-)".into(),
        y_label: "power (W)".into(),
        series: vec![
            Series::new("frictionless", x.clone(), a, Style::color(0)),
            Series::new("with friction", x, b, Style::color(1)),
        ],
        fill_between: Some((0, 1)),
        fill_label: "work lost".into(),
        ..Default::default()
    };
    let paths = write(&chart, &d.join("fill")).unwrap();
    let svg = Svg::read(&paths[1]);
    assert_eq!(svg.count("polygon"), 1);
    assert!(svg.has_text("work lost"));

    let bad = Chart {
        fill_between: Some((0, 2)),
        ..chart
    };
    let e = write(&bad, &d.join("bad")).unwrap_err().to_string();
    assert!(e.contains("fill_between"), "{e}");
}

#[test]
fn nan_values_are_skipped() {
    let d = out_dir("nan");
    let x: Vec<f64> = (0..30).map(|i| i as f64).collect();
    let mut y: Vec<f64> = x.iter().map(|x| x * x).collect();
    y[10] = f64::NAN;
    y[20] = f64::INFINITY;
    let mut x2 = x.clone();
    x2[5] = f64::NAN;
    let chart = Chart {
        title: "Gaps".into(),
        series: vec![
            Series::new("y with gaps", x, y, Style::color(0)),
            Series::new("x with a gap", x2, vec![100.0; 30], Style::color(1)),
        ],
        ..Default::default()
    };
    let paths = write(&chart, &d.join("nan")).unwrap();
    let svg_text = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(!svg_text.contains("NaN") && !svg_text.to_lowercase().contains("inf"));
    let svg = Svg::read(&paths[1]);
    // Runs 0..10, 11..20, 21..30 of the first series; 0..5, 6..30 of the second.
    assert_eq!(svg.data_polylines("#0072B2"), 3);
    assert_eq!(svg.data_polylines("#D55E00"), 2);
    let (w, h, _) = read_png(&paths[0]);
    assert_eq!((w, h), (1000, 650));
}

#[test]
fn empty_series_and_empty_chart_are_allowed() {
    let d = out_dir("empty");
    let chart = Chart {
        title: "Nothing yet".into(),
        x_label: "time (s)".into(),
        y_label: "force (N)".into(),
        series: vec![
            Series::new("no data", vec![], vec![], Style::color(0)),
            Series::new("all NaN", vec![f64::NAN; 3], vec![1.0; 3], Style::color(1)),
        ],
        ..Default::default()
    };
    let paths = write(&chart, &d.join("empty")).unwrap();
    let svg = Svg::read(&paths[1]);
    assert!(svg.has_text("no data") && svg.has_text("all NaN"));
    read_png(&paths[0]);

    let none = Chart::default();
    let paths = write(&none, &d.join("none")).unwrap();
    Svg::read(&paths[1]);
    read_png(&paths[0]);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let d = out_dir("errors");
    let mut chart = knee_chart();
    chart.series[1].y.pop();
    let e = write(&chart, &d.join("x")).unwrap_err().to_string();
    assert!(
        e.contains("static optimization") && e.contains("101"),
        "{e}"
    );

    let mut chart = knee_chart();
    chart.series[0].band = Some((vec![0.0; 3], vec![1.0; 3]));
    let e = write(&chart, &d.join("x")).unwrap_err().to_string();
    assert!(e.contains("band"), "{e}");

    let e = write(&knee_chart(), &d.join("missing-dir").join("x"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing-dir"), "{e}");

    let e = write_panels(
        &[knee_chart(), knee_chart(), knee_chart()],
        &d.join("x"),
        Layout::row(2),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("3 charts"), "{e}");

    let tiny = Chart {
        size: (0, 10),
        ..knee_chart()
    };
    assert!(write(&tiny, &d.join("x")).is_err());
}

#[test]
fn panels_split_the_figure() {
    let d = out_dir("panels");
    let mut shear = knee_chart();
    shear.title = "Shear".into();
    let mut comp = knee_chart();
    comp.title = "Compression".into();
    let paths = write_panels(&[shear, comp], &d.join("fig10"), Layout::row(2)).unwrap();
    let (w, h, px) = read_png(&paths[0]);
    assert_eq!((w, h), (2000, 650));
    // Each half holds a chart: blue line pixels on both sides.
    let left = px
        .iter()
        .enumerate()
        .filter(|(i, p)| (*i as u32 % w) < 1000 && **p == BLUE)
        .count();
    let right = px.iter().filter(|p| **p == BLUE).count() - left;
    assert!(left > 300 && right > 300, "left {left}, right {right}");
    let svg = Svg::read(&paths[1]);
    assert!(svg.has_text("Shear") && svg.has_text("Compression"));

    // A 2×2 grid with one empty cell.
    let grid = Layout {
        rows: 2,
        cols: 2,
        size: (1600, 1000),
    };
    let charts = [knee_chart(), knee_chart(), knee_chart()];
    let paths = write_panels(&charts, &d.join("grid"), grid).unwrap();
    let (w, h, px) = read_png(&paths[0]);
    assert_eq!((w, h), (1600, 1000));
    // Bottom-right cell is blank.
    let blank = px
        .iter()
        .enumerate()
        .filter(|(i, _)| (*i as u32 % w) >= 800 && (*i as u32 / w) >= 500)
        .all(|(_, p)| *p == [255, 255, 255]);
    assert!(blank);
    assert!(Svg::read(&paths[1]).count_with("text", "font-family", FONT) > 0);
}

fn solver_scatter() -> Scatter {
    let mut pts = vec![
        ScatterPoint::new("clarabel", 2.0e-3, 1e-6),
        ScatterPoint::new("ipopt-like", 8.0e-3, 1e-7),
        ScatterPoint::new("slow & bad", 9.0e-3, 1e-3),
        ScatterPoint::new("coarse", 4.0e-4, 2e-3),
        ScatterPoint::new("dominated", 3.0e-3, 1e-5),
        ScatterPoint::new("zero error", 1.0e-3, 0.0), // not drawable on log y
        ScatterPoint::new("nan", f64::NAN, 1e-4),
    ];
    pts[1].color = 1;
    Scatter {
        title: "Speed vs accuracy".into(),
        x_label: "time per frame (s)".into(),
        y_label: "max activation error (-)".into(),
        points: pts,
        log_x: true,
        log_y: true,
        pareto: true,
        reference: vec![RefLine::Vertical {
            value: 5.0e-3,
            label: "OpenSim 4.6".into(),
        }],
        ..Default::default()
    }
}

#[test]
fn scatter_with_log_axes_front_and_reference() {
    let d = out_dir("scatter");
    let s = solver_scatter();
    let paths = write_scatter(&s, &d.join("speed")).unwrap();
    let (w, h, px) = read_png(&paths[0]);
    assert_eq!((w, h), (1000, 650));
    assert!(count_color(&px, BLUE) > 100);
    let svg = Svg::read(&paths[1]);
    for t in [
        "Speed vs accuracy",
        "clarabel",
        "slow & bad",
        "OpenSim 4.6",
        "Pareto front",
    ] {
        assert!(svg.has_text(t), "SVG lacks {t:?}: {:?}", svg.texts());
    }
    // Non-drawable points get no label.
    assert!(!svg.has_text("zero error") && !svg.has_text("nan"));
    // Filled markers on the front (coarse, clarabel, ipopt-like), hollow
    // ones for the 2 dominated points; nothing for the 2 undrawable ones.
    assert_eq!(svg.count_with("circle", "fill", "#0072B2"), 2);
    assert_eq!(svg.count_with("circle", "fill", "#D55E00"), 1);
    assert_eq!(svg.count_with("circle", "fill", "none"), 2);
    // The front is one polyline through its 3 points.
    assert_eq!(svg.data_polylines("#000000"), 1);

    // Linear axes and a horizontal reference work too.
    let lin = Scatter {
        log_x: false,
        log_y: false,
        reference: vec![RefLine::Horizontal {
            value: 1e-4,
            label: "tolerance".into(),
        }],
        ..solver_scatter()
    };
    let paths = write_scatter(&lin, &d.join("linear")).unwrap();
    let svg = Svg::read(&paths[1]);
    assert!(svg.has_text("tolerance") && svg.has_text("zero error"));

    // No points at all.
    let empty = Scatter {
        points: vec![],
        ..solver_scatter()
    };
    write_scatter(&empty, &d.join("empty")).unwrap();
}

#[test]
fn log_axis_ticks_and_labels() {
    use super::render::{log_tick, log_ticks};
    let vals = |lo: f64, hi: f64| -> Vec<f64> {
        log_ticks(lo, hi).iter().map(|t| 10f64.powf(*t)).collect()
    };
    let close = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x / y - 1.0).abs() < 1e-12)
    };
    // 1-2-5 within 1..3 decades, including the part below the first decade.
    let v = vals(3e-4, 1.2e-2);
    assert!(close(&v, &[5e-4, 1e-3, 2e-3, 5e-3, 1e-2]), "{v:?}");
    // Decades only over more than three decades.
    let v = vals(0.5, 2e5);
    assert!(close(&v, &[1.0, 10.0, 100.0, 1e3, 1e4, 1e5]), "{v:?}");
    // No 1..9 × 10^k inside: five evenly spaced ticks in log space.
    let v = vals(2.1, 2.9);
    assert_eq!(v.len(), 5);
    assert!((v[0] - 2.1).abs() < 1e-12 && (v[4] - 2.9).abs() < 1e-12);
    assert_eq!(log_tick(&0.0020000000000000005), "0.002");
    assert_eq!(log_tick(&1e-5), "1e-5");
    assert_eq!(log_tick(&2.5e5), "2.5e5");
    assert_eq!(log_tick(&300.0), "300");
}

/// Linear tick labels: no trailing ".0", negative values signed.
#[test]
fn linear_tick_labels_are_plain_and_signed() {
    use super::render::linear_tick;
    assert_eq!(linear_tick(&200.0), "200");
    assert_eq!(linear_tick(&-120.0), "-120");
    assert_eq!(linear_tick(&0.25), "0.25");
    assert_eq!(linear_tick(&(0.1 + 0.2)), "0.3");
    assert_eq!(linear_tick(&-0.0), "0");
}

/// A chart's legend stands right of the plotted data, never over it: no
/// series colour right of the legend column's left edge but in the icons,
/// and the curves' pixels keep clear of the legend text.
#[test]
fn legend_stands_outside_the_data() {
    let d = out_dir("legend_outside");
    let mut c = knee_chart();
    c.size = (1600, 900);
    let paths = write(&c, &d.join("knee")).unwrap();
    let (w, _, px) = read_png(&paths[0]);
    // Blue pixels: the line (left) and its legend icon (right column).
    let cols: Vec<u32> = px
        .iter()
        .enumerate()
        .filter(|(_, p)| **p == BLUE)
        .map(|(i, _)| i as u32 % w)
        .collect();
    let mut xs = cols;
    xs.sort_unstable();
    xs.dedup();
    // A gap between the plot's right edge and the legend's icons.
    assert!(
        xs.windows(2).any(|p| p[0] > w / 2 && p[1] > p[0] + 20),
        "no legend icon apart from the data: {xs:?}"
    );
    let svg = Svg::read(&paths[1]);
    assert!(svg.has_text("inverse dynamics"));
}

/// Stacked panels are 1600 px wide, one above the other.
#[test]
fn column_layout_stacks_panels() {
    let d = out_dir("column");
    let paths = write_panels(
        &[knee_chart(), knee_chart(), knee_chart()],
        &d.join("f"),
        Layout::column(3),
    )
    .unwrap();
    let (w, h, _) = read_png(&paths[0]);
    assert_eq!((w, h), (1600, 2400));
}

/// An axis that crosses zero with a tenth or more of its span below it
/// gets a labelled negative tick (the shear panel reached -120 N and its
/// lowest label was 0).
#[test]
fn an_axis_crossing_zero_labels_its_negative_side() {
    use super::render::label_count;
    // -135..1125: plotters' 8 labels step by 200; asked for 13, by 100.
    assert!(label_count(-135.0, 1125.0) >= 13);
    // Barely below zero: the usual count.
    assert_eq!(label_count(-5.0, 1000.0), label_count(0.0, 1000.0));
    let d = out_dir("negative_ticks");
    let t: Vec<f64> = (0..=100).map(|i| i as f64 * 0.05).collect();
    let y: Vec<f64> = t.iter().map(|t| 1000.0 - 225.0 * t).collect();
    let c = Chart {
        title: "shear".into(),
        series: vec![Series::new("shear", t, y, Style::color(0))],
        size: (1600, 900),
        ..Default::default()
    };
    let paths = write(&c, &d.join("shear")).unwrap();
    let svg = Svg::read(&paths[1]);
    assert!(svg.has_text("-100"), "{:?}", svg.texts());
    assert!(
        !svg.texts().iter().any(|t| t.ends_with(".0")),
        "{:?}",
        svg.texts()
    );
}

/// A title wider than the plot (the legend takes a column) is drawn over
/// the whole figure and shrunk to fit: never clipped at the figure's edge
/// (Figure 9's title lost its first letters).
#[test]
fn a_long_title_is_not_clipped() {
    let d = out_dir("long_title");
    let mut c = knee_chart();
    c.size = (1000, 650);
    c.title =
        "Hip flexion moment, right: muscles vs contacts (Figure 9, Rajagopal, cam 1), long".into();
    let paths = write(&c, &d.join("t")).unwrap();
    let (w, _, px) = read_png(&paths[0]);
    // No dark title pixel touches the left or right edge columns.
    let edge_dark = px
        .iter()
        .enumerate()
        .filter(|(i, p)| {
            let x = *i as u32 % w;
            (x < 3 || x >= w - 3) && p.iter().all(|&c| c < 100)
        })
        .count();
    assert_eq!(edge_dark, 0, "text reaches the figure's edge");
    assert!(Svg::read(&paths[1]).has_text(&c.title));
}

/// Panels stacked in a column have one plot width, whatever their legends
/// (issue 38: Figure 10's panels had different plot widths, so their time
/// axes did not line up), and share their x range.
#[test]
fn stacked_panels_line_up() {
    let d = out_dir("panels_line_up");
    let panel = |label: &str, t_end: f64| {
        let mut c = knee_chart();
        let t: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01 * t_end).collect();
        // The solid blue line unlabelled: its pixels are the plot's alone.
        c.series[0] = Series::new(
            "",
            t.clone(),
            t.iter().map(|_| 0.0).collect(),
            Style::color(0),
        );
        c.series[1].label = label.into();
        c
    };
    let charts = [
        panel("short", 1.0),
        panel("a much longer legend label than the other panel's", 1.0),
        panel("short", 0.5),
    ];
    let paths = write_panels(&charts, &d.join("col"), Layout::column(3)).unwrap();
    let (w, h, px) = read_png(&paths[0]);
    let blue_x = |k: u32| {
        let rows = (k * h / 3)..((k + 1) * h / 3);
        let xs: Vec<u32> = px
            .iter()
            .enumerate()
            .filter(|(i, p)| rows.contains(&(*i as u32 / w)) && **p == BLUE)
            .map(|(i, _)| i as u32 % w)
            .collect();
        (*xs.iter().min().unwrap(), *xs.iter().max().unwrap())
    };
    let (a, b, c) = (blue_x(0), blue_x(1), blue_x(2));
    assert!(
        a.0.abs_diff(b.0) <= 1 && a.1.abs_diff(b.1) <= 1,
        "{a:?} {b:?}"
    );
    // The third panel's data end at half the time: its line ends half way.
    assert_eq!(a.0.abs_diff(c.0) <= 1, true, "{a:?} {c:?}");
    let half = (a.0 + a.1) / 2;
    assert!(c.1.abs_diff(half) <= 3, "{a:?} {c:?}");
}
