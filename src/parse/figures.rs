//! statopt's `<Figure>` and `<Metric>` elements (of a study document or an
//! AnalyzeTool setup; `tools::study` draws and computes them) as typed
//! values, every attribute read and checked once, each value with its
//! element's place for messages. The plan stage re-exports them
//! (`plan::figures`). The attributes each element reads are
//! `parse::known::FIGURE_ELEMENTS`; unknown children and attributes are
//! reported there (an error, or a warning with `--allow-unknown`) and
//! skipped here.

use crate::error::{Error, Location, Result};
use crate::xml::Element;

/// The data of a curve: one table, or a band's three.
#[derive(Debug, Clone, PartialEq)]
pub enum SeriesData {
    /// `<Series file="...">`.
    Line { file: String },
    /// `<Band mean="..." min="..." max="...">`: the mean's curve, shaded
    /// between min and max.
    Band {
        mean: String,
        min: String,
        max: String,
    },
}

/// A `<Series>` or `<Band>` of a figure's panel.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesSpec {
    pub data: SeriesData,
    /// The `column` attribute: one column, or several (space-separated)
    /// summed.
    pub column: String,
    /// The `label` attribute (the column when absent).
    pub label: String,
    /// Palette index (`color`, default 0).
    pub color: usize,
    /// `dashed="true"`.
    pub dashed: bool,
    /// Factor on the values (`scale`, default 1).
    pub scale: f64,
    pub loc: Location,
}

/// One panel of a figure: the `<Figure>` element's own attributes for the
/// first, a `<panel>`'s for each further one.
#[derive(Debug, Clone, PartialEq)]
pub struct PanelSpec {
    pub title: String,
    /// Default `time (s)`.
    pub x_label: String,
    pub y_label: String,
    /// The shading's legend entry (`fill_label`, or a `<fill_between>`'s
    /// `label`).
    pub fill_label: String,
    pub series: Vec<SeriesSpec>,
    /// `<fill_between>i j</fill_between>`: shade between series i and j.
    pub fill_between: Option<(usize, usize)>,
    pub loc: Location,
}

/// A `<Figure name="...">`: written as `<name>.png` and `.svg`.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureSpec {
    pub name: String,
    pub panels: Vec<PanelSpec>,
    pub loc: Location,
}

/// What a `<Metric>` computes from its series over time (`op`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MetricOp {
    Max,
    Min,
    AbsMax,
    Mean,
    /// Trapezoidal integral over time.
    Integral,
    /// The `where` column at the maximum (minimum).
    ArgMax,
    ArgMin,
    /// The value where the `where` column first equals this (interpolated).
    At(f64),
    /// The `where` column where the value first changes sign.
    Crossing,
}

/// The operations a `<Metric>` knows.
pub const METRIC_OPS: [&str; 9] = [
    "max", "min", "absmax", "mean", "integral", "argmax", "argmin", "at", "crossing",
];

impl MetricOp {
    /// Whether the op reads a `where` column.
    pub fn located(self) -> bool {
        matches!(
            self,
            MetricOp::ArgMax | MetricOp::ArgMin | MetricOp::At(_) | MetricOp::Crossing
        )
    }
}

/// A `<Metric name="..." file="..." columns="..." op="...">`.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricSpec {
    pub name: String,
    /// The table, as the attribute gives it.
    pub file: String,
    /// The `columns` attribute: the columns summed.
    pub columns: String,
    pub op: MetricOp,
    /// The `where` attribute: the column that locates the value (required
    /// by the ops that read one, [`MetricOp::located`]).
    pub where_column: Option<String>,
    /// Factor on the values (`scale`, default 1).
    pub scale: f64,
    pub loc: Location,
}

/// A `<Figure>` or a `<Metric>`, in the document's order.
#[derive(Debug, Clone, PartialEq)]
pub enum FigureOrMetric {
    Figure(FigureSpec),
    Metric(MetricSpec),
}

/// A table a figure or metric names: the attribute, its value, and the
/// element's place.
#[derive(Debug, Clone, Copy)]
pub struct TableRef<'a> {
    /// `file`, `mean`, `min` or `max`.
    pub attr: &'static str,
    pub value: &'a str,
    pub loc: &'a Location,
}

