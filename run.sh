#!/usr/bin/env bash
# gyro_calib front door. Two commands do everything on a fresh Debian / Python 3.11 machine:
#   ./run.sh demo   set up .venv (ROS 2 wheels + this package) and run the simulated bench
#   ./run.sh test   set up .venv if needed and run the whole test suite
#   ./run.sh docs   set up .venv if needed and build the documentation site (docs/_build/html)
# Extra arguments go to the demo (see ./run.sh demo --help), to pytest or to sphinx-build.
# ROS 2 distribution: Kilted by default (.venv); `--ros jazzy` right after the command (or
# GYRO_CALIB_ROS=jazzy) sets up and uses .venv-jazzy with the Jazzy wheels instead:
#   ./run.sh test --ros jazzy test/nodes
set -euo pipefail
cd "$(dirname "$0")"
cmd="${1:-}"; shift || true
ROS="${GYRO_CALIB_ROS:-kilted}"
if [ "${1:-}" = "--ros" ]; then ROS="${2:-}"; shift 2 || shift $#; fi
case "$ROS" in
  kilted) VENV="${GYRO_CALIB_VENV:-.venv}" ;;
  jazzy) VENV="${GYRO_CALIB_VENV:-.venv-jazzy}" ;;
  *) echo "run.sh: --ros must be kilted or jazzy (the supported ROS 2 distributions), got '$ROS'" >&2
     exit 2 ;;
esac
PY="${PYTHON:-python3.11}"
command -v "$PY" >/dev/null 2>&1 || PY=python3

# Debian packages the Python wheels load or the tests run (issue 20): Pango for WeasyPrint
# (certificate PDFs), DejaVu fonts, and Chromium for the headless certificate render test.
SYSTEM_PACKAGES=(libpango-1.0-0 libpangoft2-1.0-0 fonts-dejavu-core chromium)

system_packages() {
  # Idempotent and free when everything is there: dpkg -s per package, apt-get only if missing.
  command -v dpkg >/dev/null 2>&1 || return 0
  local missing=() p
  for p in "${SYSTEM_PACKAGES[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
      echo "run.sh: please install (as root): apt-get install ${missing[*]}" >&2; return 0
    fi
  fi
  echo "run.sh: installing Debian packages: ${missing[*]}" >&2
  { $sudo apt-get update -qq &&
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
      "${missing[@]}"; } ||
    echo "run.sh: could not install ${missing[*]}; certificate PDFs and the render test need them" >&2
}

setup() {
  system_packages
  local stamp="$VENV/.gyro_calib-installed"
  if [ -f "$stamp" ] && [ "$stamp" -nt requirements.txt ] && [ "$stamp" -nt setup.py ] &&
     [ "$stamp" -nt requirements-jazzy.txt ]; then
    return 0
  fi
  echo "run.sh: setting up $VENV for ROS 2 $ROS (first run takes a few minutes)" >&2
  [ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
  if [ "$ROS" = jazzy ]; then
    # everything but the Kilted ROS wheels, then the same ROS packages at Jazzy versions
    grep -v '^ros-' requirements.txt > "$VENV/requirements-common.txt"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
      -r "$VENV/requirements-common.txt" -r requirements-jazzy.txt
  else
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r requirements.txt
  fi
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps -e .
  touch "$stamp"
}

case "$cmd" in
  demo) setup; exec "$VENV/bin/bench_demo" "$@" ;;
  test) setup; exec "$VENV/bin/python" -m pytest "$@" ;;
  docs) setup
        exec "$VENV/bin/python" -m sphinx -W --keep-going -n -q -b html docs docs/_build/html "$@" ;;
  setup) setup ;;
  *) echo "usage: ./run.sh demo [--ros kilted|jazzy] [--pairs N --speed X --seed N --out FILE] | ./run.sh test [--ros kilted|jazzy] [pytest args] | ./run.sh docs [sphinx-build args]" >&2
     exit 2 ;;
esac
