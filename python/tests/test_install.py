"""`pip install .` from the checkout's root builds the same package as
`pip install ./python`: the root pyproject.toml points maturin at python/."""
import pathlib
import tomllib


def test_root_pyproject_builds_the_python_package():
    root = pathlib.Path(__file__).resolve().parents[2]
    top = tomllib.loads((root / "pyproject.toml").read_text())
    sub = tomllib.loads((root / "python" / "pyproject.toml").read_text())
    assert top["project"]["name"] == sub["project"]["name"] == "statopt"
    assert top["project"]["version"] == sub["project"]["version"]
    assert top["project"]["dependencies"] == sub["project"]["dependencies"]
    assert top["project"]["optional-dependencies"] == sub["project"]["optional-dependencies"]
    m = top["tool"]["maturin"]
    assert (root / m["manifest-path"]).is_file()
    assert (root / m["python-source"] / "statopt" / "__init__.py").is_file()
    assert m["module-name"] == sub["tool"]["maturin"]["module-name"]