impl FigureOrMetric {
    /// Read the `<Figure>` and `<Metric>` children of `parent` (a study or
    /// an AnalyzeTool), in order.
    pub fn read_children(parent: &Element) -> Result<Vec<FigureOrMetric>> {
        parent
            .children
            .iter()
            .filter_map(|c| match c.name.as_str() {
                "Figure" => Some(FigureSpec::from_xml(c).map(FigureOrMetric::Figure)),
                "Metric" => Some(MetricSpec::from_xml(c).map(FigureOrMetric::Metric)),
                _ => None,
            })
            .collect()
    }

    /// Every table it names, in the order of its elements and, per element,
    /// `file`, `mean`, `min`, `max`.
    pub fn tables(&self) -> Vec<TableRef<'_>> {
        match self {
            FigureOrMetric::Metric(m) => vec![TableRef {
                attr: "file",
                value: &m.file,
                loc: &m.loc,
            }],
            FigureOrMetric::Figure(f) => f
                .panels
                .iter()
                .flat_map(|p| &p.series)
                .flat_map(|s| match &s.data {
                    SeriesData::Line { file } => vec![TableRef {
                        attr: "file",
                        value: file,
                        loc: &s.loc,
                    }],
                    SeriesData::Band { mean, min, max } => {
                        [("mean", mean), ("min", min), ("max", max)]
                            .into_iter()
                            .map(|(attr, value)| TableRef {
                                attr,
                                value,
                                loc: &s.loc,
                            })
                            .collect()
                    }
                })
                .collect(),
        }
    }
}

/// An input error at `loc`.
pub fn error(loc: &Location, msg: impl Into<String>) -> Error {
    Error::input(loc.clone(), msg)
}

fn required<'a>(el: &'a Element, attr: &str) -> Result<&'a str> {
    el.attr(attr)
        .ok_or_else(|| el.error(format!("missing attribute {attr}")))
}

fn scale(el: &Element) -> Result<f64> {
    Ok(el
        .attr("scale")
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| el.error(format!("scale '{s}' is not a finite number")))
        })
        .transpose()?
        .unwrap_or(1.0))
}

impl SeriesSpec {
    /// A `<Series>` or `<Band>` element.
    pub fn from_xml(c: &Element) -> Result<Self> {
        let column = required(c, "column")?;
        let data = if c.name == "Band" {
            SeriesData::Band {
                mean: required(c, "mean")?.to_string(),
                min: required(c, "min")?.to_string(),
                max: required(c, "max")?.to_string(),
            }
        } else {
            SeriesData::Line {
                file: required(c, "file")?.to_string(),
            }
        };
        let scale = scale(c)?;
        let color = match c.attr("color") {
            Some(v) => v
                .trim()
                .parse::<usize>()
                .map_err(|_| c.error(format!("color '{v}' is not a palette index")))?,
            None => 0,
        };
        Ok(SeriesSpec {
            data,
            column: column.to_string(),
            label: c.attr("label").unwrap_or(column).to_string(),
            color,
            dashed: c.attr("dashed") == Some("true"),
            scale,
            loc: c.loc(),
        })
    }
}

impl PanelSpec {
    /// A panel with the titles of `el` (the `<Figure>` or a `<panel>`) and
    /// no series yet.
    fn titled(el: &Element) -> Self {
        PanelSpec {
            title: el.attr("title").unwrap_or("").to_string(),
            x_label: el.attr("x_label").unwrap_or("time (s)").to_string(),
            y_label: el.attr("y_label").unwrap_or("").to_string(),
            fill_label: el.attr("fill_label").unwrap_or("").to_string(),
            series: Vec::new(),
            fill_between: None,
            loc: el.loc(),
        }
    }
}

