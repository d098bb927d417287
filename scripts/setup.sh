#!/usr/bin/env bash
# Set up a virtual environment in .venv with petswarm installed (editable).
#   bash scripts/setup.sh          # run + render
#   bash scripts/setup.sh test     # + training stack (SB3, RLlib) + TorchRL + test tools (torch==2.13.0 CPU first),
#                                  # and Debian's chromium and tshark when missing (the browser and pcap tests)
#   bash scripts/setup.sh train    # + training stack: SB3 + SuperSuit and Ray RLlib (pins the CPU build of torch first)
#   bash scripts/setup.sh bench    # + training stack + the benchmark's peers (MPE, VMAS): `petswarm bench`
# torch is installed first and stays pinned in the second pip command: an unpinned torch would pull
# a multi-GB CUDA build, and ray[rllib]==2.60.0 pins gymnasium==1.2.2 (never pair an unpinned
# ray[rllib] with gymnasium>=1.4: pip would backtrack through old Ray releases).
set -euo pipefail
cd "$(dirname "$0")/.."
what="${1:-run}"
# the compiled core (setup.py, petswarm_env/_core.py) needs a C compiler and Python's headers: from
# Debian where missing (as root), else say which to install
need=""
command -v cc >/dev/null 2>&1 || need="$need gcc libc6-dev"
python3 -c 'import os, sysconfig, sys; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' ||
  need="$need python3-dev"
if [ -n "$need" ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    { DEBIAN_FRONTEND=noninteractive apt-get update -q >/dev/null &&
      DEBIAN_FRONTEND=noninteractive apt-get install -y -q $need >/dev/null; } ||
      { echo "setup.sh: could not install$need (the compiled core needs them)" >&2; exit 1; }
  else
    echo "setup.sh: the compiled core needs$need: install them (as root: apt-get install -y$need), then rerun" >&2
    exit 1
  fi
fi
[ -x .venv/bin/python ] || python3 -m venv .venv
py=.venv/bin/python
"$py" -m pip install -q --upgrade pip
torch=()
case "$what" in
  run)   extras="render" ;;
  test)  torch=(torch==2.13.0)  # the CPU build on this machine's disk; never an unpinned torch
         extras="render,train,rllib,torchrl,test" ;;
  train) torch=(torch==2.13.0)
         extras="render,train,rllib" ;;
  bench) torch=(torch==2.13.0)
         extras="render,train,bench" ;;
  *) echo "setup.sh: unknown target '$what' (run | test | train | bench)" >&2; exit 2 ;;
esac
[ ${#torch[@]} -eq 0 ] || "$py" -m pip install -q "${torch[@]}"
"$py" -m pip install -q "${torch[@]}" -e ".[$extras]"
if [ "$what" = test ]; then
  # the browser test of the report's replays (Debian's chromium) and the pcap test (Debian's tshark);
  # without them those tests skip and say so
  missing=""
  command -v chromium >/dev/null 2>&1 || missing="$missing chromium"
  command -v tshark >/dev/null 2>&1 || missing="$missing tshark"
  if [ -n "$missing" ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
      { DEBIAN_FRONTEND=noninteractive apt-get update -q >/dev/null &&
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q $missing >/dev/null; } ||
        echo "setup.sh: could not install$missing; the tests that need them skip" >&2
    else
      echo "setup.sh: not installed:$missing (apt-get install$missing as root); the tests that need them skip" >&2
    fi
  fi
fi
"$py" -c "import petswarm_env" && echo "petswarm installed in .venv ($what)"
