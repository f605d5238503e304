//! The composed model as one OpenSim document (`statopt-tool scene`): the
//! human model's document with each artifact's set members appended to the
//! corresponding sets, plus the members of a setup's force-set files, minus
//! contact elements (OpenSim 4.6 knows no `PointOnPlaneContact`).
//! See docs/composition.md.
//!
//! The document is rebuilt from the original XML elements (names, attributes,
//! children and text as read), so everything statopt does not model —
//! geometry, markers, controllers — is carried over unchanged.

use std::path::{Path, PathBuf};

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, BytesText, Event};
use quick_xml::Writer;

use crate::error::{Error, Result};
use crate::parse::compose;
use crate::parse::osim::ModelSpec;
use crate::tools::loading::{force_kind, ForceKind};
use crate::xml::{self, Element};

/// A composed model document.
#[derive(Debug, Clone)]
pub struct Scene {
    /// `<OpenSimDocument Version=...><Model>...`.
    pub document: Element,
    /// The composed spec (validated: it compiles).
    pub spec: ModelSpec,
    /// Names of contact elements left out of the document.
    pub omitted_contacts: Vec<String>,
}

/// The model element of a 4.0-layout document and its version.
fn model_of<'a>(root: &'a Element, what: &str) -> Result<(u32, &'a Element)> {
    if root.name != "OpenSimDocument" {
        return Err(root.error(format!(
            "{what} is not an OpenSim document: root element must be <OpenSimDocument>"
        )));
    }
    let version: u32 = root
        .attr("Version")
        .and_then(|v| v.trim().parse().ok())
        .ok_or_else(|| root.error("missing or malformed Version attribute"))?;
    if version < 30505 {
        return Err(root.error(format!(
            "the scene writer needs OpenSim 4.0-layout documents (Version >= 30505), this is {version}; open and save the model with OpenSim 4.x first"
        )));
    }
    let model = root
        .child("Model")
        .ok_or_else(|| root.error("document holds no <Model> element"))?;
    Ok((version, model))
}

fn new_element(name: &str, like: &Element) -> Element {
    Element {
        name: name.into(),
        attrs: Vec::new(),
        children: Vec::new(),
        text: Default::default(),
        line: like.line,
        file: like.file.clone(),
    }
}

/// The child `name` of `el`, created (empty) when absent.
fn child_mut<'a>(el: &'a mut Element, name: &str) -> &'a mut Element {
    let i = match el.children.iter().position(|c| c.name == name) {
        Some(i) => i,
        None => {
            let c = new_element(name, el);
            el.children.push(c);
            el.children.len() - 1
        }
    };
    &mut el.children[i]
}

/// Append `members` to the list `list` (an `<objects>` or `components` list),
/// refusing a name used twice.
fn append_unique(list: &mut Element, members: &[Element], what: &str) -> Result<()> {
    for m in members {
        let name = m.name_attr();
        if !name.is_empty() {
            if let Some(prev) = list.children.iter().find(|c| c.name_attr() == name) {
                return Err(m.error(format!(
                    "{what} member '{name}' clashes with {} at {}, line {}: names must be unique in the composed model",
                    prev.describe(),
                    prev.file.display(),
                    prev.line
                )));
            }
        }
        list.children.push(m.clone());
    }
    Ok(())
}

/// Members of an OpenSim set (`<objects>` children).
fn set_members(set: &Element) -> Vec<Element> {
    set.child("objects")
        .map(|o| o.children.clone())
        .unwrap_or_default()
}

/// Append an artifact's `Model` children to the composed model element.
fn append_artifact(model: &mut Element, art: &Element) -> Result<()> {
    for c in &art.children {
        match c.name.as_str() {
            "Ground" => {
                let ground = child_mut(model, "Ground");
                if let Some(ws) = c.child("WrapObjectSet") {
                    let set = child_mut(ground, "WrapObjectSet");
                    append_unique(
                        child_mut(set, "objects"),
                        &set_members(ws),
                        "Ground WrapObjectSet",
                    )?;
                }
                for list in ["attached_geometry", "components"] {
                    if let Some(l) = c.child(list) {
                        append_unique(
                            child_mut(ground, list),
                            &l.children,
                            &format!("Ground {list}"),
                        )?;
                    }
                }
            }
            "components" => {
                append_unique(child_mut(model, "components"), &c.children, "components")?
            }
            name if name.ends_with("Set") => {
                let members = set_members(c);
                if members.is_empty() {
                    continue;
                }
                let set = child_mut(model, name);
                if set.attr("name").is_none() {
                    if let Some(n) = c.attr("name") {
                        set.attrs.push(("name".into(), n.into()));
                    }
                }
                append_unique(child_mut(set, "objects"), &members, name)?;
            }
            // gravity (checked equal by compose::merge), credits, defaults,
            // visual preferences: the human model's stay.
            _ => {}
        }
    }
    Ok(())
}

