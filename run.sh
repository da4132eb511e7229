#!/usr/bin/env bash
# gyro_calib front door. Two commands do everything on a fresh Debian / Python 3.11 machine:
#   ./run.sh demo   set up .venv (ROS 2 wheels + this package) and run the simulated bench
#   ./run.sh test   set up .venv if needed and run the whole test suite
# Extra arguments go to the demo (see ./run.sh demo --help) or to pytest.
set -euo pipefail
cd "$(dirname "$0")"
VENV="${GYRO_CALIB_VENV:-.venv}"
PY="${PYTHON:-python3.11}"
command -v "$PY" >/dev/null 2>&1 || PY=python3

setup() {
  local stamp="$VENV/.gyro_calib-installed"
  if [ -f "$stamp" ] && [ "$stamp" -nt requirements.txt ] && [ "$stamp" -nt setup.py ]; then
    return 0
  fi
  echo "run.sh: setting up $VENV (first run takes a minute)" >&2
  [ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r requirements.txt
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps -e .
  touch "$stamp"
}

cmd="${1:-}"; shift || true
case "$cmd" in
  demo) setup; exec "$VENV/bin/bench_demo" "$@" ;;
  test) setup; exec "$VENV/bin/python" -m pytest "$@" ;;
  setup) setup ;;
  *) echo "usage: ./run.sh demo [--pairs N --speed X --seed N --out FILE] | ./run.sh test [pytest args]" >&2
     exit 2 ;;
esac
