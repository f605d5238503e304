"""Overrides of a setup without editing its file: the setup document is
edited in memory and handed to the engine as text *read as if it were the
original file* (relative paths resolve against the setup's own folder,
messages and the ``statopt_setup=`` header of every table name it, and line
numbers stay those of the file). Model, artifact and force-set files a
``model_properties`` override edits, and a ``motion`` DataFrame, are written
to a scratch folder the setup then names by absolute path.
"""

from __future__ import annotations

import numbers
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

from . import _native

#: Override names with a meaning of their own (every other name sets the
#: setup element of that name).
KNOWN = (
    "contact_weight",
    "friction",
    "time_range",
    "artifact_files",
    "model_properties",
    "motion",
    "external_load_scale",
)

_TOOLS = ("AnalyzeTool", "InverseDynamicsTool")


def _input_error(msg: str, file: Optional[str] = None, element: Optional[str] = None):
    text = f"{file}: {msg}" if file else msg
    if file and element:
        text = f"{file}, {element}: {msg}"
    e = _native.InputError(text)
    e.file, e.line, e.element, e.reason = file, None, element, msg
    return e


def _fmt(v: Any) -> str:
    """A value as setup text: numbers round-trip, sequences space-separated."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))
    if isinstance(v, (str, os.PathLike)):
        return os.fspath(v)
    try:
        return " ".join(_fmt(x) for x in v)
    except TypeError:
        return str(v)


def _abs_path(v: Any) -> str:
    """Paths given from Python are relative to the working directory."""
    if isinstance(v, (str, os.PathLike)):
        items = [v]
    else:
        items = list(v)
    out = []
    for p in items:
        s = os.path.abspath(os.fspath(p))
        if any(c.isspace() for c in s):
            raise ValueError(f"a setup cannot name a path with white space: {s!r}")
        out.append(s)
    return " ".join(out)


def _children(el: ET.Element) -> List[ET.Element]:
    return [c for c in el if isinstance(c.tag, str)]


def _set_child(parent: ET.Element, tag: str, text: str) -> ET.Element:
    """Set (or add, formatted as its siblings) the child element ``tag``."""
    el = parent.find(tag)
    if el is None:
        kids = list(parent)
        el = ET.SubElement(parent, tag)
        if kids:
            el.tail = kids[-1].tail
            kids[-1].tail = (parent.text or "\n")
    el.text = text
    return el


def _prolog_end(text: str) -> int:
    """Where the root element starts (after the declaration and comments)."""
    pos = 0
    while True:
        while pos < len(text) and text[pos].isspace():
            pos += 1
        if text.startswith("<?", pos):
            end = text.find("?>", pos)
            pos = len(text) if end < 0 else end + 2
        elif text.startswith("<!--", pos):
            end = text.find("-->", pos)
            pos = len(text) if end < 0 else end + 3
        elif text.startswith("<!", pos):
            end = text.find(">", pos)
            pos = len(text) if end < 0 else end + 1
        else:
            return pos


def _parse(text: str) -> ET.Element:
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    parser.feed(text)
    return parser.close()


class SetupDocument:
    """A setup file parsed for editing."""

    def __init__(self, path: Path):
        self.path = path
        # Absolute: paths written into the setup must not depend on where
        # the engine resolves relative ones from.
        self.dir = Path(os.path.abspath(path)).parent
        self.text = path.read_text(encoding="utf-8")
        self.prolog = self.text[: _prolog_end(self.text)]
        self.root = _parse(self.text)
        if self.root.tag in _TOOLS or self.root.tag == "StatoptStudy":
            self.tool = self.root
        else:
            kids = _children(self.root)
            self.tool = kids[0] if kids else self.root
        self.kind = self.tool.tag

    def resolve(self, p: str) -> Path:
        q = Path(p.strip())
        return q if q.is_absolute() else self.dir / q

    def serialize(self) -> str:
        return self.prolog + ET.tostring(self.root, encoding="unicode")

    def analyses(self, tag: str) -> List[ET.Element]:
        return list(self.tool.iter(tag))


def _w0_untag(doc: SetupDocument, before: str) -> None:
    """With one w0 the tables carry no w0 part in their names: point the
    setup's figures and metrics at those. The engine knows the names
    (``statopt::writers::names``, through the binding): each reference to a
    table of the sweep the setup ``before`` ran becomes the single run's."""
    refs = [(el, a) for el in doc.tool.iter() if el.tag in ("Figure", "Metric", "Series", "Band")
            for a in ("file", "mean", "min", "max") if el.get(a) is not None]
    if not refs:
        return
    new = _native.single_w0_references(str(doc.path), before, [el.get(a) for el, a in refs])
    for (el, a), v in zip(refs, new):
        el.set(a, v)


