//! Reading Functions from OpenSim XML (opensim-semantics.md §3 for the
//! properties and defaults, §2.1 for the two spellings of an object-valued
//! property).

use super::{Function, GcvSpline, PiecewiseLinear, SimmSpline};
use crate::error::Result;
use crate::xml::Element;

/// Tags accepted by [`Function::from_xml`].
pub const FUNCTION_TAGS: &[&str] = &[
    "Constant",
    "LinearFunction",
    "PolynomialFunction",
    "MultiplierFunction",
    "PiecewiseLinearFunction",
    "SimmSpline",
    "NaturalCubicSpline",
    "GCVSpline",
    "StepFunction",
];

/// Optional numeric-list property; `None` when absent or empty.
fn opt_numbers(el: &Element, name: &str) -> Result<Option<Vec<f64>>> {
    match el.child(name) {
        Some(c) if !c.text().is_empty() => Ok(Some(c.numbers()?)),
        _ => Ok(None),
    }
}

/// Required x and y arrays of a tabulated function.
fn xy(el: &Element) -> Result<(Vec<f64>, Vec<f64>)> {
    let x = opt_numbers(el, "x")?.unwrap_or_default();
    let y = opt_numbers(el, "y")?.unwrap_or_default();
    Ok((x, y))
}

impl Function {
    /// Parse a function element, e.g. `<SimmSpline name="...">` or
    /// `<LinearFunction>`. Unknown tags and bad properties give an error
    /// naming the tag, file and line.
    pub fn from_xml(el: &Element) -> Result<Function> {
        let located = |e: crate::Error| match e {
            crate::Error::Input { ref loc, .. } if loc.file.is_some() => e,
            other => el.error(match other {
                crate::Error::Input { msg, .. } => msg,
                crate::Error::Internal(m) => m,
            }),
        };
        match el.name.as_str() {
            "Constant" => Ok(Function::Constant(el.child_f64_or("value", 0.0)?)),
            "LinearFunction" => {
                let c = opt_numbers(el, "coefficients")?.unwrap_or_else(|| vec![1.0, 0.0]);
                if c.len() != 2 {
                    return Err(el.error(format!(
                        "LinearFunction of one argument needs 2 coefficients [slope intercept], found {}",
                        c.len()
                    )));
                }
                Ok(Function::Linear {
                    slope: c[0],
                    intercept: c[1],
                })
            }
            "PolynomialFunction" => {
                let c = opt_numbers(el, "coefficients")?.unwrap_or_else(|| vec![1.0]);
                Ok(Function::Polynomial(c))
            }
            "MultiplierFunction" => {
                let inner = Function::find_property(el, "function")?
                    .ok_or_else(|| el.error("MultiplierFunction has no <function> to multiply"))?;
                Ok(Function::Multiplier {
                    scale: el.child_f64_or("scale", 1.0)?,
                    inner: Box::new(inner),
                })
            }
            "PiecewiseLinearFunction" => {
                let (x, y) = xy(el)?;
                Ok(Function::PiecewiseLinear(
                    PiecewiseLinear::new(&x, &y).map_err(located)?,
                ))
            }
            "SimmSpline" | "NaturalCubicSpline" => {
                let (x, y) = xy(el)?;
                Ok(Function::SimmSpline(
                    SimmSpline::new(&x, &y).map_err(located)?,
                ))
            }
            "GCVSpline" => {
                let ho_el = el
                    .child("half_order")
                    .filter(|c| !c.text().is_empty())
                    .ok_or_else(|| el.error("GCVSpline has no <half_order>"))?;
                let ho = ho_el.int()?;
                if !(1..=4).contains(&ho) {
                    return Err(ho_el.error(format!(
                        "GCVSpline half_order must be 1 to 4 (degree 1, 3, 5 or 7), found {ho}"
                    )));
                }
                let var = el.child_f64_or("error_variance", 0.0)?;
                if var != 0.0 {
                    return Err(el.error(format!(
                        "GCVSpline with error_variance {var} is a smoothing spline, which is not \
                         supported yet; only interpolating GCVSplines (error_variance 0) are"
                    )));
                }
                let (x, y) = xy(el)?;
                let degree = 2 * ho as usize - 1;
                Ok(Function::GcvSpline(
                    GcvSpline::interpolating(degree, &x, &y).map_err(located)?,
                ))
            }
            "StepFunction" => {
                let t0 = el.child_f64_or("transition_start_time", 0.99)?;
                let t1 = el.child_f64_or("transition_end_time", 1.01)?;
                let y0 = el.child_f64_or("start_value", 0.0)?;
                let y1 = el.child_f64_or("end_value", 1.0)?;
                if t0 == t1 || !(t1 - t0).is_finite() {
                    return Err(el.error(format!(
                        "StepFunction needs distinct finite transition times, found {t0} and {t1}"
                    )));
                }
                Ok(Function::Step { t0, t1, y0, y1 })
            }
            other => Err(el.error(format!(
                "unknown Function type <{other}>; supported: {}",
                FUNCTION_TAGS.join(", ")
            ))),
        }
    }

