#!/usr/bin/env bash
# One entry point for a fresh machine: installs what is missing, then runs the command.
#   ./run.sh demo            simulate, calibrate, fuse, score and report on the default scenario
#   ./run.sh test            run the test suite
#   ./run.sh bench           run the benchmark scenarios and update BENCHMARKS.md
#   ./run.sh docs            build the documentation site into site/ (warnings are errors); docs serve: live preview
#   ./run.sh <args...>       any mocap-bench command, e.g. ./run.sh simulate scenarios/ring6.toml --out out/ring6
set -euo pipefail
cd "$(dirname "$0")"
VENV=.venv
PY="${PYTHON:-python3}"

need_system_libs() {
  # Open3D's wheel links against libusb-1.0 and libgomp, which a minimal Debian lacks.
  for lib in libusb-1.0.so.0 libgomp.so.1; do
    ldconfig -p 2>/dev/null | grep -q "$lib" || return 0
  done
  return 1
}

if need_system_libs; then
  echo "installing system libraries libusb-1.0-0 libgomp1 ..." >&2
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq >/dev/null
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libusb-1.0-0 libgomp1 >/dev/null
fi

stamp="$VENV/.installed-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  echo "creating $VENV and installing mocap-bench with its dependencies (first run only) ..." >&2
  [ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --upgrade pip >/dev/null
  "$VENV/bin/python" -m pip install -q -e ".[test,docs]"
  rm -f "$VENV"/.installed-*
  touch "$stamp"
fi

# Compiled modules are kept (__pycache__, ignored by git) even where PYTHONDONTWRITEBYTECODE is set: a test run
# starts many Python processes (test workers, command-line tests, parallel pools), each importing the project.
unset PYTHONDONTWRITEBYTECODE

cmd="${1:-demo}"; [ $# -gt 0 ] && shift
case "$cmd" in
  test) exec "$VENV/bin/python" -m pytest "$@" ;;
  docs)
    export NO_MKDOCS_2_WARNING=1
    if [ "${1:-}" = serve ]; then shift; exec "$VENV/bin/mkdocs" serve "$@"; fi
    exec "$VENV/bin/mkdocs" build --strict "$@" ;;
  *) exec "$VENV/bin/mocap-bench" "$cmd" "$@" ;;
esac
