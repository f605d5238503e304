import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def cli(repo) -> Path:
    """The CLI the package is compared with (STATOPT_TOOL, else
    target/release/statopt-tool, built when missing)."""
    env = os.environ.get("STATOPT_TOOL")
    if env:
        return Path(env)
    exe = repo / "target" / "release" / "statopt-tool"
    if not exe.exists():
        subprocess.run(["cargo", "build", "--release", "--bin", "statopt-tool"], cwd=repo, check=True)
    return exe


@pytest.fixture(scope="session")
def cam1_cli(cli, repo, tmp_path_factory):
    """The CLI's outputs of setups/leg_extension_cam1.xml (w0 = 1, 500, 1000)."""
    out = tmp_path_factory.mktemp("cli") / "cam1"
    r = subprocess.run([str(cli), str(repo / "setups" / "leg_extension_cam1.xml"), "-o", str(out), "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="session")
def cam1_py(repo):
    import statopt

    return statopt.run(repo / "setups" / "leg_extension_cam1.xml", progress=False)
