"""scripts/setup.sh's system-package detection, run for real (``setup.sh check``)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "setup.sh"
BASH = shutil.which("bash")
TRIPLET = "x86_64-linux-gnu"

pytestmark = pytest.mark.skipif(BASH is None, reason="needs bash")


def _check(mode: str = "test", *, env: dict[str, str] | None = None, user: list[str] | None = None,
           script: Path = SCRIPT) -> subprocess.CompletedProcess:
    full_env = {**os.environ, "PYTHON": sys.executable, **(env or {})}
    cmd = [*(user or []), BASH, str(script), "check", mode]
    return subprocess.run(cmd, env=full_env, capture_output=True, text=True, timeout=60)


def _on_debian_like() -> bool:
    return shutil.which("dpkg-query") is not None or Path("/usr/lib", TRIPLET).is_dir()


@pytest.mark.skipif(not _on_debian_like(), reason="system-package names are Debian's")
def test_nothing_missing_on_this_machine():
    result = _check("test")
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout == ""


def test_nothing_missing_for_a_non_root_user():
    """The bug this replaces: a normal user with everything installed was always stopped."""
    if os.geteuid() != 0:
        pytest.skip("runs as root only (it switches to the 'nobody' user); already non-root")
    if not _on_debian_like():
        pytest.skip("system-package names are Debian's")
    setpriv = shutil.which("setpriv")
    runuser = shutil.which("runuser")
    if setpriv:
        user = [setpriv, "--reuid=65534", "--regid=65534", "--clear-groups"]
    elif runuser:
        user = [runuser, "-u", "nobody", "--"]
    else:
        pytest.skip("needs setpriv or runuser to switch user")
    # A copy 'nobody' can read whatever the worktree's permissions are (pytest's tmp_path
    # is private to root).
    folder = Path(tempfile.mkdtemp(prefix="terrascape-setup-"))
    try:
        folder.chmod(0o755)
        script = folder / "setup.sh"
        shutil.copy(SCRIPT, script)
        script.chmod(0o755)
        _check_as(user, script, folder)
    finally:
        shutil.rmtree(folder)


def _check_as(user: list[str], script: Path, home: Path) -> None:
    # nobody's PATH as a login shell would have it (no /sbin: ldconfig is not on it).
    # The system Python the script finds itself (PYTHON empty), as a new user would run it.
    env = {"PATH": "/usr/local/bin:/usr/bin:/bin", "HOME": str(home), "PYTHON": ""}
    whoami = subprocess.run([*user, "id", "-u"], capture_output=True, text=True, check=True)
    assert whoami.stdout.strip() == "65534"
    result = _check("test", env=env, user=user, script=script)
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout == ""


# --- a fake system tree: exactly the missing package is reported ----------------------------
FULL_TREE = (
    f"usr/lib/{TRIPLET}/libEGL.so.1",
    f"usr/lib/{TRIPLET}/libGL.so.1",
    f"usr/lib/{TRIPLET}/dri/swrast_dri.so",
)
COMMANDS = ("Xvfb", "xdotool", "import", "chromium", "c++")


def _fake_system(root: Path, files=FULL_TREE, commands=COMMANDS) -> dict[str, str]:
    for rel in files:
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_bytes(b"")
    bin_dir = root / "bin"
    bin_dir.mkdir()
    for name in ("grep", *commands):  # grep: the script's own helper
        real = shutil.which("grep") if name == "grep" else None
        target = bin_dir / name
        if real:
            target.symlink_to(real)
        else:
            target.write_text("#!/bin/sh\nexit 0\n")
            target.chmod(0o755)
    return {"TERRASCAPE_SYSROOT": str(root), "PATH": str(bin_dir)}


def test_fake_tree_complete(tmp_path):
    result = _check("test", env=_fake_system(tmp_path))
    assert (result.returncode, result.stdout) == (0, ""), result.stderr


@pytest.mark.parametrize(("removed", "package"), [
    (f"usr/lib/{TRIPLET}/libEGL.so.1", "libegl1"),
    (f"usr/lib/{TRIPLET}/dri/swrast_dri.so", "libgl1-mesa-dri"),
    (f"usr/lib/{TRIPLET}/libGL.so.1", "libgl1"),
])
def test_fake_tree_reports_exactly_the_missing_library(tmp_path, removed, package):
    files = tuple(f for f in FULL_TREE if f != removed)
    result = _check("test", env=_fake_system(tmp_path, files=files))
    assert result.returncode == 1
    assert result.stdout.split() == [package]


@pytest.mark.parametrize(("command", "package"),
                         [("Xvfb", "xvfb"), ("xdotool", "xdotool"), ("import", "imagemagick"),
                          ("chromium", "chromium"), ("c++", "g++")])
def test_fake_tree_reports_exactly_the_missing_command(tmp_path, command, package):
    commands = tuple(c for c in COMMANDS if c != command)
    env = _fake_system(tmp_path, commands=commands)
    assert _check("test", env=env).stdout.split() == [package]
    # The demo does not need the viewer-test tools.
    assert _check("demo", env=env).returncode == 0


@pytest.mark.parametrize("drivers", [
    # Mesa >= 24.2: the drivers live in libgallium, dri/ holds links to it.
    (f"usr/lib/{TRIPLET}/libgallium-24.2.8-1.so", f"usr/lib/{TRIPLET}/dri/swrast_dri.so"),
    (f"usr/lib/{TRIPLET}/libgallium-25.0.so",),
    (f"usr/lib/{TRIPLET}/dri/radeonsi_dri.so",),  # no swrast, another *_dri.so
    ("usr/lib64/dri/swrast_dri.so",),  # Fedora-style lib64
])
def test_newer_mesa_layouts_count_as_installed(tmp_path, drivers):
    files = (*FULL_TREE[:2], *drivers)
    result = _check("test", env=_fake_system(tmp_path, files=files))
    assert (result.returncode, result.stdout) == (0, ""), result.stderr


def test_unknown_mode_is_a_usage_error():
    result = subprocess.run([BASH, str(SCRIPT), "install"], capture_output=True, text=True)
    assert result.returncode == 2
    assert "usage" in result.stderr
