#!/usr/bin/env bash
# Set up a virtual environment in .venv with petswarm installed (editable).
#   bash scripts/setup.sh          # run + render
#   bash scripts/setup.sh test     # + training stack + test tools (torch==2.13.0 CPU first), and Debian's
#                                  # chromium and tshark when missing (the browser and pcap tests)
#   bash scripts/setup.sh train    # + training stack (pins the CPU build of torch first)
set -euo pipefail
cd "$(dirname "$0")/.."
what="${1:-run}"
[ -x .venv/bin/python ] || python3 -m venv .venv
py=.venv/bin/python
"$py" -m pip install -q --upgrade pip
case "$what" in
  run)   extras="render" ;;
  test)  "$py" -m pip install -q torch==2.13.0  # the CPU build on this machine's disk; never an unpinned torch
         extras="render,train,test" ;;
  train) "$py" -m pip install -q torch==2.13.0
         extras="render,train" ;;
  *) echo "setup.sh: unknown target '$what' (run | test | train)" >&2; exit 2 ;;
esac
"$py" -m pip install -q -e ".[$extras]"
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
