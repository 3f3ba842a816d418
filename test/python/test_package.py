"""The Python half installs and imports beside the ROS package's generated messages: `pip install -e python/`
into a fresh prefix, then dqn_dovs_py and dqn_dovs.msg import together, whichever comes first on the path."""

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def ros_message_dir() -> str:
    """The directory of the path that holds the generated dqn_dovs.msg (install/ or devel/, from setup.sh)."""
    for entry in os.environ.get("PYTHONPATH", "").split(os.pathsep):
        if entry and (Path(entry) / "dqn_dovs" / "msg" / "__init__.py").is_file():
            return entry
    return ""


def run(code: str, pythonpath: list, cwd: Path, site_dir: str) -> subprocess.CompletedProcess:
    """`code` in a fresh interpreter whose site directories include `site_dir` (where pip put the editable
    install's .pth hook; PYTHONPATH entries do not read .pth files)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(pythonpath), PYTHONNOUSERSITE="1")
    code = f"import site; site.addsitedir({site_dir!r}); " + code
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True)


def test_package_is_not_a_namespace_workaround():
    import dqn_dovs_py

    init = Path(dqn_dovs_py.__file__).read_text()
    assert "extend_path" not in init and "pkgutil" not in init
    assert dqn_dovs_py.__name__ != "dqn_dovs"


def test_editable_install_imports_beside_the_ros_messages(tmp_path):
    prefix = tmp_path / "prefix"
    pip = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation", "--no-index",
         "--prefix", str(prefix), "-e", str(ROOT / "python")],
        capture_output=True, text=True)
    assert pip.returncode == 0, pip.stderr
    site = sysconfig.get_path("purelib", vars={"base": str(prefix), "platbase": str(prefix)})
    assert Path(site).is_dir(), f"pip wrote nothing under {prefix}"
    # From a folder outside the repository, so only the installed package can be found.
    code = "import dqn_dovs_py, dqn_dovs_py.decision_config; print(dqn_dovs_py.__file__)"
    out = run(code, [], tmp_path, site)
    assert out.returncode == 0, out.stderr
    assert Path(out.stdout.strip()).resolve() == (ROOT / "python" / "dqn_dovs_py" / "__init__.py").resolve()

    msgs = ros_message_dir()
    if os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1":
        assert msgs, "no dqn_dovs.msg on PYTHONPATH: source install/setup.sh (make build) first"
    if msgs:
        both = "import dqn_dovs_py.decision_config; from dqn_dovs.msg import Dovs; print(Dovs._type)"
        for order in ([site, msgs], [msgs, site]):
            out = run(both, order, tmp_path, site)
            assert out.returncode == 0, f"path order {order}: {out.stderr}"
            assert out.stdout.strip() == "dqn_dovs/Dovs"