impl FigureSpec {
    /// A `<Figure>` element.
    pub fn from_xml(el: &Element) -> Result<Self> {
        let name = el
            .attr("name")
            .ok_or_else(|| el.error("a Figure needs a name attribute"))?
            .to_string();
        let mut panels = Vec::new();
        let mut panel = PanelSpec::titled(el);
        // Where the panel's <fill_between> stands.
        let mut fill_at: Option<&Element> = None;
        for c in &el.children {
            match c.name.as_str() {
                "Series" | "Band" => panel.series.push(SeriesSpec::from_xml(c)?),
                "fill_between" => {
                    let v = c.numbers_n(2)?;
                    if v.iter()
                        .any(|x| !(*x >= 0.0 && x.fract() == 0.0 && x.is_finite()))
                    {
                        return Err(c.error(format!(
                            "fill_between needs the indices of two series of its panel (0, 1, ...), found '{}'",
                            c.text().trim()
                        )));
                    }
                    panel.fill_between = Some((v[0] as usize, v[1] as usize));
                    fill_at = Some(c);
                    if let Some(l) = c.attr("label") {
                        panel.fill_label = l.to_string();
                    }
                }
                "panel" => {
                    check_fill(&panel, fill_at.take())?;
                    panels.push(std::mem::replace(&mut panel, PanelSpec::titled(c)));
                }
                // Unknown elements: `parse::known::figure_elements`.
                _ => {}
            }
        }
        check_fill(&panel, fill_at)?;
        panels.push(panel);
        Ok(FigureSpec {
            name,
            panels,
            loc: el.loc(),
        })
    }
}

/// A panel's `<fill_between>` (at `at`) names two of its series.
fn check_fill(panel: &PanelSpec, at: Option<&Element>) -> Result<()> {
    match (panel.fill_between, at) {
        (Some((a, b)), Some(at)) if a.max(b) >= panel.series.len() => Err(at.error(format!(
            "fill_between ({a}, {b}) names a series that does not exist (its panel has {} series, counted from 0)",
            panel.series.len()
        ))),
        _ => Ok(()),
    }
}