def _model_files(doc: SetupDocument) -> List[Tuple[str, ET.Element]]:
    out = []
    for tag in ("model_file", "artifact_files", "force_set_files"):
        el = doc.tool.find(tag)
        if el is None or not (el.text or "").strip():
            continue
        for w in (el.text or "").split():
            if w != "Unassigned":
                out.append((tag, w))
    return out


def _find_components(root: ET.Element, names: List[str]) -> List[ET.Element]:
    cur = [root]
    for n in names:
        nxt = []
        for c in cur:
            for d in c.iter():
                if d is c or not isinstance(d.tag, str):
                    continue
                if d.get("name") == n or d.tag.lower() == n.lower():
                    nxt.append(d)
        cur = nxt
    return cur


def _apply_model_properties(doc: SetupDocument, props: Dict[str, Any], workdir: Path) -> None:
    files = _model_files(doc)
    if not files:
        raise _input_error("model_properties: the setup names no model file", str(doc.path))
    trees: Dict[Tuple[str, str], Tuple[Path, str, ET.Element]] = {}
    for tag, w in files:
        p = doc.resolve(w)
        try:
            text = p.read_text(encoding="utf-8")
            trees[(tag, w)] = (p, text[: _prolog_end(text)], _parse(text))
        except (OSError, ET.ParseError):
            # The engine reports unreadable files with its own message.
            continue
    edited = set()
    for key, value in props.items():
        parts = [s for s in str(key).strip("/").split("/") if s]
        if len(parts) < 2:
            raise ValueError(
                f"model_properties: '{key}' must be 'component/property' (e.g. 'tibia_pad_r/plane_origin')"
            )
        names, prop = parts[:-1], parts[-1]
        hits = []
        for k, (p, _, root) in trees.items():
            for comp in _find_components(root, names):
                el = comp.find(prop)
                if el is not None:
                    hits.append((k, p, comp, el))
        if not hits:
            raise _input_error(
                f"model_properties: no component '{'/'.join(names)}' with a property <{prop}> in "
                + ", ".join(os.path.normpath(t[0]) for t in trees.values()),
                str(doc.path),
            )
        if len(hits) > 1:
            where = "; ".join(f"{h[1]} <{h[2].tag} name=\"{h[2].get('name')}\">" for h in hits)
            raise _input_error(
                f"model_properties: '{key}' is ambiguous ({where}); give more of the component path",
                str(doc.path),
            )
        k, _, _, el = hits[0]
        el.text = _fmt(value)
        edited.add(k)
    # Write the edited files, each in a folder of its own (same file name,
    # so messages still say which file), and name them by absolute path.
    renamed: Dict[Tuple[str, str], str] = {}
    for i, k in enumerate(sorted(edited)):
        p, prolog, root = trees[k]
        d = workdir / f"model{i}"
        d.mkdir(parents=True, exist_ok=True)
        out = d / p.name
        out.write_text(prolog + ET.tostring(root, encoding="unicode"), encoding="utf-8")
        renamed[k] = str(out)
    for tag in ("model_file", "artifact_files", "force_set_files"):
        el = doc.tool.find(tag)
        if el is None or not el.text:
            continue
        words = []
        for w in el.text.split():
            if (tag, w) in renamed:
                words.append(renamed[(tag, w)])
            elif w == "Unassigned":
                words.append(w)
            else:
                words.append(str(doc.resolve(w)))
        el.text = " ".join(words)


