#!/usr/bin/env bash
# terrascape set-up: `bash scripts/setup.sh demo` or `bash scripts/setup.sh test`.
# Checks Python >= 3.11, installs the system libraries headless OpenGL needs (Mesa EGL) when
# missing and possible (root + apt), creates .venv, installs terrascape, then runs the demo or
# the whole test suite. Stops with a one-line instruction when something cannot be done here.
set -euo pipefail

mode="${1:-}"
case "$mode" in
  demo|test) ;;
  *) echo "usage: bash scripts/setup.sh demo|test" >&2; exit 2 ;;
esac
cd "$(dirname "$0")/.."

# --- Python >= 3.11 --------------------------------------------------------------------
PYTHON="${PYTHON:-}"
if [ -z "$PYTHON" ]; then
  for candidate in python3.13 python3.12 python3.11 python3; do
    if command -v "$candidate" >/dev/null 2>&1 &&
       "$candidate" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
      PYTHON="$candidate"; break
    fi
  done
fi
if [ -z "$PYTHON" ]; then
  echo "terrascape needs Python >= 3.11: install it (e.g. 'sudo apt-get install python3 python3-venv') and re-run" >&2
  exit 1
fi

# --- system packages ------------------------------------------------------------------
# Headless OpenGL through Mesa (llvmpipe): libEGL + the DRI drivers. The test suite also
# starts the real viewer under Xvfb and drives it with xdotool.
need_pkgs=()
# ldconfig lives in /sbin, which a normal user's PATH may lack; fall back to the usual dirs.
have_lib() {
  { ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null; } | grep -q "$1" ||
    ls /usr/lib/*/"$1" /usr/lib/"$1" /lib/*/"$1" >/dev/null 2>&1
}
have_lib 'libEGL.so.1' || need_pkgs+=(libegl1)
if ! ls /usr/lib/*/dri/swrast_dri.so /usr/lib/dri/swrast_dri.so >/dev/null 2>&1; then
  need_pkgs+=(libgl1-mesa-dri)
fi
have_lib 'libGL.so.1' || need_pkgs+=(libgl1)
if ! "$PYTHON" -c 'import venv, ensurepip' >/dev/null 2>&1; then
  need_pkgs+=("python3-venv")
fi
if [ "$mode" = test ]; then
  command -v Xvfb >/dev/null 2>&1 || need_pkgs+=(xvfb)
  command -v xdotool >/dev/null 2>&1 || need_pkgs+=(xdotool)
  command -v import >/dev/null 2>&1 || need_pkgs+=(imagemagick)
  command -v chromium >/dev/null 2>&1 || need_pkgs+=(chromium)
fi
if [ "${#need_pkgs[@]}" -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing system packages: ${need_pkgs[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq --no-install-recommends "${need_pkgs[@]}" >/dev/null
  else
    echo "missing system packages; run: sudo apt-get install -y ${need_pkgs[*]}  (then re-run this command)" >&2
    exit 1
  fi
fi

# --- virtual environment --------------------------------------------------------------
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
if [ "$mode" = demo ]; then
  .venv/bin/python -m pip install -q -e ".[render,report]"
  exec .venv/bin/terrascape demo --output demo-output --force
else
  .venv/bin/python -m pip install -q -e ".[test]"
  .venv/bin/ruff check src tests
  # -n 2: the suite is sized for two cores; pytest's exit code is the script's.
  exec .venv/bin/python -m pytest -n 2 -q "${@:2}"
fi
