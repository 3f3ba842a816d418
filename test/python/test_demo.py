"""scripts/demo.py: its ROS master on a port of its own (a busy port is refused with a message, never a traceback),
the package's own demo episodes, and the outcome lines with the contact class."""
from __future__ import annotations

import importlib.util
import socket
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DEMO = REPO / "scripts" / "demo.py"


def _demo_module():
    spec = importlib.util.spec_from_file_location("dqn_dovs_demo", DEMO)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_busy_port_is_refused_with_a_message_and_no_traceback():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        result = subprocess.run([sys.executable, str(DEMO), "--port", str(port), "--out", "/tmp/dqn_dovs_demo_busy"],
                                capture_output=True, text=True, timeout=60)
    assert result.returncode == 2, result.stderr
    assert f"port {port} is already in use" in result.stderr and "--port 0" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_a_port_out_of_range_is_refused():
    result = subprocess.run([sys.executable, str(DEMO), "--port", "70000"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "--port 70000 is not a TCP port" in result.stderr
    assert "Traceback" not in result.stderr


def test_the_free_port_is_free_and_the_check_sees_a_listener():
    demo = _demo_module()
    port = demo.free_port()
    assert 0 < port < 65536 and not demo.port_in_use(port)
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        assert demo.port_in_use(s.getsockname()[1])


def test_the_demo_episodes_are_the_packages_own():
    demo = _demo_module()
    folder = REPO / "data" / "scenarios" / "demo"
    for name in demo.DEFAULT_SCENARIOS:
        assert (folder / f"{name}.dovs").is_file(), name
    result = subprocess.run([sys.executable, str(DEMO), "--scenarios-dir", "/nonexistent", "--out", "/tmp/dqn_dovs_demo_x"],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "/nonexistent/1-3/1.dovs does not exist" in result.stderr


def test_an_outcome_names_the_contact_class():
    demo = _demo_module()
    assert demo.describe("success", "", float("nan")) == "success"
    assert demo.describe("timeout", "", float("nan")) == "timeout"
    assert demo.describe("collision", "rest", 0.01) == "collision (robot at rest, walked into, 0.01 m/s)"
    assert demo.describe("collision", "moving", 0.456) == "collision (robot moving, 0.46 m/s)"
    assert demo.describe("collision", "static", 0.3) == "collision (static geometry, 0.30 m/s)"


def test_stopping_a_process_that_is_already_gone_is_quiet():
    demo = _demo_module()
    proc = subprocess.Popen(["true"], start_new_session=True)
    proc.wait()
    demo.stop(proc, 1)  # no ProcessLookupError
    proc = subprocess.Popen(["sleep", "30"], start_new_session=True)
    demo.stop(proc, 5)
    assert proc.poll() is not None