def edit_setup(setup: Path, overrides: Dict[str, Any], workdir: Path) -> str:
    """The setup's text with ``overrides`` applied (see :func:`statopt.run`)."""
    try:
        doc = SetupDocument(setup)
    except OSError as e:
        raise _input_error(f"cannot read or write file: {e.strerror or e}", str(setup)) from None
    except ET.ParseError as e:
        line = e.position[0] if getattr(e, "position", None) else None
        err = _input_error(f"not well-formed XML: {e}", str(setup))
        if line:
            err = _native.InputError(f"{setup}, line {line}: not well-formed XML: {e}")
            err.file, err.line, err.element, err.reason = str(setup), line, None, f"not well-formed XML: {e}"
        raise err from None
    if doc.kind not in _TOOLS:
        raise ValueError(
            f"{setup}: overrides apply to AnalyzeTool and InverseDynamicsTool setups, not to "
            f"<{doc.kind}> documents (sweep over the study's setups instead)"
        )
    overrides = dict(overrides)
    drop_figures = overrides.pop("_drop_figures", False)
    if drop_figures:
        for parent in doc.tool.iter():
            for c in [c for c in parent if c.tag == "Figure"]:
                parent.remove(c)
    if "artifact_files" in overrides:
        v = overrides.pop("artifact_files")
        _set_child(doc.tool, "artifact_files", _abs_path(v) if v else "")
    if "contact_weight" in overrides:
        v = overrides.pop("contact_weight")
        w = [v] if isinstance(v, numbers.Real) or isinstance(v, str) else list(v)
        sos = doc.analyses("StaticOptimization")
        if not sos:
            raise _input_error("contact_weight: the setup has no StaticOptimization analysis", str(setup))
        before = doc.serialize()
        for so in sos:
            _set_child(so, "contact_weight", " ".join(_fmt(x) for x in w))
        if len(w) == 1:
            _w0_untag(doc, before)
    if "friction" in overrides:
        v = overrides.pop("friction")
        sos = doc.analyses("StaticOptimization")
        if not sos:
            raise _input_error("friction: the setup has no StaticOptimization analysis", str(setup))
        for so in sos:
            _set_child(so, "friction_cone", str(v))
    if "time_range" in overrides:
        t0, t1 = overrides.pop("time_range")
        if doc.kind == "InverseDynamicsTool":
            _set_child(doc.tool, "time_range", f"{_fmt(float(t0))} {_fmt(float(t1))}")
        else:
            _set_child(doc.tool, "initial_time", _fmt(float(t0)))
            _set_child(doc.tool, "final_time", _fmt(float(t1)))
    if "motion" in overrides:
        m = overrides.pop("motion")
        if isinstance(m, (str, os.PathLike)):
            path = _abs_path(m)
        else:
            from ._tables import write_table

            workdir.mkdir(parents=True, exist_ok=True)
            path = str(workdir / "motion.mot")
            write_table(
                m,
                path,
                name=m.attrs.get("name", "motion"),
                in_degrees=bool(m.attrs.get("in_degrees", True)),
                precision=16,
            )
        _set_child(doc.tool, "coordinates_file", path)
    if "external_load_scale" in overrides:
        raise TypeError("external_load_scale is applied by the engine (statopt.run passes it on), "
                        "not by editing the setup")
    props = overrides.pop("model_properties", None)
    for key, value in overrides.items():
        els = [doc.tool.find(key)] if doc.tool.find(key) is not None else list(doc.tool.iter(key))
        els = [e for e in els if e is not None]
        if not els:
            raise TypeError(
                f"unknown override '{key}': not one of {', '.join(KNOWN)} and {setup} has no <{key}>"
            )
        text = _abs_path(value) if re.search(r"_(file|files|directory)$", key) else _fmt(value)
        for e in els:
            e.text = text
    if props:
        _apply_model_properties(doc, props, workdir)
    return doc.serialize()


def external_scales(value: Any) -> Dict[str, float]:
    """An ``external_load_scale`` override as {ExternalForce name or "*":
    factor}: a number scales every external load, a dict the ones it
    names (``"*"``: all)."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return {"*": float(value)}
    if isinstance(value, dict) and all(
        isinstance(v, numbers.Real) and not isinstance(v, bool) for v in value.values()
    ):
        return {str(k): float(v) for k, v in value.items()}
    raise TypeError(
        f"external_load_scale: a number (every external load) or a dict {{ExternalForce name: factor}}, "
        f"got {value!r}"
    )


def metric_elements(setup: Path) -> bool:
    """Whether a setup has <Metric> elements."""
    try:
        doc = SetupDocument(setup)
    except (OSError, ET.ParseError):
        return False
    return any(True for _ in doc.tool.iter("Metric"))


def is_study(setup: Path) -> bool:
    try:
        return SetupDocument(setup).kind == "StatoptStudy"
    except (OSError, ET.ParseError):
        return False
