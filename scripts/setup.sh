#!/usr/bin/env bash
# terrascape set-up: `bash scripts/setup.sh demo`, `bash scripts/setup.sh test`, or
# `bash scripts/setup.sh check [demo|test]` (only list the missing system packages).
# Checks Python >= 3.11, installs the system libraries headless OpenGL needs (Mesa EGL) when
# missing and possible (root + apt), creates .venv, installs terrascape, then runs the demo or
# the whole test suite. Stops with a one-line instruction when something cannot be done here.
#
# Detection looks for the libraries' files (any usual lib folder; ldconfig's cache) and, when
# dpkg exists, asks dpkg whether the package is installed. TERRASCAPE_SYSROOT=/some/dir makes
# the file checks look under that folder instead of / and skips ldconfig and dpkg (tests use
# it with a fake tree); commands (Xvfb, xdotool, import) are looked up on PATH.
set -euo pipefail

sysroot="${TERRASCAPE_SYSROOT:-}"

# True when any of the glob patterns (absolute paths, taken under $sysroot) matches a file.
have_file() {
  local pattern f
  for pattern in "$@"; do
    for f in $sysroot$pattern; do
      [ -e "$f" ] && return 0
    done
  done
  return 1
}

# True when dpkg says the package is installed (never with a fake sysroot or without dpkg).
dpkg_installed() {
  [ -z "$sysroot" ] && command -v dpkg-query >/dev/null 2>&1 &&
    dpkg-query -W -f='${Status}\n' "$1" 2>/dev/null | grep -q ' installed$'
}

# A shared library by file name: ldconfig's cache (ldconfig lives in /sbin, which a normal
# user's PATH may lack) or the usual folders.
have_lib() {
  if [ -z "$sysroot" ] &&
     { ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null; } | grep -qF "$1"; then
    return 0
  fi
  have_file "/usr/lib/*/$1" "/usr/lib/$1" "/usr/lib64/$1" "/lib/*/$1" "/lib64/$1"
}

# Mesa's DRI drivers: swrast_dri.so (a file, or since Mesa 24.2 a link to libgallium-*.so),
# any *_dri.so, or the gallium library itself, in any lib folder.
have_dri() {
  have_file "/usr/lib/*/dri/swrast_dri.so" "/usr/lib/dri/swrast_dri.so" \
    "/usr/lib64/dri/swrast_dri.so" "/usr/lib/*/dri/*_dri.so" "/usr/lib/dri/*_dri.so" \
    "/usr/lib64/dri/*_dri.so" "/usr/lib/*/libgallium*.so" "/usr/lib64/libgallium*.so"
}

# Print the Debian packages MODE (demo|test) needs that are missing, one per line.
missing_system_packages() {
  local mode="$1" python="$2"
  { have_lib 'libEGL.so.1' || dpkg_installed libegl1; } || echo libegl1
  { have_dri || dpkg_installed libgl1-mesa-dri; } || echo libgl1-mesa-dri
  { have_lib 'libGL.so.1' || dpkg_installed libgl1; } || echo libgl1
  "$python" -c 'import venv, ensurepip' >/dev/null 2>&1 || echo python3-venv
  if [ "$mode" = test ]; then
    command -v Xvfb >/dev/null 2>&1 || echo xvfb
    command -v xdotool >/dev/null 2>&1 || echo xdotool
    command -v import >/dev/null 2>&1 || echo imagemagick
    command -v chromium >/dev/null 2>&1 || echo chromium
    # meshoptimizer (the export extra) is built from source: a C++ compiler and Python.h
    command -v c++ >/dev/null 2>&1 || echo g++
    "$python" -c 'import os, sys, sysconfig
sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
      >/dev/null 2>&1 || echo python3-dev
  fi
  return 0
}

find_python() {
  local candidate
  for candidate in python3.13 python3.12 python3.11 python3; do
    if command -v "$candidate" >/dev/null 2>&1 &&
       "$candidate" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
      echo "$candidate"; return 0
    fi
  done
  return 1
}

mode="${1:-}"
case "$mode" in
  demo|test|check) ;;
  *) echo "usage: bash scripts/setup.sh demo|test|check" >&2; exit 2 ;;
esac

# --- Python >= 3.11 --------------------------------------------------------------------
PYTHON="${PYTHON:-}"
if [ -z "$PYTHON" ] && ! PYTHON="$(find_python)"; then
  echo "terrascape needs Python >= 3.11: install it (e.g. 'sudo apt-get install python3 python3-venv') and re-run" >&2
  exit 1
fi

# --- system packages ------------------------------------------------------------------
# Headless OpenGL through Mesa (llvmpipe): libEGL + the DRI drivers. The test suite also
# starts the real viewer under Xvfb and drives it with xdotool.
if [ "$mode" = check ]; then
  missing="$(missing_system_packages "${2:-test}" "$PYTHON")"
  [ -n "$missing" ] && echo "$missing"
  [ -z "$missing" ]
  exit
fi
mapfile -t need_pkgs < <(missing_system_packages "$mode" "$PYTHON")
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
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
if [ "$mode" = demo ]; then
  # The viewer extra too: the README's next commands include `terrascape view`.
  .venv/bin/python -m pip install -q -e ".[viewer,report]"
  # Compile the demo's kernels one process per CPU first: quicker than compiling them one
  # after another inside the demo, and every later command starts at full speed.
  .venv/bin/terrascape warm-up
  exec .venv/bin/terrascape demo --output demo-output --force
else
  .venv/bin/python -m pip install -q -e ".[test]"
  .venv/bin/ruff check src tests
  # -n 2: the suite is sized for two cores; pytest's exit code is the script's. A test that
  # hangs fails at 15 minutes with its stacks (pytest-timeout), one stuck where that cannot
  # reach it has its stacks printed at 20 (faulthandler); and the run as a whole stops
  # with its summary after TERRASCAPE_TEST_LIMIT seconds (default 40 minutes; the suite
  # takes about five on two cores) rather than never. (--foreground: Ctrl-C still reaches it.)
  exec timeout --foreground --signal=INT --kill-after=60 "${TERRASCAPE_TEST_LIMIT:-2400}" \
    .venv/bin/python -m pytest -n 2 -q "${@:2}"
fi
