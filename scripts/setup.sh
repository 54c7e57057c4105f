#!/usr/bin/env bash
# One-shot set-up for a fresh machine: system LLVM for Mitsuba's llvm_ad_rgb variant,
# a virtual environment, and an (editable) build of the C++ core.
# Idempotent: re-running only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
VENV=${VENV:-.venv}

# Mitsuba's llvm_ad_rgb needs a recent libLLVM (LLVM 15 crashes it). Debian ships libllvm19.
if ! ls /usr/lib/x86_64-linux-gnu/libLLVM-19.so* >/dev/null 2>&1 && ! ls /usr/lib/*/libLLVM.so.19* >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "[setup] installing libllvm19 for Mitsuba's llvm_ad_rgb variant"
    (apt-get install -y -q libllvm19 >/dev/null 2>&1 || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q libllvm19 >/dev/null 2>&1; }) \
      || echo "[setup] could not install libllvm19: Mitsuba will fall back to scalar_rgb"
  else
    echo "[setup] libllvm19 not found and cannot apt-get it: Mitsuba will fall back to scalar_rgb"
  fi
fi

# Headless Chromium checks the HTML report in the tests (skipped with a reason without it).
if ! command -v chromium >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "[setup] installing chromium for the report's browser test"
  (apt-get install -y -q --no-install-recommends chromium fonts-liberation fonts-dejavu-core >/dev/null 2>&1 || \
   { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q --no-install-recommends chromium fonts-liberation fonts-dejavu-core >/dev/null 2>&1; }) \
    || echo "[setup] could not install chromium: the browser test of the report will be skipped"
fi

if [ ! -x "$VENV/bin/python" ]; then
  "$PY" -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install -q --upgrade pip
# Build requirements first, so that the editable build can run without isolation (incremental C++ rebuilds).
"$VENV/bin/python" -m pip install -q "scikit-build-core>=0.10" "nanobind>=2.4" cmake ninja
"$VENV/bin/python" -m pip install -q --no-build-isolation -e ".[test]"