    /// Find the function-valued property `prop` of `parent` in either
    /// spelling: `<LinearFunction name="prop">…` as a direct child, or
    /// `<prop><LinearFunction>…</LinearFunction></prop>`. `Ok(None)` if the
    /// property is absent or empty (`<prop/>`).
    pub fn find_property(parent: &Element, prop: &str) -> Result<Option<Function>> {
        let mut found: Option<&Element> = None;
        let mut wrapped = false;
        for c in &parent.children {
            let is_wrapper = c.name == prop;
            let is_direct = !is_wrapper && c.attr("name") == Some(prop);
            if !(is_wrapper || is_direct) {
                continue;
            }
            if let Some(prev) = found {
                return Err(c.error(format!(
                    "property '{prop}' of {} is given twice (also at line {})",
                    parent.describe(),
                    prev.line
                )));
            }
            found = Some(c);
            wrapped = is_wrapper;
        }
        let Some(el) = found else { return Ok(None) };
        if !wrapped {
            return Function::from_xml(el).map(Some);
        }
        match el.children.as_slice() {
            [] if el.text().is_empty() => Ok(None),
            [] => Err(el.error(format!(
                "expected a Function element (e.g. <LinearFunction>) inside <{prop}>, found text '{}'",
                el.text()
            ))),
            [f] => Function::from_xml(f).map(Some),
            [_, second, ..] => Err(second.error(format!(
                "<{prop}> must hold exactly one Function element"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xml::parse_str;
    use std::path::Path;

    fn parse(src: &str) -> Element {
        parse_str(src, Path::new("model.osim")).unwrap()
    }

    #[test]
    fn both_spellings() {
        let a = parse(
            "<TransformAxis name=\"rotation1\">\n\
             <coordinates>knee</coordinates>\n\
             <LinearFunction name=\"function\">\n<coefficients>2 0.5</coefficients>\n</LinearFunction>\n\
             </TransformAxis>",
        );
        let b = parse(
            "<TransformAxis name=\"rotation1\">\n\
             <function>\n<LinearFunction>\n<coefficients>2 0.5</coefficients>\n</LinearFunction>\n</function>\n\
             </TransformAxis>",
        );
        let want = Function::Linear {
            slope: 2.0,
            intercept: 0.5,
        };
        assert_eq!(
            Function::find_property(&a, "function").unwrap(),
            Some(want.clone())
        );
        assert_eq!(Function::find_property(&b, "function").unwrap(), Some(want));
        let empty = parse("<TransformAxis><function/><axis>1 0 0</axis></TransformAxis>");
        assert_eq!(Function::find_property(&empty, "function").unwrap(), None);
        assert_eq!(Function::find_property(&a, "other").unwrap(), None);
        let twice = parse(
            "<T>\n<Constant name=\"function\"><value>1</value></Constant>\n<function><Constant/></function>\n</T>",
        );
        let e = Function::find_property(&twice, "function")
            .unwrap_err()
            .to_string();
        assert!(e.contains("twice") && e.contains("line 3"), "{e}");
    }

    #[test]
    fn bad_elements_name_file_and_line() {
        let r = parse("<T>\n<function>\n<Sinusoid>\n</Sinusoid>\n</function>\n</T>");
        let e = Function::find_property(&r, "function")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("model.osim") && e.contains("line 3") && e.contains("Sinusoid"),
            "{e}"
        );
        // a spline whose data are inconsistent: error at the spline element
        let r = parse(
            "<T>\n\n<SimmSpline name=\"function\">\n<x>0 1 2</x>\n<y>0 1</y>\n</SimmSpline>\n</T>",
        );
        let e = Function::find_property(&r, "function")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("SimmSpline"), "{e}");
        let r = parse(
            "<T>\n<SimmSpline name=\"function\">\n<x>0 1 zz</x>\n<y>0 1 2</y>\n</SimmSpline>\n</T>",
        );
        let e = Function::find_property(&r, "function")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("zz"), "{e}");
        let r = parse("<GCVSpline>\n<half_order>3</half_order><error_variance>1e-3</error_variance>\n<x>0 1 2 3 4 5</x><y>0 1 2 3 4 5</y></GCVSpline>");
        let e = Function::from_xml(&r).unwrap_err().to_string();
        assert!(e.contains("not supported") && e.contains("line 1"), "{e}");
        let r = parse(
            "<GCVSpline>\n<half_order>3</half_order>\n<x>0 1 2 3 4</x><y>0 1 2 3 4</y></GCVSpline>",
        );
        let e = Function::from_xml(&r).unwrap_err().to_string();
        assert!(
            e.contains("Too few data points") && e.contains("model.osim"),
            "{e}"
        );
        let r = parse("<StepFunction><transition_start_time>1</transition_start_time><transition_end_time>1</transition_end_time></StepFunction>");
        assert!(Function::from_xml(&r).is_err());
        let r = parse("<LinearFunction><coefficients>1 2 3</coefficients></LinearFunction>");
        assert!(Function::from_xml(&r).is_err());
    }

    #[test]
    fn all_tags_and_defaults() {
        let f = |s: &str| Function::from_xml(&parse(s)).unwrap();
        assert_eq!(
            f("<Constant><value>2.5</value></Constant>"),
            Function::Constant(2.5)
        );
        assert_eq!(f("<Constant/>"), Function::Constant(0.0));
        assert_eq!(
            f("<LinearFunction/>"),
            Function::Linear {
                slope: 1.0,
                intercept: 0.0
            }
        );
        let p = f("<PolynomialFunction><coefficients>2 3 5</coefficients></PolynomialFunction>");
        assert_eq!(p.value(2.0), 19.0);
        let m = f("<MultiplierFunction><function><PolynomialFunction><coefficients>2 3 5</coefficients></PolynomialFunction></function><scale>-2</scale></MultiplierFunction>");
        assert_eq!(m.value(2.0), -38.0);
        let m2 = f("<MultiplierFunction><Constant name=\"function\"><value>3</value></Constant></MultiplierFunction>");
        assert_eq!(m2.value(0.0), 3.0);
        let s = f("<NaturalCubicSpline><x>0 1 2 3</x><y>0 1 4 9</y></NaturalCubicSpline>");
        assert!((s.value(1.5) - 2.25).abs() < 1e-12); // FMM reproduces x²
        let pl = f("<PiecewiseLinearFunction><x>0 1</x><y>0 2</y></PiecewiseLinearFunction>");
        assert_eq!(pl.value(3.0), 6.0);
        let g = f("<GCVSpline name=\"g\"><half_order>2</half_order><error_variance>0</error_variance><x>0 1 2 3</x><y>1 3 5 7</y><weights>1 1 1 1</weights></GCVSpline>");
        assert!((g.value(7.0) - 15.0).abs() < 1e-12);
        let st = f("<StepFunction/>");
        assert_eq!(st.value(0.0), 0.0);
        assert!((st.value(1.0) - 0.5).abs() < 1e-12);
        assert_eq!(st.value(2.0), 1.0);
    }
}

/// Every function in the validation models parses (both spellings occur
/// there: `<MultiplierFunction name="function"><function><Constant>…`).
#[cfg(test)]
mod validation_models {
    use super::*;
    use std::path::PathBuf;

    fn walk<'a>(el: &'a Element, out: &mut Vec<&'a Element>) {
        out.push(el);
        for c in &el.children {
            walk(c, out);
        }
    }

    #[test]
    fn all_functions_in_validation_models_parse() {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
        if !root.exists() {
            eprintln!("SKIP: {} absent", root.display());
            return;
        }
        let mut n_fun = 0;
        for case in ["arm26", "leg6dof9musc_stance", "gait10dof18musc_walk"] {
            let path = root.join(case).join("model_40.osim");
            if !path.exists() {
                eprintln!("SKIP: {} absent", path.display());
                continue;
            }
            let doc = crate::xml::parse_file(&path).unwrap();
            let mut all = Vec::new();
            walk(&doc, &mut all);
            for el in all {
                if el.name == "TransformAxis" {
                    // absent function means Constant(0) to the caller
                    let f = Function::find_property(el, "function").unwrap();
                    if let Some(f) = f {
                        n_fun += 1;
                        for i in 0..=20 {
                            let q = -2.0 + 0.2 * i as f64;
                            let (a, b, c) = f.eval2(q);
                            assert!(a.is_finite() && b.is_finite() && c.is_finite());
                        }
                    }
                }
                if FUNCTION_TAGS.contains(&el.name.as_str()) {
                    Function::from_xml(el).unwrap_or_else(|e| panic!("{e}"));
                }
            }
        }
        eprintln!("{n_fun} TransformAxis functions parsed");
    }
}