impl MetricSpec {
    /// A `<Metric>` element.
    pub fn from_xml(el: &Element) -> Result<Self> {
        let name = el
            .attr("name")
            .ok_or_else(|| el.error("a Metric needs a name attribute"))?
            .to_string();
        let columns = required(el, "columns")?.to_string();
        let file = required(el, "file")?.to_string();
        let where_column = el.attr("where").map(str::to_string);
        let op_text = el.attr("op").unwrap_or("max");
        let op = match op_text {
            "max" => MetricOp::Max,
            "min" => MetricOp::Min,
            "absmax" => MetricOp::AbsMax,
            "mean" => MetricOp::Mean,
            "integral" => MetricOp::Integral,
            "argmax" => MetricOp::ArgMax,
            "argmin" => MetricOp::ArgMin,
            "at" => MetricOp::At(f64::NAN),
            "crossing" => MetricOp::Crossing,
            other => {
                return Err(el.error(format!("unknown op '{other}' ({})", METRIC_OPS.join(", "))))
            }
        };
        if op.located() && where_column.is_none() {
            return Err(el.error(format!(
                "op '{op_text}' needs a where attribute naming the column that locates the value (e.g. where=\"knee_flexion_r\")"
            )));
        }
        let op = match op {
            MetricOp::At(_) => MetricOp::At(
                el.attr("value")
                    .and_then(|v| v.trim().parse::<f64>().ok())
                    .ok_or_else(|| el.error("op 'at' needs a numeric value attribute"))?,
            ),
            op => op,
        };
        Ok(MetricSpec {
            name,
            file,
            columns,
            op,
            where_column,
            scale: scale(el)?,
            loc: el.loc(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn read(text: &str) -> Result<Vec<FigureOrMetric>> {
        let root = crate::xml::parse_str(text, Path::new("study.xml")).unwrap();
        FigureOrMetric::read_children(&root)
    }

    #[test]
    fn figures_and_metrics_are_read_once_with_their_places() {
        let v = read(
            "<S>\n<Figure name=\"f\" title=\"t\">\n<Series file=\"a.sto\" column=\"x y\" color=\"2\" dashed=\"true\" scale=\"-1\"/>\n<fill_between label=\"gap\">0 1</fill_between><Series file=\"b.sto\" column=\"x\"/>\n<panel y_label=\"N\"/>\n<Band mean=\"m.sto\" min=\"lo.sto\" max=\"hi.sto\" column=\"z\" label=\"b\"/>\n</Figure>\n<Metric name=\"w\" file=\"a.sto\" columns=\"x\" op=\"at\" where=\"q\" value=\"0.5\"/>\n</S>",
        )
        .unwrap();
        let FigureOrMetric::Figure(f) = &v[0] else {
            panic!("{v:?}")
        };
        assert_eq!(f.name, "f");
        assert_eq!(f.panels.len(), 2);
        let (p, q) = (&f.panels[0], &f.panels[1]);
        assert_eq!((p.title.as_str(), p.x_label.as_str()), ("t", "time (s)"));
        assert_eq!(p.fill_between, Some((0, 1)));
        assert_eq!(p.fill_label, "gap");
        let s = &p.series[0];
        assert_eq!(
            (s.label.as_str(), s.color, s.dashed, s.scale),
            ("x y", 2, true, -1.0)
        );
        assert_eq!(s.loc.line, Some(3));
        assert_eq!(q.y_label, "N");
        assert_eq!(q.series[0].label, "b");
        let refs: Vec<(&str, &str)> = v[0].tables().iter().map(|r| (r.attr, r.value)).collect();
        assert_eq!(
            refs,
            [
                ("file", "a.sto"),
                ("file", "b.sto"),
                ("mean", "m.sto"),
                ("min", "lo.sto"),
                ("max", "hi.sto")
            ]
        );
        let FigureOrMetric::Metric(m) = &v[1] else {
            panic!("{v:?}")
        };
        assert_eq!(m.op, MetricOp::At(0.5));
        assert_eq!(m.where_column.as_deref(), Some("q"));
        assert_eq!(m.loc.line, Some(8));
    }

    /// What the draw found only after every run (a missing attribute, a bad
    /// scale or colour, an op without its where column) is an error of
    /// reading the document, at the element's line.
    #[test]
    fn bad_attributes_are_located_errors_when_read() {
        for (text, expected) in [
            ("<Series file=\"a.sto\"/>", "missing attribute column"),
            (
                "<Band mean=\"a\" min=\"b\" column=\"c\"/>",
                "missing attribute max",
            ),
            (
                "<Series file=\"a.sto\" column=\"c\" scale=\"x\"/>",
                "scale 'x' is not a finite number",
            ),
            (
                "<Series file=\"a.sto\" column=\"c\" color=\"red\"/>",
                "color 'red' is not a palette index",
            ),
            ("<fill_between>0</fill_between>", "expected 2 numbers"),
            (
                "<fill_between>0 -1</fill_between>",
                "fill_between needs the indices",
            ),
            (
                "<fill_between>0 1</fill_between>\n<Series file=\"a\" column=\"c\"/>",
                "names a series that does not exist (its panel has 1 series",
            ),
        ] {
            let e = read(&format!(
                "<S>\n<Figure name=\"f\">\n{text}\n</Figure>\n</S>"
            ))
            .unwrap_err()
            .to_string();
            assert!(
                e.contains(expected) && e.contains("study.xml") && e.contains("line 3"),
                "{e}"
            );
        }
        let e = read("<S><Figure/></S>").unwrap_err().to_string();
        assert!(e.contains("a Figure needs a name attribute"), "{e}");
        for (attrs, expected) in [
            ("name=\"m\" file=\"a\"", "missing attribute columns"),
            ("name=\"m\" columns=\"x\"", "missing attribute file"),
            (
                "file=\"a\" columns=\"x\"",
                "a Metric needs a name attribute",
            ),
            (
                "name=\"m\" file=\"a\" columns=\"x\" op=\"median\"",
                "unknown op 'median'",
            ),
            (
                "name=\"m\" file=\"a\" columns=\"x\" op=\"argmax\"",
                "op 'argmax' needs a where attribute",
            ),
            (
                "name=\"m\" file=\"a\" columns=\"x\" op=\"at\" where=\"q\"",
                "op 'at' needs a numeric value",
            ),
        ] {
            let e = read(&format!("<S>\n<Metric {attrs}/>\n</S>"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(expected) && e.contains("line 2"), "{e}");
        }
    }
}