/// Build the composed document: `model_file` with the artifacts appended and
/// the force-set files' members added to its ForceSet (the model's and the
/// artifacts' forces dropped first when `replace_force_set`), contact elements
/// left out. The composed model is validated with [`compose::merge`] and
/// [`crate::model::compile`] first, so a clash is reported as for an analysis.
pub fn compose_scene(
    model_file: &Path,
    artifact_files: &[PathBuf],
    force_set_files: &[PathBuf],
    replace_force_set: bool,
) -> Result<Scene> {
    let spec = compose::read_composed(model_file, artifact_files)?;
    crate::model::compile(&spec)?;

    let mut document = xml::parse_file(model_file)?;
    let (mut version, _) = model_of(&document, "the model file")?;
    let model_index = document
        .children
        .iter()
        .position(|c| c.name == "Model")
        .ok_or_else(|| document.error("document holds no <Model> element"))?;
    for a in artifact_files {
        let root = xml::parse_file(a)?;
        let (v, art_model) = model_of(&root, "the artifact file")?;
        // Upgrades OpenSim applies to older documents leave newer elements
        // alone, so the oldest version is the safe one for the whole.
        version = version.min(v);
        append_artifact(&mut document.children[model_index], art_model)?;
    }
    let model = &mut document.children[model_index];
    if replace_force_set {
        if let Some(fs) = model.children.iter_mut().find(|c| c.name == "ForceSet") {
            child_mut(fs, "objects").children.clear();
        }
    }
    for f in force_set_files {
        let members = crate::forces::read_force_set_file(f)?;
        let fs = child_mut(model, "ForceSet");
        append_unique(child_mut(fs, "objects"), &members, "ForceSet")?;
    }
    let mut omitted_contacts = Vec::new();
    if let Some(fs) = model.children.iter_mut().find(|c| c.name == "ForceSet") {
        let objects = child_mut(fs, "objects");
        objects.children.retain(|m| {
            let contact = force_kind(m) == ForceKind::Contact;
            if contact {
                omitted_contacts.push(m.name_attr().to_string());
            }
            !contact
        });
        // Groups must not name members that are no longer there.
        if let Some(groups) = fs.children.iter_mut().find(|c| c.name == "groups") {
            for g in &mut groups.children {
                for m in g.children.iter_mut().filter(|m| m.name == "members") {
                    let kept: Vec<String> = m
                        .words()
                        .into_iter()
                        .filter(|w| !omitted_contacts.contains(w))
                        .collect();
                    m.text = kept.join(" ").into();
                }
            }
        }
    }
    match document.attrs.iter_mut().find(|(k, _)| k == "Version") {
        Some((_, v)) => *v = version.to_string().into(),
        None => document
            .attrs
            .push(("Version".into(), version.to_string().into())),
    }
    Ok(Scene {
        document,
        spec,
        omitted_contacts,
    })
}

fn write_el<W: std::io::Write>(w: &mut Writer<W>, el: &Element) -> std::io::Result<()> {
    let mut start = BytesStart::new(el.name.as_str());
    for (k, v) in &el.attrs {
        start.push_attribute((k.as_str(), v.as_str()));
    }
    if el.children.is_empty() {
        if el.text.trim().is_empty() {
            w.write_event(Event::Empty(start))?;
        } else {
            w.write_event(Event::Start(start))?;
            w.write_event(Event::Text(BytesText::new(el.text.trim())))?;
            w.write_event(Event::End(BytesEnd::new(el.name.as_str())))?;
        }
        return Ok(());
    }
    w.write_event(Event::Start(start))?;
    // OpenSim documents have no mixed content; text beside child elements is
    // indentation and is not kept.
    for c in &el.children {
        write_el(w, c)?;
    }
    w.write_event(Event::End(BytesEnd::new(el.name.as_str())))
}

/// Serialise an element tree as an XML document (UTF-8, tab-indented, text
/// and attribute values escaped).
pub fn to_xml_string(root: &Element) -> String {
    let mut w = Writer::new_with_indent(Vec::new(), b'\t', 1);
    let res = w
        .write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .and_then(|_| write_el(&mut w, root));
    // Writing into a Vec cannot fail.
    debug_assert!(res.is_ok());
    let mut s = String::from_utf8_lossy(&w.into_inner()).into_owned();
    s.push('\n');
    s
}

/// Write an element tree to `path` as an XML document.
pub fn write_document(root: &Element, path: &Path) -> Result<()> {
    std::fs::write(path, to_xml_string(root)).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serializer_escapes_and_round_trips() {
        let src = "<A name=\"a &amp; &quot;b&quot;\">\n <B>1 &lt; 2 &amp; 3</B>\n <C/>\n <D x=\"&lt;\"><E>t</E></D>\n</A>";
        let root = xml::parse_str(src, Path::new("t.xml")).unwrap();
        let out = to_xml_string(&root);
        assert!(
            out.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>"),
            "{out}"
        );
        assert!(out.contains("1 &lt; 2 &amp; 3"), "{out}");
        let back = xml::parse_str(&out, Path::new("u.xml")).unwrap();
        assert_eq!(back.attr("name"), Some("a & \"b\""));
        assert_eq!(back.child("B").unwrap().text(), "1 < 2 & 3");
        assert!(back.child("C").unwrap().children.is_empty());
        assert_eq!(back.path(&["D", "E"]).unwrap().text(), "t");
        assert_eq!(back.child("D").unwrap().attr("x"), Some("<"));
        // Idempotent: writing the re-read tree gives the same text.
        assert_eq!(to_xml_string(&back), out);
    }
}
